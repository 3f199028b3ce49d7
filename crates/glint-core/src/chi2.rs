//! χ² goodness-of-fit tests of direction samplers against their pdfs (STYLE.md §5: "χ² tests of
//! every sampling routine against its pdf").
//!
//! The sphere is cut into a θ × φ grid (z up: θ from +Z, φ = atan2(y, x)); samples are counted
//! per cell and compared with the counts the claimed pdf predicts, which are integrals of the
//! pdf over each cell done numerically. Cells expected to receive fewer than 5 samples are pooled
//! (as pbrt-v3, Mitsuba and Nori do) so that Pearson's statistic is χ²-distributed, and the
//! p-value is the upper tail of that distribution (the regularised incomplete gamma function Q).
//!
//! A test passes when its p-value exceeds the significance level corrected for the number of
//! tests run together ([`significance_level`], Šidák: ≈ 0.01 / number of tests), so that a
//! correct suite fails with probability 1 %, whatever its size.
//!
//! Used by the tests of several crates; it sits in glint-core so that each can reach it. Plain
//! arithmetic only: no I/O, no threads.

use glam::Vec3;
use std::f64::consts::PI;

/// Significance of a whole suite of χ² tests.
pub const SIGNIFICANCE: f64 = 0.01;

/// Cells expected to receive fewer samples than this are pooled.
const MIN_EXPECTED: f64 = 5.0;

/// Share of the draws that may land in cells the quadrature finds empty (Nori's rule): slivers
/// of support thinner than the finest sub-grid, or directions rounded across the edge of the
/// support. A sampler that really draws where its pdf is zero puts far more there.
const STRAY_FRACTION: f64 = 1e-5;

/// Result of a χ² test of a direction sampler against its claimed pdf (solid-angle measure) on
/// a θ × φ grid over the whole sphere (z-up spherical coordinates of the vectors as given).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chi2Outcome {
    /// Pearson's statistic Σ (observed − expected)² / expected over the (pooled) cells;
    /// +inf when a sample is not finite or lands where the pdf is zero.
    pub statistic: f64,
    /// Degrees of freedom: cells after pooling, minus one.
    pub dof: usize,
    /// Probability of a statistic at least this large if the samples follow the pdf.
    pub p_value: f64,
    /// How many grid cells (the "missing" cell of failed samples included) were pooled with
    /// others because their expected count was below 5.
    pub merged_cells: usize,
}

impl Chi2Outcome {
    /// Whether the sampler passes as one of `tests` tests run together: p > [`significance_level`].
    pub fn passes(&self, tests: usize) -> bool {
        self.p_value > significance_level(tests)
    }
}

impl std::fmt::Display for Chi2Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "χ² = {:.1} with {} dof, p = {:.3e} ({} cells pooled)",
            self.statistic, self.dof, self.p_value, self.merged_cells
        )
    }
}

/// The level a p-value must exceed when `tests` tests share the suite's [`SIGNIFICANCE`]
/// (Šidák's correction 1 − (1 − α)^(1/n), just above α / n).
pub fn significance_level(tests: usize) -> f64 {
    1.0 - (1.0 - SIGNIFICANCE).powf(1.0 / tests.max(1) as f64)
}

