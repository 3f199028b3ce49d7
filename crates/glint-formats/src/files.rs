//! The one door through which every loader opens a file.
//!
//! A scene names other files (meshes, textures, skies, includes, glTF buffers and images), and
//! those may name more. Every such file, and the scene itself, is opened here, so that two
//! rules hold everywhere:
//!
//! - **Regular files only.** A device (`/dev/zero`, `/dev/random`), a FIFO, a socket or a
//!   folder is refused before a byte is read, with a message that says what it is: such a file
//!   has no size to check a header against and may never end.
//! - **The sandbox.** Under a [`FilePolicy::sandbox`] (the CLI's `--sandbox DIR`), every file
//!   must resolve, after symlinks, inside that folder. A reference that leaves it is an error
//!   naming the file that holds the reference, the field and the path ([`FormatError::Sandbox`]).
//!
//! The policy is set for the duration of one load with [`FilePolicy::apply`] and read by
//! [`check`], [`open`] and [`read`] on the same thread (loading is single-threaded), so that it
//! reaches the deepest loader (a texture named by an MTL file named by an OBJ file named by a
//! scene) without every signature on the way carrying it.
//!
//! Reading a whole file reserves its size fallibly first: a file larger than the memory left is
//! a [`FormatError::Limits`], not an abort.

use crate::error::FormatError;
use std::cell::RefCell;
use std::fs::File;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Which files a load may open.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct FilePolicy {
    /// Canonical folder every file must resolve into; `None`: any regular file.
    root: Option<PathBuf>,
}

thread_local! {
    static CURRENT: RefCell<FilePolicy> = RefCell::new(FilePolicy::default());
}

impl FilePolicy {
    /// Any regular file may be read (the default).
    pub fn open() -> FilePolicy {
        FilePolicy::default()
    }

    /// Only regular files that resolve inside `dir` (after symlinks) may be read.
    pub fn sandbox(dir: &Path) -> Result<FilePolicy, FormatError> {
        let root = std::fs::canonicalize(dir).map_err(|e| FormatError::io(dir, e))?;
        if !root.is_dir() {
            return Err(FormatError::limits(dir, "the sandbox must be a folder"));
        }
        Ok(FilePolicy { root: Some(root) })
    }

    /// The sandbox folder, canonical.
    pub fn root(&self) -> Option<&Path> {
        self.root.as_deref()
    }

    /// Runs `load` with this policy in force for every file it opens on this thread; the
    /// previous policy is restored afterwards (also if `load` panics).
    pub fn apply<R>(&self, load: impl FnOnce() -> R) -> R {
        struct Restore(Option<FilePolicy>);
        impl Drop for Restore {
            fn drop(&mut self) {
                if let Some(p) = self.0.take() {
                    CURRENT.with(|c| *c.borrow_mut() = p);
                }
            }
        }
        let previous = CURRENT.with(|c| c.replace(self.clone()));
        let _restore = Restore(Some(previous));
        load()
    }

    /// The policy in force on this thread.
    pub fn current() -> FilePolicy {
        CURRENT.with(|c| c.borrow().clone())
    }
}

/// Who names a file: the file holding the reference and the field in it, for messages.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Referrer<'a> {
    pub file: &'a Path,
    pub field: &'a str,
}

impl<'a> Referrer<'a> {
    pub(crate) fn new(file: &'a Path, field: &'a str) -> Self {
        Referrer { file, field }
    }
}

