//! Eight rays at once, structure of arrays: the batch API the batched integrators query
//! (Whitted packets and streams now; the wavefront path tracer next).
//!
//! A batch is [`Rays8<I>`] (origins, directions and intervals as lane planes) with an active-lane
//! mask ([`M8<I>`]): inactive lanes are neither tested nor written. Spheres and planes are tested
//! across the eight rays in one pass ([`sphere8`], [`plane8`], [`sphere_crossings8`]), each lane
//! performing exactly the float operations of the scalar tests in [`crate::primitives`], so
//! batches and single rays agree bit for bit. Meshes answer through
//! [`MeshBvh::intersect_batch`] and [`MeshBvh::occluded_batch`], which run today's 8-ray packet
//! kernels (`MeshBvh::intersect8`) beneath: the engine under this API can change without its
//! callers noticing.
//!
//! Like [`glint_core::lanes`], everything here is `#[inline(always)]` and ISA-neutral: callers
//! compile it inside their own baseline and AVX2 entry points.

use crate::lanes::{F8, Isa, LANES, M8, U8x, V8};
use crate::{Hit, MeshBvh};
use glint_core::{Ray, Vec3};

/// Eight rays: lane `i` is the ray `origin + t·dir`, `t` in `(tmin, tmax]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rays8<I: Isa> {
    pub origin: V8<I>,
    pub dir: V8<I>,
    pub tmin: F8<I>,
    pub tmax: F8<I>,
}

impl<I: Isa> Rays8<I> {
    #[inline(always)]
    #[must_use]
    pub fn from_rays(rays: &[Ray; LANES]) -> Rays8<I> {
        Rays8 {
            origin: V8::from_fn(|i| rays[i].origin),
            dir: V8::from_fn(|i| rays[i].dir),
            tmin: F8::from_fn(|i| rays[i].tmin),
            tmax: F8::from_fn(|i| rays[i].tmax),
        }
    }

    /// Lane `i` as a ray.
    #[inline(always)]
    #[must_use]
    pub fn ray(&self, i: usize) -> Ray {
        Ray::segment(self.origin.lane(i), self.dir.lane(i), self.tmin[i], self.tmax[i])
    }

    /// The lanes as rays; inactive lanes get an empty interval (`tmin = +∞`), which no test
    /// accepts and no box lets through.
    #[inline(always)]
    #[must_use]
    pub fn to_rays(&self, active: M8<I>) -> [Ray; LANES] {
        let bits = active.bits();
        std::array::from_fn(|i| {
            let mut r = self.ray(i);
            if bits >> i & 1 == 0 {
                (r.tmin, r.tmax) = (f32::INFINITY, f32::NEG_INFINITY);
            }
            r
        })
    }
}

/// Closest hits of eight rays: distance, primitive and barycentrics per lane (as [`Hit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hits8<I: Isa> {
    pub t: F8<I>,
    pub prim: U8x<I>,
    pub u: F8<I>,
    pub v: F8<I>,
}

impl<I: Isa> Hits8<I> {
    /// No lane has hit anything.
    #[inline(always)]
    #[must_use]
    pub fn none() -> Hits8<I> {
        Hits8 { t: F8::zero(), prim: U8x::splat(u32::MAX), u: F8::zero(), v: F8::zero() }
    }

    /// Lane `i` as a hit.
    #[inline(always)]
    #[must_use]
    pub fn hit(&self, i: usize) -> Hit {
        Hit { t: self.t[i], prim: self.prim[i], u: self.u[i], v: self.v[i] }
    }
}