/// χ² test of direction samples against `pdf` (solid angle).
///
/// `samples` are the directions a sampler returned (any non-zero length); `sample_count` is how
/// many times it was asked, so `sample_count − samples.len()` draws returned nothing. Those
/// form one more cell, expected to hold `sample_count · (1 − ∫ pdf)`: a sampler whose pdf
/// integrates to less than one (absorbed light) is tested for that too. The expected count of
/// each cell integrates `pdf` with a midpoint rule over a sub-grid (uniform in θ and φ),
/// refined per cell until the quadrature error is well below the cell's statistical noise (or
/// a 128 × 128 sub-grid is reached). Cells expected to get fewer than 5 samples are pooled.
/// Samples in cells the quadrature finds empty fail the test, beyond a forgiven 10⁻⁵ of the
/// draws (slivers of support thinner than the sub-grid, as Nori allows).
pub fn chi2_sphere(
    samples: &[Vec3],
    sample_count: usize,
    pdf: impl Fn(Vec3) -> f64,
    theta_bins: usize,
    phi_bins: usize,
) -> Chi2Outcome {
    let (theta_bins, phi_bins) = (theta_bins.max(1), phi_bins.max(1));
    let fail = |merged_cells| Chi2Outcome { statistic: f64::INFINITY, dof: 0, p_value: 0.0, merged_cells };

    let mut observed = vec![0u64; theta_bins * phi_bins];
    for d in samples {
        if !d.is_finite() || *d == Vec3::ZERO {
            return fail(0);
        }
        observed[cell_of(*d, theta_bins, phi_bins)] += 1;
    }

    let n = sample_count.max(samples.len()) as f64;
    let mut cells: Vec<(f64, f64)> = Vec::with_capacity(observed.len() + 1);
    let (mut total, mut total_error) = (0.0, 0.0);
    for t in 0..theta_bins {
        for p in 0..phi_bins {
            let o = observed[t * phi_bins + p] as f64;
            let (integral, error) = cell_integral(&pdf, t, p, theta_bins, phi_bins, n, o);
            total += integral;
            total_error += error;
            cells.push((o, integral * n));
        }
    }
    if !total.is_finite() {
        return fail(0);
    }
    // The draws that returned nothing, against the mass the pdf leaves out. That mass is a
    // difference of two nearly equal numbers, so the quadrature's own error (the sum of the
    // cells' last refinement changes) is given to the sampler: the expected count moves toward
    // the observed one by up to that much.
    let missing = (sample_count.saturating_sub(samples.len())) as f64;
    let (expected, slack) = (n * (1.0 - total), n * total_error);
    let expected =
        if (missing - expected).abs() <= slack { missing } else { expected + slack * (missing - expected).signum() };
    cells.push((missing, expected.max(0.0)));

    pearson(cells, (n * STRAY_FRACTION).floor())
}

