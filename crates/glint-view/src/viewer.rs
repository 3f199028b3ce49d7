//! The viewer's frame loop without the window: input and key actions in, a 0RGB frame of the
//! window's size out. The window (`window.rs`) feeds it events and presents its pixels; the
//! headless benchmark and the tests drive it directly, so what they measure is what the user
//! sees.
//!
//! Each frame: the camera controller applies the input; animations advance; then either the
//! picture starts over (the camera or the scene moved, a setting changed) or, at rest, it is
//! refined (progressive passes) until `max_accumulation`, after which frames cost nothing.
//! While the camera moves the frame is drawn at a reduced resolution chosen from the last
//! frames' cost per pixel so that it stays within [`TARGET_FRAME_MS`] (the adaptive
//! resolution of Blender's viewport), and scaled up to the window.

use crate::ViewError;
use crate::camera::{CameraController, ControlMode, InputState};
use crate::display::{Display, upscale};
use crate::display::{display, display_points};
use crate::frame::{ViewSettings, filter_name, ms, next_filter, rate};
use crate::overlay;
use glint_render::points::Fill;
use glint_render::{FrameStats, Hooks, Picture, Renderer};
use glint_scene::limits;
use glint_scene::{Camera, RenderMode, Scene};
use std::path::{Path, PathBuf};

/// The frame time the adaptive resolution aims at while the camera moves (30 fps).
pub const TARGET_FRAME_MS: f64 = 1000.0 / 30.0;
/// Resolution divisors the adaptive resolution chooses from.
const DIVISORS: [u32; 7] = [1, 2, 3, 4, 6, 8, 12];
/// Whitted passes at rest (8×8 supersampling's worth of jittered samples) before the picture
/// is final.
pub const WHITTED_MAX_PASSES: u32 = 64;
/// Seconds a message (screenshot written, mode refused) stays on screen.
const MESSAGE_SECONDS: f32 = 4.0;

/// What a key does (the window maps keys to these; see [`KEYS`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Action {
    Mode(RenderMode),
    /// Path: the next filter; points: the next fill.
    CycleFilter,
    MoreSamples,
    FewerSamples,
    MoreBounces,
    FewerBounces,
    /// Finer / coarser resolution at rest (divisor 1, 2, 3, 4).
    FinerResolution,
    CoarserResolution,
    ToggleAdaptive,
    CycleDisplay,
    ToggleCamera,
    ResetCamera,
    ToggleAnimation,
    ToggleOverlay,
    ToggleHelp,
    Screenshot,
    Quit,
}

/// The key help shown on screen (H): key, what it does.
pub const KEYS: [(&str, &str); 16] = [
    ("1 2 3", "Whitted / path / points"),
    ("F", "filter (path): guided, A-Trous, bilateral, off; fill (points)"),
    ("- =", "fewer / more samples per frame (path)"),
    ("[ ]", "fewer / more bounces (path), max depth (Whitted)"),
    (", .", "coarser / finer resolution"),
    ("R", "adaptive resolution while moving on/off"),
    ("V", "display: beauty, normal, depth, albedo, direct, indirect"),
    ("C", "camera: fly / orbit"),
    ("Home", "back to the first view"),
    ("WASD QE", "move (shift: faster); orbit: W/S dolly"),
    ("mouse", "drag: look (fly) / turn (orbit); wheel: zoom"),
    ("Space", "play / pause animations"),
    ("P F12", "screenshot: PNG + AOV EXR"),
    ("Tab", "statistics on / off"),
    ("H", "this help"),
    ("Esc", "quit"),
];

/// How the viewer starts.
#[derive(Clone, Debug)]
pub struct ViewerOptions {
    pub width: u32,
    pub height: u32,
    /// None: the scene's mode (points for a cloud-only scene).
    pub mode: Option<RenderMode>,
    pub control: ControlMode,
    /// Starting settings (spp, bounces, filter, points settings); width/height/mode are set
    /// from the fields above.
    pub settings: Option<ViewSettings>,
    /// Where screenshots go.
    pub screenshot_dir: PathBuf,
    /// Whitted passes / path samples per pixel after which a resting picture is final.
    pub max_accumulation: u32,
    pub adaptive: bool,
}

