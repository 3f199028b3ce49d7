//! Everything that can go wrong turning files into a scene, sorted by who is at fault.
//!
//! Every message starts with the file it is about, then the place in it (line:column for text,
//! "vertex 40" / "byte 1234" / "header" for model files), then what is wrong, so that a user
//! can go straight to the spot. Warnings (things glint recovered from) are plain strings in
//! [`crate::Loaded::warnings`], never errors.

use glint_scene::SceneError;
use std::path::PathBuf;
use thiserror::Error;

#[derive(Debug, Error)]
pub enum FormatError {
    /// The text is not valid TOML, a value has the wrong type, or a key is unknown or missing.
    #[error("{}:{line}:{column}: {}", shown(file), printable(message))]
    Syntax { file: PathBuf, line: usize, column: usize, message: String },

    /// The scene file is well-formed, but a value at this place is wrong: an unknown name, a
    /// key that does not apply to the object's type, two keys that exclude each other, a number
    /// out of range.
    #[error("{}:{line}:{column}: {}", shown(file), printable(message))]
    Value { file: PathBuf, line: usize, column: usize, message: String },

    /// The operating system could not read the file. The I/O error is part of the message and
    /// deliberately not a `source()`, so error chains (`{:#}`) do not print it twice.
    #[error("{}: cannot read: {error}", shown(file))]
    Io { file: PathBuf, error: std::io::Error },

    /// A file named by another file (a mesh or texture in a scene, a buffer in a glTF) is not
    /// there.
    #[error("{}: file not found (referenced from {})", shown(file), printable(referenced_from))]
    MissingFile { file: PathBuf, referenced_from: String },

    /// The content of a model file (OBJ, MTL, PLY, glTF) is broken at `place`.
    #[error("{}: {}: {}", shown(file), printable(place), printable(message))]
    Malformed { file: PathBuf, place: String, message: String },

    /// The file asks for absurd amounts (more elements than its bytes could hold, more than
    /// glint can index): rejected before anything is allocated.
    #[error("{}: {}", shown(file), printable(message))]
    Limits { file: PathBuf, message: String },

    /// The file was read completely, but the scene it describes failed validation.
    #[error("{}: invalid scene: {}", shown(file), printable(&source.to_string()))]
    Invalid {
        file: PathBuf,
        #[source]
        source: SceneError,
    },

    /// Sky images that do not make a cube map or a lat-long map: a missing, duplicated,
    /// non-square or unequal face, an image whose aspect is no known layout, a face transform
    /// on a lat-long map. `file` is the image, or the folder of faces.
    #[error("{}: {}", shown(file), printable(message))]
    Sky { file: PathBuf, message: String },

    /// An output file (a converted sky) could not be written; nothing was left under its name.
    #[error("{}: cannot write: {}", shown(file), printable(message))]
    Write { file: PathBuf, message: String },

    /// A device, FIFO, socket or folder where a file is expected: refused before reading (it
    /// may never end, and has no size to check a header against).
    #[error(
        "{}: is {kind}, not a regular file; glint reads scenes, models and images only from regular files{}",
        shown(file),
        referenced_from.as_deref().map_or_else(String::new, |r| format!(" (referenced from {})", printable(r)))
    )]
    NotRegular { file: PathBuf, kind: &'static str, referenced_from: Option<String> },

    /// Under `--sandbox DIR`, a file named by `scene` (in `field`) resolves outside DIR.
    #[error(
        "{}: {} {} resolves to {}, outside the sandbox {}",
        shown(scene),
        printable(field),
        shown(path),
        shown(resolved),
        shown(sandbox)
    )]
    Sandbox { scene: PathBuf, field: String, path: PathBuf, resolved: PathBuf, sandbox: PathBuf },

    /// The file's extension is not one glint reads.
    #[error(
        "{}: unsupported file type '{}' (glint reads .toml and Mitsuba .xml scenes and .obj, .ply, .gltf, .glb models)",
        shown(file),
        printable(extension)
    )]
    UnsupportedFormat { file: PathBuf, extension: String },
}

