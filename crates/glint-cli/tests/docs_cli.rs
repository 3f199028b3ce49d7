//! The commands README.md and docs/ show, run as written: every line of their `sh` blocks, in
//! order, by `sh` in a folder laid out as the repository is (`scenes/` there, the shared data at
//! `../shared`), so a later line may read what an earlier one wrote. A line that is not a
//! `glint` command or a shell variable is refused here, so a new kind of line gets a runner
//! before it ships. `glint view` lines open their window on Xvfb and are closed with Esc once
//! it shows. The set-up block's `cargo` and `.ci/` lines are what CI itself runs.
//!
//! Other docs run in the tests of their subject: docs/cluster.md in chunk_cli.rs,
//! docs/limits.md in limits_cli.rs, docs/scene-format.md's Mitsuba block in import_cli.rs.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{Xvfb, repo, scratch, shared, stderr};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// The lines of `doc`'s `sh` blocks, in order.
fn sh_lines(doc: &str) -> Vec<String> {
    let text = std::fs::read_to_string(repo().join(doc)).unwrap();
    text.split("```")
        .skip(1)
        .step_by(2)
        .filter_map(|b| b.strip_prefix("sh\n"))
        .flat_map(str::lines)
        .map(str::to_owned)
        .collect()
}

/// A folder shaped like the repository's root: `work/scenes` → the repo's scenes, `shared` →
/// the shared data beside it. Returns `work`, or None when the shared data is missing.
fn workspace(name: &str) -> Option<PathBuf> {
    let shared = shared("data")?.parent().unwrap().to_path_buf();
    let root = scratch(name);
    std::os::unix::fs::symlink(shared, root.join("shared")).unwrap();
    let work = root.join("work");
    std::fs::create_dir_all(&work).unwrap();
    std::os::unix::fs::symlink(repo().join("scenes"), work.join("scenes")).unwrap();
    Some(work)
}

/// `sh -ec script` in `dir` with the test's `glint` first on PATH (DISPLAY set when given).
fn shell(script: &str, dir: &Path, display: Option<&str>) -> Command {
    let bin = Path::new(env!("CARGO_BIN_EXE_glint")).parent().unwrap().display().to_string();
    let mut c = Command::new("sh");
    c.arg("-ec").arg(script).current_dir(dir);
    c.env("PATH", format!("{bin}:{}", std::env::var("PATH").unwrap_or_default()));
    c.env_remove("WAYLAND_DISPLAY").env_remove("DISPLAY");
    if let Some(d) = display {
        c.env("DISPLAY", d);
    }
    c
}

/// Runs a `glint view` line on the X server: waits for its window, presses Esc, and requires a
/// clean exit.
fn view_and_quit(script: &str, dir: &Path, x: &Xvfb) {
    let mut child = shell(script, dir, Some(&x.display)).stdout(Stdio::null()).stderr(Stdio::piped()).spawn().unwrap();
    let xdotool = |args: &[&str]| x.xdotool(args);
    let start = Instant::now();
    let mut window = String::new();
    while window.is_empty() {
        if let Some(status) = child.try_wait().unwrap() {
            panic!(
                "{script}: ended ({status}) before its window showed: {}",
                stderr(&child.wait_with_output().unwrap())
            );
        }
        assert!(start.elapsed() < Duration::from_secs(120), "{script}: no window within 2 minutes");
        std::thread::sleep(Duration::from_millis(100));
        window = xdotool(&["search", "--name", "^glint"]).lines().next().unwrap_or("").to_string();
    }
    // Esc until it quits: a key pressed before the window is mapped and focused is lost.
    let shown = Instant::now();
    let mut pressed = None::<Instant>;
    while child.try_wait().unwrap().is_none() {
        if shown.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("{script}: Esc did not close the viewer");
        }
        if pressed.is_none_or(|t| t.elapsed() > Duration::from_secs(2)) {
            xdotool(&["windowfocus", &window]);
            xdotool(&["key", "--window", &window, "Escape"]);
            pressed = Some(Instant::now());
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{script}: {}", stderr(&o));
    assert!(!stderr(&o).contains("panicked"), "{script}: {}", stderr(&o));
}

/// Runs every line of `doc`'s `sh` blocks as written; returns how many `glint` lines ran.
fn run_doc(doc: &str) -> usize {
    let Some(work) = workspace(&format!("docs-{}", doc.replace('/', "-"))) else { return 0 };
    let mut x = None;
    let mut variables = String::new();
    let mut ran = 0;
    for line in sh_lines(doc) {
        let command = line.split(" #").next().unwrap().trim();
        if command.is_empty() || line.starts_with("cargo ") || line.starts_with(".ci/") {
            continue;
        }
        let is_variable =
            command.split_once('=').is_some_and(|(k, _)| !k.is_empty() && k.chars().all(|c| c.is_ascii_uppercase()));
        if is_variable {
            variables.push_str(command);
            variables.push('\n');
            continue;
        }
        assert!(command.starts_with("glint"), "{doc}: no runner for the line {line:?}");
        let script = format!("{variables}{line}");
        if command.starts_with("glint view") {
            view_and_quit(&script, &work, x.get_or_insert_with(Xvfb::start));
        } else {
            let o = shell(&script, &work, None).output().unwrap();
            assert!(o.status.success(), "{doc}: {line}\n{}", stderr(&o));
            if let Some(out) = command.split_whitespace().skip_while(|a| *a != "-o").nth(1) {
                assert!(work.join(out).exists(), "{doc}: {line} wrote no {out}");
            }
        }
        ran += 1;
    }
    ran
}

#[test]
fn the_commands_of_the_readme_run() {
    let ran = run_doc("README.md");
    assert!(ran == 0 || ran == 24, "{ran} commands: a new README line needs this count raised");
}

#[test]
fn the_commands_of_the_compare_docs_run() {
    let ran = run_doc("docs/compare.md");
    assert!(ran == 0 || ran == 8, "{ran}");
}

#[test]
fn the_commands_of_the_sky_docs_run() {
    let ran = run_doc("docs/skies.md");
    assert!(ran == 0 || ran == 4, "{ran}");
}

#[test]
fn the_commands_of_the_viewer_docs_run() {
    let ran = run_doc("docs/viewer.md");
    assert!(ran == 0 || ran == 5, "{ran}");
}
