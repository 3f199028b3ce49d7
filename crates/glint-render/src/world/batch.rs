//! Eight rays at once (pipeline: batched integrators ask **World** what eight rays hit, and
//! how much light passes along eight shadow rays), structure of arrays with active-lane masks.
//!
//! The sphere set and the planes are tested across the eight rays in one pass each, the merged
//! static tree through `MeshBvh::intersect_batch`; the other instances (meshes, transformed spheres) are visited flat, each behind a box test of all
//! eight rays against its world box, so a batch that misses an instance skips it whole, and a
//! mesh is asked through `MeshBvh::intersect_batch` (the packet kernels beneath). The surface
//! data of sphere-set and plane hits is computed across lanes; other hits lane by lane with
//! the scalar code. Every lane performs the scalar queries' float operations, so a lane's hit
//! is the single-ray hit (ties between different surfaces at exactly the same distance may
//! resolve differently across the top level).

use super::World;
use super::hit::{NO_PRIM, SurfaceHit};
use super::instances::{InstanceShape, transform_ray};
use glint_accel::batch::{Hits8, Rays8, plane8, sphere_crossings8, sphere8};
use glint_accel::lanes::{F8, Isa, LANES, M8, U8x, V8};
use glint_core::float::gamma;
use glint_core::{Bounds3, Rgb, Vec2, Vec3};

/// What eight rays hit, a lane plane per field; lanes outside `hit` hold nothing meaningful.
/// Normals are as the geometry orients them (not flipped toward the ray), as [`SurfaceHit`].
#[derive(Clone, Copy, Debug)]
pub struct Surfaces8<I: Isa> {
    pub hit: M8<I>,
    pub t: F8<I>,
    pub position: V8<I>,
    pub p_error: V8<I>,
    pub geometric_normal: V8<I>,
    pub shading_normal: V8<I>,
    pub uv: [F8<I>; 2],
    pub material: U8x<I>,
    pub object: U8x<I>,
    /// Triangle index within the object's mesh; [`NO_PRIM`] for spheres and planes.
    pub prim: U8x<I>,
}

impl<I: Isa> Surfaces8<I> {
    /// Lane `i` as a surface hit (`None` where it hit nothing).
    #[must_use]
    pub fn lane(&self, i: usize) -> Option<SurfaceHit> {
        self.hit.lane(i).then(|| SurfaceHit {
            t: self.t[i],
            position: self.position.lane(i),
            p_error: self.p_error.lane(i),
            geometric_normal: self.geometric_normal.lane(i),
            shading_normal: self.shading_normal.lane(i),
            uv: Vec2::new(self.uv[0][i], self.uv[1][i]),
            material: self.material[i],
            object: self.object[i],
            prim: self.prim[i],
        })
    }

    fn set(&mut self, i: usize, h: &SurfaceHit) {
        self.hit = self.hit | M8::from_bits(1 << i);
        self.t[i] = h.t;
        self.position.set(i, h.position);
        self.p_error.set(i, h.p_error);
        self.geometric_normal.set(i, h.geometric_normal);
        self.shading_normal.set(i, h.shading_normal);
        (self.uv[0][i], self.uv[1][i]) = (h.uv.x, h.uv.y);
        (self.material[i], self.object[i], self.prim[i]) = (h.material, h.object, h.prim);
    }
}

/// Which surface a lane's closest hit is on, while the search runs.
const NONE: u32 = 0;
const SET_SPHERE: u32 = 1;
const TOP: u32 = 2;
const PLANE: u32 = 3;

/// More top-level members than this are not visited flat: each lane walks the TLAS alone.
const FLAT_TOP_LIMIT: usize = 32;

/// The entry and exit distances of one slab, ordered.
#[inline(always)]
fn slab<I: Isa>(o: F8<I>, inv: F8<I>, lo: f32, hi: f32) -> (F8<I>, F8<I>) {
    let t0 = (F8::splat(lo) - o) * inv;
    let t1 = (F8::splat(hi) - o) * inv;
    (t0.min(t1), t0.max(t1))
}

