//! World tests: packets equal single rays, animation equals a world built at that time.

use super::*;
use glint_accel::procedural::displaced_sphere;
use glint_core::{Affine3A, Quat, Ray, Rgb, Vec2, Vec3};
use glint_scene::{Camera, Fov, Object};

fn scene(extra: Option<Shape>, world_from_object: Affine3A) -> Scene {
    let m = displaced_sphere(5_000);
    let mesh = Mesh { name: "ball".into(), positions: m.positions, triangles: m.triangles, ..Mesh::default() };
    let mut objects = vec![Object { name: "ball".into(), shape: Shape::Mesh(0), material: 0, world_from_object }];
    if let Some(shape) = extra {
        objects.push(Object { name: "extra".into(), shape, material: 0, world_from_object: Affine3A::IDENTITY });
    }
    Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.3, 3.0),
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(50.0),
            lens: glint_scene::Lens::Pinhole,
        },
        materials: vec![Material::default()],
        meshes: vec![Arc::new(mesh)],
        objects,
        ..Scene::default()
    }
}

/// A scene of one small mesh (a tree of one node) walks incoherent rays as packets too
/// (`World::packs_any_rays`, what the wavefront bins its rays by), with the single-ray answers;
/// a larger one does not.
#[test]
fn a_small_mesh_packs_incoherent_rays() {
    let m = glint_accel::procedural::icosphere(0);
    let mesh = Mesh { name: "ico".into(), positions: m.positions, triangles: m.triangles, ..Mesh::default() };
    let small = Scene {
        meshes: vec![Arc::new(mesh)],
        objects: vec![Object {
            name: "ico".into(),
            shape: Shape::Mesh(0),
            material: 0,
            world_from_object: Affine3A::IDENTITY,
        }],
        ..scene(None, Affine3A::IDENTITY)
    };
    let world = World::new(small);
    assert_eq!(world.packs_any_rays(), glint_accel::Isa::detect() == glint_accel::Isa::Avx2);
    assert!(!World::new(scene(None, Affine3A::IDENTITY)).packs_any_rays());
    let mut rng = glint_accel::procedural::Rng::new(3);
    for k in 0..500 {
        let rays: [Ray; 8] = std::array::from_fn(|_| Ray::new((rng.next_vec3() - 0.5) * 1.5, rng.next_dir()));
        let (mut hits, mut occ) = ([None; 8], [false; 8]);
        world.intersect8(&rays, &mut hits);
        world.occluded8(&rays, &mut occ);
        for i in 0..8 {
            assert_eq!(format!("{:?}", hits[i]), format!("{:?}", world.intersect(&rays[i])), "packet {k} lane {i}");
            assert_eq!(occ[i], world.occluded(&rays[i]), "packet {k} lane {i}");
        }
    }
}

/// 8-ray queries equal the single-ray ones bit for bit, on the packet path (one mesh) and
/// on the looping path (a plane or a transform in the scene), for primary tiles (distances
/// and whole surface hits) and shadow rays.
#[test]
fn eight_ray_queries_equal_single_rays() {
    let cases = [
        (scene(None, Affine3A::IDENTITY), true),
        (scene(Some(Shape::Plane { normal: Vec3::Y, offset: -0.9 }), Affine3A::IDENTITY), false),
        (scene(None, Affine3A::from_translation(Vec3::new(0.1, 0.0, 0.0))), false),
    ];
    for (scene, packets) in cases {
        scene.validate().expect("valid scene");
        let world = World::new(scene);
        assert_eq!(world.traces_packets(), packets);
        let cam = world.scene().camera.rays(32, 16);
        let light = Vec3::new(3.0, 4.0, 5.0);
        for ty in (0..16).step_by(2) {
            for tx in (0..32).step_by(4) {
                let tile: [Ray; 8] =
                    std::array::from_fn(|i| cam.ray(Vec2::new((tx + i % 4) as f32 + 0.5, (ty + i / 4) as f32 + 0.5)));
                let mut dist = [None; 8];
                world.hit_distance8(&tile, &mut dist);
                let shadow: [Ray; 8] = std::array::from_fn(|i| match world.intersect(&tile[i]) {
                    Some(h) => h.spawn_ray_to(light),
                    None => Ray::new(Vec3::NAN, Vec3::Z),
                });
                let mut occ = [false; 8];
                world.occluded8(&shadow, &mut occ);
                let mut hits = [None; 8];
                world.intersect8(&tile, &mut hits);
                for i in 0..8 {
                    // Debug prints each float's shortest round trip: equal text, equal bits.
                    let hit = format!("{:?}", world.intersect(&tile[i]));
                    assert_eq!(format!("{:?}", hits[i]), hit, "hit ({tx}, {ty}) lane {i}");
                    let want = world.hit_distance(&tile[i]);
                    assert_eq!(dist[i].map(f32::to_bits), want.map(f32::to_bits), "tile ({tx}, {ty}) lane {i}");
                    assert_eq!(occ[i], world.occluded(&shadow[i]), "shadow ({tx}, {ty}) lane {i}");
                }
            }
        }
    }
}

