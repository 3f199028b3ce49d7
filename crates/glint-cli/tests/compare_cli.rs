//! `glint compare` end to end: the numbers it prints (table and JSON), the false-colour diff,
//! and bad input that fails cleanly without touching an existing diff file.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, scratch, stderr};

use glint_image::metrics::{self, mse_rgb};
use glint_image::{Image, PngOptions};
use serde_json::Value;
use std::path::Path;

/// Runs `glint args` in `dir`, asserts success, returns stdout.
fn ok(args: &[&str], dir: &Path) -> String {
    let o = glint(args, dir);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    String::from_utf8(o.stdout).expect("utf-8 output")
}

fn json(args: &[&str], dir: &Path) -> Value {
    let out = ok(args, dir);
    assert_eq!(out.lines().count(), 1, "one JSON object on one line: {out}");
    serde_json::from_str(&out).unwrap_or_else(|e| panic!("{e}: {out}"))
}

/// The value column of the table row starting with `label`.
fn row(out: &str, label: &str) -> String {
    let line = out.lines().find(|l| l.trim_start().starts_with(label)).unwrap_or_else(|| panic!("no {label}: {out}"));
    line.trim_start()[label.len()..].trim().to_string()
}

fn read(path: &Path) -> Image {
    glint_image::read_image(path).unwrap_or_else(|e| panic!("{e}"))
}

/// Linear values that are multiples of 1/64 in [0, 0.75]: `+ 0.125` stays exact in f32.
fn steps(w: u32, h: u32) -> Image {
    let pixels: Vec<[f32; 3]> =
        (0..w * h).map(|i| [(i % 49) as f32 / 64.0, (i * 7 % 49) as f32 / 64.0, (i * 3 % 49) as f32 / 64.0]).collect();
    Image::from_rgb(w, h, &pixels)
}

fn offset(image: &Image, d: f32) -> Image {
    let mut out = image.clone();
    for c in &mut out.channels {
        c.data.iter_mut().for_each(|v| *v += d);
    }
    out
}

/// A smooth picture in [0, 1] with some structure.
fn picture(w: u32, h: u32) -> Image {
    let pixels: Vec<[f32; 3]> = (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f32, (i / w) as f32);
            [(x * 0.21).sin() * 0.45 + 0.5, y / h as f32, ((x + y) * 0.37).cos() * 0.3 + 0.4]
        })
        .collect();
    Image::from_rgb(w, h, &pixels)
}

/// `image` moved one pixel to the right, wrapping around.
fn shifted(image: &Image) -> Image {
    let w = image.width as usize;
    let mut out = image.clone();
    for c in &mut out.channels {
        for row in c.data.chunks_mut(w) {
            row.rotate_right(1);
        }
    }
    out
}

#[test]
fn an_image_against_itself_is_perfect() {
    let d = scratch("compare-self");
    glint_image::write_png(&d.join("a.png"), &picture(40, 30), &PngOptions::default()).unwrap();
    let out = ok(&["compare", "a.png", "a.png"], &d);
    assert!(out.starts_with("a.png against the reference a.png (40x30)"), "{out}");
    assert_eq!(row(&out, "MSE, linear RGB"), "0");
    assert_eq!(row(&out, "MSE, 8-bit sRGB (0..255 scale)"), "0");
    assert_eq!(row(&out, "relMSE, linear RGB (eps = 0.01)"), "0");
    assert_eq!(row(&out, "PSNR, linear RGB (peak 1)"), "inf dB (identical)");
    assert_eq!(row(&out, "PSNR, 8-bit sRGB (peak 255)"), "inf dB (identical)");
    assert_eq!(row(&out, "SSIM, 8-bit sRGB luma"), "1.000000");
    let v = json(&["compare", "a.png", "a.png", "--json"], &d);
    assert_eq!((v["mse"].as_f64(), v["mse_srgb8"].as_f64(), v["rel_mse"].as_f64()), (Some(0.0), Some(0.0), Some(0.0)));
    assert!(v["psnr_db"].is_null() && v["psnr_srgb8_db"].is_null(), "an infinite PSNR is null: {v}");
    assert!((v["ssim"].as_f64().unwrap() - 1.0).abs() < 1e-12);
}

