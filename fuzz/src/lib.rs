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

/// Every error starts with the file it is about (here `path`, or a file it names) and holds
/// no raw control character: the contract `tests/corpus` checks on stable.
pub fn check_error(path: &Path, e: &glint_formats::FormatError) {
    let text = e.to_string();
    assert!(!text.chars().any(char::is_control), "a control character reaches the terminal: {text:?}");
    let file = glint_formats::error::shown(e.file());
    assert!(!file.is_empty() && text.starts_with(&file), "{}: the error does not start with its file: {text}", path.display());
}
