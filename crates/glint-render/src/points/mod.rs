//! Points mode (DESIGN.md §3): point clouds drawn as closed surfaces by image-space
//! reconstruction (Marroquim, Kraus and Cavalcanti, "Efficient point-based rendering using
//! image reconstruction", PBG 2007).
//!
//! One frame: project every point to one pixel (`project.rs`: parallel scatter, packed atomic
//! depth test) → pull-push with depth intervals and elliptical box filters (`pyramid.rs`) →
//! a G-buffer of depth, normal, albedo and material (the AOVs) → deferred Phong shading with the
//! scene's lights and the sky's irradiance, the sky behind (`shade.rs`). O(n + m) for n points
//! and m pixels. The same pyramid gives the ablations (raw points, pull-push without ellipses)
//! and a fixed-size square splatting baseline; eye-dome lighting shades clouds without normals.
//!
//! Level 0 of the pyramid is the depth buffer itself: a pixel's attributes are read from the
//! winning point when needed (by the pull into level 1 and by the final push), so the finest
//! level is never copied.

mod gather;
mod prepared;
mod project;
mod pyramid;
mod shade;
#[cfg(test)]
mod tests;
mod view;

use gather::Winner;
pub use prepared::MAX_POINTS;
use prepared::PreparedPoints;
#[cfg(test)]
use pyramid::Level;
use pyramid::Texel;
use view::View;

use crate::film::{FilmPixel, FilmRows, SurfacePixel};
use crate::first_touch;
use crate::settings::ImageSettings;
use crate::{Film, RenderError};
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::sky::IrradianceSh;
use glint_scene::{Camera, Scene};
use project::EMPTY;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;
use view::{CloudView, cloud_views};

/// Most pixels the points mode draws: its per-pixel buffers (depth word, gathered attributes,
/// level-0 texel, pyramid, G-buffer, film) come to about 250 bytes a pixel, 8 GB here.
pub const MAX_POINT_PIXELS: u64 = 1 << 25;

/// How the holes between projected points are filled (the ablations of BENCHMARKS.md).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Fill {
    /// One pixel per point, nothing filled.
    Raw,
    /// Pull-push with depth intervals, without the elliptical box filters.
    PullPush,
    /// The full method: pull-push with depth intervals and elliptical box filters.
    #[default]
    Ellipses,
    /// The baseline of common point viewers: every point a fixed square of pixels, no fill.
    Squares,
}

/// How reconstructed pixels are lit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PointShading {
    /// Phong where every cloud has normals, eye-dome lighting otherwise.
    #[default]
    Auto,
    /// Deferred Phong with the scene's lights and the sky's irradiance as ambient light.
    Phong,
    /// Eye-dome lighting (Boucheny 2009): the colour darkened where the depth steps away from
    /// the neighbours; needs no normals.
    EyeDome,
    /// The points' colours as they are.
    Flat,
}

/// The points mode's settings (the image's size and seed are the frame's [`ImageSettings`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointSettings {
    pub fill: Fill,
    pub shading: PointShading,
    /// Side of the squares in pixels for [`Fill::Squares`].
    pub square_side: u32,
    /// Eye-dome lighting strength (1 = default).
    pub edl_strength: f32,
    /// Cull back faces of clouds whose normals are oriented.
    pub cull: bool,
}

impl Default for PointSettings {
    fn default() -> Self {
        Self { fill: Fill::Ellipses, shading: PointShading::Auto, square_side: 3, edl_strength: 1.0, cull: true }
    }
}

