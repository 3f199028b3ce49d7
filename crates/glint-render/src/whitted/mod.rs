//! Whitted ray tracing (DESIGN.md §1; the thesis's backward ray tracer): a frame of it.
//!
//! Each pixel's samples (N×N stratified, one sample of a progressive pass, or sample s of the
//! N×N pattern alone) are traced by [`Tracer`] (`tracer.rs`: Phong with shadow rays,
//! reflection and refraction on an explicit stack) or by the batched kernel (`batch.rs`), and
//! averaged into the film with the first hit's AOVs: each sample's record added in sample
//! order ([`SampleSum`]'s step), which is also how the samples of a frame split into chunks
//! are merged (`chunk.rs`). A sample's values do not depend on the samples traced beside it
//! (every ray's answer is the single-ray kernel's; lanes are independent). Bands of rows
//! go to threads through the shared band driver; inside a band pixels are visited in 8×8
//! blocks for ray coherence. Every sample position is `hash(pixel, sample, seed)`: the image
//! does not depend on the thread count.

mod batch;
mod isa;
pub mod optics;
mod shade8;
mod tracer;

pub use tracer::{FirstHit, Tracer};

use crate::bands::{self, Hooks};
use crate::film::{Film, FilmPixel, FilmRows, MAX_SAMPLE_RADIANCE, PixelRecord};
use crate::settings::{ImageSettings, WhittedKernel, WhittedSettings};
use crate::stats::{BandStats, FrameStats};
use crate::{RenderError, World};
use glint_core::random::SampleStream;
use glint_core::sampling::stratified_2d;
use glint_core::{Rgb, Vec2, Vec3};
use glint_image::PngOptions;
use glint_scene::Camera;
use std::time::Instant;

/// Rows per unit of parallel work.
const BAND_ROWS: usize = 8;
/// Columns per block inside a band (pixels are visited in 8×8 blocks for ray coherence).
const BLOCK_COLS: usize = 8;

/// Where a pixel's samples go.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Samples {
    /// `samples_per_side`² stratified samples (one at the centre when that is 1).
    Stratified,
    /// One sample of progressive pass k: through the pixel centre in pass 0, hash-jittered in
    /// pass k > 0, so the average of passes 0..N converges to the supersampled image whatever
    /// the thread count (the viewer adds passes while the camera rests).
    Pass(u32),
    /// Sample `s` of the `samples_per_side`² stratified pattern alone, every pixel's film
    /// entry its raw record (see [`SampleSum`]). A supersampled frame is the sum of its
    /// samples' records in sample order, whether they are traced in one process or in chunks
    /// of samples merged later: the same additions, so the same bits.
    One(u32),
}

impl Samples {
    /// The samples of the `n`²-sample stratified pattern a frame of these samples traces per
    /// pixel (one for a progressive pass).
    #[inline]
    fn range(self, n: u32) -> std::ops::Range<u32> {
        match self {
            Samples::Stratified => 0..n * n,
            Samples::One(s) => s..s + 1,
            Samples::Pass(_) => 0..1,
        }
    }
}

/// Render a Whitted frame of the world seen by `camera` into `film` (resized to the image).
///
/// # Errors
/// [`RenderError::InvalidSetting`] for settings outside their limits;
/// [`RenderError::Cancelled`] when `hooks` cancel it.
pub fn render(
    world: &World,
    camera: &Camera,
    image: &ImageSettings,
    settings: &WhittedSettings,
    samples: Samples,
    hooks: &Hooks,
    film: &mut Film,
) -> Result<FrameStats, RenderError> {
    image.validate()?;
    let settings = frame_settings(world, camera, settings, samples)?;
    if settings.kernel != WhittedKernel::Scalar
        && let Some(aligned) = aligned_window(image)
    {
        return render_window(world, camera, image, &aligned, &settings, samples, hooks, film);
    }
    let w = image.width as usize;
    film.reset(image.width, image.height)?;
    let parts = film.bands_mut(w * BAND_ROWS).into_iter().map(BandOut::Film).collect();
    trace_bands(world, camera, image, &settings, samples, hooks, parts)
}

