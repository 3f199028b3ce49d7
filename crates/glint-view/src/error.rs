//! The viewer's errors, by who is at fault.

use glint_render::RenderError;
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error(transparent)]
    Render(#[from] RenderError),
    /// A setting the viewer cannot use (window size, a mode the scene has nothing for).
    #[error("{0}")]
    Setting(String),
    #[error("cannot write {0}: {1}")]
    Write(PathBuf, String),
    /// No window could be opened (no display, no X server or Wayland compositor).
    #[error("cannot open a window: {0}")]
    Window(String),
}
