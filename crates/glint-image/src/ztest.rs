//! Mitsuba 3's render regression test (its `src/render/tests/test_renders.py`), for glint's
//! images against references that come with their per-pixel variance.
//!
//! Per pixel and channel, after image, reference and variances are taken from linear sRGB to
//! CIE XYZ by the same matrix (Mitsuba's `srgb_to_xyz`, applied to the variances as Mitsuba's
//! test applies it) and the variances floored at [`VARIANCE_FLOOR`]:
//!
//! - `z = |image − reference| / sqrt(var_image / spp + var_reference / spp_reference)` where
//!   the image has its own variance ([`Variances::Own`]); Mitsuba's test uses the reference's
//!   variance for both (`z = |image − reference| · sqrt(spp / var_reference)`,
//!   [`Variances::ReferenceOnly`]), which holds only when both renderers are equally noisy;
//! - the two-sided p-value `p = erfc(z / √2)`;
//! - accepted when `p > α`, with the Šidák-corrected significance
//!   `α = 1 − (1 − significance)^(1 / pixels)`.
//!
//! The image passes when at least [`PASS_FRACTION`] of its pixel-channels are accepted.
//! Variances are *per sample* (the variance of one sample's radiance, as Mitsuba's `moment`
//! integrator and glint's `Variance` AOV give it).

use crate::error::ImageError;
use crate::planar::Image;

/// Variances below this are raised to it (Mitsuba's test: black pixels of a reference have no
/// variance, and a renderer's exact zero must not make every difference significant).
pub const VARIANCE_FLOOR: f64 = 1e-4;

/// The fraction of pixel-channels that must be accepted (Mitsuba's test).
pub const PASS_FRACTION: f64 = 0.9975;

/// Mitsuba's test's significance level (before the Šidák correction).
pub const SIGNIFICANCE: f64 = 0.01;

/// Linear sRGB (Rec. 709 primaries, D65) to CIE XYZ, rows X, Y, Z (Mitsuba's `srgb_to_xyz`).
pub const SRGB_TO_XYZ: [[f64; 3]; 3] =
    [[0.412453, 0.357580, 0.180423], [0.212671, 0.715160, 0.072169], [0.019334, 0.119193, 0.950227]];

/// Whose variance the test divides by.
#[derive(Clone, Copy, Debug)]
pub enum Variances<'a> {
    /// The image's own per-sample variance (R, G, B planes) and sample count, and the
    /// reference's sample count (`None`: the reference's own noise is ignored).
    Own { image: &'a Image, spp: f64, reference_spp: Option<f64> },
    /// Mitsuba's form: the reference's per-sample variance stands for the image's too.
    ReferenceOnly { spp: f64 },
}

/// The outcome of [`z_test`].
#[derive(Clone, Debug, PartialEq)]
pub struct ZTest {
    /// Pixel-channels tested (3 per pixel).
    pub tested: usize,
    pub accepted: usize,
    /// `accepted / tested`.
    pub fraction: f64,
    /// The per-test significance after the Šidák correction.
    pub alpha: f64,
    pub passed: bool,
    /// The least likely pixel-channel: (x, y, channel 0..3 = X, Y, Z, its z statistic).
    pub worst: (u32, u32, usize, f64),
}

