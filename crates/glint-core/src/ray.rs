//! Rays with an explicit parametric interval `[tmin, tmax]`.

use glam::Vec3;

/// A ray `origin + t * dir` valid for `t` in `[tmin, tmax]`.
///
/// `dir` need not be normalised: instance transforms keep `t` meaningful by transforming the
/// direction without renormalising it.
///
/// `#[repr(C)]`: eight `f32` in this order (origin, direction, tmin, tmax), so that SIMD
/// kernels can load 8 rays and transpose them into lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    /// A ray over `[0, +inf)`.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self { origin, dir, tmin: 0.0, tmax: f32::INFINITY }
    }

    /// A ray over `[tmin, tmax]`.
    pub fn segment(origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Self {
        Self { origin, dir, tmin, tmax }
    }

    /// The point at parameter `t`.
    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// True when origin, direction and interval are all finite numbers (tmax may be +inf).
    pub fn is_valid(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.dir != Vec3::ZERO
            && self.tmin.is_finite()
            && !self.tmax.is_nan()
            && self.tmin <= self.tmax
    }
}