impl PointSettings {
    /// Check the settings, and that `image` is not too large for the points mode's buffers.
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] naming the value out of range.
    pub fn validate(&self, image: &ImageSettings) -> Result<(), RenderError> {
        image.validate()?;
        if u64::from(image.width) * u64::from(image.height) > MAX_POINT_PIXELS {
            return Err(RenderError::InvalidSetting(format!(
                "image size {}x{}: the points mode draws at most 2^25 pixels (e.g. 8192x4096); its buffers take about 250 bytes per pixel",
                image.width, image.height
            )));
        }
        if !(1..=15).contains(&self.square_side) {
            return Err(RenderError::InvalidSetting(format!(
                "square side {} pixels (must be 1..=15)",
                self.square_side
            )));
        }
        if !(self.edl_strength.is_finite() && self.edl_strength >= 0.0) {
            return Err(RenderError::InvalidSetting("eye-dome strength must be a finite number >= 0".into()));
        }
        Ok(())
    }
}

/// Where one frame's time went, and how much it drew.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PointStats {
    pub points: u64,
    /// Pixels a point won.
    pub projected_pixels: u64,
    /// Sizing the frame's buffers for a new image size (their first touch); 0 when the size
    /// was drawn before. Not part of `total_ms`: a once-per-size cost, like the layout.
    pub buffers_ms: f64,
    pub clear_ms: f64,
    pub project_ms: f64,
    /// The pull, and the push down to level 1 (with the gather of each pixel's winning point).
    pub pull_push_ms: f64,
    /// The final push into the G-buffer (level 0) and the shading: one pass for a per-pixel
    /// shading (Phong, flat), which shades each row as soon as it is made.
    pub shade_ms: f64,
    pub total_ms: f64,
}

impl PointStats {
    #[must_use]
    pub fn points_per_second(&self) -> f64 {
        self.points as f64 / (self.total_ms * 1e-3)
    }
}

/// The reconstructed surface per pixel (the AOVs) and the shaded colour.
#[derive(Clone, Debug, Default)]
pub struct PointFrame {
    pub width: u32,
    pub height: u32,
    /// Linear eye depth; +inf where no surface.
    pub depth: Vec<f32>,
    /// World-space unit normal facing the camera; zero where no surface.
    pub normal: Vec<Vec3>,
    pub albedo: Vec<Rgb>,
    /// Material index; `u32::MAX` where no surface.
    pub material: Vec<u32>,
    pub colour: Vec<Rgb>,
}

impl PointFrame {
    fn resize(&mut self, width: u32, height: u32) {
        let n = width as usize * height as usize;
        self.width = width;
        self.height = height;
        first_touch::resize(&mut self.depth, n, f32::INFINITY);
        first_touch::resize(&mut self.normal, n, Vec3::ZERO);
        first_touch::resize(&mut self.albedo, n, Rgb::ZERO);
        first_touch::resize(&mut self.material, n, u32::MAX);
        first_touch::resize(&mut self.colour, n, Rgb::ZERO);
    }

    /// Fraction of pixels covered by a surface.
    #[must_use]
    pub fn coverage(&self) -> f64 {
        self.depth.iter().filter(|d| d.is_finite()).count() as f64 / self.depth.len().max(1) as f64
    }

    /// The frame as a film: beauty, and the AOVs (normal, depth, albedo, coverage = alpha).
    #[must_use]
    pub fn to_film(&self) -> Film {
        let mut film = Film::new(1, 1);
        self.write_film(&mut film);
        film
    }

    /// [`PointFrame::to_film`] into an existing film (resized when its size differs), in
    /// parallel: the viewer does this every frame and keeps the film's memory.
    pub fn write_film(&self, film: &mut Film) {
        if (film.width, film.height) != (self.width, self.height) || !film.has_surface() {
            *film = Film::new(self.width, self.height);
        }
        film.path_aovs = false;
        let FilmRows { pixels, surface } = film.rows_mut();
        pixels.par_iter_mut().zip(surface).enumerate().for_each(|(i, (p, s))| {
            let hit = self.depth[i].is_finite();
            *p = FilmPixel { colour: self.colour[i], coverage: if hit { 1.0 } else { 0.0 } };
            *s = SurfacePixel { normal: self.normal[i], albedo: self.albedo[i], depth: self.depth[i] };
        });
    }
}