/// The lanes of `rays` whose segment `(tmin, tmax]` may meet box `b`: a conservative slab test
/// (far distances scaled up by 1 + 4γ(3); NaN slabs leave a lane in).
#[inline(always)]
fn box8<I: Isa>(rays: &Rays8<I>, inv: &V8<I>, active: M8<I>, b: &Bounds3) -> M8<I> {
    let (x0, x1) = slab(rays.origin.x, inv.x, b.min.x, b.max.x);
    let (y0, y1) = slab(rays.origin.y, inv.y, b.min.y, b.max.y);
    let (z0, z1) = slab(rays.origin.z, inv.z, b.min.z, b.max.z);
    let near = x0.max(y0).max(z0).max(rays.tmin);
    let far = x1.min(y1).min(z1).min(F8::splat(f32::INFINITY)) * F8::splat(1.0 + 4.0 * gamma(3));
    let unsure = near.is_nan() | far.is_nan();
    ((near.le(far) & near.le(rays.tmax)) | unsure) & active
}

/// The sphere-set member each lane's nearest hit is on so far, carried across lanes while the
/// search runs (so the surface data needs no lane-by-lane look-up of the instances).
#[derive(Clone, Copy)]
struct SetSpheres<I: Isa> {
    centre: V8<I>,
    radius: F8<I>,
    material: U8x<I>,
    object: U8x<I>,
    /// Some taken member's material has a texture (then the uv are computed).
    textured: bool,
}

impl<I: Isa> SetSpheres<I> {
    #[inline(always)]
    fn none() -> Self {
        Self { centre: V8::zero(), radius: F8::zero(), material: U8x::splat(0), object: U8x::splat(0), textured: false }
    }

    /// Lanes `take` now hit the sphere (`centre`, `radius`) of `instance`.
    #[inline(always)]
    fn take(&mut self, take: M8<I>, instance: &super::instances::Instance, centre: Vec3, radius: f32, textured: bool) {
        self.centre = V8::select(take, V8::splat(centre), self.centre);
        self.radius = F8::select(take, F8::splat(radius), self.radius);
        self.material = U8x::select(take, U8x::splat(instance.material), self.material);
        self.object = U8x::select(take, U8x::splat(instance.object), self.object);
        self.textured |= textured;
    }
}

