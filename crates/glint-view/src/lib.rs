//! glint-view: the interactive viewer (issue 6). Everything here but the window itself runs
//! headless: the camera controller (fly and orbit, speeds from the scene's size) turns input
//! into a `glint_scene::Camera`, which the renderers draw like any other. `frame` draws one frame of
//! any mode into a 0RGB pixel buffer with its timings (the loop the window and the headless
//! benchmark share). The window (winit + softbuffer) comes next; see ARCHITECTURE.md.
#![forbid(unsafe_code)]

pub mod camera;
pub mod frame;

pub use camera::{CameraController, ControlMode, InputState};
pub use frame::{FrameRenderer, FrameStats, ViewMode, ViewSettings};
