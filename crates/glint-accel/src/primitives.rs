//! Ray–primitive tests: triangle, sphere, plane. Usable on their own (the Whitted renderer
//! intersects analytic spheres and planes directly) and as the leaf test of every BVH layout.
//!
//! - Triangle: the watertight test of Woop, Benthin and Wald, "Watertight Ray/Triangle
//!   Intersection", JCGT 2(1), 2013. The ray is sheared so that it runs along +z through the
//!   origin; the 2-D edge functions of the projected vertices then decide inside/outside, and a
//!   vertex shared by two triangles is projected bit-for-bit identically in both, so a ray can
//!   never slip between triangles that share an edge. Edge functions that come out exactly zero are
//!   recomputed in f64 (section 3 of the paper). No fused multiply-add anywhere in this test: a
//!   fused `a*b - c*d` is not antisymmetric and would break watertightness.
//! - Sphere: the quadratic `a t² + b t + c = 0`, `a = D·D`, `b = 2 D·(P−C)`, `c = |P−C|² − r²`,
//!   with the discriminant taken from the vector between the centre and the ray's closest approach
//!   (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray Tracing Gems ch. 7,
//!   eq. 10) and the roots from the cancellation-free form `q = −(b' + sign(b') √Δ)`,
//!   `t0 = c / q`, `t1 = q / a` (ibid. eq. 11–13).
//! - Plane: `p·n + offset = 0`, `t = −(P·n + offset) / (D·n)`, no hit when `D·n = 0`.
//!
//! Every test reports a hit only for `t` in `(ray.tmin, ray.tmax]` and is NaN-safe: a NaN
//! anywhere makes the comparisons fail and the test report a miss.

use glint_core::{Ray, Vec3};

/// A ray–triangle hit: the parameter `t` and the barycentrics of the hit point
/// `(1 − u − v)·p0 + u·p1 + v·p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriangleHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// Per-ray constants of the watertight test (Woop et al. 2013, section 3, steps 1–2): the axis
/// permutation that makes `kz` the dominant direction axis, and the shear that maps the ray
/// direction to +z.
#[derive(Clone, Copy, Debug)]
pub(crate) struct WoopRay {
    pub kx: usize,
    pub ky: usize,
    pub kz: usize,
    pub sx: f32,
    pub sy: f32,
    pub sz: f32,
    pub org: [f32; 3],
}

/// The axis along which `dir` is largest in magnitude (ties to the lower axis): the watertight
/// triangle test's `kz`, which with the sign of that component fixes its permutation of the
/// axes. Rays that share it and their direction octant can be tested against a triangle in
/// lanes ([`crate::MeshBvh::packs_any_rays`]).
#[inline]
#[must_use]
pub fn dominant_axis(dir: Vec3) -> usize {
    let a = dir.abs();
    if a.x >= a.y && a.x >= a.z {
        0
    } else if a.y >= a.z {
        1
    } else {
        2
    }
}

impl WoopRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir.to_array();
        let kz = dominant_axis(ray.dir);
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding of the projected triangle (the paper's step 1); both faces are
        // accepted below, but a fixed convention keeps U, V, W signs meaningful.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Self { kx, ky, kz, sx: d[kx] / d[kz], sy: d[ky] / d[kz], sz: 1.0 / d[kz], org: ray.origin.to_array() }
    }
}

