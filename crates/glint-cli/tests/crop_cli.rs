//! `glint render --crop X0,Y0,X1,Y1` (pbrt's `--pixelbounds`, Mitsuba's film crop): the
//! output is the window, and its pixels are the whole frame's, bit for bit (same camera rays,
//! random streams hashed by the film's pixel index), in the Whitted and path modes.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, repo, scratch, stderr};

fn channels(path: &std::path::Path) -> (u32, u32, Vec<Vec<f32>>) {
    let img = glint_image::read_image(path).unwrap();
    let planes = ["R", "G", "B"].iter().map(|c| img.channel(c).unwrap().to_vec()).collect();
    (img.width, img.height, planes)
}

fn assert_window_matches(args: &[&str], name: &str) {
    let d = scratch(&format!("crop-{name}"));
    let run = |extra: &[&str], out: &str| {
        let mut a: Vec<&str> = args.to_vec();
        a.extend_from_slice(extra);
        a.extend(["-o", out]);
        let o = glint(&a, &d);
        assert!(o.status.success(), "{a:?}: {}", stderr(&o));
        channels(&d.join(out))
    };
    let (w, _, full) = run(&[], "full.exr");
    let (cw, ch, crop) = run(&["--crop", "10,5,41,30"], "crop.exr");
    assert_eq!((cw, ch), (31, 25));
    for (c, (f, k)) in full.iter().zip(&crop).enumerate() {
        for y in 0..ch as usize {
            for x in 0..cw as usize {
                let (a, b) = (f[(y + 5) * w as usize + x + 10], k[y * cw as usize + x]);
                assert!(a.to_bits() == b.to_bits(), "{name}: channel {c} pixel ({x}, {y}): {a} vs {b}");
            }
        }
    }
}

#[test]
fn a_crop_is_the_frames_own_pixels() {
    let scene = |s: &str| repo().join("scenes").join(s).display().to_string();
    let whitted = scene("whitted-bench.toml");
    assert_window_matches(&["render", &whitted, "--width", "64", "--height", "48", "--spp", "4"], "whitted");
    let cornell = scene("cornell-box.toml");
    let path =
        ["render", &cornell, "--mode", "path", "--filter", "none", "--spp", "2", "--width", "48", "--height", "40"];
    assert_window_matches(&path, "path");
}

#[test]
fn bad_crops_are_refused() {
    let d = scratch("crop-bad");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    let scene = repo().join("scenes/whitted-bench.toml").display().to_string();
    let small = ["render", scene.as_str(), "--width", "32", "--height", "24", "-o", "out.png"];
    let with = |crop: &str| -> Vec<String> {
        small.iter().map(|s| s.to_string()).chain(["--crop".to_string(), crop.to_string()]).collect()
    };
    for (crop, needle) in [
        ("1,2,3", "four"),
        ("0,0,33,10", "inside the 32x24 frame"),
        ("5,5,5,9", "non-empty"),
        ("a,b,c,d", "whole numbers"),
    ] {
        let args = with(crop);
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        assert_fails_cleanly(&args, needle, &d);
    }
}