/// The discriminant part of each lane's ray–sphere quadratic, as [`crate::primitives`]'
/// `sphere_roots` computes it: `f = origin − centre`, `b = f·d`, `c = f·f − r²` and
/// `disc = a (r² − |f − d b/a|²)`, with the lanes where the roots are real (`disc ≥ 0`, `a`
/// finite and non-zero). `None` when no `active` lane can be real: first a division-free
/// test, `a|f|² − b² > a r²` with a margin well above its rounding error (the rays pass too
/// far from the centre), which spares most batches the exact arithmetic.
#[inline(always)]
fn sphere_disc8<I: Isa>(
    rays: &Rays8<I>,
    dd: F8<I>,
    active: M8<I>,
    centre: Vec3,
    radius: f32,
) -> Option<SphereDisc8<I>> {
    let d = rays.dir;
    let f = rays.origin - V8::splat(centre);
    let r2 = F8::splat(radius * radius);
    let b = f.dot(d);
    let ff = f.dot(f);
    // a|f|² − b² is a·|l|² (the squared distance of the line from the centre, times a) up to
    // rounding of at most a few ε·a|f|²: keep every lane within 1e-5·a|f|² of the sphere.
    let far = dd * ff - b * b;
    let near = dd * r2 + F8::splat(1e-5) * dd * ff;
    if (far.le(near) & active).none() && far.lt(F8::splat(f32::INFINITY)).bits() & active.bits() == active.bits() {
        return None;
    }
    let l = f - d.scale(b / dd);
    let disc = dd * (r2 - l.dot(l));
    // NaN compares false: such lanes have no real roots; `a == 0` or non-finite lanes neither.
    let real = disc.ge(F8::zero()) & dd.gt(F8::zero()) & dd.lt(F8::splat(f32::INFINITY));
    Some(SphereDisc8 { real, disc, b, c: ff - r2 })
}

/// What [`sphere_disc8`] found: the lanes with real roots, the discriminant and the
/// quadratic's `b` and `c`.
struct SphereDisc8<I: Isa> {
    real: M8<I>,
    disc: F8<I>,
    b: F8<I>,
    c: F8<I>,
}

/// Both ordered roots from [`sphere_disc8`]'s parts, lane by lane `sphere_roots`' operations.
#[inline(always)]
fn sphere_roots8<I: Isa>(dd: F8<I>, disc: F8<I>, b: F8<I>, c: F8<I>) -> (F8<I>, F8<I>) {
    let q = -(b + disc.max(F8::zero()).sqrt().copysign(b));
    let q_zero = q.eq(F8::zero());
    let t0 = F8::select(q_zero, F8::zero(), c / q);
    let t1 = F8::select(q_zero, F8::zero(), q / dd);
    let ordered = t0.le(t1);
    (F8::select(ordered, t0, t1), F8::select(ordered, t1, t0))
}

/// Lanes whose `t` lies in the ray's interval `(tmin, tmax]`.
#[inline(always)]
fn within<I: Isa>(rays: &Rays8<I>, t: F8<I>) -> M8<I> {
    t.gt(rays.tmin) & t.le(rays.tmax)
}

/// The nearest root of each active lane's ray with the sphere in `(tmin, tmax]` (the far root
/// for a ray starting inside): `(lanes that hit, t)`, as [`crate::primitives::intersect_sphere`]
/// per lane. `dd` is `dir · dir` per lane (shared by every sphere of a batch).
#[inline(always)]
#[must_use]
pub fn sphere8<I: Isa>(rays: &Rays8<I>, dd: F8<I>, active: M8<I>, centre: Vec3, radius: f32) -> (M8<I>, F8<I>) {
    let Some(SphereDisc8 { real, disc, b, c }) = sphere_disc8(rays, dd, active, centre, radius) else {
        return (M8::none_set(), F8::zero());
    };
    let real = real & active;
    if real.none() {
        return (M8::none_set(), F8::zero());
    }
    let (t0, t1) = sphere_roots8(dd, disc, b, c);
    let in0 = within(rays, t0) & real & active;
    let in1 = within(rays, t1) & real & active;
    (in0 | in1, F8::select(in0, t0, t1))
}

/// How many times each lane's interval crosses the sphere's surface (0, 1 or 2, as f32), as
/// [`crate::primitives::sphere_crossings`] per lane; 0 on inactive lanes.
#[inline(always)]
#[must_use]
pub fn sphere_crossings8<I: Isa>(rays: &Rays8<I>, dd: F8<I>, active: M8<I>, centre: Vec3, radius: f32) -> F8<I> {
    let Some(SphereDisc8 { real, disc, b, c }) = sphere_disc8(rays, dd, active, centre, radius) else {
        return F8::zero();
    };
    let live = real & active;
    if live.none() {
        return F8::zero();
    }
    let (t0, t1) = sphere_roots8(dd, disc, b, c);
    let (one, zero) = (F8::one(), F8::zero());
    F8::select(within(rays, t0) & live, one, zero) + F8::select(within(rays, t1) & live, one, zero)
}