/// The 8-ray closest hits' surface data, interpolated in lanes, is the single-ray query's bit
/// for bit on meshes with vertex normals (some flipped, some zero), uvs and per-triangle
/// materials, several meshes merged into one tree (each hit mapped back to its own), and a
/// transformed instance among them (finished by the scalar code); coherent tiles and rays in
/// every direction.
#[test]
fn eight_mesh_hits_with_attributes_equal_single_rays() {
    let m = displaced_sphere(3_000);
    let n = m.positions.len();
    let normals = (0..n)
        .map(|i| match i % 17 {
            // A cap of zero normals: its triangles fall back to the geometric normal.
            _ if m.positions[i].y > 0.7 => Vec3::ZERO,
            1 => -m.positions[i].normalize(),
            _ => (m.positions[i] + Vec3::new(0.1, 0.0, 0.05) * (i % 5) as f32).normalize(),
        })
        .collect();
    let uvs = m.positions.iter().map(|p| Vec2::new(p.x * 0.5 + 0.5, p.y.atan2(p.z))).collect();
    let smooth = Mesh {
        name: "smooth".into(),
        positions: m.positions.clone(),
        normals: Some(normals),
        uvs: Some(uvs),
        triangle_materials: Some((0..m.triangles.len() as u32).map(|t| t % 2).collect()),
        triangles: m.triangles.clone(),
        ..Mesh::default()
    };
    let flat = Mesh { name: "flat".into(), positions: m.positions, triangles: m.triangles, ..Mesh::default() };
    let object = |shape, x: f32, material| Object {
        name: "o".into(),
        shape,
        material,
        world_from_object: Affine3A::from_translation(Vec3::new(x, 0.0, 0.0)),
    };
    for moved in [false, true] {
        // The smooth mesh untransformed (its hits interpolated in lanes), the flat one moved.
        let mut objects = vec![object(Shape::Mesh(0), 0.0, 0), object(Shape::Mesh(1), 2.2, 1)];
        objects[0].world_from_object = Affine3A::IDENTITY;
        if moved {
            // A third, rotated: baked into the merged tree, its hits finished by the scalar
            // code (an instance that is not the identity).
            let mut o = object(Shape::Mesh(2), 0.0, 0);
            o.world_from_object = Affine3A::from_translation(Vec3::new(-2.2, 0.0, 0.0))
                * Affine3A::from_rotation_y(0.7)
                * Affine3A::from_scale(Vec3::splat(0.5));
            objects.push(o);
        }
        let mut scene = scene(None, Affine3A::IDENTITY);
        scene.meshes = vec![Arc::new(smooth.clone()), Arc::new(flat.clone()), Arc::new(smooth.clone())];
        scene.materials = vec![Material::default(), Material { diffuse: 0.3, ..Material::default() }];
        scene.objects = objects;
        scene.validate().expect("valid scene");
        let world = World::new(scene);
        assert!(world.traces_packets(), "one merged tree: the packet path");
        let cam = world.scene().camera.rays(48, 24);
        let mut rng = glint_core::random::SampleStream::new(7, 0, 3);
        let mut lit = 0;
        for k in 0..400 {
            let rays: [Ray; 8] = std::array::from_fn(|i| {
                if k % 2 == 0 {
                    let (tx, ty) = ((k / 2) % 12 * 4, (k / 24) % 12 * 2);
                    cam.ray(Vec2::new((tx + i % 4) as f32 + 0.5, (ty + i / 4) as f32 + 0.5))
                } else {
                    let d = glint_core::sampling::sample_uniform_sphere(rng.next_2d());
                    Ray::new(-d * 3.0 + Vec3::new(rng.next_1d() - 0.5, 0.0, 0.0), d)
                }
            });
            let mut hits = [None; 8];
            world.intersect8(&rays, &mut hits);
            for i in 0..8 {
                let want = world.intersect(&rays[i]);
                lit += usize::from(want.is_some());
                assert_eq!(format!("{:?}", hits[i]), format!("{want:?}"), "moved {moved}, batch {k}, lane {i}");
            }
        }
        assert!(lit > 1000, "{lit} hits");
    }
}

