//! Microfacet normal distributions as Mitsuba 3's `MicrofacetDistribution`
//! (include/mitsuba/render/microfacet.h): Beckmann and GGX (Trowbridge–Reitz) with anisotropic
//! roughness `alpha_u` (along the tangent, x) and `alpha_v` (along the bitangent, y), Smith's
//! separable masking–shadowing (Beckmann by Walter et al. 2007's rational fit, as Mitsuba),
//! sampling of all normals (`D cos θm`) or of the normals visible from a direction (Heitz and
//! d'Eon 2014; GGX by Heitz 2018's hemisphere projection, Beckmann by Mitsuba's numerical
//! inversion of the slope CDF), and the precomputed quadratures `roughplastic` needs.
//!
//! Directions are local (z = macro normal) and point away from the surface.

use glint_core::{Vec2, Vec3};
use glint_scene::bsdf::Distribution;
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// 1/√π.
const INV_SQRT_PI: f32 = 0.564_189_6;

/// A microfacet distribution with its roughness (α, not perceptual roughness).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Microfacet {
    pub distribution: Distribution,
    pub alpha_u: f32,
    pub alpha_v: f32,
    /// Sample the normals visible from the outgoing direction (Mitsuba's default) rather than
    /// all normals.
    pub sample_visible: bool,
}

impl Microfacet {
    #[must_use]
    pub fn new(distribution: Distribution, alpha_u: f32, alpha_v: f32, sample_visible: bool) -> Self {
        Microfacet { distribution, alpha_u, alpha_v, sample_visible }
    }

    /// Roughness as Mitsuba uses it: clamped to at least 10⁻⁴.
    #[inline]
    fn alphas(&self) -> (f32, f32) {
        (self.alpha_u.max(1e-4), self.alpha_v.max(1e-4))
    }

    /// The same distribution with both roughness values scaled.
    pub(super) fn scaled(&self, s: f32) -> Self {
        let (au, av) = self.alphas();
        Microfacet { alpha_u: au * s, alpha_v: av * s, ..*self }
    }

    /// The normal distribution `D(m)` (per unit projected area: ∫ D cos θm dω = 1).
    #[must_use]
    pub fn d(&self, m: Vec3) -> f32 {
        let (au, av) = self.alphas();
        let cos = m.z;
        let cos_2 = cos * cos;
        let result = match self.distribution {
            Distribution::Beckmann => {
                (-((m.x / au).powi(2) + (m.y / av).powi(2)) / cos_2).exp() / (PI * au * av * cos_2 * cos_2)
            }
            Distribution::Ggx => 1.0 / (PI * au * av * ((m.x / au).powi(2) + (m.y / av).powi(2) + m.z * m.z).powi(2)),
        };
        // Mitsuba drops tiny values to keep later divisions finite.
        if result * cos > 1e-20 { result } else { 0.0 }
    }

    /// Smith's masking term of one direction `v` for the microfacet `m` (0 when `v` sees the
    /// back of the microfacet or of the macro surface).
    #[must_use]
    pub fn smith_g1(&self, v: Vec3, m: Vec3) -> f32 {
        let (au, av) = self.alphas();
        let xy_alpha_2 = (au * v.x).powi(2) + (av * v.y).powi(2);
        let tan_theta_alpha_2 = xy_alpha_2 / (v.z * v.z);
        let mut result = match self.distribution {
            Distribution::Beckmann => {
                let a = 1.0 / tan_theta_alpha_2.sqrt();
                let a_sqr = a * a;
                if a >= 1.6 { 1.0 } else { (3.535 * a + 2.181 * a_sqr) / (1.0 + 2.276 * a + 2.577 * a_sqr) }
            }
            Distribution::Ggx => 2.0 / (1.0 + (1.0 + tan_theta_alpha_2).sqrt()),
        };
        if xy_alpha_2 == 0.0 {
            result = 1.0;
        }
        if v.dot(m) * v.z <= 0.0 {
            result = 0.0;
        }
        result
    }

    /// Separable masking–shadowing `G1(wi) G1(wo)`.
    #[must_use]
    pub fn g(&self, wi: Vec3, wo: Vec3, m: Vec3) -> f32 {
        self.smith_g1(wi, m) * self.smith_g1(wo, m)
    }

    /// Density (solid angle of normals) with which [`Microfacet::sample`] returns `m` seen
    /// from `wi` (`wi.z > 0`).
    #[must_use]
    pub fn pdf(&self, wi: Vec3, m: Vec3) -> f32 {
        let d = self.d(m);
        if self.sample_visible { d * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z } else { d * m.z }
    }