impl World {
    /// The closest hits of the active lanes of `rays` into `out`: lane `i` is
    /// [`World::intersect`]`(&rays.ray(i))`. `out` is written in place (a caller keeps one
    /// for its whole loop: returned by value, its 600 bytes were copied and cleared per batch);
    /// its lanes outside `out.hit` keep whatever they held.
    #[inline(always)]
    pub fn intersect_batch<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>, out: &mut Surfaces8<I>) {
        self.intersect_batch_among(rays, active, u64::MAX, out);
    }

    /// [`Self::intersect_batch`] where only the sphere-set members whose bit is set in
    /// `spheres` (bit k: the k-th member; members past 63 always) can be hit: the caller has
    /// proven the others miss every lane ([`PointCones::candidates`] for rays leaving one
    /// point). Skipping a member that no lane hits changes nothing.
    #[inline(always)]
    pub fn intersect_batch_among<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>, spheres: u64, out: &mut Surfaces8<I>) {
        let dd = rays.dir.dot(rays.dir);
        let mut best = rays.tmax;
        let mut kind = U8x::splat(NONE);
        let mut index = U8x::splat(0);
        let mut tri = Hits8::none();
        let mut set = SetSpheres::none();
        // The sphere set: nearest, the lower index on ties (as `SphereSet::closest`).
        for (k, &inst) in self.sphere_instances.iter().enumerate() {
            if k < 64 && spheres >> k & 1 == 0 {
                continue;
            }
            let instance = &self.instances[inst as usize];
            let InstanceShape::Sphere { centre, radius } = instance.shape else { continue };
            let (hit, t) = sphere8(rays, dd, active, centre, radius);
            let take = hit & (t.lt(best) | kind.eq(U8x::splat(NONE)));
            if take.none() {
                continue;
            }
            best = F8::select(take, t, best);
            kind = U8x::select(take, U8x::splat(SET_SPHERE), kind);
            index = U8x::select(take, U8x::splat(inst), index);
            set.take(
                take,
                instance,
                centre,
                radius,
                self.scene.materials[instance.material as usize].texture.is_some(),
            );
        }
        if self.tlas_used && self.top_members.len() > FLAT_TOP_LIMIT {
            *out = self.intersect_lanes(rays, active);
            return;
        }
        if let Some(merged) = &self.merged {
            let near = Rays8 { tmax: best, ..*rays };
            let hit = merged.bvh.intersect_batch(&near, active, &mut tri);
            best = F8::select(hit, tri.t, best);
            kind = U8x::select(hit, U8x::splat(TOP), kind);
            // Back to the instance and its mesh's triangle, as the top level records them.
            for i in 0..LANES {
                if hit.lane(i) {
                    (index[i], tri.prim[i]) = merged.owner(tri.prim[i]);
                }
            }
        }
        if self.tlas_used {
            let inv = V8::new(F8::one() / rays.dir.x, F8::one() / rays.dir.y, F8::one() / rays.dir.z);
            for &(inst, ref bounds) in &self.top_members {
                let near = Rays8 { tmax: best, ..*rays };
                let lanes = box8(&near, &inv, active, bounds);
                if lanes.none() {
                    continue;
                }
                let instance = &self.instances[inst as usize];
                let local = if instance.identity { near } else { self.object_rays(inst, &near, lanes) };
                let take = match instance.shape {
                    InstanceShape::Sphere { centre, radius } => {
                        let (hit, t) = sphere8(&local, local.dir.dot(local.dir), lanes, centre, radius);
                        best = F8::select(hit, t, best);
                        hit
                    }
                    InstanceShape::Mesh(m) => {
                        let hit = self.blas[m].intersect_batch(&local, lanes, &mut tri);
                        best = F8::select(hit, tri.t, best);
                        hit
                    }
                };
                kind = U8x::select(take, U8x::splat(TOP), kind);
                index = U8x::select(take, U8x::splat(inst), index);
            }
        }
        for (pi, p) in self.planes.iter().enumerate() {
            let near = Rays8 { tmax: best, ..*rays };
            let (hit, t) = plane8(&near, active, p.normal, p.offset);
            best = F8::select(hit, t, best);
            kind = U8x::select(hit, U8x::splat(PLANE), kind);
            index = U8x::select(hit, U8x::splat(pi as u32), index);
        }
        self.surfaces8(rays, best, kind, index, &tri, &set, out);
    }

    /// Lane by lane through the single-ray query (a top level too large to visit flat).
    fn intersect_lanes<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>) -> Surfaces8<I> {
        let mut out = empty_surfaces();
        for i in 0..LANES {
            if let Some(h) = active.lane(i).then(|| self.intersect(&rays.ray(i))).flatten() {
                out.set(i, &h);
            }
        }
        out
    }

    /// The lanes `lanes` of `rays` in the object space of instance `inst` (direction not
    /// renormalised: `t` is shared).
    #[inline(always)]
    fn object_rays<I: Isa>(&self, inst: u32, rays: &Rays8<I>, lanes: M8<I>) -> Rays8<I> {
        let mut out = *rays;
        let from_world = &self.instances[inst as usize].object_from_world;
        for i in 0..LANES {
            if lanes.lane(i) {
                let r = transform_ray(from_world, &rays.ray(i));
                out.origin.set(i, r.origin);
                out.dir.set(i, r.dir);
            }
        }
        out
    }

    /// The surface data of the lanes' closest hits (see [`Self::intersect_batch`]).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)] // the search's state, lane planes by field
    fn surfaces8<I: Isa>(
        &self,
        rays: &Rays8<I>,
        t: F8<I>,
        kind: U8x<I>,
        index: U8x<I>,
        tri: &Hits8<I>,
        set: &SetSpheres<I>,
        out: &mut Surfaces8<I>,
    ) {
        out.t = t;
        out.hit = !kind.eq(U8x::splat(NONE));
        let spheres = kind.eq(U8x::splat(SET_SPHERE));
        if spheres.any() {
            self.sphere_surfaces(rays, spheres, set, out);
        }
        let planes = kind.eq(U8x::splat(PLANE));
        if planes.any() {
            for (pi, p) in self.planes.iter().enumerate() {
                let lanes = planes & index.eq(U8x::splat(pi as u32));
                if lanes.any() {
                    self.plane_surfaces(rays, lanes, p, out);
                }
            }
        }
        let top = kind.eq(U8x::splat(TOP));
        if top.any() {
            for i in 0..LANES {
                if top.lane(i) {
                    let inst = &self.instances[index[i] as usize];
                    let h = tri.hit(i);
                    out.set(i, &self.instance_hit(inst, &rays.ray(i), t[i], h.prim, h.u, h.v));
                }
            }
        }
    }

    /// Sphere-set hits across lanes: `World::instance_hit` of an untransformed sphere, lane
    /// by lane the same operations, each lane's sphere as the search carried it in `set`.
    #[inline(always)]
    fn sphere_surfaces<I: Isa>(&self, rays: &Rays8<I>, lanes: M8<I>, set: &SetSpheres<I>, out: &mut Surfaces8<I>) {
        let SetSpheres { centre, radius, material, object, textured } = *set;
        let local = rays.origin + rays.dir.scale(out.t) - centre;
        let rcp = F8::one() / local.dot(local).sqrt();
        let ok = rcp.lt(F8::splat(f32::INFINITY)) & rcp.gt(F8::zero());
        let n = V8::select(ok, local.scale(rcp), V8::splat(Vec3::Y));
        let local = n.scale(radius);
        let p = centre + local;
        let err = local.abs().scale(F8::splat(gamma(5))) + p.abs().scale(F8::splat(gamma(1)));
        out.position = V8::select(lanes, p, out.position);
        out.p_error = V8::select(lanes, err, out.p_error);
        out.geometric_normal = V8::select(lanes, n, out.geometric_normal);
        out.shading_normal = V8::select(lanes, n, out.shading_normal);
        out.material = U8x::select(lanes, material, out.material);
        out.object = U8x::select(lanes, object, out.object);
        out.prim = U8x::select(lanes, U8x::splat(NO_PRIM), out.prim);
        out.uv = [F8::select(lanes, F8::zero(), out.uv[0]), F8::select(lanes, F8::zero(), out.uv[1])];
        if textured {
            // Spherical uv only where a texture reads it (atan2 and acos are not free).
            for i in 0..LANES {
                if lanes.lane(i) && self.scene.materials[material[i] as usize].texture.is_some() {
                    let n = n.lane(i);
                    out.uv[0][i] = 0.5 + n.x.atan2(-n.z) / std::f32::consts::TAU;
                    out.uv[1][i] = 1.0 - n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI;
                }
            }
        }
    }

    /// Hits on plane `p` across lanes: `World::plane_hit`, lane by lane the same operations.
    #[inline(always)]
    fn plane_surfaces<I: Isa>(
        &self,
        rays: &Rays8<I>,
        lanes: M8<I>,
        p: &super::instances::Plane,
        out: &mut Surfaces8<I>,
    ) {
        let n = V8::splat(p.normal);
        let raw = rays.origin + rays.dir.scale(out.t);
        let position = raw - n.scale(raw.dot(n) + F8::splat(p.offset));
        let a = position.abs();
        let largest = a.x.max(a.y.max(a.z));
        let err = F8::splat(gamma(6)) * (largest + F8::splat(p.offset.abs()));
        out.position = V8::select(lanes, position, out.position);
        out.p_error = V8::select(lanes, V8::new(err, err, err), out.p_error);
        out.geometric_normal = V8::select(lanes, n, out.geometric_normal);
        out.shading_normal = V8::select(lanes, n, out.shading_normal);
        out.uv[0] = F8::select(lanes, position.dot(V8::splat(p.u_axis)), out.uv[0]);
        out.uv[1] = F8::select(lanes, position.dot(V8::splat(p.v_axis)), out.uv[1]);
        out.material = U8x::select(lanes, U8x::splat(p.material), out.material);
        out.object = U8x::select(lanes, U8x::splat(p.object), out.object);
        out.prim = U8x::select(lanes, U8x::splat(NO_PRIM), out.prim);
    }

    /// The fraction of light that passes along each active shadow ray: lane `i` is
    /// [`World::transmittance`]`(&rays.ray(i))` (inactive lanes: 0).
    #[must_use]
    #[inline(always)]
    pub fn transmittance_batch<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>) -> V8<I> {
        self.transmittance_batch_among(rays, active, u64::MAX)
    }

    /// The cones of the sphere set seen from point `p` (a light), for
    /// [`PointCones::candidates`].
    #[must_use]
    pub fn point_cones(&self, p: Vec3) -> PointCones {
        let cones = self
            .sphere_instances
            .iter()
            .map(|&inst| match self.instances[inst as usize].shape {
                InstanceShape::Sphere { centre, radius } => PointCones::cone(p, centre, radius),
                InstanceShape::Mesh(_) => (Vec3::ZERO, f32::NEG_INFINITY),
            })
            .collect();
        PointCones { cones }
    }

    /// [`Self::transmittance_batch`] where only the sphere-set members whose bit is set in
    /// `spheres` (bit k: the k-th member; members past 63 always) can be crossed: the caller
    /// has proven the others miss every lane ([`PointCones::candidates`]). A skipped member
    /// contributes exactly what its test would (a factor of one), so the result is the same.
    #[must_use]
    #[inline(always)]
    pub fn transmittance_batch_among<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>, spheres: u64) -> V8<I> {
        let dd = rays.dir.dot(rays.dir);
        let mut blocked = M8::none_set();
        // The product of the transparencies crossed (planes, the sphere set, the top level in
        // this order, as the single-ray pass multiplies them).
        let mut pass = F8::one();
        for p in &self.planes {
            let (hit, _) = plane8(rays, active.and_not(blocked), p.normal, p.offset);
            if p.opaque {
                blocked = blocked | hit;
            } else {
                pass = F8::select(hit, pass * F8::splat(self.material(p.material).transparency), pass);
            }
        }
        for (k, &inst) in self.sphere_instances.iter().enumerate() {
            let live = active.and_not(blocked);
            if live.none() {
                break;
            }
            if k < 64 && spheres >> k & 1 == 0 {
                continue;
            }
            let i = &self.instances[inst as usize];
            let InstanceShape::Sphere { centre, radius } = i.shape else { continue };
            let n = sphere_crossings8(rays, dd, live, centre, radius);
            let crossed = n.gt(F8::zero());
            if i.opaque {
                blocked = blocked | crossed;
            } else {
                pass *= crossing_factor(n, self.material(i.material).transparency);
            }
        }
        if let Some(merged) = &self.merged {
            let live = active.and_not(blocked);
            if live.any() {
                blocked = blocked | merged.bvh.occluded_batch(rays, live);
            }
        }
        let mut walk = M8::none_set();
        if self.tlas_used && active.and_not(blocked).any() {
            if self.top_members.len() > FLAT_TOP_LIMIT {
                return self.transmittance_lanes(rays, active);
            }
            let inv = V8::new(F8::one() / rays.dir.x, F8::one() / rays.dir.y, F8::one() / rays.dir.z);
            for &(inst, ref bounds) in &self.top_members {
                let lanes = box8(rays, &inv, active.and_not(blocked), bounds);
                if lanes.none() {
                    continue;
                }
                let instance = &self.instances[inst as usize];
                let local = if instance.identity { *rays } else { self.object_rays(inst, rays, lanes) };
                match instance.shape {
                    InstanceShape::Sphere { centre, radius } => {
                        let n = sphere_crossings8(&local, local.dir.dot(local.dir), lanes, centre, radius);
                        if instance.opaque {
                            blocked = blocked | n.gt(F8::zero());
                        } else {
                            pass *= crossing_factor(n, self.material(instance.material).transparency);
                        }
                    }
                    InstanceShape::Mesh(m) => {
                        let hit = self.blas[m].occluded_batch(&local, lanes);
                        if instance.opaque {
                            blocked = blocked | hit;
                        } else {
                            walk = walk | hit;
                        }
                    }
                }
            }
        }
        let dark = blocked | pass.lt(F8::splat(1e-4)) | !active;
        let pass = F8::select(dark, F8::zero(), pass);
        let mut out = V8::new(pass, pass, pass);
        // A transparent mesh (its triangles may carry different materials) needs its hits in
        // order: those lanes take the single-ray walk.
        let walk = walk.and_not(dark);
        if walk.any() {
            for i in 0..LANES {
                if walk.lane(i) {
                    let t: Rgb = self.transmittance(&rays.ray(i));
                    out.set(i, t);
                }
            }
        }
        out
    }

    /// Lane by lane through the single-ray query.
    fn transmittance_lanes<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>) -> V8<I> {
        V8::from_fn(|i| if active.lane(i) { self.transmittance(&rays.ray(i)) } else { Vec3::ZERO })
    }
}