use crate::whitted::{self, Samples};
use crate::{Film, Hooks, ImageSettings, WhittedSettings};
use glint_scene::{AnimationBase, AnimationTarget, Attenuation, Keyframes, Light, Motion, Repeat, Rotation};

/// A whole Whitted frame (one ray per pixel, depth 4) of `size` seen by the scene's camera.
fn frame(world: &World, (width, height): (u32, u32)) -> Film {
    let settings = WhittedSettings { samples_per_side: 1, max_depth: 4, ..WhittedSettings::default() };
    let mut film = Film::new(1, 1);
    let image = ImageSettings::new(width, height);
    whitted::render(world, &world.scene().camera, &image, &settings, Samples::Stratified, &Hooks::default(), &mut film)
        .expect("valid settings");
    film
}

fn colours(world: &World) -> Vec<[u32; 3]> {
    frame(world, (48, 32)).pixels.iter().map(|p| p.colour.to_array().map(f32::to_bits)).collect()
}

fn spin(axis: Vec3, degrees_per_second: f32) -> Option<Rotation> {
    Some(Rotation { axis, pivot: None, degrees_per_second, phase_deg: 0.0 })
}

fn keys(keys: Vec<(f32, Vec3)>, repeat: Repeat) -> Option<Keyframes> {
    Some(Keyframes { keys, repeat })
}

/// A mesh turning about the vertical, a sphere bouncing (it starts untransformed, in the
/// sphere set, and leaves it when it moves), a light circling, over a floor.
fn animated_scene() -> Scene {
    let mut s = scene(Some(Shape::Plane { normal: Vec3::Y, offset: 1.0 }), Affine3A::from_scale(Vec3::splat(0.6)));
    s.objects.push(Object {
        name: "ball".into(),
        shape: Shape::Sphere { centre: Vec3::new(1.0, -0.5, 0.0), radius: 0.4 },
        material: 0,
        world_from_object: Affine3A::IDENTITY,
    });
    s.lights.push(Light::Point {
        position: Vec3::new(2.0, 3.0, 2.0),
        colour: Rgb::ONE,
        intensity: 1.0,
        attenuation: Attenuation::None,
    });
    s.sky = Sky::Colour(Rgb::new(0.2, 0.3, 0.5));
    let turn = Motion { rotation: spin(Vec3::new(0.3, 1.0, 0.0), 40.0), translation: None };
    s.animate(&[AnimationTarget::Object(0)], turn).expect("in range");
    let bounce = keys(vec![(0.0, Vec3::ZERO), (1.0, Vec3::new(0.0, 1.2, 0.0))], Repeat::PingPong);
    s.animate(&[AnimationTarget::Object(2)], Motion { rotation: None, translation: bounce }).expect("in range");
    let circle = Rotation { pivot: Some(Vec3::ZERO), ..spin(Vec3::Y, 90.0).expect("some") };
    s.animate(&[AnimationTarget::Light(0)], Motion { rotation: Some(circle), translation: None }).expect("in range");
    s.set_time(0.0);
    s.validate().expect("valid animated scene");
    s
}

/// The scene at `t` placed by hand from the animations' rest states, not by `set_time`.
fn placed_directly(mut s: Scene, t: f32) -> Scene {
    for a in s.animations.clone() {
        let m = a.motion.transform_at(t, a.pivot);
        match (a.target, a.base) {
            (AnimationTarget::Object(i), AnimationBase::Object { world_from_object, .. }) => {
                s.objects[i].world_from_object = m * world_from_object;
            }
            (AnimationTarget::Light(i), AnimationBase::Light(Light::Point { position, .. })) => {
                let Light::Point { position: p, .. } = &mut s.lights[i] else { panic!("a point light") };
                *p = m.transform_point3(position);
            }
            _ => panic!("no other kinds here"),
        }
    }
    s
}

