//! The path mode (DESIGN.md §2): furnace tests with known answers, next-event estimation
//! against BSDF sampling, light sampling against its pdf, thread-count independence, and the
//! guided filter's gain on the Cornell box.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{add_path_pass, path_frame, settings};
use glint_core::random::Sampler;
use glint_core::{Affine3A, PixelFilter, Reconstruction, Rgb, Vec3};
use glint_filter::{Filter, GuidedParams};
use glint_render::path::{PathAccumulator, PathKernel, PathSettings};
use glint_render::{Film, World};
use glint_scene::{Camera, Fov, Light, Material, Object, Scene, Shape, Sky};
use std::sync::Arc;

fn object(shape: Shape, material: usize) -> Object {
    Object { name: "o".into(), shape, material, world_from_object: Affine3A::IDENTITY }
}

fn path(spp: u32, bounces: u32, filter: Filter) -> PathSettings {
    PathSettings {
        spp,
        max_bounces: bounces,
        rr_start: 64,
        max_chain: 8,
        filter,
        passes: 1,
        time_budget: None,
        clamp_indirect: None,
        filter_area_direct: false,
        kernel: PathKernel::Wavefront,
        max_depth: None,
        pixel_filter: PixelFilter::Box,
        reconstruction: Reconstruction::Splat,
        hide_emitters: false,
        sampler: Sampler::Sobol,
        aovs: true,
    }
}

fn render(scene: Scene, w: u32, h: u32, p: &PathSettings) -> Film {
    let world = World::new(scene);
    path_frame(&world, &settings(w, h), p).expect("render").0
}

/// Mean and standard error of the luminance-free red channel over pixels that pass `keep`.
fn mean_and_error(film: &Film, keep: impl Fn(usize) -> bool) -> (f64, f64, usize) {
    let v: Vec<f64> =
        film.pixels.iter().enumerate().filter(|(i, _)| keep(*i)).map(|(_, p)| p.colour.x as f64).collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt(), v.len())
}

fn white_diffuse(colour: f32) -> Material {
    Material { colour: Rgb::splat(colour), diffuse: 1.0, specular: 0.0, ambient: 0.0, ..Material::default() }
}

/// White furnace: a white Lambertian sphere under a uniform white sky reflects exactly the
/// sky (it sees nothing but the sky), whatever the bounce count, the filter or the seed.
#[test]
fn white_furnace_returns_the_sky() {
    let scene = |_: ()| Scene {
        camera: Camera::look_at(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, Fov::Vertical(40.0)),
        sky: Sky::Colour(Rgb::ONE),
        materials: vec![white_diffuse(1.0)],
        objects: vec![object(Shape::Sphere { centre: Vec3::ZERO, radius: 1.0 }, 0)],
        ..Scene::default()
    };
    for p in
        [path(4, 0, Filter::None), path(4, 3, Filter::None), path(2, 2, Filter::Guided(GuidedParams::for_width(48)))]
    {
        let film = render(scene(()), 48, 48, &p);
        let (mean, err, n) = mean_and_error(&film, |i| film.pixels[i].coverage == 1.0);
        assert!(n > 500, "{n} sphere pixels");
        // 5 standard errors: fails by chance with p < 1e-6.
        assert!((mean - 1.0).abs() < 5.0 * err + 1e-6, "{p:?}: furnace mean {mean} ± {err}");
        assert!(err < 0.05, "too noisy: {err}");
    }
}

/// Inside a closed sphere of albedo ρ whose every point emits L_e, a path of B bounces sees
/// `L_e (1 + ρ + ... + ρ^(B+1))` (emission, direct light, one term per bounce). Exercises
/// next-event estimation of emissive triangles (icosphere) with MIS at deeper vertices and the
/// no-double-counting rule after the guide vertex, and full-weight emission for emitters NEE
/// cannot sample (an analytic sphere).
#[test]
fn closed_emitting_sphere_sums_the_geometric_series() {
    let rho = 0.5f32;
    // Seen from inside: the inner faces are the back faces, so the sphere emits from both.
    let emitter = Material { emission: Rgb::ONE, two_sided: true, ..white_diffuse(rho) };
    let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, Fov::Vertical(90.0));
    let ico = glint_accel::procedural::icosphere(3);
    let mesh = glint_scene::Mesh {
        name: "sphere".into(),
        positions: ico.positions,
        normals: None,
        uvs: None,
        triangles: ico.triangles,
        triangle_materials: None,
        attributes: Vec::new(),
    };
    let shapes = [Shape::Mesh(0), Shape::Sphere { centre: Vec3::ZERO, radius: 1.0 }];
    for shape in shapes {
        for bounces in [0u32, 1, 3] {
            let scene = Scene {
                camera,
                sky: Sky::Colour(Rgb::ZERO),
                materials: vec![emitter.clone()],
                meshes: vec![Arc::new(mesh.clone())],
                objects: vec![object(shape, 0)],
                ..Scene::default()
            };
            let film = render(scene, 24, 24, &path(16, bounces, Filter::None));
            // Emitters next-event estimation cannot sample (analytic spheres) are found by BSDF
            // sampling alone, so they bring no direct light at the last vertex: one term fewer.
            let terms = if matches!(shape, Shape::Mesh(_)) { bounces + 1 } else { bounces };
            let expected: f64 = (0..=terms).map(|k| (rho as f64).powi(k as i32)).sum();
            let (mean, err, _) = mean_and_error(&film, |_| true);
            assert!(
                (mean - expected).abs() < 5.0 * err + 2e-3 * expected,
                "{shape:?} {bounces} bounces: {mean} ± {err}, expected {expected}"
            );
        }
    }
}

