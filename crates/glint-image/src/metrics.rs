//! Image difference metrics for tests, golden images and `glint compare`.
//!
//! - [`mse`]: mean of `(a − b)²`.
//! - [`rel_mse`]: mean of `(a − r)² / (r² + ε)` with ε = [`REL_MSE_EPSILON`] — the relative MSE
//!   used in rendering papers (e.g. Rousselle et al. 2011), insensitive to absolute brightness.
//!   On images ([`rel_mse_rgb`]) it is taken per value — each of R, G, B on its own, not on a
//!   pixel's luminance — and averaged over all 3·N values. Only the reference `r` is in the
//!   denominator, so swapping test and reference changes it; errors of `+d` and `−d` weigh the
//!   same.
//! - [`psnr`]: `10 · log10(peak² / mse)` dB; `+∞` when `mse = 0`.
//! - [`psnr_srgb8`]: PSNR (peak 255) between the 8-bit sRGB encodings (clamp tone map, no
//!   exposure) — what a viewer of the PNGs would see.
//! - [`ssim`]: mean SSIM (Wang et al. 2004, eq. 13) on the Rec. 709 luma of the 8-bit sRGB
//!   encodings scaled to `[0, 1]`, with the paper's 11×11 Gaussian window (σ = 1.5), K1 = 0.01,
//!   K2 = 0.03, L = 1. At the borders the window is cut to the image and renormalised, so every
//!   pixel counts and images smaller than the window work.
//! - [`mse_srgb8`]: MSE of the 8-bit sRGB codes themselves (0..255 scale), the number image
//!   filtering papers report (e.g. He et al.'s guided filter tables).
//! - [`compare`]: all of the above at once, as an [`ErrorReport`] (what `glint compare` prints).
//!
//! All image metrics use the `R`, `G`, `B` planes only (alpha, depth and other AOVs are ignored),
//! each plane weighted equally. "8-bit sRGB" always means [`encode_srgb8`] with the default
//! options: exposure 0, clamp to `[0, 1]`, sRGB OETF, round to nearest. For images read from
//! 8-bit PNG/JPEG files that reproduces the stored codes exactly, so the sRGB metrics equal those
//! computed on the files' bytes.
//!
//! For pictures of the error: [`error_map`] (per-pixel RMS of the RGB difference),
//! [`diff_scale`] (its 99th percentile, the default top of the colour map) and [`false_colour`]
//! (through [`inferno`], a perceptually ordered colour map).
//!
//! Slice metrics accumulate in f64 in index order (deterministic). Image metrics return
//! [`ImageError::Mismatch`] for different sizes or missing channels; [`compare`] also for
//! non-finite values (find them with [`first_non_finite_rgb`]).

use std::fmt;

use glint_core::colour::srgb_to_linear;

use crate::error::ImageError;
use crate::planar::{Image, RgbPlanes};
use crate::png_io::{PngOptions, encode_srgb8};

/// ε of [`rel_mse`], keeping near-black reference pixels from dominating.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// Mean squared error; 0 for empty slices.
///
/// # Panics
/// If the lengths differ (compare images with [`mse_rgb`], which returns an error instead).
pub fn mse(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(a.len(), b.len(), "mse: slices of different lengths");
    if a.is_empty() {
        return 0.0;
    }
    a.iter().zip(b).map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2)).sum::<f64>() / a.len() as f64
}

/// Peak signal-to-noise ratio in dB from an MSE: `10 log10(peak² / mse)`; `+∞` for `mse = 0`.
pub fn psnr(mse: f64, peak: f64) -> f64 {
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (peak * peak / mse).log10() }
}

/// Relative MSE of `a` against `reference`: mean of `(a − r)² / (r² + ε)`, ε = [`REL_MSE_EPSILON`].
///
/// # Panics
/// If the lengths differ.
pub fn rel_mse(a: &[f32], reference: &[f32]) -> f64 {
    assert_eq!(a.len(), reference.len(), "rel_mse: slices of different lengths");
    if a.is_empty() {
        return 0.0;
    }
    a.iter()
        .zip(reference)
        .map(|(&x, &r)| {
            let (x, r) = (f64::from(x), f64::from(r));
            (x - r).powi(2) / (r * r + REL_MSE_EPSILON)
        })
        .sum::<f64>()
        / a.len() as f64
}

/// MSE over the `R`, `G`, `B` planes of two images of the same size.
pub fn mse_rgb(a: &Image, b: &Image) -> Result<f64, ImageError> {
    rgb_metric(a, b, mse)
}

/// Relative MSE over the `R`, `G`, `B` planes of `a` against `reference`: the mean over every
/// value of `(a − r)² / (r² + ε)`, ε = [`REL_MSE_EPSILON`] (per channel, not per luminance).
pub fn rel_mse_rgb(a: &Image, reference: &Image) -> Result<f64, ImageError> {
    rgb_metric(a, reference, rel_mse)
}

