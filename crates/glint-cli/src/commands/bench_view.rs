//! `glint bench view`: the viewer's frame loop without a window (issue 6). The camera orbits
//! the content once over `--frames` frames, starting from the scene's view; every frame is drawn
//! into the viewer's pixel buffer and timed, so frame rates are measured, not guessed.

use super::bench::median;
use super::points::prepare_clouds;
use super::render::filter_from_args;
use crate::cli::{BenchViewArgs, FilterOptions, ModeArg, PointArgs};
use crate::input;
use anyhow::{Context, Result, bail};
use glint_core::Vec2;
use glint_render::PathSettings;
use glint_scene::RenderMode;
use glint_view::{CameraController, ControlMode, FrameRenderer, InputState, ViewMode, ViewSettings};
use std::io::Write;

pub fn run(args: &BenchViewArgs) -> Result<()> {
    if args.frames == 0 || args.frames > 100_000 {
        bail!("--frames {}: must be 1..=100000", args.frames);
    }
    if !glint_scene::scene::image_size_ok(args.width, args.height) {
        bail!("--width/--height {}x{}: not an image size glint renders", args.width, args.height);
    }
    let pool = input::thread_pool(args.threads)?;
    let mut scene = input::load(args.input.as_deref(), true)?;
    let mode = match args.mode.unwrap_or(match scene.render.mode {
        RenderMode::Whitted => ModeArg::Whitted,
        RenderMode::Path => ModeArg::Path,
        RenderMode::Points => ModeArg::Points,
    }) {
        ModeArg::Whitted => ViewMode::Whitted,
        ModeArg::Path => ViewMode::Path,
        ModeArg::Points => ViewMode::Points,
    };
    let mut settings = ViewSettings::new(args.width, args.height, mode);
    settings.path = PathSettings {
        spp: args.spp,
        max_bounces: args.max_bounces,
        filter: filter_from_args(args.filter, &FilterOptions::default(), args.width)?,
        ..PathSettings::default()
    };
    settings.path.validate().context("path mode")?;
    pool.install(|| -> Result<()> {
        let point_args = PointArgs { neighbours: 16, radius_scale: 1.0, ..PointArgs::default() };
        prepare_clouds(&mut scene, &point_args, true)?;
        let bounds = scene.bounds();
        let mut camera = CameraController::new(&scene.camera, bounds, ControlMode::Orbit);
        let mut renderer = FrameRenderer::new(scene)?;
        // One full turn over the run.
        let turn = std::f32::consts::TAU / args.frames as f32 / glint_view::camera::LOOK_PER_PIXEL;
        let mut pixels = Vec::new();
        let mut totals = Vec::with_capacity(args.frames);
        let mut stages: Vec<(&'static str, Vec<f64>)> = Vec::new();
        let mut rates = Vec::with_capacity(args.frames);
        let mut unit = "";
        for frame in 0..args.frames {
            let stats = renderer.render(&camera.camera(), &settings, &mut pixels)?;
            if args.per_frame {
                let split: Vec<String> = stats.stages.iter().map(|(n, ms)| format!("{n} {ms:.2}")).collect();
                out!("frame {frame}: {:.2} ms ({})", stats.total_ms, split.join(", "));
            }
            totals.push(stats.total_ms);
            rates.push(stats.mrate);
            unit = stats.rate_unit;
            for (name, ms) in stats.stages {
                match stages.iter_mut().find(|(n, _)| *n == name) {
                    Some((_, v)) => v.push(ms),
                    None => stages.push((name, vec![ms])),
                }
            }
            camera.update(&InputState { look: Vec2::new(turn, 0.0), ..InputState::default() }, 1.0 / 60.0);
        }
        let mut sorted = totals.clone();
        let med = median(&mut sorted);
        let split: Vec<String> = stages.iter_mut().map(|(n, v)| format!("{n} {:.2}", median(v))).collect();
        out!(
            "{:?} {}x{}, {} frames on {} threads: median {med:.2} ms ({:.1} fps), min {:.2}, max {:.2}; stages (medians, ms): {}; {:.1} {unit}",
            mode,
            args.width,
            args.height,
            args.frames,
            rayon::current_num_threads(),
            1e3 / med,
            sorted[0],
            sorted[sorted.len() - 1],
            split.join(", "),
            median(&mut rates),
        );
        Ok(())
    })
}
