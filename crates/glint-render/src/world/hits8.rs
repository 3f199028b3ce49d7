//! Surface data of eight mesh hits at once (pipeline: the 8-ray closest-hit queries' answers
//! made into [`SurfaceHit`]s for the integrators).
//!
//! A hit on an untransformed mesh instance is interpolated in lanes: position and its error
//! bound, the geometric normal (the triangle's, normalised), the shading normal (the vertex
//! normals', normalised, on the geometric normal's side), the uv. Each lane performs the
//! scalar `World::instance_hit`'s float operations in its order (glam's, no fused
//! multiply-add), so each lane's hit is the single-ray query's bit for bit (the world tests
//! compare them). Transformed instances and spheres are finished lane by lane by the scalar
//! code. What a lane gathers (the triangle's corners, normals and uvs) is read lane by lane.

use super::World;
use super::hit::SurfaceHit;
use super::instances::InstanceShape;
use glint_accel::Hit as MeshHit;
use glint_accel::lanes::{F8, Isa, LaneKernel, M8, V8, dispatch};
use glint_core::float::gamma;
use glint_core::{Ray, Vec2, Vec3};

/// One lane's hit: the instance and its mesh triangle, barycentrics and distance.
#[derive(Clone, Copy, Debug)]
pub(super) struct Found {
    pub inst: u32,
    pub prim: u32,
    pub hit: MeshHit,
}

impl World {
    /// `out[i]` = the surface hit of `found[i]` (found by `rays[i]`), as
    /// `World::surface_hit` makes it.
    pub(super) fn mesh_hits8(&self, rays: &[Ray; 8], found: &[Option<Found>; 8], out: &mut [Option<SurfaceHit>; 8]) {
        dispatch(Kernel { world: self, rays, found, out }, crate::lanes_baseline());
    }
}

struct Kernel<'a> {
    world: &'a World,
    rays: &'a [Ray; 8],
    found: &'a [Option<Found>; 8],
    out: &'a mut [Option<SurfaceHit>; 8],
}

impl LaneKernel for Kernel<'_> {
    type Output = ();

    #[inline(always)]
    fn run<I: Isa>(self) {
        mesh_hits8::<I>(self.world, self.rays, self.found, self.out);
    }
}

/// Eight triangles' corners and attributes at the hits' barycentrics, in lanes.
struct Corners<I: Isa> {
    lanes: M8<I>,
    p: [V8<I>; 3],
    normals: M8<I>,
    n: [V8<I>; 3],
    uvs: M8<I>,
    uv: [[F8<I>; 2]; 3],
    u: F8<I>,
    v: F8<I>,
}

