//! One frame of any mode, drawn into a 0RGB pixel buffer (the format softbuffer presents) with
//! the time of each stage: what the window shows and what the headless benchmark measures.
//!
//! The renderers are built once (BVHs, the points' Morton layout) and reused for every frame;
//! only the camera changes. Whitted and path frames trace the scene's objects; a points frame
//! draws its clouds and lays traced objects over them by depth, as `glint render --mode points`
//! does.

use glint_core::Rgb;
use glint_core::colour::linear_to_srgb;
use glint_render::{
    Film, PathSettings, PointFrame, PointRenderer, PointSettings, RenderError, RenderSettings, World, render_path,
};
use glint_scene::{Camera, Scene};
use rayon::prelude::*;
use std::time::Instant;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ViewMode {
    #[default]
    Whitted,
    Path,
    Points,
}

#[derive(Clone, Debug)]
pub struct ViewSettings {
    pub width: u32,
    pub height: u32,
    pub mode: ViewMode,
    /// Whitted: N×N supersampling; path: `path.spp` is used instead.
    pub samples_per_side: u32,
    pub path: PathSettings,
    pub points: PointSettings,
}

impl ViewSettings {
    pub fn new(width: u32, height: u32, mode: ViewMode) -> Self {
        Self {
            width,
            height,
            mode,
            samples_per_side: 1,
            path: PathSettings::default(),
            points: PointSettings::new(width, height),
        }
    }
}

/// Where one frame's time went.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameStats {
    pub total_ms: f64,
    /// Named stages in order (trace, filter, project, pull-push, shade, display).
    pub stages: Vec<(&'static str, f64)>,
    /// Rays (Whitted, path) or points (points mode) per second, in millions.
    pub mrate: f64,
    /// "Mrays/s" or "Mpoints/s".
    pub rate_unit: &'static str,
}

/// The renderers of one scene, kept from frame to frame.
pub struct FrameRenderer {
    world: Option<World>,
    points: Option<PointRenderer>,
    point_frame: PointFrame,
    /// The scene (lights, materials, sky) for the points mode; the world holds its own copy.
    scene: Scene,
}

impl FrameRenderer {
    /// Build what the scene's content needs: a BVH world for its objects, the points layout
    /// for its clouds.
    pub fn new(scene: Scene) -> Result<Self, RenderError> {
        let points = if scene.clouds.is_empty() { None } else { Some(PointRenderer::new(&scene)?) };
        let world = if scene.objects.is_empty() { None } else { Some(World::new(scene.clone())) };
        Ok(Self { world, points, point_frame: PointFrame::default(), scene })
    }

    /// The modes this scene can be drawn in.
    pub fn supports(&self, mode: ViewMode) -> bool {
        match mode {
            ViewMode::Whitted | ViewMode::Path => self.world.is_some(),
            ViewMode::Points => self.points.is_some(),
        }
    }

    /// Draw one frame seen by `camera` into `pixels` (resized to width × height, 0RGB, sRGB).
    pub fn render(
        &mut self,
        camera: &Camera,
        settings: &ViewSettings,
        pixels: &mut Vec<u32>,
    ) -> Result<FrameStats, RenderError> {
        if !self.supports(settings.mode) {
            return Err(RenderError::InvalidSetting(match settings.mode {
                ViewMode::Points => "this scene has no point clouds for the points mode".into(),
                _ => "this scene has only point clouds: the ray-tracing modes have nothing to trace".into(),
            }));
        }
        let start = Instant::now();
        let render_settings = RenderSettings {
            width: settings.width,
            height: settings.height,
            samples_per_side: settings.samples_per_side,
            ..RenderSettings::from_defaults(&self.scene.render)
        };
        let mut stats = FrameStats::default();
        let film: Film = match settings.mode {
            ViewMode::Whitted | ViewMode::Path => {
                let Some(world) = self.world.as_mut() else { unreachable_mode() };
                world.scene.camera = *camera;
                if settings.mode == ViewMode::Whitted {
                    let (film, s) = glint_render::render(world, &render_settings)?;
                    stats.stages.push(("trace", s.elapsed.as_secs_f64() * 1e3));
                    stats.mrate = s.mrays_per_second();
                    film
                } else {
                    let (film, s) = render_path(world, &render_settings, &settings.path, &|_| {})?;
                    stats.stages.push(("trace", s.trace.as_secs_f64() * 1e3));
                    stats.stages.push(("filter", s.filter.as_secs_f64() * 1e3));
                    stats.mrate = s.mrays_per_second();
                    film
                }
            }
            ViewMode::Points => {
                let Some(points) = self.points.as_mut() else { unreachable_mode() };
                let point_settings =
                    PointSettings { width: settings.width, height: settings.height, ..settings.points };
                let s = points.render(&self.scene, camera, &point_settings, &mut self.point_frame)?;
                stats.stages.push(("project", s.project_ms));
                stats.stages.push(("pull-push", s.pull_push_ms));
                stats.stages.push(("shade", s.shade_ms));
                stats.mrate = s.points_per_second() * 1e-6;
                if let Some(world) = self.world.as_mut() {
                    world.scene.camera = *camera;
                    let (meshes, s) = glint_render::render(world, &render_settings)?;
                    stats.stages.push(("trace", s.elapsed.as_secs_f64() * 1e3));
                    let mut film = self.point_frame.to_film();
                    film.composite_nearer(&meshes);
                    film
                } else {
                    let display = Instant::now();
                    to_pixels(&self.point_frame.colour, pixels);
                    stats.stages.push(("display", display.elapsed().as_secs_f64() * 1e3));
                    stats.rate_unit = "Mpoints/s";
                    stats.total_ms = start.elapsed().as_secs_f64() * 1e3;
                    return Ok(stats);
                }
            }
        };
        let display = Instant::now();
        let colours: Vec<Rgb> = film.pixels.iter().map(|p| p.colour).collect();
        to_pixels(&colours, pixels);
        stats.stages.push(("display", display.elapsed().as_secs_f64() * 1e3));
        stats.rate_unit = if settings.mode == ViewMode::Points { "Mpoints/s" } else { "Mrays/s" };
        stats.total_ms = start.elapsed().as_secs_f64() * 1e3;
        Ok(stats)
    }
}

