#![allow(clippy::unwrap_used, clippy::expect_used)]

use super::project::{EMPTY, pixel_of};
use super::pyramid::{Level, ellipse_contains, interpolate};
use super::*;
use glint_core::{Affine3A, Vec3};
use glint_scene::{CloudObject, Fov, Light, Material, Orientation, PointCloud, Sky};
use std::sync::Arc;

/// A camera at the origin looking along −Z with a 90° vertical field of view: at depth z, one
/// pixel of an N-pixel-high image spans 2z / N world units.
fn camera() -> Camera {
    Camera {
        position: Vec3::ZERO,
        forward: Vec3::NEG_Z,
        up: Vec3::Y,
        fov: Fov::Vertical(90.0),
        lens: glint_scene::Lens::Pinhole,
    }
}

/// One frame of `scene`'s clouds seen by its camera.
fn render_points(
    scene: &Scene,
    (width, height): (u32, u32),
    settings: &PointSettings,
) -> Result<(PointFrame, PointStats), RenderError> {
    let mut renderer = PointRenderer::new(scene)?;
    let mut frame = PointFrame::default();
    let stats = renderer.render(scene, &scene.camera, &ImageSettings::new(width, height), settings, &mut frame)?;
    Ok((frame, stats))
}

fn scene_of(clouds: Vec<PointCloud>) -> Scene {
    Scene {
        camera: camera(),
        sky: Sky::Colour(Rgb::new(0.1, 0.2, 0.3)),
        ambient: Rgb::splat(0.2),
        materials: vec![Material::default()],
        lights: vec![Light::Directional { direction: Vec3::new(0.0, 0.0, -1.0), colour: Rgb::ONE, intensity: 1.0 }],
        clouds: clouds
            .into_iter()
            .map(|c| CloudObject {
                name: c.name.clone(),
                cloud: Arc::new(c),
                material: 0,
                world_from_object: Affine3A::IDENTITY,
            })
            .collect(),
        ..Scene::default()
    }
}

/// Points on the plane z = −`depth` (normal +Z, facing the camera), on a grid of `spacing`
/// world units over [−half, half]², each of radius `radius`, minus those `keep` rejects.
fn plane(depth: f32, half: f32, spacing: f32, radius: f32, keep: impl Fn(f32, f32, usize) -> bool) -> PointCloud {
    let n = (2.0 * half / spacing).round() as i32;
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (-half + i as f32 * spacing, -half + j as f32 * spacing);
            if keep(x, y, (j * (n + 1) + i) as usize) {
                positions.push(Vec3::new(x, y, -depth));
            }
        }
    }
    let count = positions.len();
    PointCloud {
        name: "plane".into(),
        positions,
        normals: Some(vec![Vec3::Z; count]),
        radii: Some(vec![radius; count]),
        colours: None,
        orientation: Orientation::Oriented,
        ..PointCloud::default()
    }
}

fn render(scene: &Scene, size: u32, fill: Fill) -> (PointFrame, PointRenderer) {
    let mut r = PointRenderer::new(scene).unwrap();
    let mut frame = PointFrame::default();
    let settings = PointSettings { fill, ..PointSettings::default() };
    r.render(scene, &scene.camera, &ImageSettings::new(size, size), &settings, &mut frame).unwrap();
    (frame, r)
}

/// A cheap deterministic "random" keep/drop per point.
fn hash01(i: usize) -> f32 {
    glint_core::random::unit_float(glint_core::random::hash4(i as u64, 0, 0, 11))
}

#[test]
fn a_plane_with_holes_is_filled_with_its_depth_and_normal() {
    // 128² pixels; the plane at depth 4 spans [−2, 2]² = the middle half of the image (64 px);
    // points every 4 pixels (spacing 0.25), radius 1.25 spacings, a quarter of them missing.
    let cloud = plane(4.0, 2.0, 0.25, 0.3125, |_, _, i| hash01(i) > 0.25);
    // Each point's pixel position (16 px per world unit at depth 4).
    let centres: Vec<Vec2> = cloud.positions.iter().map(|p| Vec2::new(64.0 + 16.0 * p.x, 64.0 - 16.0 * p.y)).collect();
    let scene = scene_of(vec![cloud]);
    for fill in [Fill::Ellipses, Fill::PullPush] {
        let (frame, _) = render(&scene, 128, fill);
        let mut checked = 0;
        for y in 36..92 {
            for x in 36..92 {
                let i = y * 128 + x;
                // Pixels well inside some point's disc (radius 5 px) must be filled; the
                // random removals leave a few spots no disc covers, which stay open.
                let q = Vec2::new(x as f32 + 0.5, y as f32 + 0.5);
                let nearest = centres.iter().map(|c| c.distance(q)).fold(f32::INFINITY, f32::min);
                if nearest > 5.0 - 1.5 {
                    continue;
                }
                assert!(frame.depth[i].is_finite(), "{fill:?}: hole at ({x}, {y})");
                assert!((frame.depth[i] - 4.0).abs() < 1e-4, "{fill:?}: depth {} at ({x}, {y})", frame.depth[i]);
                assert!(frame.normal[i].dot(Vec3::Z) > 0.9999, "{fill:?}: normal {} at ({x}, {y})", frame.normal[i]);
                checked += 1;
            }
        }
        assert!(checked > 56 * 56 * 8 / 10, "{checked} pixels checked");
        // Outside the plane (beyond its discs) the sky stays; without ellipses the fill
        // spreads over the whole image (the classic pull-push).
        assert_eq!(frame.depth[5 * 128 + 5].is_finite(), fill == Fill::PullPush);
        if fill == Fill::Ellipses {
            assert_eq!(frame.colour[5 * 128 + 5], Rgb::new(0.1, 0.2, 0.3));
        }
    }
    // Raw points leave the holes: the check above can fail.
    let (raw, _) = render(&scene, 128, Fill::Raw);
    let holes = (36..92).flat_map(|y| (36..92).map(move |x| y * 128 + x)).filter(|&i| !raw.depth[i].is_finite());
    assert!(holes.count() > 56 * 56 / 2);
}

