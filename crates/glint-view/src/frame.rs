//! One frame of any mode, with the time of each stage: what the window shows and what the
//! headless benchmark measures.
//!
//! The renderers are built once (BVHs, the points' Morton layout) and reused for every frame;
//! only the camera (and, for animated scenes, the top level of the BVH) changes. A frame either
//! starts a picture afresh (the camera moved, a setting changed) or *refines* the one on screen:
//! the Whitted mode adds a jittered pass (supersampling, converging to the N×N stratified
//! image), the path mode adds samples to its accumulation and filters the accumulation
//! ([`PathAccumulator`]). The points mode is exact in one pass and has nothing to refine.
//! Whitted and path frames trace the scene's objects; a points frame draws its clouds and lays
//! traced objects over them by depth, as `glint render --mode points` does.

use crate::display::{Display, display, display_points};
use glint_filter::{AtrousParams, BilateralParams, Filter, GuidedParams};
use glint_render::path::PathAccumulator;
use glint_render::{
    Film, PathSettings, PointFrame, PointRenderer, PointSettings, RenderError, RenderSettings, World, render_pass,
};
use glint_scene::{Camera, Scene};
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ViewMode {
    #[default]
    Whitted,
    Path,
    Points,
}

impl ViewMode {
    pub fn name(self) -> &'static str {
        match self {
            ViewMode::Whitted => "Whitted",
            ViewMode::Path => "path",
            ViewMode::Points => "points",
        }
    }
}

/// The path mode's filter of the indirect light, switchable in the window; its parameters
/// follow the render width (as `glint render` sets them).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterKind {
    #[default]
    Guided,
    Atrous,
    Bilateral,
    None,
}

impl FilterKind {
    pub fn name(self) -> &'static str {
        match self {
            FilterKind::Guided => "guided 4-D",
            FilterKind::Atrous => "A-Trous",
            FilterKind::Bilateral => "bilateral",
            FilterKind::None => "off",
        }
    }

    pub fn next(self) -> FilterKind {
        match self {
            FilterKind::Guided => FilterKind::Atrous,
            FilterKind::Atrous => FilterKind::Bilateral,
            FilterKind::Bilateral => FilterKind::None,
            FilterKind::None => FilterKind::Guided,
        }
    }

    /// The filter for an image `width` pixels wide.
    pub fn filter(self, width: u32) -> Filter {
        let w = width as usize;
        match self {
            FilterKind::Guided => Filter::Guided(GuidedParams::for_width(w)),
            FilterKind::Atrous => Filter::Atrous(AtrousParams::default()),
            FilterKind::Bilateral => Filter::Bilateral(BilateralParams::for_width(w)),
            FilterKind::None => Filter::None,
        }
    }
}

/// What a frame is drawn with (the render size is the window's over the resolution divisor).
#[derive(Clone, Debug)]
pub struct ViewSettings {
    pub width: u32,
    pub height: u32,
    pub mode: ViewMode,
    /// Path mode: samples per pixel per frame, bounces; `path.filter` is replaced by `filter`.
    pub path: PathSettings,
    pub filter: FilterKind,
    /// Whitted: the deepest reflection/refraction chain.
    pub max_depth: u32,
    pub points: PointSettings,
    pub seed: u64,
}

impl ViewSettings {
    pub fn new(width: u32, height: u32, mode: ViewMode) -> Self {
        Self {
            width,
            height,
            mode,
            path: PathSettings { max_bounces: 1, ..PathSettings::default() },
            filter: FilterKind::Guided,
            max_depth: 8,
            points: PointSettings::new(width, height),
            seed: 0,
        }
    }
}

/// Where one frame's time went.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    pub total_ms: f64,
    /// Named stages in order (trace, filter, project, pull-push, shade).
    pub stages: Vec<(&'static str, f64)>,
    /// Rays (Whitted, path) or points (points mode) per second, in millions.
    pub mrate: f64,
    /// "Mrays/s" or "Mpoints/s".
    pub rate_unit: &'static str,
    /// Passes (Whitted) or samples per pixel (path) in the picture now; 1 for points.
    pub accumulated: u32,
}

/// The renderers of one scene and the picture they are refining.
pub struct FrameRenderer {
    world: Option<World>,
    points: Option<PointRenderer>,
    point_frame: PointFrame,
    /// The scene (lights, materials, sky) for the points mode; the world holds its own copy.
    scene: Scene,
    /// The picture so far (beauty + AOVs) at the render size.
    film: Film,
    /// Whitted: the sum of the passes' colours.
    whitted_sum: Vec<glint_core::Rgb>,
    path: PathAccumulator,
    /// Passes in the picture (0: nothing drawn yet).
    passes: u32,
    /// The picture is `point_frame` (clouds alone), not `film`.
    points_picture: bool,
    /// `film` holds a copy of `point_frame` (made on demand).
    film_synced: bool,
}

