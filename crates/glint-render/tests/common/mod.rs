//! Helpers shared by glint-render's tests. Golden images (STYLE.md §6): references live in
//! tests/golden/ and change only by an explicit, reviewed regeneration (`GLINT_BLESS=1`); on
//! failure the actual image and a difference image are written under target/golden/.

#![allow(dead_code)] // each test file uses its own subset

use glint_image::{Image, PngOptions, encode_srgb8};
use glint_render::{RenderSettings, Schedule};
use std::path::PathBuf;

/// One ray per pixel, depth 8, seed 0, work stealing.
pub fn settings(w: u32, h: u32) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        samples_per_side: 1,
        max_depth: 8,
        min_contribution: 1e-3,
        seed: 0,
        schedule: Schedule::WorkStealing,
    }
}

pub fn golden_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/golden"))
}

/// Compares `image` (linear RGB) on 8-bit sRGB with tests/golden/`name`.png, or writes it there
/// when GLINT_BLESS is set. Tolerance: the computation is deterministic; what may differ
/// between machines is the SIMD kernel chosen at run time, which can move a silhouette pixel.
/// PSNR 40 dB and at most 0.5 % of pixels off by more than 8/255 allow that and nothing more.
pub fn assert_matches_golden(name: &str, image: &Image) {
    let (w, h) = (image.width, image.height);
    let reference_path = golden_dir().join(format!("{name}.png"));
    if std::env::var_os("GLINT_BLESS").is_some() {
        glint_image::write_png(&reference_path, image, &PngOptions::default()).expect("write golden image");
        return;
    }
    let reference = glint_image::read_image(&reference_path)
        .unwrap_or_else(|e| panic!("{e} (regenerate with GLINT_BLESS=1 cargo test -p glint-render)"));
    assert_eq!((reference.width, reference.height), (w, h), "{name}: size differs from the golden image");
    let ours = encode_srgb8(image, &PngOptions::default()).expect("encode");
    let theirs = encode_srgb8(&reference, &PngOptions::default()).expect("encode");
    let mut sq = 0.0f64;
    let mut bad = 0usize;
    let mut diff = vec![[0.0f32; 3]; (w * h) as usize];
    for (i, (a, b)) in ours.chunks(3).zip(theirs.chunks(3)).enumerate() {
        let mut worst = 0i32;
        for c in 0..3 {
            let d = a[c] as i32 - b[c] as i32;
            sq += (d * d) as f64;
            worst = worst.max(d.abs());
            diff[i][c] = d.abs() as f32 / 32.0;
        }
        if worst > 8 {
            bad += 1;
        }
    }
    let mse = sq / ours.len() as f64;
    let psnr = if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0f64 * 255.0 / mse).log10() };
    let bad_fraction = bad as f64 / (w * h) as f64;
    if psnr < 40.0 || bad_fraction > 0.005 {
        let out = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../target/golden"));
        std::fs::create_dir_all(&out).expect("create target/golden");
        glint_image::write_png(&out.join(format!("{name}-actual.png")), image, &PngOptions::default())
            .expect("write actual");
        glint_image::write_png(
            &out.join(format!("{name}-diff.png")),
            &Image::from_rgb(w, h, &diff),
            &PngOptions::default(),
        )
        .expect("write diff");
        panic!(
            "{name} differs from its golden image: PSNR {psnr:.1} dB, {:.2}% pixels off (see target/golden/)",
            bad_fraction * 100.0
        );
    }
}