/// `set_time` moves instances and lights to exactly where a world built afresh at that time
/// has them: the same hits and bit-identical renders; back at 0 the first image returns.
#[test]
fn set_time_equals_a_world_built_at_that_time() {
    let scene = animated_scene();
    let mut world = World::new(scene.clone());
    let first = colours(&world);
    let unanimated = World::new(Scene { animations: Vec::new(), ..scene.clone() });
    assert_eq!(colours(&unanimated), first, "animations at rest change nothing");
    let blas_before: Vec<usize> = world.blas.iter().map(|b| b.stats().node_bytes).collect();
    for t in [0.35, 1.3, 2.75] {
        assert!(world.set_time(t), "t = {t}: something moved");
        let fresh = World::new(placed_directly(scene.clone(), t));
        assert_eq!(world.scene().objects, fresh.scene().objects, "t = {t}");
        assert_eq!(world.scene().lights, fresh.scene().lights, "t = {t}");
        // The kept bounds follow the moves (the path mode's depth scale reads them).
        assert_eq!(world.bounds(), fresh.bounds(), "t = {t}");
        assert_eq!(world.bounds(), world.scene().bounds(), "t = {t}");
        let cam = world.scene().camera.rays(24, 16);
        for y in 0..16 {
            for x in 0..24 {
                let ray = cam.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                let (a, b) = (world.intersect(&ray), fresh.intersect(&ray));
                let key = |h: Option<SurfaceHit>| h.map(|h| (h.t.to_bits(), h.object, h.prim, h.position.to_array()));
                assert_eq!(key(a), key(b), "t = {t}, pixel ({x}, {y})");
            }
        }
        let image = colours(&world);
        assert_eq!(image, colours(&fresh), "t = {t}");
        assert_ne!(image, first, "t = {t}: the picture changed");
    }
    assert_eq!(blas_before, world.blas.iter().map(|b| b.stats().node_bytes).collect::<Vec<_>>());
    assert!(world.set_time(0.0));
    assert_eq!(colours(&world), first, "back at t = 0");
    assert!(!world.set_time(0.0), "nothing moves from 0 to 0");
}

/// A light moving sideways moves the shadow of a ball on the floor (Whitted reads the
/// scene's lights at every render).
#[test]
fn a_moving_light_moves_the_shadow() {
    let matte = Material { ambient: 0.0, diffuse: 1.0, specular: 0.0, ..Material::default() };
    let mut s = Scene {
        camera: Camera {
            position: Vec3::new(0.0, 3.0, 6.0),
            forward: Vec3::new(0.0, -3.0, -6.0),
            up: Vec3::Y,
            fov: Fov::Vertical(40.0),
            lens: glint_scene::Lens::Pinhole,
        },
        sky: Sky::Colour(Rgb::ZERO),
        materials: vec![matte],
        objects: vec![
            Object {
                name: "floor".into(),
                shape: Shape::Plane { normal: Vec3::Y, offset: 0.0 },
                material: 0,
                world_from_object: Affine3A::IDENTITY,
            },
            Object {
                name: "ball".into(),
                shape: Shape::Sphere { centre: Vec3::Y, radius: 0.5 },
                material: 0,
                world_from_object: Affine3A::IDENTITY,
            },
        ],
        lights: vec![Light::Point {
            position: Vec3::new(0.0, 5.0, 0.0),
            colour: Rgb::ONE,
            intensity: 1.0,
            attenuation: Attenuation::None,
        }],
        ..Scene::default()
    };
    let slide = keys(vec![(0.0, Vec3::ZERO), (1.0, Vec3::new(4.0, 0.0, 0.0))], Repeat::Hold);
    s.animate(&[AnimationTarget::Light(0)], Motion { rotation: None, translation: slide }).expect("in range");
    s.validate().expect("valid");
    let mut world = World::new(s);
    let centre = |w: &World| frame(w, (33, 33)).pixel(16, 16).colour;
    let lit = |w: &World, p: Vec3| {
        let light = w.scene().lights[0].position().expect("a point light");
        let hit = w.intersect(&Ray::new(p + Vec3::Y, -Vec3::Y)).expect("the floor");
        w.transmittance(&hit.spawn_ray_to(light)).x > 0.0
    };
    let aside = Vec3::new(-1.25, 0.0, 0.0);
    assert_eq!(centre(&world), Rgb::ZERO, "under the ball: in its shadow");
    assert!(lit(&world, aside));
    assert!(world.set_time(1.0));
    assert_eq!(world.scene().lights[0].position(), Some(Vec3::new(4.0, 5.0, 0.0)));
    assert!(centre(&world).x > 0.1, "the shadow has moved away");
    assert!(!lit(&world, aside), "and fallen here");
    assert!(!world.set_time(2.0), "held at the last key");
}