#[test]
fn a_tilted_plane_is_filled_with_interpolated_depth() {
    // The plane through (0, 0, −4) with normal (0, sin 30°, cos 30°): depth varies down the image.
    let tilt = Affine3A::from_translation(Vec3::new(0.0, 0.0, -4.0))
        * Affine3A::from_rotation_x(-30f32.to_radians())
        * Affine3A::from_translation(Vec3::new(0.0, 0.0, 4.0));
    let mut scene = scene_of(vec![plane(4.0, 1.5, 0.2, 0.25, |_, _, _| true)]);
    scene.clouds[0].world_from_object = tilt;
    let (frame, _) = render(&scene, 128, Fill::Ellipses);
    let n = tilt.transform_vector3(Vec3::Z);
    let view = View::new(&scene.camera, 128, 128);
    let mut worst = 0.0f32;
    for y in 48..80 {
        for x in 44..84 {
            let i = y * 128 + x;
            assert!(frame.depth[i].is_finite(), "hole at ({x}, {y})");
            // Exact depth where the pixel's centre ray meets the plane.
            let dir = view.ray_at_depth_one(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            let z = Vec3::new(0.0, 0.0, -4.0).dot(n) / dir.dot(n);
            worst = worst.max((frame.depth[i] - z).abs());
            assert!(frame.normal[i].dot(n) > 0.999, "normal {} at ({x}, {y})", frame.normal[i]);
        }
    }
    // Within a quarter of the point spacing along the view axis.
    assert!(worst < 0.05, "worst depth error {worst}");
}

#[test]
fn gaps_in_a_front_surface_are_filled_from_it_not_from_the_surface_behind() {
    // Front plane at depth 4, sparse (every 4 px); back plane at depth 8, one point per pixel.
    let front = plane(4.0, 2.0, 0.25, 0.3125, |_, _, _| true);
    // A real hole in the front surface, wider than its discs: the back plane must show there.
    let front =
        PointCloud { positions: front.positions.iter().copied().filter(|p| p.x.hypot(p.y) > 0.75).collect(), ..front };
    let count = front.positions.len();
    let front = PointCloud { normals: Some(vec![Vec3::Z; count]), radii: Some(vec![0.3125; count]), ..front };
    let back = plane(8.0, 4.0, 0.0625, 0.09, |_, _, _| true);
    let scene = scene_of(vec![front, back]);
    let (raw, _) = render(&scene, 128, Fill::Raw);
    let (full, _) = render(&scene, 128, Fill::Ellipses);
    let mut back_through_gaps = 0;
    for y in 36..92i32 {
        for x in 36..92i32 {
            let i = (y * 128 + x) as usize;
            // The pixel's distance from the image centre in world units at depth 4.
            let r = Vec2::new(x as f32 + 0.5 - 64.0, y as f32 + 0.5 - 64.0).length() / 16.0;
            if raw.depth[i] > 6.0 {
                back_through_gaps += 1;
            }
            if r > 0.75 + 0.3125 + 0.1 {
                assert!((full.depth[i] - 4.0).abs() < 1e-4, "({x}, {y}) shows depth {}", full.depth[i]);
            } else if r < 0.75 - 0.3125 - 0.1 {
                assert!((full.depth[i] - 8.0).abs() < 1e-4, "hole at ({x}, {y}) shows depth {}", full.depth[i]);
            }
        }
    }
    assert!(back_through_gaps > 1000, "the raw points must show the back plane through the gaps");
}

#[test]
fn silhouettes_stop_at_the_ellipses() {
    // A disc of points of radius 1 (16 px at depth 4), spacing 0.25 (4 px), point radius 0.3125.
    let disc = plane(4.0, 1.0, 0.25, 0.3125, |x, y, _| x.hypot(y) <= 1.0 + 1e-4);
    let scene = scene_of(vec![disc]);
    let reach = |frame: &PointFrame| {
        let mut far = 0.0f32;
        for y in 0..128 {
            for x in 0..128 {
                if frame.depth[y * 128 + x].is_finite() {
                    far = far.max(Vec2::new(x as f32 + 0.5 - 64.0, y as f32 + 0.5 - 64.0).length());
                }
            }
        }
        far
    };
    let (full, _) = render(&scene, 128, Fill::Ellipses);
    let (plain, _) = render(&scene, 128, Fill::PullPush);
    // Pixels: the disc's edge (16) plus a point's radius (5) plus the pixel's half-diagonal.
    let limit = 16.0 + 5.0 + 0.75;
    assert!(reach(&full) <= limit, "ellipses: coverage reaches {} px", reach(&full));
    assert!(reach(&full) >= 16.0, "the disc itself is covered");
    assert!(reach(&plain) > limit + 2.0, "without ellipses the fill bleeds: {} px", reach(&plain));
}

#[test]
fn displacement_vectors_point_at_the_true_centre_after_several_levels() {
    // Two points on pixels (5, 9) and (6, 12) of a 32² image: every level's texel holding both
    // must place its ellipse centre at their mean pixel centre.
    let view = View::new(&camera(), 32, 32);
    let world_at = |px: f32, py: f32| {
        let d = view.ray_at_depth_one(Vec2::new(px, py));
        d * 4.0
    };
    let positions = vec![world_at(5.5, 9.5), world_at(6.5, 12.5)];
    let cloud = PointCloud {
        name: "two".into(),
        positions,
        normals: Some(vec![Vec3::Z; 2]),
        radii: Some(vec![0.01; 2]),
        orientation: Orientation::Oriented,
        ..PointCloud::default()
    };
    let scene = scene_of(vec![cloud]);
    let (_, r) = render(&scene, 32, Fill::Ellipses);
    let levels = r.levels();
    assert_eq!(levels.len(), 5);
    let mut found = 0;
    for (k, level) in levels.iter().enumerate() {
        let scale = (1 << (k + 1)) as f32;
        for y in 0..level.height as i64 {
            for x in 0..level.width as i64 {
                let t = level.at(x, y);
                if !t.is_valid() {
                    continue;
                }
                let centre = (Vec2::new(x as f32 + 0.5, y as f32 + 0.5) + t.displacement) * scale;
                // Level k+1 holds both points from the level where (9..12 >> k+1) meet.
                let both = (9 >> (k + 1)) == (12 >> (k + 1)) && (5 >> (k + 1)) == (6 >> (k + 1));
                let expect = if both {
                    Vec2::new(6.0, 11.0)
                } else if y == 9 >> (k + 1) {
                    Vec2::new(5.5, 9.5)
                } else {
                    Vec2::new(6.5, 12.5)
                };
                // Texels filled by the push carry interpolated centres; the pulled ones are exact.
                if t.z_min == 4.0 {
                    assert!((centre - expect).length() < 1e-4, "level {} texel ({x}, {y}): {centre}", k + 1);
                    found += 1;
                }
            }
        }
    }
    assert!(found >= 5, "{found} texels checked");
}

#[test]
fn renormalisation_matches_the_papers_example() {
    // Fine pixel (1, 1): parent (0, 0) weighs 9, (1, 0) and (0, 1) 3 each, (1, 1) 1. Leave out
    // (1, 0): the rest weigh 9/13, 3/13 and 1/13.
    let texel = |colour: Rgb| Texel {
        z_min: 1.0,
        z_max: 1.5,
        depth: 1.0,
        normal: Vec3::NEG_Z,
        radius: 10.0,
        colour,
        displacement: Vec2::ZERO,
        material: 0,
    };
    let coarse = Level {
        width: 2,
        height: 2,
        texels: vec![
            texel(Rgb::new(1.0, 0.0, 0.0)),
            Texel::INVALID,
            texel(Rgb::new(0.0, 1.0, 0.0)),
            texel(Rgb::new(0.0, 0.0, 1.0)),
        ],
        ..Level::default()
    };
    let t = interpolate(&coarse, 1, 1, true).unwrap();
    let expect = Rgb::new(9.0, 3.0, 1.0) / 13.0;
    assert!((t.colour - expect).abs().max_element() < 1e-6, "{}", t.colour);
    // The three contributors of DESIGN.md: weights 1, 3, 9 → 1/13, 3/13, 9/13.
    assert!((t.colour.x - 9.0 / 13.0).abs() < 1e-6 && (t.colour.z - 1.0 / 13.0).abs() < 1e-6);
    // An ellipse that misses the fine pixel's centre drops out too.
    let mut small = coarse.clone();
    small.texels[3].radius = 0.1;
    let t = interpolate(&small, 1, 1, true).unwrap();
    assert!((t.colour - Rgb::new(9.0, 3.0, 0.0) / 12.0).abs().max_element() < 1e-6);
    let t = interpolate(&small, 1, 1, false).unwrap();
    assert!((t.colour - expect).abs().max_element() < 1e-6);
    // Nothing valid: no contributor.
    let empty = Level { width: 2, height: 2, texels: vec![Texel::INVALID; 4], ..Level::default() };
    assert!(interpolate(&empty, 1, 1, true).is_none());
}

#[test]
fn ellipses_follow_the_projected_normal() {
    // A disc tilted 60° about the image's y axis: its major axis is vertical (radius 4), its
    // minor axis horizontal (4 × cos 60° = 2).
    let n = Vec3::new(60f32.to_radians().sin(), 0.0, -60f32.to_radians().cos());
    let t = Texel { normal: n, radius: 4.0, z_min: 1.0, z_max: 2.0, ..Texel::INVALID };
    let c = Vec2::ZERO;
    assert!(ellipse_contains(&t, c, Vec2::new(0.0, 3.9)));
    assert!(!ellipse_contains(&t, c, Vec2::new(0.0, 4.1)));
    assert!(ellipse_contains(&t, c, Vec2::new(1.9, 0.0)));
    assert!(!ellipse_contains(&t, c, Vec2::new(2.1, 0.0)));
    assert!(!ellipse_contains(&t, c, Vec2::new(1.5, 3.0)));
}

/// A random cloud in front of the camera.
fn random_cloud(n: usize, seed: u64, oriented: bool) -> PointCloud {
    let mut positions = Vec::with_capacity(n);
    let mut normals = Vec::with_capacity(n);
    for i in 0..n {
        let mut s = glint_core::random::SampleStream::new(i as u64, 0, seed);
        let u = s.next_2d();
        let v = s.next_2d();
        positions.push(Vec3::new(u.x * 6.0 - 3.0, u.y * 6.0 - 3.0, -2.0 - v.x * 6.0));
        normals.push(glint_core::sampling::sample_uniform_sphere(s.next_2d()));
    }
    PointCloud {
        name: "random".into(),
        radii: Some(vec![0.02; n]),
        positions,
        normals: Some(normals),
        orientation: if oriented { Orientation::Oriented } else { Orientation::Unknown },
        ..PointCloud::default()
    }
}

#[test]
fn projection_equals_a_serial_reference() {
    for oriented in [false, true] {
        let scene = scene_of(vec![random_cloud(200_000, 3, oriented)]);
        let points = PreparedPoints::new(&scene).unwrap();
        let view = View::new(&scene.camera, 97, 61);
        let clouds = view::cloud_views(&points, &view, true);
        // One pixel per point in both builds of the lane kernel (AVX2 where the CPU has it,
        // and the SSE baseline), and the squares.
        for (side, baseline) in [(1, false), (1, true), (3, false)] {
            let depth: Vec<std::sync::atomic::AtomicU64> =
                (0..97 * 61).map(|_| std::sync::atomic::AtomicU64::new(EMPTY)).collect();
            project::project_with(&points, &clouds, &view, &depth, side, baseline);
            // Serial: every point in order, a plain comparison.
            let mut reference = vec![EMPTY; 97 * 61];
            let mut culled = 0;
            for (i, p) in points.stream.iter().enumerate() {
                let Some((x, y, z)) = pixel_of(p, &clouds[0], &view) else {
                    culled += 1;
                    continue;
                };
                let lo = -((side as i64 - 1) / 2);
                for yy in (y as i64 + lo).max(0)..(y as i64 + lo + side as i64).min(61) {
                    for xx in (x as i64 + lo).max(0)..(x as i64 + lo + side as i64).min(97) {
                        let slot = &mut reference[(yy * 97 + xx) as usize];
                        *slot = (*slot).min(project::pack(z, i as u32));
                    }
                }
            }
            let got: Vec<u64> = depth.into_iter().map(|d| d.into_inner()).collect();
            assert_eq!(got, reference, "oriented {oriented}, side {side}, baseline {baseline}");
            // Culling removes about half of the oriented points (random normals), none otherwise.
            let frac = culled as f64 / points.len() as f64;
            if oriented {
                assert!(frac > 0.4, "culled {frac}");
            }
        }
        // Independent geometry: each winner's world position projects into its pixel.
        let depth: Vec<std::sync::atomic::AtomicU64> =
            (0..97 * 61).map(|_| std::sync::atomic::AtomicU64::new(EMPTY)).collect();
        project::project(&points, &clouds, &view, &depth, 1);
        let rays = scene.camera.rays(97, 61);
        for (pixel, word) in depth.iter().enumerate() {
            let word = word.load(std::sync::atomic::Ordering::Relaxed);
            if word == EMPTY {
                continue;
            }
            let (z, i) = project::unpack(word);
            let p = points.stream[i as usize].position;
            assert!((rays.depth(p) - z).abs() < 1e-5 * z);
            // The pixel's corners bound the point's direction.
            let (x, y) = ((pixel % 97) as f32, (pixel / 97) as f32);
            let d = (p - rays.origin) / rays.depth(p);
            let q = view.centre + Vec2::new(d.dot(view.right), d.dot(view.down)) * view.focal;
            assert!(
                q.x > x - 1e-3 && q.x < x + 1.0 + 1e-3 && q.y > y - 1e-3 && q.y < y + 1.0 + 1e-3,
                "{q} in ({x}, {y})"
            );
        }
    }
}

#[test]
fn one_and_two_threads_give_the_same_bits() {
    let scene = scene_of(vec![random_cloud(300_000, 5, false), plane(6.0, 3.0, 0.1, 0.12, |_, _, i| hash01(i) > 0.5)]);
    let run = |threads: usize, fill: Fill, shading: PointShading| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        pool.install(|| {
            let mut r = PointRenderer::new(&scene).unwrap();
            let mut frame = PointFrame::default();
            let settings = PointSettings { fill, shading, ..PointSettings::default() };
            r.render(&scene, &scene.camera, &ImageSettings::new(203, 157), &settings, &mut frame).unwrap();
            frame
        })
    };
    for (fill, shading) in [
        (Fill::Ellipses, PointShading::Phong),
        (Fill::PullPush, PointShading::EyeDome),
        (Fill::Squares, PointShading::Flat),
        (Fill::Raw, PointShading::Phong),
    ] {
        let a = run(1, fill, shading);
        let b = run(2, fill, shading);
        let bits = |f: &PointFrame| -> Vec<u32> {
            f.colour
                .iter()
                .flat_map(|c| c.to_array())
                .chain(f.depth.iter().copied())
                .chain(f.normal.iter().flat_map(|n| n.to_array()))
                .map(f32::to_bits)
                .collect()
        };
        assert_eq!(bits(&a), bits(&b), "{fill:?}");
        assert!(a.coverage() > 0.1);
    }
}