/// Render a whole Whitted frame (its N×N stratified samples) straight to the 8-bit sRGB pixels
/// [`Film::encode_srgb8`] would give for it (`RGB`, or `RGBA` with `options.alpha`), into
/// `out`: each band of rows is traced into a band-sized beauty buffer and encoded while it is
/// in the cache. No whole-frame float film is made (a 1080p frame's is 33 MB, whose page
/// faults, fill and release cost a PNG render about a tenth of its time). A crop window off
/// the tile grid goes through a film.
///
/// # Errors
/// As [`render`]; [`RenderError::Memory`] when the memory budget refuses the output.
#[allow(clippy::too_many_arguments)]
pub fn render_srgb8(
    world: &World,
    camera: &Camera,
    image: &ImageSettings,
    settings: &WhittedSettings,
    hooks: &Hooks,
    options: &PngOptions,
    out: &mut Vec<u8>,
) -> Result<FrameStats, RenderError> {
    image.validate()?;
    let samples = Samples::Stratified;
    let settings = frame_settings(world, camera, settings, samples)?;
    if settings.kernel != WhittedKernel::Scalar && aligned_window(image).is_some() {
        let mut film = Film::beauty_only(image.width, image.height)?;
        let stats = render(world, camera, image, &settings, samples, hooks, &mut film)?;
        *out = film.encode_srgb8(options);
        return Ok(stats);
    }
    let channels = if options.alpha { 4 } else { 3 };
    let (w, count) = (image.width as usize, image.pixels());
    let what = || format!("the 8-bit pixels of a {} x {} image", image.width, image.height);
    let bytes = count.saturating_mul(channels);
    if out.capacity() < bytes {
        // Not reallocated frame after frame (a benchmark's, an animation's): its pages stay.
        *out = Vec::new();
        *out = glint_core::memory::try_with_capacity(what, bytes)?;
    }
    out.clear();
    out.resize(bytes, 0);
    let band_bytes = w * BAND_ROWS * channels;
    let parts = out.chunks_mut(band_bytes.max(1)).map(|bytes| BandOut::Srgb8 { bytes, options }).collect();
    trace_bands(world, camera, image, &settings, samples, hooks, parts)
}

/// The settings a frame of `samples` traces with: one sample a pixel for a progressive pass;
/// the scalar kernel where the batched one cannot go.
fn frame_settings(
    world: &World,
    camera: &Camera,
    settings: &WhittedSettings,
    samples: Samples,
) -> Result<WhittedSettings, RenderError> {
    let mut settings = match samples {
        Samples::Stratified | Samples::One(_) => *settings,
        Samples::Pass(_) => WhittedSettings { samples_per_side: 1, ..*settings },
    };
    if camera.lens != glint_scene::Lens::Pinhole || world.scene().lights.iter().any(glint_scene::Light::is_textured) {
        // The batched kernel makes its packets from one eye point and an image plane, and
        // shades lights without projected textures.
        settings.kernel = WhittedKernel::Scalar;
    }
    settings.validate()?;
    Ok(settings)
}

/// Where a band's pixels go.
enum BandOut<'a> {
    /// Into the film's rows.
    Film(FilmRows<'a>),
    /// Through a band-sized buffer of beauty into these 8-bit bytes ([`render_srgb8`]).
    Srgb8 { bytes: &'a mut [u8], options: &'a PngOptions },
}

thread_local! {
    /// Each worker thread's band of beauty for [`BandOut::Srgb8`], reused band after band.
    static BAND: std::cell::Cell<Vec<FilmPixel>> = const { std::cell::Cell::new(Vec::new()) };
}

