//! `glint bench view`: the viewer's frame loop without a window (issue 6). The camera orbits
//! the content once over `--frames` frames, starting from the scene's view; every frame goes
//! through the same `Viewer::frame` the window calls (render, channel, upscale, statistics
//! text) and is timed, so frame rates are measured, not guessed. Full resolution by default;
//! `--adaptive` measures the lowered resolution the window uses while the camera moves.

use super::bench::{StageTimes, median};
use super::points::prepare_clouds;
use super::render::filter_from_args;
use crate::cli::{BenchViewArgs, FilterOptions, PointArgs, clap_defaults};
use crate::input;
use anyhow::{Context, Result, bail};
use glint_core::Vec2;
use glint_scene::RenderMode;
use glint_view::frame::{ms, rate};
use glint_view::{ControlMode, InputState, ViewSettings, Viewer, ViewerOptions};
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
    let mode = args.mode.map_or(scene.render.mode, RenderMode::from);
    let mut settings = ViewSettings::new(args.width, args.height, mode, &scene.render);
    settings.modes.path.spp = args.spp;
    settings.modes.path.max_bounces = args.max_bounces;
    settings.modes.path.validate().context("path mode")?;
    filter_from_args(args.filter, &clap_defaults::<FilterOptions>()?, args.width)?;
    settings.filter = args.filter.into();
    pool.install(|| -> Result<()> {
        let point_args = clap_defaults::<PointArgs>()?;
        prepare_clouds(&mut scene, &point_args, true)?;
        let options = ViewerOptions {
            width: args.width,
            height: args.height,
            mode: Some(mode),
            control: ControlMode::Orbit,
            settings: Some(settings),
            adaptive: args.adaptive,
            ..ViewerOptions::default()
        };
        let mut viewer = Viewer::new(scene, "bench", options)?;
        // One full turn over the run, at 60 frames a second of scene time (animations play).
        let turn = std::f32::consts::TAU / args.frames as f32 / glint_view::camera::LOOK_PER_PIXEL;
        let input = InputState { look: Vec2::new(turn, 0.0), ..InputState::default() };
        let mut totals = Vec::with_capacity(args.frames);
        let mut stages = StageTimes::default();
        let mut rates = Vec::with_capacity(args.frames);
        let mut pixels_drawn = Vec::with_capacity(args.frames);
        let mut unit = "";
        for frame in 0..args.frames {
            let start = std::time::Instant::now();
            let outcome = viewer.frame(&input, 1.0 / 60.0)?.clone();
            let total = start.elapsed().as_secs_f64() * 1e3;
            let stats = outcome.stats;
            let (rw, rh) = outcome.render_size;
            // Everything after the render: channel, upscale, statistics text.
            let display = (total - ms(stats.elapsed)).max(0.0);
            if args.per_frame {
                let split: Vec<String> = stats.stages.iter().map(|(n, d)| format!("{n} {:.2}", ms(*d))).collect();
                out!("frame {frame}: {total:.2} ms at {rw}x{rh} ({}, display {display:.2})", split.join(", "));
            }
            totals.push(total);
            let (rate, rate_unit) = rate(&stats);
            rates.push(rate);
            pixels_drawn.push((rw * rh) as f64);
            unit = rate_unit;
            let stages_ms = stats.stages.iter().map(|(n, d)| (*n, ms(*d)));
            for (name, ms) in stages_ms.chain([("display", display)]) {
                stages.push(name, ms);
            }
        }
        let mut sorted = totals.clone();
        let med = median(&mut sorted);
        let scale = (args.width as f64 * args.height as f64 / median(&mut pixels_drawn)).sqrt();
        out!(
            "{} {}x{}{}, {} frames on {} threads: median {med:.2} ms ({:.1} fps), min {:.2}, max {:.2}; stages (medians, ms): {}; {:.1} {unit}",
            mode.name(),
            args.width,
            args.height,
            if args.adaptive { format!(" (adaptive: median frame drawn at 1/{scale:.1} of the size)") } else { String::new() },
            args.frames,
            rayon::current_num_threads(),
            1e3 / med,
            sorted[0],
            sorted[sorted.len() - 1],
            stages.medians(),
            median(&mut rates),
        );
        Ok(())
    })
}
