//! Whitted mode against answers known in closed form, then determinism.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{Settings, render, render_pass, settings};

use glint_core::{Affine3A, Quat, Ray, Rgb, Vec3};
use glint_render::{Schedule, World};
use glint_scene::{Attenuation, Camera, Fov, Light, Material, Mesh, Object, Scene, Shape, Sky};
use std::sync::Arc;

fn object(name: &str, shape: Shape, material: usize) -> Object {
    Object { name: name.into(), shape, material, world_from_object: Affine3A::IDENTITY }
}

fn matte(colour: Rgb) -> Material {
    Material { colour, ambient: 0.0, diffuse: 1.0, specular: 0.0, ..Material::default() }
}

fn centre_colour(world: &World, w: u32, h: u32) -> Rgb {
    let (film, _) = render(world, &settings(w, h)).expect("valid settings");
    film.pixel(w / 2, h / 2).colour
}

/// A diffuse sphere lit head-on by a directional light: the pixel facing the camera is
/// albedo · K_d · I · cos 0 exactly (no ambient, no specular).
#[test]
fn lambert_sphere_matches_closed_form() {
    let scene = Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(30.0),
            lens: glint_scene::Lens::Pinhole,
        },
        sky: Sky::Colour(Rgb::ZERO),
        materials: vec![matte(Rgb::new(0.5, 0.25, 1.0))],
        objects: vec![object("s", Shape::Sphere { centre: Vec3::ZERO, radius: 1.0 }, 0)],
        lights: vec![Light::Directional { direction: -Vec3::Z, colour: Rgb::ONE, intensity: 0.8 }],
        ..Scene::default()
    };
    scene.validate().unwrap();
    let c = centre_colour(&World::new(scene), 65, 65);
    let want = Rgb::new(0.5, 0.25, 1.0) * 0.8;
    assert!((c - want).abs().max_element() < 1e-3, "{c} vs {want}");
}

/// A point light blocked by an opaque sphere leaves only the ambient term; a transparent sphere
/// (transparency 0.5, constant weights) lets through 0.5 per surface crossed: 0.25.
#[test]
fn shadows_are_attenuated_by_transparent_occluders() {
    let mut scene = Scene {
        materials: vec![matte(Rgb::ONE), Material { transparency: 0.5, fresnel: false, ..matte(Rgb::ONE) }],
        objects: vec![
            object("floor", Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0),
            object("ball", Shape::Sphere { centre: Vec3::new(0.0, 2.0, 0.0), radius: 0.5 }, 1),
        ],
        lights: vec![Light::Point {
            position: Vec3::new(0.0, 4.0, 0.0),
            colour: Rgb::ONE,
            intensity: 1.0,
            attenuation: Attenuation::None,
        }],
        ..Scene::default()
    };
    scene.validate().unwrap();
    let world = World::new(scene.clone());
    let down = Ray::new(Vec3::new(0.0, 4.0, 0.0), -Vec3::Y);
    let hit = world.intersect(&down).expect("hits the ball");
    assert!((hit.t - 1.5).abs() < 1e-5);
    let shadow = Ray::segment(Vec3::new(0.0, 1e-3, 0.0), Vec3::Y, 0.0, 3.999);
    let t = world.transmittance(&shadow);
    assert!((t - Rgb::splat(0.25)).abs().max_element() < 1e-6, "{t}");
    // Opaque: nothing passes.
    scene.materials[1].transparency = 0.0;
    let world = World::new(scene);
    assert_eq!(world.transmittance(&shadow), Rgb::ZERO);
    // Beside the ball the light is unobstructed.
    let beside = Ray::segment(
        Vec3::new(3.0, 1e-3, 0.0),
        (Vec3::new(0.0, 4.0, 0.0) - Vec3::new(3.0, 1e-3, 0.0)).normalize(),
        0.0,
        4.9,
    );
    assert_eq!(world.transmittance(&beside), Rgb::ONE);
}

