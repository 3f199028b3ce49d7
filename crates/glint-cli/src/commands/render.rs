//! `glint render`: load, apply command-line overrides, render, write atomically.

use super::points;
use crate::cli::{FilterArg, FilterOptions, FlipArg, GuideArg, ModeArg, RenderArgs, SkyArgs};
use crate::input::{self, parse_vec3};
use crate::progress::LazyProgress;
use anyhow::{Context, Result, bail};
use glint_filter::{AtrousParams, BilateralParams, Filter, GuideChannels, GuidedParams};
use glint_formats::points::ColourBy;
use glint_formats::sky::{FaceTransform, SkyLoadOptions, SkySource, load_sky};
use glint_image::{PngOptions, ToneMap};
use glint_render::{Film, PathSettings, PointFrame, PointRenderer, RenderSettings, World, render_path};
use glint_scene::{Camera, Fov, RenderMode, Scene, Sky, SkyTransform};
use std::path::Path;
use std::time::Duration;

#[derive(Clone, Copy, PartialEq, Eq)]
enum OutputKind {
    Png,
    Exr,
}

fn output_kind(path: &Path) -> Result<OutputKind> {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("png") => Ok(OutputKind::Png),
        Some("exr") => Ok(OutputKind::Exr),
        _ => bail!("output {}: unsupported image type (use .png or .exr)", path.display()),
    }
}

