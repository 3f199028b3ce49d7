//! Helpers shared by the end-to-end tests of the `glint` binary.

#![allow(dead_code)] // each test file uses its own subset

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Runs `glint args` in `dir`.
pub fn glint(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_glint")).args(args).current_dir(dir).output().expect("the binary runs")
}

#[allow(unused_imports)] // each test file uses its own subset
pub use glint_testkit::{repo, shared};

/// A fresh, empty scratch folder under the target directory.
pub fn scratch(name: &str) -> PathBuf {
    glint_testkit::scratch(&format!("cli-{name}"))
}

/// `glint bench gi` on tiny settings: the Cornell box at 32×24, one rep, a 4-spp reference in
/// `gi/` (the real run is BENCHMARKS.md §6).
pub fn bench_gi_tiny(data: &str) -> Vec<&str> {
    let sizes = ["--width", "32", "--height", "24", "--quality-width", "32", "--quality-height", "24"];
    let mut args = vec!["bench", "gi", "--data", data, "--scenes", "cornell-box", "--reps", "1"];
    args.extend(sizes);
    args.extend(["--ref-spp", "4", "--out", "gi"]);
    args
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Runs `args` in `dir` and asserts a clean failure: non-zero exit, a message containing
/// `needle`, no panic, and `dir/out.png` still holding `b"precious"` (callers write it first).
pub fn assert_fails_cleanly(args: &[&str], needle: &str, dir: &Path) {
    assert_fails_keeping(args, needle, dir, "out.png");
}

/// [`assert_fails_cleanly`] with another output file: `dir/kept` must still hold `b"precious"`.
pub fn assert_fails_keeping(args: &[&str], needle: &str, dir: &Path, kept: &str) {
    let o = glint(args, dir);
    let msg = stderr(&o);
    assert!(!o.status.success(), "{args:?} succeeded");
    assert!(msg.contains(needle), "{args:?}: message does not name {needle:?}: {msg}");
    assert!(!msg.contains("panicked"), "{args:?} panicked: {msg}");
    assert_eq!(std::fs::read(dir.join(kept)).expect("kept file"), b"precious", "{args:?} touched {kept}");
}

/// An Xvfb server on a free display number, killed when dropped.
pub struct Xvfb {
    child: Child,
    pub display: String,
}

impl Xvfb {
    pub fn start() -> Xvfb {
        // -displayfd: Xvfb picks a free display and writes its number once it accepts clients.
        let mut child = Command::new("Xvfb")
            .args(["-displayfd", "1", "-screen", "0", "1024x768x24", "-nolisten", "tcp"])
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb runs (the window test needs it: .ci/install-deps installs the xvfb package)");
        let mut line = String::new();
        BufReader::new(child.stdout.take().unwrap()).read_line(&mut line).expect("Xvfb reports its display");
        let n: u32 = line.trim().parse().unwrap_or_else(|_| panic!("Xvfb display number {line:?}"));
        Xvfb { child, display: format!(":{n}") }
    }
}

impl Xvfb {
    /// `xdotool args` on this server (.ci/install-deps installs xdotool); its output, trimmed.
    pub fn xdotool(&self, args: &[&str]) -> String {
        let o = Command::new("xdotool")
            .args(args)
            .env("DISPLAY", &self.display)
            .output()
            .expect("xdotool runs (.ci/install-deps installs it)");
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    }
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Run glint with DISPLAY set, giving up (and failing) after `limit`.
pub fn glint_on(display: &str, args: &[&str], dir: &std::path::Path, limit: Duration) -> std::process::Output {
    let mut child = Command::new(env!("CARGO_BIN_EXE_glint"))
        .args(args)
        .current_dir(dir)
        .env("DISPLAY", display)
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("glint {args:?} did not finish within {limit:?}");
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    child.wait_with_output().unwrap()
}
