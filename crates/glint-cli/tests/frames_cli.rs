//! Animations on the command line (issue 18; docs/cluster.md): `--frame-range A..B` with
//! `--frame-step` and `--fps` renders each frame to its own file from an `out_%04d.png`
//! pattern, each the picture `--scene-time f/fps` gives; `--skip-existing` resumes an
//! interrupted run without touching what is done (and a killed run leaves no partial file);
//! per-frame chunks merge to the frame; bad ranges, patterns and rates are refused cleanly.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, repo, scratch, stderr};
use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

fn scene() -> String {
    repo().join("scenes/animated.toml").display().to_string()
}

const SMALL: [&str; 4] = ["--width", "64", "--height", "36"];

fn ok(args: &[&str], dir: &Path) -> String {
    let o = glint(args, dir);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stderr(&o)
}

fn render(extra: &[&str], dir: &Path) -> String {
    let scene = scene();
    let mut args = vec!["render", scene.as_str()];
    args.extend(SMALL);
    args.extend(extra);
    ok(&args, dir)
}

fn same(dir: &Path, a: &str, b: &str) {
    assert!(std::fs::read(dir.join(a)).unwrap() == std::fs::read(dir.join(b)).unwrap(), "{a} differs from {b}");
}

/// Frames 0..6 step 3 at 4 fps are frames 0, 3, 6, each equal to the single render at f/4 s;
/// the frames differ (the scene moves).
#[test]
fn each_frame_is_the_render_at_its_time() {
    let d = scratch("frames-range");
    render(&["--frame-range", "0..6", "--frame-step", "3", "--fps", "4", "-o", "f_%03d.png"], &d);
    let mut names: Vec<String> =
        std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    assert_eq!(names, ["f_000.png", "f_003.png", "f_006.png"]);
    for (f, t) in [(0, "0"), (3, "0.75"), (6, "1.5")] {
        render(&["--scene-time", t, "-o", "single.png"], &d);
        same(&d, &format!("f_{f:03}.png"), "single.png");
    }
    assert!(std::fs::read(d.join("f_000.png")).unwrap() != std::fs::read(d.join("f_003.png")).unwrap());
    // One frame needs no pattern; %d pads nothing.
    render(&["--frame-range", "3..3", "--fps", "4", "-o", "one.png"], &d);
    same(&d, "one.png", "f_003.png");
    render(&["--frame-range", "3..3", "--fps", "4", "-o", "n%d.png"], &d);
    same(&d, "n3.png", "f_003.png");
}

/// `--skip-existing` leaves a file that is there alone and renders the rest; a run killed
/// mid-frame leaves only complete files, and resuming it gives the uninterrupted run's files.
#[test]
fn skip_existing_resumes_an_interrupted_run() {
    let d = scratch("frames-resume");
    std::fs::write(d.join("f_001.png"), b"precious").unwrap();
    let said = render(&["--frame-range", "0..2", "--skip-existing", "-o", "f_%03d.png"], &d);
    assert!(said.contains("f_001.png exists, skipped"), "{said}");
    assert_eq!(std::fs::read(d.join("f_001.png")).unwrap(), b"precious");
    assert!(d.join("f_000.png").exists() && d.join("f_002.png").exists());
    // Everything there: nothing to do, nothing loaded.
    let said = render(&["--frame-range", "0..2", "--skip-existing", "-o", "f_%03d.png"], &d);
    assert_eq!(said.matches("skipped").count(), 3, "{said}");

    // The uninterrupted run, then one killed while it works on its frames.
    let scene = scene();
    let big = ["--width", "640", "--height", "360", "--mode", "path", "--spp", "2", "--frame-range", "0..5"];
    let full = scratch("frames-resume-full");
    let mut args = vec!["render", scene.as_str()];
    args.extend(big);
    args.extend(["-o", "k_%02d.png", "--quiet"]);
    ok(&args, &full);
    let mut child = Command::new(env!("CARGO_BIN_EXE_glint")).args(&args).current_dir(&d).spawn().unwrap();
    let start = Instant::now();
    while !d.join("k_01.png").exists() {
        assert!(start.elapsed() < Duration::from_secs(120), "no frame written");
        std::thread::sleep(Duration::from_millis(5));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let done: Vec<String> = std::fs::read_dir(&d)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with("k_"))
        .collect();
    assert!(done.len() < 6, "the kill came too late: {done:?}");
    // Under its own name every file is whole (a write killed midway leaves at most a hidden
    // temporary file, which --skip-existing does not take for the frame).
    for name in &done {
        assert_eq!(
            std::fs::read(d.join(name)).unwrap(),
            std::fs::read(full.join(name)).unwrap(),
            "{name} is not whole"
        );
    }
    args.push("--skip-existing");
    ok(&args, &d);
    for f in 0..6 {
        let name = format!("k_{f:02}.png");
        assert_eq!(std::fs::read(d.join(&name)).unwrap(), std::fs::read(full.join(&name)).unwrap(), "{name}");
    }
}