#[test]
fn back_faces_are_culled_only_when_normals_are_oriented() {
    // A plane whose normals point away from the camera.
    let mut away = plane(4.0, 1.0, 0.05, 0.06, |_, _, _| true);
    away.normals = Some(vec![Vec3::NEG_Z; away.len()]);
    let scene = scene_of(vec![away.clone()]);
    let (frame, _) = render(&scene, 64, Fill::Ellipses);
    assert_eq!(frame.coverage(), 0.0);
    away.orientation = Orientation::Unknown;
    let scene = scene_of(vec![away]);
    let (frame, _) = render(&scene, 64, Fill::Ellipses);
    assert!(frame.coverage() > 0.05);
    // Drawn two-sided, lit as seen from the camera: normals face it.
    let i = 32 * 64 + 32;
    assert!(frame.normal[i].dot(Vec3::Z) > 0.999);
    assert!(frame.colour[i].x > 0.5, "lit by the light behind the camera: {}", frame.colour[i]);
}

#[test]
fn squares_cover_their_side_and_eye_dome_darkens_steps() {
    // One point, squares of 5 px: 25 pixels.
    let one = PointCloud { name: "one".into(), positions: vec![Vec3::new(0.01, 0.01, -4.0)], ..PointCloud::default() };
    let scene = scene_of(vec![one]);
    let settings = PointSettings { fill: Fill::Squares, square_side: 5, ..PointSettings::default() };
    let (frame, _) = render_points(&scene, (32, 32), &settings).unwrap();
    assert_eq!(frame.depth.iter().filter(|d| d.is_finite()).count(), 25);
    // Eye-dome: two planes, the far one darkened beside the near one's edge, flat elsewhere.
    let near = plane(4.0, 1.0, 0.02, 0.03, |_, _, _| true);
    let far = plane(8.0, 8.0, 0.04, 0.05, |x, _, _| x > 0.0);
    let mut scene = scene_of(vec![near, far]);
    scene.clouds.iter_mut().for_each(|c| Arc::make_mut(&mut c.cloud).normals = None);
    let settings = PointSettings { shading: PointShading::Auto, ..PointSettings::default() };
    let (frame, _) = render_points(&scene, (128, 128), &settings).unwrap();
    let at = |x: usize, y: usize| frame.colour[y * 128 + x].x;
    // Near plane spans pixels 48..80; the far plane's pixels just right of it are dark.
    assert!(at(81, 64) < 0.5 * at(100, 64), "{} vs {}", at(81, 64), at(100, 64));
    assert!((at(64, 64) - 0.8).abs() < 1e-3, "flat inside: {}", at(64, 64));
}

