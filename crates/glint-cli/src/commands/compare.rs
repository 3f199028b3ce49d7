//! `glint compare A B`: how far image A is from the reference B (docs/compare.md).
//!
//! The numbers are glint-image's (`metrics::compare`); this module reads the two files, checks
//! them with errors that name the file (readable, R/G/B present, same size, finite values),
//! writes the optional false-colour diff and prints a table or one JSON object. Every check runs
//! before anything is written, and the diff is written atomically, so a failed comparison never
//! replaces an existing file.

use crate::cli::CompareArgs;
use anyhow::{Context, Result, anyhow, bail};
use glint_image::metrics::{self, ErrorReport, REL_MSE_EPSILON};
use glint_image::ztest::{self, Variances, ZTest};
use glint_image::{Image, ImageError, PngOptions};
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// The diff image as written: where, and which error is the top of the colour map.
struct Diff<'a> {
    path: &'a Path,
    scale: f32,
    scale_is_default: bool,
}

pub fn run(args: &CompareArgs) -> Result<()> {
    if let Some(scale) = args.diff_scale
        && !(scale.is_finite() && scale > 0.0)
    {
        bail!("--diff-scale {scale}: must be a positive number");
    }
    if let Some(diff) = &args.diff {
        check_diff_path(diff, &[&args.image, &args.reference])?;
    }
    let image = load(&args.image)?;
    let reference = load(&args.reference)?;
    if (image.width, image.height) != (reference.width, reference.height) {
        bail!(
            "cannot compare {} ({}x{}) with {} ({}x{}): the images differ in size",
            args.image.display(),
            image.width,
            image.height,
            args.reference.display(),
            reference.width,
            reference.height
        );
    }
    let report = metrics::compare(&image, &reference)?;
    let ztest = match &args.ztest {
        Some(var) => Some(run_ztest(args, var, &image, &reference)?),
        None => None,
    };
    let diff = match &args.diff {
        Some(path) => Some(write_diff(path, &image, &reference, args.diff_scale)?),
        None => None,
    };
    let text = if args.json {
        json(args, &image, &report, diff.as_ref(), ztest.as_ref())
    } else {
        table(args, &image, &report, diff.as_ref(), ztest.as_ref())
    };
    // A closed pipe (`glint compare ... | head -1`) is an error, not a panic.
    std::io::stdout().write_all(text.as_bytes()).context("cannot write to standard output")?;
    match ztest {
        Some((t, _)) if !t.passed => bail!(
            "z-test failed: {:.3} % of the pixel-channels accepted (at least {} % needed)",
            100.0 * t.fraction,
            100.0 * ztest::PASS_FRACTION
        ),
        _ => Ok(()),
    }
}

/// The z-test of `--ztest VAR`: which variances it used, and its outcome.
fn run_ztest(args: &CompareArgs, var: &Path, image: &Image, reference: &Image) -> Result<(ZTest, &'static str)> {
    let reference_var = load(var)?;
    let full = glint_image::read_image(&args.image).map_err(flat)?;
    let own = ["Variance.R", "Variance.G", "Variance.B"].map(|n| full.channel(n).map(<[f32]>::to_vec));
    let spp = match args.spp {
        Some(n) => n,
        None => match full.channel("SampleCount") {
            Some(c) if !c.is_empty() => c.iter().map(|&v| f64::from(v)).sum::<f64>() / c.len() as f64,
            _ => bail!(
                "--ztest: {} has no SampleCount channel; say how many samples per pixel it has with --spp N",
                args.image.display()
            ),
        },
    };
    let own_image = match own {
        [Some(r), Some(g), Some(b)] => {
            let mut v = Image::new(image.width, image.height);
            for (name, data) in ["R", "G", "B"].into_iter().zip([r, g, b]) {
                v.add_channel(name, data).with_context(|| format!("{}: inconsistent image", args.image.display()))?;
            }
            Some(v)
        }
        _ => None,
    };
    let (variances, source) = match &own_image {
        Some(v) => (Variances::Own { image: v, spp, reference_spp: args.reference_spp }, "the image's own"),
        None => (Variances::ReferenceOnly { spp }, "the reference's (Mitsuba's form)"),
    };
    let t = ztest::z_test(image, reference, &reference_var, variances, ztest::SIGNIFICANCE)
        .map_err(|e| anyhow!("--ztest {}: {e}", var.display()))?;
    Ok((t, source))
}