impl FrameRenderer {
    /// Build what the scene's content needs: a BVH world for its objects, the points layout
    /// for its clouds.
    pub fn new(scene: Scene) -> Result<Self, RenderError> {
        let points = if scene.clouds.is_empty() { None } else { Some(PointRenderer::new(&scene)?) };
        let world = if scene.objects.is_empty() { None } else { Some(World::new(scene.clone())) };
        Ok(Self {
            world,
            points,
            point_frame: PointFrame::default(),
            scene,
            film: Film::new(1, 1),
            whitted_sum: Vec::new(),
            path: PathAccumulator::new(),
            passes: 0,
            points_picture: false,
            film_synced: false,
        })
    }

    /// The modes this scene can be drawn in.
    pub fn supports(&self, mode: ViewMode) -> bool {
        match mode {
            ViewMode::Whitted | ViewMode::Path => self.world.is_some(),
            ViewMode::Points => self.points.is_some(),
        }
    }

    /// The scene as drawn now (animated to the current time).
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// Move the scene's animations to time `t` (seconds): only the top level of the BVH is
    /// rebuilt. Returns whether anything moved (the picture must then start over).
    pub fn set_time(&mut self, t: f32) -> bool {
        if !self.scene.is_animated() {
            return false;
        }
        self.scene.set_time(t);
        match self.world.as_mut() {
            Some(w) => w.set_time(t),
            None => true,
        }
    }

    /// The picture so far as a film (the render size; beauty + AOVs). A points frame is
    /// copied into the film only when asked (a screenshot): the display reads it directly.
    pub fn film(&mut self) -> &Film {
        if self.points_picture && !self.film_synced {
            self.point_frame.write_film(&mut self.film);
            self.film_synced = true;
        }
        &self.film
    }

    /// The picture's size (the render size of the last frame).
    pub fn size(&self) -> (u32, u32) {
        match self.points_picture {
            true => (self.point_frame.width, self.point_frame.height),
            false => (self.film.width, self.film.height),
        }
    }

    /// The picture's channel `what` as 0RGB words (its own size).
    pub fn show(&self, what: Display, pixels: &mut Vec<u32>) {
        match self.points_picture {
            true => display_points(&self.point_frame, what, pixels),
            false => display(&self.film, what, pixels),
        }
    }

    /// Passes (Whitted) or samples per pixel (path) in the picture.
    pub fn accumulated(&self) -> u32 {
        match self.passes {
            0 => 0,
            _ if !self.points_picture && self.film.path_aovs => self.path.samples_per_pixel(),
            p => p,
        }
    }