/// The bytes each stage of a frame streams at the least, as the buffers are laid out: every
/// frame-sized buffer a stage touches read or written once (what a pass would move if it ran at
/// the memory's speed; BENCHMARKS.md sets it beside a STREAM triad of the same run). Random
/// accesses (the projection's scatter, the gather of winning points) cost whole cache lines on
/// top of this.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PassBytes {
    /// Each point's 16-byte stream record read, each pixel's depth word written.
    pub project: f64,
    /// Gather (depth words read, the winners' attributes written), the pull of level 1 (depth
    /// words and attributes read, level 1 written) and the coarser levels (a third of level 1,
    /// read and written by the pull and the push).
    pub pull_push: f64,
    /// The final push fused with the (per-pixel) shading: depth words, attributes and level 1
    /// read; the G-buffer and the colour written (each row shaded while it is in the cache).
    pub shade: f64,
}

impl PassBytes {
    #[must_use]
    pub fn of_frame(points: u64, width: u32, height: u32) -> Self {
        use std::mem::size_of;
        let px = f64::from(width) * f64::from(height);
        let word = size_of::<AtomicU64>() as f64;
        let gathered = size_of::<Winner>() as f64;
        let texel = size_of::<Texel>() as f64;
        let level1 = texel * px / 4.0;
        let gbuffer = (size_of::<f32>() + size_of::<Vec3>() + size_of::<Rgb>() + size_of::<u32>()) as f64;
        let colour = size_of::<Rgb>() as f64;
        Self {
            project: points as f64 * size_of::<prepared::StreamPoint>() as f64 + px * word,
            pull_push: px * (word + gathered) + (px * (word + gathered) + level1) + 4.0 * level1 / 3.0,
            shade: px * (word + gathered + gbuffer + colour) + level1,
        }
    }
}

/// Draws a scene's point clouds; keeps its buffers from frame to frame.
pub struct PointRenderer {
    points: PreparedPoints,
    depth: Vec<AtomicU64>,
    /// What the pyramid needs of the point that won each pixel, made once per frame by one
    /// tight pass in image order (many cache misses in flight at once) and read by the pull
    /// into level 1 and by the final push.
    gathered: Vec<Winner>,
    /// Per image row, where its covered pixels lie (made by the gather).
    word_spans: Vec<pyramid::Span>,
    levels: Vec<pyramid::Level>,
    sky_irradiance: Option<IrradianceSh>,
    every_cloud_has_normals: bool,
}

