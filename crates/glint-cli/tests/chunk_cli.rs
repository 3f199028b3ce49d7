//! `glint render --chunk I/N`, `--tile I/N` and `glint merge` (issue 18; docs/cluster.md): a
//! path frame split into chunks of its passes or into tiles and merged is the single-process
//! render bit for bit (EXR with every AOV, and PNG), with and without the guided filter, for
//! chunk counts that do and do not divide the passes or the image; so is a Whitted frame split
//! by samples or by tiles; and every bad set of chunks is refused, naming the files, with
//! nothing overwritten.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{glint, repo, scratch, stderr};
use std::path::Path;
use std::process::Command;

fn cornell() -> String {
    repo().join("scenes/cornell-box.toml").display().to_string()
}

/// `glint args…` in `dir`, which must succeed.
fn ok(args: &[&str], dir: &Path) {
    let o = glint(args, dir);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
}

/// Render `frame` whole and in `n` chunks, merge, and compare the files byte for byte.
fn assert_merge_is_single(frame: &[&str], n: u32, dir: &Path) {
    assert_split_is_single(frame, "--chunk", n, dir);
}

/// Render `frame` whole and split `n` ways by `split` (`--chunk` or `--tile`), merge, and
/// compare the files byte for byte.
fn assert_split_is_single(frame: &[&str], split: &str, n: u32, dir: &Path) {
    let with = |extra: &[&str]| -> Vec<String> { frame.iter().chain(extra).map(|s| s.to_string()).collect() };
    let run = |extra: &[&str]| {
        let a = with(extra);
        ok(&a.iter().map(String::as_str).collect::<Vec<_>>(), dir);
    };
    run(&["-q", "-o", "single.exr"]);
    run(&["-q", "-o", "single.png"]);
    let mut parts = Vec::new();
    for i in 0..n {
        let (chunk, part) = (format!("{i}/{n}"), format!("part_{i}.exr"));
        run(&["-q", split, &chunk, "-o", &part]);
        parts.push(part);
    }
    // Any order of the files.
    parts.reverse();
    for out in ["merged.exr", "merged.png"] {
        let mut a: Vec<&str> = vec!["merge", "-q"];
        a.extend(parts.iter().map(String::as_str));
        a.extend(["-o", out]);
        ok(&a, dir);
    }
    for (single, merged) in [("single.exr", "merged.exr"), ("single.png", "merged.png")] {
        let (s, m) = (std::fs::read(dir.join(single)).unwrap(), std::fs::read(dir.join(merged)).unwrap());
        assert!(s == m, "{frame:?} split {n} ways by {split}: {merged} differs from {single}");
    }
    for p in parts {
        std::fs::remove_file(dir.join(p)).unwrap();
    }
}

#[test]
fn merged_chunks_are_the_single_render_bit_for_bit() {
    let d = scratch("chunk-merge");
    let scene = cornell();
    let size = ["--width", "40", "--height", "30"];
    // Unfiltered: 7 samples per pixel, a unit each; filtered (guided, the scene's default):
    // 7 passes of 2 samples; unfiltered passes of 3 samples split across pass boundaries.
    let plain: Vec<&str> =
        [&["render", &scene, "--mode", "path", "--filter", "none", "--spp", "7"][..], &size].concat();
    let guided: Vec<&str> =
        [&["render", &scene, "--mode", "path", "--filter", "guided", "--spp", "2", "--passes", "7"][..], &size]
            .concat();
    let passes: Vec<&str> =
        [&["render", &scene, "--mode", "path", "--filter", "none", "--spp", "3", "--passes", "2"][..], &size].concat();
    for n in [1, 2, 4, 7] {
        assert_merge_is_single(&plain, n, &d);
        assert_merge_is_single(&guided, n, &d);
    }
    assert_merge_is_single(&passes, 4, &d);
    // A crop window and an exposure and tone map carried to the merge by the chunks' headers.
    let window: Vec<&str> =
        [&guided[..], &["--crop", "5,3,37,21", "--exposure", "1.5", "--tonemap", "aces", "--seed", "9"]].concat();
    assert_merge_is_single(&window, 3, &d);
}

