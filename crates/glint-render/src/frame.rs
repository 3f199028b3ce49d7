//! One frame of any mode (pipeline: World + camera + settings → **frame** → film/AOVs): the
//! single place a mode is chosen and built. The CLI's `render` and `bench` commands and the
//! viewer all come here; none of them knows how a mode makes its picture.
//!
//! A [`Renderer`] holds what a scene needs for every mode it has content for (the traced
//! [`World`] of its objects, the laid-out points of its clouds) and the buffers frames reuse.
//! [`Renderer::render`] draws a whole frame (every sample the mode's settings ask for);
//! [`Renderer::add_pass`] draws progressively, starting a picture or refining the one it holds:
//! the Whitted mode adds a jittered pass (converging to the N×N stratified image), the path mode
//! adds samples to its accumulation and filters the accumulation ([`PathAccumulator`]), the
//! points mode is exact in one pass. A points frame lays the scene's traced objects over its
//! clouds by depth (the nearer surface wins each pixel).

use crate::bands::Hooks;
use crate::film::Film;
use crate::film::PixelRecord;
use crate::path::{PathAccumulator, PathSettings, PathSums, Share, render_path, render_path_sums};
use crate::points::{PointFrame, PointRenderer, PointSettings};
use crate::settings::Region;
use crate::settings::{ImageSettings, WhittedSettings};
use crate::stats::FrameStats;
use crate::whitted::{self, Samples};
use crate::{RenderError, World};
use glint_core::Rgb;
use glint_scene::{Camera, RenderDefaults, RenderMode, Scene};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// A rendering mode with its settings: the closed set every front end chooses from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mode {
    /// Whitted ray tracing (DESIGN.md §1).
    Whitted(WhittedSettings),
    /// Path tracing with filtered indirect light (DESIGN.md §2).
    Path(PathSettings),
    /// Point clouds by pull-push reconstruction (DESIGN.md §3); the scene's objects, if any,
    /// are traced Whitted-style with `meshes` and laid over the clouds by depth.
    Points { points: PointSettings, meshes: WhittedSettings },
}

impl Mode {
    #[must_use]
    pub fn kind(&self) -> RenderMode {
        match self {
            Mode::Whitted(_) => RenderMode::Whitted,
            Mode::Path(_) => RenderMode::Path,
            Mode::Points { .. } => RenderMode::Points,
        }
    }
}

/// Every mode's settings at once, so that a front end can switch modes and keep each one's
/// settings (the viewer's keys 1/2/3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ModeSettings {
    pub whitted: WhittedSettings,
    pub path: PathSettings,
    pub points: PointSettings,
}

impl ModeSettings {
    /// The settings a scene file gives (its `[image]` samples and `[render]` section).
    #[must_use]
    pub fn from_defaults(d: &RenderDefaults) -> Self {
        Self {
            whitted: WhittedSettings::from_defaults(d),
            path: PathSettings {
                max_bounces: d.max_bounces,
                max_chain: d.max_depth,
                spp: d.spp.unwrap_or(1),
                max_depth: d.path_depth,
                rr_start: d.rr_depth.unwrap_or(PathSettings::default().rr_start),
                pixel_filter: d.pixel_filter,
                hide_emitters: d.hide_emitters,
                sampler: d.sampler,
                ..PathSettings::default()
            },
            points: PointSettings::default(),
        }
    }

    /// The mode `kind` with these settings.
    #[must_use]
    pub fn mode(&self, kind: RenderMode) -> Mode {
        match kind {
            RenderMode::Whitted => Mode::Whitted(self.whitted),
            RenderMode::Path => Mode::Path(self.path),
            RenderMode::Points => Mode::Points { points: self.points, meshes: self.whitted },
        }
    }
}

