//! The one frame entry point ([`Renderer`]): every mode draws the scene as the camera moves;
//! progressive pictures refine at rest and start over bit for bit; whole frames do not depend
//! on the thread count; progress covers every row once; cancellation stops a frame; a mode
//! without content is refused.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

use glint_core::Quat;
use glint_render::{Hooks, ImageSettings, Mode, ModeSettings, RenderError, Renderer};
use glint_scene::{Camera, RenderMode};
use glint_testkit::scenes::cloud_and_sphere;
use std::collections::HashSet;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

const MODES: [RenderMode; 3] = [RenderMode::Whitted, RenderMode::Path, RenderMode::Points];

fn mode(kind: RenderMode) -> Mode {
    let scene = cloud_and_sphere();
    let mut m = ModeSettings::from_defaults(&scene.render);
    m.path.max_bounces = 1;
    m.mode(kind)
}

/// The camera turned about the vertical through the scene's centre.
fn turned(camera: &Camera, degrees: f32) -> Camera {
    let q = Quat::from_rotation_y(degrees.to_radians());
    Camera { position: q * camera.position, forward: q * camera.forward, ..*camera }
}

fn colour_bits(r: &mut Renderer) -> Vec<[u32; 3]> {
    r.film().pixels.iter().map(|p| p.colour.to_array().map(f32::to_bits)).collect()
}

#[test]
fn every_mode_draws_the_scene_as_the_camera_moves() {
    let scene = cloud_and_sphere();
    let mut r = Renderer::new(scene.clone()).unwrap();
    let image = ImageSettings::new(64, 48);
    for kind in MODES {
        assert!(r.supports(kind));
        let mut frames = Vec::new();
        for k in 0..3 {
            let camera = turned(&scene.camera, 15.0 * k as f32);
            let stats = r.render(&camera, &image, &mode(kind), &Hooks::default()).unwrap();
            assert!(stats.elapsed.as_secs_f64() > 0.0, "{kind:?}: {stats:?}");
            assert!(stats.rays.total() > 0 || stats.points > 0, "{kind:?}: {stats:?}");
            assert!(!stats.summary.is_empty() && !stats.stages.is_empty(), "{kind:?}: {stats:?}");
            assert_eq!(r.accumulated(), 1, "{kind:?}");
            let colours = colour_bits(&mut r);
            assert_eq!(colours.len(), 64 * 48);
            assert!(colours.iter().collect::<HashSet<_>>().len() > 3, "{kind:?}: not blank");
            frames.push(colours);
        }
        assert_ne!(frames[0], frames[2], "{kind:?}: the view turned");
    }
}

#[test]
fn resting_pictures_refine_and_restarts_repeat_the_first_pass() {
    let scene = cloud_and_sphere();
    let camera = scene.camera;
    let mut r = Renderer::new(scene).unwrap();
    let image = ImageSettings::new(48, 32);
    for kind in [RenderMode::Whitted, RenderMode::Path] {
        let m = mode(kind);
        r.add_pass(&camera, &image, &m, true, &Hooks::default()).unwrap();
        let first = colour_bits(&mut r);
        for k in 2..=5 {
            r.add_pass(&camera, &image, &m, false, &Hooks::default()).unwrap();
            assert_eq!(r.accumulated(), k, "{kind:?}");
        }
        assert_ne!(first, colour_bits(&mut r), "{kind:?}: refinement changes the picture");
        r.add_pass(&camera, &image, &m, true, &Hooks::default()).unwrap();
        assert_eq!((r.accumulated(), colour_bits(&mut r)), (1, first.clone()), "{kind:?}: restart");
        // A new size cannot refine the old picture; nor can a whole frame be refined.
        r.add_pass(&camera, &ImageSettings::new(24, 16), &m, false, &Hooks::default()).unwrap();
        assert_eq!((r.accumulated(), r.size()), (1, (24, 16)), "{kind:?}");
        r.render(&camera, &image, &m, &Hooks::default()).unwrap();
        r.add_pass(&camera, &image, &m, false, &Hooks::default()).unwrap();
        assert_eq!(r.accumulated(), 1, "{kind:?}: a pass after a whole frame starts over");
    }
    // Points: exact in one pass; a refining pass does nothing.
    let m = mode(RenderMode::Points);
    r.add_pass(&camera, &image, &m, true, &Hooks::default()).unwrap();
    let s = r.add_pass(&camera, &image, &m, false, &Hooks::default()).unwrap();
    assert!(s.stages.is_empty() && r.accumulated() == 1);
}

/// A whole frame is the same bits on one thread and two; the progress hook counts every row
/// once.
#[test]
fn whole_frames_do_not_depend_on_threads_and_progress_counts_rows() {
    let scene = cloud_and_sphere();
    let camera = scene.camera;
    let image = ImageSettings::new(40, 30);
    for kind in MODES {
        let m = mode(kind);
        let frame = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| {
                let mut r = Renderer::new(scene.clone()).unwrap();
                let rows = AtomicU64::new(0);
                let count = |n: u64| {
                    rows.fetch_add(n, Ordering::Relaxed);
                };
                r.render(&camera, &image, &m, &Hooks::with_progress(&count)).unwrap();
                (colour_bits(&mut r), rows.load(Ordering::Relaxed))
            })
        };
        let (one, rows) = frame(1);
        let (two, _) = frame(2);
        assert!(one == two, "{kind:?}: 1 and 2 threads differ");
        if kind != RenderMode::Points {
            assert_eq!(rows, 30, "{kind:?}: every row reported once");
        }
    }
}

