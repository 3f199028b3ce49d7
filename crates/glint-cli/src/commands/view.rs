//! `glint view`: the interactive viewer (glint-view) on a scene, model or point cloud.

use super::points::{point_settings, prepare_clouds};
use super::render::filter_from_args;
use crate::cli::{CameraControlArg, FilterArg, FilterOptions, ViewArgs, clap_defaults};
use crate::input;
use anyhow::{Context, Result, bail};
use glint_render::ImageSettings;
use glint_scene::limits;
use glint_view::window::{self, WindowOptions};
use glint_view::{ControlMode, ViewSettings, Viewer, ViewerOptions};

pub fn run(args: &ViewArgs) -> Result<()> {
    if !glint_scene::scene::image_size_ok(args.width, args.height) {
        bail!("--width/--height {}x{}: not a window size glint renders", args.width, args.height);
    }
    limits::check("--max-depth", args.max_depth, &limits::MAX_DEPTH).map_err(anyhow::Error::msg)?;
    if args.max_samples == 0 {
        bail!("--max-samples 0: must be at least 1");
    }
    if args.frames == Some(0) {
        bail!("--frames 0: must be at least 1");
    }
    if !args.screenshot_dir.is_dir() {
        bail!("--screenshot-dir {}: not a folder", args.screenshot_dir.display());
    }
    // Checked before the window opens: nothing is half-written on a bad path.
    if let Some(c) = &args.capture
        && !c.extension().is_some_and(|e| e.eq_ignore_ascii_case("png"))
    {
        bail!("--capture {}: must be a .png file", c.display());
    }
    // The window's event loop must run on the main thread: the workers are the global pool.
    input::global_thread_pool(args.threads)?;
    let mut scene = input::load_scene(args.input.as_deref(), args.points.colour_by, &args.scene, false)?;
    let mut settings = ViewSettings::new(args.width, args.height, scene.render.mode, &scene.render);
    let m = &mut settings.modes;
    (m.path.spp, m.path.max_bounces, m.path.filter_area_direct) = (args.spp, args.max_bounces, !args.paper_split);
    (m.whitted.max_depth, m.path.max_chain) = (args.max_depth, args.max_depth);
    m.path.validate().context("path mode")?;
    // Checks the filter's options as `glint render` does.
    let filter = args.filter.unwrap_or(FilterArg::scene_default(&scene));
    filter_from_args(filter, &clap_defaults::<FilterOptions>()?, args.width)?;
    settings.filter = filter.into();
    settings.modes.points = point_settings(&args.points, &ImageSettings::new(args.width, args.height))?;
    settings.seed = args.seed;
    let title = match &args.input {
        Some(p) => p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned()),
        None => "demo scene".to_string(),
    };
    {
        prepare_clouds(&mut scene, &args.points, false)?;
        let options = ViewerOptions {
            width: args.width,
            height: args.height,
            mode: args.mode.map(Into::into),
            control: match args.camera {
                CameraControlArg::Orbit => ControlMode::Orbit,
                CameraControlArg::Fly => ControlMode::Fly,
            },
            settings: Some(settings),
            screenshot_dir: args.screenshot_dir.clone(),
            max_accumulation: args.max_samples,
            adaptive: !args.fixed_resolution,
        };
        let viewer = Viewer::new(scene, &title, options)?;
        let report = window::run(viewer, &title, WindowOptions { frames: args.frames, capture: args.capture.clone() })?;
        if let Some(c) = &args.capture
            && let Some((w, h)) = report.captured
        {
            eprintln!("glint: {} frames; window ({w}x{h}) captured to {}", report.frames, c.display());
        }
        Ok(())
    }
}