/// An animated plane moves its equation: turned a quarter about Z it becomes x = 0, and
/// keyframes lift it.
#[test]
fn an_animated_plane_turns_and_rises() {
    let mut s = scene(
        Some(Shape::Plane { normal: Vec3::Y, offset: 0.0 }),
        Affine3A::from_translation(Vec3::new(0.0, 0.0, -50.0)),
    );
    let rise = keys(vec![(0.0, Vec3::ZERO), (1.0, Vec3::new(0.0, 1.0, 0.0))], Repeat::Hold);
    s.animate(&[AnimationTarget::Object(1)], Motion { rotation: None, translation: rise }).expect("in range");
    let mut world = World::new(s.clone());
    let down = Ray::new(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y);
    assert_eq!(world.intersect(&down).map(|h| h.t), Some(3.0));
    assert!(world.set_time(1.0));
    assert_eq!(world.intersect(&down).map(|h| h.t), Some(2.0));
    s.animations.clear();
    let quarter = Rotation { pivot: Some(Vec3::ZERO), ..spin(Vec3::Z, 90.0).expect("some") };
    s.animate(&[AnimationTarget::Object(1)], Motion { rotation: Some(quarter), translation: None }).expect("in range");
    let mut world = World::new(s);
    assert!(world.set_time(1.0));
    let hit = world.intersect(&Ray::new(Vec3::new(3.0, 0.5, 0.0), -Vec3::X)).expect("the plane x = 0");
    assert!((hit.t - 3.0).abs() < 1e-5 && (hit.geometric_normal - (-Vec3::X)).length() < 1e-6, "{hit:?}");
}

/// A scene with every kind of surface the batch queries treat apart: set spheres (one glass),
/// two planes (one transparent), an untransformed mesh, a transformed mesh, a transformed
/// sphere and a transparent mesh.
fn batch_scene() -> Scene {
    let mut s = scene(Some(Shape::Plane { normal: Vec3::Y, offset: 1.0 }), Affine3A::IDENTITY);
    let glass = Material { transparency: 0.7, ior: 1.5, ..Material::default() };
    let tinted = Material { transparency: 0.5, ..Material::default() };
    s.materials.extend([glass, tinted]);
    let mut add = |shape: Shape, material: usize, world_from_object: Affine3A| {
        s.objects.push(Object { name: "o".into(), shape, material, world_from_object });
    };
    add(Shape::Sphere { centre: Vec3::new(1.2, 0.0, 0.5), radius: 0.4 }, 1, Affine3A::IDENTITY);
    add(Shape::Sphere { centre: Vec3::new(-1.2, 0.2, 0.0), radius: 0.3 }, 0, Affine3A::IDENTITY);
    add(Shape::Sphere { centre: Vec3::ZERO, radius: 0.5 }, 0, Affine3A::from_translation(Vec3::new(0.0, 1.2, -1.0)));
    add(
        Shape::Mesh(0),
        2,
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(0.4),
            Quat::from_rotation_y(0.7),
            Vec3::new(1.5, 1.0, -2.0),
        ),
    );
    add(Shape::Plane { normal: Vec3::new(0.0, 0.0, 1.0), offset: 4.0 }, 2, Affine3A::IDENTITY);
    s
}

/// Eight-ray batches (surface data and shadow transmittance) equal the single-ray queries lane
/// by lane, bit for bit, with random active masks, on primary rays and on rays from inside.
#[test]
fn batches_equal_single_rays() {
    struct Check;
    impl glint_accel::lanes::LaneKernel for Check {
        type Output = ();
        #[inline(always)]
        fn run<I: glint_accel::lanes::Isa>(self) {
            batches_equal_single_rays_with::<I>();
        }
    }
    glint_accel::lanes::dispatch(Check, true);
    glint_accel::lanes::dispatch(Check, false);
}