/// Emitters shine from their front face only (the side their geometric normal points to), as
/// Mitsuba's and pbrt's area lights do, unless two-sided: a floor lit by a quad light facing
/// down receives its light (through next-event estimation and BSDF sampling alike), a quad
/// facing up leaves it dark and is itself black seen from below, and a two-sided quad lights it
/// whichever way it faces.
#[test]
fn emitters_are_one_sided_unless_two_sided() {
    let quad = |down: bool| {
        let (a, b, c, d) = (
            Vec3::new(-0.5, 2.0, -0.5),
            Vec3::new(0.5, 2.0, -0.5),
            Vec3::new(0.5, 2.0, 0.5),
            Vec3::new(-0.5, 2.0, 0.5),
        );
        // a → b → c runs clockwise seen from above: (b − a) × (c − a) points down.
        let triangles = if down { vec![[0, 1, 2], [0, 2, 3]] } else { vec![[0, 2, 1], [0, 3, 2]] };
        glint_scene::Mesh {
            name: "quad".into(),
            positions: vec![a, b, c, d],
            triangles,
            ..glint_scene::Mesh::default()
        }
    };
    let floor_light = |down: bool, two_sided: bool, max_bounces: u32| {
        let scene = Scene {
            camera: Camera::look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, Fov::Vertical(40.0)),
            sky: Sky::Colour(Rgb::ZERO),
            materials: vec![
                white_diffuse(0.8),
                Material { emission: Rgb::splat(4.0), two_sided, ..white_diffuse(0.0) },
            ],
            meshes: vec![Arc::new(quad(down))],
            objects: vec![object(Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0), object(Shape::Mesh(0), 1)],
            ..Scene::default()
        };
        let film = render(scene, 32, 24, &path(8, max_bounces, Filter::None));
        // The floor in the middle of the picture (below the light).
        film.pixel(16, 14).colour.x
    };
    for bounces in [0, 2] {
        let down = floor_light(true, false, bounces);
        assert!(down > 0.05, "a light facing the floor lights it: {down}");
        assert_eq!(floor_light(false, false, bounces), 0.0, "a light facing away leaves it dark");
        let both = floor_light(false, true, bounces);
        assert!((both - down).abs() < 0.15 * down, "two-sided lights both ways: {both} vs {down}");
    }
}

/// The guided mode and plain path tracing agree on average (the filter only moves noise around
/// and the lookup reads the right surface).
#[test]
fn guided_mode_is_unbiased_on_a_flat_lit_floor() {
    let scene = Scene {
        camera: Camera::look_at(Vec3::new(0.0, 2.0, 4.0), Vec3::ZERO, Vec3::Y, Fov::Vertical(50.0)),
        sky: Sky::Colour(Rgb::new(0.4, 0.5, 0.7)),
        materials: vec![white_diffuse(0.7), white_diffuse(0.5)],
        objects: vec![
            object(Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0),
            object(Shape::Sphere { centre: Vec3::new(0.0, 0.7, 0.0), radius: 0.7 }, 1),
        ],
        ..Scene::default()
    };
    let world = World::new(scene);
    let frame = |p: &PathSettings, seed: u64| {
        path_frame(&world, &common::Settings { seed, ..settings(40, 30) }, p).expect("render").0
    };
    let mean = |f: &Film| f.pixels.iter().map(|p| p.colour.element_sum() as f64).sum::<f64>() / f.pixels.len() as f64;
    let a = mean(&frame(&path(64, 2, Filter::None), 0));
    for filter_area_direct in [false, true] {
        // The image mean of one 4-spp guided frame varies by ~3 % from seed to seed (the sky's
        // filtered direct light at its shadow's edges): the mean of 8 frames is compared.
        let p = PathSettings { filter_area_direct, ..path(4, 2, Filter::Guided(GuidedParams::for_width(40))) };
        let b = (1..=8).map(|seed| mean(&frame(&p, seed))).sum::<f64>() / 8.0;
        assert!((a - b).abs() < 0.02 * a, "plain {a} vs guided {b} (sky direct filtered: {filter_area_direct})");
    }
}

/// The Sobol sampler stratifies each pixel's samples: on the Cornell box at 16 spp its error
/// against a converged picture is well below the independent sampler's (about a third in
/// mean squared error), and both converge to the same picture (the image means agree).
#[test]
fn the_sobol_sampler_lowers_the_error_of_the_same_samples() {
    let world = World::new(mitsuba_cbox());
    let (w, h) = (48, 48);
    let frame = |sampler: Sampler, spp: u32, seed: u64| {
        let s = common::Settings { seed, ..settings(w, h) };
        let p = PathSettings { sampler, ..path(spp, 3, Filter::None) };
        path_frame(&world, &s, &p).expect("render").0.beauty_image(false)
    };
    let reference = frame(Sampler::Independent, 1024, 99);
    let error = |sampler: Sampler| {
        (1..=3)
            .map(|seed| glint_image::metrics::compare(&frame(sampler, 16, seed), &reference).expect("same size").mse)
            .sum::<f64>()
    };
    let (sobol, independent) = (error(Sampler::Sobol), error(Sampler::Independent));
    assert!(sobol < 0.6 * independent, "MSE sobol {sobol:e} vs independent {independent:e}");
    let mean = |img: &glint_image::Image| img.channel("R").expect("R").iter().map(|&v| f64::from(v)).sum::<f64>();
    let (a, b) = (mean(&frame(Sampler::Sobol, 64, 5)), mean(&reference));
    assert!((a - b).abs() < 0.01 * b, "image sums {a} vs {b}");
}

/// Bit-identical pixels on 1 and 2 threads, filtered and not.
#[test]
fn same_image_on_one_and_two_threads() {
    let text = include_str!("../../../scenes/whitted-bench.toml");
    let scene = glint_formats::load_scene_str(text, std::path::Path::new("."), "bench.toml").expect("scene").scene;
    let world = World::new(scene);
    for p in [path(2, 2, Filter::None), path(3, 1, Filter::Guided(GuidedParams::for_width(64)))] {
        let run = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| path_frame(&world, &settings(64, 40), &p).expect("render").0)
        };
        let (a, b) = (run(1), run(2));
        assert!(a.pixels == b.pixels, "{p:?}: images differ between 1 and 2 threads");
    }
}

/// A frame's sums start from what the last frame of that size left (each band resets its own
/// as the first step starts): a frame rendered after others, filtered or not, with more
/// passes or fewer, is the same frame rendered first.
#[test]
fn a_frame_owes_nothing_to_the_frames_before_it() {
    let text = include_str!("../../../scenes/whitted-bench.toml");
    let scene = glint_formats::load_scene_str(text, std::path::Path::new("."), "bench.toml").expect("scene").scene;
    let world = World::new(scene);
    let guided = Filter::Guided(GuidedParams::for_width(48));
    let frames = [path(2, 2, Filter::None), PathSettings { passes: 3, ..path(2, 1, guided) }, path(1, 1, guided)];
    let first: Vec<Film> = frames.iter().map(|p| path_frame(&world, &settings(48, 30), p).expect("render").0).collect();
    for (p, want) in frames.iter().zip(&first).rev() {
        let again = path_frame(&world, &settings(48, 30), p).expect("render").0;
        assert!(again.pixels == want.pixels, "{p:?}: differs after other frames");
    }
}