/// A perfect mirror (no local term) shows the sky weighted by its reflectivity.
#[test]
fn mirror_reflects_the_sky_with_its_weight() {
    let mirror = Material {
        colour: Rgb::ZERO,
        ambient: 0.0,
        diffuse: 0.0,
        specular: 0.0,
        reflectivity: 0.7,
        ..Material::default()
    };
    let scene = Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(20.0),
            lens: glint_scene::Lens::Pinhole,
        },
        sky: Sky::Colour(Rgb::new(0.2, 0.4, 0.8)),
        materials: vec![mirror],
        objects: vec![object("wall", Shape::Plane { normal: Vec3::Z, offset: 0.0 }, 0)],
        ..Scene::default()
    };
    scene.validate().unwrap();
    let c = centre_colour(&World::new(scene), 33, 33);
    assert!((c - Rgb::new(0.14, 0.28, 0.56)).abs().max_element() < 1e-5, "{c}");
}

/// Two facing mirrors: the branch stops at the maximum depth, and the reflectivity series is
/// summed exactly (sky seen after k bounces contributes r^k ... here the camera looks along the
/// axis so every bounce returns; the result is the local terms' geometric series).
#[test]
fn facing_mirrors_terminate_at_max_depth() {
    let mirror = Material {
        colour: Rgb::ONE,
        ambient: 1.0,
        diffuse: 0.0,
        specular: 0.0,
        reflectivity: 0.5,
        ..Material::default()
    };
    let mut scene = Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 0.0),
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(1.0),
            lens: glint_scene::Lens::Pinhole,
        },
        ambient: Rgb::ONE,
        materials: vec![mirror],
        objects: vec![
            object("a", Shape::Plane { normal: Vec3::Z, offset: 1.0 }, 0),
            object("b", Shape::Plane { normal: -Vec3::Z, offset: 1.0 }, 0),
        ],
        ..Scene::default()
    };
    scene.validate().unwrap();
    for depth in [0u32, 1, 3, 8] {
        scene.render.max_depth = depth;
        let world = World::new(scene.clone());
        let mut s = settings(1, 1);
        s.max_depth = depth;
        s.min_contribution = 0.0;
        let (film, stats) = render(&world, &s).unwrap();
        let want: f32 = (0..=depth).map(|k| 0.5f32.powi(k as i32)).sum();
        let got = film.pixel(0, 0).colour.x;
        assert!((got - want).abs() < 1e-5, "depth {depth}: {got} vs {want}");
        assert_eq!(stats.rays.secondary, depth as u64);
    }
}

/// Looking through a glass slab at normal incidence: the exact Fresnel weights give
/// T = (1 - 0.04)² of the sky behind (plus the reflected part of the dark sky in front).
#[test]
fn glass_transmits_by_fresnel_and_refracted_rays_see_the_sky() {
    let glass = Material {
        colour: Rgb::ONE,
        ambient: 0.0,
        diffuse: 0.0,
        specular: 0.0,
        transparency: 1.0,
        ior: 1.5,
        ..Material::default()
    };
    let slab = Mesh {
        name: "slab".into(),
        positions: vec![
            Vec3::new(-5.0, -5.0, 0.5),
            Vec3::new(5.0, -5.0, 0.5),
            Vec3::new(5.0, 5.0, 0.5),
            Vec3::new(-5.0, 5.0, 0.5),
            Vec3::new(-5.0, -5.0, -0.5),
            Vec3::new(5.0, -5.0, -0.5),
            Vec3::new(5.0, 5.0, -0.5),
            Vec3::new(-5.0, 5.0, -0.5),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3], [4, 6, 5], [4, 7, 6]],
        ..Mesh::default()
    };
    let scene = Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.0, 5.0),
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(2.0),
            lens: glint_scene::Lens::Pinhole,
        },
        sky: Sky::Gradient { zenith: Rgb::ONE, horizon: Rgb::ONE, ground: Rgb::ONE },
        materials: vec![glass],
        meshes: vec![Arc::new(slab)],
        objects: vec![object("slab", Shape::Mesh(0), 0)],
        ..Scene::default()
    };
    scene.validate().unwrap();
    let mut s = settings(1, 1);
    s.max_depth = 30;
    s.min_contribution = 0.0;
    let (film, _) = render(&World::new(scene), &s).unwrap();
    // With a white sky on both sides, reflection + transmission of all orders sum to 1.
    let c = film.pixel(0, 0).colour;
    assert!((c - Rgb::ONE).abs().max_element() < 2e-3, "{c}");
}

