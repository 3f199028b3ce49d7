//! Helpers of glint-render's tests: frames of a [`World`] seen by its scene's camera, with
//! flat settings for struct-update syntax. What every crate's tests share (scratch folders,
//! golden images, fixtures) is in glint-testkit.

#![allow(dead_code)] // each test file uses its own subset

use glint_render::path::{PathAccumulator, PathSettings, render_path};
use glint_render::whitted::{self, Samples};
use glint_render::{
    Film, FrameStats, Hooks, ImageSettings, RenderError, Schedule, WhittedKernel, WhittedSettings, World,
};

/// The image and Whitted settings of a test frame, flat for struct-update syntax.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub width: u32,
    pub height: u32,
    pub samples_per_side: u32,
    pub max_depth: u32,
    pub min_contribution: f32,
    pub seed: u64,
    pub schedule: Schedule,
    pub kernel: WhittedKernel,
}

impl Settings {
    pub fn image(&self) -> ImageSettings {
        ImageSettings { width: self.width, height: self.height, seed: self.seed, schedule: self.schedule, window: None }
    }

    pub fn whitted(&self) -> WhittedSettings {
        WhittedSettings {
            samples_per_side: self.samples_per_side,
            max_depth: self.max_depth,
            min_contribution: self.min_contribution,
            kernel: self.kernel,
        }
    }

    /// The settings a scene file gives.
    pub fn from_defaults(d: &glint_scene::RenderDefaults) -> Self {
        Settings {
            width: d.width,
            height: d.height,
            samples_per_side: d.samples_per_side,
            max_depth: d.max_depth,
            min_contribution: d.min_contribution,
            ..settings(1, 1)
        }
    }
}

/// One ray per pixel, depth 8, seed 0, work stealing.
pub fn settings(w: u32, h: u32) -> Settings {
    Settings {
        width: w,
        height: h,
        samples_per_side: 1,
        max_depth: 8,
        min_contribution: 1e-3,
        seed: 0,
        schedule: Schedule::WorkStealing,
        kernel: WhittedKernel::Batched,
    }
}

/// A whole Whitted frame of the world seen by its scene's camera.
pub fn render(world: &World, s: &Settings) -> Result<(Film, FrameStats), RenderError> {
    render_samples(world, s, Samples::Stratified)
}

/// Progressive Whitted pass `k` of the world seen by its scene's camera.
pub fn render_pass(world: &World, s: &Settings, k: u32) -> Result<(Film, FrameStats), RenderError> {
    render_samples(world, s, Samples::Pass(k))
}

fn render_samples(world: &World, s: &Settings, samples: Samples) -> Result<(Film, FrameStats), RenderError> {
    let mut film = Film::new(1, 1);
    let camera = world.scene().camera;
    let stats = whitted::render(world, &camera, &s.image(), &s.whitted(), samples, &Hooks::default(), &mut film)?;
    Ok((film, stats))
}

/// A whole path-traced frame of the world seen by its scene's camera (its specular chain as
/// deep as `s.max_depth`).
pub fn path_frame(world: &World, s: &Settings, p: &PathSettings) -> Result<(Film, FrameStats), RenderError> {
    let mut film = Film::new(1, 1);
    let p = PathSettings { max_chain: s.max_depth, ..*p };
    let stats = render_path(world, &world.scene().camera, &s.image(), &p, &Hooks::default(), &mut film)?;
    Ok((film, stats))
}

/// One progressive path pass, as the viewer adds them.
pub fn add_path_pass(
    acc: &mut PathAccumulator,
    world: &World,
    s: &Settings,
    p: &PathSettings,
) -> Result<FrameStats, RenderError> {
    let p = PathSettings { max_chain: s.max_depth, ..*p };
    acc.add_pass(world, &world.scene().camera, &s.image(), &p, &Hooks::default())
}