/// A scene without any light at all renders black, not NaN.
#[test]
fn a_dark_scene_is_black() {
    let scene = Scene {
        sky: Sky::Colour(Rgb::ZERO),
        materials: vec![Material::default()],
        objects: vec![object(Shape::Sphere { centre: Vec3::new(0.0, 0.0, -3.0), radius: 1.0 }, 0)],
        ..Scene::default()
    };
    let film = render(scene, 16, 16, &path(2, 2, Filter::Guided(GuidedParams::for_width(16))));
    assert!(film.pixels.iter().all(|p| p.colour == Rgb::ZERO));
}

/// The open Cornell box of scenes/cornell-box.toml (mesh from ../shared/data).
fn cornell_box() -> World {
    let text = include_str!("../../../scenes/cornell-box.toml");
    let scene = glint_formats::load_scene_str(text, std::path::Path::new("../../scenes"), "cornell-box.toml")
        .expect("scene")
        .scene;
    World::new(scene)
}

/// The progressive accumulator: one pass of 1 spp is `render_path` at 1 spp, filtered or not,
/// bit for bit; N unfiltered passes are `render_path` at N spp; the filtered accumulation
/// converges to the same mean as the plain one; 1 and 2 threads agree.
#[test]
fn progressive_passes_match_render_path() {
    use glint_render::path::PathAccumulator;
    let world = cornell_box();
    let s = settings(48, 40);
    let guided = Filter::Guided(GuidedParams::for_width(48));
    // With and without the area light's direct light in the filtered part.
    for (filter, filter_area_direct) in [(Filter::None, false), (guided, false), (guided, true)] {
        let p = PathSettings { filter_area_direct, ..path(1, 2, filter) };
        let (reference, _) = path_frame(&world, &s, &p).expect("render");
        let mut acc = PathAccumulator::new();
        add_path_pass(&mut acc, &world, &s, &p).expect("pass");
        let mut film = Film::new(1, 1);
        acc.resolve(&world, &filter, &mut film).expect("resolve");
        let colours = |f: &Film| f.pixels.iter().map(|p| p.colour).collect::<Vec<_>>();
        assert!(colours(&film) == colours(&reference), "{p:?}: one pass differs from render_path");
        assert!(film.surface.iter().zip(&reference.surface).all(|(a, b)| a.normal == b.normal && a.depth == b.depth));
    }
    // Eight passes without a filter: render_path at 8 spp.
    let p = path(1, 2, Filter::None);
    let mut acc = PathAccumulator::new();
    for _ in 0..8 {
        add_path_pass(&mut acc, &world, &s, &p).expect("pass");
    }
    assert_eq!((acc.passes(), acc.samples_per_pixel()), (8, 8));
    let mut film = Film::new(1, 1);
    acc.resolve(&world, &Filter::None, &mut film).expect("resolve");
    let (reference, _) = path_frame(&world, &s, &path(8, 2, Filter::None)).expect("render");
    assert!(film.pixels.iter().zip(&reference.pixels).all(|(a, b)| a.colour == b.colour), "8 passes != 8 spp");
    // With a Gaussian film the passes draw positions from it: `render_path` sampling it.
    let gaussian = |p: PathSettings, reconstruction| PathSettings {
        pixel_filter: PixelFilter::Gaussian { stddev: 0.5 },
        reconstruction,
        ..p
    };
    let mut acc = PathAccumulator::new();
    for _ in 0..3 {
        add_path_pass(&mut acc, &world, &s, &gaussian(p, Reconstruction::Splat)).expect("pass");
    }
    acc.resolve(&world, &Filter::None, &mut film).expect("resolve");
    let sampled = gaussian(path(3, 2, Filter::None), Reconstruction::Sample);
    let (reference, _) = path_frame(&world, &s, &sampled).expect("render");
    assert!(film.pixels.iter().zip(&reference.pixels).all(|(a, b)| a.colour == b.colour), "Gaussian passes");
    // The filtered accumulation keeps the image's mean (the filter moves light, it does not
    // make or lose it) and it is the same on 1 and 2 threads.
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut acc = PathAccumulator::new();
            for _ in 0..4 {
                add_path_pass(&mut acc, &world, &s, &p).expect("pass");
            }
            let mut film = Film::new(1, 1);
            acc.resolve(&world, &guided, &mut film).expect("resolve");
            film
        })
    };
    let (a, b) = (run(1), run(2));
    assert!(a.pixels == b.pixels, "1 and 2 threads differ");
    let mean = |f: &Film| f.pixels.iter().map(|p| p.colour.x as f64).sum::<f64>() / f.pixels.len() as f64;
    let plain = {
        let mut acc = PathAccumulator::new();
        for _ in 0..4 {
            add_path_pass(&mut acc, &world, &s, &p).expect("pass");
        }
        let mut film = Film::new(1, 1);
        acc.resolve(&world, &Filter::None, &mut film).expect("resolve");
        film
    };
    assert!((mean(&a) - mean(&plain)).abs() < 0.05 * mean(&plain), "{} vs {}", mean(&a), mean(&plain));
    // A reset starts over.
    acc.reset();
    assert_eq!(acc.samples_per_pixel(), 0);
}

/// The accumulator keeps its buffers between frames and clears them while tracing the first
/// pass: after a resize or a reset, one pass equals a fresh accumulator's, whose colours are
/// `render_path`'s bit for bit (a width that is not a multiple of 8 leaves a partial packet of
/// camera rays at the end of each band).
#[test]
fn progressive_pass_after_reset_or_resize_starts_clean() {
    use glint_render::path::PathAccumulator;
    let world = cornell_box();
    let s = settings(43, 21);
    let guided = Filter::Guided(GuidedParams::for_width(43));
    for (spp, filter) in [(1, guided), (3, Filter::None)] {
        let p = path(spp, 1, filter);
        let (reference, _) = path_frame(&world, &s, &p).expect("render");
        let mut fresh = Film::new(1, 1);
        let mut acc = PathAccumulator::new();
        add_path_pass(&mut acc, &world, &s, &p).expect("pass");
        acc.resolve(&world, &filter, &mut fresh).expect("resolve");
        assert!(
            fresh.pixels.iter().zip(&reference.pixels).all(|(a, b)| a.colour == b.colour),
            "spp {spp}, {filter:?}: differs from render_path"
        );
        let mut film = Film::new(1, 1);
        let mut acc = PathAccumulator::new();
        add_path_pass(&mut acc, &world, &settings(24, 30), &p).expect("pass");
        add_path_pass(&mut acc, &world, &s, &p).expect("pass");
        add_path_pass(&mut acc, &world, &s, &p).expect("pass");
        acc.resolve(&world, &filter, &mut film).expect("resolve");
        acc.reset();
        add_path_pass(&mut acc, &world, &s, &p).expect("pass");
        acc.resolve(&world, &filter, &mut film).expect("resolve");
        assert!(film.pixels == fresh.pixels, "spp {spp}, {filter:?}: a reused accumulator differs");
    }
}