#[test]
fn clouds_only_scenes_and_empty_views_render() {
    // Everything behind the camera: the sky alone.
    let scene = scene_of(vec![plane(-4.0, 1.0, 0.1, 0.1, |_, _, _| true)]);
    let (frame, stats) = render_points(&scene, (16, 16), &PointSettings::default()).unwrap();
    assert_eq!(frame.coverage(), 0.0);
    assert_eq!(stats.projected_pixels, 0);
    assert!(frame.colour.iter().all(|&c| c == Rgb::new(0.1, 0.2, 0.3)));
    let bad = PointSettings { square_side: 0, ..PointSettings::default() };
    assert!(render_points(&scene, (16, 16), &bad).is_err());
    assert!(render_points(&scene, (0, 16), &PointSettings::default()).is_err());
    // Too many pixels for the points mode's buffers: refused before anything is allocated.
    let e = render_points(&scene, (16384, 8192), &PointSettings::default()).err().unwrap().to_string();
    assert!(e.contains("2^25 pixels"), "{e}");
}

/// What `glint points sample` makes, rendered with the default fill, has no holes: every
/// pixel well inside the sphere's outline shows the surface (issue 19: 10.6 % of the dragon's
/// interior was empty with the radii of COVERAGE_FACTOR 2). Random (Poisson) samples at about
/// two visible points per pixel, as a sampled million-point model at 1024² gives.
#[test]
fn a_sampled_mesh_renders_without_holes_by_default() {
    let ico = glint_accel::procedural::icosphere(5);
    let centre = Vec3::new(0.0, 0.0, -3.0);
    let mesh = glint_scene::Mesh {
        name: "sphere".into(),
        positions: ico.positions.iter().map(|p| *p + centre).collect(),
        triangles: ico.triangles,
        ..glint_scene::Mesh::default()
    };
    let cloud = glint_scene::points::sample_mesh(&mesh, 8_000, 3).expect("sampled");
    let scene = scene_of(vec![cloud]);
    let (frame, _) = render_points(&scene, (128, 128), &PointSettings::default()).expect("rendered");
    // Pixels whose centre ray passes 2.5 pixels inside the unit sphere's outline (focal 64 px).
    let (mut inside, mut holes) = (0, 0);
    for y in 0..128 {
        for x in 0..128 {
            let d = Vec3::new((x as f32 + 0.5 - 64.0) / 64.0, (64.0 - y as f32 - 0.5) / 64.0, -1.0).normalize();
            // Distance from the sphere's centre to the ray, less the margin's angle at depth 3.
            let miss = (centre - d * centre.dot(d)).length();
            if miss < 1.0 - 2.5 * 3.0 / 64.0 {
                inside += 1;
                holes += usize::from(!frame.depth[y * 128 + x].is_finite());
            }
        }
    }
    assert!(inside > 1000, "{inside}");
    assert!(holes * 1000 <= inside, "{holes} of {inside} pixels inside the outline are empty");
}

