//! The parallel render loop: bands of rows handed to threads, each pixel computed from its own
//! hash-derived samples only, so the image is bit-identical whatever the thread count or order.

use crate::film::{Film, FilmPixel};
use crate::settings::{RenderSettings, Schedule};
use crate::whitted::{RayCounts, Tracer, WhittedParams};
use crate::{RenderError, World};
use glint_core::random::SampleStream;
use glint_core::sampling::stratified_2d;
use glint_core::{Rgb, Vec2, Vec3};
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Rows per unit of parallel work.
const BAND_ROWS: usize = 8;
/// Columns per block inside a band (pixels are visited in 8×8 blocks for ray coherence).
const BLOCK_COLS: usize = 8;

#[derive(Clone, Copy, Debug, Default)]
pub struct RenderStats {
    pub rays: RayCounts,
    /// Samples whose radiance was NaN or infinite; they were dropped (counted as black).
    pub rejected_samples: u64,
    pub elapsed: Duration,
}

impl RenderStats {
    pub fn mrays_per_second(&self) -> f64 {
        self.rays.total() as f64 / self.elapsed.as_secs_f64().max(1e-9) / 1e6
    }
}

/// What a band of rows counted (every mode's driver reduces these).
#[derive(Default, Clone, Copy)]
pub(crate) struct BandStats {
    pub rays: RayCounts,
    pub rejected: u64,
}

impl BandStats {
    pub fn merge(mut self, o: BandStats) -> BandStats {
        self.rays.add(&o.rays);
        self.rejected += o.rejected;
        self
    }
}

/// Render the world's scene with the Whitted integrator.
pub fn render(world: &World, settings: &RenderSettings) -> Result<(Film, RenderStats), RenderError> {
    render_with_progress(world, settings, &|_| {})
}

/// As [`render`], calling `progress(rows_done)` as bands finish (from worker threads).
pub fn render_with_progress(
    world: &World,
    settings: &RenderSettings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Film, RenderStats), RenderError> {
    render_pattern(world, settings, Pattern::Stratified, progress)
}

/// One pass of a progressive render: one sample per pixel (`samples_per_side` is ignored),
/// through the pixel centre in pass 0 and at a hash-jittered position in pass k > 0, so the
/// average of passes 0..N converges to the supersampled image and does not depend on how
/// many threads drew them. The viewer adds passes while the camera rests.
pub fn render_pass(world: &World, settings: &RenderSettings, pass: u32) -> Result<(Film, RenderStats), RenderError> {
    render_pattern(world, &RenderSettings { samples_per_side: 1, ..*settings }, Pattern::Pass(pass), &|_| {})
}

/// Where a pixel's samples go.
#[derive(Clone, Copy)]
enum Pattern {
    /// `samples_per_side`² stratified samples (one at the centre when that is 1).
    Stratified,
    /// One sample of progressive pass k.
    Pass(u32),
}