impl Default for ViewerOptions {
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
            mode: None,
            control: ControlMode::Orbit,
            settings: None,
            screenshot_dir: PathBuf::from("."),
            max_accumulation: 1024,
            adaptive: true,
        }
    }
}

/// What one call of [`Viewer::frame`] did.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameOutcome {
    /// A frame was drawn (false: the picture is final and nothing moved).
    pub drew: bool,
    /// The frame started the picture over (as opposed to refining it).
    pub restarted: bool,
    /// Render size of the frame.
    pub render_size: (u32, u32),
    pub stats: FrameStats,
}

pub struct Viewer {
    renderer: Renderer,
    pub camera: CameraController,
    home: CameraController,
    /// The window's size and the current settings.
    pub settings: ViewSettings,
    pub display: Display,
    pub show_stats: bool,
    pub show_help: bool,
    /// Resolution divisor at rest (1 = the window's resolution).
    pub divisor: u32,
    pub adaptive: bool,
    /// Measured cost of a fresh frame, per mode (Whitted, path, points), ms per pixel.
    ms_per_pixel: [f64; 3],
    pub time: f32,
    pub playing: bool,
    /// Something changed that invalidates the picture.
    dirty: bool,
    last_camera: Option<Camera>,
    frame_pixels: Vec<u32>,
    /// The window's frame (0RGB, width × height).
    pixels: Vec<u32>,
    last: FrameOutcome,
    /// Frames per second over recent frames (from the window's clock).
    fps: f64,
    message: Option<(String, f32)>,
    screenshot_dir: PathBuf,
    max_accumulation: u32,
    title: String,
}

impl Viewer {
    /// A viewer of `scene` (clouds already prepared) named `title` on screen.
    pub fn new(scene: Scene, title: &str, options: ViewerOptions) -> Result<Self, ViewError> {
        if !glint_scene::scene::image_size_ok(options.width, options.height) {
            return Err(ViewError::Setting(format!("window size {}x{}", options.width, options.height)));
        }
        let bounds = scene.bounds();
        let camera = CameraController::new(&scene.camera, bounds, options.control);
        let defaults = scene.render;
        let renderer = Renderer::new(scene)?;
        let mut mode = options.mode.unwrap_or(defaults.mode);
        if options.mode.is_none() && !renderer.supports(mode) {
            mode =
                [RenderMode::Points, RenderMode::Whitted].into_iter().find(|m| renderer.supports(*m)).unwrap_or(mode);
        }
        if !renderer.supports(mode) {
            return Err(ViewError::Setting(format!(
                "the {} mode has nothing to draw in this scene ({})",
                mode.name(),
                if mode == RenderMode::Points { "no point clouds" } else { "only point clouds" }
            )));
        }
        let mut settings =
            options.settings.unwrap_or_else(|| ViewSettings::new(options.width, options.height, mode, &defaults));
        settings.width = options.width;
        settings.height = options.height;
        settings.mode = mode;
        settings.modes.path.validate()?;
        settings.modes.whitted.validate()?;
        Ok(Self {
            renderer,
            camera,
            home: camera,
            settings,
            display: Display::Beauty,
            show_stats: true,
            show_help: false,
            divisor: 1,
            adaptive: options.adaptive,
            ms_per_pixel: [0.0; 3],
            time: 0.0,
            playing: true,
            dirty: true,
            last_camera: None,
            frame_pixels: Vec::new(),
            pixels: vec![0; options.width as usize * options.height as usize],
            last: FrameOutcome::default(),
            fps: 0.0,
            message: None,
            screenshot_dir: options.screenshot_dir,
            max_accumulation: options.max_accumulation.max(1),
            title: title.to_string(),
        })
    }

