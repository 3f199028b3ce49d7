//! Golden image of the built-in demo scene (STYLE.md §6). The reference lives in
//! tests/golden/demo.png and changes only by an explicit, reviewed regeneration:
//! `GLINT_BLESS=1 cargo test -p glint-render --test golden`. On failure the actual image and a
//! difference image are written under target/golden/.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

use glint_image::{Image, PngOptions, encode_srgb8};
use glint_render::{RenderSettings, World};
use std::path::PathBuf;

const WIDTH: u32 = 192;
const HEIGHT: u32 = 108;

fn golden_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../tests/golden"))
}

#[test]
fn demo_scene_matches_its_golden_image() {
    let loaded = glint_formats::load_scene_str(glint_formats::DEMO_SCENE, std::path::Path::new("."), "demo").unwrap();
    let world = World::new(loaded.scene);
    let mut settings = RenderSettings::from_defaults(&world.scene.render);
    settings.width = WIDTH;
    settings.height = HEIGHT;
    let (film, stats) = glint_render::render(&world, &settings).unwrap();
    assert_eq!(stats.rejected_samples, 0);
    let image = film.beauty_image(false);
    let reference_path = golden_dir().join("demo.png");
    if std::env::var_os("GLINT_BLESS").is_some() {
        glint_image::write_png(&reference_path, &image, &PngOptions::default()).unwrap();
        return;
    }
    let reference =
        glint_image::read_image(&reference_path).expect("tests/golden/demo.png (regenerate with GLINT_BLESS=1)");
    assert_eq!((reference.width, reference.height), (WIDTH, HEIGHT));
    let ours = encode_srgb8(&image, &PngOptions::default()).unwrap();
    let theirs = encode_srgb8(&reference, &PngOptions::default()).unwrap();
    let mut sq = 0.0f64;
    let mut bad = 0usize;
    let mut diff = vec![[0.0f32; 3]; (WIDTH * HEIGHT) as usize];
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
    let bad_fraction = bad as f64 / (WIDTH * HEIGHT) as f64;
    // Tolerance: the computation is deterministic; what may differ between machines is the
    // SIMD kernel chosen at run time, which can move a silhouette pixel. PSNR 40 dB and at most
    // 0.5 % of pixels off by more than 8/255 allow that and nothing more.
    if psnr < 40.0 || bad_fraction > 0.005 {
        let out = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../target/golden"));
        std::fs::create_dir_all(&out).unwrap();
        glint_image::write_png(&out.join("demo-actual.png"), &image, &PngOptions::default()).unwrap();
        glint_image::write_png(
            &out.join("demo-diff.png"),
            &Image::from_rgb(WIDTH, HEIGHT, &diff),
            &PngOptions::default(),
        )
        .unwrap();
        panic!(
            "demo scene differs from its golden image: PSNR {psnr:.1} dB, {:.2}% pixels off (see target/golden/)",
            bad_fraction * 100.0
        );
    }
}