/// A part of a frame as a chunk file holds it ([`Renderer::render_part`]).
#[derive(Clone, Debug, PartialEq)]
pub enum Part {
    /// Path mode: per-pixel fixed-point sums of a share of the units.
    Path(PathSums),
    /// Whitted mode: pixels of the part's region.
    Whitted(WhittedPart),
}

/// A Whitted part: finished pixels when it holds every sample, else its samples' raw records
/// ([`Samples::One`]), sample after sample (`width × height` each).
#[derive(Clone, Debug, PartialEq)]
pub struct WhittedPart {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<PixelRecord>,
    pub raw: bool,
}

/// The picture a [`Renderer`] holds: a film, or (a points frame of clouds alone, which the
/// viewer displays straight from the points buffers) the points frame.
pub enum Picture<'a> {
    Film(&'a Film),
    Points(&'a PointFrame),
}

/// Whether a frame is whole or one pass of a progressive picture.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Step {
    Whole,
    Pass { restart: bool },
}

/// Bytes a frame of each mode holds per pixel at its peak, measured (peak RSS at 1024² less
/// the 8 × 8 frame's, over the pixels: Whitted 100, path 278 before its sums went to fixed
/// point, which added 160 (256-byte `PixelSums` for a 96-byte record), points about 250;
/// rounded up):
/// the film, the mode's accumulators and guides, the filter's planes, the points mode's
/// buffers and pyramid. A frame is refused before any of it is
/// allocated when `pixels ×` this exceeds the memory budget; the buffers themselves are then
/// made fallibly.
fn frame_bytes_per_pixel(kind: RenderMode) -> u64 {
    match kind {
        RenderMode::Whitted => WHITTED_BYTES_PER_PIXEL,
        RenderMode::Path => PATH_BYTES_PER_PIXEL,
        RenderMode::Points => POINTS_BYTES_PER_PIXEL,
    }
}

const WHITTED_BYTES_PER_PIXEL: u64 = 128;
const PATH_BYTES_PER_PIXEL: u64 = 448;
const POINTS_BYTES_PER_PIXEL: u64 = 256;

/// The summary's note of samples clamped to the largest radiance a sample may carry (none:
/// nothing).
fn clamped_note(clamped: u64) -> String {
    if clamped == 0 {
        String::new()
    } else {
        format!(", {clamped} samples above {:e} clamped to it", crate::film::MAX_SAMPLE_RADIANCE)
    }
}

/// Bytes a whole Whitted frame drawn straight to 8-bit sRGB ([`Renderer::render_srgb8`]) holds
/// per pixel at its peak: its 8-bit pixels (3, or 4 with alpha) and the PNG encoder's bytes
/// (measured: 3.2 at 4096², peak RSS less the 8 × 8 frame's, over the pixels), rounded up. The
/// band buffers are a few rows per thread.
const WHITTED_SRGB8_BYTES_PER_PIXEL: u64 = 8;

/// Refuse a frame whose buffers cannot fit the memory budget: `per_pixel` bytes a pixel of
/// `buffers`.
fn check_frame_memory(
    image: &ImageSettings,
    kind: RenderMode,
    per_pixel: u64,
    buffers: &str,
) -> Result<(), RenderError> {
    let pixels = u64::from(image.width) * u64::from(image.height);
    let what = || {
        format!(
            "a {} frame of {} x {} pixels ({buffers}, about {per_pixel} bytes per pixel)",
            kind.name(),
            image.width,
            image.height
        )
    };
    glint_core::memory::check(what, pixels.saturating_mul(per_pixel))?;
    Ok(())
}

/// Peak bytes per triangle while the world builds its trees (its BVHs, their precomputed
/// triangles and the build's references): about 330 measured for the whole process on the
/// 100 k-triangle dragon (peak RSS over the 15 k-triangle Lucy's; 170 before a mesh had a
/// spatial-split tree beside its any-hit tree), rounded up.
const BUILD_BYTES_PER_TRIANGLE: u64 = 384;
/// Bytes per point of the points mode's prepared layout and its temporaries (the layout is
/// 24 bytes a point; while it is made, each point's 40-byte record sorted with its key).
const LAYOUT_BYTES_PER_POINT: u64 = 64;