/// The watertight test against one triangle given as coordinate arrays. The SIMD leaf kernels
/// compute exactly the same operations in the same order lane by lane and hand lanes with a zero
/// edge function to this function, so scalar and SIMD results are bit-identical.
#[inline]
pub(crate) fn woop(r: &WoopRay, p0: [f32; 3], p1: [f32; 3], p2: [f32; 3], tmin: f32, tmax: f32) -> Option<TriangleHit> {
    let (kx, ky, kz) = (r.kx, r.ky, r.kz);
    // Vertices relative to the origin (step 3).
    let ax = p0[kx] - r.org[kx];
    let ay = p0[ky] - r.org[ky];
    let az = p0[kz] - r.org[kz];
    let bx = p1[kx] - r.org[kx];
    let by = p1[ky] - r.org[ky];
    let bz = p1[kz] - r.org[kz];
    let cx = p2[kx] - r.org[kx];
    let cy = p2[ky] - r.org[ky];
    let cz = p2[kz] - r.org[kz];
    // Shear (step 4): separate multiply and subtract, never fused.
    let ax = ax - r.sx * az;
    let ay = ay - r.sy * az;
    let bx = bx - r.sx * bz;
    let by = by - r.sy * bz;
    let cx = cx - r.sx * cz;
    let cy = cy - r.sy * cz;
    // Scaled barycentrics: 2-D edge functions (step 5).
    let mut u = cx * by - cy * bx;
    let mut v = ax * cy - ay * cx;
    let mut w = bx * ay - by * ax;
    if u == 0.0 || v == 0.0 || w == 0.0 {
        // Exact products in f64, one rounding for the difference: the sign is exact.
        let f = |a: f32, b: f32, c: f32, d: f32| (a as f64 * b as f64 - c as f64 * d as f64) as f32;
        u = f(cx, by, cy, bx);
        v = f(ax, cy, ay, cx);
        w = f(bx, ay, by, ax);
    }
    woop_finish(r, u, v, w, az, bz, cz, tmin, tmax)
}

/// Steps 6–8 of the watertight test: edge signs, determinant, distance.
#[inline]
#[allow(clippy::too_many_arguments)]
pub(crate) fn woop_finish(
    r: &WoopRay,
    u: f32,
    v: f32,
    w: f32,
    az: f32,
    bz: f32,
    cz: f32,
    tmin: f32,
    tmax: f32,
) -> Option<TriangleHit> {
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let az = r.sz * az;
    let bz = r.sz * bz;
    let cz = r.sz * cz;
    let t = u * az + v * bz + w * cz;
    let t = t / det;
    if t > tmin && t <= tmax { Some(TriangleHit { t, u: v / det, v: w / det }) } else { None }
}

/// Watertight ray/triangle intersection (Woop, Benthin, Wald 2013), both faces, hit only for
/// `t` in `(ray.tmin, ray.tmax]`.
pub fn intersect_triangle(ray: &Ray, p0: Vec3, p1: Vec3, p2: Vec3) -> Option<TriangleHit> {
    woop(&WoopRay::new(ray), p0.to_array(), p1.to_array(), p2.to_array(), ray.tmin, ray.tmax)
}

/// Nearest intersection of the ray with the sphere in `(ray.tmin, ray.tmax]`. A ray that starts
/// inside the sphere gets the far root.
pub fn intersect_sphere(ray: &Ray, centre: Vec3, radius: f32) -> Option<f32> {
    let (t0, t1) = sphere_roots(ray, centre, radius)?;
    if t0 > ray.tmin && t0 <= ray.tmax {
        Some(t0)
    } else if t1 > ray.tmin && t1 <= ray.tmax {
        Some(t1)
    } else {
        None
    }
}

/// How many times the ray's interval `(tmin, tmax]` crosses the sphere's surface (0, 1 or 2):
/// what a shadow ray through a transparent sphere is attenuated by.
#[inline]
pub fn sphere_crossings(ray: &Ray, centre: Vec3, radius: f32) -> u32 {
    match sphere_roots(ray, centre, radius) {
        None => 0,
        Some((t0, t1)) => {
            let inside = |t: f32| t > ray.tmin && t <= ray.tmax;
            inside(t0) as u32 + inside(t1) as u32
        }
    }
}

/// Both roots of the ray–sphere quadratic, ordered, whatever the interval; `None` when the
/// line misses the sphere.
#[inline]
fn sphere_roots(ray: &Ray, centre: Vec3, radius: f32) -> Option<(f32, f32)> {
    let d = ray.dir;
    let f = ray.origin - centre;
    let a = d.dot(d);
    if a == 0.0 || !a.is_finite() {
        return None;
    }
    // Half of b: b' = f·D.
    let b = f.dot(d);
    let c = f.dot(f) - radius * radius;
    // Δ/4 = b'² − a c = a (r² − |l|²), l = f − (b'/a) D the centre → closest-approach vector.
    let l = f - d * (b / a);
    let disc = a * (radius * radius - l.dot(l));
    if disc.is_nan() || disc < 0.0 {
        return None;
    }
    let q = -(b + disc.sqrt().copysign(b));
    let (t0, t1) = if q == 0.0 { (0.0, 0.0) } else { (c / q, q / a) };
    Some(if t0 <= t1 { (t0, t1) } else { (t1, t0) })
}

