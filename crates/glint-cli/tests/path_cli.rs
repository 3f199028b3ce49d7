//! `glint render --mode path` and `glint filter`, end to end.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, scratch, stderr};

const PATH_CHANNELS: [&str; 7] =
    ["Direct.R", "Direct.G", "Direct.B", "Indirect.R", "Indirect.G", "Indirect.B", "SampleCount"];

/// `bench path --kernel` times the batched shading against its scalar oracle in one run (a
/// line each, in the order named); an unknown kernel name is refused, naming the choices.
#[test]
fn bench_path_names_its_kernels_and_refuses_unknown_ones() {
    let dir = scratch("bench-path-kernels");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/mitsuba-cbox.toml");
    let args = ["bench", "path", scene, "--width", "24", "--height", "16", "--frames", "2", "--kernel"];
    let o = glint(&[&args[..], &["wavefront,wavefront-scalar"]].concat(), &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let kernels: Vec<&str> = out
        .lines()
        .filter(|l| l.starts_with("path 24x16"))
        .filter_map(|l| l.split(", ").find(|f| f.starts_with("Wavefront")))
        .map(|f| f.split(':').next().unwrap_or(""))
        .collect();
    assert_eq!(kernels, ["Wavefront", "WavefrontScalar"], "{out}");
    std::fs::write(dir.join("out.png"), b"precious").unwrap();
    assert_fails_cleanly(&[&args[..], &["wavefront,lanes"]].concat(), "wavefront-scalar", &dir);
}

/// An unknown `--reconstruction` is refused by `render` and `bench path`, naming the choices,
/// with nothing written.
#[test]
fn an_unknown_reconstruction_is_refused() {
    let dir = scratch("bad-reconstruction");
    let scene = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/mitsuba-cbox.toml");
    std::fs::write(dir.join("out.png"), b"precious").unwrap();
    for bad in ["gather", "", "SPLAT "] {
        let render = ["render", scene, "--width", "8", "--height", "8", "--reconstruction", bad, "-o", "out.png"];
        assert_fails_cleanly(&render, "splat, sample", &dir);
        let bench = ["bench", "path", scene, "--width", "8", "--height", "8", "--reconstruction", bad];
        assert_fails_cleanly(&bench, "splat, sample", &dir);
    }
}

#[test]
fn path_mode_writes_png_and_aov_exr() {
    let dir = scratch("path-render");
    for filter in ["guided", "bilateral", "atrous", "none"] {
        let out = format!("{filter}.exr");
        let o = glint(
            &[
                "render", "--mode", "path", "--filter", filter, "--spp", "2", "--width", "48", "--height", "32", "-o",
                &out,
            ],
            &dir,
        );
        assert!(o.status.success(), "{filter}: {}", stderr(&o));
        let img = glint_image::read_image(&dir.join(&out)).expect("read exr");
        for c in PATH_CHANNELS.iter().chain(&["R", "Albedo.R", "Ns.X", "Z"]) {
            assert!(img.channel(c).is_some(), "{filter}: channel {c} missing");
        }
        let samples = img.channel("SampleCount").unwrap();
        assert!(samples.iter().all(|&s| s == 2.0), "{filter}: sample counts {:?}", &samples[..4]);
        let r = img.channel("R").unwrap();
        assert!(r.iter().all(|v| v.is_finite()) && r.iter().any(|&v| v > 0.0), "{filter}: beauty");
    }
    let o = glint(&["render", "--mode", "path", "--width", "48", "--height", "32", "-o", "p.png", "-q"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("p.png").exists());
}

#[test]
fn bench_path_reports_each_stage_as_render_does() {
    // The trace and filter stages `glint render` prints, as medians over the frames.
    let dir = scratch("bench-path-stages");
    std::fs::write(dir.join("tetra.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n")
        .unwrap();
    let args = ["bench", "path", "tetra.obj", "--filter", "guided", "--width", "24", "--height", "16", "--frames", "3"];
    let o = glint(&args, &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out.lines().find(|l| l.starts_with("path 24x16")).expect("a result line");
    let stages = line.split("stages (medians, ms): ").nth(1).expect("stages");
    let names: Vec<&str> = stages.split(", ").map(|s| s.split(' ').next().unwrap_or("")).collect();
    assert_eq!(names, ["trace", "filter"], "{line}");
    for stage in stages.split(", ") {
        let ms: f64 = stage.split(' ').nth(1).and_then(|v| v.parse().ok()).expect("a time");
        assert!(ms.is_finite() && ms >= 0.0, "{line}");
    }
    assert!(out.lines().last().is_some_and(|l| l.starts_with("mpaths_per_s_median=")), "{out}");
}

/// `--beauty-only` writes an EXR of the picture alone (R, G, B, A), the bits of the full EXR's
/// picture (the path AOVs' sums are skipped, not the picture's), for a Mitsuba scene's
/// splatting film and a glint scene; with --chunk it is refused, nothing written.
#[test]
fn beauty_only_writes_the_same_picture_without_the_aovs() {
    let dir = scratch("path-beauty-only");
    let xml = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/mitsuba/scenes/cbox/cbox.xml");
    let toml = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes/mitsuba-cbox.toml");
    for scene in [xml, toml] {
        let args = ["render", scene, "--width", "24", "--height", "20", "--spp", "3", "-q"];
        for (extra, out) in [(&[][..], "all.exr"), (&["--beauty-only"][..], "beauty.exr")] {
            let o = glint(&[&args[..], extra, &["-o", out]].concat(), &dir);
            assert!(o.status.success(), "{}", stderr(&o));
        }
        let read = |f: &str| glint_image::read_image(&dir.join(f)).unwrap();
        let (all, beauty) = (read("all.exr"), read("beauty.exr"));
        let mut names: Vec<&str> = beauty.channels.iter().map(|c| c.name.as_str()).collect();
        names.sort_unstable();
        assert_eq!(names, ["A", "B", "G", "R"], "{scene}");
        assert!(all.channel("Direct.R").is_some() && all.channel("Z").is_some());
        for c in ["R", "G", "B", "A"] {
            assert_eq!(beauty.channel(c), all.channel(c), "{scene}: {c}");
        }
    }
    std::fs::write(dir.join("part.exr"), b"precious").unwrap();
    let chunk = ["render", toml, "--spp", "2", "--beauty-only", "--chunk", "0/2", "-o", "part.exr"];
    common::assert_fails_keeping(&chunk, "--beauty-only", &dir, "part.exr");
}

#[test]
fn a_time_budget_renders_several_passes() {
    let dir = scratch("path-time");
    let o = glint(
        &[
            "render",
            "--mode",
            "path",
            "--time",
            "0.5",
            "--width",
            "32",
            "--height",
            "24",
            "-o",
            "t.exr",
            "--max-bounces",
            "1",
        ],
        &dir,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("passes"), "{}", stderr(&o));
    let img = glint_image::read_image(&dir.join("t.exr")).expect("read");
    let s = img.channel("SampleCount").unwrap()[0];
    assert!(s > 1.0, "{s} samples after 0.5 s");
}

/// `glint filter` on an unfiltered 1-spp render gives what filtering inside the render gives
/// with the paper's split (a stored EXR keeps the indirect light apart, not area lights' direct
/// light).
#[test]
fn filtering_a_stored_render_matches_filtering_in_the_render() {
    let dir = scratch("path-filter");
    let common = ["--mode", "path", "--spp", "1", "--width", "64", "--height", "48", "--seed", "3"];
    let run = |extra: &[&str]| {
        let mut args = vec!["render"];
        args.extend_from_slice(&common);
        args.extend_from_slice(extra);
        let o = glint(&args, &dir);
        assert!(o.status.success(), "{}", stderr(&o));
    };
    run(&["--filter", "none", "-o", "raw.exr"]);
    run(&["--filter", "atrous", "--paper-split", "-o", "inside.exr"]);
    let o = glint(&["filter", "raw.exr", "--filter", "atrous", "-o", "outside.exr"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let raw = glint_image::read_image(&dir.join("raw.exr")).unwrap();
    let inside = glint_image::read_image(&dir.join("inside.exr")).unwrap();
    let outside = glint_image::read_image(&dir.join("outside.exr")).unwrap();
    let diff = |a: &glint_image::Image, b: &glint_image::Image| {
        let (x, y) = (a.channel("R").unwrap(), b.channel("R").unwrap());
        x.iter().zip(y).map(|(p, q)| ((p - q) as f64).powi(2)).sum::<f64>() / x.len() as f64
    };
    // The filter changed the image, and both routes agree (A-Trous sees the same buffers; the
    // depth guide differs only by its scale, which A-Trous's depth weight tolerates).
    assert!(diff(&raw, &outside) > 1e-6, "filter changed nothing");
    assert!(
        diff(&inside, &outside) < 0.1 * diff(&raw, &outside),
        "{} vs {}",
        diff(&inside, &outside),
        diff(&raw, &outside)
    );
    let o = glint(&["filter", "raw.exr", "-o", "guided.png"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.join("guided.png").exists());
}

/// `--sampler` picks the camera samples' random numbers: the same seed gives another picture
/// with each sampler, the same one again with the same sampler; a name glint does not know is
/// refused before anything is written.
#[test]
fn the_sampler_option_changes_the_numbers_and_refuses_unknown_names() {
    let dir = scratch("path-sampler");
    let render = |sampler: &str, out: &str| {
        let args = ["render", "--mode", "path", "--spp", "4", "--width", "32", "--height", "24", "--filter", "none"];
        let mut args = args.to_vec();
        args.extend_from_slice(&["--sampler", sampler, "-o", out]);
        glint(&args, &dir)
    };
    for (sampler, out) in [("sobol", "a.exr"), ("independent", "b.exr"), ("sobol", "c.exr")] {
        let o = render(sampler, out);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    let read = |f: &str| glint_image::read_image(&dir.join(f)).unwrap().channel("R").unwrap().to_vec();
    assert_ne!(read("a.exr"), read("b.exr"));
    assert_eq!(read("a.exr"), read("c.exr"));
    let o = render("halton", "d.exr");
    assert!(!o.status.success() && stderr(&o).contains("halton"), "{}", stderr(&o));
    assert!(!dir.join("d.exr").exists());
}

#[test]
fn bad_path_options_and_filter_inputs_fail_cleanly() {
    let dir = scratch("path-bad");
    std::fs::write(dir.join("out.png"), b"precious").unwrap();
    let o = glint(&["render", "--width", "16", "--height", "16", "-o", "whitted.exr"], &dir);
    assert!(o.status.success());
    let base = ["render", "--mode", "path", "--width", "16", "--height", "16", "-o", "out.png"];
    let with = |extra: &[&str]| -> Vec<String> { base.iter().chain(extra).map(|s| s.to_string()).collect() };
    for (extra, needle) in [
        (&["--spp", "0"][..], "samples per pixel"),
        (&["--time", "0"], "--time"),
        (&["--time", "-3"], "--time"),
        (&["--radius", "0"], "--radius"),
        (&["--eps-normal", "-1"], "--eps-normal"),
        (&["--eps-depth", "nan"], "--eps-depth"),
        (&["--iterations", "0"], "--iterations"),
        (&["--max-bounces", "1000"], "bounces"),
        (&["--clamp", "-1"], "clamp"),
    ] {
        let args = with(extra);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_fails_cleanly(&args, needle, &dir);
    }
    // A Whitted EXR has no Indirect channels.
    assert_fails_cleanly(&["filter", "whitted.exr", "-o", "out.png"], "Indirect.R", &dir);
    assert_fails_cleanly(&["filter", "missing.exr", "-o", "out.png"], "missing.exr", &dir);
    assert_fails_cleanly(&["filter", "whitted.exr", "--filter", "none", "-o", "out.png"], "nothing to do", &dir);
    assert_fails_cleanly(&["filter", "out.png", "-o", "out.png"], "overwrite", &dir);
    // NaN in the indirect light.
    let mut img = glint_image::read_image(&dir.join("whitted.exr")).unwrap();
    for name in PATH_CHANNELS {
        img.add_channel(name, vec![0.5; 256]).unwrap();
    }
    img.channel_mut("Indirect.G").unwrap()[17] = f32::NAN;
    glint_image::write_exr(&dir.join("nan.exr"), &img).unwrap();
    assert_fails_cleanly(&["filter", "nan.exr", "-o", "out.png"], "Indirect.G", &dir);
}

/// A scene that says `[render] mode = "path"` renders in path mode unless --mode says otherwise.
#[test]
fn the_scene_chooses_the_mode() {
    let dir = scratch("path-scene-mode");
    let scene = "[render]\nmode = \"path\"\nmax_bounces = 1\n\n[camera]\nposition = [0.0, 0.0, 4.0]\nlook_at = [0.0, 0.0, 0.0]\n\n[[object]]\ntype = \"sphere\"\ncentre = [0.0, 0.0, 0.0]\nradius = 1.0\n";
    std::fs::write(dir.join("s.toml"), scene).unwrap();
    let o = glint(&["render", "s.toml", "--width", "24", "--height", "16", "-o", "p.exr"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("path 24x16") && stderr(&o).contains("1 bounces"), "{}", stderr(&o));
    assert!(glint_image::read_image(&dir.join("p.exr")).unwrap().channel("Indirect.R").is_some());
    let o = glint(&["render", "s.toml", "--mode", "whitted", "--width", "24", "--height", "16", "-o", "w.exr"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(glint_image::read_image(&dir.join("w.exr")).unwrap().channel("Indirect.R").is_none());
}

/// `glint bench filters` and `glint bench gi` run end to end on tiny settings (the real runs are
/// in BENCHMARKS.md §6).
#[test]
fn the_paper_benchmarks_run() {
    let Some(data) = common::shared("data/scenes/cornell_box/cornell_box_open.obj") else { return };
    let data = data.parent().and_then(|p| p.parent()).and_then(|p| p.parent()).expect("data folder");
    let data = data.to_str().expect("utf-8 path");
    let dir = scratch("bench-gi");
    let o = glint(&["bench", "filters", "--data", data, "--width", "48", "--height", "32", "--reps", "1"], &dir);
    // Sponza is the filters' input; without it the command says which file is missing.
    assert!(o.status.success() || stderr(&o).contains("sponza"), "{}", stderr(&o));
    let o = glint(&common::bench_gi_tiny(data), &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("Table 1") && out.contains("Figure 8") && out.contains("guided+area"), "{out}");
    assert!(dir.join("gi/gi-contact-sheet.png").exists());
    assert!(dir.join("gi/cornell-box-guided-1spp.png").exists());
    let o = glint(&["bench", "gi", "--data", "nowhere", "--skip-quality"], &dir);
    assert!(!o.status.success() && stderr(&o).contains("nowhere"), "{}", stderr(&o));
}
