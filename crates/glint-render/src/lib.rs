//! glint-render: scene + acceleration structure → pixels.
//!
//! [`World`] turns a validated `Scene` into traceable geometry (a BVH per mesh, a top-level BVH
//! over object instances, planes beside it) and answers "what does this ray hit" with everything
//! shading needs. The driver ([`render`]) runs an integrator over the image in parallel and fills
//! a [`Film`] (beauty + AOVs). The modes live in their own folders: `whitted/`, `path/`, `points/`.
#![forbid(unsafe_code)]

pub mod driver;
pub mod error;
pub mod film;
pub mod path;
pub mod points;
pub mod settings;
pub mod whitted;
pub mod world;

pub use driver::{RenderStats, render, render_pass, render_with_progress};
pub use error::RenderError;
pub use film::{Film, FilmPixel};
pub use path::{PathSettings, PathStats, render_path};
pub use points::{Fill, PointFrame, PointRenderer, PointSettings, PointShading, PointStats, render_points};
pub use settings::{RenderSettings, Schedule};
pub use world::{SurfaceHit, World};