/// Reads `path` and keeps its `R`, `G`, `B` planes (a lone `Y` is replicated), which must be
/// finite. Errors start with the path.
fn load(path: &Path) -> Result<Image> {
    let mut image = glint_image::read_image(path).map_err(flat)?;
    let names: Vec<String> = image.channels.iter().map(|c| c.name.clone()).collect();
    let has = |name: &str| names.iter().any(|n| n == name);
    let planes = if has("R") && has("G") && has("B") {
        ["R", "G", "B"].map(|name| take(&mut image, name))
    } else if has("Y") {
        let y = take(&mut image, "Y");
        [y.clone(), y.clone(), y]
    } else {
        bail!("{}: no R, G, B (or Y) channels to compare; the file has {}", path.display(), names.join(", "));
    };
    let mut rgb = Image::new(image.width, image.height);
    for (name, data) in ["R", "G", "B"].into_iter().zip(planes) {
        rgb.add_channel(name, data).with_context(|| format!("{}: inconsistent image", path.display()))?;
    }
    if let Some(bad) = metrics::first_non_finite_rgb(&rgb) {
        bail!("{}: {bad}; glint compare needs finite R, G, B values", path.display());
    }
    Ok(rgb)
}

/// glint-image's messages start with the file and already include their cause (an I/O error
/// prints its source), so they become one message: as a chain, `{:#}` would print the cause twice.
fn flat(e: ImageError) -> anyhow::Error {
    anyhow!("{e}")
}

/// Moves the channel `name` (known to exist) out of `image`.
fn take(image: &mut Image, name: &str) -> Vec<f32> {
    image.channels.iter_mut().find(|c| c.name == name).map(|c| std::mem::take(&mut c.data)).unwrap_or_default()
}

/// Refuses, before any work, a diff path glint cannot write or that is one of the inputs.
fn check_diff_path(diff: &Path, inputs: &[&Path]) -> Result<()> {
    let extension = diff.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if !matches!(extension.as_deref(), Some("png" | "jpg" | "jpeg" | "exr" | "hdr")) {
        bail!("--diff {}: unsupported image type (use .png, .jpg, .exr or .hdr)", diff.display());
    }
    if let Ok(target) = diff.canonicalize() {
        for input in inputs {
            if input.canonicalize().is_ok_and(|i| i == target) {
                bail!("--diff {}: is one of the images being compared; refusing to overwrite it", diff.display());
            }
        }
    }
    Ok(())
}

fn write_diff<'a>(path: &'a Path, image: &Image, reference: &Image, scale: Option<f32>) -> Result<Diff<'a>> {
    let errors = metrics::error_map(image, reference)?;
    let (scale, scale_is_default) = match scale {
        Some(s) => (s, false),
        None => (metrics::diff_scale(&errors), true),
    };
    let picture = metrics::false_colour(&errors, image.width, image.height, scale)?;
    glint_image::write_image(path, &picture, &PngOptions::default())
        .map_err(|e| anyhow!("cannot write the diff image: {e}"))?;
    Ok(Diff { path, scale, scale_is_default })
}

fn table(
    args: &CompareArgs,
    image: &Image,
    r: &ErrorReport,
    diff: Option<&Diff<'_>>,
    ztest: Option<&(ZTest, &str)>,
) -> String {
    let mut out = String::new();
    let mut row = |label: &str, value: String| {
        let _ = writeln!(out, "  {label:<34}{value}");
    };
    row("MSE, linear RGB", significant(r.mse));
    row("MSE, 8-bit sRGB (0..255 scale)", significant(r.mse_srgb8));
    row(&format!("relMSE, linear RGB (eps = {REL_MSE_EPSILON})"), significant(r.rel_mse));
    row("PSNR, linear RGB (peak 1)", decibels(r.psnr));
    row("PSNR, 8-bit sRGB (peak 255)", decibels(r.psnr_srgb8));
    row("SSIM, 8-bit sRGB luma", format!("{:.6}", r.ssim));
    if let Some(d) = diff {
        let source = if d.scale_is_default { "the 99th percentile" } else { "--diff-scale" };
        row(
            "diff image (inferno)",
            format!("{} (top colour: RMS RGB error {} = {source})", d.path.display(), significant(d.scale.into())),
        );
    }
    if let Some((t, source)) = ztest {
        row(
            "z-test (Mitsuba's render test)",
            format!(
                "{}: {}/{} pixel-channels accepted ({:.3} %, need {} %), alpha {:.3e}, variance: {source}",
                if t.passed { "PASS" } else { "FAIL" },
                t.accepted,
                t.tested,
                100.0 * t.fraction,
                100.0 * ztest::PASS_FRACTION,
                t.alpha
            ),
        );
        row(
            "z-test, least likely pixel",
            format!("({}, {}) {} z = {:.2}", t.worst.0, t.worst.1, ["X", "Y", "Z"][t.worst.2], t.worst.3),
        );
    }
    format!(
        "{} against the reference {} ({}x{})\n{out}",
        args.image.display(),
        args.reference.display(),
        image.width,
        image.height
    )
}