    /// The window's frame: 0RGB words, width × height.
    pub fn pixels(&self) -> &[u32] {
        &self.pixels
    }

    pub fn size(&self) -> (u32, u32) {
        (self.settings.width, self.settings.height)
    }

    pub fn renderer(&self) -> &Renderer {
        &self.renderer
    }

    /// The last frame's outcome.
    pub fn last(&self) -> &FrameOutcome {
        &self.last
    }

    /// The window changed size (zero sizes, as when minimised, are ignored).
    pub fn resize(&mut self, width: u32, height: u32) {
        if width == 0
            || height == 0
            || (width, height) == self.size()
            || !glint_scene::scene::image_size_ok(width, height)
        {
            return;
        }
        self.settings.width = width;
        self.settings.height = height;
        self.pixels = vec![0; width as usize * height as usize];
        self.dirty = true;
    }

    /// Show `text` on screen for a few seconds.
    pub fn say(&mut self, text: impl Into<String>) {
        self.message = Some((text.into(), MESSAGE_SECONDS));
    }

    /// The picture at rest is final: no frame needs drawing until something changes.
    pub fn is_idle(&self) -> bool {
        let animating = self.playing && self.renderer.scene().is_animated();
        !self.dirty
            && !animating
            && self.message.is_none()
            && self.final_picture()
            && self.renderer.size() == self.rest_size()
            && self.last_camera == Some(self.camera.camera())
    }

    /// The render size at rest.
    fn rest_size(&self) -> (u32, u32) {
        let (w, h) = self.size();
        ((w / self.divisor).max(1), (h / self.divisor).max(1))
    }

    fn final_picture(&self) -> bool {
        let cap = match self.settings.mode {
            RenderMode::Points => 1,
            RenderMode::Whitted => self.max_accumulation.min(WHITTED_MAX_PASSES),
            RenderMode::Path => self.max_accumulation,
        };
        self.renderer.accumulated() >= cap
    }

    /// Apply a key's action. Returns false for [`Action::Quit`].
    pub fn apply(&mut self, action: Action) -> Result<bool, ViewError> {
        let s = &mut self.settings;
        match action {
            Action::Quit => return Ok(false),
            Action::Mode(m) => {
                if self.renderer.supports(m) {
                    s.mode = m;
                    if m != RenderMode::Path && matches!(self.display, Display::Direct | Display::Indirect) {
                        self.display = Display::Beauty;
                    }
                } else {
                    let why = if m == RenderMode::Points { "no point clouds" } else { "only point clouds" };
                    self.say(format!("{} mode: this scene has {why}", m.name()));
                    return Ok(true);
                }
            }
            Action::CycleFilter => match s.mode {
                RenderMode::Points => {
                    s.modes.points.fill = match s.modes.points.fill {
                        Fill::Ellipses => Fill::PullPush,
                        Fill::PullPush => Fill::Raw,
                        Fill::Raw => Fill::Squares,
                        Fill::Squares => Fill::Ellipses,
                    }
                }
                _ => s.filter = next_filter(s.filter),
            },
            Action::MoreSamples => s.modes.path.spp = (s.modes.path.spp * 2).min(64),
            Action::FewerSamples => s.modes.path.spp = (s.modes.path.spp / 2).max(1),
            Action::MoreBounces | Action::FewerBounces => {
                let up = action == Action::MoreBounces;
                let step = |v: u32, range: &std::ops::RangeInclusive<u32>| {
                    if up { (v + 1).min(*range.end()) } else { v.saturating_sub(1).max(*range.start()) }
                };
                match s.mode {
                    RenderMode::Whitted => {
                        s.modes.whitted.max_depth = step(s.modes.whitted.max_depth, &limits::MAX_DEPTH)
                    }
                    _ => s.modes.path.max_bounces = step(s.modes.path.max_bounces, &limits::MAX_BOUNCES),
                }
            }
            Action::FinerResolution => self.divisor = (self.divisor - 1).max(1),
            Action::CoarserResolution => self.divisor = (self.divisor + 1).min(4),
            Action::ToggleAdaptive => self.adaptive = !self.adaptive,
            Action::CycleDisplay => {
                self.display = self.display.next(s.mode == RenderMode::Path);
                self.redisplay();
                return Ok(true);
            }
            Action::ToggleCamera => {
                let mode = match self.camera.mode {
                    ControlMode::Fly => ControlMode::Orbit,
                    ControlMode::Orbit => ControlMode::Fly,
                };
                self.camera.set_mode(mode);
                return Ok(true);
            }
            Action::ResetCamera => {
                let mode = self.camera.mode;
                self.camera = self.home;
                self.camera.set_mode(mode);
            }
            Action::ToggleAnimation => {
                self.playing = !self.playing;
                return Ok(true);
            }
            Action::ToggleOverlay => {
                self.show_stats = !self.show_stats;
                self.redisplay();
                return Ok(true);
            }
            Action::ToggleHelp => {
                self.show_help = !self.show_help;
                self.redisplay();
                return Ok(true);
            }
            Action::Screenshot => {
                match self.screenshot() {
                    Ok((png, exr)) => self.say(format!("saved {} and {}", png.display(), exr.display())),
                    Err(e) => self.say(format!("screenshot failed: {e}")),
                }
                return Ok(true);
            }
        }
        self.dirty = true;
        Ok(true)
    }

