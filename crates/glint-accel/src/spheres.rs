//! A small set of spheres tested four at a time (SoA, SSE2 through glam's `Vec4`).
//!
//! For the handful of untransformed spheres of a classic Whitted scene this replaces "box test,
//! then one scalar sphere test per box hit" by one vector pass. Every lane performs exactly the
//! floating-point operations of [`crate::primitives::intersect_sphere`], in the same order (no
//! fused operations), so the answers are bit-identical to the scalar test.

use glint_core::{Ray, Vec3, Vec4};

#[derive(Clone, Debug, Default)]
pub struct SphereSet {
    cx: Vec<Vec4>,
    cy: Vec<Vec4>,
    cz: Vec<Vec4>,
    r2: Vec<Vec4>,
    len: usize,
}

/// Both roots of four ray–sphere quadratics (ordered), and which lanes have real roots.
struct Roots {
    t0: Vec4,
    t1: Vec4,
    real: u32,
}

impl SphereSet {
    /// Spheres as (centre, radius); index in the slice = the id reported back.
    pub fn new(spheres: &[(Vec3, f32)]) -> Self {
        let groups = spheres.len().div_ceil(4);
        let mut set = SphereSet { len: spheres.len(), ..Default::default() };
        for g in 0..groups {
            // Padding lanes: radius² = -1 makes the discriminant negative, so they never hit.
            let lane = |k: usize| spheres.get(g * 4 + k).copied().unwrap_or((Vec3::ZERO, -1.0));
            let l: [(Vec3, f32); 4] = std::array::from_fn(lane);
            set.cx.push(Vec4::from_array(l.map(|s| s.0.x)));
            set.cy.push(Vec4::from_array(l.map(|s| s.0.y)));
            set.cz.push(Vec4::from_array(l.map(|s| s.0.z)));
            set.r2.push(Vec4::from_array(l.map(|s| if s.1 < 0.0 { -1.0 } else { s.1 * s.1 })));
        }
        set
    }

    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    #[inline(always)]
    fn roots(&self, g: usize, o: [Vec4; 3], d: [Vec4; 3], a: Vec4) -> Roots {
        let f = [o[0] - self.cx[g], o[1] - self.cy[g], o[2] - self.cz[g]];
        let b = f[0] * d[0] + f[1] * d[1] + f[2] * d[2];
        let c = (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) - self.r2[g];
        let k = b / a;
        let l = [f[0] - d[0] * k, f[1] - d[1] * k, f[2] - d[2] * k];
        let disc = a * (self.r2[g] - (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]));
        // NaN compares false: such lanes are not real.
        let real = disc.cmpge(Vec4::ZERO).bitmask();
        let root = Vec4::from_array(disc.max(Vec4::ZERO).to_array().map(f32::sqrt));
        let q = -(b + root.copysign(b));
        let q_zero = q.cmpeq(Vec4::ZERO);
        let t0 = Vec4::select(q_zero, Vec4::ZERO, c / q);
        let t1 = Vec4::select(q_zero, Vec4::ZERO, q / a);
        let swap = t0.cmple(t1);
        Roots { t0: Vec4::select(swap, t0, t1), t1: Vec4::select(swap, t1, t0), real }
    }

    #[inline(always)]
    fn splat_ray(ray: &Ray) -> ([Vec4; 3], [Vec4; 3], Vec4) {
        let d = ray.dir;
        let a = d.dot(d);
        (
            [Vec4::splat(ray.origin.x), Vec4::splat(ray.origin.y), Vec4::splat(ray.origin.z)],
            [Vec4::splat(d.x), Vec4::splat(d.y), Vec4::splat(d.z)],
            Vec4::splat(a),
        )
    }

    /// Nearest hit in `(tmin, tmax]`: `(t, sphere index)`; ties go to the lower index.
    #[inline]
    pub fn closest(&self, ray: &Ray) -> Option<(f32, u32)> {
        if self.len == 0 {
            return None;
        }
        let a = ray.dir.dot(ray.dir);
        if a == 0.0 || !a.is_finite() {
            return None;
        }
        let (o, d, av) = Self::splat_ray(ray);
        let (tmin, mut tmax) = (Vec4::splat(ray.tmin), ray.tmax);
        let mut best = None;
        for g in 0..self.cx.len() {
            let r = self.roots(g, o, d, av);
            if r.real == 0 {
                continue;
            }
            let tm = Vec4::splat(tmax);
            let in0 = r.t0.cmpgt(tmin) & r.t0.cmple(tm);
            let in1 = r.t1.cmpgt(tmin) & r.t1.cmple(tm);
            let t = Vec4::select(in0, r.t0, r.t1).to_array();
            let mut mask = (in0 | in1).bitmask() & r.real;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                if t[lane] < tmax || best.is_none() && t[lane] <= tmax {
                    tmax = t[lane];
                    best = Some((t[lane], (g * 4 + lane) as u32));
                }
            }
        }
        best
    }

    /// Calls `visit(sphere index, crossings)` for every sphere whose surface the interval
    /// `(tmin, tmax]` crosses (1 or 2 times); stops early when `visit` returns true, and then
    /// returns true.
    #[inline]
    pub fn crossings(&self, ray: &Ray, mut visit: impl FnMut(u32, u32) -> bool) -> bool {
        if self.len == 0 {
            return false;
        }
        let a = ray.dir.dot(ray.dir);
        if a == 0.0 || !a.is_finite() {
            return false;
        }
        let (o, d, av) = Self::splat_ray(ray);
        let (tmin, tmax) = (Vec4::splat(ray.tmin), Vec4::splat(ray.tmax));
        for g in 0..self.cx.len() {
            let r = self.roots(g, o, d, av);
            if r.real == 0 {
                continue;
            }
            let m0 = (r.t0.cmpgt(tmin) & r.t0.cmple(tmax)).bitmask() & r.real;
            let m1 = (r.t1.cmpgt(tmin) & r.t1.cmple(tmax)).bitmask() & r.real;
            let mut mask = m0 | m1;
            while mask != 0 {
                let lane = mask.trailing_zeros();
                mask &= mask - 1;
                let n = ((m0 >> lane) & 1) + ((m1 >> lane) & 1);
                if visit(g as u32 * 4 + lane, n) {
                    return true;
                }
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::primitives::{intersect_sphere, sphere_crossings};
    use crate::procedural::Rng;

    #[test]
    fn equals_the_scalar_sphere_test_bit_for_bit() {
        let mut rng = Rng::new(5);
        for n in [1usize, 3, 4, 5, 9] {
            let spheres: Vec<(Vec3, f32)> =
                (0..n).map(|_| ((rng.next_vec3() - 0.5) * 6.0, 0.1 + rng.next_f32() * 1.5)).collect();
            let set = SphereSet::new(&spheres);
            for i in 0..20_000 {
                let origin = (rng.next_vec3() - 0.5) * 10.0;
                let dir = rng.next_dir() * if i % 3 == 0 { 2.5 } else { 1.0 };
                let tmax = if i % 4 == 0 { rng.next_f32() * 6.0 } else { f32::INFINITY };
                let ray = Ray::segment(origin, dir, if i % 5 == 0 { 0.5 } else { 0.0 }, tmax);
                let mut want: Option<(f32, u32)> = None;
                for (k, s) in spheres.iter().enumerate() {
                    if let Some(t) = intersect_sphere(&ray, s.0, s.1)
                        && want.is_none_or(|w| t < w.0)
                    {
                        want = Some((t, k as u32));
                    }
                }
                let got = set.closest(&ray);
                assert_eq!(got.map(|g| g.0.to_bits()), want.map(|w| w.0.to_bits()), "n {n} ray {i}");
                let mut counts = vec![0u32; n];
                set.crossings(&ray, |k, c| {
                    counts[k as usize] = c;
                    false
                });
                for (k, s) in spheres.iter().enumerate() {
                    assert_eq!(counts[k], sphere_crossings(&ray, s.0, s.1), "n {n} ray {i} sphere {k}");
                }
            }
        }
    }

    #[test]
    fn empty_set_and_degenerate_rays_do_not_hit() {
        let set = SphereSet::new(&[]);
        assert!(set.closest(&Ray::new(Vec3::ZERO, Vec3::X)).is_none());
        let set = SphereSet::new(&[(Vec3::ZERO, 1.0)]);
        assert!(set.closest(&Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO)).is_none());
        assert!(set.closest(&Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(f32::NAN, 0.0, -1.0))).is_none());
        assert_eq!(set.closest(&Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z)).map(|h| h.1), Some(0));
    }
}