/// A dark bar a hundredth of a pixel high across the pixel centres of one row, in front of a
/// glowing wall: the first pass's guide rays (through the centres) all see the bar, but every
/// later pass jitters its samples, guide rays included, so with the guided filter the row
/// converges to the wall's light like its neighbours instead of staying black.
#[test]
fn passes_after_the_first_jitter_their_guide_rays() {
    let camera = Camera::look_at(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, Fov::Vertical(40.0));
    let centre = camera.rays(16, 16).ray(glint_core::Vec2::new(8.5, 8.5));
    let y = centre.dir.y / -centre.dir.z * 4.0;
    let (h, w) = (0.001, 10.0);
    let bar = glint_scene::Mesh {
        name: "bar".into(),
        positions: vec![
            Vec3::new(-w, y - h, -4.0),
            Vec3::new(w, y - h, -4.0),
            Vec3::new(w, y + h, -4.0),
            Vec3::new(-w, y + h, -4.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        ..glint_scene::Mesh::default()
    };
    let wall = Material { emission: Rgb::ONE, ..white_diffuse(0.5) };
    let scene = Scene {
        camera,
        sky: Sky::Colour(Rgb::ZERO),
        materials: vec![wall, white_diffuse(0.0)],
        meshes: vec![Arc::new(bar)],
        objects: vec![object(Shape::Plane { normal: Vec3::Z, offset: 5.0 }, 0), object(Shape::Mesh(0), 1)],
        ..Scene::default()
    };
    let guided = Filter::Guided(GuidedParams::for_width(16));
    let row = |passes: u32| {
        let film = render(scene.clone(), 16, 16, &PathSettings { passes, ..path(1, 1, guided) });
        (film.pixel(8, 8).colour.x, film.pixel(8, 4).colour.x)
    };
    let (dark, lit) = row(1);
    assert!(dark < 0.05 && lit > 0.9, "one pass: the centres see the bar ({dark}) and the wall ({lit})");
    let (crack, _) = row(16);
    assert!(crack > 0.8, "sixteen passes: the bar covers a hundredth of the pixel, not all of it ({crack})");
}

/// The open Cornell box rendered straight from its OBJ (its default view) at one sample per
/// pixel and three bounces: with the guided filter (which by default also filters the direct
/// light of area lights and the sky) the error against a converged render is under a third of
/// plain path tracing's. The paper's split (only the indirect light filtered) is kept for its
/// tables.
#[test]
fn the_default_guided_render_is_clean() {
    let path_of = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/scenes/cornell_box/cornell_box_open.obj");
    let Ok(loaded) = glint_formats::load(std::path::Path::new(path_of)) else {
        eprintln!("skipped: {path_of} is not there");
        return;
    };
    let world = World::new(loaded.scene);
    let (w, h) = (64, 64);
    let frame = |p: &PathSettings, seed: u64| {
        let s = common::Settings { seed, ..settings(w, h) };
        path_frame(&world, &s, p).expect("render").0.beauty_image(false)
    };
    let reference = frame(&path(256, 3, Filter::None), 99);
    let guided = Filter::Guided(GuidedParams::for_width(w as usize));
    let mse = |p: &PathSettings| glint_image::metrics::compare(&frame(p, 0), &reference).expect("same size").mse;
    let plain = mse(&path(1, 3, Filter::None));
    let filtered = mse(&PathSettings { filter_area_direct: true, ..path(1, 3, guided) });
    assert!(filtered <= plain / 3.0, "guided {filtered:e} vs plain {plain:e}");
}

/// Mitsuba's Cornell box (diffuse walls, a one-sided area light) as the scenes/ file has it.
fn mitsuba_cbox() -> Scene {
    let path = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/mitsuba-cbox.toml"));
    glint_formats::load(path).expect("scenes/mitsuba-cbox.toml").scene
}

/// The wavefront tracer is the recursive one with its work reordered: where no surface has a
/// delta lobe, both read the same random numbers, so every frame — plain, guided (guide rays,
/// filter, lookups), progressive passes, under glint's budgets or Mitsuba's `max_depth` — is
/// the same picture up to the order of float additions, and the same rays are counted.
#[test]
fn wavefront_and_recursive_tracers_agree_without_delta_lobes() {
    let world = World::new(mitsuba_cbox());
    let guided = Filter::Guided(GuidedParams::for_width(32));
    let s = settings(32, 32);
    for p in [
        path(3, 4, Filter::None),
        PathSettings { rr_start: 2, ..path(2, 6, Filter::None) },
        PathSettings { filter_area_direct: true, ..path(3, 3, guided) },
        path(1, 2, guided),
        // Mitsuba's budget (scenes from its XML): emitters only, direct light, and long paths.
        PathSettings { max_depth: Some(1), ..path(2, 3, Filter::None) },
        PathSettings { max_depth: Some(2), ..path(2, 3, Filter::None) },
        PathSettings { max_depth: Some(6), rr_start: 2, ..path(3, 3, Filter::None) },
        PathSettings { max_depth: Some(4), ..path(2, 3, guided) },
    ] {
        let frame = |kernel| path_frame(&world, &s, &PathSettings { kernel, ..p }).expect("render");
        let (a, sa) = frame(PathKernel::Wavefront);
        let (b, sb) = frame(PathKernel::Recursive);
        assert_eq!(sa.rays.total(), sb.rays.total(), "{p:?}: ray counts");
        let mut lit = 0;
        assert!(a.path_aovs && b.path_aovs && a.path.len() == a.pixels.len() && b.path.len() == b.pixels.len());
        for (i, (x, y)) in (0..a.pixels.len()).map(|i| (a.record(i), b.record(i))).enumerate() {
            let (xp, yp) = (a.path[i], b.path[i]);
            for (u, v) in
                [(x.colour, y.colour), (xp.direct, yp.direct), (xp.indirect, yp.indirect), (x.albedo, y.albedo)]
            {
                let tol = 1e-4 * u.abs().max(v.abs()).max_element().max(1e-3);
                assert!((u - v).abs().max_element() <= tol, "{p:?}: pixel {i}: {u} vs {v}");
            }
            assert_eq!((x.normal, x.depth, x.coverage), (y.normal, y.depth, y.coverage), "pixel {i}");
            lit += (x.colour.max_element() > 0.01) as usize;
        }
        // With a budget of one vertex only the light itself shows.
        let want = if p.max_depth == Some(1) { 4 } else { 600 };
        assert!(lit > want, "{p:?}: {lit} lit pixels");
    }
    let mut acc = [PathAccumulator::new(), PathAccumulator::new()];
    for (acc, kernel) in acc.iter_mut().zip([PathKernel::Wavefront, PathKernel::Recursive]) {
        for _ in 0..2 {
            add_path_pass(acc, &world, &s, &PathSettings { kernel, ..path(2, 3, Filter::None) }).expect("pass");
        }
    }
    let films = acc.map(|mut a| {
        let mut film = Film::new(1, 1);
        a.resolve(&world, &guided, &mut film).expect("resolve");
        film
    });
    for (i, (x, y)) in films[0].pixels.iter().zip(&films[1].pixels).enumerate() {
        let tol = 1e-4 * x.colour.abs().max(y.colour.abs()).max_element().max(1e-3);
        assert!((x.colour - y.colour).abs().max_element() <= tol, "progressive pixel {i}");
    }
}

/// The wavefront shades the vertices on surfaces without delta lobes eight at a time in
/// lanes; `WavefrontScalar` sends the same vertices, in the same order, through the scalar
/// code. Every lane performs the scalar operations in their order (libm's `powf`, `sin` and
/// `cos` lane by lane), so the two pictures are the same bit for bit: Phong's diffuse-only
/// reading (the Cornell box of scenes/), Mitsuba's `diffuse` (its XML box), smooth shading
/// normals (the dragon made diffuse), glossy lobes beside diffuse ones (the glossy dragon; a
/// glossy-only dragon with a high exponent), emissive triangles with a sky and two suns in one
/// choice, Sponza under its sun and sky (every surface glossy), roulette, Mitsuba's budget,
/// both samplers, guided frames with lookups.
#[test]
fn vertices_in_lanes_are_the_scalar_vertices() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/../../");
    let load = |p: &str| glint_formats::load(std::path::Path::new(&format!("{root}{p}"))).expect(p).scene;
    let dragon = load("scenes/cornell-dragon.toml");
    let mut diffuse_dragon = dragon.clone();
    for m in &mut diffuse_dragon.materials {
        m.specular = 0.0;
    }
    let mut shiny_dragon = dragon.clone();
    for m in shiny_dragon.materials.iter_mut().filter(|m| m.specular > 0.0) {
        (m.diffuse, m.specular, m.shininess) = (0.0, 0.8, 300.0);
    }
    // Light through the open front: two suns, a sky, the ceiling's lamp in the same choice.
    let mut sunlit = mitsuba_cbox();
    sunlit.sky = Sky::Gradient { zenith: Rgb::new(0.2, 0.3, 0.8), horizon: Rgb::splat(0.9), ground: Rgb::splat(0.1) };
    for (direction, colour) in
        [(Vec3::new(0.2, -0.3, -1.0), Rgb::new(1.0, 0.9, 0.8)), (Vec3::new(-0.5, -0.2, -1.0), Rgb::splat(0.3))]
    {
        sunlit.lights.push(Light::Directional { direction: direction.normalize(), colour, intensity: 2.0 });
    }
    for m in &mut sunlit.materials {
        (m.specular, m.shininess) = (0.3, 12.0);
    }
    let mitsuba_xml = load("../shared/data/mitsuba/scenes/cbox/cbox.xml");
    let sponza = load("scenes/sponza.toml");
    let guided = Filter::Guided(GuidedParams::for_width(32));
    let s = settings(32, 32);
    for (name, scene) in [
        ("cbox", mitsuba_cbox()),
        ("cbox.xml", mitsuba_xml),
        ("dragon", dragon),
        ("diffuse dragon", diffuse_dragon),
        ("shiny dragon", shiny_dragon),
        ("sunlit cbox", sunlit),
        ("sponza", sponza),
    ] {
        let world = World::new(scene);
        assert!(glint_render::path::lights_in_lanes(&world), "{name}: lights the lanes take");
        for p in [
            path(3, 4, Filter::None),
            PathSettings { rr_start: 1, sampler: Sampler::Independent, ..path(2, 6, Filter::None) },
            PathSettings { max_depth: Some(6), rr_start: 2, ..path(3, 3, Filter::None) },
            PathSettings { filter_area_direct: true, ..path(2, 2, guided) },
        ] {
            let frame = |kernel| path_frame(&world, &s, &PathSettings { kernel, ..p }).expect("render");
            let (a, sa) = frame(PathKernel::Wavefront);
            let (b, sb) = frame(PathKernel::WavefrontScalar);
            assert_eq!(sa.rays, sb.rays, "{name} {p:?}: ray counts");
            let mut lit = 0;
            for i in 0..a.pixels.len() {
                let (x, y) = (a.record(i), b.record(i));
                let bits = |v: Vec3| v.to_array().map(f32::to_bits);
                assert_eq!(bits(x.colour), bits(y.colour), "{name} {p:?}: pixel {i}");
                assert_eq!(bits(a.path[i].indirect), bits(b.path[i].indirect), "{name} {p:?}: indirect {i}");
                lit += (x.colour.max_element() > 0.01) as usize;
            }
            assert!(lit > 400, "{name} {p:?}: {lit} lit pixels");
        }
    }
}

/// Where guide vertices also follow mirror and glass lobes, the wavefront tracer runs those
/// beside the indirect path on their own random dimensions: a different picture, the same
/// estimator. Many independent frames of each tracer (disjoint seeds) give per-pixel means
/// whose difference is tested against its standard error (Welch's t, Bonferroni over every
/// pixel and channel, as Mitsuba's per-pixel z-tests), and the image means must agree too.
#[test]
fn wavefront_and_recursive_tracers_agree_in_distribution() {
    let quad = glint_scene::Mesh {
        name: "light".into(),
        positions: vec![
            Vec3::new(-0.5, 1.99, -0.5),
            Vec3::new(0.5, 1.99, -0.5),
            Vec3::new(0.5, 1.99, 0.5),
            Vec3::new(-0.5, 1.99, 0.5),
        ],
        triangles: vec![[0, 2, 1], [0, 3, 2]],
        ..glint_scene::Mesh::default()
    };
    // Mostly diffuse (p_delta < 0.5): their guide vertices follow the delta lobes as tails.
    let glassy = Material { transparency: 0.25, reflectivity: 0.05, ior: 1.5, ..white_diffuse(0.7) };
    let mirrorish = Material { reflectivity: 0.3, ..white_diffuse(0.6) };
    let scene = Scene {
        // From above: the floor's mirror lobe shows the light's reflection.
        camera: Camera::look_at(Vec3::new(0.0, 2.5, 4.0), Vec3::new(0.0, 0.3, 0.0), Vec3::Y, Fov::Vertical(50.0)),
        sky: Sky::Colour(Rgb::new(0.5, 0.55, 0.7)),
        materials: vec![
            white_diffuse(0.8),
            mirrorish,
            glassy,
            Material { emission: Rgb::splat(6.0), ..white_diffuse(0.0) },
            // A back wall the sky shows through (its transmission lobe).
            Material { transparency: 0.3, ..white_diffuse(0.6) },
        ],
        meshes: vec![Arc::new(quad)],
        objects: vec![
            object(Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 1),
            object(Shape::Plane { normal: Vec3::Z, offset: 1.5 }, 4),
            object(Shape::Sphere { centre: Vec3::new(-0.5, 0.6, 0.0), radius: 0.6 }, 2),
            object(Shape::Sphere { centre: Vec3::new(0.7, 0.4, 0.4), radius: 0.4 }, 1),
            object(Shape::Mesh(0), 3),
        ],
        ..Scene::default()
    };
    scene.validate().expect("valid scene");
    let world = World::new(scene);
    let (w, h, frames) = (16u32, 16u32, 96u64);
    // glint's budgets, and Mitsuba's (which counts the delta bounces too).
    for budget in [path(8, 3, Filter::None), PathSettings { max_depth: Some(3), ..path(8, 3, Filter::None) }] {
        // Per kernel: per-pixel, per-channel sum and sum of squares over the frames.
        let stats = |kernel: PathKernel, seed0: u64| {
            let mut sum = vec![[0.0f64; 3]; (w * h) as usize];
            let mut sq = sum.clone();
            for f in 0..frames {
                let s = common::Settings { seed: seed0 + f, ..settings(w, h) };
                let film = path_frame(&world, &s, &PathSettings { kernel, ..budget }).expect("render").0;
                for (i, p) in film.pixels.iter().enumerate() {
                    for c in 0..3 {
                        let v = f64::from(p.colour[c]);
                        sum[i][c] += v;
                        sq[i][c] += v * v;
                    }
                }
            }
            (sum, sq)
        };
        let a = stats(PathKernel::Wavefront, 1000);
        let b = stats(PathKernel::Recursive, 0);
        let n = frames as f64;
        let moments = |(sum, sq): &(Vec<[f64; 3]>, Vec<[f64; 3]>), i: usize, c: usize| {
            let mean = sum[i][c] / n;
            (mean, ((sq[i][c] / n - mean * mean) * n / (n - 1.0)).max(0.0))
        };
        // Two-sided p = 0.01 over 768 tests (Bonferroni): |z| < 4.4; 5.0 leaves room for the
        // heavy tails of glass paths' variance estimates. A 10 % error in the delta lobes' weight,
        // or a lobe dropped, fails (checked by breaking the tracer on purpose).
        let mut worst = (0.0f64, 0usize);
        let (mut total_a, mut total_b, mut var_a, mut var_b) = (0.0, 0.0, 0.0, 0.0);
        for i in 0..(w * h) as usize {
            for c in 0..3 {
                let ((ma, va), (mb, vb)) = (moments(&a, i, c), moments(&b, i, c));
                (total_a, total_b, var_a, var_b) = (total_a + ma, total_b + mb, var_a + va, var_b + vb);
                let se = (va / n + vb / n).sqrt();
                if se > 0.0 {
                    let t = (ma - mb).abs() / se;
                    if t > worst.0 {
                        worst = (t, i);
                    }
                } else {
                    assert_eq!(ma, mb, "pixel {i} channel {c}: constant but different");
                }
            }
        }
        assert!(worst.0 < 5.0, "{budget:?}: pixel {}: |t| = {:.2}", worst.1, worst.0);
        // The whole image: its mean (pixels are independent across frames) within 4 standard errors.
        let se = (var_a / n + var_b / n).sqrt();
        assert!((total_a - total_b).abs() < 4.0 * se, "image sums {total_a} vs {total_b} ± {se}");
        assert!(total_a > 10.0, "a lit picture: {total_a}");
    }
}

/// The Variance AOV is the variance of one sample: across frames of different seeds, a
/// pixel's mean of N samples varies by Variance / N (averaged over the image, within the
/// sampling error of 200 frames; a sphere over a floor under a uniform sky, whose samples are
/// bounded so that the variance of the variance is small), and it is written only without a
/// filter.
#[test]
fn the_variance_aov_is_the_variance_of_one_sample() {
    let world = World::new(Scene {
        camera: Camera::look_at(Vec3::new(0.0, 1.5, 3.0), Vec3::ZERO, Vec3::Y, Fov::Vertical(50.0)),
        sky: Sky::Colour(Rgb::ONE),
        materials: vec![white_diffuse(0.8)],
        objects: vec![
            object(Shape::Sphere { centre: Vec3::new(0.0, 0.5, 0.0), radius: 0.5 }, 0),
            object(Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0),
        ],
        ..Scene::default()
    });
    let (w, h, spp, frames) = (12, 12, 8, 200);
    // Independent samples: with the stratified default a pixel's mean varies less than that.
    let p = PathSettings { sampler: Sampler::Independent, ..path(spp, 2, Filter::None) };
    let mut sum = vec![0.0f64; w * h];
    let mut sum_sq = vec![0.0f64; w * h];
    let mut predicted = 0.0;
    for seed in 0..frames {
        let s = common::Settings { seed, ..settings(w as u32, h as u32) };
        let film = path_frame(&world, &s, &p).expect("render").0;
        assert!(film.variance);
        for (i, (px, aov)) in film.pixels.iter().zip(&film.path).enumerate() {
            let c = f64::from(px.colour.x);
            sum[i] += c;
            sum_sq[i] += c * c;
            predicted += f64::from(aov.variance.x) / f64::from(spp);
        }
    }
    let n = frames as f64;
    let observed = (0..w * h).map(|i| (sum_sq[i] - sum[i] * sum[i] / n) / (n - 1.0)).sum::<f64>() / (w * h) as f64;
    let predicted = predicted / (n * (w * h) as f64);
    assert!(predicted > 0.0);
    assert!((observed / predicted - 1.0).abs() < 0.05, "observed {observed:e}, predicted {predicted:e}");
    let guided = path(4, 2, Filter::Guided(GuidedParams::for_width(8)));
    let film = path_frame(&world, &settings(8, 8), &guided).expect("render").0;
    assert!(!film.variance && film.aov_image().channel("Variance.R").is_none());
}

/// A time budget without a filter traces its passes in steps of many (the sums do not depend
/// on the grouping): the frame is the fixed frame of as many samples, bit for bit, AOVs
/// included, and reports its passes of `spp`; with a filter every pass is its own step.
#[test]
fn a_time_budget_is_the_frame_of_as_many_samples() {
    let world = World::new(mitsuba_cbox());
    let s = settings(24, 20);
    let gaussian = PixelFilter::Gaussian { stddev: 0.5 };
    let budget = Some(std::time::Duration::from_millis(150));
    for p in [PathSettings { pixel_filter: gaussian, ..path(2, 3, Filter::None) }, path(1, 2, Filter::None)] {
        let (timed, stats) = path_frame(&world, &s, &PathSettings { time_budget: budget, ..p }).expect("render");
        let n = stats.samples_per_pixel;
        assert!(n > 2 * p.spp && n % p.spp == 0, "{n} spp in the budget");
        assert_eq!(stats.passes, n / p.spp);
        let (fixed, _) = path_frame(&world, &s, &PathSettings { spp: n, ..p }).expect("render");
        assert_eq!(timed.pixels, fixed.pixels, "{n} spp");
        assert_eq!(timed.path, fixed.path, "{n} spp");
    }
}

/// A frame without the path AOVs (`aovs: false`, a render to PNG) draws the same picture and
/// first-hit AOVs bit for bit, splatted, sampled from the filter, in a box or filtered, and its
/// film holds no path AOV (none is written as zeros).
#[test]
fn a_frame_without_path_aovs_draws_the_same_picture() {
    let world = World::new(mitsuba_cbox());
    let s = settings(24, 20);
    let gaussian = PixelFilter::Gaussian { stddev: 0.5 };
    let guided = Filter::Guided(GuidedParams::for_width(24));
    let frames = [
        PathSettings { pixel_filter: gaussian, ..path(3, 3, Filter::None) },
        PathSettings { pixel_filter: gaussian, reconstruction: Reconstruction::Sample, ..path(3, 3, Filter::None) },
        path(3, 3, Filter::None),
        PathSettings { filter_area_direct: true, passes: 2, ..path(2, 2, guided) },
    ];
    let bits = |c: Rgb| c.to_array().map(f32::to_bits);
    for p in frames {
        let all = path_frame(&world, &s, &p).expect("render").0;
        let beauty = path_frame(&world, &s, &PathSettings { aovs: false, ..p }).expect("render").0;
        assert!(all.path_aovs && !beauty.path_aovs && !beauty.variance, "{p:?}");
        let image = beauty.aov_image();
        for name in ["Direct.R", "Indirect.G", "SampleCount", "Variance.B"] {
            assert!(image.channel(name).is_none(), "{name} written without the path AOVs: {p:?}");
        }
        assert!(image.channel("Albedo.R").is_some() && image.channel("Z").is_some());
        for (i, (a, b)) in all.pixels.iter().zip(&beauty.pixels).enumerate() {
            assert_eq!(bits(a.colour), bits(b.colour), "{p:?}: pixel {i}");
            assert_eq!(a.coverage.to_bits(), b.coverage.to_bits(), "{p:?}: coverage {i}");
            assert_eq!(all.surface[i], beauty.surface[i], "{p:?}: first hit {i}");
        }
    }
}

/// Mitsuba's `hide_emitters`: the sky and an emitter seen directly from the camera add nothing,
/// while what they light keeps every bit (only the camera vertex's emission is left out).
#[test]
fn hidden_emitters_leave_out_only_what_the_camera_sees_directly() {
    let scene = || Scene {
        camera: Camera::look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::new(0.0, 0.5, 0.0), Vec3::Y, Fov::Vertical(60.0)),
        sky: Sky::Colour(Rgb::splat(2.0)),
        materials: vec![white_diffuse(0.8), Material { emission: Rgb::splat(5.0), ..white_diffuse(0.0) }],
        objects: vec![
            object(Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0),
            object(Shape::Sphere { centre: Vec3::new(0.0, 0.6, 0.0), radius: 0.3 }, 1),
        ],
        ..Scene::default()
    };
    for kernel in [PathKernel::Wavefront, PathKernel::Recursive] {
        let shown = PathSettings { kernel, ..path(4, 2, Filter::None) };
        let hidden = PathSettings { hide_emitters: true, ..shown };
        let (a, b) = (render(scene(), 32, 24, &shown), render(scene(), 32, 24, &hidden));
        let (mut sky, mut lit) = (0, 0);
        for (i, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
            if (i % 32, i / 32) == (16, 12) {
                // The emitting sphere in the middle of the picture.
                assert!(p.colour.x > 4.0 && q.colour.x == 0.0, "{kernel:?}: sphere {} / {}", p.colour.x, q.colour.x);
            } else if p.coverage == 0.0 {
                sky += 1;
                assert_eq!((p.colour.x, q.colour.x), (2.0, 0.0), "{kernel:?}: the sky seen directly is hidden");
            } else if p.coverage == 1.0 && i / 32 > 18 {
                lit += 1;
                assert_eq!(p.colour, q.colour, "{kernel:?}: the floor at pixel {i} keeps its light");
            }
        }
        assert!(sky > 50 && lit > 50, "{kernel:?}: {sky} sky and {lit} floor pixels");
    }
}