/// Each active lane's hit with the plane `p · normal + offset = 0` in `(tmin, tmax]`, as
/// [`crate::primitives::intersect_plane`] per lane (no hit parallel to the plane).
#[inline(always)]
#[must_use]
pub fn plane8<I: Isa>(rays: &Rays8<I>, active: M8<I>, normal: Vec3, offset: f32) -> (M8<I>, F8<I>) {
    let n = V8::splat(normal);
    let denom = rays.dir.dot(n);
    let t = -(rays.origin.dot(n) + F8::splat(offset)) / denom;
    (within(rays, t) & !denom.eq(F8::zero()) & active, t)
}

/// [`glint_core::float::offset_ray_origin`] of eight points at once: lane by lane the same
/// operations and the same one-ulp rounding (as bit arithmetic across lanes), so the same bits.
#[inline(always)]
#[must_use]
pub fn offset_ray_origin8<I: Isa>(p: V8<I>, p_error: V8<I>, n: V8<I>, w: V8<I>) -> V8<I> {
    RayOrigins8::new(p, p_error, n).toward(w)
}

/// Both spawn points of eight surface points, worked out once for every ray a hit spawns:
/// `offset_ray_origin` only looks at a direction's side of the surface (the sign of `w · n`),
/// so each spawned ray picks one of the two.
#[derive(Clone, Copy, Debug)]
pub struct RayOrigins8<I: Isa> {
    /// The point pushed out along `+n`, and along `−n`, each rounded away from the surface.
    front: V8<I>,
    back: V8<I>,
    n: V8<I>,
}

impl<I: Isa> RayOrigins8<I> {
    #[inline(always)]
    #[must_use]
    pub fn new(p: V8<I>, p_error: V8<I>, n: V8<I>) -> Self {
        // At least the largest error component, as the scalar offset: on an axis-aligned
        // surface at coordinate 0 the projected bound is 0 (see `offset_ray_origin`).
        let d = n.abs().dot(p_error).max(p_error.max_element());
        let offset = n.scale(d);
        RayOrigins8 { front: round_away(p + offset, offset), back: round_away(p + (-offset), -offset), n }
    }

    /// The origin of rays leaving in direction `w`.
    #[inline(always)]
    #[must_use]
    pub fn toward(&self, w: V8<I>) -> V8<I> {
        V8::select(w.dot(self.n).lt(F8::zero()), self.back, self.front)
    }
}

/// [`round_away8`] of each component.
#[inline(always)]
fn round_away<I: Isa>(po: V8<I>, o: V8<I>) -> V8<I> {
    V8::new(round_away8(po.x, o.x), round_away8(po.y, o.y), round_away8(po.z, o.z))
}

/// Per lane: [`glint_core::float::next_float_up`] of `v` where `o` > 0, [`glint_core::float::next_float_down`] where `o` < 0, `v`
/// itself where `o` is 0 or NaN.
#[inline(always)]
fn round_away8<I: Isa>(v: F8<I>, o: F8<I>) -> F8<I> {
    let bits = v.to_bits();
    let one = U8x::splat(1);
    let (plus, minus) = (bits.wrapping_add(one), bits.wrapping_sub(one));
    let zero = v.eq(F8::zero());
    let (pos, neg) = (v.gt(F8::zero()), v.lt(F8::zero()));
    // Up: away from −∞ (±0 → the smallest positive subnormal); +∞ and NaN stay.
    let up = U8x::select(pos, plus, U8x::select(neg, minus, U8x::select(zero, one, bits)));
    let up = U8x::select(v.eq(F8::splat(f32::INFINITY)), bits, up);
    // Down: toward −∞ (±0 → the smallest negative subnormal); −∞ and NaN stay.
    let down = U8x::select(pos, minus, U8x::select(neg, plus, U8x::select(zero, U8x::splat(0x8000_0001), bits)));
    let down = U8x::select(v.eq(F8::splat(f32::NEG_INFINITY)), bits, down);
    let rounded = U8x::select(o.gt(F8::zero()), up, U8x::select(o.lt(F8::zero()), down, bits));
    F8::from_bits(rounded)
}