#[test]
fn a_known_offset_prints_its_mse() {
    let d = scratch("compare-offset");
    let a = steps(24, 16);
    glint_image::write_exr(&d.join("a.exr"), &a).unwrap();
    glint_image::write_exr(&d.join("b.exr"), &offset(&a, 0.125)).unwrap();
    let out = ok(&["compare", "a.exr", "b.exr"], &d);
    // 0.125² on every value.
    assert_eq!(row(&out, "MSE, linear RGB"), "0.0156250", "{out}");
    assert_eq!(row(&out, "PSNR, linear RGB (peak 1)"), "18.06 dB", "{out}");
    let v = json(&["compare", "a.exr", "b.exr", "--json"], &d);
    assert_eq!(v["mse"].as_f64(), Some(0.015625));
    assert!((v["psnr_db"].as_f64().unwrap() - 10.0 * 64f64.log10()).abs() < 1e-12, "{v}");
    // B is the reference: relMSE divides by B's values, so swapping changes it (and only it).
    let w = json(&["compare", "b.exr", "a.exr", "--json"], &d);
    assert_eq!(w["mse"], v["mse"]);
    assert_eq!(w["mse_srgb8"], v["mse_srgb8"]);
    assert!(w["rel_mse"].as_f64().unwrap() > v["rel_mse"].as_f64().unwrap(), "{v} {w}");
}

#[test]
fn a_shifted_copy_prints_the_metrics_of_glint_image() {
    let d = scratch("compare-shift");
    let a = picture(37, 23);
    glint_image::write_png(&d.join("a.png"), &a, &PngOptions::default()).unwrap();
    glint_image::write_png(&d.join("b.png"), &shifted(&a), &PngOptions::default()).unwrap();
    let (ra, rb) = (read(&d.join("a.png")), read(&d.join("b.png")));
    let expected = metrics::compare(&ra, &rb).unwrap();
    assert_eq!(expected.mse, mse_rgb(&ra, &rb).unwrap());
    assert!(expected.mse > 1e-4);
    let v = json(&["compare", "a.png", "b.png", "--json"], &d);
    assert_eq!(v["a"], "a.png");
    assert_eq!(v["b"], "b.png");
    assert_eq!((v["width"].as_u64(), v["height"].as_u64()), (Some(37), Some(23)));
    for (key, want) in [
        ("mse", expected.mse),
        ("mse_srgb8", expected.mse_srgb8),
        ("rel_mse", expected.rel_mse),
        ("rel_mse_epsilon", 0.01),
        ("psnr_db", expected.psnr),
        ("psnr_srgb8_db", expected.psnr_srgb8),
        ("ssim", expected.ssim),
    ] {
        let got = v[key].as_f64().unwrap_or_else(|| panic!("{key}: {v}"));
        assert!((got - want).abs() <= 1e-14 * want.abs(), "{key}: {got} vs {want}");
    }
    assert!(v["diff"].is_null());
    // The table shows the same numbers to six significant digits.
    let out = ok(&["compare", "a.png", "b.png"], &d);
    let printed: f64 = row(&out, "MSE, linear RGB").parse().unwrap();
    assert!((printed / expected.mse - 1.0).abs() < 1e-5, "{printed} vs {}", expected.mse);
    let printed: f64 = row(&out, "MSE, 8-bit sRGB (0..255 scale)").parse().unwrap();
    assert!((printed / expected.mse_srgb8 - 1.0).abs() < 1e-5, "{printed} vs {}", expected.mse_srgb8);
    // PNGs hold 8-bit codes, and the sRGB metric sees exactly those codes.
    let codes = |p: &str| image_codes(&d.join(p));
    let (ca, cb) = (codes("a.png"), codes("b.png"));
    let by_hand =
        ca.iter().zip(&cb).map(|(&x, &y)| (f64::from(x) - f64::from(y)).powi(2)).sum::<f64>() / ca.len() as f64;
    assert!((expected.mse_srgb8 - by_hand).abs() < 1e-9, "{} vs {by_hand}", expected.mse_srgb8);
}