/// The sphere set as cones seen from one point `p`: a ray that starts at `p` (or a segment
/// whose far end is `p`) can meet sphere k only if its direction `u` away from `p` satisfies
/// `u · axis_k ≥ cos_k`, `cos_k = √(D² − r²)/D` the cosine of the sphere's angular radius at
/// distance D, lowered by a margin for rounding. Shadow rays toward a point light are such
/// segments; a packet none of whose lanes is inside a cone skips that sphere. A point inside
/// or near a sphere gives a cone that admits everything.
#[derive(Clone, Debug, Default)]
pub struct PointCones {
    cones: Vec<(Vec3, f32)>,
}

impl PointCones {
    /// Relative margin on the cone's cosine: far above the rounding of unit directions made
    /// from offset origins (a few ulps), far below any cone that matters.
    const MARGIN: f32 = 1e-4;

    fn cone(p: Vec3, centre: Vec3, radius: f32) -> (Vec3, f32) {
        let to = centre - p;
        let d2 = to.length_squared();
        let r2 = radius * radius;
        // Near or inside the sphere (or non-finite input): always tested.
        if !(d2.is_finite() && r2.is_finite()) || d2 <= r2 * 1.01 {
            return (Vec3::ZERO, f32::NEG_INFINITY);
        }
        let d = d2.sqrt();
        ((to / d), ((d2 - r2).sqrt() / d) - Self::MARGIN)
    }

