//! Render errors: settings that cannot be rendered.

use thiserror::Error;

#[derive(Debug, Error, PartialEq)]
pub enum RenderError {
    #[error("invalid render setting: {0}")]
    InvalidSetting(String),
}