#[inline(always)]
fn mesh_hits8<I: Isa>(world: &World, rays: &[Ray; 8], found: &[Option<Found>; 8], out: &mut [Option<SurfaceHit>; 8]) {
    let zero3 = V8::<I>::zero();
    let mut c = Corners::<I> {
        lanes: M8::none_set(),
        p: [zero3; 3],
        normals: M8::none_set(),
        n: [zero3; 3],
        uvs: M8::none_set(),
        uv: [[F8::zero(); 2]; 3],
        u: F8::zero(),
        v: F8::zero(),
    };
    let (mut lanes, mut normals, mut uvs) = (0u32, 0u32, 0u32);
    for (i, f) in found.iter().enumerate() {
        let Some(f) = f else {
            out[i] = None;
            continue;
        };
        let inst = &world.instances[f.inst as usize];
        let InstanceShape::Mesh(m) = inst.shape else {
            out[i] = Some(world.instance_hit(inst, &rays[i], f.hit.t, f.prim, f.hit.u, f.hit.v));
            continue;
        };
        if !inst.identity {
            out[i] = Some(world.instance_hit(inst, &rays[i], f.hit.t, f.prim, f.hit.u, f.hit.v));
            continue;
        }
        let mesh = &world.meshes[m];
        let tri = mesh.triangles[f.prim as usize].map(|k| k as usize);
        lanes |= 1 << i;
        for (k, &vi) in tri.iter().enumerate() {
            c.p[k].set(i, mesh.positions[vi]);
        }
        if let Some(n) = &mesh.normals {
            normals |= 1 << i;
            for (k, &vi) in tri.iter().enumerate() {
                c.n[k].set(i, n[vi]);
            }
        }
        if let Some(t) = &mesh.uvs {
            uvs |= 1 << i;
            for (k, &vi) in tri.iter().enumerate() {
                (c.uv[k][0][i], c.uv[k][1][i]) = (t[vi].x, t[vi].y);
            }
        }
        (c.u[i], c.v[i]) = (f.hit.u, f.hit.v);
    }
    if lanes == 0 {
        return;
    }
    (c.lanes, c.normals, c.uvs) = (M8::from_bits(lanes), M8::from_bits(normals), M8::from_bits(uvs));
    let s = interpolate(&c);
    for (i, f) in found.iter().enumerate() {
        let Some(f) = f.filter(|_| c.lanes.lane(i)) else { continue };
        let inst = &world.instances[f.inst as usize];
        let mesh = match inst.shape {
            InstanceShape::Mesh(m) => &world.meshes[m],
            InstanceShape::Sphere { .. } => continue,
        };
        let material = match &mesh.triangle_materials {
            Some(ms) => ms[f.prim as usize],
            None => inst.material,
        };
        out[i] = Some(SurfaceHit {
            t: f.hit.t,
            position: s.position.lane(i),
            p_error: s.p_error.lane(i),
            geometric_normal: s.geometric.lane(i),
            shading_normal: s.shading.lane(i),
            uv: Vec2::new(s.uv[0][i], s.uv[1][i]),
            material,
            object: inst.object,
            prim: f.prim,
        });
    }
}

struct Interpolated<I: Isa> {
    position: V8<I>,
    p_error: V8<I>,
    geometric: V8<I>,
    shading: V8<I>,
    uv: [F8<I>; 2],
}

/// glam's `normalize_or`: `v · (1 / |v|)` where that reciprocal is finite and positive, else
/// `fallback`.
#[inline(always)]
fn normalize_or<I: Isa>(v: V8<I>, fallback: V8<I>) -> V8<I> {
    let rcp = F8::one() / v.dot(v).sqrt();
    let ok = rcp.gt(F8::zero()) & rcp.lt(F8::splat(f32::INFINITY));
    V8::select(ok, v.scale(rcp), fallback)
}

/// `v` turned to the side of `n` (`-v` where `v · n < 0`).
#[inline(always)]
fn face<I: Isa>(v: V8<I>, n: V8<I>) -> V8<I> {
    V8::select(v.dot(n).lt(F8::zero()), -v, v)
}

/// `instance_hit`'s mesh branch for an untransformed instance, operation for operation.
#[inline(always)]
fn interpolate<I: Isa>(c: &Corners<I>) -> Interpolated<I> {
    let (u, v) = (c.u, c.v);
    let w = F8::one() - u - v;
    let [p0, p1, p2] = c.p;
    let (a, b, d) = (p0.scale(w), p1.scale(u), p2.scale(v));
    let position = a + b + d;
    let p_error = (a.abs() + b.abs() + d.abs()).scale(F8::splat(gamma(7)));
    let geometric = normalize_or((p1 - p0).cross(p2 - p0), V8::splat(Vec3::Y));
    let [n0, n1, n2] = c.n;
    let smooth = face(normalize_or(n0.scale(w) + n1.scale(u) + n2.scale(v), geometric), geometric);
    let shading = face(V8::select(c.normals, smooth, geometric), geometric);
    let [t0, t1, t2] = c.uv;
    let uv = [0, 1].map(|k| F8::select(c.uvs, t0[k] * w + t1[k] * u + t2[k] * v, F8::zero()));
    Interpolated { position, p_error, geometric, shading, uv }
}