/// Phong in lanes (AVX2 and SSE) against the pixel-by-pixel oracle, with every light kind and
/// spot curve, the sky's irradiance as ambient light, two materials (one with a specular
/// power above 1 and one below) and a material index the scene lacks; and the renderer's
/// shading inside the final push gives the bits of the pass run on its own.
#[test]
fn phong_in_lanes_matches_the_scalar_shading() {
    use glint_scene::{Attenuation, SpotFalloff};
    let mut cloud = random_cloud(60_000, 9, true);
    let mut scene = scene_of(vec![random_cloud(60_000, 8, false), plane(6.0, 3.0, 0.05, 0.06, |_, _, _| true)]);
    cloud.name = "third".into();
    scene.clouds.push(CloudObject {
        name: cloud.name.clone(),
        cloud: Arc::new(cloud),
        material: 7,
        world_from_object: Affine3A::IDENTITY,
    });
    scene.clouds[1].material = 1;
    scene.materials.push(Material {
        specular: 0.7,
        shininess: 0.5,
        emission: Rgb::new(0.01, 0.0, 0.02),
        ..Material::default()
    });
    scene.sky_ambient = true;
    let spot = |falloff, x: f32| Light::Spot {
        position: Vec3::new(x, 2.0, 0.0),
        direction: Vec3::new(0.0, -0.3, -1.0).normalize(),
        inner_deg: 10.0,
        outer_deg: 35.0,
        colour: Rgb::new(1.0, 0.8, 0.6),
        intensity: 2.0,
        attenuation: Attenuation::InverseSquare,
        falloff,
        projection: None,
    };
    scene.lights.extend([
        Light::Point {
            position: Vec3::new(-2.0, 1.0, -1.0),
            colour: Rgb::ONE,
            intensity: 3.0,
            attenuation: Attenuation::InverseSquare,
        },
        spot(SpotFalloff::Smoothstep, -1.0),
        spot(SpotFalloff::LinearAngle, 0.0),
        spot(SpotFalloff::SquaredCosine, 1.0),
    ]);
    let sh = scene.sky.irradiance_sh();
    let (mut frame, _) = render(&scene, 211, Fill::Ellipses);
    assert!(frame.material.contains(&7) && frame.material.contains(&1), "every material on screen");
    // The renderer shaded each row inside the final push.
    let fused = frame.colour.clone();
    let view = View::new(&scene.camera, frame.width, frame.height);
    let mut shaded = |kernel| {
        let params = shade::ShadeParams {
            scene: &scene,
            view: &view,
            sky_irradiance: Some(&sh),
            shading: PointShading::Phong,
            edl_strength: 1.0,
            kernel,
        };
        shade::Shader::new(params).frame(&mut frame);
        frame.colour.clone()
    };
    let (scalar, best, baseline) =
        (shaded(shade::Kernel::Scalar), shaded(shade::Kernel::Best), shaded(shade::Kernel::Baseline));
    let bits = |c: &[Rgb]| c.iter().flat_map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert!(bits(&best) == bits(&baseline), "the AVX2 and SSE lanes differ");
    assert!(bits(&fused) == bits(&best), "shading inside the final push differs from the pass on its own");
    let mut exact = 0;
    for (a, b) in scalar.iter().zip(&best) {
        let err = (*a - *b).abs().max_element();
        assert!(err <= 1e-4 * a.max_element().max(1.0), "{a} vs {b}");
        exact += usize::from(a == b);
    }
    // Only the specular power differs (a polynomial for powf): most pixels are bit-identical.
    assert!(exact * 2 > scalar.len(), "{exact} of {} pixels identical", scalar.len());
}