/// PSNR (dB, peak 255) between the 8-bit sRGB encodings of two images (clamp, exposure 0).
pub fn psnr_srgb8(a: &Image, b: &Image) -> Result<f64, ImageError> {
    Ok(psnr(mse_srgb8(a, b)?, 255.0))
}

/// MSE between the 8-bit sRGB encodings of two images (clamp, exposure 0), on the 0..255
/// scale: the mean over all R, G, B codes of `(code_a − code_b)²`. Exact (integer sums).
pub fn mse_srgb8(a: &Image, b: &Image) -> Result<f64, ImageError> {
    let (a, b) = encode_pair(a, b)?;
    Ok(mse_codes(&a, &b))
}

/// Mean SSIM on luma of the 8-bit sRGB encodings (details in the module docs): 1 for identical
/// images, lower for different ones.
pub fn ssim(a: &Image, b: &Image) -> Result<f64, ImageError> {
    let (ea, eb) = encode_pair(a, b)?;
    Ok(ssim_codes(&ea, &eb, a))
}

/// Every number `glint compare` prints for a test image against a reference (see [`compare`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ErrorReport {
    /// MSE of the linear R, G, B values ([`mse_rgb`]).
    pub mse: f64,
    /// MSE of the 8-bit sRGB codes, 0..255 scale ([`mse_srgb8`]).
    pub mse_srgb8: f64,
    /// Relative MSE of the linear values against the reference ([`rel_mse_rgb`]): the mean over
    /// every R, G, B value of `(a − r)² / (r² + 0.01)`.
    pub rel_mse: f64,
    /// PSNR of `mse` with peak 1, in dB (negative when the error exceeds 1, as in HDR images).
    pub psnr: f64,
    /// PSNR of `mse_srgb8` with peak 255, in dB ([`psnr_srgb8`]).
    pub psnr_srgb8: f64,
    /// Mean SSIM on the luma of the 8-bit sRGB encodings ([`ssim`]).
    pub ssim: f64,
}

/// All the metrics of `test` against `reference` at once (the sRGB encoding is done once).
/// Identical images give 0 errors, `+∞` PSNRs and SSIM 1. Errors ([`ImageError::Mismatch`]):
/// different sizes, missing `R`, `G`, `B`, or a non-finite R, G, B value (naming the image and
/// its first such pixel), which would make every mean meaningless.
pub fn compare(test: &Image, reference: &Image) -> Result<ErrorReport, ImageError> {
    same_size(test, reference)?;
    rgb_of(test, "first")?;
    rgb_of(reference, "second")?;
    for (image, which) in [(test, "first"), (reference, "second")] {
        if let Some(bad) = first_non_finite_rgb(image) {
            return Err(ImageError::mismatch(format!("the {which} image has a non-finite value: {bad}")));
        }
    }
    let mse = mse_rgb(test, reference)?;
    let (ea, eb) = encode_pair(test, reference)?;
    let mse_srgb8 = mse_codes(&ea, &eb);
    Ok(ErrorReport {
        mse,
        mse_srgb8,
        rel_mse: rel_mse_rgb(test, reference)?,
        psnr: psnr(mse, 1.0),
        psnr_srgb8: psnr(mse_srgb8, 255.0),
        ssim: ssim_codes(&ea, &eb, test),
    })
}

/// Where a non-finite value sits in an image: pixel `(x, y)` (x right, y down from the top-left)
/// and channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NonFinite {
    pub x: u32,
    pub y: u32,
    pub channel: &'static str,
    pub value: f32,
}

impl fmt::Display for NonFinite {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "pixel ({}, {}) channel {} is {}", self.x, self.y, self.channel, self.value)
    }
}

/// The first NaN or ±∞ among the `R`, `G`, `B` values, scanning pixels row by row from the
/// top-left and, within a pixel, R then G then B. `None` when all are finite or the image has
/// no `R`, `G`, `B`. Other channels are not looked at (a render's depth `Z` is +∞ where no
/// sample hit).
pub fn first_non_finite_rgb(image: &Image) -> Option<NonFinite> {
    let (r, g, b) = image.rgb_planes()?;
    let planes = [("R", r), ("G", g), ("B", b)];
    if planes.iter().all(|(_, p)| p.iter().all(|v| v.is_finite())) {
        return None;
    }
    let width = image.width.max(1) as usize;
    (0..r.len().min(g.len()).min(b.len())).find_map(|i| {
        planes.iter().find(|(_, p)| !p[i].is_finite()).map(|&(channel, p)| NonFinite {
            x: (i % width) as u32,
            y: (i / width) as u32,
            channel,
            value: p[i],
        })
    })
}