impl FormatError {
    pub(crate) fn malformed(file: impl Into<PathBuf>, place: impl Into<String>, message: impl Into<String>) -> Self {
        Self::Malformed { file: file.into(), place: place.into(), message: message.into() }
    }

    pub(crate) fn limits(file: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::Limits { file: file.into(), message: message.into() }
    }

    pub(crate) fn sky(file: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::Sky { file: file.into(), message: message.into() }
    }

    pub(crate) fn write(file: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::Write { file: file.into(), message: message.into() }
    }

    pub(crate) fn io(file: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io { file: file.into(), error: source }
    }

    /// The file the error is about.
    pub fn file(&self) -> &std::path::Path {
        match self {
            Self::Syntax { file, .. }
            | Self::Value { file, .. }
            | Self::Io { file, .. }
            | Self::MissingFile { file, .. }
            | Self::Malformed { file, .. }
            | Self::Limits { file, .. }
            | Self::Invalid { file, .. }
            | Self::Sky { file, .. }
            | Self::Write { file, .. }
            | Self::NotRegular { file, .. }
            | Self::Sandbox { scene: file, .. }
            | Self::UnsupportedFormat { file, .. } => file,
        }
    }
}

/// `text` safe to print on a terminal: control characters (escape sequences, carriage returns,
/// backspaces, NUL) and the Unicode controls that reorder or hide text (bidirectional overrides,
/// zero-width joiners) are written as visible escapes (`\u{1b}`), the rest is kept. Every
/// string that comes from a file passes through this before it is printed: names and lines
/// in errors and warnings. Already printable text is returned unchanged, so applying it twice
/// is harmless.
pub fn printable(text: &str) -> String {
    if !text.chars().any(needs_escape) {
        return text.to_string();
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if needs_escape(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out
}

fn needs_escape(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200b}'..='\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2060}'..='\u{2069}' | '\u{feff}')
}

/// A path as [`printable`] text.
pub fn shown(path: &std::path::Path) -> String {
    printable(&path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_message_starts_with_the_file() {
        let errs = [
            FormatError::Syntax { file: "a.toml".into(), line: 3, column: 1, message: "x".into() },
            FormatError::malformed("a.ply", "vertex 4", "truncated"),
            FormatError::limits("a.ply", "too many"),
            FormatError::MissingFile { file: "m.obj".into(), referenced_from: "a.toml:4".into() },
            FormatError::Invalid { file: "a.toml".into(), source: SceneError::Empty },
            FormatError::sky("skies/miramar", "missing cube face ny"),
            FormatError::write("out/px.png", "disk full"),
            FormatError::NotRegular { file: "/dev/zero".into(), kind: "a character device", referenced_from: None },
            FormatError::Sandbox {
                scene: "s.toml".into(),
                field: "objects[0].file".into(),
                path: "../x.obj".into(),
                resolved: "/x.obj".into(),
                sandbox: "/box".into(),
            },
        ];
        for e in errs {
            let text = e.to_string();
            assert!(text.starts_with(&e.file().display().to_string()), "{text}");
        }
    }

    #[test]
    fn printable_shows_terminal_controls_as_escapes() {
        assert_eq!(printable("plain name: ok"), "plain name: ok");
        assert_eq!(printable("red\u{1b}[31mtext\r\u{7}"), "red\\u{1b}[31mtext\\r\\u{7}");
        assert_eq!(printable("a\u{202e}b"), "a\\u{202e}b");
        let once = printable("\u{1b}]0;title\u{7}");
        assert_eq!(printable(&once), once);
        // The escape reaches no message: names, places and paths alike.
        let e = FormatError::malformed("evil\u{1b}[2J.obj", "line 1\u{1b}[1m", "`\u{1b}[31m` unknown");
        assert!(!e.to_string().contains('\u{1b}'), "{e}");
    }
}