/// Error-bounded offsets: a lit sphere far from the origin shades like the same sphere at the
/// origin (no shadow acne, no light leaking).
#[test]
fn no_self_intersection_far_from_the_origin() {
    let make = |offset: Vec3| {
        let scene = Scene {
            camera: Camera {
                position: offset + Vec3::new(0.0, 0.0, 4.0),
                forward: -Vec3::Z,
                up: Vec3::Y,
                fov: Fov::Vertical(40.0),
                lens: glint_scene::Lens::Pinhole,
            },
            sky: Sky::Colour(Rgb::ZERO),
            materials: vec![matte(Rgb::ONE)],
            objects: vec![object("s", Shape::Sphere { centre: offset, radius: 1.0 }, 0)],
            lights: vec![Light::Directional {
                direction: Vec3::new(-0.3, -0.5, -1.0).normalize(),
                colour: Rgb::ONE,
                intensity: 1.0,
            }],
            ..Scene::default()
        };
        let (film, _) = render(&World::new(scene), &settings(48, 48)).unwrap();
        film
    };
    let near = make(Vec3::ZERO);
    let far = make(Vec3::new(1.0e4, -3.0e3, 2.0e4));
    let mut worst = 0.0f32;
    let mut lit_black = 0;
    for (a, b) in near.pixels.iter().zip(&far.pixels) {
        worst = worst.max((a.colour - b.colour).abs().max_element());
        if a.colour.x > 0.05 && b.colour.x == 0.0 {
            lit_black += 1;
        }
    }
    assert_eq!(lit_black, 0, "acne: lit pixels turned black far from the origin");
    assert!(worst < 0.05, "worst difference {worst}");
}

/// Moving an instance moves its hits; refitting a mesh moves its hits; nothing else changes.
#[test]
fn two_level_updates_move_only_what_moved() {
    let tri = Mesh {
        name: "tri".into(),
        positions: vec![Vec3::new(-1.0, -1.0, 0.0), Vec3::new(1.0, -1.0, 0.0), Vec3::new(0.0, 1.0, 0.0)],
        triangles: vec![[0, 1, 2]],
        ..Mesh::default()
    };
    let scene = Scene {
        materials: vec![Material::default()],
        meshes: vec![Arc::new(tri)],
        objects: vec![
            object("tri", Shape::Mesh(0), 0),
            object("ball", Shape::Sphere { centre: Vec3::new(10.0, 0.0, 0.0), radius: 1.0 }, 0),
        ],
        ..Scene::default()
    };
    scene.validate().unwrap();
    let mut world = World::new(scene);
    let ray = Ray::new(Vec3::new(0.0, 0.0, 5.0), -Vec3::Z);
    assert!((world.intersect(&ray).unwrap().t - 5.0).abs() < 1e-5);
    // Translate the triangle toward the camera, and rotate it a quarter turn about Y (edge-on
    // would miss; a half turn keeps it facing): t shrinks by 2.
    assert!(world.set_transform(
        0,
        Affine3A::from_rotation_translation(Quat::from_rotation_y(std::f32::consts::PI), Vec3::new(0.0, 0.0, 2.0))
    ));
    let h = world.intersect(&ray).unwrap();
    assert!((h.t - 3.0).abs() < 1e-5, "{}", h.t);
    assert_eq!(h.object, 0);
    // The sphere did not move.
    let side = Ray::new(Vec3::new(10.0, 0.0, 5.0), -Vec3::Z);
    assert!((world.intersect(&side).unwrap().t - 4.0).abs() < 1e-5);
    // Deform the mesh: push every vertex 1 unit further away in object space (object z → -1,
    // which the half turn maps to world z = 3).
    let moved = vec![Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, -1.0, -1.0), Vec3::new(0.0, 1.0, -1.0)];
    assert!(world.update_mesh_positions(0, moved));
    let h = world.intersect(&ray).unwrap();
    assert!((h.t - 2.0).abs() < 1e-5, "{}", h.t);
    // Move the sphere (it leaves the untransformed-sphere set for the TLAS) and back.
    assert!(world.set_transform(1, Affine3A::from_translation(Vec3::new(0.0, 3.0, 0.0))));
    assert!(world.intersect(&side).is_none());
    let up = Ray::new(Vec3::new(10.0, 3.0, 5.0), -Vec3::Z);
    assert!((world.intersect(&up).unwrap().t - 4.0).abs() < 1e-5);
    assert!(world.occluded(&up));
    assert!(world.set_transform(1, Affine3A::IDENTITY));
    assert!((world.intersect(&side).unwrap().t - 4.0).abs() < 1e-5);
    assert!(!world.occluded(&up));
}

