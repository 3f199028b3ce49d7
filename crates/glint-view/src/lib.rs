//! glint-view: the interactive viewer (issue 6). Data flows input → camera → frame → display →
//! window:
//! - `camera`: fly and orbit control (speeds from the scene's size) producing a
//!   `glint_scene::Camera`, which the renderers draw like any other;
//! - `frame`: what a frame is drawn with (mode, every mode's settings, filter); the frame itself
//!   is drawn by `glint_render::Renderer`, the same entry point `glint render` calls, afresh or
//!   refining the picture on screen;
//! - `display`: the beauty or an AOV as 0RGB pixels, scaled up from a reduced resolution;
//! - `overlay`: statistics and key help drawn as bitmap text;
//! - `viewer`: the frame loop without a window — input and key actions in, the window's frame
//!   out (the headless benchmark and the tests drive it);
//! - `window`: winit + softbuffer around the viewer (the only part that needs a display).
#![forbid(unsafe_code)]

pub mod camera;
pub mod display;
pub mod error;
pub mod frame;
pub mod overlay;
pub mod viewer;
pub mod window;

pub use camera::{CameraController, ControlMode, InputState};
pub use display::{Display, display, to_pixels};
pub use error::ViewError;
pub use frame::ViewSettings;
pub use viewer::{Action, FrameOutcome, Viewer, ViewerOptions};