/// The 8-bit codes of a PNG, re-encoded from the linear values glint reads (exact round trip).
fn image_codes(path: &Path) -> Vec<u8> {
    glint_image::encode_srgb8(&read(path), &PngOptions::default()).unwrap()
}

#[test]
fn diff_writes_a_false_colour_png_of_the_same_size() {
    let d = scratch("compare-diff");
    let a = steps(30, 20);
    let mut b = a.clone();
    // One pixel far off, the lower half off by 1/32 in G (exact in f32), the rest identical.
    b.channel_mut("R").unwrap()[0] += 1.0;
    for v in &mut b.channel_mut("G").unwrap()[10 * 30..] {
        *v += 0.03125;
    }
    glint_image::write_exr(&d.join("a.exr"), &a).unwrap();
    glint_image::write_exr(&d.join("b.exr"), &b).unwrap();
    let v = json(&["compare", "a.exr", "b.exr", "--diff", "d.png", "--json"], &d);
    let diff = read(&d.join("d.png"));
    assert_eq!((diff.width, diff.height), (30, 20));
    assert_eq!(v["diff"]["path"], "d.png");
    assert_eq!(v["diff"]["scale_is_default"], true);
    // The default scale is the 99th percentile: the block's error, not the outlier's.
    let block = (0.03125f64 * 0.03125 / 3.0).sqrt();
    let scale = v["diff"]["scale"].as_f64().unwrap();
    assert!((scale - block).abs() < 1e-6, "{scale} vs {block}");
    let codes = glint_image::encode_srgb8(&diff, &PngOptions::default()).unwrap();
    let at = |x: usize, y: usize| &codes[3 * (y * 30 + x)..3 * (y * 30 + x) + 3];
    let black = at(5, 5).to_vec();
    let top = at(5, 15).to_vec();
    assert!(black.iter().all(|&c| c < 8), "no error is black: {black:?}");
    // inferno's top, pale yellow: sRGB (0.988362, 0.998364, 0.644924).
    assert_eq!(top, [252, 255, 164], "the scale is the top colour");
    assert_eq!(at(0, 0), &top[..], "beyond the scale: clamped to the top");
    // An explicit scale: the block now sits half-way up the map, darker than the top.
    let v = json(
        &["compare", "a.exr", "b.exr", "--diff", "d.png", "--diff-scale", &(2.0 * block).to_string(), "--json"],
        &d,
    );
    assert_eq!(v["diff"]["scale_is_default"], false);
    let codes = glint_image::encode_srgb8(&read(&d.join("d.png")), &PngOptions::default()).unwrap();
    let half = &codes[3 * (15 * 30 + 5)..3 * (15 * 30 + 5) + 3];
    assert!(half[1] < top[1] - 60, "{half:?} vs {top:?}");
    // The table names the diff and its scale.
    let out = ok(&["compare", "a.exr", "b.exr", "--diff", "d.png"], &d);
    assert!(row(&out, "diff image (inferno)").starts_with("d.png (top colour: RMS RGB error"), "{out}");
}

#[test]
fn exr_with_many_channels_uses_rgb() {
    let d = scratch("compare-aovs");
    let mut a = picture(16, 8);
    a.add_channel("A", vec![1.0; 128]).unwrap();
    a.add_channel("Z", vec![f32::INFINITY; 128]).unwrap(); // a render's depth where nothing was hit
    a.add_channel("Albedo.R", vec![f32::NAN; 128]).unwrap();
    glint_image::write_exr(&d.join("film.exr"), &a).unwrap();
    glint_image::write_exr(&d.join("plain.exr"), &picture(16, 8)).unwrap();
    let v = json(&["compare", "film.exr", "plain.exr", "--json"], &d);
    assert_eq!(v["mse"].as_f64(), Some(0.0));
    // A grey (Y-only) EXR is compared as R = G = B = Y.
    let mut y = Image::new(16, 8);
    y.add_channel("Y", vec![0.5; 128]).unwrap();
    glint_image::write_exr(&d.join("y.exr"), &y).unwrap();
    glint_image::write_exr(&d.join("grey.exr"), &Image::from_rgb(16, 8, &[[0.5; 3]; 128])).unwrap();
    let v = json(&["compare", "y.exr", "grey.exr", "--json"], &d);
    assert_eq!(v["mse"].as_f64(), Some(0.0));
}

