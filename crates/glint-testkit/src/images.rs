//! Image comparisons for tests (STYLE.md §6: golden images with honest tolerances). References
//! live in `tests/golden/` and change only by an explicit, reviewed regeneration
//! (`GLINT_BLESS=1`); on failure the actual image and a difference image are written under
//! `target/golden/`.

use glint_image::{Image, PngOptions, encode_srgb8};
use std::path::PathBuf;

/// The repository's golden images.
#[must_use]
pub fn golden_dir() -> PathBuf {
    crate::repo().join("tests/golden")
}

/// How far two images are apart on 8-bit sRGB: PSNR in dB (infinite when equal) and the
/// fraction of pixels whose worst channel is off by more than `tolerance` codes, with a
/// per-pixel difference picture (|Δ| / 32 per channel).
pub struct Difference {
    pub psnr: f64,
    pub off_fraction: f64,
    pub picture: Image,
}

/// Compare `a` with `b` (linear RGB of one size) after encoding both to 8-bit sRGB.
#[must_use]
pub fn difference(a: &Image, b: &Image, tolerance: i32) -> Difference {
    assert_eq!((a.width, a.height), (b.width, b.height), "images of different sizes");
    let ours = encode_srgb8(a, &PngOptions::default()).expect("encode");
    let theirs = encode_srgb8(b, &PngOptions::default()).expect("encode");
    let mut sq = 0.0f64;
    let mut off = 0usize;
    let mut diff = vec![[0.0f32; 3]; a.width as usize * a.height as usize];
    for (i, (p, q)) in ours.chunks(3).zip(theirs.chunks(3)).enumerate() {
        let mut worst = 0i32;
        for c in 0..3 {
            let d = i32::from(p[c]) - i32::from(q[c]);
            sq += f64::from(d * d);
            worst = worst.max(d.abs());
            diff[i][c] = d.abs() as f32 / 32.0;
        }
        if worst > tolerance {
            off += 1;
        }
    }
    let mse = sq / ours.len().max(1) as f64;
    let psnr = if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0f64 * 255.0 / mse).log10() };
    Difference {
        psnr,
        off_fraction: off as f64 / diff.len().max(1) as f64,
        picture: Image::from_rgb(a.width, a.height, &diff),
    }
}

/// Compares `image` (linear RGB) on 8-bit sRGB with `tests/golden/<name>.png`, or writes it
/// there when `GLINT_BLESS` is set. Tolerance: the computation is deterministic; what may
/// differ between machines is the SIMD kernel chosen at run time, which can move a silhouette
/// pixel. PSNR 40 dB and at most 0.5 % of pixels off by more than 8/255 allow that and nothing
/// more.
pub fn assert_matches_golden(name: &str, image: &Image) {
    let reference_path = golden_dir().join(format!("{name}.png"));
    if std::env::var_os("GLINT_BLESS").is_some() {
        glint_image::write_png(&reference_path, image, &PngOptions::default()).expect("write golden image");
        return;
    }
    let reference = glint_image::read_image(&reference_path)
        .unwrap_or_else(|e| panic!("{e} (regenerate with GLINT_BLESS=1 and review the pictures)"));
    assert_eq!((reference.width, reference.height), (image.width, image.height), "{name}: size differs");
    let d = difference(image, &reference, 8);
    if d.psnr < 40.0 || d.off_fraction > 0.005 {
        let out = crate::target_dir().join("golden");
        std::fs::create_dir_all(&out).expect("create target/golden");
        glint_image::write_png(&out.join(format!("{name}-actual.png")), image, &PngOptions::default())
            .expect("write actual");
        glint_image::write_png(&out.join(format!("{name}-diff.png")), &d.picture, &PngOptions::default())
            .expect("write diff");
        panic!(
            "{name} differs from its golden image: PSNR {:.1} dB, {:.2}% pixels off (see target/golden/)",
            d.psnr,
            d.off_fraction * 100.0
        );
    }
}
