//! glint-core: the vocabulary every other crate speaks.
//!
//! Math (glam re-exported), rays, bounding boxes, floating-point error bounds, colour,
//! orthonormal frames, sampling warps and hash-derived random streams, and the memory budget large allocations are checked against. It sits at the bottom
//! of the crate graph: no I/O, no threads, no unsafe, no dependency on any other glint crate.
#![forbid(unsafe_code)]

pub mod bounds;
pub mod chi2;
pub mod colour;
pub mod float;
pub mod frame;
pub mod memory;
pub mod pixel_filter;
pub mod random;
pub mod ray;
pub mod sampling;

pub use bounds::Bounds3;
pub use colour::Rgb;
pub use frame::Frame;
pub use glam;
pub use glam::{Affine3A, Mat3, Mat4, Quat, UVec2, Vec2, Vec3, Vec3A, Vec4};
pub use pixel_filter::{PixelFilter, PixelSampler, Reconstruction};
pub use ray::Ray;