fn unreachable_mode() -> ! {
    // `supports` was checked first.
    unreachable!("mode checked by FrameRenderer::supports")
}

/// Entries of the linear → 8-bit sRGB table (12 bits of linear input: even the darkest step is
/// under one 8-bit level).
const SRGB_TABLE_SIZE: usize = 4096;

fn srgb_table() -> &'static [u8; SRGB_TABLE_SIZE] {
    static TABLE: std::sync::OnceLock<[u8; SRGB_TABLE_SIZE]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| (linear_to_srgb(i as f32 / (SRGB_TABLE_SIZE - 1) as f32) * 255.0 + 0.5) as u8)
    })
}

/// Linear colours → 0RGB words of 8-bit sRGB (clamped), by table: the display of a frame costs
/// a lookup per channel, not a power.
pub fn to_pixels(colours: &[Rgb], pixels: &mut Vec<u32>) {
    pixels.resize(colours.len(), 0);
    let table = srgb_table();
    let scale = (SRGB_TABLE_SIZE - 1) as f32;
    // NaN clamps to 0 through the saturating cast.
    let q = |v: f32| u32::from(table[((v.clamp(0.0, 1.0) * scale + 0.5) as usize).min(SRGB_TABLE_SIZE - 1)]);
    pixels.par_chunks_mut(4096).zip(colours.par_chunks(4096)).for_each(|(out, c)| {
        for (o, c) in out.iter_mut().zip(c) {
            *o = (q(c.x) << 16) | (q(c.y) << 8) | q(c.z);
        }
    });
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::{CameraController, ControlMode, InputState};
    use glint_core::{Affine3A, Vec2, Vec3};
    use glint_scene::{CloudObject, Light, Material, Object, PointCloud, Shape, Sky};
    use std::sync::Arc;

    fn scene() -> Scene {
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
            let mut settings = ViewSettings::new(64, 48, mode);
            settings.path.max_bounces = 1;
            let mut frames = Vec::new();
            for _ in 0..3 {
                let stats = r.render(&camera.camera(), &settings, &mut pixels).unwrap();
                assert_eq!(pixels.len(), 64 * 48);
                assert!(stats.total_ms > 0.0 && stats.mrate > 0.0, "{mode:?}: {stats:?}");
                assert!(stats.stages.iter().all(|(_, ms)| ms.is_finite() && *ms >= 0.0));
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
    fn missing_content_for_a_mode_is_an_error() {
        let mut s = scene();
        s.objects.clear();
        let mut r = FrameRenderer::new(s.clone()).unwrap();
        assert!(!r.supports(ViewMode::Whitted));
        let e = r.render(&s.camera, &ViewSettings::new(8, 8, ViewMode::Path), &mut Vec::new()).unwrap_err();
        assert!(e.to_string().contains("only point clouds"));
        let mut s = scene();
        s.clouds.clear();
        let mut r = FrameRenderer::new(s.clone()).unwrap();
        assert!(r.render(&s.camera, &ViewSettings::new(8, 8, ViewMode::Points), &mut Vec::new()).is_err());
    }

    #[test]
    fn pixels_are_srgb_words() {
        let mut p = Vec::new();
        to_pixels(&[Rgb::new(1.0, 0.0, 0.0), Rgb::new(0.0, 2.0, -1.0), Rgb::splat(0.5), Rgb::splat(f32::NAN)], &mut p);
        assert_eq!(p[0], 0x00ff_0000);
        assert_eq!(p[1], 0x0000_ff00);
        assert_eq!(p[2], 0x00bc_bcbc);
        assert_eq!(p[3], 0);
        // The table is within one level of the exact conversion everywhere.
        for i in 0..=1000 {
            let v = i as f32 / 1000.0;
            let exact = (linear_to_srgb(v) * 255.0 + 0.5) as i32;
            to_pixels(&[Rgb::splat(v)], &mut p);
            assert!(((p[0] & 0xff) as i32 - exact).abs() <= 1, "{v}");
        }
    }
}