    /// Advance by `dt` seconds with `input`: move the camera, play animations, draw (or refine,
    /// or keep) the picture, and compose the window's frame.
    pub fn frame(&mut self, input: &InputState, dt: f32) -> Result<&FrameOutcome, ViewError> {
        let dt = if dt.is_finite() { dt.clamp(0.0, 0.25) } else { 0.0 };
        if let Some((_, left)) = self.message.as_mut() {
            *left -= dt;
            if *left <= 0.0 {
                self.message = None;
            }
        }
        let mut moving = self.camera.update(input, dt);
        if self.playing && self.renderer.scene().is_animated() {
            self.time += dt;
            moving |= self.renderer.set_time(self.time);
        }
        let camera = self.camera.camera();
        let mode_index = self.settings.mode as usize;
        let divisor = if moving && self.adaptive { self.moving_divisor(mode_index) } else { self.divisor };
        let (w, h) = self.size();
        let (rw, rh) = ((w / divisor).max(1), (h / divisor).max(1));
        let restart = moving || self.dirty || self.last_camera != Some(camera) || (rw, rh) != self.renderer.size();
        if !restart && self.final_picture() {
            self.last.drew = false;
            self.last.restarted = false;
            if self.message.is_some() {
                self.redisplay();
            }
            return Ok(&self.last);
        }
        let (image, mode) = self.settings.frame(rw, rh);
        let stats = self.renderer.add_pass(&camera, &image, &mode, restart, &Hooks::default())?;
        if restart {
            let ms = ms(stats.elapsed) / (rw as f64 * rh as f64);
            let old = self.ms_per_pixel[mode_index];
            self.ms_per_pixel[mode_index] = if old == 0.0 { ms } else { 0.5 * (old + ms) };
        }
        self.dirty = false;
        self.last_camera = Some(camera);
        if dt > 0.0 {
            let fps = 1.0 / dt as f64;
            self.fps = if self.fps == 0.0 { fps } else { 0.8 * self.fps + 0.2 * fps };
        }
        self.last = FrameOutcome { drew: true, restarted: restart, render_size: (rw, rh), stats };
        self.redisplay();
        Ok(&self.last)
    }

