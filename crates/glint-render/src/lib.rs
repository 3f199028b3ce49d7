//! glint-render: scene + acceleration structure → pixels.
//!
//! The pipeline, by module: [`World`] (`world/`) turns a validated `Scene` into traceable
//! geometry and answers what a ray hits; the integrators (`whitted/`, `path/`, `points/`) make
//! a mode's samples; the band driver (`bands.rs`) runs them over the image in parallel; the
//! [`Film`] holds the beauty and the AOVs. [`Renderer`] (`frame.rs`) is the one entry point
//! every front end calls: a scene, a camera, [`ImageSettings`] and a [`Mode`] in; a film and
//! [`FrameStats`] out. Mode-specific names live in their module (`path::PathSettings`,
//! `points::PointSettings`, ...); each public name has one path.
#![forbid(unsafe_code)]
#![warn(clippy::must_use_candidate, clippy::missing_errors_doc, clippy::missing_panics_doc)]

mod bands;
pub mod chunk;
mod error;
mod film;
mod first_touch;
pub mod fixed;
mod frame;
mod lights8;
pub mod path;
pub mod points;
mod settings;
mod stats;
pub mod whitted;
mod world;

pub use bands::{Hooks, Schedule};
pub use error::RenderError;
pub use film::{Film, FilmPixel, FilmRows, MAX_SAMPLE_RADIANCE, PathAovs, PixelRecord, SurfacePixel};
pub use frame::{Mode, ModeSettings, Part, Picture, Renderer, WhittedPart};
pub use settings::{ImageSettings, Region, WhittedKernel, WhittedSettings, Window};
pub use stats::{BandStats, FrameStats, RayCounts};
pub use world::{EmissiveTriangle, NO_PRIM, SurfaceHit, Surfaces8, World, WorldStats};