/// Apply size, sampling and camera overrides from the command line.
pub fn apply_overrides(scene: &mut Scene, args: &RenderArgs) -> Result<()> {
    if let Some(t) = args.scene_time {
        if !t.is_finite() {
            bail!("--scene-time {t}: must be a finite number of seconds");
        }
        if !scene.is_animated() && !args.quiet {
            eprintln!("glint: warning: --scene-time {t}: the scene has no animations");
        }
        scene.set_time(t);
    }
    if let Some(w) = args.width {
        scene.render.width = w;
    }
    if let Some(h) = args.height {
        scene.render.height = h;
    }
    if let Some(spp) = args.spp
        && mode(args, scene) == ModeArg::Whitted
    {
        let n = (spp as f64).sqrt().round() as u32;
        if spp == 0 || n * n != spp {
            bail!("--spp {spp}: Whitted mode takes N×N stratified samples; use a square number (1, 4, 9, 16, ...)");
        }
        scene.render.samples_per_side = n;
    }
    if let Some(d) = args.max_depth {
        scene.render.max_depth = d;
    }
    let c = &args.camera;
    // A model or cloud file's view was framed for the default image: refit it to this one.
    let is_scene_file =
        args.input.as_deref().is_some_and(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")));
    if args.input.is_some() && !is_scene_file && (args.width.is_some() || args.height.is_some()) {
        scene.camera = glint_formats::default_camera(scene, scene.render.width, scene.render.height);
    }
    let mut cam: Camera = scene.camera;
    if let Some(e) = &c.eye {
        cam.position = parse_vec3("eye", e)?;
    }
    if let Some(u) = &c.up {
        cam.up = parse_vec3("up", u)?;
    }
    if let Some(l) = &c.look_at {
        let target = parse_vec3("look-at", l)?;
        let d = target - cam.position;
        if d.length_squared() == 0.0 {
            bail!("--look-at {l}: the camera cannot look at its own position");
        }
        cam.forward = d.normalize();
    }
    if let Some(f) = c.fov {
        cam.fov = Fov::Vertical(f);
    }
    scene.camera = cam;
    apply_sky(scene, &args.sky, args.input.as_deref())?;
    scene.validate().context("after applying the command-line options")?;
    Ok(())
}

/// `--sky` replaces the sky; `--sky-rotation` / `--sky-intensity` also adjust the scene's own.
fn apply_sky(scene: &mut Scene, args: &SkyArgs, input: Option<&Path>) -> Result<()> {
    if let Some(i) = args.sky_intensity
        && !(i.is_finite() && i >= 0.0)
    {
        bail!("--sky-intensity {i}: must be a finite number >= 0");
    }
    if let Some(r) = args.sky_rotation
        && !r.is_finite()
    {
        bail!("--sky-rotation {r}: must be a finite number of degrees");
    }
    if let Some(path) = &args.sky {
        let flip = args.sky_flip.unwrap_or(FlipArg::None);
        let options = SkyLoadOptions {
            all_faces: FaceTransform {
                flip_horizontal: matches!(flip, FlipArg::Horizontal | FlipArg::Both),
                flip_vertical: matches!(flip, FlipArg::Vertical | FlipArg::Both),
                rotate_degrees: 0,
            },
            rotation_degrees: args.sky_rotation.unwrap_or(0.0),
            intensity: args.sky_intensity.unwrap_or(1.0),
            ..SkyLoadOptions::default()
        };
        let loaded = load_sky(&SkySource::Path(path.clone()), &options).context("--sky")?;
        for w in &loaded.warnings {
            eprintln!("warning: {w}");
        }
        scene.sky = loaded.sky;
        // A model file comes with a generic scene around it: let the new sky light it.
        let is_scene_file = input.is_some_and(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")));
        if !is_scene_file {
            scene.sky_ambient = true;
        }
    } else {
        if args.sky_flip.is_some() {
            bail!("--sky-flip applies to the images of --sky PATH");
        }
        let (rotation, intensity) = (args.sky_rotation, args.sky_intensity);
        match &mut scene.sky {
            Sky::CubeMap { transform, .. } | Sky::LatLong { transform, .. } => {
                *transform = SkyTransform::new(
                    rotation.unwrap_or(transform.rotation_degrees),
                    transform.intensity * intensity.unwrap_or(1.0),
                );
            }
            Sky::Colour(c) => *c *= intensity.unwrap_or(1.0),
            Sky::Gradient { zenith, horizon, ground } => {
                let k = intensity.unwrap_or(1.0);
                (*zenith, *horizon, *ground) = (*zenith * k, *horizon * k, *ground * k);
            }
        }
    }
    if args.sky_ambient {
        scene.sky_ambient = true;
    }
    Ok(())
}

/// The mode to render in: the command line's, else the scene's.
pub fn mode(args: &RenderArgs, scene: &Scene) -> ModeArg {
    args.mode.unwrap_or(match scene.render.mode {
        RenderMode::Whitted => ModeArg::Whitted,
        RenderMode::Path => ModeArg::Path,
        RenderMode::Points => ModeArg::Points,
    })
}

/// The filter the options describe, its defaults scaled to an image `width` pixels wide.
pub fn filter_from_args(kind: FilterArg, o: &FilterOptions, width: u32) -> Result<Filter> {
    let w = width as usize;
    let check_eps = |name: &str, v: Option<f32>| -> Result<()> {
        if let Some(e) = v
            && !(e.is_finite() && e > 0.0)
        {
            bail!("--{name} {e}: must be a finite number > 0");
        }
        Ok(())
    };
    check_eps("eps-normal", o.eps_normal)?;
    check_eps("eps-depth", o.eps_depth)?;
    if let Some(r) = o.radius
        && !(1..=1024).contains(&r)
    {
        bail!("--radius {r}: must be 1..=1024 pixels");
    }
    if let Some(i) = o.iterations
        && !(1..=10).contains(&i)
    {
        bail!("--iterations {i}: must be 1..=10");
    }
    Ok(match kind {
        FilterArg::None => Filter::None,
        FilterArg::Guided => {
            let d = GuidedParams::for_width(w);
            Filter::Guided(GuidedParams {
                radius: o.radius.unwrap_or(d.radius),
                eps_normal: o.eps_normal.unwrap_or(d.eps_normal),
                eps_depth: o.eps_depth.unwrap_or(d.eps_depth),
                channels: match o.guide {
                    GuideArg::Grey => GuideChannels::Grey,
                    GuideArg::Normal => GuideChannels::Normal,
                    GuideArg::NormalDepth => GuideChannels::NormalDepth,
                },
            })
        }
        FilterArg::Bilateral => {
            let d = BilateralParams::for_width(w);
            let radius = o.radius.unwrap_or(d.radius);
            Filter::Bilateral(BilateralParams { radius, sigma_spatial: radius as f32 * 0.5, ..d })
        }
        FilterArg::Atrous => {
            let d = AtrousParams::default();
            Filter::Atrous(AtrousParams { iterations: o.iterations.unwrap_or(d.iterations), ..d })
        }
    })
}

/// Path-mode settings from the command line and the scene's defaults.
fn path_settings(args: &RenderArgs, scene: &Scene, width: u32) -> Result<PathSettings> {
    let p = &args.path;
    let time_budget = match p.time {
        Some(t) if t.is_finite() && t > 0.0 && t < 1e6 => Some(Duration::from_secs_f64(t)),
        Some(t) => bail!("--time {t}: must be a number of seconds > 0"),
        None => None,
    };
    Ok(PathSettings {
        spp: args.spp.unwrap_or(1),
        max_bounces: p.max_bounces.unwrap_or(scene.render.max_bounces),
        filter: filter_from_args(p.filter, &p.filter_options, width)?,
        time_budget,
        clamp_indirect: p.clamp,
        filter_area_direct: p.filter_area_lights,
        ..PathSettings::default()
    })
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let kind = output_kind(&args.output)?;
    let _: ToneMap = args
        .tonemap
        .parse()
        .map_err(|_| anyhow::anyhow!("--tonemap {:?}: use clamp, reinhard or aces", args.tonemap))?;
    if !args.exposure.is_finite() {
        bail!("--exposure must be a finite number");
    }
    let pool = input::thread_pool(args.threads)?;
    points::check_point_args(&args.points)?;
    let colour_by = args.points.colour_by;
    let mut scene = input::load_with(args.input.as_deref(), colour_by, args.quiet)?;
    let is_scene_file =
        args.input.as_deref().is_some_and(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")));
    if colour_by != ColourBy::Auto && (is_scene_file || scene.clouds.is_empty()) {
        bail!(
            "--colour-by applies to a point-cloud file (.las, .laz, .ply, .xyz, .pts); the clouds of a scene file take `colour_by` in their [[object]]"
        );
    }
    apply_overrides(&mut scene, args)?;
    let mut settings = RenderSettings::from_defaults(&scene.render);
    settings.seed = args.seed;

    let mode = mode(args, &scene);
    if mode == ModeArg::Points {
        return run_points(args, kind, scene, &settings, &pool);
    }
    if scene.objects.is_empty() {
        bail!("the scene holds only point clouds, which --mode points draws (the ray tracers do not see them)");
    }
    if !scene.clouds.is_empty() && !args.quiet {
        eprintln!(
            "glint: warning: {} point cloud(s) left out: only --mode points draws point clouds",
            scene.clouds.len()
        );
    }
    let path = match mode {
        ModeArg::Path => Some(path_settings(args, &scene, settings.width)?),
        _ => None,
    };

    let (film, summary) = pool.install(|| -> Result<_> {
        let world = World::new(scene);
        let progress = LazyProgress::new(settings.height as u64, !args.quiet);
        let advance = |rows| progress.advance(rows);
        let built = format!("build {:.1} ms, {} triangles", world.stats.build_ms, world.stats.triangles);
        let result = match &path {
            None => {
                let (film, stats) = glint_render::render_with_progress(&world, &settings, &advance)?;
                let n = settings.samples_per_side;
                let summary = format!(
                    "whitted {}x{} at {} spp in {:.3} s ({:.1} Mrays/s, {built}), {} NaN/inf samples dropped",
                    settings.width,
                    settings.height,
                    n * n,
                    stats.elapsed.as_secs_f64(),
                    stats.mrays_per_second(),
                    stats.rejected_samples,
                );
                (film, summary)
            }
            Some(p) => {
                let (film, stats) = render_path(&world, &settings, p, &advance)?;
                let summary = format!(
                    "path {}x{} at {} spp ({} pass{}, {} bounces, filter {}) in {:.3} s (trace {:.3} s at {:.1} Mrays/s, filter {:.1} ms, {built}), {} NaN/inf samples dropped",
                    settings.width,
                    settings.height,
                    stats.samples_per_pixel,
                    stats.passes,
                    if stats.passes == 1 { "" } else { "es" },
                    p.max_bounces,
                    filter_name(&p.filter),
                    stats.elapsed.as_secs_f64(),
                    stats.trace.as_secs_f64(),
                    stats.mrays_per_second(),
                    stats.filter.as_secs_f64() * 1e3,
                    stats.rejected_samples,
                );
                (film, summary)
            }
        };
        progress.finish();
        Ok(result)
    })?;

    write_output(args, kind, &film, &summary)
}

fn write_output(args: &RenderArgs, kind: OutputKind, film: &Film, summary: &str) -> Result<()> {
    let tone_map: ToneMap = args
        .tonemap
        .parse()
        .map_err(|_| anyhow::anyhow!("--tonemap {:?}: use clamp, reinhard or aces", args.tonemap))?;
    let image = match kind {
        OutputKind::Png => film.beauty_image(args.alpha),
        OutputKind::Exr => film.aov_image(),
    };
    let options = PngOptions { exposure: args.exposure, tone_map, alpha: args.alpha };
    glint_image::write_image(&args.output, &image, &options)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if !args.quiet {
        eprintln!("glint: {summary} -> {}", args.output.display());
    }
    Ok(())
}

/// Points mode: prepare the clouds (estimate what they lack), reconstruct and shade them; the
/// scene's meshes, spheres and planes, if any, are traced Whitted-style and the nearer surface
/// wins each pixel.
fn run_points(
    args: &RenderArgs,
    kind: OutputKind,
    mut scene: Scene,
    settings: &RenderSettings,
    pool: &rayon::ThreadPool,
) -> Result<()> {
    if scene.clouds.is_empty() {
        bail!("--mode points draws point clouds, and this scene has none (use --mode whitted or path)");
    }
    let point_settings = points::point_settings(&args.points, settings.width, settings.height)?;
    let (film, summary) = pool.install(|| -> Result<_> {
        points::prepare_clouds(&mut scene, &args.points, args.quiet)?;
        let start = std::time::Instant::now();
        let mut renderer = PointRenderer::new(&scene)?;
        let prepared_ms = start.elapsed().as_secs_f64() * 1e3;
        let mut frame = PointFrame::default();
        let stats = renderer.render(&scene, &scene.camera, &point_settings, &mut frame)?;
        let mut film = frame.to_film();
        let mut traced = String::new();
        if !scene.objects.is_empty() {
            let world = World::new(scene.clone());
            let (meshes, s) = glint_render::render(&world, settings)?;
            film.composite_nearer(&meshes);
            traced = format!(", meshes traced in {:.1} ms", s.elapsed.as_secs_f64() * 1e3);
        }
        let summary = format!(
            "points {}x{} ({} points, fill {:?}) in {:.1} ms: project {:.1} ms, pull-push {:.1} ms, shade {:.1} ms ({:.0} M points/s; layout {:.0} ms{traced})",
            settings.width,
            settings.height,
            stats.points,
            point_settings.fill,
            stats.total_ms,
            stats.project_ms,
            stats.pull_push_ms,
            stats.shade_ms,
            stats.points_per_second() * 1e-6,
            prepared_ms,
        );
        Ok((film, summary))
    })?;
    write_output(args, kind, &film, &summary)
}

pub fn filter_name(f: &Filter) -> String {
    match f {
        Filter::None => "none".into(),
        Filter::Guided(p) => {
            let dims = match p.channels {
                GuideChannels::Grey => "1-D",
                GuideChannels::Normal => "3-D",
                GuideChannels::NormalDepth => "4-D",
            };
            format!("guided {dims} r={}", p.radius)
        }
        Filter::Bilateral(p) => format!("bilateral r={}", p.radius),
        Filter::Atrous(p) => format!("A-Trous {} iterations", p.iterations),
    }
}