/// Mitsuba's Cornell box has a Gaussian film: its samples are splatted into the pixels around
/// theirs. Split by samples or by tiles (each tile traced with the splats' reach around it),
/// cropped, and on one thread, the frame is the single render's bit for bit.
#[test]
fn splatted_frames_merge_crop_and_thread_bit_for_bit() {
    let Some(xml) = common::shared("data/mitsuba/scenes/cbox/cbox.xml") else { return };
    let xml = xml.display().to_string();
    let d = scratch("splat-merge");
    let plain = ["render", &xml, "-D", "res=40", "--spp", "5", "--max-bounces", "2"];
    assert_merge_is_single(&plain, 3, &d);
    for n in [2, 5] {
        assert_split_is_single(&plain, "--tile", n, &d);
    }
    let window: Vec<&str> = [&plain[..], &["--crop", "7,3,33,21"]].concat();
    assert_split_is_single(&window, "--tile", 4, &d);
    // A crop of the frame: its own pixels (those at its edges hold splats from outside it).
    ok(&[&plain[..], &["-q", "-o", "whole.exr"]].concat(), &d);
    ok(&[&window[..], &["-q", "-o", "window.exr"]].concat(), &d);
    ok(&[&plain[..], &["-q", "--threads", "1", "-o", "one.exr"]].concat(), &d);
    let read = |f: &str| glint_image::read_image(&d.join(f)).unwrap();
    let (whole, window, one) = (read("whole.exr"), read("window.exr"), read("one.exr"));
    for c in ["R", "G", "B", "Direct.R", "Indirect.B", "SampleCount"] {
        let (a, b) = (whole.channel(c).unwrap(), window.channel(c).unwrap());
        for y in 0..18 {
            for x in 0..26 {
                let (f, k) = (a[(y + 3) * 40 + x + 7], b[y * 26 + x]);
                assert_eq!(f.to_bits(), k.to_bits(), "{c} at ({x}, {y}) of the crop: {k} vs the frame's {f}");
            }
        }
        assert_eq!(a, one.channel(c).unwrap(), "{c}: one thread");
    }
    assert!(whole.channel("Variance.R").is_none(), "a splatted pixel has no per-sample variance");
    // Drawn from the filter instead, the pixels differ, and the variance is there.
    ok(&[&plain[..], &["-q", "--reconstruction", "sample", "-o", "sampled.exr"]].concat(), &d);
    let sampled = read("sampled.exr");
    assert!(sampled.channel("Variance.R").is_some());
    assert_ne!(sampled.channel("R").unwrap(), whole.channel("R").unwrap());
    // `bench path` times either, with the path AOVs' sums (as a render to EXR) or without.
    for (rc, aovs) in [("splat", false), ("sample", false), ("splat", true)] {
        let args = ["bench", "path", &xml, "--width", "16", "--height", "16", "--frames", "1", "--reconstruction", rc];
        let o = common::glint(&[&args[..], if aovs { &["--aovs"] } else { &[] }].concat(), &d);
        assert!(o.status.success() && String::from_utf8_lossy(&o.stdout).contains("mpaths_per_s_median="), "{rc}");
    }
    // More samples than a splatted sum can hold: refused, naming the way out.
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    let many = ["render", &xml, "-D", "res=8", "--spp", "50000", "-o", "out.png"];
    common::assert_fails_cleanly(&many, "--reconstruction sample", &d);
}

#[test]
fn merged_tiles_and_whitted_chunks_are_the_single_render_bit_for_bit() {
    let d = scratch("tile-merge");
    let scene = cornell();
    let size = ["--width", "40", "--height", "30"];
    let guided: Vec<&str> =
        [&["render", &scene, "--mode", "path", "--filter", "guided", "--spp", "3", "--passes", "2"][..], &size]
            .concat();
    for n in [1, 2, 4, 7] {
        assert_split_is_single(&guided, "--tile", n, &d);
    }
    let plain: Vec<&str> =
        [&["render", &scene, "--mode", "path", "--filter", "none", "--spp", "5"][..], &size].concat();
    assert_split_is_single(&plain, "--tile", 3, &d);
    // A-Trous reads further than the guided filter; a crop window split in tiles.
    let atrous: Vec<&str> =
        [&["render", &scene, "--mode", "path", "--filter", "atrous", "--spp", "2"][..], &size].concat();
    assert_split_is_single(&atrous, "--tile", 4, &d);
    let window: Vec<&str> = [&guided[..], &["--crop", "5,3,37,21", "--seed", "4"]].concat();
    assert_split_is_single(&window, "--tile", 5, &d);
    // Whitted: spheres and a mirror plane supersampled 3 x 3, split by samples (9 = 2 + 2 + 2
    // + 3, and 1 per chunk) and by tiles; one sample per pixel in tiles; a mesh.
    let bench = repo().join("scenes/whitted-bench.toml").display().to_string();
    let whitted: Vec<&str> = [&["render", &bench, "--spp", "9"][..], &size].concat();
    for n in [4, 9] {
        assert_split_is_single(&whitted, "--chunk", n, &d);
    }
    assert_split_is_single(&whitted, "--tile", 7, &d);
    let single: Vec<&str> = [&["render", &bench][..], &size].concat();
    assert_split_is_single(&single, "--tile", 4, &d);
    let bunny = repo().join("scenes/bunny-on-plane.toml").display().to_string();
    let mesh: Vec<&str> = [&["render", &bunny, "--mode", "whitted", "--spp", "4"][..], &size].concat();
    assert_split_is_single(&mesh, "--chunk", 3, &d);
    assert_split_is_single(&mesh, "--tile", 3, &d);
}