    /// Sample a microfacet normal seen from `wi` (`wi.z > 0`): the normal and its density.
    #[must_use]
    pub fn sample(&self, wi: Vec3, u: Vec2) -> (Vec3, f32) {
        let (au, av) = self.alphas();
        if !self.sample_visible {
            let (sin_phi, cos_phi, alpha_2) = if au == av {
                let (s, c) = (TAU * u.y).sin_cos();
                (s, c, au * au)
            } else {
                let ratio = av / au;
                let tmp = ratio * (TAU * u.y).tan();
                let mut cos_phi = 1.0 / (tmp * tmp + 1.0).sqrt();
                cos_phi = cos_phi.copysign((u.y - 0.5).abs() - 0.25);
                let sin_phi = cos_phi * tmp;
                (sin_phi, cos_phi, 1.0 / ((cos_phi / au).powi(2) + (sin_phi / av).powi(2)))
            };
            let (cos_theta, pdf) = match self.distribution {
                Distribution::Beckmann => {
                    let cos_theta = 1.0 / (1.0 - alpha_2 * (1.0 - u.x).ln()).sqrt();
                    let cos_3 = (cos_theta * cos_theta * cos_theta).max(1e-20);
                    (cos_theta, (1.0 - u.x) / (PI * au * av * cos_3))
                }
                Distribution::Ggx => {
                    let tan_2 = alpha_2 * u.x / (1.0 - u.x);
                    let cos_theta = 1.0 / (1.0 + tan_2).sqrt();
                    let temp = 1.0 + tan_2 / alpha_2;
                    let cos_3 = (cos_theta * cos_theta * cos_theta).max(1e-20);
                    (cos_theta, 1.0 / (PI * au * av * cos_3 * temp * temp))
                }
            };
            let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
            return (Vec3::new(cos_phi * sin_theta, sin_phi * sin_theta, cos_theta), pdf);
        }
        // Visible normals: stretch, sample the α = 1 slopes, rotate and unstretch.
        let wi_p = Vec3::new(au * wi.x, av * wi.y, wi.z).normalize();
        let (sin_phi, cos_phi) = sincos_phi(wi_p);
        let slope = self.sample_visible_11(wi_p.z, u);
        let slope =
            Vec2::new((cos_phi * slope.x - sin_phi * slope.y) * au, (sin_phi * slope.x + cos_phi * slope.y) * av);
        let m = Vec3::new(-slope.x, -slope.y, 1.0).normalize();
        let pdf = self.d(m) * self.smith_g1(wi, m) * wi.dot(m).abs() / wi.z;
        (m, pdf)
    }

    /// Slopes of the visible normals of the α = 1 distribution seen at `cos_theta_i`.
    fn sample_visible_11(&self, cos_theta_i: f32, u: Vec2) -> Vec2 {
        match self.distribution {
            Distribution::Beckmann => {
                // Mitsuba's numerical inversion of the slope CDF (three Newton steps in the
                // erf domain from the analytic solution at grazing incidence).
                let tan_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt() / cos_theta_i;
                let cot_theta_i = 1.0 / tan_theta_i;
                let maxval = erf(cot_theta_i);
                let u = u.clamp(Vec2::splat(1e-6), Vec2::splat(1.0 - 1e-6));
                let mut x = maxval - (maxval + 1.0) * erf((-u.x.ln()).sqrt());
                let sx = u.x * (1.0 + maxval + INV_SQRT_PI * tan_theta_i * (-cot_theta_i * cot_theta_i).exp());
                for _ in 0..3 {
                    let slope = erfinv(x);
                    let value = 1.0 + x + INV_SQRT_PI * tan_theta_i * (-slope * slope).exp() - sx;
                    let derivative = 1.0 - slope * tan_theta_i;
                    x -= value / derivative;
                }
                Vec2::new(erfinv(x), erfinv(2.0 * u.y - 1.0))
            }
            Distribution::Ggx => {
                // Heitz 2018: a point on the disc, squeezed toward the visible half.
                let mut p = disc_concentric(u);
                let s = 0.5 * (1.0 + cos_theta_i);
                let h = (1.0 - p.x * p.x).max(0.0).sqrt();
                p.y = h + (p.y - h) * s;
                let (x, y) = (p.x, p.y);
                let z = (1.0 - p.length_squared()).max(0.0).sqrt();
                let sin_theta_i = (1.0 - cos_theta_i * cos_theta_i).max(0.0).sqrt();
                let norm = 1.0 / (sin_theta_i * y + cos_theta_i * z);
                Vec2::new(cos_theta_i * y - sin_theta_i * z, x) * norm
            }
        }
    }
}

