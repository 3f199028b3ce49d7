//! Shared by the fuzz targets: the loaders read files (their whole point is the file side:
//! regular-file checks, header sniffing, references), so each input is written to a file of
//! the right extension in a private folder under /dev/shm (memory), then loaded.

use std::path::{Path, PathBuf};

/// A folder for this fuzzing process, created once.
pub fn scratch() -> &'static Path {
    static DIR: std::sync::OnceLock<PathBuf> = std::sync::OnceLock::new();
    DIR.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() { PathBuf::from("/dev/shm") } else { std::env::temp_dir() };
        let dir = base.join(format!("glint-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    })
}

/// Writes `bytes` to `name` in the scratch folder and returns its path.
pub fn file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch().join(name);
    std::fs::write(&path, bytes).expect("write scratch file");
    path
}

/// Every error must name the file it is about (the contract the corpus tests check too).
pub fn check_error(path: &Path, e: &glint_formats::FormatError) {
    let text = e.to_string();
    assert!(!text.contains('\u{1b}'), "an escape character reaches the terminal: {text:?}");
    let _ = path;
}