/// What kind of non-regular file `meta` describes.
fn kind_of(meta: &std::fs::Metadata) -> &'static str {
    let t = meta.file_type();
    if t.is_dir() {
        return "a folder";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

fn not_regular(path: &Path, meta: &std::fs::Metadata, by: Option<Referrer>) -> FormatError {
    FormatError::NotRegular {
        file: path.to_path_buf(),
        kind: kind_of(meta),
        referenced_from: by.map(|r| format!("{} ({})", r.file.display(), r.field)),
    }
}

/// Checks `path` against the rules (a regular file; inside the sandbox, if any) and returns
/// the path to open: the canonical one under a sandbox (so that what was checked is what is
/// opened), `path` itself otherwise. A missing file is [`FormatError::MissingFile`] when `by`
/// names a referrer, [`FormatError::Io`] otherwise.
pub(crate) fn check(path: &Path, by: Option<Referrer>) -> Result<PathBuf, FormatError> {
    let meta = std::fs::metadata(path).map_err(|e| match (e.kind(), by) {
        (std::io::ErrorKind::NotFound, Some(r)) => FormatError::MissingFile {
            file: path.to_path_buf(),
            referenced_from: format!("{} ({})", r.file.display(), r.field),
        },
        _ => FormatError::io(path, e),
    })?;
    if !meta.is_file() {
        return Err(not_regular(path, &meta, by));
    }
    Ok(inside_sandbox(path, by, "file")?.unwrap_or_else(|| path.to_path_buf()))
}

/// `path` resolved (symlinks and `..` followed) when a sandbox is set and it lies inside it;
/// None without a sandbox; an error naming the referrer (`what` when there is none) outside.
fn inside_sandbox(path: &Path, by: Option<Referrer>, what: &str) -> Result<Option<PathBuf>, FormatError> {
    let policy = FilePolicy::current();
    let Some(root) = policy.root() else { return Ok(None) };
    let resolved = std::fs::canonicalize(path).map_err(|e| FormatError::io(path, e))?;
    if !resolved.starts_with(root) {
        let (scene, field) = by.map_or((path, what), |r| (r.file, r.field));
        return Err(FormatError::Sandbox {
            scene: scene.to_path_buf(),
            field: field.to_string(),
            path: path.to_path_buf(),
            resolved,
            sandbox: root.to_path_buf(),
        });
    }
    Ok(Some(resolved))
}

/// Checks a folder named by `by` (a folder of sky faces): it must exist and lie in the sandbox.
pub(crate) fn check_folder(path: &Path, by: Option<Referrer>) -> Result<(), FormatError> {
    let meta = std::fs::metadata(path).map_err(|e| FormatError::io(path, e))?;
    if !meta.is_dir() {
        return Err(FormatError::io(path, std::io::Error::other("not a folder")));
    }
    inside_sandbox(path, by, "folder")?;
    Ok(())
}

/// Opens `path` after [`check`], and checks the opened file again (what was opened is a
/// regular file even if the name was swapped since). Returns the file and its length.
pub(crate) fn open(path: &Path, by: Option<Referrer>) -> Result<(File, u64), FormatError> {
    let target = check(path, by)?;
    let file = File::open(&target).map_err(|e| FormatError::io(path, e))?;
    let meta = file.metadata().map_err(|e| FormatError::io(path, e))?;
    if !meta.is_file() {
        return Err(not_regular(path, &meta, by));
    }
    Ok((file, meta.len()))
}

/// Reads all of `path` after [`open`], reserving its length fallibly first.
pub(crate) fn read(path: &Path, by: Option<Referrer>) -> Result<Vec<u8>, FormatError> {
    let (file, len) = open(path, by)?;
    read_all(path, file, len)
}

/// Bytes [`read_sniffed`] looks at before reading the rest.
pub(crate) const HEAD_BYTES: usize = 4096;

/// Reads `path` after [`open`], but first hands its first [`HEAD_BYTES`] to `sniff`, which
/// says whether they can start a file of the expected format (`Err(why)` if not): a file
/// of the wrong kind is refused after a few kilobytes, however large it is.
pub(crate) fn read_sniffed(
    path: &Path,
    by: Option<Referrer>,
    sniff: impl FnOnce(&[u8]) -> Result<(), String>,
) -> Result<Vec<u8>, FormatError> {
    let (mut file, len) = open(path, by)?;
    let mut head = Vec::with_capacity(HEAD_BYTES);
    (&mut file).take(HEAD_BYTES as u64).read_to_end(&mut head).map_err(|e| FormatError::io(path, e))?;
    sniff(&head).map_err(|why| FormatError::malformed(path, "start of file", why))?;
    let rest = len.saturating_sub(head.len() as u64);
    let mut bytes = head;
    bytes.try_reserve_exact(usize::try_from(rest).unwrap_or(usize::MAX)).map_err(|_| {
        FormatError::limits(path, format!("the file is {len} bytes, more than the memory glint can reserve to read it"))
    })?;
    file.take(rest).read_to_end(&mut bytes).map_err(|e| FormatError::io(path, e))?;
    Ok(bytes)
}

/// A sniff for text formats (OBJ, MTL, XYZ, TOML, XML): no NUL byte at the start.
pub(crate) fn text(kind: &'static str) -> impl FnOnce(&[u8]) -> Result<(), String> {
    move |head| match head.iter().position(|&b| b == 0) {
        Some(at) => Err(format!("not {kind}: binary data (a NUL byte at byte {at}) where text was expected")),
        None => Ok(()),
    }
}

/// [`read_sniffed`] with [`text`], as UTF-8 (the lines glint reports must be text).
pub(crate) fn read_text(path: &Path, by: Option<Referrer>, kind: &'static str) -> Result<String, FormatError> {
    let bytes = read_sniffed(path, by, text(kind))?;
    String::from_utf8(bytes).map_err(|e| {
        let at = e.utf8_error().valid_up_to();
        FormatError::malformed(path, format!("byte {at}"), format!("not {kind}: it is not UTF-8 text"))
    })
}

/// The rest of `file` (`len` bytes by its metadata), with a fallible reservation.
pub(crate) fn read_all(path: &Path, mut file: File, len: u64) -> Result<Vec<u8>, FormatError> {
    let mut bytes = Vec::new();
    let too_big = || {
        FormatError::limits(path, format!("the file is {len} bytes, more than the memory glint can reserve to read it"))
    };
    let want = usize::try_from(len).map_err(|_| too_big())?;
    bytes.try_reserve_exact(want).map_err(|_| too_big())?;
    // `take` bounds a file that grows while it is read.
    (&mut file).take(len).read_to_end(&mut bytes).map_err(|e| FormatError::io(path, e))?;
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::TempDir;

    #[test]
    fn devices_and_folders_are_refused_by_name() {
        let dir = TempDir::new("files-kinds");
        let err = read(dir.path(), None).expect_err("folder");
        assert!(err.to_string().contains("is a folder, not a regular file"), "{err}");
        #[cfg(unix)]
        {
            let err = read(Path::new("/dev/zero"), None).expect_err("device");
            assert!(err.to_string().starts_with("/dev/zero: is a character device"), "{err}");
            let link = dir.join("zero.obj");
            std::os::unix::fs::symlink("/dev/zero", &link).expect("symlink");
            let err = read(&link, Some(Referrer::new(Path::new("s.toml"), "objects[0].file"))).expect_err("link");
            let text = err.to_string();
            assert!(text.contains("is a character device") && text.contains("s.toml (objects[0].file)"), "{text}");
        }
    }

    #[test]
    fn the_sandbox_admits_inside_and_refuses_outside_after_symlinks() {
        let dir = TempDir::new("files-sandbox");
        let inside = dir.join("box");
        std::fs::create_dir(&inside).expect("mkdir");
        std::fs::write(inside.join("a.obj"), b"v 0 0 0").expect("write");
        std::fs::write(dir.join("secret.txt"), b"secret").expect("write");
        let policy = FilePolicy::sandbox(&inside).expect("sandbox");
        let by = Referrer::new(Path::new("scene.toml"), "objects[1].file");
        policy.apply(|| {
            assert_eq!(read(&inside.join("a.obj"), Some(by)).expect("inside"), b"v 0 0 0");
            let err = read(&inside.join("../secret.txt"), Some(by)).expect_err("dot-dot");
            let text = err.to_string();
            assert!(text.starts_with("scene.toml: objects[1].file"), "{text}");
            assert!(text.contains("secret.txt") && text.contains("outside the sandbox"), "{text}");
            #[cfg(unix)]
            {
                std::os::unix::fs::symlink(dir.join("secret.txt"), inside.join("link.obj")).expect("symlink");
                let err = read(&inside.join("link.obj"), Some(by)).expect_err("symlink out");
                assert!(err.to_string().contains("outside the sandbox"), "{err}");
            }
        });
        // Outside `apply`, the default policy is back.
        assert_eq!(read(&dir.join("secret.txt"), None).expect("open policy"), b"secret");
    }

    #[test]
    fn a_missing_referenced_file_names_its_referrer() {
        let err = read(Path::new("/no/such/mesh.ply"), Some(Referrer::new(Path::new("a.toml"), "objects[0].file")))
            .expect_err("missing");
        assert!(err.to_string().contains("a.toml (objects[0].file)"), "{err}");
    }
}
