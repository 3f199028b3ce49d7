//! Sampling warps: uniform [0,1)² → distributions on discs, hemispheres and pixels.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_4, PI};

/// Concentric mapping of the unit square to the unit disc (Shirley and Chiu 1997): the square
/// `o = 2u − 1` ring by ring onto the disc, the ring of radius `r` = the larger of `|o.x|`,
/// `|o.y|`, its angle `π/4 · (the smaller over the larger)` from the nearer axis.
///
/// The angle's cosine and sine come from [`sin_cos_quarter`] (an angle within π/4 of an axis:
/// the sine and cosine of the offset, swapped for the y axis), whose operations a batched
/// caller can repeat in lanes for the same bits (`path/wavefront/phong8.rs`).
#[inline]
pub fn sample_disc_concentric(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    if o.x.abs() > o.y.abs() {
        let (s, c) = sin_cos_quarter(FRAC_PI_4 * (o.y / o.x));
        Vec2::new(c, s) * o.x
    } else {
        // At π/2 − a from the x axis: cosine and sine of a swapped.
        let (s, c) = sin_cos_quarter(FRAC_PI_4 * (o.x / o.y));
        Vec2::new(s, c) * o.y
    }
}

/// Taylor coefficients of `sin x / x` in `x²` beyond 1: −1/3!, 1/5!, −1/7!, 1/9! (the next
/// term is under 2e-9 for |x| ≤ π/4).
pub const SIN_QUARTER: [f32; 4] = [-1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362_880.0];
/// Taylor coefficients of `cos x` in `x²` beyond 1: −1/2!, 1/4!, …, −1/10! (the next term is
/// under 2e-10 for |x| ≤ π/4).
pub const COS_QUARTER: [f32; 5] = [-0.5, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40_320.0, -1.0 / 3_628_800.0];

/// `(sin x, cos x)` for |x| ≤ π/4, within 2 ulp of the true values: Horner's scheme on the
/// Taylor polynomials (no fused multiply-add, so eight lanes doing these operations in this
/// order give these bits). libm's `sincosf` was 3 % of a Cornell box frame behind the
/// wavefront's batched bounces, called lane by lane.
#[inline]
#[must_use]
pub fn sin_cos_quarter(x: f32) -> (f32, f32) {
    let z = x * x;
    let [s1, s2, s3, s4] = SIN_QUARTER;
    let [c1, c2, c3, c4, c5] = COS_QUARTER;
    let sin = x + x * z * (s1 + z * (s2 + z * (s3 + z * s4)));
    let cos = 1.0 + z * (c1 + z * (c2 + z * (c3 + z * (c4 + z * c5))));
    (sin, cos)
}

/// Cosine-weighted direction on the +Z hemisphere; pdf (solid angle) = cos θ / π.
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_disc_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) / PI
}

/// Uniform direction on the unit sphere; pdf = 1 / 4π.
pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Stratified (jittered) position of sub-sample `index` of an `n × n` grid in the unit square.
pub fn stratified_2d(index: u32, n: u32, jitter: Vec2) -> Vec2 {
    let n = n.max(1);
    let (i, j) = (index % n, (index / n) % n);
    Vec2::new((i as f32 + jitter.x) / n as f32, (j as f32 + jitter.y) / n as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::SampleStream;

    #[test]
    fn cosine_hemisphere_is_unit_and_upward() {
        let mut s = SampleStream::new(0, 0, 1);
        let mut mean_z = 0.0;
        let n = 20_000;
        for _ in 0..n {
            let d = sample_cosine_hemisphere(s.next_2d());
            assert!((d.length() - 1.0).abs() < 1e-4);
            assert!(d.z >= 0.0);
            mean_z += d.z / n as f32;
        }
        // E[cos θ] under the cosine pdf is 2/3.
        assert!((mean_z - 2.0 / 3.0).abs() < 0.01, "{mean_z}");
    }

    #[test]
    fn quarter_sine_and_cosine_are_within_two_ulp() {
        for i in 0..=20_000 {
            let x = (i as f32 / 10_000.0 - 1.0) * FRAC_PI_4;
            let (s, c) = sin_cos_quarter(x);
            let (ws, wc) = (f64::from(x).sin(), f64::from(x).cos());
            // Two ulp of the value, or of 2⁻²⁴ near a zero sine.
            let ulp = |v: f64| 2.0 * (v.abs().max(1.0 / 64.0) * f64::from(f32::EPSILON));
            assert!((f64::from(s) - ws).abs() <= ulp(ws), "sin {x}: {s} vs {ws}");
            assert!((f64::from(c) - wc).abs() <= ulp(wc), "cos {x}: {c} vs {wc}");
        }
    }

    #[test]
    fn concentric_disc_points_keep_their_ring_and_angle() {
        let mut s = SampleStream::new(3, 0, 5);
        for _ in 0..20_000 {
            let u = s.next_2d();
            let d = sample_disc_concentric(u);
            let o = u * 2.0 - Vec2::ONE;
            let r = o.x.abs().max(o.y.abs());
            assert!((d.length() - r).abs() <= 2e-7, "{u}: radius {} vs {r}", d.length());
            // The angle of Shirley and Chiu's mapping, computed with libm.
            let theta = if o.x.abs() > o.y.abs() {
                FRAC_PI_4 * (o.y / o.x) + if o.x < 0.0 { PI } else { 0.0 }
            } else {
                std::f32::consts::FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y) + if o.y < 0.0 { PI } else { 0.0 }
            };
            let want = Vec2::new(theta.cos(), theta.sin()) * r;
            assert!((d - want).length() <= 1e-6, "{u}: {d} vs {want}");
        }
        assert_eq!(sample_disc_concentric(Vec2::splat(0.5)), Vec2::ZERO);
    }

    /// The χ² tests below, for the suite's significance level.
    const CHI2_TESTS: usize = 2;

    #[test]
    fn cosine_hemisphere_matches_its_pdf_chi2() {
        let n = 200_000;
        let s: Vec<Vec3> = (0..n).map(|i| sample_cosine_hemisphere(SampleStream::new(i, 1, 11).next_2d())).collect();
        let out = crate::chi2::chi2_sphere(&s, n as usize, |d| cosine_hemisphere_pdf(d.z) as f64, 16, 32);
        assert!(out.passes(CHI2_TESTS), "{out}");
    }

    #[test]
    fn uniform_sphere_matches_its_pdf_chi2() {
        let n = 200_000;
        let s: Vec<Vec3> = (0..n).map(|i| sample_uniform_sphere(SampleStream::new(i, 2, 11).next_2d())).collect();
        let out = crate::chi2::chi2_sphere(&s, n as usize, |_| 1.0 / (4.0 * std::f64::consts::PI), 16, 32);
        assert!(out.passes(CHI2_TESTS), "{out}");
    }

    #[test]
    fn stratified_stays_in_its_cell() {
        for idx in 0..9 {
            let p = stratified_2d(idx, 3, Vec2::splat(0.999));
            let (i, j) = (idx % 3, idx / 3);
            assert!(p.x >= i as f32 / 3.0 && p.x < (i + 1) as f32 / 3.0);
            assert!(p.y >= j as f32 / 3.0 && p.y < (j + 1) as f32 / 3.0);
        }
    }
}
