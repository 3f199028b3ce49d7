//! Image difference metrics for tests, golden images and `glint compare`.
//!
//! - [`mse`]: mean of `(a − b)²`.
//! - [`rel_mse`]: mean of `(a − r)² / (r² + ε)` with ε = [`REL_MSE_EPSILON`] — the relative MSE
//!   used in rendering papers (e.g. Rousselle et al. 2011), insensitive to absolute brightness.
//! - [`psnr`]: `10 · log10(peak² / mse)` dB; `+∞` when `mse = 0`.
//! - [`psnr_srgb8`]: PSNR (peak 255) between the 8-bit sRGB encodings (clamp tone map, no
//!   exposure) — what a viewer of the PNGs would see.
//! - [`ssim`]: mean SSIM (Wang et al. 2004, eq. 13) on the Rec. 709 luma of the 8-bit sRGB
//!   encodings scaled to `[0, 1]`, with the paper's 11×11 Gaussian window (σ = 1.5), K1 = 0.01,
//!   K2 = 0.03, L = 1. At the borders the window is cut to the image and renormalised, so every
//!   pixel counts and images smaller than the window work.
//!
//! Slice metrics accumulate in f64 in index order (deterministic). Image metrics return
//! [`ImageError::Mismatch`] for different sizes or missing channels.

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

/// Relative MSE over the `R`, `G`, `B` planes of `a` against `reference`.
pub fn rel_mse_rgb(a: &Image, reference: &Image) -> Result<f64, ImageError> {
    rgb_metric(a, reference, rel_mse)
}

/// PSNR (dB, peak 255) between the 8-bit sRGB encodings of two images (clamp, exposure 0).
pub fn psnr_srgb8(a: &Image, b: &Image) -> Result<f64, ImageError> {
    let (a, b) = encode_pair(a, b)?;
    let sum: u64 = a.iter().zip(&b).map(|(&x, &y)| u64::from(x.abs_diff(y)).pow(2)).sum();
    let mse = if a.is_empty() { 0.0 } else { sum as f64 / a.len() as f64 };
    Ok(psnr(mse, 255.0))
}

/// Mean SSIM on luma of the 8-bit sRGB encodings (details in the module docs): 1 for identical
/// images, lower for different ones.
pub fn ssim(a: &Image, b: &Image) -> Result<f64, ImageError> {
    let (ea, eb) = encode_pair(a, b)?;
    let (w, h) = (a.width as usize, a.height as usize);
    Ok(ssim_planes(&luma(&ea), &luma(&eb), w, h))
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
}
