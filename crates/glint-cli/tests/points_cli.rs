//! `glint render --mode points` and `glint points sample`, end to end, on the real scans in
//! ../shared/data: PNG and EXR output, every fill and shading, colouring, clouds in TOML scenes
//! beside traced shapes, malformed inputs, and thread-count independence.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, assert_fails_keeping, glint, repo, scratch, shared, stderr};
use glint_image::Image;
use std::path::{Path, PathBuf};

/// Small images keep the whole file at a few seconds.
const SIZE: [&str; 4] = ["--width", "96", "--height", "72"];

fn bunny() -> Option<PathBuf> {
    shared("data/pointclouds/stanford_bunny_rawscan_40256.xyz")
}

fn autzen() -> Option<PathBuf> {
    shared("data/pointclouds/autzen_trim.las")
}

fn utf8(p: &Path) -> &str {
    p.to_str().expect("utf-8 path")
}

/// `glint render ARGS --width 96 --height 72 -o OUT` in `dir`, asserted to succeed; returns the
/// image written and the messages.
fn render(dir: &Path, args: &[&str], out: &str) -> (Image, String) {
    let mut all = vec!["render"];
    all.extend_from_slice(args);
    all.extend_from_slice(&SIZE);
    all.extend_from_slice(&["-o", out]);
    let o = glint(&all, dir);
    assert!(o.status.success(), "{all:?}: {}", stderr(&o));
    let img = glint_image::read_image(&dir.join(out)).expect("read the output");
    assert_eq!((img.width, img.height), (96, 72), "{all:?}");
    (img, stderr(&o))
}

/// Pixels with alpha above one half.
fn covered(img: &Image) -> usize {
    img.channel("A").expect("alpha").iter().filter(|&&a| a > 0.5).count()
}

/// The AOVs of a points-mode EXR agree with its coverage: every pixel is fully in or out; depth
/// is finite and positive and the normal unit length where a point was drawn, depth +inf where
/// none was; the other channels are finite everywhere.
fn check_aovs(img: &Image, what: &str) {
    for c in ["R", "G", "B", "A", "Albedo.R", "Albedo.G", "Albedo.B", "Ns.X", "Ns.Y", "Ns.Z"] {
        assert!(img.channel(c).is_some(), "{what}: channel {c} missing");
        assert!(img.channel(c).unwrap().iter().all(|v| v.is_finite()), "{what}: {c} not finite");
    }
    let a = img.channel("A").unwrap();
    let z = img.channel("Z").unwrap_or_else(|| panic!("{what}: no Z channel"));
    let n = ["Ns.X", "Ns.Y", "Ns.Z"].map(|c| img.channel(c).unwrap());
    let count = covered(img);
    assert!(count > a.len() / 20, "{what}: only {count} of {} pixels covered", a.len());
    for (i, &alpha) in a.iter().enumerate() {
        assert!(alpha == 0.0 || alpha == 1.0, "{what}: pixel {i} has alpha {alpha}");
        if alpha == 1.0 {
            assert!(z[i].is_finite() && z[i] > 0.0, "{what}: pixel {i} covered at depth {}", z[i]);
            let len = (n[0][i].powi(2) + n[1][i].powi(2) + n[2][i].powi(2)).sqrt();
            assert!((len - 1.0).abs() < 1e-3, "{what}: pixel {i} normal of length {len}");
        } else {
            assert!(z[i] == f32::INFINITY, "{what}: empty pixel {i} at depth {}", z[i]);
        }
    }
}

#[test]
fn clouds_render_to_png_and_to_exr_with_aovs() {
    let (Some(bunny), Some(autzen)) = (bunny(), autzen()) else { return };
    let dir = scratch("points-render");
    for (name, cloud) in [("bunny", &bunny), ("autzen", &autzen)] {
        let (exr, msg) = render(&dir, &[utf8(cloud)], &format!("{name}.exr"));
        // A cloud file renders in points mode without being asked to.
        assert!(msg.contains("points 96x72"), "{name}: {msg}");
        check_aovs(&exr, name);
        let (png, _) = render(&dir, &[utf8(cloud), "-q"], &format!("{name}.png"));
        assert!(png.channel("A").is_none(), "{name}: RGB PNG without --alpha");
        let (rgba, _) = render(&dir, &[utf8(cloud), "--alpha", "-q"], &format!("{name}-alpha.png"));
        let a = rgba.channel("A").expect("RGBA PNG with --alpha");
        assert!(a.contains(&0.0) && a.contains(&1.0), "{name}: alpha is not both 0 and 1 somewhere");
        assert_eq!(covered(&rgba), covered(&exr), "{name}: PNG alpha and EXR A disagree");
    }
}