/// The gather in lanes (AVX2 and SSE) gives [`gather::Winner::new`]'s bits for every covered
/// pixel: two clouds sharing pixel runs (one with normals, some of them zero; one without), and
/// a cloud scaled by its transform.
#[test]
fn the_gather_in_lanes_equals_the_scalar_winners() {
    let mut with_normals = random_cloud(40_000, 3, false);
    if let Some(n) = with_normals.normals.as_mut() {
        n.iter_mut().step_by(7).for_each(|n| *n = Vec3::ZERO);
    }
    let mut without = random_cloud(40_000, 4, false);
    without.normals = None;
    let mut scene = scene_of(vec![with_normals, without, plane(6.0, 3.0, 0.05, 0.06, |_, _, _| true)]);
    scene.clouds[2].world_from_object = Affine3A::from_scale(Vec3::splat(1.5));
    scene.clouds[1].material = 3;
    let (_, r) = render(&scene, 173, Fill::Ellipses);
    let view = View::new(&scene.camera, 173, 173);
    let clouds = cloud_views(&r.points, &view, true);
    let gathered = |baseline| {
        let mut out = vec![gather::Winner::NONE; r.depth.len()];
        let mut spans = vec![pyramid::Span::EMPTY; 173];
        gather::gather(&r.points, &clouds, &view, &r.depth, &mut out, &mut spans, baseline);
        for (y, span) in spans.iter().enumerate() {
            let covered = |x: usize| r.depth[y * 173 + x].load(std::sync::atomic::Ordering::Relaxed) != EMPTY;
            let want = (0..173)
                .filter(|&x| covered(x))
                .fold(pyramid::Span::EMPTY, |s, x| s.union(pyramid::Span { lo: x as u32, hi: x as u32 + 1 }));
            assert_eq!(*span, want, "row {y}'s span");
        }
        out
    };
    let (best, baseline) = (gathered(false), gathered(true));
    let mut covered = 0;
    for (i, word) in r.depth.iter().enumerate() {
        let word = word.load(std::sync::atomic::Ordering::Relaxed);
        if word == EMPTY {
            assert_eq!(best[i], gather::Winner::NONE);
            continue;
        }
        covered += 1;
        let p = word as u32 as usize;
        let cv = view::cloud_for(&clouds, p as u32);
        let (x, y) = (i % 173, i / 173);
        let want = gather::Winner::new(&view, cv, x, y, r.points.stream[p].normal, r.points.attributes[p]);
        let bits = |w: &gather::Winner| (w.normal.map(f32::to_bits), w.radius.to_bits(), w.colour, w.material);
        assert_eq!(bits(&best[i]), bits(&want), "pixel ({x}, {y})");
        assert_eq!(bits(&baseline[i]), bits(&want), "pixel ({x}, {y}), SSE lanes");
    }
    let zero_codes = r
        .depth
        .iter()
        .filter(|w| {
            let w = w.load(std::sync::atomic::Ordering::Relaxed);
            w != EMPTY && (w as u32) < clouds[0].end && r.points.stream[w as u32 as usize].normal == 0
        })
        .count();
    assert!(covered > 10_000 && zero_codes > 100, "{covered} covered, {zero_codes} without a normal");
}