/// Per-pixel error of `a` against `b`: the RMS of the three channel differences,
/// `sqrt(((a_R − b_R)² + (a_G − b_G)² + (a_B − b_B)²) / 3)`, row-major. The mean of its squares
/// is [`mse_rgb`]. Symmetric in `a` and `b`.
pub fn error_map(a: &Image, b: &Image) -> Result<Vec<f32>, ImageError> {
    same_size(a, b)?;
    let (ar, ag, ab) = rgb_of(a, "first")?;
    let (br, bg, bb) = rgb_of(b, "second")?;
    let d = |x: f32, y: f32| (f64::from(x) - f64::from(y)).powi(2);
    Ok((0..a.pixel_count())
        .map(|i| ((d(ar[i], br[i]) + d(ag[i], bg[i]) + d(ab[i], bb[i])) / 3.0).sqrt() as f32)
        .collect())
}

/// The `p`-th percentile (`p` in `[0, 100]`, clamped) of `values` by nearest rank: the smallest
/// value `v` such that at least `p` % of the values are `≤ v` (the minimum for `p = 0`). 0 for an
/// empty slice. Values are ordered by `f32::total_cmp`, so NaN counts as the largest.
pub fn percentile(values: &[f32], p: f64) -> f32 {
    if values.is_empty() {
        return 0.0;
    }
    let n = values.len();
    let rank = ((p.clamp(0.0, 100.0) / 100.0) * n as f64).ceil() as usize;
    let mut sorted = values.to_vec();
    let (_, &mut v, _) = sorted.select_nth_unstable_by(rank.clamp(1, n) - 1, f32::total_cmp);
    v
}

/// The percentile of the errors that [`diff_scale`] maps to the top of the colour map.
pub const DIFF_PERCENTILE: f64 = 99.0;

/// The default top of the colour map for an [`error_map`]: its [`DIFF_PERCENTILE`]th
/// percentile, so that a few outliers cannot turn the rest of the picture black. When that is
/// 0 (fewer than 1 % of the pixels differ) the largest error is used instead, and 1 when every
/// error is 0 (the picture is then black).
pub fn diff_scale(errors: &[f32]) -> f32 {
    let p = percentile(errors, DIFF_PERCENTILE);
    if p > 0.0 {
        return p;
    }
    let max = errors.iter().copied().filter(|v| v.is_finite()).fold(0.0f32, f32::max);
    if max > 0.0 { max } else { 1.0 }
}

/// Matplotlib's *inferno* colour map (van der Walt and Smith, 2015): entries 0, 17, 34, ..., 255
/// of its 256-entry table, sRGB in `[0, 1]`. Black to pale yellow with monotonically increasing
/// lightness (and luminance), readable in grey and by colour-blind viewers. Linear interpolation
/// between these 16 stops stays within 6.1/255 of the full table.
const INFERNO: [[f32; 3]; 16] = [
    [0.001462, 0.000466, 0.013866],
    [0.046915, 0.030324, 0.150164],
    [0.142378, 0.046242, 0.308553],
    [0.258234, 0.038571, 0.406485],
    [0.366529, 0.071579, 0.431994],
    [0.472328, 0.110547, 0.428334],
    [0.578304, 0.148039, 0.404411],
    [0.682656, 0.189501, 0.360757],
    [0.780517, 0.243327, 0.299523],
    [0.865006, 0.316822, 0.226055],
    [0.929644, 0.411479, 0.145367],
    [0.970919, 0.522853, 0.058367],
    [0.987622, 0.645320, 0.039886],
    [0.978806, 0.774545, 0.176037],
    [0.950018, 0.903409, 0.380271],
    [0.988362, 0.998364, 0.644924],
];

/// Matplotlib's *inferno* colour map at `t` (clamped to `[0, 1]`, NaN → 0), as sRGB in `[0, 1]`:
/// black at 0, pale yellow at 1, lightness and luminance rising all the way. Interpolated
/// linearly (in sRGB) between 16 stops of matplotlib's 256-entry table, within 6.1/255 of it.
pub fn inferno(t: f32) -> [f32; 3] {
    let t = if t.is_nan() { 0.0 } else { t.clamp(0.0, 1.0) };
    let x = t * (INFERNO.len() - 1) as f32;
    let k = (x as usize).min(INFERNO.len() - 2);
    let f = x - k as f32;
    let (lo, hi) = (INFERNO[k], INFERNO[k + 1]);
    [0, 1, 2].map(|c| lo[c] + (hi[c] - lo[c]) * f)
}