    /// Draw a frame seen by `camera`: afresh, or (`refine`, same camera and settings as the
    /// previous frame) adding to the picture. The points mode does not refine: a refining
    /// frame returns at once with no stages.
    pub fn draw(&mut self, camera: &Camera, settings: &ViewSettings, refine: bool) -> Result<FrameStats, RenderError> {
        if !self.supports(settings.mode) {
            return Err(RenderError::InvalidSetting(match settings.mode {
                ViewMode::Points => "this scene has no point clouds for the points mode".into(),
                _ => "this scene has only point clouds: the ray-tracing modes have nothing to trace".into(),
            }));
        }
        let size_changed = self.size() != (settings.width, settings.height);
        if settings.mode != ViewMode::Points || !refine {
            // Whatever is drawn next replaces the points picture (a refining points frame
            // keeps it).
            self.points_picture = false;
        }
        let refine = refine && self.passes > 0 && !size_changed;
        let start = Instant::now();
        let render_settings = RenderSettings {
            width: settings.width,
            height: settings.height,
            samples_per_side: 1,
            max_depth: settings.max_depth,
            seed: settings.seed,
            ..RenderSettings::from_defaults(&self.scene.render)
        };
        let mut stats = FrameStats { rate_unit: "Mrays/s", ..FrameStats::default() };
        match settings.mode {
            ViewMode::Whitted => {
                let Some(world) = self.world.as_mut() else { unreachable_mode() };
                world.scene.camera = *camera;
                let pass = if refine { self.passes } else { 0 };
                let (film, s) = render_pass(world, &render_settings, pass)?;
                stats.stages.push(("trace", s.elapsed.as_secs_f64() * 1e3));
                stats.mrate = s.mrays_per_second();
                if refine {
                    for (sum, p) in self.whitted_sum.iter_mut().zip(&film.pixels) {
                        *sum += p.colour;
                    }
                    self.passes += 1;
                    let inv = 1.0 / self.passes as f32;
                    for (out, sum) in self.film.pixels.iter_mut().zip(&self.whitted_sum) {
                        out.colour = *sum * inv;
                    }
                } else {
                    self.whitted_sum.clear();
                    self.whitted_sum.extend(film.pixels.iter().map(|p| p.colour));
                    self.film = film;
                    self.passes = 1;
                }
            }
            ViewMode::Path => {
                let Some(world) = self.world.as_mut() else { unreachable_mode() };
                world.scene.camera = *camera;
                if !refine {
                    self.path.reset();
                }
                let filter = settings.filter.filter(settings.width);
                let s = self.path.add_pass(world, &render_settings, &PathSettings { filter, ..settings.path })?;
                let filter_time = self.path.resolve(world, &filter, &mut self.film)?;
                stats.stages.push(("trace", s.trace.as_secs_f64() * 1e3));
                stats.stages.push(("filter", filter_time.as_secs_f64() * 1e3));
                stats.mrate = s.mrays_per_second();
                self.passes = self.path.passes();
            }
            ViewMode::Points => {
                stats.rate_unit = "Mpoints/s";
                if refine {
                    stats.accumulated = 1;
                    return Ok(stats);
                }
                let Some(points) = self.points.as_mut() else { unreachable_mode() };
                let point_settings =
                    PointSettings { width: settings.width, height: settings.height, ..settings.points };
                let s = points.render(&self.scene, camera, &point_settings, &mut self.point_frame)?;
                stats.stages.push(("project", s.project_ms));
                stats.stages.push(("pull-push", s.pull_push_ms));
                stats.stages.push(("shade", s.shade_ms));
                stats.mrate = s.points_per_second() * 1e-6;
                if let Some(world) = self.world.as_mut() {
                    // Traced objects laid over the clouds by depth: in the film.
                    self.point_frame.write_film(&mut self.film);
                    world.scene.camera = *camera;
                    let (meshes, s) = render_pass(world, &render_settings, 0)?;
                    stats.stages.push(("trace", s.elapsed.as_secs_f64() * 1e3));
                    self.film.composite_nearer(&meshes);
                } else {
                    self.points_picture = true;
                    self.film_synced = false;
                }
                self.passes = 1;
            }
        }
        stats.accumulated = self.accumulated();
        stats.total_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(stats)
    }
}

fn unreachable_mode() -> ! {
    // `supports` was checked first.
    unreachable!("mode checked by FrameRenderer::supports")
}

