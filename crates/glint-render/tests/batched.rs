//! The batched Whitted tracer against the scalar one (the oracle): every Whitted-capable scene
//! in scenes/ and the demo scene, at one sample and at 2×2 stratified samples, must give the
//! same picture — at most 1/255 apart per 8-bit channel, on no more than 0.1 % of the pixels.
//!
//! Why any pixel may differ at all: a sample's contributions are summed depth by depth instead
//! of in the scalar stack's order, and the Phong power is a polynomial (relative error below
//! 3e-5); both move a value by a few ulps, which can cross an 8-bit rounding boundary. The
//! ray queries themselves are bit-identical lane by lane (`world::tests`). The AVX2 and
//! baseline builds of the batched tracer must agree bit for bit (no fused multiply-add in
//! either).

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{Settings, render};
use glint_image::{PngOptions, encode_srgb8};
use glint_render::{Film, WhittedKernel, World};
use std::path::Path;

fn scenes() -> Vec<(String, glint_scene::Scene)> {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes"));
    let mut out = Vec::new();
    let mut files: Vec<_> = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().path()).collect();
    files.sort();
    for path in files {
        if path.extension().is_none_or(|e| e != "toml") {
            continue;
        }
        match glint_formats::load(&path) {
            Ok(loaded) if !loaded.scene.objects.is_empty() => {
                out.push((path.file_name().unwrap().to_string_lossy().into_owned(), loaded.scene));
            }
            Ok(_) => {}
            // Scenes that read ../shared/data are skipped where it is not there.
            Err(e) => eprintln!("skipped {}: {e}", path.display()),
        }
    }
    let demo = glint_formats::load_scene_str(glint_formats::DEMO_SCENE, Path::new("."), "demo").unwrap();
    out.push(("demo (built in)".into(), demo.scene));
    out
}

fn srgb8(film: &Film) -> Vec<u8> {
    encode_srgb8(&film.beauty_image(false), &PngOptions::default()).unwrap()
}

#[test]
fn batched_and_scalar_tracers_make_the_same_pictures() {
    let scenes = scenes();
    assert!(scenes.len() >= 6, "{} scenes", scenes.len());
    for (name, scene) in scenes {
        same_pictures(&name, scene);
    }
}

/// Spot lights of every falloff curve (glint's smoothstep, Mitsuba's linear angle, glTF's
/// squared cosine: the curves imported scenes bring), each cone's edge on the demo's floor.
#[test]
fn batched_and_scalar_tracers_light_spots_alike() {
    use glint_scene::{Attenuation, Light, SpotFalloff};
    let mut scene = glint_formats::load_scene_str(glint_formats::DEMO_SCENE, Path::new("."), "demo").unwrap().scene;
    let target = scene.bounds().centre();
    scene.lights = [SpotFalloff::Smoothstep, SpotFalloff::LinearAngle, SpotFalloff::SquaredCosine]
        .into_iter()
        .enumerate()
        .map(|(k, falloff)| {
            let position = target + glint_core::Vec3::new(k as f32 * 2.0 - 2.0, 6.0, 2.0);
            Light::Spot {
                position,
                direction: (target - position).normalize(),
                inner_deg: 10.0 + 5.0 * k as f32,
                outer_deg: 30.0,
                colour: glint_core::Rgb::ONE,
                intensity: 0.8,
                attenuation: Attenuation::None,
                falloff,
                projection: None,
            }
        })
        .collect();
    same_pictures("demo under three spots", scene);
}

/// Render `scene` with the scalar tracer, the batched one and its baseline build, at one sample
/// and 2×2 samples, and hold them to the module's criteria.
fn same_pictures(name: &str, scene: glint_scene::Scene) {
    let world = World::new(scene);
    for n in [1, 2] {
        let base =
            Settings { width: 160, height: 90, samples_per_side: n, ..Settings::from_defaults(&world.scene().render) };
        let frame = |kernel| render(&world, &Settings { kernel, ..base }).unwrap();
        let (scalar, s_stats) = frame(WhittedKernel::Scalar);
        let (batched, b_stats) = frame(WhittedKernel::Batched);
        let (baseline, _) = frame(WhittedKernel::BatchedBaseline);
        assert_eq!(s_stats.rays, b_stats.rays, "{name} ({n}×{n}): the same rays traced");
        let bits = |f: &Film| f.pixels.iter().map(|p| p.colour.to_array().map(f32::to_bits)).collect::<Vec<_>>();
        assert!(bits(&batched) == bits(&baseline), "{name} ({n}×{n}): the AVX2 and baseline builds differ");
        let (a, b) = (srgb8(&scalar), srgb8(&batched));
        let mut off = 0;
        for (p, q) in a.chunks(3).zip(b.chunks(3)) {
            let worst = p.iter().zip(q).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0);
            assert!(worst <= 1, "{name} ({n}×{n}): a pixel differs by {worst}/255");
            off += usize::from(worst > 0);
        }
        let pixels = a.len() / 3;
        eprintln!("{name} ({n}×{n}): {off} of {pixels} pixels 1/255 apart");
        assert!(off * 1000 <= pixels, "{name} ({n}×{n}): {off} of {pixels} pixels differ by 1/255");
        for (p, q) in (0..scalar.pixels.len()).map(|i| (scalar.record(i), batched.record(i))) {
            assert_eq!((p.coverage, p.depth.to_bits()), (q.coverage, q.depth.to_bits()), "{name}: AOVs");
        }
    }
}
