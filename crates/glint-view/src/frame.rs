//! What the viewer draws with (pipeline: keys → **settings** → `glint_render::Renderer`): the
//! mode shown, every mode's settings (so switching modes keeps each one's), the path mode's
//! filter kind (its parameters follow the render width, as `glint render` sets them) and the
//! window's size. The frame itself is drawn by the library's [`glint_render::Renderer`], the
//! same entry point `glint render` calls; this module only says which [`Mode`] to draw.

use glint_filter::{Filter, FilterKind};
use glint_render::{FrameStats, ImageSettings, Mode, ModeSettings};
use glint_scene::{RenderDefaults, RenderMode};

/// What a frame is drawn with (the render size is the window's over the resolution divisor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewSettings {
    pub width: u32,
    pub height: u32,
    pub mode: RenderMode,
    /// Every mode's settings; the path mode's filter is replaced by `filter` at the render
    /// width.
    pub modes: ModeSettings,
    pub filter: FilterKind,
    pub seed: u64,
}

impl ViewSettings {
    /// The viewer's defaults: the scene file's settings (`defaults`), one indirect bounce, the
    /// guided filter.
    #[must_use]
    pub fn new(width: u32, height: u32, mode: RenderMode, defaults: &RenderDefaults) -> Self {
        let mut modes = ModeSettings::from_defaults(defaults);
        modes.path.max_bounces = 1;
        Self { width, height, mode, modes, filter: FilterKind::Guided, seed: 0 }
    }

    /// The image and mode of a frame drawn at `width × height`.
    #[must_use]
    pub fn frame(&self, width: u32, height: u32) -> (ImageSettings, Mode) {
        let mut modes = self.modes;
        modes.whitted.samples_per_side = 1;
        modes.path.filter = Filter::for_width(self.filter, width as usize);
        modes.path.time_budget = None;
        (ImageSettings { seed: self.seed, ..ImageSettings::new(width, height) }, modes.mode(self.mode))
    }
}

/// The next filter of the F key's cycle.
#[must_use]
pub fn next_filter(f: FilterKind) -> FilterKind {
    match f {
        FilterKind::Guided => FilterKind::Atrous,
        FilterKind::Atrous => FilterKind::Bilateral,
        FilterKind::Bilateral => FilterKind::None,
        FilterKind::None => FilterKind::Guided,
    }
}

/// The filter's name on screen.
#[must_use]
pub fn filter_name(f: FilterKind) -> &'static str {
    match f {
        FilterKind::Guided => "guided 4-D",
        FilterKind::Atrous => "A-Trous",
        FilterKind::Bilateral => "bilateral",
        FilterKind::None => "off",
    }
}

/// A frame's throughput as the statistics show it: millions of points per second for a frame
/// that drew points, else of rays.
#[must_use]
pub fn rate(stats: &FrameStats) -> (f64, &'static str) {
    if stats.points > 0 { (stats.mpoints_per_second(), "Mpoints/s") } else { (stats.mrays_per_second(), "Mrays/s") }
}

/// A stage's time in milliseconds.
#[must_use]
pub fn ms(d: std::time::Duration) -> f64 {
    d.as_secs_f64() * 1e3
}
