//! Errors of glint-image, by fault domain: the file system (`Io`), a file's contents (`Decode`,
//! `UnsupportedFormat`, `Limits`), the encoder (`Encode`) and the caller's data (`Mismatch`).
//! Every variant that concerns a file starts its message with the file's path.

use std::path::PathBuf;

use thiserror::Error;

/// Anything that can go wrong reading, writing or comparing images.
#[derive(Debug, Error)]
pub enum ImageError {
    /// The file system refused: missing file, no permission, disk full, path is a directory...
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    /// The file exists but its contents are not a valid image of its format.
    #[error("{}: cannot decode image: {message}", path.display())]
    Decode { path: PathBuf, message: String },
    /// The image could not be encoded (e.g. an EXR channel name that is not Latin-1).
    #[error("{}: cannot encode image: {message}", path.display())]
    Encode { path: PathBuf, message: String },
    /// The extension (or, when reading, the contents) names no format glint reads or writes.
    #[error(
        "{}: unsupported image format (glint reads .png, .jpg/.jpeg, .tga, .bmp, .hdr, .exr and writes .png, .jpg, .hdr, .exr)",
        path.display()
    )]
    UnsupportedFormat { path: PathBuf },
    /// The caller's data does not fit together: channel length, duplicate names, image sizes.
    #[error("{message}")]
    Mismatch { message: String },
    /// The file claims a size beyond what glint will allocate; rejected before allocating.
    #[error("{}: image too large: {message}", path.display())]
    Limits { path: PathBuf, message: String },
}

impl ImageError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io { path: path.into(), source }
    }

    pub(crate) fn decode(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::Decode { path: path.into(), message: message.into() }
    }

    pub(crate) fn encode(path: impl Into<PathBuf>, message: impl Into<String>) -> Self {
        Self::Encode { path: path.into(), message: message.into() }
    }

    pub(crate) fn mismatch(message: impl Into<String>) -> Self {
        Self::Mismatch { message: message.into() }
    }
}

/// A tone-map name that is not one of `clamp`, `reinhard`, `aces`.
#[derive(Debug, Error, Clone, PartialEq, Eq)]
#[error("unknown tone map '{0}' (expected clamp, reinhard or aces)")]
pub struct UnknownToneMap(pub String);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_start_with_the_path() {
        let e = ImageError::decode("a/b.png", "bad");
        assert!(e.to_string().starts_with("a/b.png: "), "{e}");
        let e = ImageError::UnsupportedFormat { path: "x.tga".into() };
        assert!(e.to_string().starts_with("x.tga: "), "{e}");
    }
}
