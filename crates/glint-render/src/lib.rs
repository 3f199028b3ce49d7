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

/// Tests only: the path mode's lanes kernels (`path/wavefront/phong8.rs`,
/// `world/hits8.rs`) run on the SSE baseline even where the CPU has AVX2, for the test that
/// demands the same bits from both (a CPU without AVX2 runs the baseline).
#[cfg(test)]
pub(crate) static LANES_BASELINE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether the path mode's lanes kernels are held to the SSE baseline (tests only).
#[inline]
pub(crate) fn lanes_baseline() -> bool {
    #[cfg(test)]
    return LANES_BASELINE.load(std::sync::atomic::Ordering::Relaxed);
    #[cfg(not(test))]
    false
}

pub use bands::{Hooks, Schedule};
pub use error::RenderError;
pub use film::{Film, FilmPixel, FilmRows, MAX_SAMPLE_RADIANCE, PathAovs, PixelRecord, SurfacePixel};
pub use frame::{Mode, ModeSettings, Part, Picture, Renderer, WhittedPart};
pub use settings::{ImageSettings, Region, WhittedKernel, WhittedSettings, Window};
pub use stats::{BandStats, FrameStats, RayCounts};
pub use world::{EmissiveTriangle, NO_PRIM, SurfaceHit, Surfaces8, World, WorldStats};