/// Intersection with the plane `p·normal + offset = 0` in `(ray.tmin, ray.tmax]`; no hit when the
/// ray runs parallel to the plane (`D·N = 0`).
pub fn intersect_plane(ray: &Ray, normal: Vec3, offset: f32) -> Option<f32> {
    let denom = ray.dir.dot(normal);
    if denom == 0.0 {
        return None;
    }
    let t = -(ray.origin.dot(normal) + offset) / denom;
    (t > ray.tmin && t <= ray.tmax).then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_crossings_count_surfaces_in_the_interval() {
        let c = Vec3::ZERO;
        let through = Ray::segment(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 0.0, 10.0);
        assert_eq!(sphere_crossings(&through, c, 1.0), 2);
        let into = Ray::segment(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 0.0, 5.0);
        assert_eq!(sphere_crossings(&into, c, 1.0), 1);
        let short = Ray::segment(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z, 0.0, 3.0);
        assert_eq!(sphere_crossings(&short, c, 1.0), 0);
        let miss = Ray::segment(Vec3::new(0.0, 2.0, 5.0), -Vec3::Z, 0.0, 10.0);
        assert_eq!(sphere_crossings(&miss, c, 1.0), 0);
    }

    fn tri() -> (Vec3, Vec3, Vec3) {
        (Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0))
    }

    #[test]
    fn triangle_hit_reports_t_and_barycentrics() {
        let (a, b, c) = tri();
        let ray = Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let h = intersect_triangle(&ray, a, b, c).expect("hit");
        assert!((h.t - 2.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6);
        assert!((h.v - 0.5).abs() < 1e-6);
        let p = a * (1.0 - h.u - h.v) + b * h.u + c * h.v;
        assert!((p - ray.at(h.t)).length() < 1e-6);
        // Back face too.
        let back = Ray::new(Vec3::new(0.25, 0.5, -2.0), Vec3::new(0.0, 0.0, 1.0));
        assert!(intersect_triangle(&back, a, b, c).is_some());
    }

    #[test]
    fn triangle_miss_and_interval() {
        let (a, b, c) = tri();
        let miss = Ray::new(Vec3::new(0.75, 0.75, 2.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(intersect_triangle(&miss, a, b, c).is_none());
        let behind = Ray::new(Vec3::new(0.25, 0.25, -2.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(intersect_triangle(&behind, a, b, c).is_none());
        let short = Ray::segment(Vec3::new(0.25, 0.25, 2.0), Vec3::new(0.0, 0.0, -1.0), 0.0, 1.5);
        assert!(intersect_triangle(&short, a, b, c).is_none());
        // (tmin, tmax]: t == tmax hits, t == tmin does not.
        let exact = Ray::segment(Vec3::new(0.25, 0.25, 2.0), Vec3::new(0.0, 0.0, -1.0), 0.0, 2.0);
        assert!(intersect_triangle(&exact, a, b, c).is_some());
        let at_min = Ray::segment(Vec3::new(0.25, 0.25, 2.0), Vec3::new(0.0, 0.0, -1.0), 2.0, 5.0);
        assert!(intersect_triangle(&at_min, a, b, c).is_none());
        // Parallel to the plane of the triangle.
        let parallel = Ray::new(Vec3::new(-1.0, 0.25, 0.0), Vec3::X);
        assert!(intersect_triangle(&parallel, a, b, c).is_none());
    }

    #[test]
    fn shared_edge_is_hit_by_exactly_one_side_or_both() {
        // Two triangles sharing the edge (1,0,0)-(0,1,0); a ray straight at the edge midpoint.
        let (a, b, c) = tri();
        let d = Vec3::new(1.0, 1.0, 0.0);
        let ray = Ray::new(Vec3::new(0.5, 0.5, 1.0), Vec3::new(0.0, 0.0, -1.0));
        let h1 = intersect_triangle(&ray, a, b, c);
        let h2 = intersect_triangle(&ray, b, d, c);
        assert!(h1.is_some() || h2.is_some());
        // A vertex shared by both.
        let ray = Ray::new(Vec3::new(1.0, 0.0, 1.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(intersect_triangle(&ray, a, b, c).is_some() || intersect_triangle(&ray, b, d, c).is_some());
    }

    #[test]
    fn degenerate_and_nan_inputs_miss() {
        let p = Vec3::ONE;
        let ray = Ray::new(Vec3::new(1.0, 1.0, 3.0), -Vec3::Z);
        assert!(intersect_triangle(&ray, p, p, p).is_none());
        let (a, b, c) = tri();
        let nan = Ray::new(Vec3::splat(f32::NAN), -Vec3::Z);
        assert!(intersect_triangle(&nan, a, b, c).is_none());
        let zero = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::ZERO);
        assert!(intersect_triangle(&zero, a, b, c).is_none());
        assert!(intersect_sphere(&zero, Vec3::ZERO, 1.0).is_none());
        assert!(intersect_sphere(&nan, Vec3::ZERO, 1.0).is_none());
        assert!(intersect_plane(&nan, Vec3::Y, 0.0).is_none());
    }

    #[test]
    fn sphere_hit_miss_inside_and_interval() {
        let c = Vec3::new(0.0, 0.0, -5.0);
        let ray = Ray::new(Vec3::ZERO, -Vec3::Z);
        assert_eq!(intersect_sphere(&ray, c, 1.0), Some(4.0));
        // Unnormalised direction: t scales.
        let ray2 = Ray::new(Vec3::ZERO, -Vec3::Z * 2.0);
        assert_eq!(intersect_sphere(&ray2, c, 1.0), Some(2.0));
        // Miss.
        let miss = Ray::new(Vec3::new(2.0, 0.0, 0.0), -Vec3::Z);
        assert!(intersect_sphere(&miss, c, 1.0).is_none());
        // Inside: far root.
        let inside = Ray::new(c, Vec3::X);
        assert_eq!(intersect_sphere(&inside, c, 1.0), Some(1.0));
        // Behind.
        let behind = Ray::new(Vec3::ZERO, Vec3::Z);
        assert!(intersect_sphere(&behind, c, 1.0).is_none());
        // tmax before the sphere; tmin past the near root gives the far root.
        assert!(intersect_sphere(&Ray::segment(Vec3::ZERO, -Vec3::Z, 0.0, 3.9), c, 1.0).is_none());
        assert_eq!(intersect_sphere(&Ray::segment(Vec3::ZERO, -Vec3::Z, 4.5, 10.0), c, 1.0), Some(6.0));
        // Tangent-ish: grazing just inside and just outside the silhouette.
        let graze_in = Ray::new(Vec3::new(0.999_99, 0.0, 0.0), -Vec3::Z);
        let t = intersect_sphere(&graze_in, c, 1.0).expect("grazing ray inside the silhouette");
        assert!((t - 5.0).abs() < 0.01);
        let graze_out = Ray::new(Vec3::new(1.000_01, 0.0, 0.0), -Vec3::Z);
        assert!(intersect_sphere(&graze_out, c, 1.0).is_none());
    }

    #[test]
    fn sphere_far_away_is_precise() {
        // Ray Tracing Gems ch. 7: a small sphere far away; the naive discriminant loses it.
        let c = Vec3::new(0.0, 0.0, -1.0e4);
        let ray = Ray::new(Vec3::new(0.0, 0.009, 0.0), -Vec3::Z);
        let t = intersect_sphere(&ray, c, 0.01).expect("hit");
        let expected = 1.0e4 - (0.01f32 * 0.01 - 0.009 * 0.009).sqrt();
        assert!((t - expected).abs() < 1e-2, "{t} vs {expected}");
    }

    #[test]
    fn plane_hit_parallel_and_interval() {
        let ray = Ray::new(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -1.0, 0.0));
        assert_eq!(intersect_plane(&ray, Vec3::Y, 0.0), Some(2.0));
        // p·n + offset = 0 with offset 1: the plane y = -1.
        assert_eq!(intersect_plane(&ray, Vec3::Y, 1.0), Some(3.0));
        let parallel = Ray::new(Vec3::new(0.0, 2.0, 0.0), Vec3::X);
        assert!(intersect_plane(&parallel, Vec3::Y, 0.0).is_none());
        let away = Ray::new(Vec3::new(0.0, 2.0, 0.0), Vec3::Y);
        assert!(intersect_plane(&away, Vec3::Y, 0.0).is_none());
        assert!(intersect_plane(&Ray::segment(ray.origin, ray.dir, 0.0, 1.0), Vec3::Y, 0.0).is_none());
    }
}