#[test]
fn bad_tile_sets_are_refused_naming_the_files() {
    let d = scratch("tile-refusals");
    let scene = cornell();
    let base = ["render", scene.as_str(), "--mode", "path", "--filter", "none", "--spp", "2", "-q"];
    let base: Vec<&str> = [&base[..], &["--width", "16", "--height", "12"]].concat();
    for (split, n, prefix) in [("--tile", 3, "t"), ("--chunk", 2, "c")] {
        for i in 0..n {
            let (share, out) = (format!("{i}/{n}"), format!("{prefix}_{i}.exr"));
            ok(&[&base[..], &[split, &share, "-o", &out]].concat(), &d);
        }
    }
    assert_merge_refused(&d, &["t_0.exr", "t_2.exr"], "m.exr", &["chunk 1 of 3 missing"]);
    assert_merge_refused(&d, &["t_0.exr", "t_1.exr", "t_1.exr"], "m.exr", &["t_1.exr", "both chunk 1/3"]);
    // A tile among chunks of samples (of the same frame: the hash agrees).
    assert_merge_refused(&d, &["c_0.exr", "t_1.exr"], "m.exr", &["c_0.exr", "t_1.exr", "split into samples vs tiles"]);
    ok(&["merge", "-q", "t_2.exr", "t_0.exr", "t_1.exr", "-o", "m.png"], &d);
}

/// Writes the chunks of a small frame (`n` of them, `extra` options) as `prefix_I.exr`.
fn chunks(dir: &Path, n: u32, prefix: &str, extra: &[&str]) {
    let scene = cornell();
    for i in 0..n {
        let (chunk, part) = (format!("{i}/{n}"), format!("{prefix}_{i}.exr"));
        let mut a = vec!["render", scene.as_str(), "--mode", "path", "--filter", "none", "--spp", "4", "-q"];
        a.extend(["--width", "16", "--height", "12", "--chunk", &chunk, "-o", &part]);
        a.extend(extra);
        ok(&a, dir);
    }
}

/// `glint merge inputs -o out` must fail naming every needle, leave every input as it was and
/// write no output.
fn assert_merge_refused(dir: &Path, inputs: &[&str], out: &str, needles: &[&str]) {
    let before: Vec<Vec<u8>> = inputs.iter().map(|p| std::fs::read(dir.join(p)).unwrap_or_default()).collect();
    let existed = dir.join(out).exists();
    let mut a = vec!["merge"];
    a.extend(inputs);
    a.extend(["-o", out]);
    let o = glint(&a, dir);
    let msg = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{a:?} did not fail cleanly: {msg}");
    assert!(!msg.contains("panicked"), "{a:?}: {msg}");
    for n in needles {
        assert!(msg.contains(n), "{a:?}: the message does not name {n:?}: {msg}");
    }
    for (p, b) in inputs.iter().zip(before) {
        assert_eq!(std::fs::read(dir.join(p)).unwrap_or_default(), b, "{a:?} changed {p}");
    }
    assert_eq!(dir.join(out).exists(), existed, "{a:?} wrote {out}");
}

