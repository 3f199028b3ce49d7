//! Render settings: the scene file's defaults, overridden by the command line.

use crate::RenderError;
use glint_scene::RenderDefaults;
use glint_scene::scene::{MAX_IMAGE_SIDE, image_size_ok};

/// How image bands are handed to threads (the thesis compares OpenMP-style static splits with
/// TBB-style work stealing; rayon is the latter).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Schedule {
    /// rayon work stealing over bands of rows.
    #[default]
    WorkStealing,
    /// One contiguous block of bands per thread, fixed up front.
    Static,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// N for N×N stratified supersampling; 1 = a single ray through each pixel centre.
    pub samples_per_side: u32,
    pub max_depth: u32,
    pub min_contribution: f32,
    /// The only source of randomness (sample jitter).
    pub seed: u64,
    pub schedule: Schedule,
}

/// Deepest recursion accepted (the integrator's stack is bounded by it).
pub const MAX_DEPTH_LIMIT: u32 = 64;

impl RenderSettings {
    pub fn from_defaults(d: &RenderDefaults) -> Self {
        Self {
            width: d.width,
            height: d.height,
            samples_per_side: d.samples_per_side,
            max_depth: d.max_depth,
            min_contribution: d.min_contribution,
            seed: 0,
            schedule: Schedule::WorkStealing,
        }
    }

    pub fn validate(&self) -> Result<(), RenderError> {
        if !image_size_ok(self.width, self.height) {
            return Err(RenderError::InvalidSetting(format!(
                "image size {}x{} (each side must be 1..={MAX_IMAGE_SIDE}, at most 2^27 pixels in all)",
                self.width, self.height
            )));
        }
        if self.samples_per_side == 0 || self.samples_per_side > 64 {
            return Err(RenderError::InvalidSetting(format!(
                "{} samples per side (must be 1..=64)",
                self.samples_per_side
            )));
        }
        if self.max_depth > MAX_DEPTH_LIMIT {
            return Err(RenderError::InvalidSetting(format!(
                "max depth {} (must be at most {MAX_DEPTH_LIMIT})",
                self.max_depth
            )));
        }
        if !(self.min_contribution.is_finite() && self.min_contribution >= 0.0) {
            return Err(RenderError::InvalidSetting("min contribution must be a finite number >= 0".into()));
        }
        Ok(())
    }
}