/// ∫ f dω over the whole sphere, by the midpoint rule on a `theta_bins` × `phi_bins` grid
/// uniform in cos θ and φ (so every point carries the same solid angle).
pub fn integrate_sphere(f: impl Fn(Vec3) -> f64, theta_bins: usize, phi_bins: usize) -> f64 {
    let (nz, np) = (theta_bins.max(1), phi_bins.max(1));
    let mut sum = 0.0;
    for i in 0..nz {
        let z = 1.0 - 2.0 * (i as f64 + 0.5) / nz as f64;
        let r = (1.0 - z * z).max(0.0).sqrt();
        for j in 0..np {
            let phi = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            sum += f(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
        }
    }
    sum * 4.0 * PI / (nz * np) as f64
}

/// The grid cell of a non-zero direction.
fn cell_of(d: Vec3, theta_bins: usize, phi_bins: usize) -> usize {
    let d = d.as_dvec3();
    let theta = (d.z / d.length()).clamp(-1.0, 1.0).acos();
    let mut phi = d.y.atan2(d.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let t = ((theta / PI * theta_bins as f64) as usize).min(theta_bins - 1);
    let p = ((phi / (2.0 * PI) * phi_bins as f64) as usize).min(phi_bins - 1);
    t * phi_bins + p
}

/// ∫ pdf dω over cell (`t`, `p`), from an 8 × 8 sub-grid on, doubled until the change from
/// the last refinement, in expected samples (`n` drawn), is below a fiftieth of the cell's
/// standard deviation. (Comparing coarser sub-grids let piecewise-constant pdfs — tabulated
/// environment maps — stop early by chance: over 30 seeds the statistic of a correct sampler
/// sat 74 above its 2048 degrees of freedom; from 8 × 8 at a fiftieth, 16, within noise.) A cell
/// whose `observed` count is far from the estimate is refined to the finest sub-grid before it
/// is believed: a sliver of non-zero pdf (the edge of a lit region) that the coarse sub-grids
/// miss must not fail a correct sampler.
fn cell_integral(
    pdf: &impl Fn(Vec3) -> f64,
    t: usize,
    p: usize,
    theta_bins: usize,
    phi_bins: usize,
    n: f64,
    observed: f64,
) -> (f64, f64) {
    const MAX_SUBDIVISION: usize = 128;
    let (theta0, theta1) = (PI * t as f64 / theta_bins as f64, PI * (t + 1) as f64 / theta_bins as f64);
    let (phi0, phi1) = (2.0 * PI * p as f64 / phi_bins as f64, 2.0 * PI * (p + 1) as f64 / phi_bins as f64);
    // Midpoints in θ (weighted by sin θ), not in cos θ: pdfs that grow like 1 / sin θ toward a
    // pole (lat-long maps, whose poles may be the grid's) are then bounded integrands.
    let midpoint = |k: usize| {
        let mut sum = 0.0;
        for i in 0..k {
            let theta = theta0 + (theta1 - theta0) * (i as f64 + 0.5) / k as f64;
            let (r, z) = theta.sin_cos();
            let mut row = 0.0;
            for j in 0..k {
                let phi = phi0 + (phi1 - phi0) * (j as f64 + 0.5) / k as f64;
                row += pdf(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32));
            }
            sum += row * r;
        }
        sum * (theta1 - theta0) * (phi1 - phi0) / (k * k) as f64
    };
    let mut k = 8;
    let mut coarse = midpoint(k);
    loop {
        k *= 2;
        let fine = midpoint(k);
        let (expected, change) = (fine * n, (fine - coarse).abs() * n);
        let converged = change <= 0.02 * expected.max(1.0).sqrt();
        let suspicious = (observed - expected).powi(2) > 16.0 * expected.max(1.0) || (observed > 0.0 && fine <= 0.0);
        if !fine.is_finite() || k >= MAX_SUBDIVISION || (converged && !suspicious) {
            return (fine, change / n);
        }
        coarse = fine;
    }
}

/// Pearson's statistic over (observed, expected) cells, pooling those expected below 5. Up to
/// `strays` samples in cells expected to be empty are forgiven; more fail the test.
fn pearson(mut cells: Vec<(f64, f64)>, strays: f64) -> Chi2Outcome {
    cells.sort_by(|a, b| a.1.total_cmp(&b.1));
    let (mut statistic, mut emitted, mut merged_cells) = (0.0, 0usize, 0usize);
    let (mut pool_observed, mut pool_expected, mut pool_cells) = (0.0, 0.0, 0usize);
    let mut stray = 0.0;
    for (observed, expected) in cells {
        if expected <= 0.0 {
            stray += observed;
            if stray > strays {
                // Samples where the pdf says none can be.
                return Chi2Outcome { statistic: f64::INFINITY, dof: emitted, p_value: 0.0, merged_cells };
            }
            continue;
        }
        pool_observed += observed;
        pool_expected += expected;
        pool_cells += 1;
        if pool_expected >= MIN_EXPECTED {
            statistic += (pool_observed - pool_expected).powi(2) / pool_expected;
            emitted += 1;
            if pool_cells > 1 {
                merged_cells += pool_cells;
            }
            (pool_observed, pool_expected, pool_cells) = (0.0, 0.0, 0);
        }
    }
    if pool_cells > 0 {
        // Only when every cell together expects fewer than 5 samples.
        statistic += (pool_observed - pool_expected).powi(2) / pool_expected;
        emitted += 1;
        if pool_cells > 1 {
            merged_cells += pool_cells;
        }
    }
    let dof = emitted.saturating_sub(1);
    let p_value = if dof == 0 { 1.0 } else { chi2_p_value(statistic, dof) };
    Chi2Outcome { statistic, dof, p_value, merged_cells }
}

/// Upper tail of the χ² distribution with `dof` degrees of freedom at `statistic`:
/// Q(dof / 2, statistic / 2).
pub fn chi2_p_value(statistic: f64, dof: usize) -> f64 {
    if statistic.is_nan() {
        return 0.0;
    }
    if dof == 0 {
        return 1.0;
    }
    gamma_q(dof as f64 / 2.0, statistic.max(0.0) / 2.0)
}

/// Regularised upper incomplete gamma function Q(a, x) = Γ(a, x) / Γ(a), a > 0, x ≥ 0:
/// the series of P below x = a + 1 and Lentz's continued fraction of Q above ("Numerical
/// Recipes", §6.2), each where it converges fast.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if x.is_infinite() {
        return 0.0;
    }
    if x < a + 1.0 { (1.0 - gamma_p_series(a, x)).clamp(0.0, 1.0) } else { gamma_q_fraction(a, x).clamp(0.0, 1.0) }
}

/// P(a, x) = e^-x x^a / Γ(a) Σ_k x^k / (a (a+1) … (a+k)).
fn gamma_p_series(a: f64, x: f64) -> f64 {
    let (mut term, mut sum, mut ap) = (1.0 / a, 1.0 / a, a);
    for _ in 0..100_000 {
        ap += 1.0;
        term *= x / ap;
        sum += term;
        if term.abs() < sum.abs() * 1e-16 {
            break;
        }
    }
    sum * (-x + a * x.ln() - ln_gamma(a)).exp()
}