#[test]
fn bad_chunk_sets_are_refused_naming_the_files() {
    let d = scratch("chunk-refusals");
    chunks(&d, 3, "a", &[]);
    chunks(&d, 3, "seed", &["--seed", "5"]);
    chunks(&d, 2, "two", &[]);
    // A missing chunk, a duplicate, another frame (seed), another chunk count.
    assert_merge_refused(&d, &["a_0.exr", "a_2.exr"], "m.exr", &["chunk 1 of 3 missing"]);
    assert_merge_refused(&d, &["a_0.exr", "a_1.exr", "a_1.exr", "a_2.exr"], "m.exr", &["a_1.exr", "both chunk 1/3"]);
    assert_merge_refused(&d, &["a_0.exr", "a_1.exr", "seed_2.exr"], "m.exr", &["a_0.exr", "seed_2.exr", "hash"]);
    assert_merge_refused(&d, &["a_0.exr", "a_1.exr", "two_1.exr"], "m.exr", &["two_1.exr", "chunk count"]);
    // A truncated chunk, an EXR that is not a chunk, a file that is not an EXR, a missing file.
    let bytes = std::fs::read(d.join("a_1.exr")).unwrap();
    std::fs::write(d.join("cut_1.exr"), &bytes[..bytes.len() * 2 / 3]).unwrap();
    assert_merge_refused(&d, &["a_0.exr", "cut_1.exr", "a_2.exr"], "m.exr", &["cut_1.exr"]);
    let scene = cornell();
    ok(&["render", &scene, "--mode", "path", "--width", "16", "--height", "12", "-q", "-o", "plain.exr"], &d);
    assert_merge_refused(&d, &["a_0.exr", "plain.exr", "a_2.exr"], "m.exr", &["plain.exr", "not a glint chunk"]);
    std::fs::write(d.join("notes.exr"), b"these are notes, not an image").unwrap();
    assert_merge_refused(&d, &["notes.exr", "a_1.exr", "a_2.exr"], "m.exr", &["notes.exr", "not an OpenEXR"]);
    assert_merge_refused(&d, &["a_0.exr", "gone.exr", "a_2.exr"], "m.exr", &["gone.exr"]);
    // The output is never one of the inputs, and an existing output survives a refusal.
    assert_merge_refused(&d, &["a_0.exr", "a_1.exr", "a_2.exr"], "a_1.exr", &["a_1.exr", "one of the chunk files"]);
    std::fs::write(d.join("kept.png"), b"precious").unwrap();
    assert_merge_refused(&d, &["a_0.exr", "a_2.exr"], "kept.png", &["missing"]);
    assert_eq!(std::fs::read(d.join("kept.png")).unwrap(), b"precious");
    // The good set merges.
    ok(&["merge", "-q", "a_0.exr", "a_1.exr", "a_2.exr", "-o", "m.png"], &d);
}

#[test]
fn bad_chunk_options_are_refused() {
    let d = scratch("chunk-options");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    std::fs::write(d.join("part.exr"), b"precious").unwrap();
    let scene = cornell();
    let base = ["render", scene.as_str(), "--width", "16", "--height", "12", "-q"];
    let cases: [(&[&str], &str); 14] = [
        (&["--mode", "path", "--chunk", "4/4", "-o", "part.exr"], "chunk 4 of 4 does not exist"),
        (&["--mode", "path", "--chunk", "x", "-o", "part.exr"], "expected I/N"),
        (&["--mode", "path", "--chunk", "0/4", "-o", "out.png"], "give -o a .exr"),
        (&["--mode", "whitted", "--spp", "4", "--chunk", "0/5", "-o", "part.exr"], "at most one chunk per sample"),
        (&["--mode", "path", "--tile", "0/500", "-o", "part.exr"], "no grid of 500 tiles fits"),
        (&["--mode", "path", "--tile", "2/2", "-o", "part.exr"], "tile 2 of 2 does not exist"),
        (&["--mode", "whitted", "--tile", "0/2", "-o", "out.png"], "--tile writes a chunk file"),
        (&["--mode", "path", "--tile", "0/2", "--chunk", "0/2", "-o", "part.exr"], "give one"),
        (&["--mode", "path", "--passes", "4", "--time", "1", "--tile", "0/2", "-o", "part.exr"], "time budget"),
        (&["--mode", "path", "--tile", "auto/2", "-o", "part.exr"], "--tile auto/2: neither SLURM_ARRAY_TASK_ID"),
        (
            &["--mode", "path", "--filter", "none", "--spp", "3", "--chunk", "0/4", "-o", "part.exr"],
            "at most one chunk per unit",
        ),
        (&["--mode", "path", "--passes", "2", "--chunk", "0/3", "-o", "part.exr"], "3 chunks of a frame of 2 passes"),
        (&["--mode", "path", "--passes", "4", "--time", "1", "--chunk", "0/2", "-o", "part.exr"], "time budget"),
        (&["--mode", "path", "--passes", "4", "--chunk", "auto/2", "-o", "part.exr"], "SLURM_ARRAY_TASK_ID"),
    ];
    for (extra, needle) in cases {
        let a: Vec<&str> = base.iter().chain(extra).copied().collect();
        let o = Command::new(env!("CARGO_BIN_EXE_glint"))
            .args(&a)
            .current_dir(&d)
            .env_remove("SLURM_ARRAY_TASK_ID")
            .env_remove("JOB_COMPLETION_INDEX")
            .output()
            .unwrap();
        let msg = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{a:?}: {msg}");
        assert!(msg.contains(needle) && !msg.contains("panicked"), "{a:?}: {msg}");
        assert_eq!(std::fs::read(d.join("part.exr")).unwrap(), b"precious", "{a:?}");
        assert_eq!(std::fs::read(d.join("out.png")).unwrap(), b"precious", "{a:?}");
    }
}