fn demo_like_scene() -> Scene {
    let mut scene = Scene {
        camera: Camera::look_at(Vec3::new(0.0, 1.5, 6.0), Vec3::new(0.0, 0.8, 0.0), Vec3::Y, Fov::Vertical(45.0)),
        ambient: Rgb::splat(0.1),
        materials: vec![
            Material { colour: Rgb::new(0.8, 0.8, 0.8), reflectivity: 0.1, ..Material::default() },
            Material { colour: Rgb::ONE, reflectivity: 0.9, ..Material::default() },
            Material { colour: Rgb::ONE, transparency: 0.95, ior: 1.5, diffuse: 0.1, ..Material::default() },
        ],
        objects: vec![
            object("floor", Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0),
            object("mirror", Shape::Sphere { centre: Vec3::new(-1.2, 1.0, 0.0), radius: 1.0 }, 1),
            object("glass", Shape::Sphere { centre: Vec3::new(1.0, 0.8, 1.0), radius: 0.8 }, 2),
        ],
        lights: vec![
            Light::Point {
                position: Vec3::new(-4.0, 6.0, 5.0),
                colour: Rgb::ONE,
                intensity: 0.9,
                attenuation: Attenuation::None,
            },
            Light::Directional { direction: Vec3::new(0.3, -1.0, -0.2).normalize(), colour: Rgb::ONE, intensity: 0.4 },
        ],
        ..Scene::default()
    };
    scene.render.samples_per_side = 2;
    scene
}

/// The same seed gives the same image bit for bit on 1 and 2 threads, and with either schedule.
#[test]
fn bit_identical_on_one_and_two_threads() {
    let world = World::new(demo_like_scene());
    let mut s = settings(96, 64);
    s.samples_per_side = 2;
    s.seed = 7;
    let run = |threads: usize, schedule: Schedule| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let s = Settings { schedule, ..s };
        pool.install(|| render(&world, &s).unwrap().0)
    };
    let a = run(1, Schedule::WorkStealing);
    let bits = |f: &glint_render::Film| -> Vec<u32> {
        (0..f.pixels.len())
            .map(|i| f.record(i))
            .flat_map(|p| [p.colour.x, p.colour.y, p.colour.z, p.depth, p.coverage, p.normal.x])
            .map(f32::to_bits)
            .collect()
    };
    for (threads, schedule) in [(2, Schedule::WorkStealing), (2, Schedule::Static), (1, Schedule::Static)] {
        let b = run(threads, schedule);
        assert!(bits(&a) == bits(&b), "{threads} threads {schedule:?} differ");
    }
    // A different seed moves the jittered samples.
    let c = {
        let s = Settings { seed: 8, ..s };
        render(&world, &s).unwrap().0
    };
    assert!(bits(&a) != bits(&c));
}

#[test]
fn impossible_settings_are_errors_not_panics() {
    let world = World::new(demo_like_scene());
    for s in [
        Settings { width: 0, ..settings(8, 8) },
        Settings { samples_per_side: 0, ..settings(8, 8) },
        Settings { max_depth: 10_000, ..settings(8, 8) },
        Settings { min_contribution: f32::NAN, ..settings(8, 8) },
    ] {
        assert!(render(&world, &s).is_err());
    }
}