/// Refuse a scene whose acceleration structures cannot fit the memory budget: a mesh that
/// loaded can still need several times its size for its trees.
fn check_scene_memory(scene: &Scene) -> Result<(), RenderError> {
    let triangles: u64 = scene.meshes.iter().map(|m| m.triangles.len() as u64).sum();
    let points: u64 = scene.clouds.iter().map(|c| c.cloud.positions.len() as u64).sum();
    let needed = triangles
        .saturating_mul(BUILD_BYTES_PER_TRIANGLE)
        .saturating_add(points.saturating_mul(LAYOUT_BYTES_PER_POINT));
    let what = || {
        format!(
            "the acceleration structures of {triangles} triangles and {points} points (about \
             {BUILD_BYTES_PER_TRIANGLE} bytes per triangle and {LAYOUT_BYTES_PER_POINT} per point)"
        )
    };
    glint_core::memory::check(what, needed)?;
    Ok(())
}

/// A scene made renderable in every mode it has content for, and the picture being drawn.
pub struct Renderer {
    world: World,
    points: Option<PointRenderer>,
    /// Time spent laying out the clouds (Morton order, packed normals), once per scene.
    layout: Duration,
    point_frame: PointFrame,
    /// The picture so far (beauty + AOVs) at the render size.
    film: Film,
    /// A Whitted refinement pass before it is added to the picture.
    scratch: Film,
    /// Whitted: the sum of the passes' colours.
    whitted_sum: Vec<Rgb>,
    path: PathAccumulator,
    /// Whitted passes in the picture (0: nothing drawn yet).
    passes: u32,
    /// Passes (Whitted), samples per pixel (path) or 1 (points) in the picture.
    accumulated: u32,
    /// The picture is a progressive one that a pass may refine (not a whole frame).
    progressive: bool,
    /// The picture is `point_frame` (clouds alone), not `film`.
    points_picture: bool,
    /// `film` holds a copy of `point_frame` (made on demand).
    film_synced: bool,
}