#[allow(clippy::needless_range_loop)] // lanes indexed as the kernels index them
fn batches_equal_single_rays_with<I: glint_accel::lanes::Isa>() {
    use glint_accel::batch::Rays8;
    use glint_accel::lanes::{LANES, M8};
    let scene = batch_scene();
    scene.validate().expect("valid scene");
    let world = World::new(scene);
    let cam = world.scene().camera.rays(64, 48);
    let light = Vec3::new(2.0, 5.0, 4.0);
    let (mut hits, mut kinds, mut partial) = (0, std::collections::HashSet::new(), 0);
    let mut seed = 1u32;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed
    };
    let cones = world.point_cones(light);
    let eye_cones = world.point_cones(cam.origin);
    let (mut skipped, mut skipped_primary) = (0, 0);
    // One output kept across batches, as the tracer keeps it: stale lanes must not leak.
    let mut batch = Surfaces8::default();
    for ty in 0..24 {
        for tx in 0..16 {
            let rays: [Ray; LANES] = std::array::from_fn(|i| {
                let r = cam.ray(Vec2::new((tx * 4 + i % 4) as f32 + 0.5, (ty * 2 + i / 4) as f32 + 0.5));
                if (tx + ty) % 3 == 0 { Ray::new(Vec3::new(0.1, 0.2, 0.1), r.dir) } else { r }
            });
            let active = M8::<I>::from_bits(next() & 0xff | 1);
            let rays8 = Rays8::<I>::from_rays(&rays);
            if (tx + ty) % 3 == 0 {
                world.intersect_batch(&rays8, active, &mut batch);
            } else {
                // Camera rays leave the eye: its cones may skip spheres (the same hits).
                let spheres = eye_cones.candidates(rays8.dir, active);
                skipped_primary += (!spheres & 0b111).count_ones();
                world.intersect_batch_among(&rays8, active, spheres, &mut batch);
            }
            let mut shadows = [Ray::new(Vec3::ZERO, Vec3::Y); LANES];
            let mut to_light = 0u32;
            for i in 0..LANES {
                let want = if active.lane(i) { world.intersect(&rays[i]) } else { None };
                to_light |= u32::from(want.is_some()) << i;
                assert_eq!(format!("{:?}", batch.lane(i)), format!("{want:?}"), "tile ({tx}, {ty}) lane {i}");
                if let Some(h) = want {
                    shadows[i] = h.spawn_ray_to(light);
                    hits += 1;
                    kinds.insert(h.object);
                }
            }
            let pass = world.transmittance_batch(&Rays8::from_rays(&shadows), active);
            for i in 0..LANES {
                let want = if active.lane(i) { world.transmittance(&shadows[i]) } else { Rgb::ZERO };
                assert_eq!(
                    pass.lane(i).to_array().map(f32::to_bits),
                    want.to_array().map(f32::to_bits),
                    "shadow ({tx}, {ty}) lane {i}"
                );
                partial += (want.x > 0.0 && want.x < 1.0) as usize;
            }
            // The light's cones may skip spheres for the lanes aimed at it: same light passed.
            let shadow8 = Rays8::<I>::from_rays(&shadows);
            let to_light = M8::<I>::from_bits(to_light) & active;
            let spheres = cones.candidates(-shadow8.dir, to_light);
            skipped += (!spheres & 0b111).count_ones();
            let among = world.transmittance_batch_among(&shadow8, to_light, spheres);
            for i in (0..LANES).filter(|&i| to_light.lane(i)) {
                let want = world.transmittance(&shadows[i]).to_array().map(f32::to_bits);
                assert_eq!(among.lane(i).to_array().map(f32::to_bits), want, "culled shadow ({tx}, {ty}) lane {i}");
            }
        }
    }
    assert!(hits > 1000 && kinds.len() >= 6 && partial > 20, "{hits} hits on {kinds:?}, {partial} partial shadows");
    assert!(skipped > 500, "the light's cones skipped only {skipped} sphere tests");
    assert!(skipped_primary > 200, "the eye's cones skipped only {skipped_primary} sphere tests");
}