/// Mitsuba's `Frame3f::sincos_phi`: (sin φ, cos φ) of a direction, (0, 1) at the pole.
pub(super) fn sincos_phi(v: Vec3) -> (f32, f32) {
    let sin_theta_2 = v.x * v.x + v.y * v.y;
    if sin_theta_2.abs() <= 4.0 * f32::EPSILON {
        return (0.0, 1.0);
    }
    let inv = 1.0 / sin_theta_2.sqrt();
    ((v.y * inv).clamp(-1.0, 1.0), (v.x * inv).clamp(-1.0, 1.0))
}

/// Mitsuba's `square_to_uniform_disk_concentric` (Shirley–Chiu with Cline's branch-free
/// quadrants).
pub(super) fn disc_concentric(u: Vec2) -> Vec2 {
    let (x, y) = (2.0 * u.x - 1.0, 2.0 * u.y - 1.0);
    if x == 0.0 && y == 0.0 {
        return Vec2::ZERO;
    }
    let q13 = x.abs() < y.abs();
    let (r, rp) = if q13 { (y, x) } else { (x, y) };
    let mut phi = 0.25 * PI * rp / r;
    if q13 {
        phi = 0.5 * PI - phi;
    }
    let (s, c) = phi.sin_cos();
    Vec2::new(r * c, r * s)
}

/// Mitsuba's `square_to_cosine_hemisphere`.
pub(super) fn cosine_hemisphere(u: Vec2) -> Vec3 {
    let p = disc_concentric(u);
    Vec3::new(p.x, p.y, (1.0 - p.length_squared()).max(0.0).sqrt())
}

/// Its density (solid angle): cos θ / π (not clamped, as Mitsuba).
#[inline]
pub(super) fn cosine_hemisphere_pdf(v: Vec3) -> f32 {
    FRAC_1_PI * v.z
}

/// The error function (Abramowitz and Stegun 7.1.26 refined: |error| < 2·10⁻⁷ in f64).
pub(super) fn erf(x: f32) -> f32 {
    let xd = f64::from(x);
    let t = 1.0 / (1.0 + 0.5 * xd.abs());
    // Numerical Recipes' erfc Chebyshev fit (fractional error < 1.2·10⁻⁷).
    let poly = -xd * xd - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98 + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let erfc = t * poly.exp();
    (if xd >= 0.0 { 1.0 - erfc } else { erfc - 1.0 }) as f32
}

/// The inverse error function (Giles 2010, single precision).
pub(super) fn erfinv(x: f32) -> f32 {
    let mut w = -((1.0 - x) * (1.0 + x)).ln();
    let p = if w < 5.0 {
        w -= 2.5;
        let c = [
            2.810_226_4e-8,
            3.432_739_4e-7,
            -3.523_387_7e-6,
            -4.391_506_5e-6,
            2.185_808_7e-4,
            -1.253_725e-3,
            -4.177_681_6e-3,
            2.466_407_3e-1,
            1.501_409_4,
        ];
        c[1..].iter().fold(c[0], |p, &ci| ci + p * w)
    } else {
        w = w.sqrt() - 3.0;
        let c = [
            -2.002_142_6e-4,
            1.009_505_6e-4,
            1.349_343_2e-3,
            -3.673_428_4e-3,
            5.739_507_7e-3,
            -7.622_461_3e-3,
            9.438_870_5e-3,
            1.001_674,
            2.832_976_8,
        ];
        c[1..].iter().fold(c[0], |p, &ci| ci + p * w)
    };
    p * x
}

