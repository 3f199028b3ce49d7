//! Eight rays at once, structure of arrays: the batch API the batched integrators query
//! (Whitted packets and streams now; the wavefront path tracer next).
//!
//! A batch is [`Rays8`] (origins, directions and intervals as lane planes) with an active-lane
//! mask ([`M8`]): inactive lanes are neither tested nor written. Spheres and planes are tested
//! across the eight rays in one pass ([`sphere8`], [`plane8`], [`sphere_crossings8`]), each lane
//! performing exactly the float operations of the scalar tests in [`crate::primitives`], so
//! batches and single rays agree bit for bit. Meshes answer through
//! [`MeshBvh::intersect_batch`] and [`MeshBvh::occluded_batch`], which run today's 8-ray packet
//! kernels (`MeshBvh::intersect8`) beneath: the engine under this API can change without its
//! callers noticing.
//!
//! Like [`glint_core::lanes`], everything here is `#[inline(always)]` and ISA-neutral: callers
//! compile it inside their own baseline and AVX2 entry points.

use crate::{Hit, MeshBvh};
use glint_core::lanes::{F8, LANES, M8, U8x, V8};
use glint_core::{Ray, Vec3};

/// Eight rays: lane `i` is the ray `origin + t·dir`, `t` in `(tmin, tmax]`.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rays8 {
    pub origin: V8,
    pub dir: V8,
    pub tmin: F8,
    pub tmax: F8,
}

impl Rays8 {
    #[inline(always)]
    #[must_use]
    pub fn from_rays(rays: &[Ray; LANES]) -> Rays8 {
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
    pub fn to_rays(&self, active: M8) -> [Ray; LANES] {
        std::array::from_fn(|i| {
            let mut r = self.ray(i);
            if !active.lane(i) {
                (r.tmin, r.tmax) = (f32::INFINITY, f32::NEG_INFINITY);
            }
            r
        })
    }
}

/// Closest hits of eight rays: distance, primitive and barycentrics per lane (as [`Hit`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hits8 {
    pub t: F8,
    pub prim: U8x,
    pub u: F8,
    pub v: F8,
}