    /// Bit k set where a lane's direction `from_p` (unit, pointing away from the point) may
    /// fall inside sphere k's cone; bits past the last sphere are set.
    #[inline(always)]
    pub fn candidates<I: Isa>(&self, from_p: V8<I>, lanes: M8<I>) -> u64 {
        let mut bits = !0u64;
        for (k, &(axis, cos)) in self.cones.iter().enumerate().take(64) {
            if cos > -1.0 && (from_p.dot(V8::splat(axis)).ge(F8::splat(cos)) & lanes).none() {
                bits &= !(1 << k);
            }
        }
        bits
    }
}

/// `transparency^n` for n ∈ {0, 1, 2} crossings, as the single-ray pass's `powi` gives it.
#[inline(always)]
fn crossing_factor<I: Isa>(n: F8<I>, transparency: f32) -> F8<I> {
    let (one, two) = (F8::splat(transparency), F8::splat(transparency * transparency));
    F8::select(n.eq(F8::one()), one, F8::select(n.eq(F8::splat(2.0)), two, F8::one()))
}

impl<I: Isa> Default for Surfaces8<I> {
    /// No lane hit.
    fn default() -> Self {
        empty_surfaces()
    }
}

#[inline(always)]
fn empty_surfaces<I: Isa>() -> Surfaces8<I> {
    Surfaces8 {
        hit: M8::none_set(),
        t: F8::zero(),
        position: V8::zero(),
        p_error: V8::zero(),
        geometric_normal: V8::zero(),
        shading_normal: V8::zero(),
        uv: [F8::zero(); 2],
        material: U8x::splat(0),
        object: U8x::splat(0),
        prim: U8x::splat(NO_PRIM),
    }
}