#[test]
fn every_fill_and_shading_runs_and_raw_leaves_holes() {
    let Some(bunny) = bunny() else { return };
    let dir = scratch("points-fills");
    let mut coverage = Vec::new();
    for fill in ["ellipses", "pull-push", "raw", "squares"] {
        // Zoomed in (a narrow field of view) so that neighbouring points land pixels apart.
        let (img, msg) = render(&dir, &[utf8(&bunny), "--fill", fill, "--fov", "8"], &format!("{fill}.exr"));
        assert!(msg.contains("points 96x72"), "{fill}: {msg}");
        check_aovs(&img, fill);
        coverage.push((fill, covered(&img)));
    }
    let count = |f: &str| coverage.iter().find(|c| c.0 == f).unwrap().1;
    assert!(count("raw") < count("ellipses"), "{coverage:?}");
    // Without the ellipse test pull-push fills every hole, the background's too.
    assert!(count("ellipses") <= count("pull-push"), "{coverage:?}");
    assert!(count("raw") < count("squares"), "{coverage:?}");
    for shading in ["auto", "phong", "edl", "flat"] {
        render(&dir, &[utf8(&bunny), "--shading", shading, "--edl-strength", "2", "-q"], &format!("{shading}.png"));
    }
    render(&dir, &[utf8(&bunny), "--two-sided", "--fill", "squares", "--square-size", "5", "-q"], "sq.png");
    render(&dir, &[utf8(&bunny), "--neighbours", "8", "--radius-scale", "1.5", "-q"], "scaled.png");
}

#[test]
fn las_colours_differ_and_rgb_needs_colours() {
    let (Some(bunny), Some(autzen)) = (bunny(), autzen()) else { return };
    let dir = scratch("points-colour");
    let rgb =
        |img: &Image| -> Vec<f32> { ["R", "G", "B"].iter().flat_map(|c| img.channel(c).unwrap().to_vec()).collect() };
    let images: Vec<(&str, Vec<f32>)> = ["classification", "intensity", "elevation"]
        .into_iter()
        .map(|by| (by, rgb(&render(&dir, &[utf8(&autzen), "--colour-by", by, "-q"], &format!("{by}.exr")).0)))
        .collect();
    for (i, (a, x)) in images.iter().enumerate() {
        for (b, y) in &images[i + 1..] {
            let mse = glint_image::metrics::mse(x, y);
            assert!(mse > 1e-4, "colour by {a} and by {b} give the same picture (MSE {mse})");
        }
    }
    std::fs::write(dir.join("out.png"), b"precious").unwrap();
    assert_fails_cleanly(
        &["render", utf8(&bunny), "--colour-by", "rgb", "-o", "out.png"],
        "stanford_bunny_rawscan_40256.xyz",
        &dir,
    );
    // A scene's clouds are coloured by their own `colour_by`: the flag would be ignored.
    std::fs::write(dir.join("s.toml"), cloud_scene(&bunny, "")).unwrap();
    assert_fails_cleanly(&["render", "s.toml", "--colour-by", "elevation", "-o", "out.png"], "colour_by", &dir);
}