/// The row spans only skip texels that stay invalid: pulling and pushing with each row's span
/// gives the texels of visiting every texel (full-width spans), and every span is tight.
#[test]
fn spans_skip_only_texels_that_stay_invalid() {
    use pyramid::{Span, pull_level, push_level};
    let tight = |l: &Level, y: usize| {
        let row = &l.texels[y * l.width as usize..(y + 1) * l.width as usize];
        match (row.iter().position(Texel::is_valid), row.iter().rposition(Texel::is_valid)) {
            (Some(a), Some(b)) => Span { lo: a as u32, hi: b as u32 + 1 },
            _ => Span::EMPTY,
        }
    };
    let full = |l: &Level| {
        let mut l = l.clone();
        l.spans.fill(Span { lo: 0, hi: l.width });
        l
    };
    let (w, h) = (67u32, 45u32);
    let mut fine = Level::default();
    fine.resize(w, h);
    // Two clusters of sparse texels (one touching the left edge), the rest empty.
    for y in 0..h as usize {
        for x in 0..w as usize {
            let i = y * w as usize + x;
            let inside = (x < 9 && (10..30).contains(&y)) || ((30..50).contains(&x) && (20..40).contains(&y));
            if inside && hash01(i) < 0.35 {
                let z = 2.0 + hash01(i + 7);
                fine.texels[i] = Texel {
                    z_min: z,
                    z_max: z + 0.1,
                    depth: z + 0.05,
                    normal: Vec3::new(hash01(i + 1) - 0.5, hash01(i + 2) - 0.5, -1.0).normalize(),
                    radius: 0.4 + hash01(i + 3),
                    colour: Rgb::splat(hash01(i + 4)),
                    displacement: Vec2::ZERO,
                    material: 0,
                };
            }
        }
    }
    for y in 0..h as usize {
        fine.spans[y] = tight(&fine, y);
    }
    assert!(fine.spans.iter().filter(|s| s.is_empty()).count() > 10);
    let mut coarse = Level::default();
    coarse.resize(w.div_ceil(2), h.div_ceil(2));
    let mut coarse_full = coarse.clone();
    pull_level(&fine, &mut coarse);
    pull_level(&full(&fine), &mut coarse_full);
    assert!(coarse.texels == coarse_full.texels, "pull");
    for y in 0..coarse.height as usize {
        assert_eq!(coarse.spans[y], tight(&coarse, y), "coarse row {y}");
    }
    for ellipses in [false, true] {
        let (mut pushed, mut pushed_full) = (fine.clone(), full(&fine));
        push_level(&coarse, &mut pushed, ellipses);
        push_level(&full(&coarse), &mut pushed_full, ellipses);
        assert!(pushed.texels == pushed_full.texels, "push (ellipses {ellipses})");
        assert!(pushed.texels != fine.texels, "the push filled something");
        for y in 0..h as usize {
            assert_eq!(pushed.spans[y], tight(&pushed, y), "fine row {y}");
        }
    }
}