/// A false-colour picture of per-pixel `values` (e.g. an [`error_map`]): `value / scale` through
/// [`inferno`], so 0 is black and `scale` or more the top colour (pale yellow). The image has
/// linear `R`, `G`, `B` channels whose 8-bit sRGB encoding ([`crate::write_png`]) gives the colour
/// map's sRGB colours. Errors: `values.len() != width · height`, or a `scale` that is not a
/// positive finite number.
pub fn false_colour(values: &[f32], width: u32, height: u32, scale: f32) -> Result<Image, ImageError> {
    if !(scale.is_finite() && scale > 0.0) {
        return Err(ImageError::mismatch(format!("the colour-map scale must be positive and finite, not {scale}")));
    }
    let count = width as usize * height as usize;
    if values.len() != count {
        return Err(ImageError::mismatch(format!(
            "{} values for a {width}x{height} false-colour image, which needs {count}",
            values.len()
        )));
    }
    let colours: Vec<[f32; 3]> = values.iter().map(|&v| inferno(v / scale).map(srgb_to_linear)).collect();
    Ok(Image::from_rgb(width, height, &colours))
}

/// Mean SSIM of two single-channel planes with values in `[0, 1]` (L = 1).
pub fn ssim_planes(x: &[f64], y: &[f64], width: usize, height: usize) -> f64 {
    assert!(x.len() == width * height && y.len() == width * height, "ssim_planes: wrong plane sizes");
    if x.is_empty() {
        return 1.0;
    }
    const C1: f64 = 0.01 * 0.01;
    const C2: f64 = 0.03 * 0.03;
    let blur = |p: &[f64]| gaussian_blur(p, width, height);
    let xx: Vec<f64> = x.iter().map(|v| v * v).collect();
    let yy: Vec<f64> = y.iter().map(|v| v * v).collect();
    let xy: Vec<f64> = x.iter().zip(y).map(|(a, b)| a * b).collect();
    let (mx, my, sxx, syy, sxy) = (blur(x), blur(y), blur(&xx), blur(&yy), blur(&xy));
    let mut total = 0.0;
    for i in 0..x.len() {
        let (mx, my) = (mx[i], my[i]);
        let var_x = sxx[i] - mx * mx;
        let var_y = syy[i] - my * my;
        let cov = sxy[i] - mx * my;
        total += ((2.0 * mx * my + C1) * (2.0 * cov + C2)) / ((mx * mx + my * my + C1) * (var_x + var_y + C2));
    }
    total / x.len() as f64
}

fn rgb_metric(a: &Image, b: &Image, metric: fn(&[f32], &[f32]) -> f64) -> Result<f64, ImageError> {
    same_size(a, b)?;
    let (ar, ag, ab) = rgb_of(a, "first")?;
    let (br, bg, bb) = rgb_of(b, "second")?;
    let n = a.pixel_count();
    if n == 0 {
        return Ok(0.0);
    }
    // Equal weights per plane: the mean over all 3n values.
    Ok((metric(ar, br) + metric(ag, bg) + metric(ab, bb)) / 3.0)
}

fn same_size(a: &Image, b: &Image) -> Result<(), ImageError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(ImageError::mismatch(format!(
            "cannot compare a {}x{} image with a {}x{} image",
            a.width, a.height, b.width, b.height
        )));
    }
    a.validate()?;
    b.validate()
}

fn rgb_of<'a>(image: &'a Image, which: &str) -> Result<RgbPlanes<'a>, ImageError> {
    image.rgb_planes().ok_or_else(|| ImageError::mismatch(format!("the {which} image has no R, G, B channels")))
}

fn encode_pair(a: &Image, b: &Image) -> Result<(Vec<u8>, Vec<u8>), ImageError> {
    same_size(a, b)?;
    rgb_of(a, "first")?;
    rgb_of(b, "second")?;
    let options = PngOptions::default();
    Ok((encode_srgb8(a, &options)?, encode_srgb8(b, &options)?))
}

/// MSE of two equally long code slices (0..255 scale); integer sums, so exact up to the division.
fn mse_codes(a: &[u8], b: &[u8]) -> f64 {
    let sum: u64 = a.iter().zip(b).map(|(&x, &y)| u64::from(x.abs_diff(y)).pow(2)).sum();
    if a.is_empty() { 0.0 } else { sum as f64 / a.len() as f64 }
}

/// [`ssim`] of two interleaved RGB encodings of images the size of `like`.
fn ssim_codes(a: &[u8], b: &[u8], like: &Image) -> f64 {
    ssim_planes(&luma(a), &luma(b), like.width as usize, like.height as usize)
}

/// Rec. 709 luma of interleaved 8-bit sRGB, in `[0, 1]`.
fn luma(rgb8: &[u8]) -> Vec<f64> {
    rgb8.chunks_exact(3)
        .map(|p| (0.2126 * f64::from(p[0]) + 0.7152 * f64::from(p[1]) + 0.0722 * f64::from(p[2])) / 255.0)
        .collect()
}