#[test]
fn a_sampled_mesh_renders_as_points() {
    let Some(mesh) = shared("data/meshes/lucy_decimated.ply") else { return };
    let dir = scratch("points-sample");
    let sample = |out: &str, seed: &str| {
        let o = glint(&["points", "sample", utf8(&mesh), "--count", "20000", "--seed", seed, "-o", out], &dir);
        assert!(o.status.success(), "{}", stderr(&o));
        std::fs::read(dir.join(out)).unwrap()
    };
    let a = sample("a.ply", "7");
    assert_eq!(a, sample("b.ply", "7"), "the same seed gave different files");
    assert_ne!(a, sample("c.ply", "8"), "another seed gave the same file");
    let (img, msg) = render(&dir, &["a.ply"], "lucy.exr");
    assert!(msg.contains("points 96x72 (20000 points"), "a faceless PLY is drawn in points mode: {msg}");
    assert!(!msg.contains("estimated"), "the sampled normals and radii were lost: {msg}");
    check_aovs(&img, "sampled lucy");

    for name in ["out.png", "keep.ply"] {
        std::fs::write(dir.join(name), b"precious").unwrap();
    }
    let m = utf8(&mesh);
    assert_fails_keeping(&["points", "sample", m, "--count", "0", "-o", "keep.ply"], "--count", &dir, "keep.ply");
    assert_fails_cleanly(&["points", "sample", m, "--count", "10", "-o", "out.png"], "out.png", &dir);
    assert_fails_keeping(
        &["points", "sample", "nowhere.obj", "--count", "10", "-o", "keep.ply"],
        "nowhere.obj",
        &dir,
        "keep.ply",
    );
}

/// A scene with the bunny scan (camera in front of it) and `extra` TOML after it.
fn cloud_scene(bunny: &Path, extra: &str) -> String {
    format!(
        "background = [0.5, 0.6, 0.8]\n\n[camera]\nposition = [-0.017, 0.11, 0.4]\nlook_at = [-0.017, 0.11, 0.0]\nfov = 30\n\n\
         [[light]]\ntype = \"point\"\nposition = [1.0, 2.0, 2.0]\n\n\
         [[object]]\nname = \"bunny\"\ntype = \"points\"\npath = '{}'\n{extra}",
        bunny.display()
    )
}

/// A small sphere in front of the bunny's middle and a wall behind it.
const SPHERE_AND_WALL: &str = "\n[[object]]\ntype = \"sphere\"\ncentre = [-0.017, 0.11, 0.2]\nradius = 0.01\n\n\
     [[object]]\ntype = \"plane\"\nnormal = [0.0, 0.0, 1.0]\noffset = 0.2\n";

#[test]
fn scenes_draw_clouds_beside_traced_shapes() {
    let Some(bunny) = bunny() else { return };
    let dir = scratch("points-scene");
    std::fs::write(dir.join("cloud.toml"), cloud_scene(&bunny, "")).unwrap();
    std::fs::write(dir.join("mixed.toml"), cloud_scene(&bunny, SPHERE_AND_WALL)).unwrap();
    let points_mode =
        cloud_scene(&bunny, SPHERE_AND_WALL).replacen("\n[camera]", "\n[render]\nmode = \"points\"\n\n[camera]", 1);
    std::fs::write(dir.join("mixed-points.toml"), points_mode).unwrap();

    let (alone, _) = render(&dir, &["cloud.toml", "--mode", "points"], "alone.exr");
    check_aovs(&alone, "the cloud alone");
    // `[render] mode = "points"` chooses the mode; the sphere and the wall are traced.
    let (mixed, msg) = render(&dir, &["mixed-points.toml"], "mixed.exr");
    assert!(msg.contains("points 96x72") && msg.contains("meshes traced"), "{msg}");
    let (za, zm) = (alone.channel("Z").unwrap(), mixed.channel("Z").unwrap());
    assert!(mixed.channel("A").unwrap().iter().all(|&a| a == 1.0), "the wall covers every pixel");
    let centre = 36 * 96 + 48;
    assert!(za[centre].is_finite(), "the bunny covers the centre");
    assert!((zm[centre] - 0.19).abs() < 0.01, "the sphere in front wins the centre: depth {}", zm[centre]);
    let (mut bunny_kept, mut wall) = (0, 0);
    for i in 0..za.len() {
        if za[i].is_finite() && zm[i] > 0.25 {
            // The bunny is nearer than the wall: its pixels keep their depth.
            assert_eq!(zm[i], za[i], "pixel {i}");
            bunny_kept += 1;
        } else if za[i].is_infinite() {
            assert!(zm[i] >= 0.6 - 1e-3 && zm[i].is_finite(), "pixel {i}: the wall at depth {}", zm[i]);
            wall += 1;
        }
    }
    assert!(bunny_kept > 500 && wall > 500, "{bunny_kept} bunny pixels, {wall} wall pixels");

    // The ray tracers leave the cloud out, with a warning, and draw the rest.
    let (whitted, msg) = render(&dir, &["mixed.toml", "--mode", "whitted"], "whitted.exr");
    assert!(msg.contains("left out"), "{msg}");
    assert!((whitted.channel("Z").unwrap()[centre] - 0.19).abs() < 0.01);

    std::fs::write(dir.join("out.png"), b"precious").unwrap();
    for mode in ["whitted", "path"] {
        assert_fails_cleanly(&["render", "cloud.toml", "--mode", mode, "-o", "out.png"], "--mode points", &dir);
    }
    let spheres = "[camera]\nposition = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\n\n[[object]]\ntype = \"sphere\"\nradius = 1\n";
    std::fs::write(dir.join("spheres.toml"), spheres).unwrap();
    assert_fails_cleanly(&["render", "spheres.toml", "--mode", "points", "-o", "out.png"], "point clouds", &dir);
    assert_fails_cleanly(&["render", "--mode", "points", "-o", "out.png"], "point clouds", &dir);
}