impl Renderer {
    /// Build what a validated scene's content needs: a BVH world for its objects, the points
    /// layout for its clouds.
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] when the clouds cannot be laid out (too many points).
    pub fn new(scene: Scene) -> Result<Self, RenderError> {
        check_scene_memory(&scene)?;
        let start = Instant::now();
        let points = if scene.clouds.is_empty() { None } else { Some(PointRenderer::new(&scene)?) };
        let layout = start.elapsed();
        Ok(Self {
            world: World::new(scene),
            points,
            layout,
            point_frame: PointFrame::default(),
            film: Film::new(1, 1),
            scratch: Film::new(1, 1),
            whitted_sum: Vec::new(),
            path: PathAccumulator::new(),
            passes: 0,
            accumulated: 0,
            progressive: false,
            points_picture: false,
            film_synced: false,
        })
    }

    /// The scene as drawn now (animated to the current time).
    #[must_use]
    pub fn scene(&self) -> &Scene {
        self.world.scene()
    }

    /// The traced world of the scene's objects.
    #[must_use]
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Whether the scene has content for mode `kind`: objects for the ray tracers, clouds for
    /// the points mode.
    #[must_use]
    pub fn supports(&self, kind: RenderMode) -> bool {
        match kind {
            RenderMode::Whitted | RenderMode::Path => !self.scene().objects.is_empty(),
            RenderMode::Points => self.points.is_some(),
        }
    }

    /// Move the scene's animations to time `t` (seconds): only the top level of the BVH is
    /// rebuilt. Returns whether anything moved (a progressive picture must then start over).
    pub fn set_time(&mut self, t: f32) -> bool {
        self.world.set_time(t)
    }

    /// Draw a whole frame of `mode` seen by `camera`: every sample its settings ask for. The
    /// picture is then [`Renderer::film`].
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] for settings outside their limits or a mode the scene
    /// has no content for; [`RenderError::Cancelled`] when `hooks` cancel it.
    pub fn render(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        mode: &Mode,
        hooks: &Hooks,
    ) -> Result<FrameStats, RenderError> {
        self.frame(camera, image, mode, Step::Whole, hooks)
    }

    /// Draw one pass of a progressive picture: afresh (`restart`, or when the image size
    /// changed or nothing is drawn yet), else added to the picture drawn with the same camera
    /// and settings. A refining points frame does nothing (the points mode is exact in one
    /// pass) and returns no stages.
    ///
    /// # Errors
    /// As [`Renderer::render`].
    pub fn add_pass(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        mode: &Mode,
        restart: bool,
        hooks: &Hooks,
    ) -> Result<FrameStats, RenderError> {
        let restart = restart || !self.progressive || self.size() != (image.width, image.height);
        self.frame(camera, image, mode, Step::Pass { restart }, hooks)
    }

    /// Draw a whole frame of `mode` as [`Renderer::render`] does and return its picture as the
    /// 8-bit sRGB pixels [`Film::encode_srgb8`] gives for it, in `out`. A Whitted frame is
    /// encoded band by band as it is traced, with no float film in between (a PNG render's
    /// frame); the film then holds no picture (it is emptied). Other modes draw their film
    /// and encode it.
    ///
    /// # Errors
    /// As [`Renderer::render`].
    pub fn render_srgb8(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        mode: &Mode,
        hooks: &Hooks,
        options: &glint_image::PngOptions,
        out: &mut Vec<u8>,
    ) -> Result<FrameStats, RenderError> {
        let Mode::Whitted(settings) = mode else {
            // The picture alone: a path frame keeps no AOV's sums.
            let beauty = match mode {
                Mode::Path(path) => &Mode::Path(PathSettings { aovs: false, ..*path }),
                _ => mode,
            };
            let stats = self.render(camera, image, beauty, hooks)?;
            *out = self.film().encode_srgb8(options);
            return Ok(stats);
        };
        self.check_content(image, mode.kind())?;
        check_frame_memory(image, mode.kind(), WHITTED_SRGB8_BYTES_PER_PIXEL, "8-bit pixels, drawn band by band")?;
        let start = Instant::now();
        (self.progressive, self.accumulated, self.points_picture) = (false, 0, false);
        // The film would hold a stale picture: emptied, its memory given back.
        self.film = Film::beauty_only(0, 0)?;
        self.passes = 1;
        let mut stats = whitted::render_srgb8(&self.world, camera, image, settings, hooks, options, out)?;
        stats.elapsed = start.elapsed();
        stats.passes = 1;
        stats.summary = self.whitted_summary(image, &stats);
        self.accumulated = 1;
        Ok(stats)
    }

    /// Refuse a frame of mode `kind` the scene or the settings cannot give.
    fn check_content(&self, image: &ImageSettings, kind: RenderMode) -> Result<(), RenderError> {
        if !self.supports(kind) {
            return Err(RenderError::InvalidSetting(match kind {
                RenderMode::Points => "this scene has no point clouds for the points mode".into(),
                _ => "this scene has only point clouds: the ray-tracing modes have nothing to trace".into(),
            }));
        }
        if image.window.is_some() && kind == RenderMode::Points {
            return Err(RenderError::InvalidSetting(
                "a crop window: the points mode reconstructs the whole frame at once (pull-push), render it whole"
                    .into(),
            ));
        }
        Ok(())
    }

    /// The one mode dispatch.
    fn frame(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        mode: &Mode,
        step: Step,
        hooks: &Hooks,
    ) -> Result<FrameStats, RenderError> {
        self.check_content(image, mode.kind())?;
        check_frame_memory(image, mode.kind(), frame_bytes_per_pixel(mode.kind()), "film and buffers")?;
        let start = Instant::now();
        // Until this frame is done, there is nothing to refine.
        (self.progressive, self.accumulated) = (false, 0);
        let mut stats = match mode {
            Mode::Whitted(settings) => self.whitted(camera, image, settings, step, hooks)?,
            Mode::Path(settings) => self.path(camera, image, settings, step, hooks)?,
            Mode::Points { points, meshes } => self.points(camera, image, points, meshes, step, hooks)?,
        };
        stats.elapsed = start.elapsed().saturating_sub(stats.setup);
        self.progressive = step != Step::Whole;
        self.accumulated = match mode {
            Mode::Whitted(_) => stats.passes,
            _ => stats.samples_per_pixel,
        };
        Ok(stats)
    }

    /// The one-line summary of a whole Whitted frame.
    fn whitted_summary(&self, image: &ImageSettings, stats: &FrameStats) -> String {
        format!(
            "whitted {}x{} at {} spp in {:.3} s ({:.1} Mrays/s, {}, buffers {:.1} ms), {} NaN/inf samples dropped{}",
            image.width,
            image.height,
            stats.samples_per_pixel,
            stats.elapsed.as_secs_f64(),
            stats.mrays_per_second(),
            self.built(),
            stats.setup.as_secs_f64() * 1e3,
            stats.rejected_samples,
            clamped_note(stats.clamped_samples),
        )
    }

    fn whitted(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        settings: &WhittedSettings,
        step: Step,
        hooks: &Hooks,
    ) -> Result<FrameStats, RenderError> {
        self.points_picture = false;
        let setup = self.size_film(image, false)?;
        let world = &self.world;
        let mut stats = match step {
            Step::Whole => {
                self.passes = 1;
                whitted::render(world, camera, image, settings, Samples::Stratified, hooks, &mut self.film)?
            }
            Step::Pass { restart: true } => {
                self.passes = 0;
                let stats = whitted::render(world, camera, image, settings, Samples::Pass(0), hooks, &mut self.film)?;
                // The sums start from this pass's colours when a second pass comes: a moving
                // camera restarts every frame and never needs them (copying them cost 6 ms a
                // 1280 × 720 frame).
                self.whitted_sum.clear();
                self.passes = 1;
                stats
            }
            Step::Pass { restart: false } => {
                let pass = Samples::Pass(self.passes);
                // Only the pass's colours are added to the picture.
                self.scratch.reset_with(image.width, image.height, false)?;
                let stats = whitted::render(world, camera, image, settings, pass, hooks, &mut self.scratch)?;
                if self.whitted_sum.is_empty() {
                    self.whitted_sum.par_extend(self.film.pixels.par_iter().map(|p| p.colour));
                }
                self.whitted_sum.par_iter_mut().zip(&self.scratch.pixels).for_each(|(sum, p)| *sum += p.colour);
                self.passes += 1;
                let inv = 1.0 / self.passes as f32;
                self.film.pixels.par_iter_mut().zip(&self.whitted_sum).for_each(|(out, sum)| out.colour = *sum * inv);
                stats
            }
        };
        stats.passes = self.passes;
        stats.setup = setup;
        if step == Step::Whole {
            stats.summary = self.whitted_summary(image, &stats);
        }
        Ok(stats)
    }

    fn path(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        settings: &PathSettings,
        step: Step,
        hooks: &Hooks,
    ) -> Result<FrameStats, RenderError> {
        self.points_picture = false;
        let world = &self.world;
        match step {
            Step::Whole => {
                let film = self.size_film(image, true)?;
                let world = &self.world;
                let mut stats = render_path(world, camera, image, settings, hooks, &mut self.film)?;
                stats.setup += film;
                stats.summary = self.path_summary(image, settings, &stats);
                Ok(stats)
            }
            Step::Pass { restart } => {
                if restart {
                    self.path.reset();
                }
                let mut stats = self.path.add_pass(world, camera, image, settings, hooks)?;
                let filter = self.path.resolve(world, &settings.filter, &mut self.film)?;
                stats.stages.push(("filter", filter));
                Ok(stats)
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn points(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        settings: &PointSettings,
        meshes: &WhittedSettings,
        step: Step,
        hooks: &Hooks,
    ) -> Result<FrameStats, RenderError> {
        if step == (Step::Pass { restart: false }) {
            return Ok(FrameStats { passes: 1, samples_per_pixel: 1, ..FrameStats::default() });
        }
        let Some(points) = self.points.as_mut() else {
            return Err(RenderError::InvalidSetting("this scene has no point clouds for the points mode".into()));
        };
        hooks.check()?;
        let scene = self.world.scene();
        let s = points.render(scene, camera, image, settings, &mut self.point_frame)?;
        let ms = |v: f64| Duration::from_secs_f64(v * 1e-3);
        let mut stats = FrameStats {
            stages: vec![
                ("project", ms(s.project_ms)),
                ("pull-push", ms(s.pull_push_ms)),
                ("push+shade", ms(s.shade_ms)),
            ],
            points: s.points,
            passes: 1,
            samples_per_pixel: 1,
            setup: ms(s.buffers_ms),
            ..FrameStats::default()
        };
        let mut traced = String::new();
        if scene.objects.is_empty() {
            // Clouds alone: the picture is the points frame; the film is made on demand.
            self.points_picture = true;
            self.film_synced = false;
        } else {
            self.points_picture = false;
            self.point_frame.write_film(&mut self.film);
            // The traced meshes are laid over the clouds by depth.
            self.scratch.reset_with(image.width, image.height, true)?;
            let m = whitted::render(&self.world, camera, image, meshes, Samples::Stratified, hooks, &mut self.scratch)?;
            self.film.composite_nearer(&self.scratch);
            stats.stages.push(("trace", m.elapsed));
            stats.rays = m.rays;
            stats.rejected_samples = m.rejected_samples;
            traced = format!(", meshes traced in {:.1} ms", m.elapsed.as_secs_f64() * 1e3);
        }
        if step == Step::Whole {
            stats.summary = format!(
                "points {}x{} ({} points, fill {:?}) in {:.1} ms: project {:.1} ms, pull-push {:.1} ms, push+shade {:.1} ms ({:.0} M points/s; layout {:.0} ms, buffers {:.1} ms{traced})",
                image.width,
                image.height,
                s.points,
                settings.fill,
                s.total_ms,
                s.project_ms,
                s.pull_push_ms,
                s.shade_ms,
                s.points_per_second() * 1e-6,
                self.layout.as_secs_f64() * 1e3,
                s.buffers_ms,
            );
        }
        Ok(stats)
    }

    /// Make the film the size of `image`'s frame, with the first-hit AOVs (a frame drawn to 8
    /// bits may have left it without them) and the path AOVs when `path_aovs`, before the
    /// frame's clock starts: a new size allocates and first touches it (44 bytes a pixel: 91 MB
    /// at 1920 × 1080, whose page faults a single frame would otherwise time as rendering).
    /// Returns that time (zero when the size and planes were drawn before): `FrameStats::setup`.
    fn size_film(&mut self, image: &ImageSettings, path_aovs: bool) -> Result<Duration, RenderError> {
        let sized = (self.film.width, self.film.height) == (image.width, image.height);
        if sized && self.film.has_surface() && (!path_aovs || self.film.path.len() == self.film.pixels.len()) {
            return Ok(Duration::ZERO);
        }
        let start = Instant::now();
        self.film.reset_with(image.width, image.height, true)?;
        if path_aovs {
            self.film.path_aovs_mut()?;
        }
        Ok(start.elapsed())
    }

    /// The summary of a path frame (or a share of one).
    fn path_summary(&self, image: &ImageSettings, settings: &PathSettings, stats: &FrameStats) -> String {
        let trace = stats.stage("trace").unwrap_or_default();
        format!(
            "path {}x{} at {} spp ({} pass{}, {}, filter {}) in {:.3} s ({:.2} M paths/s; trace {:.3} s at {:.1} Mrays/s, filter {:.1} ms, {}, buffers {:.1} ms), {} NaN/inf samples dropped{}",
            image.width,
            image.height,
            stats.samples_per_pixel,
            stats.passes,
            if stats.passes == 1 { "" } else { "es" },
            // Mitsuba's total vertex budget when the scene gave one, else glint's.
            match settings.max_depth {
                Some(d) => format!("max depth {d}"),
                None => format!("{} bounces", settings.max_bounces),
            },
            settings.filter,
            stats.elapsed.as_secs_f64(),
            stats.mpaths_per_second(),
            trace.as_secs_f64(),
            stats.mrays_per_second(),
            stats.stage("filter").unwrap_or_default().as_secs_f64() * 1e3,
            self.built(),
            stats.setup.as_secs_f64() * 1e3,
            stats.rejected_samples,
            clamped_note(stats.clamped_samples),
        )
    }

    /// Render a part of a frame for a chunk file: `share` of its units (a path frame's passes
    /// with a filter, its samples per pixel without one; a Whitted frame's samples per pixel)
    /// over `region` of its pixels (None: all of them). The parts of a frame put together
    /// ([`crate::chunk::merge`]) are [`Renderer::render`]'s film bit for bit: a path part
    /// holds per-pixel fixed-point sums, which the whole frame resolves the same way; a
    /// Whitted part holding every sample holds finished pixels, one holding some of them its
    /// samples' raw records, which a supersampled frame adds in sample order
    /// ([`whitted::SampleSum`]). The held picture is left as it is.
    ///
    /// # Errors
    /// As [`Renderer::render`]; [`RenderError::InvalidSetting`] for the points mode (global:
    /// not split), a share outside the frame's units or a region outside the image.
    pub fn render_part(
        &mut self,
        camera: &Camera,
        image: &ImageSettings,
        mode: &Mode,
        share: Share,
        region: Option<Region>,
        hooks: &Hooks,
    ) -> Result<(FrameStats, Part), RenderError> {
        if !self.supports(mode.kind()) || mode.kind() == RenderMode::Points {
            return Err(RenderError::InvalidSetting(format!(
                "a {} frame of this scene is not split into chunks: the ray-tracing modes are, and only for scenes with objects",
                mode.kind().name()
            )));
        }
        check_frame_memory(image, mode.kind(), frame_bytes_per_pixel(mode.kind()), "film and buffers")?;
        let part_name = |stats: &FrameStats| match region {
            Some(r) => format!("tile {}/{} ({}x{} at {},{})", share.index, share.count, r.width, r.height, r.x0, r.y0),
            None if stats.passes == 0 => String::new(),
            None => format!("chunk {}/{}", share.index, share.count),
        };
        match mode {
            Mode::Path(settings) => {
                // A chunk is merged into any output: it carries every AOV's sums.
                let settings = &PathSettings { aovs: true, ..*settings };
                let (mut stats, sums) = render_path_sums(&self.world, camera, image, settings, share, region, hooks)?;
                let part_image = region.map_or(*image, |r| image.sub(r));
                stats.summary =
                    format!("{} of {}", part_name(&stats), self.path_summary(&part_image, settings, &stats));
                Ok((stats, Part::Path(sums)))
            }
            Mode::Whitted(settings) => {
                let part_image = region.map_or(*image, |r| image.sub(r));
                let samples = settings.samples_per_side * settings.samples_per_side;
                let units = share.units(u64::from(samples));
                if share.count == 0 || share.index >= share.count || u64::from(share.count) > u64::from(samples) {
                    return Err(RenderError::InvalidSetting(format!(
                        "chunk {}/{} of a Whitted frame of {samples} samples per pixel: at most one chunk per sample (0-based)",
                        share.index, share.count
                    )));
                }
                // A chunk's records carry the first-hit AOVs.
                self.film.reset_with(part_image.width, part_image.height, true)?;
                self.scratch.reset_with(part_image.width, part_image.height, true)?;
                let world = &self.world;
                let (stats, part) = if units == (0..u64::from(samples)) {
                    let stats = whitted::render(
                        world,
                        camera,
                        &part_image,
                        settings,
                        Samples::Stratified,
                        hooks,
                        &mut self.film,
                    )?;
                    (
                        stats,
                        WhittedPart {
                            width: part_image.width,
                            height: part_image.height,
                            pixels: self.film.records(),
                            raw: false,
                        },
                    )
                } else {
                    let what = || format!("the sample records of a {} x {} image", part_image.width, part_image.height);
                    let count = (units.end - units.start) as usize;
                    let mut pixels =
                        glint_core::memory::try_with_capacity(what, part_image.pixels().saturating_mul(count))?;
                    let mut stats = FrameStats::default();
                    let start = Instant::now();
                    let scratch = &mut self.scratch;
                    hooks.over_passes(count as u64, |hooks| -> Result<(), RenderError> {
                        for s in units {
                            let one = Samples::One(s as u32);
                            let one = whitted::render(world, camera, &part_image, settings, one, hooks, scratch)?;
                            pixels.extend((0..scratch.pixels.len()).map(|i| scratch.record(i)));
                            stats.rays.add(&one.rays);
                            stats.rejected_samples += one.rejected_samples;
                            stats.clamped_samples += one.clamped_samples;
                            stats.samples_per_pixel += 1;
                        }
                        Ok(())
                    })?;
                    stats.elapsed = start.elapsed();
                    (stats, WhittedPart { width: part_image.width, height: part_image.height, pixels, raw: true })
                };
                let mut stats = stats;
                stats.summary = format!(
                    "{} of whitted {}x{} at {} of {samples} spp in {:.3} s ({:.1} Mrays/s, {})",
                    part_name(&stats),
                    part_image.width,
                    part_image.height,
                    stats.samples_per_pixel,
                    stats.elapsed.as_secs_f64(),
                    stats.mrays_per_second(),
                    self.built(),
                );
                // The film no longer holds a picture that a pass could refine.
                (self.progressive, self.accumulated) = (false, 0);
                Ok((stats, Part::Whitted(part)))
            }
            Mode::Points { .. } => unreachable!("refused above"),
        }
    }

    /// "build X ms, N triangles": the acceleration structures, for summaries.
    fn built(&self) -> String {
        let s = &self.world.stats;
        format!("build {:.1} ms, {} triangles", s.build_ms, s.triangles)
    }

    /// The picture as a film (beauty + AOVs at the render size). A points frame of clouds
    /// alone is copied into the film only when asked (a screenshot, an output file).
    pub fn film(&mut self) -> &Film {
        if self.points_picture && !self.film_synced {
            self.point_frame.write_film(&mut self.film);
            self.film_synced = true;
        }
        &self.film
    }

    /// The picture as it is held (for a display that reads points frames directly).
    #[must_use]
    pub fn picture(&self) -> Picture<'_> {
        match self.points_picture {
            true => Picture::Points(&self.point_frame),
            false => Picture::Film(&self.film),
        }
    }

    /// The picture's size (the render size of the last frame).
    #[must_use]
    pub fn size(&self) -> (u32, u32) {
        match self.points_picture {
            true => (self.point_frame.width, self.point_frame.height),
            false => (self.film.width, self.film.height),
        }
    }

    /// Passes (Whitted) or samples per pixel (path) in the picture; 1 for points; 0 before
    /// the first frame and after a failed one.
    #[must_use]
    pub fn accumulated(&self) -> u32 {
        self.accumulated
    }
}