/// `--chunk auto/N` takes the index from a Slurm array (task id less the array's first id) or
/// a Kubernetes Indexed Job: the same file as the explicit index.
#[test]
fn auto_chunks_take_the_index_from_the_scheduler() {
    let d = scratch("chunk-auto");
    let scene = cornell();
    let base = ["render", scene.as_str(), "--mode", "path", "--width", "16", "--height", "12", "--passes", "3", "-q"];
    let run = |extra: &[&str], env: &[(&str, &str)]| {
        let a: Vec<&str> = base.iter().chain(extra).copied().collect();
        let mut c = Command::new(env!("CARGO_BIN_EXE_glint"));
        c.args(&a).current_dir(&d).env_remove("SLURM_ARRAY_TASK_ID").env_remove("SLURM_ARRAY_TASK_MIN");
        c.env_remove("JOB_COMPLETION_INDEX");
        for (k, v) in env {
            c.env(k, v);
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "{a:?} {env:?}: {}", stderr(&o));
    };
    run(&["--chunk", "1/3", "-o", "explicit.exr"], &[]);
    run(&["--chunk", "auto/3", "-o", "slurm.exr"], &[("SLURM_ARRAY_TASK_ID", "8"), ("SLURM_ARRAY_TASK_MIN", "7")]);
    run(&["--chunk", "auto/3", "-o", "k8s.exr"], &[("JOB_COMPLETION_INDEX", "1")]);
    let explicit = std::fs::read(d.join("explicit.exr")).unwrap();
    for f in ["slurm.exr", "k8s.exr"] {
        assert!(std::fs::read(d.join(f)).unwrap() == explicit, "{f} is not chunk 1/3");
    }
}