#[test]
fn malformed_clouds_and_options_fail_cleanly() {
    let (Some(bunny), Some(autzen)) = (bunny(), autzen()) else { return };
    let dir = scratch("points-bad");
    std::fs::write(dir.join("out.png"), b"precious").unwrap();
    let las = std::fs::read(&autzen).unwrap();
    std::fs::write(dir.join("truncated.las"), &las[..1000]).unwrap();
    std::fs::write(dir.join("nan.xyz"), "0 0 0\n1 0 0\nnan 1 0\n0 1 1\n").unwrap();
    std::fs::write(dir.join("ragged.xyz"), "0 0 0\n1 0 0\n0 1\n0 1 1\n").unwrap();
    std::fs::write(
        dir.join("huge.ply"),
        "ply\nformat ascii 1.0\nelement vertex 100000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 1 1\n",
    )
    .unwrap();
    std::fs::write(dir.join("colour.toml"), cloud_scene(&bunny, "colour_by = \"height\"\n")).unwrap();
    let no_path = cloud_scene(&bunny, "").replace(&format!("path = '{}'\n", bunny.display()), "");
    assert!(!no_path.contains("path ="));
    std::fs::write(dir.join("no-path.toml"), no_path).unwrap();
    // `sensor` orients estimated normals: a cloud with its own normals takes none.
    std::fs::write(
        dir.join("normals.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         property float nx\nproperty float ny\nproperty float nz\nend_header\n0 0 0 0 0 1\n1 0 0 0 0 1\n0 1 0 0 0 1\n",
    )
    .unwrap();
    std::fs::write(dir.join("sensor.toml"), cloud_scene(&dir.join("normals.ply"), "sensor = [0.0, 0.0, 5.0]\n"))
        .unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["render", "sensor.toml", "-o", "out.png"], "sensor.toml:"),
        (&["render", "sensor.toml", "-o", "out.png"], "its own"),
        (&["render", "truncated.las", "-o", "out.png"], "truncated.las"),
        (&["render", "nan.xyz", "-o", "out.png"], "nan.xyz"),
        (&["render", "ragged.xyz", "-o", "out.png"], "ragged.xyz"),
        (&["render", "huge.ply", "-o", "out.png"], "huge.ply"),
        (&["render", "colour.toml", "-o", "out.png"], "colour.toml:"),
        (&["render", "colour.toml", "-o", "out.png"], "height"),
        (&["render", "no-path.toml", "-o", "out.png"], "no-path.toml:"),
        (&["render", "no-path.toml", "-o", "out.png"], "`path`"),
        (&["render", "missing.xyz", "-o", "out.png"], "missing.xyz"),
    ];
    for (args, needle) in cases {
        assert_fails_cleanly(args, needle, &dir);
    }
    let b = utf8(&bunny);
    for (option, value) in [
        ("--square-size", "0"),
        ("--square-size", "16"),
        ("--neighbours", "1"),
        ("--radius-scale", "-1"),
        ("--radius-scale", "nan"),
        ("--edl-strength", "-1"),
    ] {
        assert_fails_cleanly(&["render", b, option, value, "-o", "out.png"], option, &dir);
    }
}