fn json(
    args: &CompareArgs,
    image: &Image,
    r: &ErrorReport,
    diff: Option<&Diff<'_>>,
    ztest: Option<&(ZTest, &str)>,
) -> String {
    let ztest = match ztest {
        Some((t, source)) => format!(
            "{{\"passed\":{},\"accepted\":{},\"tested\":{},\"fraction\":{},\"alpha\":{},\"variance\":{}}}",
            t.passed,
            t.accepted,
            t.tested,
            json_number(t.fraction),
            json_number(t.alpha),
            json_string(source)
        ),
        None => "null".to_string(),
    };
    let diff = match diff {
        Some(d) => format!(
            "{{\"path\":{},\"scale\":{},\"scale_is_default\":{}}}",
            json_string(&d.path.display().to_string()),
            json_number_f32(d.scale),
            d.scale_is_default
        ),
        None => "null".to_string(),
    };
    format!(
        "{{\"a\":{},\"b\":{},\"width\":{},\"height\":{},\"mse\":{},\"mse_srgb8\":{},\"rel_mse\":{},\
         \"rel_mse_epsilon\":{},\"psnr_db\":{},\"psnr_srgb8_db\":{},\"ssim\":{},\"diff\":{diff},\"ztest\":{ztest}}}\n",
        json_string(&args.image.display().to_string()),
        json_string(&args.reference.display().to_string()),
        image.width,
        image.height,
        json_number(r.mse),
        json_number(r.mse_srgb8),
        json_number(r.rel_mse),
        json_number(REL_MSE_EPSILON),
        json_number(r.psnr),
        json_number(r.psnr_srgb8),
        json_number(r.ssim),
    )
}

/// Six significant digits, plain for ordinary magnitudes, scientific for tiny or huge ones.
fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let exponent = v.abs().log10().floor() as i32;
    if (-4..6).contains(&exponent) { format!("{v:.*}", (5 - exponent).max(0) as usize) } else { format!("{v:.5e}") }
}

fn decibels(v: f64) -> String {
    if v == f64::INFINITY { "inf dB (identical)".to_string() } else { format!("{v:.2} dB") }
}

/// A JSON number that reads back as the same f64; JSON has no infinity, so ±∞ and NaN are
/// `null` (an infinite PSNR: the images are identical).
fn json_number(v: f64) -> String {
    if v.is_finite() { format!("{v:?}") } else { "null".to_string() }
}

/// [`json_number`] for an f32, printed as the shortest decimal that reads back as that f32
/// (`0.05`, not the f64 widening's `0.05000000074505806`).
fn json_number_f32(v: f32) -> String {
    if v.is_finite() { format!("{v:?}") } else { "null".to_string() }
}

fn json_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if u32::from(c) < 0x20 => {
                let _ = write!(out, "\\u{:04x}", u32::from(c));
            }
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_print_readably_and_json_stays_valid() {
        assert_eq!(significant(0.015625), "0.0156250");
        assert_eq!(significant(123.456789), "123.457");
        assert_eq!(significant(0.0), "0");
        assert_eq!(significant(1.5e-7), "1.50000e-7");
        assert_eq!(decibels(f64::INFINITY), "inf dB (identical)");
        assert_eq!(decibels(18.0618), "18.06 dB");
        assert_eq!(json_number(0.015625), "0.015625");
        assert_eq!(json_number(1e-20), "1e-20");
        assert_eq!(json_number(f64::INFINITY), "null");
        assert_eq!(json_number_f32(0.05), "0.05");
        assert_eq!(json_number_f32(1e-7), "1e-7");
        assert_eq!(json_string("a\"b\\c\nd.png"), "\"a\\\"b\\\\c\\u000ad.png\"");
    }
}
