//! The `glint` binary end to end: renders, bad input, and the promise that a failed command
//! never overwrites an existing output file.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, scratch, shared, stderr};

#[test]
fn render_without_a_scene_writes_the_demo_to_glint_png() {
    let d = scratch("demo");
    let o = glint(&["render", "--width", "64", "--height", "36", "-q"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = glint_image::read_image(&d.join("glint.png")).unwrap();
    assert_eq!((img.width, img.height), (64, 36));
}

#[test]
fn renders_exr_with_aovs_and_rgba_png() {
    let d = scratch("exr");
    let o = glint(&["render", "-o", "out.exr", "--width", "32", "--height", "24", "-q"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = glint_image::read_image(&d.join("out.exr")).unwrap();
    for c in ["R", "G", "B", "A", "Albedo.R", "Ns.X", "Z"] {
        assert!(img.channel(c).is_some(), "channel {c} missing");
    }
    let o = glint(&["render", "-o", "a.png", "--alpha", "--width", "32", "--height", "24", "-q"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = glint_image::read_image(&d.join("a.png")).unwrap();
    assert!(img.channel("A").is_some());
}

#[test]
fn the_same_render_gives_the_same_exr_file() {
    let d = scratch("exr-twice");
    for name in ["a.exr", "b.exr"] {
        let o =
            glint(&["render", "-o", name, "--width", "40", "--height", "30", "--spp", "4", "--seed", "3", "-q"], &d);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_eq!(std::fs::read(d.join("a.exr")).unwrap(), std::fs::read(d.join("b.exr")).unwrap());
}

/// Every failing command: non-zero exit, a message naming the problem, and out.png untouched.
#[test]
fn bad_input_fails_cleanly_without_touching_the_output() {
    let d = scratch("bad");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    std::fs::write(d.join("broken.toml"), "[camera]\nposition = [0, 1, 2]\nbogus = 3\n").unwrap();
    std::fs::write(d.join("nan.toml"), "[[object]]\ntype = \"sphere\"\ncentre = [nan, 0, 0]\nradius = 1\n").unwrap();
    std::fs::write(d.join("trunc.ply"), "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\n").unwrap();
    std::fs::write(d.join("huge.ply"), "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n").unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["render", "missing.toml", "-o", "out.png"], "missing.toml"),
        (&["render", "broken.toml", "-o", "out.png"], "broken.toml"),
        (&["render", "nan.toml", "-o", "out.png"], "nan.toml"),
        (&["render", "trunc.ply", "-o", "out.png"], "trunc.ply"),
        (&["render", "huge.ply", "-o", "out.png"], "huge.ply"),
        (&["render", "-o", "out.png", "--spp", "5"], "--spp"),
        (&["render", "-o", "out.png", "--width", "0"], "size"),
        (&["render", "-o", "out.png", "--width", "100000000"], "size"),
        (&["render", "-o", "out.png", "--width", "30000", "--height", "30000"], "size"),
        (&["render", "-o", "out.png", "--eye", "0,1,nan"], "--eye"),
        (&["render", "-o", "out.png", "--eye", "1,2"], "--eye"),
        (&["render", "-o", "out.png", "--eye", "0,0,0", "--look-at", "0,0,0"], "look-at"),
        (&["render", "-o", "out.png", "--threads", "0"], "--threads"),
        (&["render", "-o", "out.png", "--tonemap", "filmic"], "tonemap"),
        (&["render", "-o", "out.tiff"], "out.tiff"),
        (&["render", "-o", "no/such/dir/out.png", "--width", "8", "--height", "8"], "out.png"),
    ];
    for (args, needle) in cases {
        assert_fails_cleanly(args, needle, &d);
    }
}

#[test]
fn a_model_file_renders_directly() {
    let Some(bunny) = shared("data/meshes/stanford_bunny_bun_zipper.ply") else { return };
    let d = scratch("model");
    let o = glint(&["render", bunny.to_str().unwrap(), "-o", "bunny.png", "--width", "64", "--height", "48", "-q"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = glint_image::read_image(&d.join("bunny.exr").with_extension("png")).unwrap();
    // The bunny is framed: the centre pixel is the model, not the background.
    let film =
        glint(&["render", bunny.to_str().unwrap(), "-o", "bunny.exr", "--width", "64", "--height", "48", "-q"], &d);
    assert!(film.status.success());
    let exr = glint_image::read_image(&d.join("bunny.exr")).unwrap();
    let a = exr.channel("A").unwrap();
    let covered = a.iter().filter(|&&c| c > 0.0).count();
    assert!(covered > 64 * 48 / 10, "the model covers only {covered} pixels");
    assert_eq!((img.width, img.height), (64, 48));
}

/// `glint bench rays` on `scene` with `kind` rays at 64 × 48, one pass, and `extra`.
fn bench_rays_64x48(scene: &std::path::Path, kind: &str, extra: &[&str], d: &std::path::Path) -> std::process::Output {
    let scene = scene.to_str().unwrap();
    let mut args =
        vec!["bench", "rays", "--scene", scene, "--kind", kind, "--width", "64", "--height", "48", "--reps", "1"];
    args.extend_from_slice(extra);
    glint(&args, d)
}

#[test]
fn bench_rays_dumps_what_it_traced() {
    let Some(bunny) = shared("data/meshes/stanford_bunny_bun_zipper.ply") else { return };
    let d = scratch("bench");
    for kind in ["primary", "diffuse", "shadow"] {
        let o = bench_rays_64x48(&bunny, kind, &["--dump", "dump"], &d);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout);
        assert!(out.lines().last().unwrap().starts_with("mrays_per_s_median="), "{out}");
        let rays = std::fs::metadata(d.join("dump.rays.f32")).unwrap().len();
        let hits = std::fs::metadata(d.join("dump.hits.f32")).unwrap().len();
        assert_eq!(rays, hits * 8, "{kind}: 8 floats per ray, 1 per hit");
        assert_eq!(std::fs::metadata(d.join("dump.tris.f32")).unwrap().len() % 36, 0);
    }
}

/// `--any-hit` asks the same rays whether they hit anything: every ray the closest-hit pass
/// finds a hit for is occluded, every miss is not (the dumps' hit files, 1.0 or +inf for
/// any-hit queries, a distance or +inf for closest hits).
#[test]
fn bench_rays_any_hit_agrees_with_closest_hits() {
    let Some(bunny) = shared("data/meshes/stanford_bunny_bun_zipper.ply") else { return };
    let d = scratch("bench-any");
    let run = |prefix: &str, any: bool| {
        let mut args = vec!["bench", "rays", "--scene", bunny.to_str().unwrap(), "--kind", "diffuse"];
        args.extend(["--width", "64", "--height", "48", "--reps", "1", "--dump", prefix]);
        if any {
            args.push("--any-hit");
        }
        let o = glint(&args, &d);
        assert!(o.status.success(), "{}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout).to_string();
        assert_eq!(out.contains("any-hit queries"), any, "{out}");
        let bytes = std::fs::read(d.join(format!("{prefix}.hits.f32"))).unwrap();
        bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect::<Vec<f32>>()
    };
    let (closest, any) = (run("closest", false), run("any", true));
    assert_eq!(closest.len(), any.len());
    let hits = closest.iter().filter(|t| t.is_finite()).count();
    // Diffuse rays from a closed-ish mesh: some hit it again, some escape.
    assert!(hits > 0 && hits < closest.len(), "{hits} of {} rays hit", closest.len());
    for (i, (c, a)) in closest.iter().zip(&any).enumerate() {
        assert_eq!(c.is_finite(), a.is_finite(), "ray {i}: closest {c}, any {a}");
    }
}

/// `--builds N` times N builds of the scene's structures and reports their median and fastest
/// (the build benchmark of BENCHMARKS.md §2.1); zero builds is refused.
#[test]
fn bench_rays_times_repeated_builds() {
    let Some(bunny) = shared("data/meshes/stanford_bunny_bun_zipper.ply") else { return };
    let d = scratch("bench-builds");
    let run = |builds: &str| {
        glint(
            &[
                "bench",
                "rays",
                "--scene",
                bunny.to_str().unwrap(),
                "--width",
                "32",
                "--height",
                "24",
                "--reps",
                "1",
                "--builds",
                builds,
            ],
            &d,
        )
    };
    let o = run("3");
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out.lines().find(|l| l.starts_with("scene:")).unwrap_or_default();
    let field = |key: &str| -> f64 {
        let rest = &line[line.find(key).unwrap_or_else(|| panic!("no {key:?} in {line:?}")) + key.len()..];
        rest.split_whitespace().next().unwrap().parse().unwrap()
    };
    let (median, fastest) = (field("build median "), field("fastest "));
    assert!(fastest > 0.0 && fastest <= median, "{line}");
    assert!(line.contains("of 3;"), "{line}");
    let o = run("0");
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--builds must be at least 1"), "{}", stderr(&o));
}

/// `--build fast` builds without spatial splits and `--build spatial` (the default, as the
/// renderer builds) with them: the same hits for every ray, more node memory; a build that is
/// neither is refused.
#[test]
fn bench_rays_builds_with_and_without_spatial_splits() {
    let Some(bunny) = shared("data/meshes/stanford_bunny_bun_zipper.ply") else { return };
    let d = scratch("bench-build-kinds");
    let run = |build: &str, kind: &str| {
        let prefix = format!("{build}-{kind}");
        let o = bench_rays_64x48(&bunny, kind, &["--build", build, "--dump", &prefix], &d);
        assert!(o.status.success(), "{build} {kind}: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout).into_owned();
        let line = out.lines().find(|l| l.starts_with("scene:")).unwrap_or_default().to_owned();
        let bytes: f64 = line
            .split("; ")
            .find_map(|f| f.strip_suffix(" bytes of BVH nodes per triangle"))
            .unwrap_or_else(|| panic!("no node bytes in {line:?}"))
            .parse()
            .unwrap();
        (std::fs::read(d.join(format!("{prefix}.hits.f32"))).unwrap(), bytes)
    };
    for kind in ["primary", "diffuse"] {
        let (fast, fast_bytes) = run("fast", kind);
        let (spatial, spatial_bytes) = run("spatial", kind);
        assert!(!fast.is_empty());
        assert_eq!(fast, spatial, "{kind}: the hits differ");
        assert!(spatial_bytes > fast_bytes, "{kind}: {spatial_bytes} vs {fast_bytes} bytes per triangle");
    }
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    assert_fails_cleanly(&["bench", "rays", "--scene", bunny.to_str().unwrap(), "--build", "best"], "--build", &d);
}

/// `--scene-time` shows scenes/animated.toml at a time: two times give two pictures, time 0
/// is the scene as loaded, and a non-finite time is refused.
#[test]
fn scene_time_renders_the_animation_at_that_time() {
    let d = scratch("scene-time");
    let scene = common::repo().join("scenes/animated.toml");
    let scene = scene.to_str().unwrap();
    let render = |name: &str, extra: &[&str]| {
        let mut args = vec!["render", scene, "-o", name, "--width", "64", "--height", "36", "-q"];
        args.extend_from_slice(extra);
        let o = glint(&args, &d);
        assert!(o.status.success(), "{args:?}: {}", stderr(&o));
        std::fs::read(d.join(name)).unwrap()
    };
    let plain = render("plain.exr", &[]);
    assert_eq!(render("zero.exr", &["--scene-time", "0"]), plain, "t = 0 is the scene as loaded");
    let later = render("later.exr", &["--scene-time", "1.5"]);
    assert_ne!(later, plain, "things moved by t = 1.5");
    assert_ne!(render("before.exr", &["--scene-time", "-0.5"]), plain, "negative times are times too");
    assert_eq!(render("again.exr", &["--scene-time", "1.5"]), later, "the same time, the same picture");
    let path = render("path.png", &["--scene-time", "1.5", "--mode", "path"]);
    assert!(!path.is_empty());
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    for bad in ["nan", "inf", "-inf"] {
        assert_fails_cleanly(&["render", scene, "-o", "out.png", "--scene-time", bad], "--scene-time", &d);
    }
    assert_fails_cleanly(&["render", scene, "-o", "out.png", "--scene-time", "soon"], "--scene-time", &d);
}