/// Q(a, x) = e^-x x^a / Γ(a) · 1/(x + 1 − a − 1·(1 − a)/(x + 3 − a − …)), modified Lentz.
fn gamma_q_fraction(a: f64, x: f64) -> f64 {
    const TINY: f64 = 1e-300;
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / TINY;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..100_000 {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < TINY {
            d = TINY;
        }
        c = b + an / c;
        if c.abs() < TINY {
            c = TINY;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    (-x + a * x.ln() - ln_gamma(a)).exp() * h
}

/// ln Γ(x) for x > 0 (Lanczos, g = 7, nine coefficients: ~1e-15 relative).
fn ln_gamma(x: f64) -> f64 {
    const G: f64 = 7.0;
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    if x < 0.5 {
        // Reflection: Γ(x) Γ(1 − x) = π / sin(πx).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let mut sum = C[0];
    for (i, c) in C.iter().enumerate().skip(1) {
        sum += c / (x + i as f64);
    }
    let t = x + G + 0.5;
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + sum.ln()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::random::SampleStream;
    use crate::sampling::{cosine_hemisphere_pdf, sample_cosine_hemisphere, sample_uniform_sphere};
    use glam::Vec2;
    use std::f64::consts::FRAC_1_PI;

    /// The tests of this module that compare a sampler with a pdf and are expected to pass.
    const PASSING_TESTS: usize = 4;

    fn draw(n: usize, seed: u64, warp: impl Fn(Vec2) -> Option<Vec3>) -> Vec<Vec3> {
        (0..n).filter_map(|i| warp(SampleStream::new(i as u64, 0, seed).next_2d())).collect()
    }

    #[test]
    fn ln_gamma_matches_factorials() {
        let mut factorial = 1.0f64;
        for n in 1..30 {
            assert!((ln_gamma(n as f64) - factorial.ln()).abs() < 1e-12 * factorial.ln().max(1.0), "{n}");
            factorial *= n as f64;
        }
        assert!((ln_gamma(0.5) - PI.sqrt().ln()).abs() < 1e-14);
        assert!((ln_gamma(0.1) - 2.252_712_651_734_206).abs() < 1e-12);
    }

    #[test]
    fn q_matches_closed_forms_and_tables() {
        // Q(n, x) = e^-x Σ_{k<n} x^k / k! for integer n, on both sides of x = a + 1.
        for (a, x) in [(1u32, 0.3f64), (1, 7.0), (5, 2.0), (5, 9.0), (50, 40.0), (50, 60.0), (200, 180.0)] {
            let (mut term, mut sum) = (1.0f64, 1.0f64);
            for k in 1..a {
                term *= x / k as f64;
                sum += term;
            }
            let want = (-x).exp() * sum;
            let got = gamma_q(a as f64, x);
            assert!((got - want).abs() < 1e-12 + 1e-10 * want, "Q({a}, {x}) = {got}, want {want}");
        }
        // χ² critical values at 5 % (statistics tables) and dof 2, where the tail is e^(-x/2).
        for (x, dof) in [(3.841_458_820_694_124, 1), (18.307_038_053_275_146, 10), (124.342_113_404_004_07, 100)] {
            assert!((chi2_p_value(x, dof) - 0.05).abs() < 1e-9, "{dof}: {}", chi2_p_value(x, dof));
        }
        assert!((chi2_p_value(3.0, 2) - (-1.5f64).exp()).abs() < 1e-14);
        assert_eq!(chi2_p_value(0.0, 7), 1.0);
        assert_eq!(chi2_p_value(f64::INFINITY, 7), 0.0);
        assert!(chi2_p_value(1e5, 1000) < 1e-300);
    }

    #[test]
    fn cosine_hemisphere_passes() {
        let n = 200_000;
        let s = draw(n, 1, |u| Some(sample_cosine_hemisphere(u)));
        let out = chi2_sphere(&s, n, |d| cosine_hemisphere_pdf(d.z) as f64, 16, 32);
        assert!(out.passes(PASSING_TESTS), "{out}");
        // The lower hemisphere expects nothing and is skipped; what remains is mostly unpooled.
        assert!(out.dof > 200, "{out}");
        // One stray sample in 200 000 where the pdf is zero is forgiven (10⁻⁵ of the draws).
        let mut strays = s.clone();
        strays[0] = -Vec3::Z;
        assert!(chi2_sphere(&strays, n, |d| cosine_hemisphere_pdf(d.z) as f64, 16, 32).passes(PASSING_TESTS));
    }

    #[test]
    fn uniform_sphere_passes() {
        let n = 200_000;
        let s = draw(n, 2, |u| Some(sample_uniform_sphere(u)));
        let out = chi2_sphere(&s, n, |_| 0.25 * FRAC_1_PI, 20, 40);
        assert!(out.passes(PASSING_TESTS), "{out}");
        assert!(out.dof > 700, "{out}");
    }

    #[test]
    fn failed_draws_are_a_missing_mass() {
        // Half the draws fail; the pdf (of the successful half) integrates to ½.
        let n = 100_000;
        let s = draw(n, 3, |u| (u.x < 0.5).then(|| sample_uniform_sphere(Vec2::new(u.x * 2.0, u.y))));
        let out = chi2_sphere(&s, n, |_| 0.125 * FRAC_1_PI, 12, 24);
        assert!(out.passes(PASSING_TESTS), "{out}");
        // Claiming the full mass for the same samples fails: half the draws went missing.
        let out = chi2_sphere(&s, n, |_| 0.25 * FRAC_1_PI, 12, 24);
        assert!(out.p_value < 1e-12, "{out}");
    }

    #[test]
    fn a_wrong_pdf_fails() {
        let n = 50_000;
        let s = draw(n, 4, |u| Some(sample_cosine_hemisphere(u)));
        // Uniform on the sphere claimed for cosine samples.
        let out = chi2_sphere(&s, n, |_| 0.25 * FRAC_1_PI, 16, 32);
        assert!(out.p_value < 1e-12, "{out}");
        // Uniform on the hemisphere: the right support, the wrong shape.
        let out = chi2_sphere(&s, n, |d| if d.z > 0.0 { 0.5 * FRAC_1_PI } else { 0.0 }, 16, 32);
        assert!(out.p_value < 1e-12, "{out}");
        // Samples where the pdf is zero fail outright, beyond 10⁻⁵ of the draws.
        let out = chi2_sphere(&[-Vec3::Z], 1, |d| cosine_hemisphere_pdf(d.z) as f64, 4, 8);
        assert_eq!(out.p_value, 0.0);
        let mut strays = s.clone();
        strays.truncate(n - 2);
        strays.extend([-Vec3::Z, -Vec3::Z]);
        let out = chi2_sphere(&strays, n, |d| cosine_hemisphere_pdf(d.z) as f64, 16, 32);
        assert_eq!(out.p_value, 0.0, "{out}");
        // So does a NaN sample.
        let out = chi2_sphere(&[Vec3::NAN], 1, |_| 0.25 * FRAC_1_PI, 4, 8);
        assert_eq!(out.p_value, 0.0);
    }

    #[test]
    fn small_cells_are_pooled() {
        // A narrow lobe (cos^200) on a fine grid: most cells expect almost nothing.
        let n = 20_000;
        let exponent = 200.0f32;
        let s = draw(n, 5, |u| {
            let z = u.x.powf(1.0 / (exponent + 1.0));
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f32::consts::PI * u.y;
            Some(Vec3::new(r * phi.cos(), r * phi.sin(), z))
        });
        let pdf = |d: Vec3| {
            if d.z > 0.0 { (exponent as f64 + 1.0) / (2.0 * PI) * (d.z as f64).powf(exponent as f64) } else { 0.0 }
        };
        let out = chi2_sphere(&s, n, pdf, 64, 64);
        assert!(out.merged_cells > 100, "{out}");
        assert!(out.passes(PASSING_TESTS), "{out}");
    }

    #[test]
    fn integrates_over_the_sphere() {
        assert!((integrate_sphere(|_| 1.0, 8, 16) - 4.0 * PI).abs() < 1e-9);
        let cosine = integrate_sphere(|d| cosine_hemisphere_pdf(d.z) as f64, 64, 128);
        assert!((cosine - 1.0).abs() < 1e-6, "{cosine}");
    }

    #[test]
    fn significance_is_sidak() {
        assert!((significance_level(1) - 0.01).abs() < 1e-15);
        let l = significance_level(10);
        assert!(l > 0.001 && l < 0.001_01, "{l}");
    }
}