    /// The adaptive divisor: the finest whose predicted frame time fits the target.
    fn moving_divisor(&self, mode_index: usize) -> u32 {
        let per_pixel = self.ms_per_pixel[mode_index];
        if per_pixel == 0.0 {
            return self.divisor.max(2);
        }
        let (w, h) = self.size();
        let pixels = w as f64 * h as f64;
        DIVISORS
            .into_iter()
            .filter(|&d| d >= self.divisor)
            .find(|&d| per_pixel * pixels / (d as f64 * d as f64) <= TARGET_FRAME_MS)
            .unwrap_or(DIVISORS[DIVISORS.len() - 1])
    }

    /// Compose the window's frame from the film: channel, upscale, statistics.
    fn redisplay(&mut self) {
        match self.renderer.picture() {
            Picture::Film(film) => display(film, self.display, &mut self.frame_pixels),
            Picture::Points(frame) => display_points(frame, self.display, &mut self.frame_pixels),
        }
        let (fw, fh) = self.renderer.size();
        let (w, h) = (self.settings.width as usize, self.settings.height as usize);
        if (fw as usize, fh as usize) == (w, h) {
            self.pixels.copy_from_slice(&self.frame_pixels);
        } else {
            upscale(&self.frame_pixels, fw as usize, fh as usize, &mut self.pixels, w, h);
        }
        let mut lines = Vec::new();
        if self.show_stats {
            lines = self.stats_lines();
        }
        if self.show_help {
            lines.push(String::new());
            lines.extend(KEYS.iter().map(|(k, what)| format!("{k:>8}  {what}")));
        }
        if let Some((m, _)) = &self.message {
            lines.push(m.clone());
        }
        overlay::draw_text(&mut self.pixels, w, h, &lines, overlay::scale_for(w));
    }

    /// The statistics block.
    pub fn stats_lines(&self) -> Vec<String> {
        let s = &self.settings;
        let o = &self.last;
        let (rw, rh) = o.render_size;
        let reduced =
            if (rw, rh) != self.size() && rw > 0 { format!(" (1/{})", s.width / rw.max(1)) } else { String::new() };
        let m = &s.modes;
        let what = match s.mode {
            RenderMode::Whitted => format!("max depth {}", m.whitted.max_depth),
            RenderMode::Path => {
                format!("filter {}, {} spp/frame, {} bounces", filter_name(s.filter), m.path.spp, m.path.max_bounces)
            }
            RenderMode::Points => format!("fill {:?}", m.points.fill).to_lowercase(),
        };
        let mut lines = vec![
            format!("{}  |  {}  {}x{}{reduced}  |  {what}", self.title, s.mode.name(), rw, rh),
            format!(
                "{} fps  {:.1} ms:  {}",
                if self.fps > 0.0 { format!("{:.1}", self.fps) } else { "-".into() },
                ms(o.stats.elapsed),
                o.stats.stages.iter().map(|(n, d)| format!("{n} {:.1}", ms(*d))).collect::<Vec<_>>().join("  ")
            ),
        ];
        let accumulated = match s.mode {
            RenderMode::Whitted => format!("{} passes", self.renderer.accumulated()),
            RenderMode::Path => format!("{} spp", self.renderer.accumulated()),
            RenderMode::Points => "exact".into(),
        };
        let (rate, unit) = rate(&o.stats);
        let paths =
            if o.stats.paths > 0 { format!("  {:.2} M paths/s", o.stats.mpaths_per_second()) } else { String::new() };
        lines.push(format!(
            "{rate:.1} {unit}{paths}  |  {accumulated}  |  display {}  |  camera {:?}{}",
            self.display.name(),
            self.camera.mode,
            if self.adaptive { "" } else { "  |  fixed resolution" }
        ));
        if self.renderer.scene().is_animated() {
            lines.push(format!("animation {:.2} s{}", self.time, if self.playing { "" } else { " (paused)" }));
        }
        if !self.show_help {
            lines.push("H: keys".into());
        }
        lines
    }