/// Three meshes (one moved, one mirrored) and a transparent one: the merged tree answers what
/// the instances answered — same surface, object and triangle, distances equal up to rounding,
/// the same occlusion — and an object moved later leaves the tree and is found where it went.
#[test]
fn the_merged_tree_finds_what_the_instances_find() {
    let ball = |n| {
        let m = displaced_sphere(n);
        Arc::new(Mesh { name: "ball".into(), positions: m.positions, triangles: m.triangles, ..Mesh::default() })
    };
    let placed =
        |mesh, material, w| Object { name: "o".into(), shape: Shape::Mesh(mesh), material, world_from_object: w };
    let scene = Scene {
        camera: Camera {
            position: Vec3::new(0.0, 0.3, 6.0),
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(50.0),
            lens: glint_scene::Lens::Pinhole,
        },
        materials: vec![Material::default(), Material { transparency: 0.5, ..Material::default() }],
        meshes: vec![ball(2_000), ball(3_000), ball(1_000), ball(500)],
        objects: vec![
            placed(0, 0, Affine3A::IDENTITY),
            placed(
                1,
                0,
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(0.7, 1.2, 0.9),
                    Quat::from_rotation_y(0.6),
                    Vec3::new(1.4, 0.2, -0.5),
                ),
            ),
            placed(
                2,
                0,
                Affine3A::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * Affine3A::from_translation(Vec3::new(1.5, -0.4, 0.8)),
            ),
            placed(3, 1, Affine3A::from_translation(Vec3::new(0.0, 1.3, 0.5))),
        ],
        ..Scene::default()
    };
    scene.validate().expect("valid scene");
    let merged = World::new(scene.clone());
    let merged_triangles: usize = (0..3).map(|m| merged.meshes[m].triangles.len()).sum();
    assert_eq!(merged.merged.as_ref().map(|m| m.owner.len()), Some(merged_triangles));
    let members: Vec<bool> = merged.instances.iter().map(|i| i.merged).collect();
    assert_eq!(members, [true, true, true, false], "opaque static meshes merged, the transparent one not");
    let mut apart = World::new(scene);
    apart.pin(&[0, 1, 2, 3]);
    assert!(apart.merged.is_none() && apart.instances.iter().all(|i| !i.merged));
    let cam = merged.scene().camera.rays(64, 48);
    let light = Vec3::new(3.0, 4.0, 5.0);
    let (mut hits, mut same) = (0, 0);
    for y in 0..48 {
        for x in 0..64 {
            let ray = cam.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let (a, b) = (merged.intersect(&ray), apart.intersect(&ray));
            assert_eq!(a.is_some(), b.is_some(), "pixel ({x}, {y}) {a:?} {b:?}");
            let (Some(a), Some(b)) = (a, b) else { continue };
            hits += 1;
            assert!((a.t - b.t).abs() <= 1e-5 * a.t, "pixel ({x}, {y}): t {} vs {}", a.t, b.t);
            same += ((a.object, a.prim, a.material) == (b.object, b.prim, b.material)
                && (a.shading_normal - b.shading_normal).length() < 1e-4) as usize;
            let shadow = a.spawn_ray_to(light);
            assert_eq!(merged.occluded(&shadow), apart.occluded(&shadow), "pixel ({x}, {y})");
            assert_eq!(merged.transmittance(&shadow), apart.transmittance(&shadow), "pixel ({x}, {y})");
        }
    }
    // Rounding may move a hit across an edge of two triangles; never to another object.
    assert!(hits > 500 && same * 1000 >= hits * 998, "{same} of {hits} hits on the same triangle");
    // Object 1 moves: it leaves the merged tree and is hit where it went.
    let mut moving = merged;
    let up = Affine3A::from_translation(Vec3::new(0.0, 20.0, 0.0));
    assert!(moving.set_transform(1, up));
    assert!(!moving.instances[1].merged);
    let probe = Ray::new(Vec3::new(0.0, 20.0, 6.0), -Vec3::Z);
    assert_eq!(moving.intersect(&probe).map(|h| h.object), Some(1));
}

/// A shadow ray leaving an axis-aligned wall at coordinate 0 does not find the wall itself
/// (Mitsuba's Cornell box: its green wall at x = 0 lost 30 % of its direct light to such
/// self-hits, at t ≈ 1e-5, before ray origins were offset by at least the largest error bound).
#[test]
fn shadow_rays_leave_an_axis_aligned_wall_at_zero() {
    let wall = Mesh {
        name: "wall".into(),
        positions: vec![
            Vec3::new(0.0, 0.0, 559.2),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.0, 548.8, 0.0),
            Vec3::new(0.0, 548.8, 559.2),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        ..Mesh::default()
    };
    let world = World::new(Scene {
        materials: vec![Material::default()],
        meshes: vec![Arc::new(wall)],
        objects: vec![Object {
            name: "wall".into(),
            shape: Shape::Mesh(0),
            material: 0,
            world_from_object: Affine3A::IDENTITY,
        }],
        ..Scene::default()
    });
    let eye = Vec3::new(278.0, 273.0, -800.0);
    let mut blocked = 0;
    for i in 0..400 {
        let p = Vec3::new(0.0, 20.0 + (i % 20) as f32 * 25.0, 10.0 + (i / 20) as f32 * 27.0);
        let hit = world.intersect(&Ray::new(eye, (p - eye).normalize())).expect("the wall");
        let light = Vec3::new(213.0 + (i % 7) as f32 * 20.0, 548.3, 227.0 + (i % 5) as f32 * 25.0);
        blocked += usize::from(world.occluded(&hit.spawn_ray_to(light)));
    }
    assert_eq!(blocked, 0);
}