impl BandOut<'_> {
    /// Run `trace` on the band's rows (band `index` of `pixels_per_band`-pixel bands) and
    /// put its pixels where they go.
    fn fill(self, index: usize, pixels_per_band: usize, trace: impl FnOnce(FilmRows) -> BandStats) -> BandStats {
        match self {
            BandOut::Film(rows) => trace(rows),
            BandOut::Srgb8 { bytes, options } => {
                let channels = if options.alpha { 4 } else { 3 };
                let first = index * pixels_per_band;
                // Taken out and put back: nothing else on this thread can see it meanwhile.
                let mut band = BAND.take();
                band.clear();
                band.resize(bytes.len() / channels, FilmPixel::default());
                let stats = trace(FilmRows { pixels: &mut band, surface: &mut [] });
                glint_image::encode_srgb8_into(
                    options,
                    first,
                    |start, block| {
                        let len = block.len();
                        let Some(pixels) = band.get(start - first..start - first + len) else { return };
                        let [r, g, b, a] = &mut block.planes;
                        for (i, p) in pixels.iter().enumerate() {
                            (r[i], g[i], b[i], a[i]) = (p.colour.x, p.colour.y, p.colour.z, p.coverage);
                        }
                    },
                    bytes,
                );
                BAND.set(band);
                stats
            }
        }
    }
}

/// Trace every band of the frame into `parts` (band i's destination: rows i·[`BAND_ROWS`]
/// onwards).
fn trace_bands(
    world: &World,
    camera: &Camera,
    image: &ImageSettings,
    settings: &WhittedSettings,
    samples: Samples,
    hooks: &Hooks,
    parts: Vec<BandOut>,
) -> Result<FrameStats, RenderError> {
    let settings = *settings;
    let start = Instant::now();
    let w = image.width as usize;
    let per_band = w * BAND_ROWS;
    let rays = image.camera_rays(camera);
    let (film_x, film_y) = image.film_origin();
    // Ray footprints for sky filtering: a sample's angular width at the image centre (a
    // pixel's over the samples per side), shrinking off-axis as cos^1.5 (a pinhole pixel
    // subtends cos³ of the centre's solid angle). Reflected and refracted rays keep their
    // primary ray's footprint: exact behind flat mirrors, too sharp behind curved ones, never
    // too blurry.
    let centre_cone = 1.0 / (rays.focal_pixels * settings.samples_per_side as f32);
    let forward = camera.forward.normalize();

    let render_band = |band_index: usize, mut band: FilmRows| -> BandStats {
        let mut tracer = Tracer::default();
        let (mut rejected, mut clamped) = (0, 0);
        let y0 = band_index * BAND_ROWS;
        let rows = band.len() / w;
        let n = settings.samples_per_side;
        let range = samples.range(n);
        let inv_samples = 1.0 / range.len() as f32;
        for bx in (0..w).step_by(BLOCK_COLS) {
            for row in 0..rows {
                let y = y0 + row;
                for x in bx..(bx + BLOCK_COLS).min(w) {
                    let pixel_index = image.pixel_id(x, y);
                    let mut acc = PixelAccumulator::default();
                    for s in range.clone() {
                        let (index, centre) = match samples {
                            Samples::Stratified | Samples::One(_) => (u64::from(s), n == 1),
                            Samples::Pass(k) => (u64::from(k), k == 0),
                        };
                        let (offset, lens) = if centre && !rays.samples_lens() {
                            (Vec2::splat(0.5), None)
                        } else {
                            let mut stream = SampleStream::new(pixel_index, index, image.seed);
                            let jitter = stream.next_2d();
                            let offset = match samples {
                                _ if centre => Vec2::splat(0.5),
                                Samples::Stratified | Samples::One(_) => stratified_2d(s, n, jitter),
                                Samples::Pass(_) => jitter,
                            };
                            (offset, rays.samples_lens().then(|| stream.next_2d()))
                        };
                        let p = Vec2::new((film_x + x) as f32, (film_y + y) as f32) + offset;
                        let ray = lens.map_or_else(|| rays.ray(p), |u| rays.ray_through_lens(p, u));
                        let cos = ray.dir.dot(forward);
                        let (c, first) = tracer.trace(world, ray, centre_cone * cos * cos.sqrt(), &settings);
                        let colour = if !c.is_finite() {
                            rejected += 1;
                            Rgb::ZERO
                        } else if c.max_element() > MAX_SAMPLE_RADIANCE {
                            clamped += 1;
                            c.min(Rgb::splat(MAX_SAMPLE_RADIANCE))
                        } else {
                            c
                        };
                        let hit = first.map(|f| (f.normal, f.albedo, rays.depth(f.position)));
                        // Each sample's record added in sample order, as a frame split into
                        // chunks of samples is merged (`SampleSum`).
                        acc.add_record(&PixelAccumulator::one(colour, hit).record());
                    }
                    band.set(
                        row * w + x,
                        match samples {
                            Samples::One(_) => acc.record(),
                            _ => acc.finish(inv_samples),
                        },
                    );
                }
            }
        }
        hooks.report(rows as u64);
        BandStats { rays: tracer.counts, rejected, clamped }
    };

    let totals = match settings.kernel {
        WhittedKernel::Scalar => bands::run(parts, image.schedule, hooks, |i, out: BandOut| {
            out.fill(i, per_band, |rows| render_band(i, rows))
        })?,
        kernel => {
            let frame = batch::Frame::new(world, camera, image, &settings, samples);
            let baseline = kernel == WhittedKernel::BatchedBaseline;
            bands::run(parts, image.schedule, hooks, |i, out: BandOut| {
                out.fill(i, per_band, |band| {
                    let rows = (band.len() / w) as u64;
                    let stats = isa::band(&frame, i, BAND_ROWS, band, baseline);
                    hooks.report(rows);
                    stats
                })
            })?
        }
    };
    let elapsed = start.elapsed();
    Ok(FrameStats {
        elapsed,
        stages: vec![("trace", elapsed)],
        rays: totals.rays,
        rejected_samples: totals.rejected,
        clamped_samples: totals.clamped,
        passes: 1,
        samples_per_pixel: samples.range(settings.samples_per_side).len() as u32,
        ..FrameStats::default()
    })
}

