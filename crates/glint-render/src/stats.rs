//! What a frame counted (pipeline: integrators → **stats** → the front ends' summaries): rays by
//! kind, dropped samples, time by stage. Every mode reports through [`FrameStats`]; the counts
//! are integers, so any reduction order gives the same totals.

use std::time::Duration;

/// Counts of rays traced, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RayCounts {
    pub primary: u64,
    pub secondary: u64,
    pub shadow: u64,
}

impl RayCounts {
    #[must_use]
    pub fn total(&self) -> u64 {
        self.primary + self.secondary + self.shadow
    }

    pub fn add(&mut self, o: &RayCounts) {
        self.primary += o.primary;
        self.secondary += o.secondary;
        self.shadow += o.shadow;
    }
}

/// What one band of rows counted; the band driver reduces these over the image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BandStats {
    pub rays: RayCounts,
    /// Samples whose radiance was NaN or infinite (dropped, counted as black).
    pub rejected: u64,
    /// Samples whose radiance exceeded the largest a sample may carry and was clamped to it
    /// (path mode's `MAX_SAMPLE_RADIANCE`).
    pub clamped: u64,
}

impl BandStats {
    #[must_use]
    pub fn merge(mut self, o: BandStats) -> BandStats {
        self.rays.add(&o.rays);
        self.rejected += o.rejected;
        self.clamped += o.clamped;
        self
    }
}

/// One frame of any mode: where its time went and what it did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    /// Wall time of the whole frame.
    pub elapsed: Duration,
    /// Once-per-size work before the frame, not part of `elapsed`: the points mode's buffers
    /// sized and first touched for an image size not drawn before (zero for later frames).
    pub setup: Duration,
    /// Named stages in order ("trace", "filter", "project", "pull-push", "shade", ...).
    pub stages: Vec<(&'static str, Duration)>,
    pub rays: RayCounts,
    /// Points drawn (points mode).
    pub points: u64,
    /// Camera samples traced to the end of their paths (path mode).
    pub paths: u64,
    /// Samples whose result was NaN or infinite: dropped, counted as black.
    pub rejected_samples: u64,
    /// Samples whose radiance was clamped to the largest a sample may carry.
    pub clamped_samples: u64,
    /// Passes in the picture (progressive frames; 1 for a whole frame of one pass).
    pub passes: u32,
    /// Samples per pixel in the picture.
    pub samples_per_pixel: u32,
    /// One line in the mode's own words (what `glint render` prints).
    pub summary: String,
}

impl FrameStats {
    /// The time of stage `name`, if the frame had it.
    #[must_use]
    pub fn stage(&self, name: &str) -> Option<Duration> {
        self.stages.iter().find(|(n, _)| *n == name).map(|(_, d)| *d)
    }

    /// Rays per second over the tracing stage (the whole frame when it has none), in millions.
    #[must_use]
    pub fn mrays_per_second(&self) -> f64 {
        let t = self.stage("trace").unwrap_or(self.elapsed);
        self.rays.total() as f64 / t.as_secs_f64().max(1e-9) / 1e6
    }

    /// Paths per second over the whole frame (filter included), in millions.
    #[must_use]
    pub fn mpaths_per_second(&self) -> f64 {
        self.paths as f64 / self.elapsed.as_secs_f64().max(1e-9) / 1e6
    }

    /// Points per second over the frame without its traced part (the meshes a points frame
    /// lays over its clouds), in millions.
    #[must_use]
    pub fn mpoints_per_second(&self) -> f64 {
        let t = self.elapsed.saturating_sub(self.stage("trace").unwrap_or_default());
        self.points as f64 / t.as_secs_f64().max(1e-9) / 1e6
    }
}