fn render_pattern(
    world: &World,
    settings: &RenderSettings,
    pattern: Pattern,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Film, RenderStats), RenderError> {
    settings.validate()?;
    let start = Instant::now();
    let (w, h) = (settings.width as usize, settings.height as usize);
    let mut film = Film::new(settings.width, settings.height);
    let camera = world.scene.camera.rays(settings.width, settings.height);
    let params = WhittedParams { max_depth: settings.max_depth, min_contribution: settings.min_contribution };
    // Ray footprints for sky filtering: a sample's angular width at the image centre (a
    // pixel's over the samples per side), shrinking off-axis as cos^1.5 (a pinhole pixel
    // subtends cos³ of the centre's solid angle). Reflected and refracted rays keep their
    // primary ray's footprint: exact behind flat mirrors, too sharp behind curved ones, never
    // too blurry.
    let centre_cone = 1.0 / (camera.focal_pixels * settings.samples_per_side as f32);
    let forward = world.scene.camera.forward.normalize();

    let render_band = |band_index: usize, band: &mut [FilmPixel]| -> BandStats {
        let mut tracer = Tracer::default();
        let mut rejected = 0;
        let y0 = band_index * BAND_ROWS;
        let rows = band.len() / w;
        let n = settings.samples_per_side;
        let inv_samples = 1.0 / (n * n) as f32;
        for bx in (0..w).step_by(BLOCK_COLS) {
            for row in 0..rows {
                let y = y0 + row;
                for x in bx..(bx + BLOCK_COLS).min(w) {
                    let pixel_index = (y * w + x) as u64;
                    let mut acc = PixelAccumulator::default();
                    for s in 0..n * n {
                        let offset = match pattern {
                            Pattern::Stratified if n == 1 => Vec2::splat(0.5),
                            Pattern::Pass(0) => Vec2::splat(0.5),
                            Pattern::Stratified => {
                                let mut stream = SampleStream::new(pixel_index, s as u64, settings.seed);
                                stratified_2d(s, n, stream.next_2d())
                            }
                            Pattern::Pass(k) => SampleStream::new(pixel_index, k as u64, settings.seed).next_2d(),
                        };
                        let ray = camera.ray(Vec2::new(x as f32, y as f32) + offset);
                        let cos = ray.dir.dot(forward);
                        let (c, first) = tracer.trace(world, ray, centre_cone * cos * cos.sqrt(), &params);
                        if c.is_finite() {
                            acc.colour += c;
                        } else {
                            rejected += 1;
                        }
                        if let Some(f) = first {
                            acc.hits += 1;
                            acc.normal += f.normal;
                            acc.albedo += f.albedo;
                            acc.depth += camera.depth(f.position);
                        }
                    }
                    band[row * w + x] = acc.finish(inv_samples);
                }
            }
        }
        progress(rows as u64);
        BandStats { rays: tracer.counts, rejected }
    };

    let band_len = w * BAND_ROWS;
    let stats = match settings.schedule {
        Schedule::WorkStealing => film
            .pixels
            .par_chunks_mut(band_len)
            .enumerate()
            .map(|(i, band)| render_band(i, band))
            .reduce(BandStats::default, BandStats::merge),
        Schedule::Static => {
            let threads = rayon::current_num_threads().max(1);
            let bands = h.div_ceil(BAND_ROWS);
            let per_thread = bands.div_ceil(threads);
            let mut results = vec![BandStats::default(); threads];
            rayon::scope(|scope| {
                let mut rest: &mut [FilmPixel] = &mut film.pixels;
                for (t, result) in results.iter_mut().enumerate() {
                    let take = (per_thread * band_len).min(rest.len());
                    let (mine, tail) = rest.split_at_mut(take);
                    rest = tail;
                    let first_band = t * per_thread;
                    let render_band = &render_band;
                    scope.spawn(move |_| {
                        for (k, band) in mine.chunks_mut(band_len).enumerate() {
                            *result = result.merge(render_band(first_band + k, band));
                        }
                    });
                }
            });
            results.into_iter().fold(BandStats::default(), BandStats::merge)
        }
    };
    let stats = RenderStats { rays: stats.rays, rejected_samples: stats.rejected, elapsed: start.elapsed() };
    Ok((film, stats))
}

#[derive(Default)]
struct PixelAccumulator {
    colour: Rgb,
    normal: Vec3,
    albedo: Rgb,
    depth: f32,
    hits: u32,
}

impl PixelAccumulator {
    fn finish(self, inv_samples: f32) -> FilmPixel {
        let coverage = self.hits as f32 * inv_samples;
        if self.hits == 0 {
            return FilmPixel { colour: self.colour * inv_samples, ..FilmPixel::default() };
        }
        let inv_hits = 1.0 / self.hits as f32;
        FilmPixel {
            colour: self.colour * inv_samples,
            normal: self.normal.normalize_or_zero(),
            albedo: self.albedo * inv_hits,
            depth: self.depth * inv_hits,
            coverage,
            ..FilmPixel::default()
        }
    }
}