/// Transparent meshes take the ordered walk; a slab (two surfaces) of transparency 0.5 passes
/// a quarter, a slab whose far face is opaque (per-triangle material) passes nothing, and a
/// transparent sphere in the same scene multiplies in.
#[test]
fn shadow_rays_walk_transparent_meshes_in_order() {
    let slab = |opaque_back: bool| Mesh {
        name: "slab".into(),
        positions: vec![
            Vec3::new(-1.0, 2.0, -1.0),
            Vec3::new(1.0, 2.0, -1.0),
            Vec3::new(1.0, 2.0, 1.0),
            Vec3::new(-1.0, 2.0, 1.0),
            Vec3::new(-1.0, 1.5, -1.0),
            Vec3::new(1.0, 1.5, -1.0),
            Vec3::new(1.0, 1.5, 1.0),
            Vec3::new(-1.0, 1.5, 1.0),
        ],
        triangles: vec![[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7]],
        triangle_materials: Some(if opaque_back { vec![1, 1, 0, 0] } else { vec![1, 1, 1, 1] }),
        ..Mesh::default()
    };
    let make = |opaque_back: bool, with_ball: bool| {
        let mut objects =
            vec![object("floor", Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0), object("slab", Shape::Mesh(0), 1)];
        if with_ball {
            objects.push(object("ball", Shape::Sphere { centre: Vec3::new(0.0, 3.0, 0.0), radius: 0.3 }, 1));
        }
        let scene = Scene {
            materials: vec![matte(Rgb::ONE), Material { transparency: 0.5, fresnel: false, ..matte(Rgb::ONE) }],
            meshes: vec![Arc::new(slab(opaque_back))],
            objects,
            ..Scene::default()
        };
        scene.validate().unwrap();
        World::new(scene)
    };
    let shadow = Ray::segment(Vec3::new(0.0, 1e-3, 0.0), Vec3::Y, 0.0, 3.999);
    let t = make(false, false).transmittance(&shadow);
    assert!((t - Rgb::splat(0.25)).abs().max_element() < 1e-6, "{t}");
    assert_eq!(make(true, false).transmittance(&shadow), Rgb::ZERO);
    let t = make(false, true).transmittance(&shadow);
    assert!((t - Rgb::splat(0.0625)).abs().max_element() < 1e-6, "{t}");
}

/// Progressive passes: pass 0 is the one-ray-per-pixel render bit for bit; the mean of 64
/// passes approaches the 8×8 supersampled image (much closer than pass 0 alone); passes do not
/// depend on the thread count.
#[test]
fn progressive_passes_converge_to_the_supersampled_image() {
    let text = include_str!("../../../scenes/whitted-bench.toml");
    let scene = glint_formats::load_scene_str(text, std::path::Path::new("."), "bench.toml").expect("scene").scene;
    let world = World::new(scene);
    let s = settings(64, 40);
    let (single, _) = render(&world, &s).expect("render");
    let (pass0, _) = render_pass(&world, &s, 0).expect("pass");
    assert!(pass0.pixels == single.pixels, "pass 0 is the centre-sample render");
    let (reference, _) = render(&world, &Settings { samples_per_side: 8, ..s }).expect("render");
    let mut sum = vec![Rgb::ZERO; pass0.pixels.len()];
    for k in 0..64 {
        let (f, _) = render_pass(&world, &s, k).expect("pass");
        for (acc, p) in sum.iter_mut().zip(&f.pixels) {
            *acc += p.colour;
        }
    }
    let err = |c: &dyn Fn(usize) -> Rgb| {
        reference.pixels.iter().enumerate().map(|(i, p)| (c(i) - p.colour).length_squared() as f64).sum::<f64>()
    };
    let e_mean = err(&|i| sum[i] / 64.0);
    let e_single = err(&|i| pass0.pixels[i].colour);
    assert!(e_mean < 0.25 * e_single, "64 passes {e_mean} vs one {e_single}");
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| render_pass(&world, &s, 5).expect("pass").0)
    };
    assert!(run(1).pixels == run(2).pixels);
}
