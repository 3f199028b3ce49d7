//! `glint render`: load, apply command-line overrides, render, write atomically.

use super::points;
use crate::cli::{FilterArg, FilterOptions, FlipArg, GuideArg, RenderArgs, SkyArgs, SkyFixArg, ToneMapArg};
use crate::input::{self, parse_vec3};
use crate::progress::LazyProgress;
use anyhow::{Context, Result, bail};
use glint_filter::{AtrousParams, BilateralParams, Filter, FilterKind, GuideChannels, GuidedParams};
use glint_formats::points::ColourBy;
use glint_formats::sky::{FaceTransform, SkyLoadOptions, SkySource, load_sky};
use glint_image::PngOptions;
use glint_render::chunk::{Chunk, Split};
use glint_render::path::{PathSettings, Share};
use glint_render::{Film, Hooks, ImageSettings, Mode, ModeSettings, Region, Renderer, Window};
use glint_scene::{Camera, Fov, RenderMode, Scene, Sky};
use std::path::Path;
use std::time::Duration;

#[derive(Clone, Copy, PartialEq, Eq)]
pub enum OutputKind {
    Png,
    /// Every AOV.
    Exr,
    /// The picture alone (`--beauty-only`).
    ExrBeauty,
}

pub fn output_kind(path: &Path) -> Result<OutputKind> {
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
        && mode(args, scene) == RenderMode::Whitted
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
            auto_fix: args.sky_fix == Some(SkyFixArg::Auto),
            ..SkyLoadOptions::default()
        };
        let loaded = load_sky(&SkySource::Path(path.clone()), &options).context("--sky")?;
        for w in &loaded.warnings {
            eprintln!("warning: {}", glint_formats::printable(w));
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
        if args.sky_fix.is_some() {
            bail!("--sky-fix applies to the images of --sky PATH (a scene's sky takes [sky.face.*] keys)");
        }
        let (rotation, intensity) = (args.sky_rotation, args.sky_intensity);
        match &mut scene.sky {
            Sky::CubeMap { transform, .. } | Sky::LatLong { transform, .. } => {
                *transform = transform.adjusted(rotation, intensity.unwrap_or(1.0));
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
pub fn mode(args: &RenderArgs, scene: &Scene) -> RenderMode {
    args.mode.map_or(scene.render.mode, RenderMode::from)
}

/// The filter the options describe, its defaults scaled to an image `width` pixels wide.
pub fn filter_from_args(kind: FilterArg, o: &FilterOptions, width: u32) -> Result<Filter> {
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
    Ok(match Filter::for_width(FilterKind::from(kind), width as usize) {
        Filter::None => Filter::None,
        Filter::Guided(d) => Filter::Guided(GuidedParams {
            radius: o.radius.unwrap_or(d.radius),
            eps_normal: o.eps_normal.unwrap_or(d.eps_normal),
            eps_depth: o.eps_depth.unwrap_or(d.eps_depth),
            channels: match o.guide {
                GuideArg::Grey => GuideChannels::Grey,
                GuideArg::Normal => GuideChannels::Normal,
                GuideArg::NormalDepth => GuideChannels::NormalDepth,
            },
        }),
        Filter::Bilateral(d) => {
            let radius = o.radius.unwrap_or(d.radius);
            Filter::Bilateral(BilateralParams { radius, sigma_spatial: radius as f32 * 0.5, ..d })
        }
        Filter::Atrous(d) => Filter::Atrous(AtrousParams { iterations: o.iterations.unwrap_or(d.iterations), ..d }),
    })
}

/// Path-mode settings from the command line over the scene's (`path`).
fn path_settings(args: &RenderArgs, path: PathSettings, width: u32, scene: &Scene) -> Result<PathSettings> {
    let p = &args.path;
    let filter = p.filter.unwrap_or(FilterArg::scene_default(scene));
    let time_budget = match p.time {
        Some(t) if t.is_finite() && t > 0.0 && t < 1e6 => Some(Duration::from_secs_f64(t)),
        Some(t) => bail!("--time {t}: must be a number of seconds > 0"),
        None => None,
    };
    Ok(PathSettings {
        spp: args.spp.unwrap_or(path.spp),
        max_bounces: p.max_bounces.unwrap_or(path.max_bounces),
        filter: filter_from_args(filter, &p.filter_options, width)?,
        time_budget,
        clamp_indirect: p.clamp,
        filter_area_direct: !p.paper_split,
        passes: p.passes,
        // --max-bounces asks for glint's budgets over a Mitsuba scene's max_depth.
        max_depth: if p.max_bounces.is_some() { None } else { path.max_depth },
        sampler: p.sampler.map_or(path.sampler, Into::into),
        reconstruction: p.reconstruction.into(),
        ..path
    })
}

/// `--crop X0,Y0,X1,Y1` → x0, y0, width, height, inside a `w × h` frame.
fn parse_crop(text: &str, w: u32, h: u32) -> Result<[u32; 4]> {
    let v: Vec<u32> = text.split(',').map(|s| s.trim().parse::<u32>()).collect::<Result<_, _>>().map_err(|_| {
        anyhow::anyhow!("--crop {text:?}: expected four whole numbers of pixels x0,y0,x1,y1 (e.g. 0,0,64,64)")
    })?;
    let &[x0, y0, x1, y1] = v.as_slice() else {
        bail!("--crop {text:?}: expected four numbers x0,y0,x1,y1, got {}", v.len());
    };
    if !(x0 < x1 && y0 < y1 && x1 <= w && y1 <= h) {
        bail!(
            "--crop {x0},{y0},{x1},{y1}: must be a non-empty window inside the {w}x{h} frame (x0 < x1 <= {w}, y0 < y1 <= {h})"
        );
    }
    Ok([x0, y0, x1 - x0, y1 - y0])
}

/// The image and the mode the options describe, over the scene's own settings.
fn frame_settings(args: &RenderArgs, scene: &Scene) -> Result<(ImageSettings, Mode)> {
    let (w, h) = (scene.render.width, scene.render.height);
    let crop = match &args.crop {
        Some(text) => Some(parse_crop(text, w, h)?),
        None => scene.render.crop,
    };
    let image = match crop {
        Some([x0, y0, cw, ch]) => ImageSettings {
            seed: args.seed,
            window: Some(Window { full_width: w, full_height: h, x0, y0 }),
            ..ImageSettings::new(cw, ch)
        },
        None => ImageSettings { seed: args.seed, ..ImageSettings::new(w, h) },
    };
    let mut modes = ModeSettings::from_defaults(&scene.render);
    modes.path = path_settings(args, modes.path, image.width, scene)?;
    let kind = mode(args, scene);
    // The points mode's size limit is its own: a Whitted or path frame is not held to it
    // (check_point_args has validated the options at 1 x 1).
    let points_image = if kind == RenderMode::Points { image } else { ImageSettings::new(1, 1) };
    modes.points = points::point_settings(&args.points, &points_image)?;
    Ok((image, modes.mode(kind)))
}

/// `--chunk I/N`, or `auto/N` with I from the scheduler: a Slurm array task
/// (`SLURM_ARRAY_TASK_ID` less `SLURM_ARRAY_TASK_MIN`, 0 when unset) or a Kubernetes Indexed
/// Job (`JOB_COMPLETION_INDEX`). `env` reads a variable.
pub fn parse_chunk(text: &str, env: impl Fn(&str) -> Option<String>) -> Result<Share> {
    parse_share("--chunk", "chunk", text, env)
}

/// `--tile I/N`, or `auto/N` with I from the scheduler as for [`parse_chunk`].
pub fn parse_tile(text: &str, env: impl Fn(&str) -> Option<String>) -> Result<Share> {
    parse_share("--tile", "tile", text, env)
}

/// `I/N` or `auto/N` of option `flag`, whose parts are called `what`s.
fn parse_share(flag: &str, what: &str, text: &str, env: impl Fn(&str) -> Option<String>) -> Result<Share> {
    let form = || anyhow::anyhow!("{flag} {text:?}: expected I/N ({what} I of N, 0-based, e.g. 0/4) or auto/N");
    let (i, n) = text.split_once('/').ok_or_else(form)?;
    let count: u32 = n.trim().parse().map_err(|_| form())?;
    let number = |name: &str, v: &str| -> Result<u32> {
        v.trim().parse().map_err(|_| anyhow::anyhow!("{flag} {text}: {name}={v:?} is not a whole number"))
    };
    let index = if i.trim() == "auto" {
        if let Some(id) = env("SLURM_ARRAY_TASK_ID") {
            let id = number("SLURM_ARRAY_TASK_ID", &id)?;
            let min = env("SLURM_ARRAY_TASK_MIN").map(|m| number("SLURM_ARRAY_TASK_MIN", &m)).transpose()?.unwrap_or(0);
            id.checked_sub(min).ok_or_else(|| {
                anyhow::anyhow!("{flag} {text}: SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}")
            })?
        } else if let Some(k) = env("JOB_COMPLETION_INDEX") {
            number("JOB_COMPLETION_INDEX", &k)?
        } else {
            bail!(
                "{flag} {text}: neither SLURM_ARRAY_TASK_ID (a Slurm job array) nor JOB_COMPLETION_INDEX (a Kubernetes Indexed Job) is set; give the index: {flag} I/{count}"
            );
        }
    } else {
        i.trim().parse().map_err(|_| form())?
    };
    if count == 0 || index >= count {
        bail!("{flag} {text}: {what} {index} of {count} does not exist ({what}s are numbered 0..{count})");
    }
    Ok(Share { index, count })
}

/// FNV-1a, 128 bits (stable: the same in every process and build), over formatted text (the scene's `Debug` form is large: hashed as it
/// is written, never held).
struct Fnv128(u128);

impl std::fmt::Write for Fnv128 {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        const PRIME: u128 = 0x0000_0000_0100_0000_0000_0000_0000_013B;
        for b in s.bytes() {
            self.0 ^= u128::from(b);
            self.0 = self.0.wrapping_mul(PRIME);
        }
        Ok(())
    }
}

/// The hash of everything that changes a chunked frame's picture: the resolved scene (after
/// every command-line override: camera, size, time, sky), the image (size, crop, seed), the
/// mode's settings (spp, passes, bounces, filter and its settings, kernel) and the output
/// settings the merge applies.
fn frame_hash(scene: &Scene, image: &ImageSettings, mode: &Mode, output: &[(String, String)]) -> String {
    use std::fmt::Write;
    let mut h = Fnv128(0x6c62_272e_07bb_0142_62b8_2175_6295_c58d);
    // Writing into the hasher cannot fail.
    let _ = write!(h, "{scene:?}\u{1}{image:?}\u{1}{mode:?}\u{1}{output:?}");
    format!("{:032x}", h.0)
}

/// The output settings a chunk carries for the merge (as `glint.setting.*`).
fn output_settings(args: &RenderArgs) -> Vec<(String, String)> {
    use clap::ValueEnum;
    let tonemap = args.tonemap.to_possible_value().map(|v| v.get_name().to_string()).unwrap_or_default();
    vec![
        ("exposure".into(), format!("{:?}", args.exposure)),
        ("tonemap".into(), tonemap),
        ("alpha".into(), args.alpha.to_string()),
    ]
}

/// The PNG options of a chunk's `glint.setting.*` attributes (`from` names the file).
pub fn png_options_from(settings: &[(String, String)], from: &Path) -> Result<PngOptions> {
    use clap::ValueEnum;
    let get = |k: &str| {
        settings
            .iter()
            .find(|(n, _)| n == k)
            .map(|(_, v)| v.as_str())
            .ok_or_else(|| anyhow::anyhow!("{}: the header has no glint.setting.{k}", from.display()))
    };
    let bad = |k: &str, v: &str| anyhow::anyhow!("{}: glint.setting.{k} {v:?} cannot be read", from.display());
    let exposure: f32 = get("exposure")?.parse().map_err(|_| bad("exposure", get("exposure").unwrap_or("")))?;
    let tonemap =
        ToneMapArg::from_str(get("tonemap")?, false).map_err(|_| bad("tonemap", get("tonemap").unwrap_or("")))?;
    let alpha = match get("alpha")? {
        "true" => true,
        "false" => false,
        v => return Err(bad("alpha", v)),
    };
    if !exposure.is_finite() {
        return Err(bad("exposure", get("exposure")?));
    }
    Ok(PngOptions { exposure, tone_map: tonemap.into(), alpha })
}

/// One output of a render: the scene time to show (None: as loaded and overridden) and where
/// the picture goes.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameOut {
    pub frame: Option<u32>,
    pub time: Option<f32>,
    pub output: std::path::PathBuf,
}

/// `--frame-range A..B`: the inclusive range (A ≤ B).
pub fn parse_frame_range(text: &str) -> Result<(u32, u32)> {
    let form = || anyhow::anyhow!("--frame-range {text:?}: expected A..B, two whole numbers with A <= B (e.g. 0..239)");
    let (a, b) = text.split_once("..").ok_or_else(form)?;
    let (a, b): (u32, u32) = (a.trim().parse().map_err(|_| form())?, b.trim().parse().map_err(|_| form())?);
    if a > b {
        return Err(form());
    }
    Ok((a, b))
}

/// `pattern` with frame `f` in place of its `%d` or `%0Nd` (N ≤ 9), or None when it has none.
pub fn frame_path(pattern: &Path, f: u32) -> Result<Option<std::path::PathBuf>> {
    let text = pattern.to_str().ok_or_else(|| anyhow::anyhow!("-o {}: not UTF-8", pattern.display()))?;
    let Some(at) = text.find('%') else { return Ok(None) };
    let rest = &text[at + 1..];
    let (width, tail) = match rest.as_bytes() {
        [b'd', ..] => (0, &rest[1..]),
        [b'0', n @ b'1'..=b'9', b'd', ..] => (usize::from(n - b'0'), &rest[3..]),
        _ => bail!("-o {text}: a frame number is written %d or %0Nd (e.g. out_%04d.png)"),
    };
    if tail.contains('%') {
        bail!("-o {text}: one frame-number placeholder only");
    }
    Ok(Some(format!("{}{f:0width$}{tail}", &text[..at]).into()))
}

/// The outputs the command asks for: one, or one per frame of `--frame-range`.
pub fn frame_outputs(args: &RenderArgs) -> Result<Vec<FrameOut>> {
    let Some(range) = &args.frame_range else {
        if frame_path(&args.output, 0).ok().flatten().is_some() {
            bail!("-o {}: a frame-number pattern needs --frame-range A..B", args.output.display());
        }
        return Ok(vec![FrameOut { frame: None, time: None, output: args.output.clone() }]);
    };
    let (a, b) = parse_frame_range(range)?;
    if args.frame_step == 0 {
        bail!("--frame-step 0: the step is a whole number of frames, at least 1");
    }
    if !(args.fps.is_finite() && args.fps > 0.0) {
        bail!("--fps {}: frames per second must be a positive number", args.fps);
    }
    if args.scene_time.is_some() {
        bail!("--scene-time and --frame-range both set the scene's time: give one");
    }
    let frames: Vec<u32> = (a..=b).step_by(args.frame_step as usize).collect();
    let mut outputs = Vec::with_capacity(frames.len());
    for f in frames {
        let output = match frame_path(&args.output, f)? {
            Some(p) => p,
            None if a == b => args.output.clone(),
            None => bail!(
                "--frame-range {range}: -o {} has no frame number, so every frame would overwrite it; write it as a pattern (e.g. out_%04d.png)",
                args.output.display()
            ),
        };
        outputs.push(FrameOut { frame: Some(f), time: Some(f as f32 / args.fps), output });
    }
    Ok(outputs)
}

/// With `--skip-existing`, whether `out` is already there (then said, unless quiet).
fn skip(args: &RenderArgs, out: &FrameOut) -> bool {
    let skip = args.skip_existing && out.output.exists();
    if skip && !args.quiet {
        eprintln!("glint: {} exists, skipped (--skip-existing)", out.output.display());
    }
    skip
}

pub fn run(args: &RenderArgs) -> Result<()> {
    let kind = output_kind(&args.output)?;
    if !args.exposure.is_finite() {
        bail!("--exposure must be a finite number");
    }
    let env = |k: &str| std::env::var(k).ok();
    let split = match (&args.chunk, &args.tile) {
        (Some(_), Some(_)) => bail!("--chunk and --tile both split the frame: give one"),
        (Some(text), None) => Some((Split::Samples, parse_chunk(text, env)?)),
        (None, Some(text)) => Some((Split::Tiles, parse_tile(text, env)?)),
        (None, None) => None,
    };
    if let Some((split, share)) = split
        && kind != OutputKind::Exr
    {
        bail!(
            "--{} writes a chunk file: give -o a .exr name (e.g. part_{}.exr), not {}",
            if split == Split::Samples { "chunk" } else { "tile" },
            share.index,
            args.output.display()
        );
    }
    let outputs = frame_outputs(args)?;
    for out in &outputs {
        output_kind(&out.output)?;
    }
    if outputs.iter().all(|o| args.skip_existing && o.output.exists()) {
        outputs.iter().for_each(|o| _ = skip(args, o));
        return Ok(());
    }
    let pool = input::thread_pool(args.threads)?;
    points::check_point_args(&args.points)?;
    let colour_by = args.points.colour_by;
    let mut scene = input::load_scene(args.input.as_deref(), colour_by, &args.scene, args.quiet)?;
    let is_scene_file =
        args.input.as_deref().is_some_and(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml")));
    if colour_by != ColourBy::Auto && (is_scene_file || scene.clouds.is_empty()) {
        bail!(
            "--colour-by applies to a point-cloud file (.las, .laz, .ply, .xyz, .pts); the clouds of a scene file take `colour_by` in their [[object]]"
        );
    }
    apply_overrides(&mut scene, args)?;
    let (image, mut frame_mode) = frame_settings(args, &scene)?;
    if args.beauty_only {
        if split.is_some() {
            bail!("--beauty-only leaves out the AOVs, and a chunk or tile carries them all for `glint merge`");
        }
        // The picture alone: a path frame keeps no AOV's sums.
        if let Mode::Path(path) = &mut frame_mode {
            path.aovs = false;
        }
    }
    let points_mode = frame_mode.kind() == RenderMode::Points;
    if points_mode && scene.clouds.is_empty() {
        bail!("--mode points draws point clouds, and this scene has none (use --mode whitted or path)");
    }
    if !points_mode && scene.objects.is_empty() {
        bail!("the scene holds only point clouds, which --mode points draws (the ray tracers do not see them)");
    }
    if !points_mode && !scene.clouds.is_empty() && !args.quiet {
        eprintln!(
            "glint: warning: {} point cloud(s) left out: only --mode points draws point clouds",
            scene.clouds.len()
        );
    }
    let camera = scene.camera;
    if let Some((split, share)) = split {
        if points_mode {
            bail!(
                "--chunk and --tile split Whitted and path frames; a points frame is reconstructed whole (pull-push), render it in one process"
            );
        }
        let settings = output_settings(args);
        let hash_before = frame_hash(&scene, &image, &frame_mode, &settings);
        let full = Region::whole(image.width, image.height);
        let region = match split {
            Split::Samples => None,
            Split::Tiles => Some(Region::tile(image.width, image.height, share.index, share.count)?),
        };
        if args.path.time.is_some() {
            bail!(
                "a time budget (--time) decides the passes while rendering: a frame split into chunks or tiles needs a fixed number (--passes)"
            );
        }
        let total_units = match frame_mode {
            Mode::Path(path) => path.units(),
            Mode::Whitted(w) => u64::from(w.samples_per_side * w.samples_per_side),
            Mode::Points { .. } => 1,
        };
        // A tile holds every unit of its pixels.
        let units_share = if split == Split::Tiles { Share::WHOLE } else { share };
        return pool.install(|| -> Result<()> {
            let mut renderer = Renderer::new(scene)?;
            for out in outputs.iter().filter(|o| !skip(args, o)) {
                // A frame's hash is of the scene at its time (a single frame keeps the loaded one's).
                let hash = match out.time {
                    Some(t) => {
                        renderer.set_time(t);
                        frame_hash(renderer.scene(), &image, &frame_mode, &settings)
                    }
                    None => hash_before.clone(),
                };
                let rows = region.map_or(image.height, |r| r.height);
                let progress = LazyProgress::new(u64::from(rows), !args.quiet);
                let advance = |rows| progress.advance(rows);
                let (stats, part) = renderer.render_part(
                    &camera,
                    &image,
                    &frame_mode,
                    units_share,
                    region,
                    &Hooks::with_progress(&advance),
                )?;
                progress.finish();
                let units = units_share.units(total_units);
                let chunk = Chunk {
                    hash,
                    version: env!("CARGO_PKG_VERSION").to_string(),
                    split,
                    index: share.index,
                    count: share.count,
                    first_unit: units.start,
                    end_unit: units.end,
                    total_units,
                    frame: (image.width, image.height),
                    region: region.unwrap_or(full),
                    settings: settings.clone(),
                    part,
                };
                chunk.write(&out.output)?;
                if !args.quiet {
                    eprintln!("glint: {} -> {}", stats.summary, out.output.display());
                }
            }
            Ok(())
        });
    }
    pool.install(|| -> Result<()> {
        if points_mode {
            points::prepare_clouds(&mut scene, &args.points, args.quiet)?;
        }
        let mut renderer = Renderer::new(scene)?;
        for out in outputs.iter().filter(|o| !skip(args, o)) {
            if let Some(t) = out.time {
                renderer.set_time(t);
            }
            let progress = LazyProgress::new(u64::from(image.height), !args.quiet && !points_mode);
            let advance = |rows| progress.advance(rows);
            let hooks = Hooks::with_progress(&advance);
            let kind = output_kind(&out.output)?;
            if kind == OutputKind::Png {
                // Encoded as it is drawn: a Whitted frame makes no float film at all.
                let options = png_options(args);
                let mut pixels = Vec::new();
                let stats = renderer.render_srgb8(&camera, &image, &frame_mode, &hooks, &options, &mut pixels)?;
                progress.finish();
                glint_image::write_png_srgb8(&out.output, image.width, image.height, options.alpha, &pixels)
                    .with_context(|| format!("cannot write {}", out.output.display()))?;
                if !args.quiet {
                    eprintln!("glint: {} -> {}", stats.summary, out.output.display());
                }
            } else {
                let stats = renderer.render(&camera, &image, &frame_mode, &hooks)?;
                progress.finish();
                write_output(args, &out.output, renderer.film(), &stats.summary)?;
            }
        }
        Ok(())
    })
}

fn png_options(args: &RenderArgs) -> PngOptions {
    PngOptions { exposure: args.exposure, tone_map: args.tonemap.into(), alpha: args.alpha }
}

fn write_output(args: &RenderArgs, output: &Path, film: &Film, summary: &str) -> Result<()> {
    let kind = match output_kind(output)? {
        OutputKind::Exr if args.beauty_only => OutputKind::ExrBeauty,
        kind => kind,
    };
    write_film(output, kind, film, &png_options(args), summary, args.quiet)
}

/// Write a film to `output`: the beauty as PNG, every AOV as EXR, or the beauty alone as EXR
/// (atomically).
pub fn write_film(
    output: &Path,
    kind: OutputKind,
    film: &Film,
    options: &PngOptions,
    summary: &str,
    quiet: bool,
) -> Result<()> {
    // In 4-byte planes: the EXR's 21 AOV planes and its encoded bytes; the PNG's 8-bit pixels
    // (RGBA at most) and its encoded bytes.
    let channels: u64 = match kind {
        OutputKind::Png => 1 + 1,
        OutputKind::Exr => 21 + 21,
        OutputKind::ExrBeauty => 4 + 4,
    };
    let pixels = u64::from(film.width) * u64::from(film.height);
    let what = || format!("the output image {} ({} x {})", output.display(), film.width, film.height);
    glint_core::memory::check(what, pixels.saturating_mul(channels * 4))?;
    let written = match kind {
        OutputKind::Png => {
            let pixels = film.encode_srgb8(options);
            glint_image::write_png_srgb8(output, film.width, film.height, options.alpha, &pixels)
        }
        OutputKind::Exr => glint_image::write_exr_owned(output, film.aov_image()),
        OutputKind::ExrBeauty => glint_image::write_exr_owned(output, film.beauty_image(true)),
    };
    written.with_context(|| format!("cannot write {}", output.display()))?;
    if !quiet {
        eprintln!("glint: {summary} -> {}", output.display());
    }
    Ok(())
}