/// The batched kernel's tiles (16 × 8 pixels) and the order of a tile's streams depend on
/// where the image starts, and a sample's contributions are added in stream order: a crop
/// window whose edges do not fall on the film's tile grid would differ from the whole frame
/// by an ulp here and there. The window grown to the grid (None: it is on it) renders the
/// film's own tiles; [`render_window`] cuts the window out of it.
fn aligned_window(image: &ImageSettings) -> Option<ImageSettings> {
    let w = image.window?;
    let (x0, y0) = (w.x0 as usize, w.y0 as usize);
    let (x1, y1) = (x0 + image.width as usize, y0 + image.height as usize);
    let (ax0, ay0) = (x0 - x0 % batch::TILE_W, y0 - y0 % BAND_ROWS);
    let ax1 = x1.next_multiple_of(batch::TILE_W).min(w.full_width as usize);
    let ay1 = y1.next_multiple_of(BAND_ROWS).min(w.full_height as usize);
    if (ax0, ay0, ax1, ay1) == (x0, y0, x1, y1) {
        return None;
    }
    Some(ImageSettings {
        width: (ax1 - ax0) as u32,
        height: (ay1 - ay0) as u32,
        window: Some(crate::Window { x0: ax0 as u32, y0: ay0 as u32, ..w }),
        ..*image
    })
}

/// Render `aligned` (the window grown to the tile grid) and keep `image`'s pixels of it.
#[allow(clippy::too_many_arguments)]
fn render_window(
    world: &World,
    camera: &Camera,
    image: &ImageSettings,
    aligned: &ImageSettings,
    settings: &WhittedSettings,
    samples: Samples,
    hooks: &Hooks,
    film: &mut Film,
) -> Result<FrameStats, RenderError> {
    let mut grown = if film.has_surface() {
        Film::try_new(aligned.width, aligned.height)?
    } else {
        Film::beauty_only(aligned.width, aligned.height)?
    };
    let stats = render(world, camera, aligned, settings, samples, hooks, &mut grown)?;
    let (dx, dy) = (image.film_origin().0 - aligned.film_origin().0, image.film_origin().1 - aligned.film_origin().1);
    let (w, gw) = (image.width as usize, aligned.width as usize);
    film.reset(image.width, image.height)?;
    for (y, row) in film.pixels.chunks_mut(w).enumerate() {
        let start = (y + dy) * gw + dx;
        row.copy_from_slice(&grown.pixels[start..start + w]);
    }
    for (y, row) in film.surface.chunks_mut(w).enumerate() {
        let start = (y + dy) * gw + dx;
        row.copy_from_slice(&grown.surface[start..start + w]);
    }
    Ok(stats)
}