/// Runs the test on the R, G, B planes of `image` against `reference`, whose per-sample
/// variance is `reference_var` (R, G, B).
///
/// # Errors
/// [`ImageError::Mismatch`] when sizes differ, a plane is missing, a sample count is not
/// positive, or a value is not finite.
pub fn z_test(
    image: &Image,
    reference: &Image,
    reference_var: &Image,
    variances: Variances<'_>,
    significance: f64,
) -> Result<ZTest, ImageError> {
    let (w, h) = (image.width, image.height);
    let planes = |img: &Image, what: &str| -> Result<[Vec<f64>; 3], ImageError> {
        if (img.width, img.height) != (w, h) {
            return Err(ImageError::mismatch(format!("the {what} is {}x{}, the image {w}x{h}", img.width, img.height)));
        }
        let (r, g, b) =
            img.rgb_planes().ok_or_else(|| ImageError::mismatch(format!("the {what} has no R, G, B planes")))?;
        let n = r.len();
        let mut out = [vec![0.0; n], vec![0.0; n], vec![0.0; n]];
        for i in 0..n {
            let rgb = [f64::from(r[i]), f64::from(g[i]), f64::from(b[i])];
            if rgb.iter().any(|v| !v.is_finite()) {
                return Err(ImageError::mismatch(format!(
                    "the {what} has a non-finite value at pixel ({}, {})",
                    i % w as usize,
                    i / w as usize
                )));
            }
            for (k, row) in SRGB_TO_XYZ.iter().enumerate() {
                out[k][i] = row[0] * rgb[0] + row[1] * rgb[1] + row[2] * rgb[2];
            }
        }
        Ok(out)
    };
    if !(significance > 0.0 && significance < 1.0) {
        return Err(ImageError::mismatch(format!("significance {significance} must be in (0, 1)")));
    }
    let positive = |n: f64, what: &str| {
        if n.is_finite() && n > 0.0 {
            Ok(())
        } else {
            Err(ImageError::mismatch(format!("{what} {n} must be a positive number")))
        }
    };
    let img = planes(image, "image")?;
    let reference = planes(reference, "reference")?;
    let ref_var = planes(reference_var, "reference variance")?;
    // The variance of the difference, per pixel-channel.
    let mut var = [vec![0.0; img[0].len()], vec![0.0; img[0].len()], vec![0.0; img[0].len()]];
    match variances {
        Variances::Own { image: own, spp, reference_spp } => {
            positive(spp, "the image's sample count")?;
            if let Some(n) = reference_spp {
                positive(n, "the reference's sample count")?;
            }
            let own = planes(own, "image variance")?;
            for k in 0..3 {
                for i in 0..var[k].len() {
                    let r = reference_spp.map_or(0.0, |n| ref_var[k][i].max(VARIANCE_FLOOR) / n);
                    var[k][i] = own[k][i].max(VARIANCE_FLOOR) / spp + r;
                }
            }
        }
        Variances::ReferenceOnly { spp } => {
            positive(spp, "the image's sample count")?;
            for k in 0..3 {
                for i in 0..var[k].len() {
                    var[k][i] = ref_var[k][i].max(VARIANCE_FLOOR) / spp;
                }
            }
        }
    }
    let pixels = (w as usize * h as usize).max(1);
    let alpha = 1.0 - (1.0 - significance).powf(1.0 / pixels as f64);
    let mut accepted = 0;
    let mut worst = (0, 0, 0, 0.0);
    for k in 0..3 {
        for i in 0..img[k].len() {
            let z = (img[k][i] - reference[k][i]).abs() / var[k][i].sqrt();
            if two_sided_p(z) > alpha {
                accepted += 1;
            }
            if z > worst.3 {
                worst = ((i % w as usize) as u32, (i / w as usize) as u32, k, z);
            }
        }
    }
    let tested = 3 * img[0].len();
    let fraction = if tested == 0 { 1.0 } else { accepted as f64 / tested as f64 };
    Ok(ZTest { tested, accepted, fraction, alpha, passed: fraction >= PASS_FRACTION, worst })
}

/// The two-sided p-value of a standard normal statistic `z ≥ 0`: `P(|Z| ≥ z) = erfc(z/√2)`.
#[must_use]
pub fn two_sided_p(z: f64) -> f64 {
    erfc(z / std::f64::consts::SQRT_2)
}

