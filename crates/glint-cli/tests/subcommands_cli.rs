//! What a newcomer runs first: the binary with no argument (the README's `cargo run --release`),
//! and for every subcommand `--help` plus one minimal valid invocation, so that a default which
//! fails its own validation is caught for each of them (issue 13: `glint` alone once failed
//! because it built its options by hand instead of from clap's defaults).

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{Xvfb, glint, glint_on, scratch, shared, stderr};
use std::collections::BTreeSet;
use std::path::Path;
use std::time::Duration;

/// The demo scene's size (crates/glint-formats' embedded demo.toml).
const DEMO_SIZE: (u32, u32) = (1280, 720);

/// `glint` with no argument in a fresh, empty folder writes glint.png there: the demo scene at
/// its own size, exactly what `glint render` with no scene writes.
#[test]
fn no_argument_renders_the_demo_to_glint_png() {
    let d = scratch("no-argument");
    let o = glint(&[], &d);
    assert!(o.status.success(), "glint with no argument failed: {}", stderr(&o));
    let img = glint_image::read_image(&d.join("glint.png")).expect("glint.png written and readable");
    assert_eq!((img.width, img.height), DEMO_SIZE);
    let explicit = scratch("no-argument-render");
    let o = glint(&["render"], &explicit);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(
        std::fs::read(d.join("glint.png")).unwrap(),
        std::fs::read(explicit.join("glint.png")).unwrap(),
        "`glint` and `glint render` must write the same file"
    );
}

/// The subcommands a `--help` text lists under "Commands:" (clap's own `help` left out).
fn listed_subcommands(help: &str) -> BTreeSet<String> {
    help.lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next())
        .filter(|name| *name != "help")
        .map(str::to_owned)
        .collect()
}

fn help_of(path: &[&str], dir: &Path) -> String {
    let mut args = path.to_vec();
    args.push("--help");
    let o = glint(&args, dir);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("Usage: glint"), "{args:?} printed no usage: {text}");
    text
}

/// Every leaf subcommand, found by walking `--help` from the top (so a new subcommand cannot be
/// forgotten by the table below).
fn every_subcommand(dir: &Path) -> BTreeSet<String> {
    let mut leaves = BTreeSet::new();
    let mut todo = vec![Vec::<String>::new()];
    while let Some(path) = todo.pop() {
        let refs: Vec<&str> = path.iter().map(String::as_str).collect();
        let children = listed_subcommands(&help_of(&refs, dir));
        if children.is_empty() {
            leaves.insert(path.join(" "));
        }
        for child in children {
            let mut next = path.clone();
            next.push(child);
            todo.push(next);
        }
    }
    leaves
}

/// A tiny mesh every command that wants a model can read.
const TETRAHEDRON: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

/// One minimal valid invocation per subcommand: only the arguments it requires, plus smaller
/// sizes, repetitions and frame counts so the suite stays quick (those defaults are plain
/// numbers; every other option keeps its default, which is what this test is about). `None`
/// where the invocation needs ../shared/data and it is absent.
fn minimal_invocation(name: &str, data: Option<&str>) -> Option<Vec<String>> {
    let v = |args: &[&str]| Some(args.iter().map(|s| (*s).to_owned()).collect::<Vec<_>>());
    match name {
        "render" => v(&["render", "--width", "64", "--height", "36", "-o", "render.png"]),
        "view" => v(&["view", "--width", "64", "--height", "36", "--frames", "2"]),
        "points sample" => v(&["points", "sample", "tetra.obj", "--count", "100", "-o", "sample.ply"]),
        "bench rays" => v(&["bench", "rays", "--scene", "tetra.obj", "--width", "32", "--height", "24", "--reps", "1"]),
        "bench whitted" => v(&["bench", "whitted", "--width", "64", "--height", "36", "--frames", "1"]),
        "bench filters" => v(&["bench", "filters", "--data", data?, "--width", "48", "--height", "32", "--reps", "1"]),
        "bench gi" => v(&common::bench_gi_tiny(data?)),
        "bench points" => v(&["bench", "points", "--data", data?, "--clouds", "bunny", "--sizes", "64", "--reps", "1"]),
        "bench path" => {
            v(&["bench", "path", "tetra.obj", "--spp", "1", "--width", "16", "--height", "16", "--frames", "1"])
        }
        "bench view" => v(&["bench", "view", "--width", "64", "--height", "36", "--frames", "2"]),
        "sky convert" => v(&["sky", "convert", "sky.png", "faces", "--to", "faces"]),
        "compare" => v(&["compare", "render.png", "render.png"]),
        "filter" => v(&["filter", "path.exr", "-o", "filtered.exr"]),
        "merge" => v(&["merge", "part_0.exr", "-o", "merged.png"]),
        other => panic!("subcommand `{other}` has no minimal invocation here: add one"),
    }
}

#[test]
fn every_subcommand_has_help_and_runs_with_its_defaults() {
    let d = scratch("subcommands");
    std::fs::write(d.join("tetra.obj"), TETRAHEDRON).unwrap();
    // Inputs for the commands that read images: a small lat-long sky and a path-mode EXR.
    let sky: Vec<[f32; 3]> = (0..32 * 16).map(|i| [0.2 + (i % 32) as f32 / 64.0, 0.4, 0.8]).collect();
    glint_image::write_image(
        &d.join("sky.png"),
        &glint_image::Image::from_rgb(32, 16, &sky),
        &glint_image::PngOptions::default(),
    )
    .unwrap();
    let o = glint(&["render", "--mode", "path", "--width", "32", "--height", "24", "-q", "-o", "path.exr"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    // And a frame in one chunk for `merge`.
    let chunk =
        ["render", "--mode", "path", "--width", "32", "--height", "24", "-q", "--chunk", "0/1", "-o", "part_0.exr"];
    let o = glint(&chunk, &d);
    assert!(o.status.success(), "{}", stderr(&o));

    let data = shared("data/scenes/cornell_box/cornell_box_open.obj").map(|_| {
        let p = common::repo().join("../shared/data");
        p.to_str().expect("utf-8 path").to_owned()
    });
    let display = Xvfb::start();
    let subcommands = every_subcommand(&d);
    assert!(subcommands.len() >= 12, "found only {subcommands:?}");
    // `render` first: `compare` reads what it writes.
    let mut order: Vec<&String> = subcommands.iter().collect();
    order.sort_by_key(|name| *name != "render");
    for name in order {
        let Some(args) = minimal_invocation(name, data.as_deref()) else {
            eprintln!("skipped `{name}`: ../shared/data is not there");
            continue;
        };
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let o = glint_on(&display.display, &args, &d, Duration::from_secs(300));
        let err = stderr(&o);
        assert!(o.status.success(), "`glint {}` failed: {err}", args.join(" "));
        assert!(!err.contains("panicked"), "`glint {}` panicked: {err}", args.join(" "));
    }
    for written in ["render.png", "sample.ply", "faces/px.png", "filtered.exr", "merged.png"] {
        assert!(d.join(written).is_file(), "{written} was not written");
    }
}