/// Nodes and weights of the `n`-point Gauss–Legendre rule on [−1, 1] (Newton on the Legendre
/// polynomial from Chebyshev guesses, as Mitsuba's `quad::gauss_legendre`).
pub(super) fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    let mut nodes = vec![0.0; n];
    let mut weights = vec![0.0; n];
    // P_n and its derivative at x.
    let legendre = |x: f64| {
        let (mut p0, mut p1) = (1.0, x);
        for k in 2..=n {
            let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
            p0 = p1;
            p1 = p2;
        }
        let dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
        (p1, dp)
    };
    for i in 0..n.div_ceil(2) {
        let mut x = -(std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (p, dp) = legendre(x);
            let step = p / dp;
            x -= step;
            if step.abs() <= 4.0 * x.abs() * f64::EPSILON {
                break;
            }
        }
        let (_, dp) = legendre(x);
        let w = 2.0 / ((1.0 - x * x) * dp * dp);
        nodes[i] = x;
        nodes[n - 1 - i] = -x;
        weights[i] = w;
        weights[n - 1 - i] = w;
    }
    (nodes, weights)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::chi2::{chi2_sphere, integrate_sphere, significance_level};
    use glint_core::random::SampleStream;

    fn distributions() -> Vec<Microfacet> {
        let mut out = Vec::new();
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for (au, av) in [(0.05, 0.05), (0.3, 0.3), (0.8, 0.8), (0.1, 0.5)] {
                for sample_visible in [false, true] {
                    out.push(Microfacet::new(distribution, au, av, sample_visible));
                }
            }
        }
        out
    }

    /// Smith's G1 of the Beckmann distribution in closed form (Walter et al. 2007, eq. 27).
    fn smith_g1_beckmann_exact(m: &Microfacet, v: Vec3) -> f32 {
        let alpha = ((m.alpha_u * v.x).powi(2) + (m.alpha_v * v.y).powi(2)).sqrt() / (1.0 - v.z * v.z).sqrt();
        let tan = (1.0 - v.z * v.z).sqrt() / v.z;
        if tan == 0.0 {
            return 1.0;
        }
        let a = 1.0 / (alpha * tan);
        2.0 / (1.0 + erf(a) + (-a * a).exp() / (a * PI.sqrt()))
    }

    #[test]
    fn erf_and_erfinv_are_inverse() {
        for x in [-0.99, -0.5, -0.1, 0.0, 0.3, 0.9, 0.999] {
            let y = erfinv(x);
            assert!((erf(y) - x).abs() < 2e-6, "{x}: erf(erfinv) = {}", erf(y));
        }
        assert!((erf(1.0) - 0.842_700_8).abs() < 1e-6);
    }

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        for n in [1, 2, 5, 32] {
            let (x, w) = gauss_legendre(n);
            let deg = 2 * n - 1;
            let sum: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(deg as i32 - 1)).sum();
            // ∫ x^(2n−2) on [−1,1] = 2/(2n−1).
            assert!((sum - 2.0 / deg as f64).abs() < 1e-12, "{n}: {sum}");
        }
    }

    #[test]
    fn projected_normals_integrate_to_one() {
        for m in distributions().into_iter().filter(|m| m.alpha_u >= 0.1) {
            let i = integrate_sphere(|v| if v.z > 0.0 { f64::from(m.d(v) * v.z) } else { 0.0 }, 1000, 200);
            assert!((i - 1.0).abs() < 0.01, "{m:?}: {i}");
        }
    }

    #[test]
    fn normal_sampling_matches_its_pdf() {
        let ms = distributions();
        let wis =
            [Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.6, -0.3, 0.5).normalize(), Vec3::new(-0.9, 0.2, 0.15).normalize()];
        let tests = ms.len() * wis.len();
        let n = 20_000;
        for m in &ms {
            for &wi in &wis {
                let mut s = Vec::with_capacity(n);
                for i in 0..n {
                    let mut r = SampleStream::new(i as u64, 3, 11);
                    let (h, pdf) = m.sample(wi, r.next_2d());
                    let expected = m.pdf(wi, h);
                    assert!(
                        (pdf - expected).abs() <= 1e-3 * expected.max(1.0),
                        "{m:?} {wi}: sampled pdf {pdf} vs {expected}"
                    );
                    s.push(h);
                }
                // Mitsuba's Beckmann pdf uses the rational fit of G1 (0.35 % off at most), so it
                // integrates to slightly less than one; its sampler draws the exact visible
                // normals, tested here against the exact G1.
                let exact = |h: Vec3| {
                    if m.distribution == Distribution::Beckmann && m.sample_visible && wi.dot(h) > 0.0 {
                        m.d(h) * smith_g1_beckmann_exact(m, wi) * wi.dot(h) / wi.z
                    } else {
                        m.pdf(wi, h)
                    }
                };
                let out = chi2_sphere(&s, n, |h| f64::from(exact(h)), 10, 20);
                assert!(out.p_value > significance_level(tests), "{m:?} wi {wi}: {out}");
            }
        }
    }
}