/// Every failing comparison: non-zero exit, a message naming the file and the problem, no
/// panic, and an existing diff file (out.png) left as it was.
#[test]
fn bad_input_fails_cleanly_without_touching_the_diff() {
    let d = scratch("compare-bad");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    let a = picture(20, 10);
    glint_image::write_png(&d.join("a.png"), &a, &PngOptions::default()).unwrap();
    glint_image::write_png(&d.join("b.png"), &shifted(&a), &PngOptions::default()).unwrap();
    glint_image::write_png(&d.join("small.png"), &picture(10, 20), &PngOptions::default()).unwrap();
    let mut nan = a.clone();
    nan.channel_mut("G").unwrap()[2 * 20 + 3] = f32::NAN;
    nan.channel_mut("B").unwrap()[5 * 20 + 1] = f32::INFINITY;
    glint_image::write_exr(&d.join("nan.exr"), &nan).unwrap();
    let mut inf = a.clone();
    inf.channel_mut("R").unwrap()[9 * 20 + 19] = f32::NEG_INFINITY;
    glint_image::write_exr(&d.join("inf.exr"), &inf).unwrap();
    let mut depth = Image::new(20, 10);
    depth.add_channel("Z", vec![1.0; 200]).unwrap();
    glint_image::write_exr(&d.join("depth.exr"), &depth).unwrap();
    std::fs::write(d.join("garbage.png"), b"not a png, just some text").unwrap();
    let bytes = std::fs::read(d.join("a.png")).unwrap();
    std::fs::write(d.join("cut.png"), &bytes[..bytes.len() / 2]).unwrap();
    let diff = ["--diff", "out.png"];
    let with_diff = |args: &[&'static str]| -> Vec<&'static str> {
        let mut v = vec!["compare"];
        v.extend_from_slice(args);
        v.extend_from_slice(&diff);
        v
    };
    let cases: &[(Vec<&str>, &str)] = &[
        (with_diff(&["a.png", "small.png"]), "a.png (20x10) with small.png (10x20)"),
        (with_diff(&["small.png", "a.png"]), "differ in size"),
        (with_diff(&["missing.png", "a.png"]), "missing.png"),
        (with_diff(&["a.png", "missing.exr"]), "missing.exr"),
        (with_diff(&["garbage.png", "a.png"]), "garbage.png"),
        (with_diff(&["a.png", "cut.png"]), "cut.png"),
        (with_diff(&["nan.exr", "a.png"]), "nan.exr: pixel (3, 2) channel G is NaN"),
        (with_diff(&["a.png", "nan.exr"]), "nan.exr: pixel (3, 2) channel G is NaN"),
        (with_diff(&["a.png", "inf.exr"]), "inf.exr: pixel (19, 9) channel R is -inf"),
        (with_diff(&["depth.exr", "a.png"]), "depth.exr: no R, G, B"),
        (with_diff(&["a.png", "b.png", "--diff-scale", "0"]), "--diff-scale"),
        (with_diff(&["a.png", "b.png", "--diff-scale", "-1"]), "--diff-scale"),
        (with_diff(&["a.png", "b.png", "--diff-scale", "nan"]), "--diff-scale"),
        (with_diff(&["a.png", "b.png", "--diff-scale", "inf"]), "--diff-scale"),
        (vec!["compare", "a.png", "b.png", "--diff-scale", "1"], "--diff"),
        (vec!["compare", "a.png", "b.png", "--diff", "out.tiff"], "out.tiff"),
        (vec!["compare", "a.png", "b.png", "--diff", "no/such/dir/out.png"], "out.png"),
        (vec!["compare", "a.png"], "B"),
    ];
    for (args, needle) in cases {
        assert_fails_cleanly(args, needle, &d);
    }
    // A missing file is named once, with its cause once.
    let msg = stderr(&glint(&["compare", "missing.png", "a.png"], &d));
    assert_eq!(msg.matches("missing.png").count(), 1, "{msg}");
    assert_eq!(msg.matches("No such file").count(), 1, "{msg}");
    // --diff naming one of the inputs is refused, and the input survives.
    let b_bytes = std::fs::read(d.join("b.png")).unwrap();
    assert_fails_cleanly(&["compare", "a.png", "b.png", "--diff", "./b.png"], "refusing to overwrite", &d);
    assert_eq!(std::fs::read(d.join("b.png")).unwrap(), b_bytes);
    // Nothing was left behind (temporary files, stray diffs).
    let mut names: Vec<String> =
        std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    assert_eq!(
        names,
        ["a.png", "b.png", "cut.png", "depth.exr", "garbage.png", "inf.exr", "nan.exr", "out.png", "small.png"]
    );
}

/// `--ztest VAR.exr`, as docs/compare.md shows it: an image within its own noise of the
/// reference passes (exit 0, PASS, the image's own variance and SampleCount used), a biased
/// one fails with exit status 1 after printing the numbers; without a variance layer the
/// reference's variance stands for both and `--spp` is required.
#[test]
fn ztest_passes_within_the_noise_and_fails_a_biased_image() {
    let d = scratch("compare-ztest");
    let (w, h) = (24u32, 16u32);
    let reference = picture(w, h);
    let mut var = Image::new(w, h);
    for name in ["R", "G", "B"] {
        var.add_channel(name, vec![0.04; (w * h) as usize]).unwrap();
    }
    glint_image::write_exr(&d.join("ref.exr"), &reference).unwrap();
    glint_image::write_exr(&d.join("ref_var.exr"), &var).unwrap();
    // A glint-like EXR: beauty, Variance.R/G/B and SampleCount (100 samples: σ of the mean 0.02).
    let with_layers = |beauty: &Image, name: &str| {
        let mut img = beauty.clone();
        for c in ["Variance.R", "Variance.G", "Variance.B"] {
            img.add_channel(c, vec![0.04; (w * h) as usize]).unwrap();
        }
        img.add_channel("SampleCount", vec![100.0; (w * h) as usize]).unwrap();
        glint_image::write_exr(&d.join(name), &img).unwrap();
    };
    with_layers(&offset(&reference, 0.01), "close.exr");
    with_layers(&offset(&reference, 0.2), "far.exr");
    let out = ok(&["compare", "close.exr", "ref.exr", "--ztest", "ref_var.exr"], &d);
    let z = row(&out, "z-test (Mitsuba's render test)");
    assert!(z.starts_with("PASS: 1152/1152") && z.contains("the image's own"), "{z}");
    let o = glint(&["compare", "far.exr", "ref.exr", "--ztest", "ref_var.exr", "--json"], &d);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    let v: Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["ztest"]["passed"], Value::Bool(false));
    assert_eq!(v["ztest"]["accepted"], 0);
    assert!(stderr(&o).contains("z-test failed"), "{}", stderr(&o));
    // A plain image: Mitsuba's form needs --spp.
    glint_image::write_exr(&d.join("plain.exr"), &offset(&reference, 0.01)).unwrap();
    let o = glint(&["compare", "plain.exr", "ref.exr", "--ztest", "ref_var.exr"], &d);
    assert!(!o.status.success() && stderr(&o).contains("--spp"), "{}", stderr(&o));
    let v = json(&["compare", "plain.exr", "ref.exr", "--ztest", "ref_var.exr", "--spp", "100", "--json"], &d);
    assert_eq!(v["ztest"]["passed"], Value::Bool(true));
    assert!(v["ztest"]["variance"].as_str().unwrap().contains("reference"));
    let v = json(&["compare", "plain.exr", "ref.exr", "--json"], &d);
    assert_eq!(v["ztest"], Value::Null);
}
