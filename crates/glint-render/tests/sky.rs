//! Skies in the Whitted mode (DESIGN.md §4): faces seen the right way round, direction-only
//! lookups, mip-mapped minification, Schlick reflections and the sky as ambient light.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{render, settings};

use glint_core::{Affine3A, Rgb, Vec3};
use glint_render::World;
use glint_scene::{Camera, CubeMap, Fov, LatLongMap, Material, Object, Scene, Shape, Sky, SkyTransform, TextureImage};
use std::sync::Arc;

fn object(shape: Shape, material: usize) -> Object {
    Object { name: "o".into(), shape, material, world_from_object: Affine3A::IDENTITY }
}

/// A scene that shows only the sky: one small sphere far behind the camera.
fn sky_only(camera: Camera, sky: Sky) -> Scene {
    let behind = camera.position - camera.forward.normalize() * 1000.0;
    Scene {
        camera,
        sky,
        materials: vec![Material::default()],
        objects: vec![object(Shape::Sphere { centre: behind, radius: 0.1 }, 0)],
        ..Scene::default()
    }
}

/// 5×7 bitmaps of asymmetric letters: mirrored or flipped, they read differently.
const GLYPHS: [[&str; 7]; 6] = [
    ["#####", "#....", "#....", "####.", "#....", "#....", "#...."], // F
    ["####.", "#...#", "#...#", "####.", "#.#..", "#..#.", "#...#"], // R
    ["####.", "#...#", "#...#", "####.", "#....", "#....", "#...."], // P
    ["#...#", "#..#.", "#.#..", "##...", "#.#..", "#..#.", "#...#"], // K
    ["#....", "#....", "#....", "#....", "#....", "#....", "#####"], // L
    ["#####", "..#..", "..#..", "..#..", "..#..", "..#..", "..#.."], // T
];

/// A face of `n`² texels: a letter in the upper left quadrant and a colour ramp, unique per face.
fn lettered_face(face: usize, n: usize) -> TextureImage {
    let mut texels = vec![Rgb::ZERO; n * n];
    let cell = n / 16;
    for y in 0..n {
        for x in 0..n {
            let base = Rgb::new(x as f32 / n as f32, y as f32 / n as f32, face as f32 / 6.0) * 0.3;
            let (gx, gy) = (x / cell, y / cell);
            let ink = (1..6).contains(&gx) && (1..8).contains(&gy) && GLYPHS[face][gy - 1].as_bytes()[gx - 1] == b'#';
            texels[y * n + x] = if ink { Rgb::ONE } else { base };
        }
    }
    TextureImage { width: n as u32, height: n as u32, texels }
}

fn psnr(a: &[Rgb], b: &[Rgb]) -> f64 {
    let mse: f64 =
        a.iter().zip(b).map(|(p, q)| ((*p - *q).length_squared() / 3.0) as f64).sum::<f64>() / a.len() as f64;
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (1.0 / mse).log10() }
}

fn render_colours(scene: Scene, w: u32, h: u32) -> Vec<Rgb> {
    scene.validate().unwrap();
    let (film, stats) = render(&World::new(scene), &settings(w, h)).unwrap();
    assert_eq!(stats.rejected_samples, 0);
    film.pixels.iter().map(|p| p.colour).collect()
}