/// The running sums of a supersampled frame's pixels, one sample's records at a time (each
/// pixel's record as [`Samples::One`] leaves it in the film), in sample order.
pub struct SampleSum {
    pixels: Vec<PixelAccumulator>,
}

impl SampleSum {
    /// Empty sums for `pixels` pixels (allocated fallibly).
    ///
    /// # Errors
    /// [`RenderError`] when the memory budget or the allocator refuses them.
    pub fn try_new(pixels: usize) -> Result<Self, RenderError> {
        let what = || format!("the sample sums of {pixels} pixels");
        let mut v = glint_core::memory::try_with_capacity(what, pixels)?;
        crate::first_touch::resize(&mut v, pixels, PixelAccumulator::default());
        Ok(Self { pixels: v })
    }

    /// Add one sample's records (a film of [`Samples::One`]).
    pub fn add(&mut self, records: &[PixelRecord]) {
        use rayon::prelude::*;
        self.pixels.par_iter_mut().zip(records).for_each(|(acc, r)| acc.add_record(r));
    }

    /// The pixels of `samples` samples, into `out` (of as many pixels).
    pub fn finish(&self, samples: u32, out: FilmRows) {
        use rayon::prelude::*;
        let inv_samples = 1.0 / samples.max(1) as f32;
        let FilmRows { pixels, surface } = out;
        if surface.is_empty() {
            pixels.par_iter_mut().zip(&self.pixels).for_each(|(o, acc)| *o = acc.finish(inv_samples).beauty());
        } else {
            let out = pixels.par_iter_mut().zip(surface);
            out.zip(&self.pixels).for_each(|((o, s), acc)| {
                let record = acc.finish(inv_samples);
                (*o, *s) = (record.beauty(), record.surface());
            });
        }
    }
}

#[derive(Clone, Copy, Default)]
struct PixelAccumulator {
    colour: Rgb,
    normal: Vec3,
    albedo: Rgb,
    depth: f32,
    hits: u32,
}

impl PixelAccumulator {
    /// One sample: its colour (as admitted) and, when it hit, the first hit's normal, albedo
    /// and depth.
    #[inline]
    fn one(colour: Rgb, hit: Option<(Vec3, Rgb, f32)>) -> Self {
        let mut acc = PixelAccumulator { colour: Rgb::ZERO + colour, ..PixelAccumulator::default() };
        if let Some((normal, albedo, depth)) = hit {
            acc.hits = 1;
            acc.normal = Vec3::ZERO + normal;
            acc.albedo = Rgb::ZERO + albedo;
            acc.depth = 0.0 + depth;
        }
        acc
    }

    /// Add one sample's record ([`PixelAccumulator::record`]).
    #[inline]
    fn add_record(&mut self, r: &PixelRecord) {
        self.colour += r.colour;
        if r.coverage > 0.0 {
            self.hits += 1;
            self.normal += r.normal;
            self.albedo += r.albedo;
            self.depth += r.depth;
        }
    }

    /// One sample's raw record ([`Samples::One`]): its colour and, when it hit, the first
    /// hit's normal as it is summed (not normalised), albedo, depth and coverage 1.
    fn record(&self) -> PixelRecord {
        if self.hits == 0 {
            return PixelRecord { colour: self.colour, ..PixelRecord::default() };
        }
        PixelRecord { colour: self.colour, normal: self.normal, albedo: self.albedo, depth: self.depth, coverage: 1.0 }
    }

    fn finish(self, inv_samples: f32) -> PixelRecord {
        let coverage = self.hits as f32 * inv_samples;
        if self.hits == 0 {
            return PixelRecord { colour: self.colour * inv_samples, ..PixelRecord::default() };
        }
        let inv_hits = 1.0 / self.hits as f32;
        PixelRecord {
            colour: self.colour * inv_samples,
            normal: self.normal.normalize_or_zero(),
            albedo: self.albedo * inv_hits,
            depth: self.depth * inv_hits,
            coverage,
        }
    }
}