/// Separable 11-tap Gaussian (σ = 1.5), cut at the borders and renormalised per pixel. The
/// cut 2-D window is the product of the cut 1-D ones, so renormalising each pass is exact.
fn gaussian_blur(plane: &[f64], width: usize, height: usize) -> Vec<f64> {
    const RADIUS: isize = 5;
    const SIGMA: f64 = 1.5;
    let weights: Vec<f64> = (-RADIUS..=RADIUS).map(|d| (-((d * d) as f64) / (2.0 * SIGMA * SIGMA)).exp()).collect();
    let pass = |src: &[f64], len: usize, count: usize, at: &dyn Fn(usize, usize) -> usize| {
        let mut out = vec![0.0; src.len()];
        for line in 0..count {
            for i in 0..len {
                let (mut sum, mut norm) = (0.0, 0.0);
                for (k, w) in weights.iter().enumerate() {
                    let j = i as isize + k as isize - RADIUS;
                    if (0..len as isize).contains(&j) {
                        sum += w * src[at(line, j as usize)];
                        norm += w;
                    }
                }
                out[at(line, i)] = sum / norm;
            }
        }
        out
    };
    let horizontal = pass(plane, width, height, &|y, x| y * width + x);
    pass(&horizontal, height, width, &|x, y| y * width + x)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gradient(w: u32, h: u32, phase: f32) -> Image {
        let pixels: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let (x, y) = ((i % w) as f32, (i / w) as f32);
                [(x * 0.3 + phase).sin() * 0.4 + 0.5, y / h as f32, ((x + y) * 0.7).cos() * 0.25 + 0.3]
            })
            .collect();
        Image::from_rgb(w, h, &pixels)
    }

    #[test]
    fn mse_and_rel_mse() {
        let a = [0.0f32, 1.0, 2.0, 3.0];
        assert_eq!(mse(&a, &a), 0.0);
        assert_eq!(mse(&a, &[1.0, 1.0, 2.0, 1.0]), (1.0 + 4.0) / 4.0);
        assert_eq!(mse(&[], &[]), 0.0);
        assert_eq!(rel_mse(&a, &a), 0.0);
        let r = rel_mse(&[2.0], &[1.0]);
        assert!((r - 1.0 / 1.01).abs() < 1e-12, "{r}");
    }

    #[test]
    fn psnr_known_values() {
        assert_eq!(psnr(0.0, 1.0), f64::INFINITY);
        assert!((psnr(0.01, 1.0) - 20.0).abs() < 1e-12);
        assert!((psnr(1.0, 255.0) - 48.130_803_608_679_1).abs() < 1e-9);
        // One 8-bit step of error on every value: 20 log10(255).
        let a = Image::from_rgb(1, 1, &[[0.0; 3]]);
        let one_step = glint_core::colour::srgb_to_linear(1.0 / 255.0);
        let b = Image::from_rgb(1, 1, &[[one_step; 3]]);
        let p = psnr_srgb8(&a, &b).expect("psnr");
        assert!((p - 20.0 * 255f64.log10()).abs() < 1e-9, "{p}");
        assert_eq!(psnr_srgb8(&a, &a).expect("same"), f64::INFINITY);
    }

    #[test]
    fn image_mse() {
        let a = Image::from_rgb(2, 1, &[[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]]);
        let b = Image::from_rgb(2, 1, &[[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]]);
        assert_eq!(mse_rgb(&a, &a).expect("same"), 0.0);
        assert!((mse_rgb(&a, &b).expect("diff") - 1.0 / 6.0).abs() < 1e-12);
        assert!(rel_mse_rgb(&a, &b).expect("rel") > 0.0);
    }

    #[test]
    fn ssim_identical_is_one_and_different_less() {
        for (w, h) in [(1, 1), (7, 3), (40, 30)] {
            let a = gradient(w, h, 0.0);
            let s = ssim(&a, &a).expect("ssim");
            assert!((s - 1.0).abs() < 1e-12, "{w}x{h}: {s}");
        }
        let a = gradient(40, 30, 0.0);
        let b = gradient(40, 30, 1.0);
        let s = ssim(&a, &b).expect("ssim");
        assert!(s < 0.99, "{s}");
        // Noise lowers SSIM less than a large structural change, more than nothing.
        let mut noisy = a.clone();
        for (i, v) in noisy.channels[0].data.iter_mut().enumerate() {
            *v += if i % 2 == 0 { 0.02 } else { -0.02 };
        }
        let n = ssim(&a, &noisy).expect("noisy");
        assert!(s < n && n < 1.0, "structural {s}, noise {n}");
    }

    #[test]
    fn ssim_matches_brute_force_window() {
        // Direct evaluation of the cut-and-renormalised 11x11 Gaussian window at every pixel.
        let (w, h) = (13usize, 9usize);
        let x: Vec<f64> = (0..w * h).map(|i| ((i * 37) % 101) as f64 / 100.0).collect();
        let y: Vec<f64> = (0..w * h).map(|i| ((i * 53 + 7) % 97) as f64 / 96.0).collect();
        let g = |d: isize| (-((d * d) as f64) / 4.5).exp();
        let mut total = 0.0;
        for py in 0..h as isize {
            for px in 0..w as isize {
                let (mut s, mut m) = ([0.0f64; 5], 0.0);
                for qy in (py - 5).max(0)..=(py + 5).min(h as isize - 1) {
                    for qx in (px - 5).max(0)..=(px + 5).min(w as isize - 1) {
                        let wt = g(qx - px) * g(qy - py);
                        let (a, b) = (x[(qy as usize) * w + qx as usize], y[(qy as usize) * w + qx as usize]);
                        for (acc, v) in s.iter_mut().zip([a, b, a * a, b * b, a * b]) {
                            *acc += wt * v;
                        }
                        m += wt;
                    }
                }
                let [mx, my, xx, yy, xy] = s.map(|v| v / m);
                let (c1, c2) = (1e-4, 9e-4);
                total += ((2.0 * mx * my + c1) * (2.0 * (xy - mx * my) + c2))
                    / ((mx * mx + my * my + c1) * (xx - mx * mx + yy - my * my + c2));
            }
        }
        let expected = total / (w * h) as f64;
        let got = ssim_planes(&x, &y, w, h);
        assert!((got - expected).abs() < 1e-12, "{got} vs {expected}");
    }

    #[test]
    fn size_and_channel_mismatch_are_errors() {
        let a = gradient(4, 4, 0.0);
        let b = gradient(4, 5, 0.0);
        assert!(matches!(mse_rgb(&a, &b), Err(ImageError::Mismatch { .. })));
        assert!(matches!(psnr_srgb8(&a, &b), Err(ImageError::Mismatch { .. })));
        assert!(matches!(ssim(&a, &b), Err(ImageError::Mismatch { .. })));
        let mut z = Image::new(4, 4);
        z.add_channel("Z", vec![0.0; 16]).expect("Z");
        let err = mse_rgb(&a, &z).expect_err("no rgb");
        assert!(err.to_string().contains("second image has no R, G, B"), "{err}");
    }

    /// Values that are multiples of 1/64 in [0, 0.75]: adding 0.125 is exact in f32.
    fn steps(w: u32, h: u32) -> Image {
        let pixels: Vec<[f32; 3]> = (0..w * h)
            .map(|i| [(i % 49) as f32 / 64.0, (i * 7 % 49) as f32 / 64.0, (i * 3 % 49) as f32 / 64.0])
            .collect();
        Image::from_rgb(w, h, &pixels)
    }

    fn offset(image: &Image, d: f32) -> Image {
        let mut out = image.clone();
        for c in &mut out.channels {
            c.data.iter_mut().for_each(|v| *v += d);
        }
        out
    }

    #[test]
    fn compare_identical_images_is_perfect() {
        for (w, h) in [(1, 1), (9, 4), (40, 30)] {
            let a = gradient(w, h, 0.3);
            let r = compare(&a, &a).expect("compare");
            assert_eq!((r.mse, r.mse_srgb8, r.rel_mse), (0.0, 0.0, 0.0), "{w}x{h}");
            assert_eq!((r.psnr, r.psnr_srgb8), (f64::INFINITY, f64::INFINITY), "{w}x{h}");
            assert!((r.ssim - 1.0).abs() < 1e-12, "{w}x{h}: {}", r.ssim);
        }
    }

    #[test]
    fn compare_known_offset_gives_exact_errors() {
        let a = steps(11, 7);
        let b = offset(&a, 0.125);
        let r = compare(&a, &b).expect("compare");
        assert_eq!(r.mse, 0.015625);
        assert_eq!(r.psnr, 10.0 * (1.0 / 0.015625f64).log10());
        assert_eq!(r, compare(&b, &a).map(|s| ErrorReport { rel_mse: r.rel_mse, ..s }).expect("swapped"));
        // relMSE by its definition, per value against the reference b.
        let (ra, rb) = (a.rgb().expect("rgb"), b.rgb().expect("rgb"));
        let expected: f64 = ra
            .iter()
            .flatten()
            .zip(rb.iter().flatten())
            .map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2) / (f64::from(y).powi(2) + REL_MSE_EPSILON))
            .sum::<f64>()
            / (3 * ra.len()) as f64;
        assert!((r.rel_mse - expected).abs() < 1e-15, "{} vs {expected}", r.rel_mse);
        // Every 8-bit code 3 steps apart: MSE 9 on the 0..255 scale, PSNR 10 log10(255² / 9).
        let code = |k: u32| srgb_to_linear(k as f32 / 255.0);
        let a8: Vec<[f32; 3]> = (0..60).map(|i| [code(i), code(2 * i + 5), code(250 - 3 * i)]).collect();
        let b8: Vec<[f32; 3]> = (0..60).map(|i| [code(i + 3), code(2 * i + 2), code(252 - 3 * i - 5)]).collect();
        let (a8, b8) = (Image::from_rgb(10, 6, &a8), Image::from_rgb(10, 6, &b8));
        let r8 = compare(&a8, &b8).expect("compare 8-bit");
        assert_eq!(r8.mse_srgb8, 9.0);
        assert_eq!(mse_srgb8(&a8, &b8).expect("mse8"), 9.0);
        assert_eq!(r8.psnr_srgb8, psnr(9.0, 255.0));
        assert_eq!(r8.psnr_srgb8, psnr_srgb8(&a8, &b8).expect("psnr8"));
        assert_eq!(r8.ssim, ssim(&a8, &b8).expect("ssim"));
        // Values above 1 clamp to code 255 before the sRGB metrics.
        let bright = Image::from_rgb(1, 1, &[[1.0, 1.0, 1.0]]);
        let brighter = Image::from_rgb(1, 1, &[[4.0, 2.0, 1.5]]);
        let r = compare(&bright, &brighter).expect("clamped");
        assert_eq!((r.mse_srgb8, r.psnr_srgb8), (0.0, f64::INFINITY));
        assert!(r.mse > 0.0);
    }

    #[test]
    fn rel_mse_symmetric_cases() {
        let reference = [0.0f32, 0.125, 0.5, 2.0, 10.0]; // ± 0.25 stays exact in f32
        let plus: Vec<f32> = reference.iter().map(|r| r + 0.25).collect();
        let minus: Vec<f32> = reference.iter().map(|r| r - 0.25).collect();
        // An error of +d and one of -d weigh the same: the denominator is the reference's.
        assert_eq!(rel_mse(&plus, &reference), rel_mse(&minus, &reference));
        // Swapping test and reference changes relMSE in general...
        let (a, b) = ([0.2f32, 0.2], [0.5f32, 0.5]);
        assert!(rel_mse(&a, &b) < rel_mse(&b, &a));
        // ...but not when the pairs swap among themselves, nor when a is -r.
        let (a, b) = ([0.2f32, 0.5], [0.5f32, 0.2]);
        assert_eq!(rel_mse(&a, &b), rel_mse(&b, &a));
        let neg: Vec<f32> = reference.iter().map(|r| -r).collect();
        assert_eq!(rel_mse(&neg, &reference), rel_mse(&reference, &neg));
        // A zero reference divides by ε alone: (0.1)² / 0.01 = 1.
        assert!((rel_mse(&[0.1], &[0.0]) - 1.0).abs() < 1e-7);
        // Scale invariance for bright values: the same relative error, about the same relMSE.
        let (x, y) = (rel_mse(&[110.0], &[100.0]), rel_mse(&[1100.0], &[1000.0]));
        assert!((x - y).abs() < 1e-6 && (x - 0.01).abs() < 1e-6, "{x} {y}");
    }

    #[test]
    fn compare_rejects_non_finite_values_and_mismatches() {
        let a = steps(5, 3);
        let mut b = a.clone();
        b.channel_mut("G").expect("G")[7] = f32::NAN;
        b.channel_mut("B").expect("B")[12] = f32::INFINITY;
        let bad = first_non_finite_rgb(&b).expect("found");
        assert_eq!((bad.x, bad.y, bad.channel), (2, 1, "G"));
        assert_eq!(bad.to_string(), "pixel (2, 1) channel G is NaN");
        let err = compare(&a, &b).expect_err("NaN");
        assert!(err.to_string().contains("second image") && err.to_string().contains("(2, 1) channel G"), "{err}");
        // The same pixel: R before G before B.
        b.channel_mut("R").expect("R")[7] = f32::NEG_INFINITY;
        let bad = first_non_finite_rgb(&b).expect("found");
        assert_eq!((bad.channel, bad.to_string()), ("R", "pixel (2, 1) channel R is -inf".to_string()));
        assert!(first_non_finite_rgb(&a).is_none());
        // Other channels (a render's Z is +inf where nothing was hit) are not looked at.
        let mut z = a.clone();
        z.add_channel("Z", vec![f32::INFINITY; 15]).expect("Z");
        assert!(first_non_finite_rgb(&z).is_none());
        assert_eq!(compare(&z, &a).expect("Z ignored").mse, 0.0);
        assert!(matches!(compare(&a, &steps(3, 5)), Err(ImageError::Mismatch { .. })));
        assert!(matches!(compare(&a, &Image::new(5, 3)), Err(ImageError::Mismatch { .. })));
    }

    #[test]
    fn error_map_is_per_pixel_rms_and_averages_to_mse() {
        let a = Image::from_rgb(2, 1, &[[0.0, 0.0, 0.0], [1.0, 2.0, 3.0]]);
        let b = Image::from_rgb(2, 1, &[[0.0, 0.0, 0.0], [4.0, 2.0, 3.0]]);
        assert_eq!(error_map(&a, &b).expect("map"), [0.0, 3.0f32.sqrt()]);
        let (a, b) = (gradient(23, 17, 0.0), gradient(23, 17, 0.8));
        let map = error_map(&a, &b).expect("map");
        assert_eq!(map, error_map(&b, &a).expect("swapped"));
        let mean_square = map.iter().map(|&e| f64::from(e).powi(2)).sum::<f64>() / map.len() as f64;
        assert!((mean_square - mse_rgb(&a, &b).expect("mse")).abs() < 1e-7);
        assert!(error_map(&a, &gradient(17, 23, 0.0)).is_err());
    }

    #[test]
    fn percentile_by_nearest_rank() {
        let values: Vec<f32> = (1..=100).rev().map(|v| v as f32).collect();
        assert_eq!(percentile(&values, 99.0), 99.0);
        assert_eq!(percentile(&values, 50.0), 50.0);
        assert_eq!(percentile(&values, 100.0), 100.0);
        assert_eq!(percentile(&values, 0.0), 1.0);
        assert_eq!(percentile(&values, 0.5), 1.0);
        assert_eq!(percentile(&[3.0, 1.0, 2.0], 50.0), 2.0);
        assert_eq!(percentile(&[7.0], 99.0), 7.0);
        assert_eq!(percentile(&[], 99.0), 0.0);
    }

    #[test]
    fn diff_scale_falls_back_to_the_maximum_then_one() {
        let mut errors = vec![0.0f32; 1000];
        assert_eq!(diff_scale(&errors), 1.0);
        errors[5] = 0.5;
        assert_eq!(diff_scale(&errors), 0.5, "fewer than 1 % differ: the maximum");
        for e in errors.iter_mut().take(100) {
            *e = 0.25;
        }
        errors[5] = 9.0;
        assert_eq!(diff_scale(&errors), 0.25, "the 99th percentile ignores the outlier");
    }

    #[test]
    fn inferno_runs_from_black_to_pale_yellow_ever_brighter() {
        assert_eq!(inferno(0.0), INFERNO[0]);
        assert_eq!(inferno(1.0), INFERNO[15]);
        assert_eq!(inferno(-3.0), INFERNO[0]);
        assert_eq!(inferno(7.0), INFERNO[15]);
        assert_eq!(inferno(f32::NAN), INFERNO[0]);
        assert_eq!(inferno(1.0 / 15.0), INFERNO[1]);
        let mid = inferno(0.5 / 15.0);
        for c in 0..3 {
            assert!((mid[c] - 0.5 * (INFERNO[0][c] + INFERNO[1][c])).abs() < 1e-6);
        }
        let luminance = |c: [f32; 3]| {
            let [r, g, b] = c.map(srgb_to_linear);
            0.2126 * r + 0.7152 * g + 0.0722 * b
        };
        let mut previous = -1.0;
        for i in 0..=1000 {
            let y = luminance(inferno(i as f32 / 1000.0));
            assert!(y > previous, "luminance falls at t = {}", i as f32 / 1000.0);
            previous = y;
        }
    }

    #[test]
    fn false_colour_maps_zero_to_black_and_the_scale_to_the_top() {
        let image = false_colour(&[0.0, 0.1, 0.2, 5.0], 2, 2, 0.2).expect("image");
        let bytes = encode_srgb8(&image, &PngOptions::default()).expect("encode");
        let code = |c: [f32; 3]| c.map(|v| (v * 255.0).round() as u8);
        assert_eq!(bytes[0..3], code(INFERNO[0]));
        assert_eq!(bytes[3..6], code(inferno(0.5)));
        assert_eq!(bytes[6..9], code(INFERNO[15]));
        assert_eq!(bytes[9..12], code(INFERNO[15]));
        assert!(false_colour(&[0.0; 3], 2, 2, 1.0).is_err());
        for scale in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert!(false_colour(&[0.0; 4], 2, 2, scale).is_err(), "{scale}");
        }
    }
}
