//! Render errors: settings that cannot be rendered.

use thiserror::Error;

#[derive(Debug, Error, PartialEq)]
pub enum RenderError {
    #[error("invalid render setting: {0}")]
    InvalidSetting(String),
    /// The image-space filter refused its input (a bug upstream: the renderer's buffers are
    /// finite and of one size).
    #[error("filter: {0}")]
    Filter(String),
    /// The caller cancelled the frame (its [`crate::Hooks::cancel`] flag).
    #[error("the render was cancelled")]
    Cancelled,
    /// A buffer the frame needs is larger than the memory budget or the allocator refused it.
    #[error(transparent)]
    Memory(#[from] glint_core::memory::MemoryError),
}
