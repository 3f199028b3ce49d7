//! glint-view: the interactive viewer (issue 6). Everything here but the window itself runs
//! headless: the camera controller (fly and orbit, speeds from the scene's size) turns input
//! into a `glint_scene::Camera`, which the renderers draw like any other. The window (winit +
//! softbuffer) and the frame loop come next; see ARCHITECTURE.md.
#![forbid(unsafe_code)]

pub mod camera;

pub use camera::{CameraController, ControlMode, InputState};