/// The complementary error function, to about 1e-12 relative: below 2 by the Maclaurin series
/// of erf (its largest term is about 2.4, so `1 − erf` keeps 13 digits where erfc ≈ 5e-3);
/// from 2 on by Laplace's continued fraction `erfc x = e^{−x²}/√π · 1/(x + ½/(x + 1/(x + 3/2/(x + …))))`
/// evaluated with the modified Lentz method (Numerical Recipes, 3rd ed., §5.2).
#[must_use]
pub fn erfc(x: f64) -> f64 {
    if x.is_nan() {
        return f64::NAN;
    }
    if x < 0.0 {
        return 2.0 - erfc(-x);
    }
    if x < 2.0 {
        // erf x = 2/√π Σ (−1)^n x^(2n+1) / (n! (2n+1))
        let (mut term, mut sum) = (x, x);
        let x2 = x * x;
        for n in 1..200 {
            term *= -x2 / n as f64;
            let add = term / (2 * n + 1) as f64;
            sum += add;
            if add.abs() < 1e-17 * sum.abs() {
                break;
            }
        }
        return 1.0 - sum * std::f64::consts::FRAC_2_SQRT_PI;
    }
    // f = x + a1/(x + a2/(x + …)), a_n = n/2.
    let tiny = 1e-300;
    let mut f = x;
    let (mut c, mut d) = (x, 0.0);
    for n in 1..500 {
        let a = n as f64 * 0.5;
        d = x + a * d;
        d = if d.abs() < tiny { 1.0 / tiny } else { 1.0 / d };
        c = x + a / c;
        if c.abs() < tiny {
            c = tiny;
        }
        let delta = c * d;
        f *= delta;
        if (delta - 1.0).abs() < 1e-16 {
            break;
        }
    }
    (-x * x).exp() / (f * std::f64::consts::PI.sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn flat(w: u32, h: u32, v: [f32; 3]) -> Image {
        let mut img = Image::new(w, h);
        for (name, c) in ["R", "G", "B"].into_iter().zip(v) {
            img.add_channel(name, vec![c; (w * h) as usize]).expect("sized");
        }
        img
    }

    #[test]
    fn erfc_matches_tabulated_values() {
        // Abramowitz and Stegun, table 7.1, and erfc(5) from its asymptotic series.
        for (x, want) in [
            (0.0, 1.0),
            (0.5, 0.479_500_122_186_953_5),
            (1.0, 0.157_299_207_050_285_1),
            (2.0, 4.677_734_981_047_266e-3),
            (3.0, 2.209_049_699_858_544e-5),
            (4.0, 1.541_725_790_028_002e-8),
            (5.0, 1.537_459_794_428_035e-12),
            (-1.0, 1.842_700_792_949_715),
        ] {
            let got = erfc(x);
            assert!(((got - want) / want).abs() < 1e-10, "erfc({x}) = {got}, want {want}");
        }
        // Continuous where the two methods meet.
        assert!((erfc(2.0 - 1e-12) / erfc(2.0) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn equal_images_pass_and_a_biased_one_fails() {
        let reference = flat(16, 16, [0.5, 0.4, 0.3]);
        let var = flat(16, 16, [0.01, 0.01, 0.01]);
        let same = z_test(&reference, &reference, &var, Variances::ReferenceOnly { spp: 100.0 }, SIGNIFICANCE)
            .expect("same size");
        assert!(same.passed && same.fraction == 1.0, "{same:?}");
        // The standard error of the mean is 0.01 (XYZ rows sum to about 1): a 1 % bias is about
        // 0.4 σ (accepted), a 20 % bias about 8 σ (p ≈ 1e-15 < α ≈ 4e-5: rejected everywhere).
        let close = flat(16, 16, [0.505, 0.404, 0.303]);
        let t = z_test(&close, &reference, &var, Variances::ReferenceOnly { spp: 100.0 }, SIGNIFICANCE).expect("ok");
        assert!(t.passed, "{t:?}");
        let far = flat(16, 16, [0.6, 0.48, 0.36]);
        let t = z_test(&far, &reference, &var, Variances::ReferenceOnly { spp: 100.0 }, SIGNIFICANCE).expect("ok");
        assert!(!t.passed && t.accepted == 0, "{t:?}");
        // With the image's own (larger) variance the same bias is within the noise.
        let own = flat(16, 16, [1.0, 1.0, 1.0]);
        let t = z_test(
            &far,
            &reference,
            &var,
            Variances::Own { image: &own, spp: 100.0, reference_spp: Some(32_000.0) },
            SIGNIFICANCE,
        )
        .expect("ok");
        assert!(t.passed, "{t:?}");
    }

    #[test]
    fn a_few_bad_pixels_are_tolerated_many_are_not() {
        let reference = flat(20, 20, [0.5, 0.5, 0.5]);
        let var = flat(20, 20, [0.01, 0.01, 0.01]);
        let mut img = reference.clone();
        // One pixel off in all three channels: 3 of 1200 pixel-channels = 0.25 %, right at
        // the limit; two pixels are too many.
        for name in ["R", "G", "B"] {
            img.channel_mut(name).expect("plane")[7] = 2.0;
        }
        let t = z_test(&img, &reference, &var, Variances::ReferenceOnly { spp: 100.0 }, SIGNIFICANCE).expect("ok");
        assert_eq!((t.tested, t.accepted), (1200, 1197));
        assert!(t.passed && (t.worst.0, t.worst.1) == (7, 0), "{t:?}");
        for name in ["R", "G", "B"] {
            img.channel_mut(name).expect("plane")[8] = 2.0;
        }
        let t = z_test(&img, &reference, &var, Variances::ReferenceOnly { spp: 100.0 }, SIGNIFICANCE).expect("ok");
        assert!(!t.passed, "{t:?}");
    }

    #[test]
    fn bad_inputs_are_errors() {
        let a = flat(4, 4, [0.5; 3]);
        let small = flat(2, 2, [0.5; 3]);
        let r = Variances::ReferenceOnly { spp: 10.0 };
        assert!(z_test(&a, &small, &a, r, SIGNIFICANCE).is_err());
        assert!(z_test(&a, &a, &a, Variances::ReferenceOnly { spp: 0.0 }, SIGNIFICANCE).is_err());
        assert!(z_test(&a, &a, &a, r, 0.0).is_err());
        let mut nan = a.clone();
        nan.channel_mut("G").expect("plane")[3] = f32::NAN;
        let e = z_test(&nan, &a, &a, r, SIGNIFICANCE).expect_err("nan").to_string();
        assert!(e.contains("(3, 0)"), "{e}");
    }
}