/// The push's interpolation (branch-free over its four texels) gives the bits of the plain
/// loop that skips the texels left out, on a coarse level of random texels (a third invalid,
/// normals with −0.0 components, displacements of either sign, ellipses that miss).
#[test]
fn interpolation_without_branches_equals_the_plain_loop() {
    fn plain(coarse: &Level, x: i64, y: i64, ellipses: bool) -> Option<Texel> {
        let (px, py) = (x >> 1, y >> 1);
        let (nx, ny) = (if x & 1 == 1 { px + 1 } else { px - 1 }, if y & 1 == 1 { py + 1 } else { py - 1 });
        let q = Vec2::new((x as f32 + 0.5) * 0.5, (y as f32 + 0.5) * 0.5);
        let (mut w_sum, mut z_min, mut z_max, mut depth, mut radius) = (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let (mut normal, mut colour, mut centre, mut material) = (Vec3::ZERO, Rgb::ZERO, Vec2::ZERO, u32::MAX);
        for (cx, cy, w) in [(px, py, 9.0f32), (nx, py, 3.0), (px, ny, 3.0), (nx, ny, 1.0)] {
            let t = coarse.at(cx, cy);
            if !t.is_valid() {
                continue;
            }
            let c = Vec2::new(cx as f32 + 0.5, cy as f32 + 0.5) + t.displacement;
            if ellipses && !ellipse_contains(&t, c, q) {
                continue;
            }
            if material == u32::MAX {
                material = t.material;
            }
            w_sum += w;
            z_min += w * t.z_min;
            z_max += w * t.z_max;
            depth += w * t.depth;
            normal += w * t.normal;
            radius += w * t.radius;
            colour += w * t.colour;
            centre += w * c;
        }
        (w_sum != 0.0).then(|| {
            let inv = 1.0 / w_sum;
            Texel {
                z_min: z_min * inv,
                z_max: z_max * inv,
                depth: depth * inv,
                normal: normal.normalize_or(Vec3::NEG_Z),
                radius: 2.0 * radius * inv,
                colour: colour * inv,
                displacement: 2.0 * centre * inv - Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
                material,
            }
        })
    }
    let (w, h) = (23u32, 17u32);
    let mut coarse = Level::default();
    coarse.resize(w, h);
    for (i, t) in coarse.texels.iter_mut().enumerate() {
        if hash01(i) < 0.33 {
            continue;
        }
        let r = |k: usize| hash01(i * 16 + k);
        let signed_zero = |v: f32| if v < 0.1 { -0.0 } else { v - 0.5 };
        *t = Texel {
            z_min: 1.0 + r(1),
            z_max: 1.5 + r(2),
            depth: 1.2 + r(3),
            normal: Vec3::new(signed_zero(r(4)), signed_zero(r(5)), -0.2 - r(6)),
            radius: 0.2 + 1.5 * r(7),
            colour: Rgb::new(r(8), r(9), r(10)),
            displacement: Vec2::new(r(11) - 0.5, signed_zero(r(12))),
            material: (i % 3) as u32,
        };
    }
    let bits = |t: Option<Texel>| {
        t.map(|t| {
            [t.z_min, t.z_max, t.depth, t.normal.x, t.normal.y, t.normal.z, t.radius, t.colour.x, t.colour.y]
                .map(f32::to_bits)
                .into_iter()
                .chain([t.colour.z, t.displacement.x, t.displacement.y].map(f32::to_bits))
                .chain([t.material])
                .collect::<Vec<_>>()
        })
    };
    let mut some = 0;
    for ellipses in [false, true] {
        for y in 0..2 * h as i64 {
            for x in 0..2 * w as i64 {
                let want = plain(&coarse, x, y, ellipses);
                some += usize::from(want.is_some());
                assert_eq!(bits(interpolate(&coarse, x, y, ellipses)), bits(want), "({x}, {y}), ellipses {ellipses}");
            }
        }
    }
    assert!(some > 1000, "{some}");
}

/// The pull's texel (branch-free over its children) gives the bits of the plain loop that
/// skips the children whose interval misses the frontmost one's.
#[test]
fn pull_without_branches_equals_the_plain_loop() {
    use pyramid::{CHILD_OFFSETS, pull_texel};
    fn plain(children: [(Texel, Vec2); 4]) -> Texel {
        let front = children.iter().fold(Texel::INVALID, |f, (c, _)| if c.z_min < f.z_min { *c } else { f });
        if !front.is_valid() {
            return Texel::INVALID;
        }
        let (mut n, mut z_min, mut z_max, mut depth) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY, 0.0f32);
        let (mut normal, mut radius, mut colour, mut displacement) = (Vec3::ZERO, 0.0, Rgb::ZERO, Vec2::ZERO);
        for (c, offset) in &children {
            if c.z_min <= front.z_max {
                n += 1.0;
                z_min = z_min.min(c.z_min);
                z_max = z_max.max(c.z_max);
                depth += c.depth;
                normal += c.normal;
                radius += c.radius;
                colour += c.colour;
                displacement += c.displacement + *offset;
            }
        }
        let inv = 1.0 / n;
        Texel {
            z_min,
            z_max,
            depth: depth * inv,
            normal: normal.normalize_or(front.normal),
            radius: radius * inv * 0.5,
            colour: colour * inv,
            displacement: displacement * (inv * 0.5),
            material: front.material,
        }
    }
    let texel = |i: usize| {
        if hash01(i) < 0.3 {
            return Texel::INVALID;
        }
        let r = |k: usize| hash01(i * 16 + k);
        let signed_zero = |v: f32| if v < 0.1 { -0.0 } else { v - 0.5 };
        let z = 1.0 + 2.0 * r(1);
        Texel {
            z_min: z,
            z_max: z + 0.5 * r(2),
            depth: z + 0.1,
            normal: Vec3::new(signed_zero(r(3)), signed_zero(r(4)), -0.5),
            radius: r(5),
            colour: Rgb::new(r(6), r(7), r(8)),
            displacement: Vec2::new(signed_zero(r(9)), r(10) - 0.5),
            material: i as u32 % 5,
        }
    };
    let mut joined_some = 0;
    for k in 0..4000 {
        let children: [(Texel, Vec2); 4] = std::array::from_fn(|c| (texel(4 * k + c), CHILD_OFFSETS[c]));
        let (a, b) = (pull_texel(children), plain(children));
        let bits = |t: &Texel| {
            let f = [t.z_min, t.z_max, t.depth, t.normal.x, t.normal.y, t.normal.z, t.radius];
            let g = [t.colour.x, t.colour.y, t.colour.z, t.displacement.x, t.displacement.y];
            (f.map(f32::to_bits), g.map(f32::to_bits), t.material)
        };
        assert_eq!(bits(&a), bits(&b), "children {k}");
        joined_some += usize::from(a.is_valid());
    }
    assert!(joined_some > 3000, "{joined_some}");
}

/// The normal AOV is unit length without a final normalisation (the texel normals are unit
/// and the camera's basis is orthonormal), under a tilted camera and a rotated, scaled cloud.
#[test]
fn world_normals_are_unit_without_normalising_again() {
    let mut scene = scene_of(vec![random_cloud(50_000, 12, false), plane(6.0, 3.0, 0.05, 0.06, |_, _, _| true)]);
    scene.clouds[1].world_from_object =
        Affine3A::from_scale_rotation_translation(Vec3::splat(1.3), glint_core::Quat::from_rotation_y(0.4), Vec3::ZERO);
    scene.camera.forward = Vec3::new(0.2, -0.1, -1.0).normalize();
    let (frame, _) = render(&scene, 157, Fill::Ellipses);
    let mut surface = 0;
    for (n, d) in frame.normal.iter().zip(&frame.depth) {
        if d.is_finite() {
            surface += 1;
            assert!((n.length() - 1.0).abs() < 1e-6, "|{n}| = {}", n.length());
        }
    }
    assert!(surface > 5000, "{surface}");
}