impl Hits8 {
    /// No lane has hit anything.
    pub const NONE: Hits8 = Hits8 { t: F8::ZERO, prim: U8x::from_array([u32::MAX; LANES]), u: F8::ZERO, v: F8::ZERO };

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
/// finite and non-zero). A batch where no lane is real skips the rest.
#[inline(always)]
fn sphere_disc8(rays: &Rays8, dd: F8, centre: Vec3, radius: f32) -> (M8, F8, F8, F8) {
    let d = rays.dir;
    let f = rays.origin - V8::splat(centre);
    let r2 = F8::splat(radius * radius);
    let b = f.dot(d);
    let l = f - d.scale(b / dd);
    let disc = dd * (r2 - l.dot(l));
    // NaN compares false: such lanes have no real roots; `a == 0` or non-finite lanes neither.
    let real = disc.ge(F8::ZERO) & dd.gt(F8::ZERO) & dd.lt(F8::splat(f32::INFINITY));
    (real, disc, b, f.dot(f) - r2)
}

/// Both ordered roots from [`sphere_disc8`]'s parts, lane by lane `sphere_roots`' operations.
#[inline(always)]
fn sphere_roots8(dd: F8, disc: F8, b: F8, c: F8) -> (F8, F8) {
    let q = -(b + disc.max(F8::ZERO).sqrt().copysign(b));
    let q_zero = q.eq(F8::ZERO);
    let t0 = F8::select(q_zero, F8::ZERO, c / q);
    let t1 = F8::select(q_zero, F8::ZERO, q / dd);
    let ordered = t0.le(t1);
    (F8::select(ordered, t0, t1), F8::select(ordered, t1, t0))
}

/// Lanes whose `t` lies in the ray's interval `(tmin, tmax]`.
#[inline(always)]
fn within(rays: &Rays8, t: F8) -> M8 {
    t.gt(rays.tmin) & t.le(rays.tmax)
}

/// The nearest root of each active lane's ray with the sphere in `(tmin, tmax]` (the far root
/// for a ray starting inside): `(lanes that hit, t)`, as [`crate::primitives::intersect_sphere`]
/// per lane. `dd` is `dir · dir` per lane (shared by every sphere of a batch).
#[inline(always)]
#[must_use]
pub fn sphere8(rays: &Rays8, dd: F8, active: M8, centre: Vec3, radius: f32) -> (M8, F8) {
    let (real, disc, b, c) = sphere_disc8(rays, dd, centre, radius);
    let real = real & active;
    if real.none() {
        return (M8::NONE, F8::ZERO);
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
pub fn sphere_crossings8(rays: &Rays8, dd: F8, active: M8, centre: Vec3, radius: f32) -> F8 {
    let (real, disc, b, c) = sphere_disc8(rays, dd, centre, radius);
    let live = real & active;
    if live.none() {
        return F8::ZERO;
    }
    let (t0, t1) = sphere_roots8(dd, disc, b, c);
    let one = |m: M8| F8::select(m & live, F8::ONE, F8::ZERO);
    one(within(rays, t0)) + one(within(rays, t1))
}

/// Each active lane's hit with the plane `p · normal + offset = 0` in `(tmin, tmax]`, as
/// [`crate::primitives::intersect_plane`] per lane (no hit parallel to the plane).
#[inline(always)]
#[must_use]
pub fn plane8(rays: &Rays8, active: M8, normal: Vec3, offset: f32) -> (M8, F8) {
    let n = V8::splat(normal);
    let denom = rays.dir.dot(n);
    let t = -(rays.origin.dot(n) + F8::splat(offset)) / denom;
    (within(rays, t) & !denom.eq(F8::ZERO) & active, t)
}

impl MeshBvh {
    /// Closest hits of the active lanes of `rays`, each in its own interval: the lanes that
    /// hit, whose hits are written into `out` (other lanes untouched). Lane `i` equals
    /// [`MeshBvh::intersect`] of `rays.ray(i)` bit for bit.
    #[inline]
    pub fn intersect_batch(&self, rays: &Rays8, active: M8, out: &mut Hits8) -> M8 {
        let mut found = [None; LANES];
        self.intersect8(&rays.to_rays(active), &mut found);
        let mut hit = 0;
        for (i, f) in found.into_iter().enumerate() {
            if let (Some(h), true) = (f, active.lane(i)) {
                (out.t[i], out.prim[i], out.u[i], out.v[i]) = (h.t, h.prim, h.u, h.v);
                hit |= 1 << i;
            }
        }
        M8::from_bits(hit)
    }

    /// The active lanes of `rays` that hit anything in their interval (any hit), as
    /// [`MeshBvh::occluded`] per lane.
    #[inline]
    pub fn occluded_batch(&self, rays: &Rays8, active: M8) -> M8 {
        let mut blocked = [false; LANES];
        self.occluded8(&rays.to_rays(active), &mut blocked);
        M8::from_fn(|i| blocked[i]) & active
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lanes are indexed as the kernels index them
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::primitives::{intersect_plane, intersect_sphere, sphere_crossings};
    use crate::procedural::{Rng, displaced_sphere};

    fn random_rays(rng: &mut Rng, spread: f32) -> [Ray; LANES] {
        std::array::from_fn(|i| {
            let origin = (rng.next_vec3() - 0.5) * spread;
            let dir = rng.next_dir() * if i % 3 == 0 { 2.5 } else { 1.0 };
            let tmax = if i % 4 == 0 { rng.next_f32() * 6.0 } else { f32::INFINITY };
            Ray::segment(origin, dir, if i % 5 == 0 { 0.5 } else { 0.0 }, tmax)
        })
    }

    /// Spheres and their crossings across lanes equal the scalar tests bit for bit, and
    /// inactive lanes never hit.
    #[test]
    fn lanes_equal_the_scalar_primitive_tests() {
        let mut rng = Rng::new(9);
        for _ in 0..4000 {
            let rays = random_rays(&mut rng, 10.0);
            let batch = Rays8::from_rays(&rays);
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
    #[test]
    fn planes_equal_the_scalar_test() {
        let mut rng = Rng::new(3);
        for _ in 0..4000 {
            let rays = random_rays(&mut rng, 4.0);
            let batch = Rays8::from_rays(&rays);
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
    #[test]
    fn mesh_batches_equal_single_rays() {
        let m = displaced_sphere(4000);
        let bvh = MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::default());
        let mut rng = Rng::new(11);
        for _ in 0..2000 {
            let rays = random_rays(&mut rng, 5.0);
            let batch = Rays8::from_rays(&rays);
            let active = M8::from_bits((rng.next_f32() * 256.0) as u32 & 0xff);
            let mut out = Hits8::NONE;
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
}