/// Per-frame chunks: two chunks of frames 1 and 2, merged frame by frame, equal the frames
/// rendered whole; the frames' chunks do not mix (each frame has its own scene hash).
#[test]
fn frame_chunks_merge_to_each_frame() {
    let d = scratch("frames-chunks");
    let path = ["--mode", "path", "--spp", "4", "--filter", "none", "--frame-range", "1..2"];
    for i in ["0", "1"] {
        let mut extra = path.to_vec();
        let pattern = format!("p_%d_{i}.exr");
        let chunk = format!("{i}/2");
        extra.extend(["--chunk", chunk.as_str(), "-o", pattern.as_str()]);
        render(&extra, &d);
    }
    let mut extra = path.to_vec();
    extra.extend(["-o", "whole_%d.png"]);
    render(&extra, &d);
    for f in ["1", "2"] {
        ok(&["merge", &format!("p_{f}_0.exr"), &format!("p_{f}_1.exr"), "-o", &format!("merged_{f}.png")], &d);
        same(&d, &format!("merged_{f}.png"), &format!("whole_{f}.png"));
    }
    let o = glint(&["merge", "p_1_0.exr", "p_2_1.exr", "-o", "mixed.png"], &d);
    assert!(!o.status.success() && !d.join("mixed.png").exists(), "frames 1 and 2 merged: {}", stderr(&o));
}

/// Bad ranges, steps, rates and patterns: a clear error, nothing written or overwritten.
#[test]
fn bad_frame_options_are_refused() {
    let d = scratch("frames-bad");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    let scene = scene();
    let cases: [(&[&str], &str); 9] = [
        (&["--frame-range", "5..2"], "A <= B"),
        (&["--frame-range", "x"], "expected A..B"),
        (&["--frame-range", "-1..3"], "expected A..B"),
        (&["--frame-range", "0..3", "--frame-step", "0"], "--frame-step 0"),
        (&["--frame-range", "0..3", "--fps", "0"], "--fps 0"),
        (&["--frame-range", "0..3", "--fps", "NaN"], "--fps NaN"),
        (&["--frame-range", "0..3", "--scene-time", "1"], "give one"),
        (&["--frame-range", "0..3"], "every frame would overwrite it"),
        (&["--frame-range", "0..3", "-o", "o_%4d.png"], "%0Nd"),
    ];
    for (extra, needle) in cases {
        let mut args = vec!["render", scene.as_str()];
        if !extra.contains(&"-o") {
            args.extend(["-o", "out.png"]);
        }
        args.extend(extra);
        assert_fails_cleanly(&args, needle, &d);
    }
    assert_fails_cleanly(&["render", scene.as_str(), "-o", "out_%02d.png"], "needs --frame-range", &d);
    let names: Vec<_> = std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 1, "{names:?}");
}