/// `sensor` is "the scanner's position" in the cloud file's own coordinates. A LAS file is Z-up
/// (x east, y north, z up), so a sensor 1000 m below the tile must turn the estimated normals
/// down, and the ground, seen from above, is culled; a sensor above keeps it.
#[test]
fn a_las_sensor_is_given_in_the_files_coordinates() {
    let Some(autzen) = autzen() else { return };
    let dir = scratch("points-sensor");
    let las = std::fs::read(&autzen).unwrap();
    // LAS 1.x header: max x, min x, max y, min y, max z, min z as f64 from byte 179.
    let bound = |i: usize| f64::from_le_bytes(las[179 + 8 * i..187 + 8 * i].try_into().unwrap());
    let centre = [0.5 * (bound(0) + bound(1)), 0.5 * (bound(2) + bound(3)), 0.5 * (bound(4) + bound(5))];
    let mut coverage = Vec::new();
    for dz in [1000.0, -1000.0] {
        let scene = format!(
            "[camera]\nposition = [0.0, 600.0, 300.0]\nlook_at = [0.0, 0.0, 0.0]\n\n\
             [[light]]\ntype = \"directional\"\ndirection = [0.0, -1.0, -0.3]\n\n\
             [[object]]\ntype = \"points\"\npath = '{}'\nsensor = [{:.1}, {:.1}, {:.1}]\n",
            autzen.display(),
            centre[0],
            centre[1],
            centre[2] + dz
        );
        std::fs::write(dir.join("sensor.toml"), scene).unwrap();
        let (img, _) = render(&dir, &["sensor.toml", "--mode", "points", "-q"], &format!("sensor{dz}.exr"));
        coverage.push(covered(&img));
    }
    assert!(coverage[1] * 2 < coverage[0], "pixels covered with the sensor above and below: {coverage:?}");
}

/// STYLE.md §7: the thread count never changes a render.
#[test]
fn one_and_two_threads_write_the_same_exr() {
    let Some(bunny) = bunny() else { return };
    let dir = scratch("points-threads");
    for fill in ["ellipses", "pull-push"] {
        let file = |threads: &str| {
            let out = format!("{fill}-{threads}.exr");
            render(&dir, &[utf8(&bunny), "--fill", fill, "--threads", threads, "-q"], &out);
            std::fs::read(dir.join(out)).unwrap()
        };
        assert!(file("1") == file("2"), "--fill {fill}: 1 and 2 threads differ");
    }
}

#[test]
fn the_example_scene_renders() {
    if bunny().is_none() {
        return;
    }
    let dir = scratch("points-example");
    let scene = repo().join("scenes/points-bunny.toml");
    let (img, msg) = render(&dir, &[utf8(&scene)], "example.exr");
    assert!(msg.contains("points 96x72") && msg.contains("meshes traced"), "{msg}");
    assert!(img.channel("R").unwrap().iter().all(|v| v.is_finite()));
}

/// `glint bench points` runs end to end on tiny settings (the real runs are in BENCHMARKS.md),
/// and rejects bad arguments before printing a table.
#[test]
fn bench_points_runs() {
    let Some(data) = shared("data/pointclouds") else { return };
    let data = data.parent().expect("data folder");
    let dir = scratch("points-bench");
    let args = ["bench", "points", "--data", utf8(data)];
    let run = |extra: &[&str]| glint(&[&args[..], extra].concat(), &dir);
    let o =
        run(&["--clouds", "bunny", "--reps", "2", "--sizes", "48", "--fills", "full,raw,squares", "--images", "imgs"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert_eq!(out.lines().filter(|l| l.starts_with("| bunny | 40256 | 48² |")).count(), 3, "{out}");
    assert!(dir.join("imgs/bunny-48-full.png").exists());
    for (extra, needle) in [
        (&["--clouds", "bogus"][..], "bogus"),
        (&["--sizes", "0"], "--sizes"),
        (&["--fills", "ellipse"], "--fills"),
        (&["--reps", "0"], "--reps"),
    ] {
        let o = run(extra);
        assert!(!o.status.success() && stderr(&o).contains(needle), "{extra:?}: {}", stderr(&o));
        assert!(o.stdout.is_empty(), "{extra:?} printed {}", String::from_utf8_lossy(&o.stdout));
    }
}
