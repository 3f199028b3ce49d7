//! Errors of glint-filter. Every one is the caller's fault (the filters have no I/O): planes of
//! the wrong size, values that are not finite, parameters outside their domain, AOV images that
//! lack a channel. Messages name the plane (`input[1] (G)`, `normal.y`, `Indirect.R`, ...) and,
//! for bad values, the first bad pixel in row-major order.

use thiserror::Error;

/// Anything that makes a filter refuse its input.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum FilterError {
    /// Width or height is zero.
    #[error("cannot filter an empty {width}x{height} image")]
    Empty { width: usize, height: usize },
    /// A plane does not hold `width * height` values.
    #[error("{plane} has {len} values, but a {width}x{height} image needs {expected}")]
    SizeMismatch { plane: String, len: usize, width: usize, height: usize, expected: usize },
    /// A plane holds NaN or ±infinity; `x`, `y` is the first such pixel (row-major).
    #[error("{plane} is not finite at pixel ({x}, {y}): {value}")]
    NotFinite { plane: String, x: usize, y: usize, value: f32 },
    /// A parameter is outside its domain (radius 0, a sigma or epsilon that is not > 0, ...).
    #[error("invalid {filter} parameter: {message}")]
    InvalidParameter { filter: &'static str, message: String },
    /// An AOV image lacks channels the filter needs.
    #[error("the image lacks channel(s) {} needed to filter it (it has: {})", missing.join(", "), present.join(", "))]
    MissingChannels { missing: Vec<String>, present: Vec<String> },
    /// The AOV image itself is inconsistent (a channel of the wrong length, a zero size, ...).
    #[error("invalid AOV image: {message}")]
    InvalidImage { message: String },
}

impl FilterError {
    pub(crate) fn parameter(filter: &'static str, message: impl Into<String>) -> Self {
        Self::InvalidParameter { filter, message: message.into() }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn messages_name_plane_and_pixel() {
        let e = FilterError::NotFinite { plane: "normal.y".into(), x: 3, y: 7, value: f32::NAN };
        assert_eq!(e.to_string(), "normal.y is not finite at pixel (3, 7): NaN");
        let e = FilterError::MissingChannels {
            missing: vec!["Indirect.R".into(), "Z".into()],
            present: vec!["R".into(), "G".into()],
        };
        assert!(e.to_string().contains("Indirect.R, Z"), "{e}");
    }
}