/// A pixel filter spreads each pixel's samples as its profile: next to a sharp edge between a
/// black wall (left half) and a white sky, the pixels see the sky in the proportion of the
/// profile's mass on the sky's side (the box filter: a hard step), whether the samples are
/// splatted or their positions drawn from the filter.
#[test]
fn pixel_filters_weight_samples_by_their_profile() {
    let wall = glint_scene::Mesh {
        name: "wall".into(),
        positions: vec![
            Vec3::new(-100.0, -100.0, -1.0),
            Vec3::new(0.0, -100.0, -1.0),
            Vec3::new(0.0, 100.0, -1.0),
            Vec3::new(-100.0, 100.0, -1.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        ..glint_scene::Mesh::default()
    };
    let scene = Scene {
        camera: Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, Fov::Vertical(40.0)),
        sky: Sky::Colour(Rgb::ONE),
        materials: vec![white_diffuse(0.0)],
        meshes: vec![Arc::new(wall)],
        objects: vec![object(Shape::Mesh(0), 0)],
        ..Scene::default()
    };
    let world = World::new(scene);
    let filters = [PixelFilter::Box, PixelFilter::Tent { radius: 1.0 }, PixelFilter::Gaussian { stddev: 0.5 }];
    for (filter, reconstruction) in
        filters.into_iter().flat_map(|f| [(f, Reconstruction::Splat), (f, Reconstruction::Sample)])
    {
        let p = PathSettings { pixel_filter: filter, reconstruction, ..path(1024, 0, Filter::None) };
        let film = path_frame(&world, &settings(16, 8), &p).expect("render").0;
        // The fraction of the profile's mass beyond `d` pixels (fine midpoint sums).
        let r = filter.radius();
        let mass = |a: f32, b: f32| {
            (0..4000).map(|k| filter.eval(a + (b - a) * (k as f32 + 0.5) / 4000.0)).sum::<f32>() * (b - a)
        };
        let beyond = |d: f32| if d >= r { 0.0 } else { mass(d, r) / mass(-r, r) };
        for x in 6..10 {
            // Pixel x's centre is x + ½ − 8 pixels right of the edge.
            let d = x as f32 + 0.5 - 8.0;
            let want = if d > 0.0 { 1.0 - beyond(d) } else { beyond(-d) };
            let got = (0..8).map(|y| film.pixel(x, y).colour.x).sum::<f32>() / 8.0;
            assert!((got - want).abs() < 0.01, "{filter:?} {reconstruction:?}: pixel {x}: {got}, profile says {want}");
        }
    }
}

/// Splatting (Mitsuba's film) and filter sampling converge to the same picture, and splatted
/// pixels, which average their neighbours' samples too, have a lower error at the same
/// samples per pixel: on the Cornell box with Mitsuba's Gaussian film (σ = ½, about three
/// pixels' worth of samples in each), at 16 spp, against a 512-spp render.
#[test]
fn splatting_lowers_the_error_of_each_sample() {
    let world = cornell_box();
    let gaussian = |spp: u32, reconstruction: Reconstruction| PathSettings {
        pixel_filter: PixelFilter::Gaussian { stddev: 0.5 },
        reconstruction,
        sampler: Sampler::Independent,
        ..path(spp, 2, Filter::None)
    };
    let frame = |p: &PathSettings, seed: u64| {
        let s = common::Settings { seed, ..settings(48, 40) };
        path_frame(&world, &s, p).expect("render").0
    };
    let reference = frame(&gaussian(512, Reconstruction::Splat), 100);
    let mse = |f: &Film| {
        let d = |a: Rgb, b: Rgb| (a - b).length_squared() as f64 / 3.0;
        f.pixels.iter().zip(&reference.pixels).map(|(p, q)| d(p.colour, q.colour)).sum::<f64>() / f.pixels.len() as f64
    };
    let mean = |f: &Film| f.pixels.iter().map(|p| f64::from(p.colour.element_sum())).sum::<f64>();
    let (splat, sample) =
        (frame(&gaussian(16, Reconstruction::Splat), 1), frame(&gaussian(16, Reconstruction::Sample), 1));
    let (e_splat, e_sample) = (mse(&splat), mse(&sample));
    assert!(e_splat < 0.5 * e_sample, "MSE at 16 spp: splatted {e_splat:.3e}, sampled {e_sample:.3e}");
    let sampled_reference = frame(&gaussian(512, Reconstruction::Sample), 101);
    let (a, b) = (mean(&reference), mean(&sampled_reference));
    assert!((a / b - 1.0).abs() < 0.01, "image means: splatted {a}, sampled {b}");
}

/// An emission texture scales the emitted radiance where it is read: a light quad textured
/// with a checker (on / off by quarters) lights the floor as two quads covering just its lit
/// quarters do (light sampling reads the texture at the sampled point, BSDF sampling at the
/// hit), and the camera sees the pattern.
#[test]
fn an_emission_texture_lights_as_its_lit_parts() {
    use glint_core::Vec2;
    let quad = |x0: f32, x1: f32, z0: f32, z1: f32| glint_scene::Mesh {
        name: "light".into(),
        positions: vec![Vec3::new(x0, 2.0, z0), Vec3::new(x1, 2.0, z0), Vec3::new(x1, 2.0, z1), Vec3::new(x0, 2.0, z1)],
        // Wound to face down (toward the floor).
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        // u along x, v along z over the whole light (x, z in [−½, ½]).
        uvs: Some(vec![
            Vec2::new(x0 + 0.5, z0 + 0.5),
            Vec2::new(x1 + 0.5, z0 + 0.5),
            Vec2::new(x1 + 0.5, z1 + 0.5),
            Vec2::new(x0 + 0.5, z1 + 0.5),
        ]),
        ..glint_scene::Mesh::default()
    };
    let scene = |meshes: Vec<glint_scene::Mesh>, textured: bool| Scene {
        camera: Camera::look_at(Vec3::new(0.0, 1.0, 3.0), Vec3::ZERO, Vec3::Y, Fov::Vertical(50.0)),
        sky: Sky::Colour(Rgb::ZERO),
        materials: vec![
            white_diffuse(0.8),
            Material { emission: Rgb::splat(4.0), emission_texture: textured.then_some(0), ..white_diffuse(0.0) },
        ],
        textures: vec![glint_scene::Texture::Checker { size: 0.5, even: Rgb::ONE, odd: Rgb::ZERO }],
        objects: std::iter::once(object(Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0))
            .chain((0..meshes.len()).map(|i| object(Shape::Mesh(i), 1)))
            .collect(),
        meshes: meshes.into_iter().map(Arc::new).collect(),
        ..Scene::default()
    };
    let textured = scene(vec![quad(-0.5, 0.5, -0.5, 0.5)], true);
    let quarters = scene(vec![quad(-0.5, 0.0, -0.5, 0.0), quad(0.0, 0.5, 0.0, 0.5)], false);
    for kernel in [PathKernel::Wavefront, PathKernel::Recursive] {
        let p = PathSettings { kernel, ..path(64, 1, Filter::None) };
        let (a, b) = (render(textured.clone(), 32, 24, &p), render(quarters.clone(), 32, 24, &p));
        for (name, keep) in [("left", 0..16), ("right", 16..32)] {
            let (ma, _, _) = mean_and_error(&a, |i| keep.contains(&(i % 32)));
            let (mb, _, _) = mean_and_error(&b, |i| keep.contains(&(i % 32)));
            assert!(mb > 0.01 && (ma - mb).abs() < 0.03 * mb, "{kernel:?} {name}: textured {ma} vs quarters {mb}");
        }
    }
    // Seen from below, the light shows its pattern.
    let mut below = textured;
    below.camera = Camera::look_at(Vec3::new(0.0, 0.5, 0.0), Vec3::new(0.0, 2.0, 0.0), Vec3::Z, Fov::Vertical(20.0));
    let film = render(below, 16, 16, &path(4, 0, Filter::None));
    let (on, off) = (film.pixel(4, 4).colour.x, film.pixel(11, 4).colour.x);
    assert!((on == 4.0 && off == 0.0) || (on == 0.0 && off == 4.0), "pattern: {on} / {off}");
}