#[test]
fn a_cancelled_frame_stops_with_an_error_and_the_next_starts_over() {
    let scene = cloud_and_sphere();
    let camera = scene.camera;
    let mut r = Renderer::new(scene).unwrap();
    let image = ImageSettings::new(32, 24);
    let stop = AtomicBool::new(true);
    let hooks = Hooks { progress: None, cancel: Some(&stop) };
    for kind in MODES {
        let e = r.add_pass(&camera, &image, &mode(kind), false, &hooks).unwrap_err();
        assert_eq!(e, RenderError::Cancelled, "{kind:?}");
        assert_eq!(r.accumulated(), 0, "{kind:?}: nothing to refine after a cancelled frame");
        assert!(r.render(&camera, &image, &mode(kind), &Hooks::default()).is_ok());
    }
}

#[test]
fn a_mode_without_content_is_refused() {
    let mut clouds = cloud_and_sphere();
    clouds.objects.clear();
    let camera = clouds.camera;
    let mut r = Renderer::new(clouds).unwrap();
    assert!(!r.supports(RenderMode::Whitted) && r.supports(RenderMode::Points));
    let e = r.render(&camera, &ImageSettings::new(8, 8), &mode(RenderMode::Path), &Hooks::default()).unwrap_err();
    assert!(e.to_string().contains("only point clouds"), "{e}");
    let mut objects = cloud_and_sphere();
    objects.clouds.clear();
    let mut r = Renderer::new(objects).unwrap();
    assert!(r.render(&camera, &ImageSettings::new(8, 8), &mode(RenderMode::Points), &Hooks::default()).is_err());
}

/// A frame drawn straight to 8-bit sRGB (a PNG render's) is the film's encoding byte for byte,
/// on every Whitted path (both kernels, supersampled, a crop window off the tile grid and one
/// on it) and every tone map, exposure and alpha setting; other modes draw their film and
/// encode it. The film then holds no stale picture.
#[test]
fn frames_drawn_to_8_bits_are_the_films_encoding() {
    use glint_image::{PngOptions, ToneMap};
    use glint_render::{Region, WhittedKernel};
    let scene = cloud_and_sphere();
    let camera = scene.camera;
    let mut r = Renderer::new(scene).unwrap();
    let image = ImageSettings::new(40, 27);
    let off_grid = image.sub(Region { x0: 5, y0: 3, width: 21, height: 13 });
    let on_grid = image.sub(Region { x0: 16, y0: 8, width: 24, height: 19 });
    let options = [
        PngOptions::default(),
        PngOptions { exposure: 1.5, tone_map: ToneMap::Aces, alpha: true },
        PngOptions { exposure: -1.0, tone_map: ToneMap::Reinhard, alpha: false },
    ];
    let Mode::Whitted(base) = mode(RenderMode::Whitted) else { unreachable!() };
    let mut bytes = Vec::new();
    for kernel in [WhittedKernel::Batched, WhittedKernel::BatchedBaseline, WhittedKernel::Scalar] {
        for side in [1, 2] {
            let m = Mode::Whitted(glint_render::WhittedSettings { kernel, samples_per_side: side, ..base });
            for (image, o) in [image, off_grid, on_grid].into_iter().zip(options) {
                let what = format!("{kernel:?}, {side}x{side} samples, {}x{}, {o:?}", image.width, image.height);
                r.render(&camera, &image, &m, &Hooks::default()).unwrap();
                let want = r.film().encode_srgb8(&o);
                let stats = r.render_srgb8(&camera, &image, &m, &Hooks::default(), &o, &mut bytes).unwrap();
                assert!(bytes == want, "{what}: the bytes differ");
                assert!(stats.rays.total() > 0 && stats.summary.starts_with("whitted"), "{what}: {stats:?}");
                assert_eq!((r.film().pixels.len(), r.accumulated()), (0, 1), "{what}: no stale film");
            }
        }
    }
    for kind in [RenderMode::Path, RenderMode::Points] {
        r.render(&camera, &image, &mode(kind), &Hooks::default()).unwrap();
        let want = r.film().encode_srgb8(&options[1]);
        r.render_srgb8(&camera, &image, &mode(kind), &Hooks::default(), &options[1], &mut bytes).unwrap();
        assert!(bytes == want, "{kind:?}");
    }
    // A refused frame is refused the same way.
    let e = r.render_srgb8(
        &camera,
        &ImageSettings::new(0, 4),
        &mode(RenderMode::Whitted),
        &Hooks::default(),
        &options[0],
        &mut bytes,
    );
    assert!(e.is_err());
}