/// A mesh attribute at a hit: a face's value, or its vertices' values weighted by where the
/// hit lies in the triangle, whether the mesh is merged into the static tree or placed by a
/// transform; the texture that reads it scales it, and a surface without it shows the scale.
#[test]
fn mesh_attributes_are_read_at_the_hit() {
    use glint_scene::{MeshAttribute, Texture};
    let corners = [Rgb::new(1.0, 0.0, 0.0), Rgb::new(0.0, 1.0, 0.0), Rgb::new(0.0, 0.0, 1.0), Rgb::ONE];
    let quad = Mesh {
        name: "quad".into(),
        positions: vec![
            Vec3::new(-1.0, -1.0, 0.0),
            Vec3::new(1.0, -1.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(-1.0, 1.0, 0.0),
        ],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        attributes: vec![
            MeshAttribute { name: "vertex_color".into(), values: corners.to_vec() },
            MeshAttribute { name: "face_color".into(), values: vec![Rgb::splat(0.25), Rgb::splat(0.75)] },
        ],
        ..Mesh::default()
    };
    for placed in
        [Affine3A::IDENTITY, Affine3A::from_rotation_translation(Quat::from_rotation_y(0.4), Vec3::new(0.3, 0.1, -0.5))]
    {
        let scene = Scene {
            materials: vec![Material::default()],
            meshes: vec![Arc::new(quad.clone())],
            objects: vec![Object {
                name: "quad".into(),
                shape: Shape::Mesh(0),
                material: 0,
                world_from_object: placed,
            }],
            textures: vec![Texture::MeshAttribute { name: "vertex_color".into(), scale: 2.0 }],
            ..Scene::default()
        };
        let world = World::new(scene);
        // Local (0.5, −0.2): in triangle 0 (below the diagonal y = x).
        let local = Vec3::new(0.5, -0.2, 0.0);
        let target = placed.transform_point3(local);
        let normal = placed.transform_vector3(Vec3::Z);
        let ray = Ray::new(target + normal * 2.0, -normal);
        let hit = world.intersect(&ray).expect("the quad");
        // p = a + b1 (b − a) + b2 (c − a) with a, b, c = (−1, −1), (1, −1), (1, 1):
        // y = −1 + 2 b2, x = −1 + 2 b1 + 2 b2.
        let (b2, b1) = ((local.y + 1.0) / 2.0, (local.x - local.y) / 2.0);
        let want = corners[0] * (1.0 - b1 - b2) + corners[1] * b1 + corners[2] * b2;
        let got = world.mesh_attribute(&hit, "vertex_color").expect("vertex_color");
        assert!((got - want).abs().max_element() < 1e-5, "{got} vs {want}");
        assert_eq!(world.mesh_attribute(&hit, "face_color"), Some(Rgb::splat(0.25)));
        assert!((world.texture_at(0, &hit) - want * 2.0).abs().max_element() < 1e-5);
        assert_eq!(world.mesh_attribute(&hit, "vertex_nothing"), None);
        // Above the diagonal: the second face.
        let other = placed.transform_point3(Vec3::new(-0.5, 0.5, 0.0));
        let hit = world.intersect(&Ray::new(other + normal * 2.0, -normal)).expect("the quad");
        assert_eq!(world.mesh_attribute(&hit, "face_color"), Some(Rgb::splat(0.75)));
    }
}

/// A light's cones never drop a sphere that a ray leaving the light meets: directions aimed
/// at and just around each sphere's silhouette (where rounding decides), including a light
/// inside a sphere (its cone admits everything) and one right at a surface.
#[test]
fn point_cones_keep_every_sphere_a_ray_meets() {
    use glint_accel::batch::Rays8;
    use glint_accel::lanes::{LANES, M8, Sse};
    let world = World::new(batch_scene());
    let mut seed = 7u32;
    let mut rnd = || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed as f32 / u32::MAX as f32
    };
    let spheres = [(Vec3::new(1.2, 0.0, 0.5), 0.4f32), (Vec3::new(-1.2, 0.2, 0.0), 0.3)];
    let lights =
        [Vec3::new(2.0, 5.0, 4.0), Vec3::new(-30.0, 0.1, 2.0), Vec3::new(1.3, 0.1, 0.5), Vec3::new(1.2, 0.4, 0.5)];
    let (mut met, mut dropped) = (0, 0);
    for light in lights {
        let cones = world.point_cones(light);
        for (k, &(centre, radius)) in spheres.iter().enumerate() {
            for _ in 0..2000 {
                // A point on or near the silhouette disc, seen from the light.
                let p = centre
                    + Vec3::new(rnd() - 0.5, rnd() - 0.5, rnd() - 0.5).normalize_or_zero()
                        * radius
                        * (0.98 + 0.04 * rnd());
                let dir = (p - light).normalize();
                let ray = Ray::new(light, dir);
                let meets = glint_accel::primitives::intersect_sphere(&ray, centre, radius).is_some();
                let from = Rays8::<Sse>::from_rays(&[ray; LANES]);
                let kept = cones.candidates(from.dir, M8::all()) >> k & 1 == 1;
                assert!(kept || !meets, "light {light} sphere {k}: a meeting ray {dir} was culled");
                met += usize::from(meets);
                dropped += usize::from(!kept);
            }
        }
    }
    assert!(met > 1000 && dropped > 100, "{met} meeting rays, {dropped} culled");
}