/// Looking at each named face the way a person would — ahead at the front, turning to the
/// right, left and back with +Y up, tilting the head up from the front (the top of the picture
/// toward the back) and down — shows the face exactly as its image is stored: letters read
/// the right way, not mirrored or upside down.
#[test]
fn every_face_reads_the_right_way_round() {
    let n = 64;
    let faces: [TextureImage; 6] = std::array::from_fn(|f| lettered_face(f, n));
    let map = Arc::new(CubeMap::from_faces(faces.clone()).unwrap());
    // (face index in px nx py ny pz nz order, forward, up)
    let views = [
        (0, Vec3::X, Vec3::Y),   // right
        (1, -Vec3::X, Vec3::Y),  // left
        (2, Vec3::Y, Vec3::Z),   // up: the top of the picture is the back
        (3, -Vec3::Y, -Vec3::Z), // down: the top of the picture is the front
        (4, -Vec3::Z, Vec3::Y),  // front (the default camera)
        (5, Vec3::Z, Vec3::Y),   // back
    ];
    for (face, forward, up) in views {
        let camera = Camera {
            position: Vec3::new(3.0, -2.0, 7.0),
            forward,
            up,
            fov: Fov::Vertical(90.0),
            lens: glint_scene::Lens::Pinhole,
        };
        let sky = Sky::CubeMap { map: map.clone(), transform: SkyTransform::default() };
        let seen = render_colours(sky_only(camera, sky), n as u32, n as u32);
        let stored = &faces[face].texels;
        let p = psnr(&seen, stored);
        assert!(p > 50.0, "face {face}: the picture differs from the stored face ({p:.1} dB)");
        // And it is not the mirror image, nor upside down.
        let mirrored: Vec<Rgb> = (0..n * n).map(|i| stored[(i / n) * n + (n - 1 - i % n)]).collect();
        let flipped: Vec<Rgb> = (0..n * n).map(|i| stored[(n - 1 - i / n) * n + i % n]).collect();
        assert!(psnr(&seen, &mirrored) < 25.0, "face {face} matches its mirror image");
        assert!(psnr(&seen, &flipped) < 25.0, "face {face} matches its upside-down image");
    }
}

#[test]
fn moving_the_camera_leaves_the_sky_bit_identical() {
    let map = Arc::new(LatLongMap::from_fn(64, |d| Rgb::new(d.x.abs(), d.y.max(0.0), 0.5 + 0.5 * d.z)));
    let cube = Arc::new(CubeMap::from_fn(32, |d| Rgb::new(d.x.abs(), d.y.max(0.0), 0.5 + 0.5 * d.z)));
    for sky in [
        Sky::LatLong { map, transform: SkyTransform::new(30.0, 1.5) },
        Sky::CubeMap { map: cube, transform: SkyTransform::default() },
    ] {
        let at = |p: Vec3| {
            let camera = Camera {
                position: p,
                forward: Vec3::new(0.3, 0.2, -1.0),
                up: Vec3::Y,
                fov: Fov::Vertical(60.0),
                lens: glint_scene::Lens::Pinhole,
            };
            render_colours(sky_only(camera, sky.clone()), 48, 32)
        };
        let a = at(Vec3::ZERO);
        let b = at(Vec3::new(120.0, -40.0, 3e4));
        assert!(a.iter().zip(&b).all(|(p, q)| p.to_array() == q.to_array()), "the sky moved with the camera");
    }
}

/// A 1024² face of one-texel checks seen at 64 pixels across (16 texels per pixel): the mip
/// pyramid gives the mean grey, where the finest level alone would alias into noise.
#[test]
fn minified_faces_do_not_alias() {
    let n = 1024usize;
    let checks = glint_testkit::skies::checker_face(n);
    let map = Arc::new(CubeMap::from_faces(std::array::from_fn(|_| checks.clone())).unwrap());
    let camera = Camera {
        position: Vec3::ZERO,
        forward: Vec3::new(0.2, 0.1, -1.0),
        up: Vec3::Y,
        fov: Fov::Vertical(90.0),
        lens: glint_scene::Lens::Pinhole,
    };
    let seen =
        render_colours(sky_only(camera, Sky::CubeMap { map: map.clone(), transform: SkyTransform::default() }), 64, 64);
    let worst = seen.iter().map(|c| (c.x - 0.5).abs()).fold(0.0f32, f32::max);
    assert!(worst < 0.05, "a minified checker should read grey, worst pixel off by {worst}");
    // The finest level alone, one ray per pixel, is far from grey somewhere.
    let raw = (0..64 * 64)
        .map(|i| {
            let cam = camera.rays(64, 64);
            let r = cam.ray(glint_core::Vec2::new((i % 64) as f32 + 0.5, (i / 64) as f32 + 0.5));
            (map.lookup(r.dir).x - 0.5).abs()
        })
        .fold(0.0f32, f32::max);
    assert!(raw > 0.3, "the unfiltered lookup should alias ({raw})");
}

