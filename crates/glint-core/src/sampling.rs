//! Sampling warps: uniform [0,1)² → distributions on discs, hemispheres and pixels.

use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Concentric mapping of the unit square to the unit disc (Shirley and Chiu 1997).
pub fn sample_disc_concentric(u: Vec2) -> Vec2 {
    let o = u * 2.0 - Vec2::ONE;
    if o == Vec2::ZERO {
        return Vec2::ZERO;
    }
    let (r, theta) =
        if o.x.abs() > o.y.abs() { (o.x, FRAC_PI_4 * (o.y / o.x)) } else { (o.y, FRAC_PI_2 - FRAC_PI_4 * (o.x / o.y)) };
    Vec2::new(theta.cos(), theta.sin()) * r
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