    /// Write the picture: the beauty as PNG and every AOV as EXR, under the next free
    /// `glint-view-NNN` name in the screenshot folder (nothing is overwritten).
    pub fn screenshot(&mut self) -> Result<(PathBuf, PathBuf), ViewError> {
        let (png, exr) = next_free_names(&self.screenshot_dir)?;
        let film = self.renderer.film();
        glint_image::write_png_srgb8(
            &png,
            film.width,
            film.height,
            false,
            &film.encode_srgb8(&glint_image::PngOptions::default()),
        )
        .map_err(|e| ViewError::Write(png.clone(), e.to_string()))?;
        glint_image::write_exr(&exr, &film.aov_image()).map_err(|e| ViewError::Write(exr.clone(), e.to_string()))?;
        Ok((png, exr))
    }
}

fn next_free_names(dir: &Path) -> Result<(PathBuf, PathBuf), ViewError> {
    for n in 1..10_000 {
        let png = dir.join(format!("glint-view-{n:03}.png"));
        let exr = dir.join(format!("glint-view-{n:03}.exr"));
        if !png.exists() && !exr.exists() {
            return Ok((png, exr));
        }
    }
    Err(ViewError::Write(dir.to_path_buf(), "no free glint-view-NNN name left".into()))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use glint_core::Vec2;
    use glint_filter::FilterKind;
    use glint_scene::{AnimationTarget, Motion, Rotation};

    fn viewer(mode: RenderMode, w: u32, h: u32) -> Viewer {
        let options =
            ViewerOptions { width: w, height: h, mode: Some(mode), max_accumulation: 6, ..Default::default() };
        Viewer::new(glint_testkit::scenes::cloud_and_sphere(), "test", options).unwrap()
    }

    fn turn() -> InputState {
        InputState { look: Vec2::new(30.0, 0.0), ..InputState::default() }
    }

    #[test]
    fn a_resting_picture_refines_until_final_then_frames_cost_nothing() {
        for mode in [RenderMode::Whitted, RenderMode::Path] {
            let mut v = viewer(mode, 64, 40);
            let rest = InputState::default();
            let mut drawn = 0;
            for _ in 0..10 {
                if v.frame(&rest, 0.02).unwrap().drew {
                    drawn += 1;
                }
            }
            assert_eq!(drawn, 6, "{mode:?}: refines to max_accumulation, then stops");
            assert!(v.is_idle());
            assert_eq!(v.renderer().accumulated(), 6);
            assert_eq!(v.pixels().len(), 64 * 40);
            // Moving starts over.
            let o = v.frame(&turn(), 0.02).unwrap();
            assert!(o.drew && o.restarted);
            assert!(!v.is_idle());
        }
        // Points: one frame is final.
        let mut v = viewer(RenderMode::Points, 64, 40);
        assert!(v.frame(&InputState::default(), 0.02).unwrap().drew);
        assert!(!v.frame(&InputState::default(), 0.02).unwrap().drew);
        assert!(v.is_idle());
    }

    #[test]
    fn moving_frames_drop_resolution_to_keep_the_frame_rate_and_rest_restores_it() {
        let mut v = viewer(RenderMode::Path, 320, 200);
        v.frame(&InputState::default(), 0.02).unwrap();
        // Pretend the path mode costs 1 ms a pixel: only the coarsest divisor fits 33 ms, and
        // it cannot fit; the coarsest is used.
        v.ms_per_pixel[RenderMode::Path as usize] = 1.0;
        let o = v.frame(&turn(), 0.02).unwrap().clone();
        assert_eq!(o.render_size, (320 / 12, 200 / 12));
        // The frame is still the window's size, scaled up.
        assert_eq!(v.pixels().len(), 320 * 200);
        // Cheap enough for full size: full size.
        v.ms_per_pixel[RenderMode::Path as usize] = 1e-7;
        assert_eq!(v.frame(&turn(), 0.02).unwrap().render_size, (320, 200));
        // 4× too slow at full size: divisor 2 (a quarter of the pixels).
        v.ms_per_pixel[RenderMode::Path as usize] = 4.0 * TARGET_FRAME_MS / (320.0 * 200.0);
        assert_eq!(v.frame(&turn(), 0.02).unwrap().render_size, (160, 100));
        // At rest: the full size again, refining from there.
        let o = v.frame(&InputState::default(), 0.02).unwrap().clone();
        assert!(o.restarted && o.render_size == (320, 200));
        assert!(!v.frame(&InputState::default(), 0.02).unwrap().restarted);
        // Fixed resolution: moving frames stay full size.
        v.apply(Action::ToggleAdaptive).unwrap();
        assert_eq!(v.frame(&turn(), 0.02).unwrap().render_size, (320, 200));
        // The user's coarser resolution holds at rest.
        v.apply(Action::CoarserResolution).unwrap();
        assert_eq!(v.frame(&InputState::default(), 0.02).unwrap().render_size, (160, 100));
    }

    #[test]
    fn keys_switch_modes_filters_and_channels() {
        let mut v = viewer(RenderMode::Whitted, 48, 32);
        v.frame(&InputState::default(), 0.02).unwrap();
        let whitted = v.pixels().to_vec();
        v.apply(Action::Mode(RenderMode::Path)).unwrap();
        assert_eq!(v.settings.mode, RenderMode::Path);
        assert!(v.frame(&InputState::default(), 0.02).unwrap().restarted);
        assert_ne!(v.pixels(), &whitted[..]);
        let filters: Vec<FilterKind> = (0..4)
            .map(|_| {
                v.apply(Action::CycleFilter).unwrap();
                v.settings.filter
            })
            .collect();
        assert_eq!(filters, [FilterKind::Atrous, FilterKind::Bilateral, FilterKind::None, FilterKind::Guided]);
        v.apply(Action::MoreSamples).unwrap();
        v.apply(Action::MoreBounces).unwrap();
        assert_eq!((v.settings.modes.path.spp, v.settings.modes.path.max_bounces), (2, 2));
        v.apply(Action::FewerBounces).unwrap();
        v.apply(Action::FewerBounces).unwrap();
        v.apply(Action::FewerBounces).unwrap();
        assert_eq!(v.settings.modes.path.max_bounces, 0);
        v.frame(&InputState::default(), 0.02).unwrap();
        // Every channel shows something different (the overlay is off to compare pictures).
        v.apply(Action::ToggleOverlay).unwrap();
        let mut seen = vec![v.pixels().to_vec()];
        for _ in 0..5 {
            v.apply(Action::CycleDisplay).unwrap();
            seen.push(v.pixels().to_vec());
        }
        assert_eq!(v.display, Display::Indirect);
        for i in 0..seen.len() {
            for j in i + 1..seen.len() {
                // Indirect light is zero with zero bounces: its picture may equal another's
                // only if both are black.
                assert!(seen[i] != seen[j] || seen[i].iter().all(|&p| p == 0), "channels {i} and {j} look alike");
            }
        }
        // Leaving the path mode leaves its channels.
        v.apply(Action::Mode(RenderMode::Points)).unwrap();
        assert_eq!(v.display, Display::Beauty);
        // A mode with nothing to draw is refused with a message, not an error.
        let mut s = glint_testkit::scenes::cloud_and_sphere();
        s.clouds.clear();
        let mut v = Viewer::new(s, "t", ViewerOptions { width: 32, height: 32, ..Default::default() }).unwrap();
        assert!(v.apply(Action::Mode(RenderMode::Points)).unwrap());
        assert_eq!(v.settings.mode, RenderMode::Whitted);
        assert!(v.message.as_ref().is_some_and(|(m, _)| m.contains("no point clouds")));
        assert!(!v.apply(Action::Quit).unwrap());
    }

    #[test]
    fn the_statistics_name_the_stages_and_the_rate() {
        let mut v = viewer(RenderMode::Path, 64, 40);
        v.frame(&InputState::default(), 0.05).unwrap();
        v.frame(&InputState::default(), 0.05).unwrap();
        let text = v.stats_lines().join("\n");
        for needle in ["path", "64x40", "fps", "trace", "filter", "Mrays/s", "M paths/s", "2 spp", "guided"] {
            assert!(text.contains(needle), "{needle:?} missing from {text}");
        }
        // The overlay is drawn: white text pixels in the top-left corner.
        assert!(v.pixels()[..64 * 12].contains(&0x00ff_ffff));
        let mut v = viewer(RenderMode::Points, 64, 40);
        v.frame(&InputState::default(), 0.05).unwrap();
        let text = v.stats_lines().join("\n");
        for needle in ["points", "project", "pull-push", "shade", "Mpoints/s"] {
            assert!(text.contains(needle), "{needle:?} missing from {text}");
        }
    }

    #[test]
    fn screenshots_write_png_and_aov_exr_without_overwriting() {
        let dir = std::env::temp_dir().join(format!("glint-view-shots-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let options = ViewerOptions {
            width: 40,
            height: 30,
            mode: Some(RenderMode::Path),
            screenshot_dir: dir.clone(),
            ..Default::default()
        };
        let mut v = Viewer::new(glint_testkit::scenes::cloud_and_sphere(), "t", options).unwrap();
        v.frame(&InputState::default(), 0.02).unwrap();
        let (png, exr) = v.screenshot().unwrap();
        assert!(png.ends_with("glint-view-001.png") && exr.ends_with("glint-view-001.exr"));
        let image = glint_image::read_image(&png).unwrap();
        assert_eq!((image.width, image.height), (40, 30));
        let aovs = glint_image::read_image(&exr).unwrap();
        for channel in ["R", "G", "B", "Ns.X", "Z", "Albedo.R", "Direct.R", "Indirect.R"] {
            assert!(aovs.channel(channel).is_some(), "{channel} missing");
        }
        v.apply(Action::Screenshot).unwrap();
        assert!(dir.join("glint-view-002.png").exists() && dir.join("glint-view-002.exr").exists());
        // A folder that does not exist: an error on screen, not a panic.
        v.screenshot_dir = dir.join("missing");
        assert!(v.screenshot().is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn animations_play_restart_the_picture_and_pause() {
        // The ball orbits the origin (about its own centre it would look still).
        let rotation = Rotation {
            axis: glint_core::Vec3::Z,
            pivot: Some(glint_core::Vec3::ZERO),
            degrees_per_second: 90.0,
            phase_deg: 0.0,
        };
        let mut scene2 = glint_testkit::scenes::cloud_and_sphere();
        scene2.animate(&[AnimationTarget::Object(0)], Motion { rotation: Some(rotation), translation: None }).unwrap();
        let options = ViewerOptions { width: 48, height: 32, mode: Some(RenderMode::Path), ..Default::default() };
        let mut v = Viewer::new(scene2, "t", options).unwrap();
        v.apply(Action::ToggleOverlay).unwrap();
        let rest = InputState::default();
        let mut frames = Vec::new();
        for _ in 0..3 {
            let o = v.frame(&rest, 0.25).unwrap();
            assert!(o.drew && o.restarted, "playing: every frame starts over");
            frames.push(v.pixels().to_vec());
        }
        assert!(v.time > 0.7);
        assert_ne!(frames[0], frames[2], "the ball moved");
        assert!(!v.is_idle());
        v.apply(Action::ToggleAnimation).unwrap();
        let o = v.frame(&rest, 0.25).unwrap();
        assert!(o.drew && !o.restarted, "paused: the picture refines");
        let t = v.time;
        v.frame(&rest, 0.25).unwrap();
        assert_eq!(v.time, t);
    }
}