impl MeshBvh {
    /// Closest hits of the active lanes of `rays`, each in its own interval: the lanes that
    /// hit, whose hits are written into `out` (other lanes untouched). Lane `i` equals
    /// [`MeshBvh::intersect`] of `rays.ray(i)` bit for bit.
    ///
    /// Left to the compiler to inline: inlined, it made the batched Whitted kernel of scenes
    /// without meshes 5 % slower (its registers and layout). Out of line, an `Avx2`
    /// instantiation sits outside the caller's `target_feature` function, where every lane
    /// operation is a call: so it takes the active lanes' bits once and works on arrays.
    #[inline]
    pub fn intersect_batch<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>, out: &mut Hits8<I>) -> M8<I> {
        let mut found = [None; LANES];
        self.intersect8(&rays.to_rays(active), &mut found);
        let bits = active.bits();
        let mut hit = 0;
        for (i, f) in found.into_iter().enumerate() {
            if let (Some(h), true) = (f, bits >> i & 1 == 1) {
                (out.t[i], out.prim[i], out.u[i], out.v[i]) = (h.t, h.prim, h.u, h.v);
                hit |= 1 << i;
            }
        }
        M8::from_bits(hit)
    }

    /// The active lanes of `rays` that hit anything in their interval (any hit), as
    /// [`MeshBvh::occluded`] per lane (inlining: see [`MeshBvh::intersect_batch`]).
    #[inline]
    pub fn occluded_batch<I: Isa>(&self, rays: &Rays8<I>, active: M8<I>) -> M8<I> {
        let mut blocked = [false; LANES];
        self.occluded8(&rays.to_rays(active), &mut blocked);
        let bits = blocked.iter().enumerate().fold(0, |m, (i, &b)| m | u32::from(b) << i);
        M8::from_bits(bits & active.bits())
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lanes are indexed as the kernels index them
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::lanes::Sse;
    use crate::primitives::{intersect_plane, intersect_sphere, sphere_crossings};
    use crate::procedural::{Rng, displaced_sphere};
    use glint_core::float::{gamma, next_float_down, next_float_up, offset_ray_origin};

    fn random_rays(rng: &mut Rng, spread: f32) -> [Ray; LANES] {
        std::array::from_fn(|i| {
            let origin = (rng.next_vec3() - 0.5) * spread;
            let dir = rng.next_dir() * if i % 3 == 0 { 2.5 } else { 1.0 };
            let tmax = if i % 4 == 0 { rng.next_f32() * 6.0 } else { f32::INFINITY };
            Ray::segment(origin, dir, if i % 5 == 0 { 0.5 } else { 0.0 }, tmax)
        })
    }

    struct Checks;

    impl crate::lanes::LaneKernel for Checks {
        type Output = ();
        #[inline(always)]
        fn run<I: Isa>(self) {
            lanes_equal_the_scalar_primitive_tests::<I>();
            planes_equal_the_scalar_test::<I>();
            mesh_batches_equal_single_rays::<I>();
        }
    }

    /// Every check below, with each instruction set this CPU has.
    #[test]
    fn batches_equal_single_rays_on_every_isa() {
        crate::lanes::dispatch(Checks, true);
        crate::lanes::dispatch(Checks, false);
    }

    /// Spheres and their crossings across lanes equal the scalar tests bit for bit, and
    /// inactive lanes never hit.
    fn lanes_equal_the_scalar_primitive_tests<I: Isa>() {
        let mut rng = Rng::new(9);
        for _ in 0..4000 {
            let rays = random_rays(&mut rng, 10.0);
            let batch = Rays8::<I>::from_rays(&rays);
            let dd = batch.dir.dot(batch.dir);
            let active = M8::from_bits((rng.next_f32() * 256.0) as u32 & 0xff);
            let (c, r) = ((rng.next_vec3() - 0.5) * 6.0, 0.1 + rng.next_f32() * 1.5);
            let (hit, t) = sphere8(&batch, dd, active, c, r);
            let crossings = sphere_crossings8(&batch, dd, active, c, r);
            for i in 0..LANES {
                let want = intersect_sphere(&rays[i], c, r).filter(|_| active.lane(i));
                assert_eq!(hit.lane(i).then_some(t[i].to_bits()), want.map(f32::to_bits), "sphere lane {i}");
                let want = if active.lane(i) { sphere_crossings(&rays[i], c, r) } else { 0 };
                assert_eq!(crossings[i], want as f32, "crossings lane {i}");
            }
        }
    }

    /// The plane test against the scalar one on rays aimed at it.
    fn planes_equal_the_scalar_test<I: Isa>() {
        let mut rng = Rng::new(3);
        for _ in 0..4000 {
            let rays = random_rays(&mut rng, 4.0);
            let batch = Rays8::<I>::from_rays(&rays);
            let (n, offset) = (rng.next_dir(), rng.next_f32() - 0.5);
            let active = M8::from_bits((rng.next_f32() * 256.0) as u32 & 0xff);
            let (hit, t) = plane8(&batch, active, n, offset);
            for i in 0..LANES {
                let want = intersect_plane(&rays[i], n, offset).filter(|_| active.lane(i));
                assert_eq!(hit.lane(i).then_some(t[i].to_bits()), want.map(f32::to_bits), "lane {i}");
            }
        }
    }

    /// Mesh batches equal single-ray queries on the active lanes and leave the rest alone.
    fn mesh_batches_equal_single_rays<I: Isa>() {
        let m = displaced_sphere(4000);
        let bvh = MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::default());
        let mut rng = Rng::new(11);
        for _ in 0..2000 {
            let rays = random_rays(&mut rng, 5.0);
            let batch = Rays8::<I>::from_rays(&rays);
            let active = M8::from_bits((rng.next_f32() * 256.0) as u32 & 0xff);
            let mut out = Hits8::<I>::none();
            let hit = bvh.intersect_batch(&batch, active, &mut out);
            let blocked = bvh.occluded_batch(&batch, active);
            for i in 0..LANES {
                let want = bvh.intersect(&rays[i]).filter(|_| active.lane(i));
                assert_eq!(hit.lane(i).then(|| out.hit(i)), want, "lane {i}");
                if !active.lane(i) {
                    assert_eq!(out.prim[i], u32::MAX, "inactive lane {i} written");
                }
                assert_eq!(blocked.lane(i), active.lane(i) && bvh.occluded(&rays[i]), "occluded lane {i}");
            }
        }
    }

    #[test]
    fn eight_offsets_equal_the_scalar_offset() {
        let p = V8::<Sse>::from_fn(|i| Vec3::new(i as f32 * 1.7 - 3.0, 0.25 * i as f32, -(i as f32).powi(3)));
        let e = V8::from_fn(|i| Vec3::splat(gamma(5) * (1.0 + i as f32)));
        let n = V8::from_fn(|i| Vec3::new((i as f32).sin(), (i as f32).cos(), 0.3).normalize());
        let w = V8::from_fn(|i| if i % 2 == 0 { Vec3::Y } else { -Vec3::X });
        let o = offset_ray_origin8(p, e, n, w);
        for i in 0..LANES {
            assert_eq!(o.lane(i), offset_ray_origin(p.lane(i), e.lane(i), n.lane(i), w.lane(i)), "lane {i}");
        }
        // Axis-aligned walls at coordinate 0 (a Cornell box's): the error bound along the
        // normal is 0, the offset comes from the other components.
        let p = V8::<Sse>::from_fn(|i| Vec3::new(0.0, 0.3 * i as f32, 1.0 - 0.2 * i as f32));
        let e = V8::from_fn(|i| Vec3::new(0.0, gamma(5) * (1.0 + i as f32), gamma(7)));
        let n = V8::from_fn(|i| if i % 3 == 0 { -Vec3::X } else { Vec3::X });
        let w = V8::from_fn(|i| Vec3::new(if i % 2 == 0 { 1.0 } else { -1.0 }, 0.5, 0.1).normalize());
        let o = offset_ray_origin8(p, e, n, w);
        for i in 0..LANES {
            let want = offset_ray_origin(p.lane(i), e.lane(i), n.lane(i), w.lane(i));
            assert_ne!(want.x, 0.0, "lane {i}: the scalar offset leaves the wall");
            assert_eq!(o.lane(i), want, "lane {i}");
        }
    }

    #[test]
    fn eight_roundings_equal_the_scalar_steps() {
        let specials =
            [0.0f32, -0.0, 1.0, -1.0, f32::MIN_POSITIVE, -f32::MIN_POSITIVE, 1e-45, -1e-45, f32::MAX, f32::MIN];
        let more = [f32::INFINITY, f32::NEG_INFINITY, f32::NAN, 3.5e7, -2.25];
        for &v in specials.iter().chain(&more) {
            for o in [1.0f32, -1.0, 0.0] {
                let got = round_away8::<Sse>(F8::splat(v), F8::splat(o))[0];
                let want = if o > 0.0 {
                    next_float_up(v)
                } else if o < 0.0 {
                    next_float_down(v)
                } else {
                    v
                };
                assert_eq!(got.to_bits(), want.to_bits(), "v {v:e} o {o}");
            }
        }
    }
}
