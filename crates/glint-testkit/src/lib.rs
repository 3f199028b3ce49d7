//! glint-testkit: what glint's tests share, written once (a dev-dependency of the other
//! crates; never linked into the binary).
//!
//! - [`scratch`]: a fresh, empty folder under the target directory;
//! - [`shared`]: a file of the shared data folder (`../shared/data` beside the repository), or
//!   `None` with a note when it is not there;
//! - [`images`]: comparisons on 8-bit sRGB (PSNR, pixels off) and golden images;
//! - [`scenes`]: small scenes with a known content (a cloud beside a sphere);
//! - [`skies`]: synthetic sky images (smooth lat-long maps, cube faces with a known pattern).
//!
//! It depends on glint-core, glint-image and glint-scene only, so the crates below
//! glint-scene do not use it from their own unit tests (that would link two copies of them).
#![forbid(unsafe_code)]
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::missing_panics_doc)] // test support: a failure is the report

pub mod images;
pub mod scenes;
pub mod skies;

use std::path::PathBuf;

/// The repository root.
#[must_use]
pub fn repo() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."))
}

/// The target directory (`CARGO_TARGET_DIR` when set, else the repository's `target/`).
#[must_use]
pub fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR").map_or_else(|| repo().join("target"), PathBuf::from)
}

/// A fresh, empty folder `target/tmp/<name>` (removed first if it exists).
#[must_use]
pub fn scratch(name: &str) -> PathBuf {
    let d = target_dir().join("tmp").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).expect("create scratch folder");
    d
}

/// `../shared/<rel>` beside the repository, or None (with a note) when it is not there.
#[must_use]
pub fn shared(rel: &str) -> Option<PathBuf> {
    let p = repo().join("../shared").join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipped: {} is not there", p.display());
        None
    }
}