#[cfg(test)]
pub(crate) mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::{CameraController, ControlMode, InputState};
    use glint_core::{Affine3A, Rgb, Vec2, Vec3};
    use glint_scene::{CloudObject, Light, Material, Object, PointCloud, Shape, Sky};
    use std::sync::Arc;

    pub(crate) fn scene() -> Scene {
        let positions: Vec<Vec3> =
            (0..4000).map(|i| Vec3::new((i % 64) as f32 * 0.03 - 1.0, (i / 64) as f32 * 0.03 - 1.0, 0.0)).collect();
        let n = positions.len();
        let cloud = PointCloud {
            name: "grid".into(),
            positions,
            normals: Some(vec![Vec3::Z; n]),
            radii: Some(vec![0.03; n]),
            orientation: glint_scene::Orientation::Oriented,
            ..PointCloud::default()
        };
        Scene {
            camera: Camera { position: Vec3::new(0.0, 0.0, 4.0), ..Camera::default() },
            sky: Sky::Colour(Rgb::new(0.1, 0.2, 0.4)),
            ambient: Rgb::splat(0.1),
            materials: vec![Material::default()],
            lights: vec![Light::Directional { direction: Vec3::NEG_Z, colour: Rgb::ONE, intensity: 1.0 }],
            objects: vec![Object {
                name: "ball".into(),
                shape: Shape::Sphere { centre: Vec3::new(0.8, 0.8, 0.5), radius: 0.3 },
                material: 0,
                world_from_object: Affine3A::IDENTITY,
            }],
            clouds: vec![CloudObject {
                name: "grid".into(),
                cloud: Arc::new(cloud),
                material: 0,
                world_from_object: Affine3A::IDENTITY,
            }],
            ..Scene::default()
        }
    }

    #[test]
    fn every_mode_draws_frames_of_the_scene_as_the_camera_moves() {
        let scene = scene();
        let mut r = FrameRenderer::new(scene.clone()).unwrap();
        let mut camera = CameraController::new(&scene.camera, scene.bounds(), ControlMode::Orbit);
        let mut pixels = Vec::new();
        for mode in [ViewMode::Whitted, ViewMode::Path, ViewMode::Points] {
            assert!(r.supports(mode));
            let settings = ViewSettings::new(64, 48, mode);
            let mut frames = Vec::new();
            for _ in 0..3 {
                let stats = r.draw(&camera.camera(), &settings, false).unwrap();
                r.show(Display::Beauty, &mut pixels);
                assert_eq!(pixels.len(), 64 * 48);
                assert!(stats.total_ms > 0.0 && stats.mrate > 0.0, "{mode:?}: {stats:?}");
                assert!(stats.stages.iter().all(|(_, ms)| ms.is_finite() && *ms >= 0.0));
                assert_eq!(stats.accumulated, 1);
                // Not blank: sky, lit points/sphere.
                let distinct: std::collections::HashSet<u32> = pixels.iter().copied().collect();
                assert!(distinct.len() > 3, "{mode:?}: {} colours", distinct.len());
                frames.push(pixels.clone());
                camera.update(&InputState { look: Vec2::new(40.0, 0.0), ..InputState::default() }, 0.016);
            }
            assert_ne!(frames[0], frames[2], "{mode:?}: the view turned");
        }
    }

    #[test]
    fn resting_frames_refine_and_moving_frames_start_over() {
        let scene = scene();
        let mut r = FrameRenderer::new(scene.clone()).unwrap();
        let camera = scene.camera;
        for mode in [ViewMode::Whitted, ViewMode::Path] {
            let settings = ViewSettings::new(48, 32, mode);
            r.draw(&camera, &settings, false).unwrap();
            let first = r.film().clone();
            for k in 2..=5 {
                let s = r.draw(&camera, &settings, true).unwrap();
                assert_eq!(s.accumulated, k, "{mode:?}");
            }
            assert_ne!(first.pixels, r.film().pixels, "{mode:?}: refinement changes the picture");
            // Starting over gives the first frame again, bit for bit.
            r.draw(&camera, &settings, false).unwrap();
            assert_eq!(r.accumulated(), 1);
            assert!(first.pixels == r.film().pixels, "{mode:?}");
            // A new size cannot refine the old picture.
            let s = r.draw(&camera, &ViewSettings::new(24, 16, mode), true).unwrap();
            assert_eq!((s.accumulated, r.film().width), (1, 24));
        }
        // Points: exact in one pass; a refining frame does nothing.
        let settings = ViewSettings::new(48, 32, ViewMode::Points);
        r.draw(&camera, &settings, false).unwrap();
        let s = r.draw(&camera, &settings, true).unwrap();
        assert!(s.stages.is_empty() && s.accumulated == 1);
        // Clouds alone: the display reads the points frame; the film (screenshots) is the same
        // picture, made on demand.
        let mut clouds = scene.clone();
        clouds.objects.clear();
        let mut r = FrameRenderer::new(clouds).unwrap();
        r.draw(&camera, &settings, false).unwrap();
        let (mut shown, mut from_film) = (Vec::new(), Vec::new());
        for what in Display::ALL {
            r.show(what, &mut shown);
            display(r.film(), what, &mut from_film);
            assert_eq!(shown, from_film, "{what:?}");
            if what == Display::Beauty {
                assert!(shown.iter().collect::<std::collections::HashSet<_>>().len() > 3, "lit points and sky");
            }
        }
        assert_eq!(r.size(), (48, 32));
    }

    #[test]
    fn missing_content_for_a_mode_is_an_error() {
        let mut s = scene();
        s.objects.clear();
        let mut r = FrameRenderer::new(s.clone()).unwrap();
        assert!(!r.supports(ViewMode::Whitted));
        let e = r.draw(&s.camera, &ViewSettings::new(8, 8, ViewMode::Path), false).unwrap_err();
        assert!(e.to_string().contains("only point clouds"));
        let mut s = scene();
        s.clouds.clear();
        let mut r = FrameRenderer::new(s.clone()).unwrap();
        assert!(r.draw(&s.camera, &ViewSettings::new(8, 8, ViewMode::Points), false).is_err());
    }
}
