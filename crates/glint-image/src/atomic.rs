//! Atomic file replacement: every file glint-image writes goes through [`atomic_write`], so a
//! crash, a full disk or a bad path never leaves a half-written image under the target name.

use std::fs::{self, File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use crate::error::ImageError;

/// Writes `bytes` to `path` atomically: a uniquely named temporary file is created in the
/// *same* directory (so the rename cannot cross file systems), written, fsynced and renamed
/// over `path`; the directory is then fsynced (best effort, Unix only).
///
/// On any error the existing file at `path` (if any) is untouched, the temporary file is
/// removed and the error names `path`. The new file gets default permissions; those of a file
/// it replaces are not carried over.
pub fn atomic_write(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    write_via_temp(path, bytes, |_| Ok(()))
}

/// [`atomic_write`] with a hook run after the temp file is complete and before the rename, so
/// tests can inject a failure at the worst moment.
fn write_via_temp(
    path: &Path,
    bytes: &[u8],
    before_rename: impl FnOnce(&Path) -> io::Result<()>,
) -> Result<(), ImageError> {
    let fail = |source| ImageError::io(path, source);
    let file_name =
        path.file_name().ok_or_else(|| fail(io::Error::new(io::ErrorKind::InvalidInput, "not a file path")))?;
    let dir = match path.parent() {
        Some(parent) if !parent.as_os_str().is_empty() => parent,
        _ => Path::new("."),
    };
    if path.is_dir() {
        return Err(fail(io::Error::new(io::ErrorKind::IsADirectory, "is a directory")));
    }
    let (temp_path, mut file) = create_temp(dir, file_name).map_err(fail)?;
    let result = file
        .write_all(bytes)
        .and_then(|()| file.sync_all())
        .and_then(|()| {
            drop(file);
            before_rename(&temp_path)
        })
        .and_then(|()| fs::rename(&temp_path, path));
    if let Err(source) = result {
        let _ = fs::remove_file(&temp_path);
        return Err(fail(source));
    }
    sync_dir(dir);
    Ok(())
}

/// Creates `dir/.{name}.{pid}-{n}.tmp` exclusively, trying the next `n` if it exists.
fn create_temp(dir: &Path, file_name: &std::ffi::OsStr) -> io::Result<(PathBuf, File)> {
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let pid = std::process::id();
    for _ in 0..1000 {
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        let mut name = std::ffi::OsString::from(".");
        name.push(file_name);
        name.push(format!(".{pid}-{n}.tmp"));
        let temp_path = dir.join(name);
        match OpenOptions::new().write(true).create_new(true).open(&temp_path) {
            Ok(file) => return Ok((temp_path, file)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(e),
        }
    }
    Err(io::Error::new(io::ErrorKind::AlreadyExists, "could not find a free temporary file name"))
}

/// Makes the rename durable. Failure only weakens durability, never correctness, so it is
/// ignored; directories cannot be opened for syncing on Windows.
fn sync_dir(dir: &Path) {
    #[cfg(unix)]
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    #[cfg(not(unix))]
    let _ = dir;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_dir::TestDir;

    fn entries(dir: &Path) -> Vec<String> {
        let mut names: Vec<String> = fs::read_dir(dir)
            .expect("list dir")
            .map(|e| e.expect("entry").file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        names
    }

    #[test]
    fn writes_and_replaces() {
        let dir = TestDir::new("atomic-replace");
        let path = dir.join("out.bin");
        atomic_write(&path, b"first").expect("write");
        atomic_write(&path, b"second").expect("replace");
        assert_eq!(fs::read(&path).expect("read"), b"second");
        assert_eq!(entries(dir.path()), ["out.bin"]);
    }

    #[test]
    fn failure_before_rename_keeps_old_file_and_removes_temp() {
        let dir = TestDir::new("atomic-fail");
        let path = dir.join("out.bin");
        fs::write(&path, b"old").expect("seed");
        let mut seen_temp = None;
        let err = write_via_temp(&path, b"new contents", |temp| {
            assert_eq!(fs::read(temp).expect("temp complete"), b"new contents");
            assert_eq!(temp.parent(), Some(dir.path()), "temp must be in the same directory");
            seen_temp = Some(temp.to_path_buf());
            Err(io::Error::other("injected failure"))
        })
        .expect_err("must fail");
        assert!(err.to_string().starts_with(&path.display().to_string()), "{err}");
        assert_eq!(fs::read(&path).expect("read"), b"old");
        assert!(!seen_temp.expect("hook ran").exists());
        assert_eq!(entries(dir.path()), ["out.bin"]);
    }

    #[test]
    fn path_that_is_a_directory_is_left_alone() {
        let dir = TestDir::new("atomic-dir");
        let target = dir.join("taken");
        fs::create_dir(&target).expect("mkdir");
        fs::write(target.join("inner"), b"keep").expect("seed");
        let err = atomic_write(&target, b"x").expect_err("must fail");
        assert!(matches!(err, ImageError::Io { .. }), "{err}");
        assert!(err.to_string().contains("taken"), "{err}");
        assert!(target.is_dir());
        assert_eq!(fs::read(target.join("inner")).expect("read"), b"keep");
        assert_eq!(entries(dir.path()), ["taken"]);
    }

    #[test]
    fn missing_parent_directory_is_an_error_naming_the_path() {
        let dir = TestDir::new("atomic-noparent");
        let path = dir.join("no/such/dir/out.png");
        let err = atomic_write(&path, b"x").expect_err("must fail");
        assert!(err.to_string().contains("no/such/dir/out.png"), "{err}");
        assert!(entries(dir.path()).is_empty());
    }

    #[cfg(unix)]
    #[test]
    fn read_only_directory_keeps_old_file() {
        use std::os::unix::fs::PermissionsExt;
        let dir = TestDir::new("atomic-readonly");
        let sub = dir.join("ro");
        fs::create_dir(&sub).expect("mkdir");
        let path = sub.join("out.png");
        fs::write(&path, b"old").expect("seed");
        fs::set_permissions(&sub, fs::Permissions::from_mode(0o555)).expect("chmod");
        // Root (and some CI sandboxes) ignore directory permissions; then this case cannot be
        // provoked and `failure_before_rename_keeps_old_file_and_removes_temp` covers it.
        let probe = sub.join("probe");
        let enforced = fs::write(&probe, b"").is_err();
        let _ = fs::remove_file(&probe);
        if enforced {
            let err = atomic_write(&path, b"new").expect_err("must fail");
            assert!(err.to_string().contains("out.png"), "{err}");
            assert_eq!(fs::read(&path).expect("read"), b"old");
            assert_eq!(entries(&sub), ["out.png"]);
        } else {
            eprintln!("note: directory permissions not enforced (running as root?); skipped");
        }
        fs::set_permissions(&sub, fs::Permissions::from_mode(0o755)).expect("chmod back");
    }
}
