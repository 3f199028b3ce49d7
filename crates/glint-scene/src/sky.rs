//! What a ray that leaves the scene sees. Looked up by direction only: moving the camera never
//! changes the sky. Cube maps and lat-long maps plug in here (their own issue).

use glint_core::{Rgb, Vec3};

#[derive(Clone, Debug, PartialEq)]
pub enum Sky {
    /// One colour in every direction (the thesis's background colour).
    Colour(Rgb),
    /// Blend from `horizon` (y = 0) to `zenith` (y = 1); `ground` below the horizon.
    Gradient { zenith: Rgb, horizon: Rgb, ground: Rgb },
}

impl Default for Sky {
    fn default() -> Self {
        Sky::Colour(Rgb::new(0.35, 0.55, 0.85))
    }
}

impl Sky {
    /// Radiance arriving from direction `dir` (any length), i.e. seen by a ray travelling
    /// along `dir`.
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Rgb {
        match self {
            Sky::Colour(c) => *c,
            Sky::Gradient { zenith, horizon, ground } => {
                let y = dir.normalize_or(Vec3::Y).y;
                if y >= 0.0 { horizon.lerp(*zenith, y.min(1.0)) } else { *ground }
            }
        }
    }
}
