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
    #[error("{}:{line}:{column}: {message}", file.display())]
    Syntax { file: PathBuf, line: usize, column: usize, message: String },

    /// The scene file is well-formed, but a value at this place is wrong: an unknown name, a
    /// key that does not apply to the object's type, two keys that exclude each other, a number
    /// out of range.
    #[error("{}:{line}:{column}: {message}", file.display())]
    Value { file: PathBuf, line: usize, column: usize, message: String },

    /// The operating system could not read the file. The I/O error is part of the message and
    /// deliberately not a `source()`, so error chains (`{:#}`) do not print it twice.
    #[error("{}: cannot read: {error}", file.display())]
    Io { file: PathBuf, error: std::io::Error },

    /// A file named by another file (a mesh or texture in a scene, a buffer in a glTF) is not
    /// there.
    #[error("{}: file not found (referenced from {referenced_from})", file.display())]
    MissingFile { file: PathBuf, referenced_from: String },

    /// The content of a model file (OBJ, MTL, PLY, glTF) is broken at `place`.
    #[error("{}: {place}: {message}", file.display())]
    Malformed { file: PathBuf, place: String, message: String },

    /// The file asks for absurd amounts (more elements than its bytes could hold, more than
    /// glint can index): rejected before anything is allocated.
    #[error("{}: {message}", file.display())]
    Limits { file: PathBuf, message: String },

    /// The file was read completely, but the scene it describes failed validation.
    #[error("{}: invalid scene: {source}", file.display())]
    Invalid {
        file: PathBuf,
        #[source]
        source: SceneError,
    },

    /// Sky images that do not make a cube map or a lat-long map: a missing, duplicated,
    /// non-square or unequal face, an image whose aspect is no known layout, a face transform
    /// on a lat-long map. `file` is the image, or the folder of faces.
    #[error("{}: {message}", file.display())]
    Sky { file: PathBuf, message: String },

    /// An output file (a converted sky) could not be written; nothing was left under its name.
    #[error("{}: cannot write: {message}", file.display())]
    Write { file: PathBuf, message: String },

    /// The file's extension is not one glint reads.
    #[error("{}: unsupported file type '{extension}' (glint reads .toml and Mitsuba .xml scenes and .obj, .ply, .gltf, .glb models)", file.display())]
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
            | Self::UnsupportedFormat { file, .. } => file,
        }
    }
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
        ];
        for e in errs {
            let text = e.to_string();
            assert!(text.starts_with(&e.file().display().to_string()), "{text}");
        }
    }
}