impl PointRenderer {
    /// Lay out the scene's clouds for drawing (Morton order, packed normals).
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] when the clouds hold more than [`MAX_POINTS`] points.
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        let points = PreparedPoints::new(scene)?;
        Ok(Self {
            every_cloud_has_normals: points.clouds.iter().all(|c| c.has_normals),
            points,
            depth: Vec::new(),
            gathered: Vec::new(),
            word_spans: Vec::new(),
            levels: Vec::new(),
            sky_irradiance: scene.sky_ambient.then(|| scene.sky.irradiance_sh()),
        })
    }

    /// Draw the clouds of `scene` (the one this renderer was made from) seen by `camera`.
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] for settings outside their limits, an image too
    /// large for the points mode's buffers, or a camera that is not a pinhole.
    pub fn render(
        &mut self,
        scene: &Scene,
        camera: &Camera,
        image: &ImageSettings,
        settings: &PointSettings,
        frame: &mut PointFrame,
    ) -> Result<PointStats, RenderError> {
        settings.validate(image)?;
        if camera.lens != glint_scene::Lens::Pinhole {
            return Err(RenderError::InvalidSetting(format!(
                "points mode projects every point through a pinhole camera; this scene's camera is {:?}",
                camera.lens
            )));
        }
        let sizing = Instant::now();
        let (w, h) = (image.width, image.height);
        let resized = self.size_buffers(w, h, settings.fill, frame);
        let start = Instant::now();
        let buffers_ms = if resized { (start - sizing).as_secs_f64() * 1e3 } else { 0.0 };
        let view = View::new(camera, w, h);
        let clouds = cloud_views(&self.points, &view, settings.cull);
        if !resized {
            self.depth.par_chunks(1 << 14).for_each(|c| c.iter().for_each(|d| d.store(EMPTY, Ordering::Relaxed)));
        }
        let t_clear = Instant::now();

        let side = if settings.fill == Fill::Squares { settings.square_side } else { 1 };
        if !clouds.is_empty() {
            project::project(&self.points, &clouds, &view, &self.depth, side);
        }
        let t_project = Instant::now();

        let shading = match settings.shading {
            PointShading::Auto if self.every_cloud_has_normals => PointShading::Phong,
            PointShading::Auto => PointShading::EyeDome,
            s => s,
        };
        let sky = self.sky_irradiance;
        let shader = shade::Shader::new(shade::ShadeParams {
            scene,
            view: &view,
            sky_irradiance: sky.as_ref(),
            shading,
            edl_strength: settings.edl_strength,
            kernel: shade::Kernel::Best,
        });
        // A per-pixel shading runs on each G-buffer row as the final push makes it, while the
        // row is in the cache; eye-dome lighting needs the neighbouring rows and runs after.
        let fused = shader.per_pixel();
        let t_pull_push = self.reconstruct(&view, &clouds, settings.fill, frame, fused.then_some(&shader));
        if !fused {
            shader.frame(frame);
        }
        let t_shade = Instant::now();

        let ms = |a: Instant, b: Instant| (b - a).as_secs_f64() * 1e3;
        let projected = self.depth.par_iter().filter(|d| d.load(Ordering::Relaxed) != EMPTY).count();
        Ok(PointStats {
            points: self.points.len() as u64,
            projected_pixels: projected as u64,
            buffers_ms,
            clear_ms: ms(start, t_clear),
            project_ms: ms(t_clear, t_project),
            pull_push_ms: ms(t_project, t_pull_push),
            shade_ms: ms(t_pull_push, t_shade),
            total_ms: ms(start, t_shade),
        })
    }

    /// Give every frame-sized buffer (depth words, gathered attributes, pyramid levels, the
    /// G-buffer and colour) the size of a `width × height` frame, first touched on every
    /// thread, and the depth words cleared. Returns whether anything was resized: a size seen
    /// before costs nothing, a new one costs the page faults of ~80 bytes a pixel, which a
    /// single frame (`glint render`) would otherwise pay inside its passes and a benchmark's
    /// or the viewer's later frames never do; [`PointStats::buffers_ms`] reports it apart.
    fn size_buffers(&mut self, width: u32, height: u32, fill: Fill, frame: &mut PointFrame) -> bool {
        let n = width as usize * height as usize;
        let count =
            if matches!(fill, Fill::PullPush | Fill::Ellipses) { pyramid::level_count(width, height) } else { 0 };
        let sized = self.depth.len() == n
            && frame.width == width
            && frame.height == height
            && frame.depth.len() == n
            && self.gathered.len() == n
            && self.levels.len() >= count;
        if sized {
            return false;
        }
        frame.resize(width, height);
        if self.depth.len() != n {
            self.depth = (0..n).into_par_iter().map(|_| AtomicU64::new(EMPTY)).collect();
        } else {
            self.depth.par_chunks(1 << 14).for_each(|c| c.iter().for_each(|d| d.store(EMPTY, Ordering::Relaxed)));
        }
        first_touch::resize(&mut self.gathered, n, Winner::NONE);
        self.levels.resize_with(count.max(self.levels.len()), pyramid::Level::default);
        let (mut w, mut h) = (width, height);
        for level in self.levels.iter_mut().take(count) {
            w = w.div_ceil(2);
            h = h.div_ceil(2);
            level.resize(w, h);
        }
        true
    }

    /// The depth word of pixel (x, y), [`EMPTY`] outside the image.
    #[inline]
    fn word(&self, view: &View, x: i64, y: i64) -> u64 {
        if x < 0 || y < 0 || x >= i64::from(view.width) || y >= i64::from(view.height) {
            return EMPTY;
        }
        self.depth[y as usize * view.width as usize + x as usize].load(Ordering::Relaxed)
    }

    /// Level-0 texel of pixel (x, y), whose depth word is `word`: the point that won it
    /// (gathered by [`Self::gather`]), or invalid.
    #[inline]
    fn level0(&self, view: &View, x: i64, y: i64, word: u64) -> Texel {
        if word == EMPTY {
            return Texel::INVALID;
        }
        let (z, _) = project::unpack(word);
        let w = &self.gathered[y as usize * view.width as usize + x as usize];
        Texel {
            z_min: z,
            z_max: z + w.radius,
            depth: z,
            normal: Vec3::from_array(w.normal),
            radius: w.radius * view.focal / z,
            colour: prepared::decode_colour(w.colour),
            displacement: Vec2::ZERO,
            material: w.material,
        }
    }

    /// Make each covered pixel's [`Winner`] (`gather.rs`).
    fn gather(&mut self, view: &View, clouds: &[CloudView]) {
        let mut gathered = std::mem::take(&mut self.gathered);
        first_touch::resize(&mut gathered, self.depth.len(), Winner::NONE);
        self.word_spans.resize(view.height as usize, pyramid::Span::EMPTY);
        gather::gather(&self.points, clouds, view, &self.depth, &mut gathered, &mut self.word_spans, false);
        self.gathered = gathered;
    }

    /// Pull-push (per `fill`) down to the G-buffer in `frame`, each row shaded by `shader` as
    /// soon as the final push has made it. Returns when the pyramid was done (the final push
    /// into the G-buffer began).
    fn reconstruct(
        &mut self,
        view: &View,
        clouds: &[CloudView],
        fill: Fill,
        frame: &mut PointFrame,
        shader: Option<&shade::Shader<'_>>,
    ) -> Instant {
        self.gather(view, clouds);
        let pyramid = matches!(fill, Fill::PullPush | Fill::Ellipses);
        let ellipses = fill == Fill::Ellipses;
        let count = if pyramid { pyramid::level_count(view.width, view.height) } else { 0 };
        // Take the levels out of self so that level 0 (read through self) and the levels can
        // be borrowed at once.
        let mut levels = std::mem::take(&mut self.levels);
        levels.resize_with(count, pyramid::Level::default);
        let (mut w, mut h) = (view.width, view.height);
        for level in levels.iter_mut() {
            w = w.div_ceil(2);
            h = h.div_ceil(2);
            level.resize(w, h);
        }
        if count > 0 {
            self.pull_from_depth(view, &mut levels[0]);
            for k in 1..count {
                let (fine, coarse) = levels.split_at_mut(k);
                let fine = &fine[k - 1];
                pyramid::pull_level(fine, &mut coarse[0]);
            }
            for k in (1..count).rev() {
                let (fine, coarse) = levels.split_at_mut(k);
                pyramid::push_level(&coarse[0], &mut fine[k - 1], ellipses);
            }
        }
        let pyramid_done = Instant::now();
        let width = view.width as usize;
        let level1 = levels.first();
        let this = &*self;
        frame
            .depth
            .par_chunks_mut(width)
            .zip(frame.normal.par_chunks_mut(width))
            .zip(frame.albedo.par_chunks_mut(width))
            .zip(frame.material.par_chunks_mut(width))
            .zip(frame.colour.par_chunks_mut(width))
            .enumerate()
            .with_min_len(4)
            .for_each(|(y, ((((depth, normal), albedo), material), colour))| {
                let rows = level1.map(|l1| pyramid::CoarseRows::new(l1, y as i64));
                let words = &this.depth[y * width..(y + 1) * width];
                // Outside the span nothing is covered or near a surface: no surface there.
                let span = match &rows {
                    Some(rows) => rows.span().to_fine(width as u32),
                    None => this.word_spans[y],
                };
                let (lo, hi) = if span.is_empty() { (0, 0) } else { (span.lo as usize, span.hi as usize) };
                for (a, b) in [(0, lo), (hi, width)] {
                    depth[a..b].fill(f32::INFINITY);
                    normal[a..b].fill(Vec3::ZERO);
                    albedo[a..b].fill(Rgb::ZERO);
                    material[a..b].fill(u32::MAX);
                }
                for x in lo..hi {
                    let word = words[x].load(Ordering::Relaxed);
                    let t = match (&rows, word) {
                        // Empty: only the interpolation can give it a surface.
                        (Some(rows), EMPTY) => rows.interpolate(x as i64, y as i64, ellipses).unwrap_or(Texel::INVALID),
                        (None, EMPTY) => Texel::INVALID,
                        (Some(rows), _) => {
                            // Level 0 again, from the gathered attributes in image order: cheaper
                            // than keeping a frame of texels from the pull (60 bytes a pixel,
                            // whose first touch cost a single frame ~40 ms at 1024²).
                            let own = this.level0(view, x as i64, y as i64, word);
                            rows.push(x as i64, y as i64, &own, ellipses).unwrap_or(own)
                        }
                        (None, word) => this.level0(view, x as i64, y as i64, word),
                    };
                    if t.is_valid() {
                        depth[x] = t.depth;
                        // A unit texel normal in the camera's orthonormal basis: unit to a few
                        // ulps without normalising again (a square root and a division a pixel).
                        normal[x] = view.world_from_camera(t.normal);
                        albedo[x] = t.colour;
                        material[x] = t.material;
                    } else {
                        depth[x] = f32::INFINITY;
                        normal[x] = Vec3::ZERO;
                        albedo[x] = Rgb::ZERO;
                        material[x] = u32::MAX;
                    }
                }
                if let Some(shader) = shader {
                    let g = shade::GBufferRow { depth, normal, albedo, material };
                    shader.row(y, &g, depth, colour);
                }
            });
        self.levels = levels;
        pyramid_done
    }

    /// Pull level 1 straight from the depth buffer: 2×2 blocks without a point (most of them,
    /// in most images) cost four loads. The level-0 texels made on the way are not kept: the
    /// final push makes them again where it needs them.
    fn pull_from_depth(&self, view: &View, coarse: &mut pyramid::Level) {
        let cw = coarse.width as usize;
        let word_span = |y: usize| self.word_spans.get(y).copied().unwrap_or(pyramid::Span::EMPTY);
        let rows = coarse.texels.par_chunks_mut(cw).zip(coarse.spans.par_iter_mut());
        rows.enumerate().with_min_len(4).for_each(|(cy, (row, span))| {
            let fy = 2 * cy as i64;
            let candidates = word_span(2 * cy).union(word_span(2 * cy + 1)).to_coarse();
            pyramid::pull_row(row, span, candidates, |cx| {
                let fx = 2 * cx as i64;
                let words = [
                    self.word(view, fx, fy),
                    self.word(view, fx + 1, fy),
                    self.word(view, fx, fy + 1),
                    self.word(view, fx + 1, fy + 1),
                ];
                if words == [EMPTY; 4] {
                    return Texel::INVALID;
                }
                pyramid::pull_texel(std::array::from_fn(|k| {
                    let (x, y) = (fx + (k & 1) as i64, fy + (k >> 1) as i64);
                    (self.level0(view, x, y, words[k]), pyramid::CHILD_OFFSETS[k])
                }))
            });
        });
    }

    /// The pyramid levels above level 0 after the last frame.
    #[cfg(test)]
    pub(crate) fn levels(&self) -> &[Level] {
        &self.levels
    }
}