/// A flat surface that only reflects (no diffuse, no ambient), f0 = 0.04, under a uniform sky
/// of radiance 1: each pixel is Schlick's F for its viewing angle.
#[test]
fn schlick_reflection_follows_the_viewing_angle() {
    let f0 = 0.04f32;
    let mirror = Material {
        ambient: 0.0,
        diffuse: 0.0,
        specular: 0.0,
        reflection_f0: Some(Rgb::splat(f0)),
        ..Material::default()
    };
    let camera = Camera {
        position: Vec3::new(0.0, 1.0, 0.0),
        forward: Vec3::new(0.0, -1.0, -1.0),
        up: Vec3::Y,
        fov: Fov::Vertical(60.0),
        lens: glint_scene::Lens::Pinhole,
    };
    let scene = Scene {
        camera,
        sky: Sky::Colour(Rgb::ONE),
        materials: vec![mirror],
        objects: vec![object(Shape::Plane { normal: Vec3::Y, offset: 0.0 }, 0)],
        ..Scene::default()
    };
    let (w, h) = (33, 33);
    scene.validate().unwrap();
    let world = World::new(scene.clone());
    let (film, _) = render(&world, &settings(w, h)).unwrap();
    let rays = scene.camera.rays(w, h);
    for (x, y) in [(16, 16), (16, 4), (16, 30), (2, 28)] {
        let r = rays.ray(glint_core::Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let cos = (-r.dir.normalize()).dot(Vec3::Y);
        let want = f0 + (1.0 - f0) * (1.0 - cos).powi(5);
        let got = film.pixel(x, y).colour.x;
        assert!((got - want).abs() < 1e-4, "pixel ({x}, {y}): {got} vs Schlick {want}");
    }
    // A sphere above the plane shows in the reflection (a traced ray, not a raw sky lookup):
    // the pixel that reflects it is darker than the sky's F.
    let mut blocked = scene;
    blocked.materials.push(Material {
        colour: Rgb::ZERO,
        ambient: 0.0,
        diffuse: 0.0,
        specular: 0.0,
        ..Material::default()
    });
    blocked.objects.push(object(Shape::Sphere { centre: Vec3::new(0.0, 1.0, -2.0), radius: 0.9 }, 1));
    let (film2, _) = render(&World::new(blocked), &settings(w, h)).unwrap();
    let (a, b) = (film.pixel(16, 16).colour.x, film2.pixel(16, 16).colour.x);
    assert!(b < 0.5 * a, "the occluder should show in the reflection: {b} vs {a}");
}

/// With `sky_ambient`, a white sky of radiance L gives a matte surface (K_a = 1, no lights)
/// exactly its albedo times L; a sky bright only above lights the top of a sphere, not its
/// underside.
#[test]
fn the_sky_is_the_ambient_light() {
    let matte =
        Material { colour: Rgb::new(0.5, 0.5, 0.25), ambient: 1.0, diffuse: 0.0, specular: 0.0, ..Material::default() };
    let camera = Camera {
        position: Vec3::new(0.0, 0.0, 4.0),
        forward: -Vec3::Z,
        up: Vec3::Y,
        fov: Fov::Vertical(40.0),
        lens: glint_scene::Lens::Pinhole,
    };
    let mut scene = Scene {
        camera,
        sky: Sky::Colour(Rgb::splat(2.0)),
        ambient: Rgb::ONE,
        sky_ambient: true,
        materials: vec![matte],
        objects: vec![object(Shape::Sphere { centre: Vec3::ZERO, radius: 1.0 }, 0)],
        ..Scene::default()
    };
    let c = render_colours(scene.clone(), 33, 33)[16 * 33 + 16];
    assert!((c - Rgb::new(1.0, 1.0, 0.5)).abs().max_element() < 1e-3, "{c}");
    let cube = Arc::new(CubeMap::from_fn(16, |d| if d.y > 0.0 { Rgb::splat(2.0) } else { Rgb::ZERO }));
    scene.sky = Sky::CubeMap { map: cube, transform: SkyTransform::default() };
    let img = render_colours(scene, 33, 33);
    let (top, bottom) = (img[5 * 33 + 16], img[27 * 33 + 16]);
    assert!(top.x > 3.0 * bottom.x + 0.1, "top {top} should be lit far more than bottom {bottom}");
}
