//! Errors found when a scene is validated. Each names the object and what is wrong with it.

use thiserror::Error;

#[derive(Debug, Error, PartialEq)]
pub enum SceneError {
    #[error("{what}: {message}")]
    InvalidValue { what: String, message: String },
    #[error("{what}: refers to {kind} #{index}, but the scene has only {count}")]
    BadReference { what: String, kind: &'static str, index: usize, count: usize },
    #[error("the scene is empty: it has no object to render")]
    Empty,
    #[error("image size {width}x{height} is impossible (each side must be 1..={max}, at most 2^27 pixels in all)")]
    ImageSize { width: u32, height: u32, max: u32 },
}

impl SceneError {
    pub fn invalid(what: impl Into<String>, message: impl Into<String>) -> Self {
        Self::InvalidValue { what: what.into(), message: message.into() }
    }
}
