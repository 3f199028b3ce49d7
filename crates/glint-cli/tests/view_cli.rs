//! The viewer end to end: `glint bench view` (the frame loop, headless) and `glint view` in a
//! real window on a virtual X server (Xvfb, which .ci/install-deps installs).
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
use common::{Xvfb, glint, glint_on, repo, scratch, shared, stderr};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

#[test]
fn the_headless_frame_loop_measures_every_mode() {
    let dir = scratch("bench-view");
    let o = glint(&["bench", "view", "--frames", "3", "--width", "64", "--height", "48"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.starts_with("Whitted 64x48, 3 frames") && text.contains("fps") && text.contains("Mrays/s"), "{text}");
    let o = glint(
        &["bench", "view", "--mode", "path", "--frames", "2", "--width", "48", "--height", "32", "--per-frame"],
        &dir,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("frame 1:") && text.contains("filter"), "{text}");
    if let Some(bunny) = shared("data/pointclouds/stanford_bunny_rawscan_40256.xyz") {
        let o = glint(
            &["bench", "view", bunny.to_str().unwrap(), "--frames", "3", "--width", "64", "--height", "48"],
            &dir,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8(o.stdout).unwrap();
        assert!(text.starts_with("points") && text.contains("pull-push") && text.contains("Mpoints/s"), "{text}");
        // The demo scene has no clouds for the points mode.
        let o = glint(&["bench", "view", "--mode", "points", "--frames", "1"], &dir);
        assert!(!o.status.success() && stderr(&o).contains("no point clouds"), "{}", stderr(&o));
    }
    for bad in [&["--frames", "0"][..], &["--width", "0"][..], &["--mode", "path", "--spp", "0"][..]] {
        let mut args = vec!["bench", "view"];
        args.extend_from_slice(bad);
        let o = glint(&args, &dir);
        assert!(!o.status.success(), "{bad:?} should fail");
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    }
}

/// The real window: `glint view` opens it on Xvfb, draws a few frames and closes; the pixels
/// read back from the X server are the scene (they match a `glint render` of the same view
/// below the statistics box, to within the display's rounding), with the statistics drawn over its corner; not a blank or
/// garbage frame.
#[cfg(target_os = "linux")]
#[test]
fn the_window_shows_the_scene() {
    let dir = scratch("view-window");
    let x = Xvfb::start();
    let scene = repo().join("scenes/whitted-bench.toml");
    let scene = scene.to_str().unwrap();
    let o = glint_on(
        &x.display,
        &[
            "view",
            scene,
            "--width",
            "320",
            "--height",
            "200",
            "--frames",
            "8",
            "--max-samples",
            "1",
            "--capture",
            "shot.png",
        ],
        &dir,
        Duration::from_secs(120),
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("captured"), "{}", stderr(&o));
    let o = glint(&["render", scene, "--width", "320", "--height", "200", "-o", "ref.png"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let shot = glint_image::read_image(&dir.join("shot.png")).unwrap();
    let reference = glint_image::read_image(&dir.join("ref.png")).unwrap();
    assert_eq!((shot.width, shot.height), (320, 200));
    let bytes = |img: &glint_image::Image| glint_image::encode_srgb8(img, &glint_image::PngOptions::default()).unwrap();
    let (a, b) = (bytes(&shot), bytes(&reference));
    // Below the statistics box (6 lines of 11 px + margins at scale 1): the picture. With
    // --max-samples 1 the window keeps the one-ray-per-pixel frame `glint render` draws; only
    // the display's sRGB table (within one level of the exact encoding) differs.
    let from = 80 * 320 * 3;
    let mse = a[from..].iter().zip(&b[from..]).map(|(x, y)| (*x as f64 - *y as f64).powi(2)).sum::<f64>()
        / (a.len() - from) as f64;
    let psnr = 10.0 * (255.0f64 * 255.0 / mse.max(1e-9)).log10();
    assert!(psnr > 45.0, "the window is not the scene: {psnr:.1} dB against the render");
    // Not a flat frame: the sky, the floor's checks, the spheres.
    let distinct: std::collections::HashSet<&[u8]> = a[from..].chunks(3).collect();
    assert!(distinct.len() > 500, "{} colours", distinct.len());
    // The statistics are drawn: pure white glyph pixels in the top-left box.
    assert!(a[..40 * 320 * 3].chunks(3).any(|p| p == [255, 255, 255]));
    // Keys through the real window (xdotool sends them to it): 2 switches to the path mode,
    // P writes a screenshot (the EXR then carries the path mode's AOVs), Esc quits cleanly.
    let mut child = Command::new(env!("CARGO_BIN_EXE_glint"))
        .args(["view", scene, "--width", "160", "--height", "120"])
        .current_dir(&dir)
        .env("DISPLAY", &x.display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let xdotool = |args: &[&str]| x.xdotool(args);
    let wait_for = |what: &str, done: &mut dyn FnMut() -> bool| {
        let start = Instant::now();
        while !done() {
            assert!(start.elapsed() < Duration::from_secs(60), "timed out waiting for {what}");
            std::thread::sleep(Duration::from_millis(100));
        }
    };
    // The window, or why there is none: a viewer that exited says so (its status and stderr),
    // one that hangs is killed rather than left behind.
    let start = Instant::now();
    let window = loop {
        let found = xdotool(&["search", "--name", "^glint"]).lines().next().unwrap_or("").to_string();
        if !found.is_empty() {
            break found;
        }
        if let Some(status) = child.try_wait().unwrap() {
            let mut err = String::new();
            child.stderr.take().map(|mut e| std::io::Read::read_to_string(&mut e, &mut err));
            panic!("the viewer exited ({status}) before its window showed: {err}");
        }
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("timed out waiting for the window (the viewer was still running)");
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    xdotool(&["windowfocus", &window]);
    xdotool(&["key", "--window", &window, "2"]);
    std::thread::sleep(Duration::from_millis(500));
    xdotool(&["key", "--window", &window, "p"]);
    let shot = dir.join("glint-view-001.exr");
    wait_for("the screenshot", &mut || shot.exists() && dir.join("glint-view-001.png").exists());
    xdotool(&["key", "--window", &window, "Escape"]);
    wait_for("the viewer to quit", &mut || child.try_wait().unwrap().is_some());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let aovs = glint_image::read_image(&shot).unwrap();
    assert_eq!((aovs.width, aovs.height), (160, 120));
    assert!(aovs.channel("Direct.R").is_some(), "key 2 did not switch to the path mode");
    // A display that cannot be opened: a clear error and a non-zero exit, no panic.
    let o = glint_on(":9999", &["view", "--frames", "1"], &dir, Duration::from_secs(30));
    assert!(!o.status.success());
    assert!(stderr(&o).contains("cannot open a window") && !stderr(&o).contains("panicked"), "{}", stderr(&o));
}

/// Without any display the viewer refuses at once, naming the headless alternative; bad
/// options fail before a window would open.
#[test]
fn the_viewer_fails_cleanly_without_a_display_or_with_bad_options() {
    let dir = scratch("view-errors");
    let run = |args: &[&str]| {
        Command::new(env!("CARGO_BIN_EXE_glint"))
            .args(args)
            .current_dir(&dir)
            .env_remove("DISPLAY")
            .env_remove("WAYLAND_DISPLAY")
            .output()
            .unwrap()
    };
    let o = run(&["view", "--frames", "1"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("no display") && stderr(&o).contains("bench view"), "{}", stderr(&o));
    for (args, needle) in [
        (&["view", "--width", "0"][..], "--width"),
        (&["view", "--spp", "0"][..], "samples per pixel"),
        (&["view", "--max-depth", "65"][..], "--max-depth"),
        (&["view", "--frames", "0"][..], "--frames"),
        (&["view", "--capture", "x.jpg"][..], "--capture"),
        (&["view", "--screenshot-dir", "missing"][..], "--screenshot-dir"),
        (&["view", "no-such-scene.toml"][..], "no-such-scene.toml"),
        (&["view", "--mode", "points"][..], "no point clouds"),
    ] {
        let o = run(args);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(stderr(&o).contains(needle), "{args:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    }
}