/// The commands of docs/cluster.md as written, run by `sh` in a folder that holds the repo's
/// scenes: the shell block (four chunks, the merge, the single render: the same PNG), the
/// Slurm array script run once per task id, its merge step's `--wrap` command, and the
/// Kubernetes container's command once per completion index, whose merge (in the text) must
/// again give the single render. `sbatch` and `kubectl` themselves need a cluster.
#[test]
fn the_commands_of_the_cluster_docs_run() {
    let doc = std::fs::read_to_string(repo().join("docs/cluster.md")).unwrap();
    let blocks: Vec<&str> = doc.split("```").skip(1).step_by(2).collect();
    let block = |tag: &str| -> &str {
        blocks.iter().find(|b| b.starts_with(tag)).unwrap_or_else(|| panic!("no {tag} block")).trim_start_matches(tag)
    };
    let d = scratch("chunk-docs");
    std::os::unix::fs::symlink(repo().join("scenes"), d.join("scenes")).unwrap();
    std::fs::create_dir_all(d.join("parts")).unwrap();
    let bin = Path::new(env!("CARGO_BIN_EXE_glint")).parent().unwrap().display().to_string();
    let path = format!("{bin}:{}", std::env::var("PATH").unwrap_or_default());
    let sh = |script: &str, env: &[(&str, &str)]| {
        let mut c = Command::new("sh");
        c.arg("-ec").arg(script).current_dir(&d).env("PATH", &path);
        c.env_remove("SLURM_ARRAY_TASK_ID").env_remove("SLURM_ARRAY_TASK_MIN").env_remove("JOB_COMPLETION_INDEX");
        for (k, v) in env {
            c.env(k, v);
        }
        let o = c.output().unwrap();
        assert!(o.status.success(), "{script}: {}", stderr(&o));
    };
    let same = |a: &str, b: &str| {
        assert!(std::fs::read(d.join(a)).unwrap() == std::fs::read(d.join(b)).unwrap(), "{a} differs from {b}");
    };
    // The shell block.
    let commands = block("sh\nglint");
    sh(&format!("glint{commands}"), &[]);
    same("final.png", "single.png");
    // The Slurm script, as each array task runs it, and the merge it submits.
    std::fs::remove_dir_all(d.join("parts")).unwrap();
    std::fs::remove_file(d.join("final.png")).unwrap();
    let script = block("sh\n#!/bin/sh");
    for task in ["0", "1", "2", "3"] {
        sh(&format!("#!/bin/sh{script}"), &[("SLURM_ARRAY_TASK_ID", task), ("SLURM_ARRAY_TASK_MIN", "0")]);
    }
    let submit = block("text");
    let wrap = submit.split("--wrap \"").nth(1).and_then(|s| s.split('"').next()).expect("the merge's --wrap");
    sh(wrap, &[]);
    same("final.png", "single.png");
    // The Kubernetes container's command, per completion index, and the merge in the text.
    std::fs::remove_dir_all(d.join("parts")).unwrap();
    std::fs::remove_file(d.join("final.png")).unwrap();
    let yaml = block("yaml");
    let command = yaml.split("\"-c\", \"").nth(1).and_then(|s| s.split('"').next()).expect("the container's command");
    for index in ["0", "1", "2", "3"] {
        sh(command, &[("JOB_COMPLETION_INDEX", index)]);
    }
    let merge = doc.split("When the Job has completed").nth(1).and_then(|s| s.split('`').nth(3)).expect("the merge");
    assert!(merge.starts_with("glint merge"), "{merge}");
    sh(merge, &[]);
    same("final.png", "single.png");
    // The tiles block: three path tiles merged are the whole render; two Whitted tiles merge.
    std::fs::create_dir_all(d.join("tiles")).unwrap();
    let tiles =
        blocks.iter().find(|b| b.starts_with("sh\nglint render scenes/cornell-box.toml --mode path --passes 2"));
    sh(tiles.expect("the tiles block").trim_start_matches("sh\n"), &[]);
    same("tiled.png", "whole.png");
    assert!(d.join("whitted.png").exists());
    // The animation block: frames 0, 12, 24, 36 (the second line skips them all), and frame 1
    // in two chunks, merged.
    std::fs::create_dir_all(d.join("frames")).unwrap();
    let frames =
        blocks.iter().find(|b| b.starts_with("sh\nglint render scenes/animated.toml")).expect("the frames block");
    sh(frames.trim_start_matches("sh\n"), &[]);
    let mut names: Vec<String> = std::fs::read_dir(d.join("frames"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "f_0000.png",
            "f_0012.png",
            "f_0024.png",
            "f_0036.png",
            "p_0000_0.exr",
            "p_0000_1.exr",
            "p_0001.png",
            "p_0001_0.exr",
            "p_0001_1.exr"
        ]
    );
}

/// docs/cluster.md, "A real Slurm on one machine": `scripts/slurm-local.sh` starts munged,
/// slurmctld and slurmd (installing slurm-wlm and munge if missing; it needs root), renders the
/// four chunks as a real 4-task job array, merges them and compares with the single render.
/// Opt-in, as it installs packages and starts daemons: `GLINT_SLURM_TEST=1`. The section's
/// commands are checked to be this test and the script either way.
#[test]
fn a_real_single_node_slurm_renders_the_chunks() {
    let doc = std::fs::read_to_string(repo().join("docs/cluster.md")).unwrap();
    let section = doc.split("## A real Slurm on one machine").nth(1).expect("the section on a real Slurm");
    let block = section.split("```sh\n").nth(1).and_then(|s| s.split("```").next()).expect("its commands");
    assert_eq!(
        block.lines().collect::<Vec<_>>(),
        ["GLINT_SLURM_TEST=1 cargo test -p glint-cli --test chunk_cli slurm", "scripts/slurm-local.sh"]
    );
    if std::env::var("GLINT_SLURM_TEST").as_deref() != Ok("1") {
        eprintln!("skipped: set GLINT_SLURM_TEST=1 to start a real Slurm (needs root; installs slurm-wlm, munge)");
        return;
    }
    let o = Command::new(repo().join("scripts/slurm-local.sh"))
        .current_dir(repo())
        .env("GLINT", env!("CARGO_BIN_EXE_glint"))
        .output()
        .expect("scripts/slurm-local.sh runs");
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "scripts/slurm-local.sh failed:\n{out}\n{}", stderr(&o));
    assert!(out.contains("identical"), "no \"identical\" in:\n{out}");
    println!("{out}");
}
