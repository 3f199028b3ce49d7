//! Path tracing with guided-image-filtered indirect light (DESIGN.md §2; Bauszat, Eisemann and
//! Magnor 2011).
//!
//! A frame is one or more *passes* of `spp` samples per pixel. In a pass with a filter:
//! 1. **guide rays**: the first sample of every pixel goes through its centre and traces its
//!    diffuse indirect light into a buffer, with the normal, depth and albedo of its guide
//!    vertex ([`integrator`]);
//! 2. **filter**: the buffer (demodulated) is filtered by glint-filter, guided by normal and
//!    depth;
//! 3. **further samples** trace direct light and everything but the diffuse indirect light
//!    themselves, and read the filtered indirect light at the most similar of the four guides
//!    around them ([`lookup`]), times their own albedo.
//!
//! Without a filter every sample traces its own indirect path (plain path tracing, the
//! reference). Pixels are box-filtered averages of their samples. With a time budget, passes
//! repeat (new guide rays, new samples) until it is spent and the passes are averaged.
//! Every random number is `hash(pixel, sample, dimension, seed)`: the image does not depend on
//! the thread count.

mod bsdf;
mod integrator;
mod lights;
mod lookup;
pub mod models;
mod pow;
mod progressive;
mod shading;
mod splat;
mod sums;
mod wavefront;

use crate::bands::{self, Hooks};
use crate::film::Film;
use crate::fixed;
use crate::settings::{ImageSettings, Region};
use crate::stats::{BandStats, FrameStats};
use crate::world::SurfaceHit;
use crate::{RenderError, World};
use glint_core::random::{SampleStream, Sampler};
use glint_core::{PixelFilter, PixelSampler, Ray, Reconstruction, Rgb, Vec2, Vec3};
use glint_filter::Filter;
use glint_scene::{Camera, limits};
use integrator::{CameraSample, IndirectMode, Integrator, PathParams};
use lights::LightSet;
use lookup::GuideMap;
pub use progressive::PathAccumulator;
use rayon::prelude::*;
use std::time::{Duration, Instant};
pub use sums::{FirstSample, PathSums, PixelSums};
use wavefront::{Request, Wavefront};

/// Rows per unit of parallel work.
const BAND_ROWS: usize = 4;

/// The last frame's (or pass's) guide rays, kept for the next one.
static GUIDES: crate::first_touch::Pool<GuidePixel> = crate::first_touch::Pool::new();

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    /// Samples per pixel in each pass (the first is the guide ray).
    pub spp: u32,
    /// Indirect bounces (0 = direct light only).
    pub max_bounces: u32,
    /// Russian roulette from this bounce on.
    pub rr_start: u32,
    /// The longest chain of delta (mirror, glass) bounces the camera ray follows to its guide
    /// vertex (the scene's `max_depth`).
    pub max_chain: u32,
    pub filter: Filter,
    /// Passes of `spp` samples per pixel (at least 1); a time budget may add more.
    pub passes: u32,
    /// Render passes until this much time has been spent (at least `passes`).
    pub time_budget: Option<Duration>,
    /// Firefly clamp: the largest component of the indirect radiance a sample brings to its
    /// guide vertex (biased: caustics darken). None = off, the unbiased default.
    pub clamp_indirect: Option<f32>,
    /// Also filter the diffuse direct light of area lights and the sky (sampled lights), not
    /// only the indirect light (the default): at one sample per pixel their direct light is as
    /// noisy as the indirect light. `false` is the paper's split (its direct light came from
    /// point lights; its tables are reproduced with it). Point, spot and directional lights
    /// are never filtered (sharp shadows).
    pub filter_area_direct: bool,
    pub kernel: PathKernel,
    /// Mitsuba's `max_depth`: a path has at most this many vertices (every bounce counts,
    /// mirror and glass ones included: 1 = emitters seen directly, 2 = direct light). Light
    /// is sampled at a vertex and its BSDF followed only while the next vertex is within the
    /// budget, as Mitsuba's `path` integrator does, so scenes read from Mitsuba XML render
    /// the same light transport. `None`: glint's own budgets (`max_bounces` after the guide
    /// vertex, `max_chain` before it). Both kernels keep either budget.
    pub max_depth: Option<u32>,
    /// The film's pixel filter. Without an image filter, a filter wider than a pixel is
    /// applied as `reconstruction` says; with one, each sample's position is drawn from it
    /// (the guided filter reads one sample per pixel), and the first guide ray still goes
    /// through the pixel centre. The box: positions uniform in the pixel.
    pub pixel_filter: PixelFilter,
    /// How an unfiltered frame applies a pixel filter wider than a pixel: splatting each
    /// sample into every pixel it reaches (Mitsuba's film, the default) or drawing its
    /// position from the filter (`glint_core::pixel_filter`).
    pub reconstruction: Reconstruction,
    /// Emitters and the sky seen directly from the camera add nothing (Mitsuba's
    /// `hide_emitters`); after a bounce, mirror and glass ones included, they are seen.
    pub hide_emitters: bool,
    /// How the camera samples draw their random numbers: stratified across a pixel's samples
    /// (Sobol, the default) or independent (Mitsuba's `independent` sampler; what a Variance
    /// AOV's `variance / N` as the error of a pixel's mean assumes).
    pub sampler: Sampler,
    /// Sum the path AOVs (Direct, Indirect, SampleCount, Variance) beside the beauty (the
    /// default: a render to EXR writes them). Off, each sample adds its colour alone (with
    /// Mitsuba's Gaussian film that is 4 of a splat's 10 terms): a frame that shows only the
    /// picture (a render to PNG) draws the same beauty bit for bit, faster.
    pub aovs: bool,
}

/// Whether the lanes take every light the path mode samples in `world` (emissive triangles,
/// the sky, at most two directional lights; no point or spot light): the wavefront kernel
/// then shades the vertices on surfaces without delta lobes eight at a time.
#[must_use]
pub fn lights_in_lanes(world: &World) -> bool {
    LightSet::new(world).suns().is_some()
}

/// How the path tracer runs its samples (the same estimator either way; BENCHMARKS.md §6
/// compares their speed, tests/path.rs their pictures).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PathKernel {
    /// Breadth first: a band's paths traced one bounce at a time, binned by direction, rays
    /// and shadow rays asked eight at a time ([`wavefront`]).
    #[default]
    Wavefront,
    /// The wavefront with every vertex shaded one at a time: the oracle of its vertices
    /// shaded eight at a time (the same picture, bit for bit), and their speed's baseline.
    WavefrontScalar,
    /// Depth first, one camera sample after another (the oracle).
    Recursive,
}

impl Default for PathSettings {
    fn default() -> Self {
        Self {
            spp: 1,
            max_bounces: 3,
            rr_start: 3,
            max_chain: 8,
            filter: Filter::None,
            passes: 1,
            time_budget: None,
            clamp_indirect: None,
            filter_area_direct: true,
            kernel: PathKernel::default(),
            max_depth: None,
            pixel_filter: PixelFilter::Box,
            reconstruction: Reconstruction::Splat,
            hide_emitters: false,
            sampler: Sampler::Sobol,
            aovs: true,
        }
    }
}

impl PathSettings {
    /// # Errors
    /// [`RenderError::InvalidSetting`] naming the value outside its range
    /// (`glint_scene::limits`).
    pub fn validate(&self) -> Result<(), RenderError> {
        limits::check("samples per pixel", self.spp, &limits::SPP)
            .and_then(|()| limits::check("bounces", self.max_bounces, &limits::MAX_BOUNCES))
            .and_then(|()| limits::check("max depth", self.max_chain, &limits::MAX_DEPTH))
            .and_then(|()| self.max_depth.map_or(Ok(()), |d| limits::check("path depth", d, &limits::PATH_DEPTH)))
            .map_err(RenderError::InvalidSetting)?;
        if let Some(c) = self.clamp_indirect
            && !(c.is_finite() && c > 0.0)
        {
            return Err(RenderError::InvalidSetting(format!("indirect clamp {c} (must be a finite number > 0)")));
        }
        if self.passes == 0 || self.passes.saturating_mul(self.spp) > *limits::SPP.end() * 16 {
            return Err(RenderError::InvalidSetting(format!(
                "{} passes of {} spp (must be at least 1, at most {} samples per pixel in all)",
                self.passes,
                self.spp,
                *limits::SPP.end() * 16
            )));
        }
        self.pixel_filter.validate().map_err(RenderError::InvalidSetting)?;
        let samples = u64::from(self.passes) * u64::from(self.spp);
        if samples * self.splat_footprint() > fixed::MAX_TERMS {
            return Err(RenderError::InvalidSetting(format!(
                "{samples} samples per pixel splatted through a pixel filter of radius {} (each sample adds \
                 to up to {} pixels): at most {} samples per pixel (or draw positions from the filter: \
                 --reconstruction sample)",
                self.pixel_filter.radius(),
                self.splat_footprint(),
                fixed::MAX_TERMS / self.splat_footprint()
            )));
        }
        if let Some(t) = self.time_budget
            && t.is_zero()
        {
            return Err(RenderError::InvalidSetting("time budget must be more than 0 s".into()));
        }
        Ok(())
    }

    fn filtered(&self) -> bool {
        !matches!(self.filter, Filter::None)
    }

    /// How many pixels on either side a sample's splat reaches: the pixel filter's reach when
    /// samples are splatted (an unfiltered frame, [`Reconstruction::Splat`]), else 0 (each
    /// sample stays in its pixel).
    #[must_use]
    pub fn splat_reach(&self) -> usize {
        match (self.filtered(), self.reconstruction) {
            (false, Reconstruction::Splat) => self.pixel_filter.reach(),
            _ => 0,
        }
    }

    /// The most pixels one sample adds to (1 when samples are not splatted).
    fn splat_footprint(&self) -> u64 {
        let side = 2 * self.splat_reach() as u64 + 1;
        side * side
    }

    /// The frame's units of work, the steps a [`Share`] splits: its passes with a filter (one
    /// guide pass and the lookups that read it), its samples per pixel without one (every
    /// sample is independent). A time budget adds units while it lasts.
    #[must_use]
    pub fn units(&self) -> u64 {
        if self.filtered() { u64::from(self.passes) } else { u64::from(self.passes) * u64::from(self.spp) }
    }
}

/// Which of a frame's units a render traces: share `index` (0-based) of `count`, each a
/// contiguous run of units (share i: units ⌊i·T/count⌋ .. ⌊(i+1)·T/count⌋ of T), each unit
/// traced with exactly the random streams it has in the whole frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Share {
    pub index: u32,
    pub count: u32,
}

impl Share {
    /// The whole frame.
    pub const WHOLE: Share = Share { index: 0, count: 1 };

    /// This share's units of a frame of `total`.
    #[must_use]
    pub fn units(&self, total: u64) -> std::ops::Range<u64> {
        let at = |i: u32| (u128::from(total) * u128::from(i) / u128::from(self.count.max(1))) as u64;
        at(self.index)..at(self.index + 1)
    }

    /// # Errors
    /// [`RenderError::InvalidSetting`] when the index is not below the count, or the frame has
    /// fewer units than shares (a share would be empty).
    pub fn validate(&self, path: &PathSettings) -> Result<(), RenderError> {
        let total = path.units();
        let unit = if path.filtered() { "passes (--passes)" } else { "samples per pixel (--spp × --passes)" };
        if self.count == 0 || self.index >= self.count {
            return Err(RenderError::InvalidSetting(format!(
                "chunk {}/{}: the index must be below the count (0-based)",
                self.index, self.count
            )));
        }
        if u64::from(self.count) > total {
            return Err(RenderError::InvalidSetting(format!(
                "{} chunks of a frame of {total} {unit}: at most one chunk per unit",
                self.count
            )));
        }
        if self.count > 1 && path.time_budget.is_some() {
            return Err(RenderError::InvalidSetting(
                "a time budget (--time) decides the passes while rendering: a chunked frame needs a fixed number"
                    .into(),
            ));
        }
        Ok(())
    }
}

/// The guide sample of one pixel.
#[derive(Clone, Copy, Debug, Default)]
struct GuidePixel {
    sample: CameraSample,
}

/// Everything a pass needs, shared by the threads.
struct Frame {
    lights: LightSet,
    camera: glint_scene::camera::CameraRays,
    params: PathParams,
    seed: u64,
    schedule: crate::bands::Schedule,
    centre_cone: f32,
    forward: Vec3,
    width: usize,
    /// Draws sample positions from the film's pixel filter (uniform in the pixel when samples
    /// are splatted).
    pixel: PixelSampler,
    /// The pixel filter samples are splatted through ([`PathSettings::splat_reach`] > 0).
    splat: Option<PixelFilter>,
    sampler: Sampler,
    /// The image's place in its film (pixel ids and camera positions are the film's).
    image: ImageSettings,
    /// The sample asked to go through the pixel centre does: always with a box filter, and
    /// for the guide rays of a filtered frame; otherwise it is drawn from the pixel filter.
    centre_first: bool,
}

impl Frame {
    /// The shared state of a pass over the world's scene seen by its camera. The diffuse
    /// direct light of area lights and the sky joins the filtered part only when a filter runs.
    fn new(world: &World, view: &Camera, image: &ImageSettings, path: &PathSettings) -> Frame {
        let camera = image.camera_rays(view);
        Frame {
            lights: LightSet::new(world),
            camera,
            params: PathParams {
                max_bounces: path.max_bounces,
                max_chain: path.max_chain,
                rr_start: path.rr_start,
                clamp_indirect: path.clamp_indirect.unwrap_or(f32::INFINITY),
                filter_area_direct: path.filter_area_direct && path.filtered(),
                max_depth: path.max_depth,
                filtered: path.filtered(),
                hide_emitters: path.hide_emitters,
            },
            seed: image.seed,
            schedule: image.schedule,
            centre_cone: 1.0 / (camera.focal_pixels * (path.spp as f32).sqrt()),
            forward: view.forward.normalize(),
            width: image.width as usize,
            pixel: PixelSampler::new(if path.splat_reach() > 0 { PixelFilter::Box } else { path.pixel_filter }),
            splat: (path.splat_reach() > 0).then_some(path.pixel_filter),
            sampler: path.sampler,
            image: *image,
            centre_first: path.filtered() || path.pixel_filter == PixelFilter::Box,
        }
    }

    /// Trace sample `sample` of pixel (x, y); sample 0 of a pass with a guide (or the very
    /// first sample) goes through the centre. Returns the sample's offset from the pixel's
    /// corner (the centre at ½; in [0, 1)² unless drawn from a filter wider than the pixel)
    /// and the sample.
    fn sample(
        &self,
        it: &mut Integrator,
        x: usize,
        y: usize,
        sample: u64,
        centre: bool,
        mode: IndirectMode,
    ) -> (Vec2, CameraSample) {
        let (offset, ray, mut stream) = self.camera_ray(x, y, sample, centre);
        let first = it.world.intersect(&ray);
        (offset, self.sample_from(it, ray, first, &mut stream, mode))
    }

    /// The offset within the pixel and camera ray of sample `sample` of pixel (x, y), and the
    /// sample's stream after the jitter (see [`Frame::sample`]).
    #[inline]
    fn camera_ray(&self, x: usize, y: usize, sample: u64, centre: bool) -> (Vec2, Ray, SampleStream) {
        let mut stream = self.sampler.stream(self.image.pixel_id(x, y), sample, self.seed);
        // The pixel sample's dimensions are the centre ray's too (stepped over, not drawn), so
        // that every sample reads the same dimensions for the same purpose (stratified across
        // the pixel's samples).
        let offset = if centre && self.centre_first {
            stream.skip(2);
            Vec2::splat(0.5)
        } else {
            self.pixel.position(stream.next_2d())
        };
        let on_film = match self.image.film_origin() {
            (0, 0) => Vec2::new(x as f32, y as f32) + offset,
            (fx, fy) => Vec2::new((fx + x) as f32, (fy + y) as f32) + offset,
        };
        let ray = if self.camera.samples_lens() {
            self.camera.ray_through_lens(on_film, stream.next_2d())
        } else {
            self.camera.ray(on_film)
        };
        (offset, ray, stream)
    }

    /// The rest of [`Frame::sample`] given the camera ray's closest hit `first`.
    #[inline]
    fn sample_from(
        &self,
        it: &mut Integrator,
        ray: Ray,
        first: Option<SurfaceHit>,
        stream: &mut SampleStream,
        mode: IndirectMode,
    ) -> CameraSample {
        let cos = ray.dir.dot(self.forward);
        let camera = &self.camera;
        it.camera_sample_from(ray, first, self.centre_cone * cos * cos.sqrt(), |p| camera.depth(p), stream, mode)
    }
}

/// Camera samples traced per run of the wavefront tracer: a pool of a few thousand paths,
/// whose queues stay in the worker's cache.
const RUN_SAMPLES: usize = 4096;

/// A worker's tracer of camera samples, by [`PathKernel`].
enum Tracer<'a> {
    Wavefront { wavefront: Box<Wavefront<'a>>, requests: Vec<Request>, out: Vec<(Vec2, CameraSample)> },
    Recursive { frame: &'a Frame, it: Integrator<'a> },
}

impl<'a> Tracer<'a> {
    fn new(world: &'a World, frame: &'a Frame, kernel: PathKernel) -> Self {
        match kernel {
            PathKernel::Wavefront | PathKernel::WavefrontScalar => Tracer::Wavefront {
                wavefront: Box::new(Wavefront::new(world, frame, kernel == PathKernel::Wavefront)),
                requests: Vec::with_capacity(RUN_SAMPLES),
                out: Vec::with_capacity(RUN_SAMPLES),
            },
            PathKernel::Recursive => {
                Tracer::Recursive { frame, it: Integrator::new(world, &frame.lights, frame.params) }
            }
        }
    }

    fn counts(&self) -> crate::stats::RayCounts {
        match self {
            Tracer::Wavefront { wavefront, .. } => wavefront.counts,
            Tracer::Recursive { it, .. } => it.counts,
        }
    }

    /// Trace samples `0..count` of each of `pixels` pixels (`request(k, s)` says which) and
    /// hand each to `take(k, s, offset in the pixel, sample)`, pixel by pixel, each pixel's
    /// samples in order (so sums come out in the same order whatever the kernel).
    fn samples(
        &mut self,
        pixels: usize,
        count: u64,
        request: impl Fn(usize, u64) -> Request,
        mut take: impl FnMut(usize, u64, Vec2, &CameraSample),
    ) {
        if count == 0 {
            return;
        }
        match self {
            Tracer::Recursive { frame, it } => {
                for k in 0..pixels {
                    for s in 0..count {
                        let r = request(k, s);
                        let (offset, cs) = frame.sample(it, r.x, r.y, r.index, r.centre, r.mode);
                        take(k, s, offset, &cs);
                    }
                }
            }
            Tracer::Wavefront { wavefront, requests, out } => {
                let per_run = (RUN_SAMPLES as u64 / count).max(1) as usize;
                for first in (0..pixels).step_by(per_run) {
                    let last = (first + per_run).min(pixels);
                    requests.clear();
                    requests.extend(
                        (first..last).flat_map(|k| (0..count).map(move |s| (k, s))).map(|(k, s)| request(k, s)),
                    );
                    wavefront.run(requests, out);
                    let mut i = 0;
                    for k in first..last {
                        for s in 0..count {
                            let (offset, cs) = &out[i];
                            take(k, s, *offset, cs);
                            i += 1;
                        }
                    }
                }
            }
        }
    }
}

/// Render a path-traced frame of the world seen by `camera` into `film` (resized): passes of
/// `path.spp` samples per pixel, repeated while the time budget lasts, averaged. The frame's
/// [`PathSums`] resolved ([`render_path_sums`] of the whole frame).
///
/// # Errors
/// [`RenderError::InvalidSetting`] for settings outside their limits; [`RenderError::Filter`]
/// if the filter refuses its input; [`RenderError::Cancelled`] when `hooks` cancel it.
pub fn render_path(
    world: &World,
    camera: &Camera,
    image: &ImageSettings,
    path: &PathSettings,
    hooks: &Hooks,
    film: &mut Film,
) -> Result<FrameStats, RenderError> {
    let (mut stats, sums) = render_path_sums(world, camera, image, path, Share::WHOLE, None, hooks)?;
    let start = Instant::now();
    sums.resolve(film)?;
    sums.recycle();
    stats.elapsed += start.elapsed();
    Ok(stats)
}

/// Trace `share` of a path-traced frame's units (see [`PathSettings::units`]) into per-pixel
/// sums, of the whole image or of `region`'s pixels (a tile). A time budget applies to the
/// whole frame only (it adds units while it lasts, up to [`fixed::MAX_TERMS`] samples per
/// pixel).
///
/// A region's sums are the whole frame's at its pixels, bit for bit. Without a filter its
/// pixels are independent and only they are traced. With one, a pass's samples read the
/// filtered indirect light of the guide rays around them, and the filter's running sums are
/// re-based on a grid anchored at the image's edges (`glint_filter::guided`), so no margin
/// short of the whole image gives the whole frame's bits: every pass traces and filters the
/// guide rays of the whole image (one sample per pixel of the pass's `spp`) and the other
/// samples in the region only.
///
/// # Errors
/// As [`render_path`]; a share outside the frame's units ([`Share::validate`]); a region
/// outside the image.
pub fn render_path_sums(
    world: &World,
    camera: &Camera,
    image: &ImageSettings,
    path: &PathSettings,
    share: Share,
    region: Option<Region>,
    hooks: &Hooks,
) -> Result<(FrameStats, PathSums), RenderError> {
    image.validate()?;
    path.validate()?;
    share.validate(path)?;
    let filtered = path.filtered();
    let region = match region {
        Some(r) if r.x0 + r.width > image.width || r.y0 + r.height > image.height || r.pixels() == 0 => {
            return Err(RenderError::InvalidSetting(format!(
                "the region {}x{} at ({}, {}) is not inside the {}x{} image",
                r.width, r.height, r.x0, r.y0, image.width, image.height
            )));
        }
        // Independent pixels: the region is an image of its own.
        Some(r) if !filtered => return render_path_sums(world, camera, &image.sub(r), path, share, None, hooks),
        Some(r) => r,
        None => Region::whole(image.width, image.height),
    };
    // Splatted, a pixel holds its neighbours' samples too: a window of the film is traced
    // with the splats' reach around it (as far as the film goes) and cut out, so that its
    // pixels are the whole film's bit for bit. Its progress is reported in its own rows.
    let reach = path.splat_reach() as u32;
    let (grown, inner) = image.grown(reach);
    if grown != *image {
        let (traced, shown) = (u64::from(grown.height), u64::from(image.height));
        let whole = Region::whole(grown.width, grown.height);
        let (stats, sums) =
            hooks.scaled(shown, traced, |hooks| trace_sums(world, camera, &grown, path, share, whole, hooks))?;
        return Ok((stats, sums.crop(inner)));
    }
    trace_sums(world, camera, image, path, share, region, hooks)
}

/// [`render_path_sums`] of `region` of `image` (checked).
fn trace_sums(
    world: &World,
    camera: &Camera,
    image: &ImageSettings,
    path: &PathSettings,
    share: Share,
    region: Region,
    hooks: &Hooks,
) -> Result<(FrameStats, PathSums), RenderError> {
    let filtered = path.filtered();
    let tiled = region != Region::whole(image.width, image.height);
    // The sums and guide buffers: the last frame's memory when it fits, cleared in the frame;
    // else made and first touched on every thread before the frame's clock starts, and
    // reported apart (`FrameStats::setup`), so that the first frame of a process (`glint
    // render`) times what a benchmark's or the viewer's later frames time.
    let setup = Instant::now();
    let kept_planes =
        || FILTER_BUFFERS.lock().is_ok_and(|b| b.as_ref().is_some_and(|b| b.depth.len() == image.pixels()));
    let fresh = !sums::POOL.fits(region.pixels())
        || !GUIDES.fits(image.pixels())
        || !sums::FIRST.fits(region.pixels())
        || (filtered && !kept_planes());
    if fresh {
        if filtered {
            let mut buffers = take_filter_buffers();
            buffers.size(image.pixels());
            keep_filter_buffers(buffers);
            glint_filter::reserve(&path.filter, image.width as usize, image.height as usize);
        }
        let what = || format!("the path accumulator of a {} x {} image", region.width, region.height);
        sums::POOL.give(sums::POOL.take(region.pixels(), PixelSums::default(), what)?);
        let what = || format!("the guide rays of a {} x {} image", image.width, image.height);
        GUIDES.give(GUIDES.take(image.pixels(), GuidePixel::default(), what)?);
        let what = || format!("the first samples of a {} x {} image", region.width, region.height);
        sums::FIRST.give(sums::FIRST.take(region.pixels(), FirstSample::default(), what)?);
    }
    let setup = if fresh { setup.elapsed() } else { Duration::ZERO };
    let start = Instant::now();
    let frame = Frame::new(world, camera, image, path);
    let what = || format!("the path accumulator of a {} x {} image", region.width, region.height);
    // The last frame's sums, not cleared here: the first step resets each band's as it
    // starts (in cache), instead of a separate pass over 200 MB (1024 × 768).
    let mut acc = sums::POOL.take_stale(region.pixels(), PixelSums::default(), what)?;
    let mut first: Option<Vec<GuidePixel>> = None;
    let mut stats = FrameStats::default();
    let (mut trace, mut filter) = (Duration::ZERO, Duration::ZERO);
    // Progress is reported over the first step, by the loop that finishes its pixels.
    let quiet = Hooks { progress: None, ..*hooks };
    let spp = u64::from(path.spp);
    let units = share.units(path.units());
    // A step is a pass (filtered: each pass filters its own guide rays) or, without a filter,
    // any run of samples: the sums of a frame's samples do not depend on how they are grouped
    // (fixed point; each sample's streams are its index's), so the share's samples are one
    // step and a time budget adds steps of many passes (`next_step`). Passes of one sample
    // each cost 11 % more than one pass of all (Mitsuba's Cornell box, 24 spp: the sums are
    // read and written once a pass, and a pixel's samples are traced apart).
    let per_pass = if filtered { 1 } else { spp };
    let mut unit = units.start;
    let mut step_passes = if filtered { 1 } else { units.end.div_ceil(per_pass) - unit / per_pass };
    loop {
        let pass_start = Instant::now();
        let pass = unit / per_pass;
        let step_end = ((pass + step_passes) * per_pass).min(if share.count == 1 { u64::MAX } else { units.end });
        let (base, count) = if filtered { (pass * spp, 1) } else { (unit, step_end - unit) };
        let first_step = unit == units.start;
        let trace_start = Instant::now();
        // A region's progress is its own rows, which only the lookups visit alone.
        let lookups_report = filtered && (spp > 1 || tiled);
        let guide_hooks = if first_step && !lookups_report { hooks } else { &quiet };
        let sums = Sums { acc: &mut acc, stale: first_step };
        // A filtered pass's guide rays write the filter's input planes as they go.
        let mut inputs = filtered.then(take_filter_buffers);
        let (guides, far) =
            trace_guides(world, &frame, path, base, count, sums, inputs.as_mut(), guide_hooks, &mut stats)?;
        trace += trace_start.elapsed();
        if let Some(mut buffers) = inputs {
            let filter_start = Instant::now();
            filter_inputs(frame.width, guides.len() / frame.width.max(1), far, &path.filter, &mut buffers)?;
            filter += filter_start.elapsed();
            let trace_start = Instant::now();
            let lookup_hooks = if first_step && lookups_report { hooks } else { &quiet };
            let lookups = Lookups { guides: &guides, filtered: &buffers, region };
            let sums = Sums { acc: &mut acc, stale: first_step };
            let traced = trace_lookups(world, &frame, path, base, &lookups, sums, lookup_hooks, &mut stats);
            keep_filter_buffers(buffers);
            traced?;
            trace += trace_start.elapsed();
        }
        if unit == 0 {
            first = Some(guides);
        } else {
            GUIDES.give(guides);
        }
        // The step's time per pass (its passes are whole but for a share's first and last).
        let per_pass_time = pass_start.elapsed() / (step_end - unit).div_ceil(per_pass).max(1) as u32;
        unit = step_end;
        if unit < units.end {
            continue;
        }
        // Only a whole frame has a time budget (Share::validate), and its passes stop where a
        // pixel's sums could overflow.
        let room = (fixed::MAX_TERMS / (spp * path.splat_footprint())).saturating_sub(unit / per_pass);
        match path.time_budget.map(|budget| next_step(budget.saturating_sub(start.elapsed()), per_pass_time, filtered))
        {
            Some(n) if n > 0 && room > 0 => step_passes = n.min(room),
            _ => break,
        }
    }
    let passes = (unit.div_ceil(per_pass) - units.start / per_pass) as u32;
    let samples = if filtered { (unit - units.start) * spp } else { unit - units.start };
    let region_pixels = |g: &[GuidePixel]| -> Vec<GuidePixel> {
        let (x0, w) = (region.x0 as usize, image.width as usize);
        (region.y0 as usize..(region.y0 + region.height) as usize)
            .flat_map(|y| g[y * w + x0..][..region.width as usize].iter().copied())
            .collect()
    };
    let first_sample = |g: &GuidePixel| FirstSample {
        normal: g.sample.guide.map_or(Vec3::ZERO, |q| q.normal),
        albedo: g.sample.albedo,
        depth: g.sample.guide.map_or(f32::INFINITY, |q| q.depth),
    };
    let first = match first {
        Some(g) => {
            let what = || format!("the first samples of a {} x {} image", region.width, region.height);
            // Every element is written below.
            let mut samples = sums::FIRST.take_stale(region.pixels(), FirstSample::default(), what)?;
            match tiled {
                true => {
                    samples.par_iter_mut().zip(region_pixels(&g).par_iter()).for_each(|(s, g)| *s = first_sample(g))
                }
                false => samples.par_iter_mut().zip(g.par_iter()).for_each(|(s, g)| *s = first_sample(g)),
            }
            GUIDES.give(g);
            Some(samples)
        }
        None => None,
    };
    let sums = PathSums {
        width: region.width,
        height: region.height,
        filtered,
        splat: frame.splat.is_some(),
        aovs: path.aovs,
        units: unit - units.start,
        pixels: acc,
        first,
    };
    stats.passes = passes;
    stats.samples_per_pixel = samples as u32;
    stats.paths = region.pixels() as u64 * samples;
    stats.elapsed = start.elapsed();
    stats.setup = setup;
    stats.stages = vec![("trace", trace), ("filter", filter)];
    Ok((stats, sums))
}

/// How many passes a time budget's next step traces, `left` of the budget remaining and a
/// pass taking `per_pass` (the last step's): none when a pass no longer fits; one with a
/// filter; without one, half of those that fit (at least one), so that an estimate off by
/// the machine's noise overshoots by a fraction of a small last step, while the budget is
/// spent in a few steps rather than a pass at a time.
fn next_step(left: Duration, per_pass: Duration, filtered: bool) -> u64 {
    let fit = (left.as_nanos() / per_pass.as_nanos().max(1)).min(u128::from(u32::MAX)) as u64;
    match fit {
        0 => 0,
        _ if filtered => 1,
        _ => (fit / 2).max(1),
    }
}

/// The scene's depth scale for the filter's guide: 1 / its bounding diagonal.
fn depth_scale(world: &World) -> f32 {
    let bounds = world.bounds();
    if bounds.is_empty() { 1.0 } else { 1.0 / bounds.diagonal_length().max(1e-6) }
}

/// The sums a step adds to: the share's pixels, `stale` in its first step (each band's are
/// reset before they are added to).
struct Sums<'a> {
    acc: &'a mut [PixelSums],
    stale: bool,
}

/// A pass's first step: every pixel's guide ray (through its centre when a filter runs) and,
/// without a filter, `count` samples from `base` on, added to the sums (the returned guides are
/// sample `base`'s; with a filter the sums are not touched). With `inputs` (a filtered pass),
/// each band then writes its pixels into the filter's input planes while its guide samples
/// are in cache (no pass over the whole image's 72-byte samples after the trace); the second
/// value returned is the largest guide depth written, for [`filter_inputs`].
#[allow(clippy::too_many_arguments)]
fn trace_guides(
    world: &World,
    frame: &Frame,
    path: &PathSettings,
    base: u64,
    count: u64,
    sums: Sums,
    inputs: Option<&mut FilterBuffers>,
    hooks: &Hooks,
    stats: &mut FrameStats,
) -> Result<(Vec<GuidePixel>, f32), RenderError> {
    let w = frame.width;
    let reach = frame.splat.map_or(0, |f| f.reach());
    // Splatted bands are taller: a band's halo is `reach` rows above and below it.
    let band_rows = if reach > 0 { splat::band_rows(reach, BAND_ROWS) } else { BAND_ROWS };
    let band_len = w * band_rows;
    let n = frame.image.pixels();
    let what = || format!("the guide rays of a {} x {} image", frame.width, frame.image.height);
    let mut guides = GUIDES.take(n, GuidePixel::default(), what)?;
    let mut fars = vec![0.0f32; n.div_ceil(band_len.max(1))];
    let depth_scale = depth_scale(world);
    type Part<'a> = (&'a mut [GuidePixel], &'a mut [PixelSums], Option<InputBand<'a>>, &'a mut f32);
    let parts: Vec<Part<'_>> = match inputs {
        Some(buffers) => {
            let bands = buffers.bands(n, band_len);
            guides
                .chunks_mut(band_len)
                .zip(bands)
                .zip(&mut fars)
                .map(|((g, b), f)| (g, &mut [][..], Some(b), f))
                .collect()
        }
        None => {
            let acc = sums.acc.chunks_mut(band_len);
            guides.chunks_mut(band_len).zip(acc).zip(&mut fars).map(|((g, a), f)| (g, a, None, f)).collect()
        }
    };
    let filtered = path.filtered();
    let halos = std::sync::Mutex::new(Vec::new());
    let totals = bands::run(parts, frame.schedule, hooks, |band, (gs, accs, inputs, far)| {
        if sums.stale {
            accs.fill(PixelSums::default());
        }
        let height = frame.image.height as usize;
        // Splatted, the band's sums are the splats' (with their halo).
        let (mut splats, accs) = match frame.splat {
            Some(f) => (Some(splat::BandSplats::new(f, w, height, band * band_rows, accs)), &mut [][..]),
            None => (None, accs),
        };
        let mut tracer = Tracer::new(world, frame, path.kernel);
        let (mut rejected, mut clamped) = (0, 0);
        // The guide ray of the first pass goes through the pixel centre (the guide and the
        // AOVs); every other sample, later passes' guide rays included, is jittered, so a pixel
        // centre on a crack does not stay dark for the whole budget.
        let request = |k: usize, s: u64| Request {
            x: k % w,
            y: band * band_rows + k / w,
            index: base + s,
            centre: base + s == 0,
            mode: IndirectMode::Trace,
        };
        tracer.samples(gs.len(), count, request, |k, s, offset, cs| {
            let Some(cs) = cs.admitted(&mut rejected, &mut clamped) else {
                match splats.as_mut() {
                    Some(splats) => splats.own(k).samples += 1,
                    None if !filtered => accs[k].samples += 1,
                    None => {}
                }
                return;
            };
            let cs = &cs;
            if s == 0 {
                gs[k].sample = *cs;
            }
            if let Some(splats) = splats.as_mut() {
                splats.add(k, offset, cs, path.aovs);
            } else if !filtered {
                let a = &mut accs[k];
                a.add_sample(cs.rest + cs.albedo * cs.indirect, cs.direct, cs.indirect, path.aovs);
                a.covered += cs.covered as u32;
                a.samples += 1;
            }
        });
        // The filter's inputs, while the band's guide samples are in cache.
        if let Some(mut inputs) = inputs {
            for (k, g) in gs.iter().enumerate() {
                *far = far.max(inputs.put(k, g.sample.indirect, g.sample.guide, depth_scale));
            }
        }
        if let (Some(splats), Ok(mut halos)) = (splats, halos.lock()) {
            halos.push(splats.into_halo());
        }
        hooks.report((gs.len() / w) as u64);
        BandStats { rays: tracer.counts(), rejected, clamped }
    })?;
    if reach > 0 {
        let halos = halos.into_inner().map_err(|_| RenderError::InvalidSetting("a band's splats were lost".into()))?;
        splat::add_halos(sums.acc, w, reach, halos);
    }
    stats.rays.add(&totals.rays);
    stats.rejected_samples += totals.rejected;
    stats.clamped_samples += totals.clamped;
    Ok((guides, fars.into_iter().fold(0.0, f32::max)))
}

/// The kept [`FILTER_BUFFERS`] (or new ones), for a pass to fill and filter and then give
/// back with [`keep_filter_buffers`].
fn take_filter_buffers() -> FilterBuffers {
    FILTER_BUFFERS.lock().ok().and_then(|mut kept| kept.take()).unwrap_or_default()
}

/// The last pass's filter planes (a 1024 × 768 frame's ten are 31 MB: made and page-faulted
/// anew, they cost a Sponza frame's filter step more than the filter).
static FILTER_BUFFERS: std::sync::Mutex<Option<FilterBuffers>> = std::sync::Mutex::new(None);

/// Keep `buffers` for the next pass's [`take_filter_buffers`].
fn keep_filter_buffers(buffers: FilterBuffers) {
    if let Ok(mut kept) = FILTER_BUFFERS.lock() {
        *kept = Some(buffers);
    }
}

/// The guide map's planes of the last pass with lookups, kept for the next.
static MAP_NORMALS: crate::first_touch::Pool<Vec3> = crate::first_touch::Pool::new();
static MAP_DEPTHS: crate::first_touch::Pool<f32> = crate::first_touch::Pool::new();

/// What a pass's lookups read: the whole image's guide samples and their filtered indirect
/// light, and the pixels to finish (`region`, whose sums the step adds to).
struct Lookups<'a> {
    guides: &'a [GuidePixel],
    filtered: &'a FilterBuffers,
    region: Region,
}

/// A pass's third step: the guide samples' colours with the filtered indirect light, and the
/// further samples, which read it through the geometry-aware lookup.
#[allow(clippy::too_many_arguments)]
fn trace_lookups(
    world: &World,
    frame: &Frame,
    path: &PathSettings,
    base: u64,
    lookups: &Lookups,
    sums: Sums,
    hooks: &Hooks,
    stats: &mut FrameStats,
) -> Result<(), RenderError> {
    let Lookups { guides, filtered, region } = *lookups;
    let w = frame.width;
    let h = guides.len() / w.max(1);
    let further = path.spp as u64 - 1;
    // The guide map's planes, for the further samples' lookups (none at 1 spp).
    let n = if further > 0 { guides.len() } else { 0 };
    let what = || format!("the guide map of a {w} x {h} image");
    // Every element is written below: taken as the last pass left them, not cleared first.
    let mut normals = MAP_NORMALS.take_stale(n, Vec3::ZERO, what)?;
    let mut depths = MAP_DEPTHS.take_stale(n, f32::INFINITY, what)?;
    normals.par_iter_mut().zip(&mut depths).zip(guides).with_min_len(4096).for_each(|((n, d), g)| {
        (*n, *d) = g.sample.guide.map_or((Vec3::ZERO, f32::INFINITY), |q| (q.normal, q.depth));
    });
    let map = GuideMap { width: w, height: h, normal: &normals, depth: &depths };
    let (rx, rw) = (region.x0 as usize, region.width as usize);
    let parts: Vec<_> = sums.acc.chunks_mut(rw * BAND_ROWS).collect();
    let totals = bands::run(parts, frame.schedule, hooks, |band, accs| {
        if sums.stale {
            accs.fill(PixelSums::default());
        }
        let mut tracer = Tracer::new(world, frame, path.kernel);
        let (mut rejected, mut clamped) = (0, 0);
        let y0 = region.y0 as usize + band * BAND_ROWS;
        // A pass is never split between chunks, so its samples are summed per pixel in f32,
        // in their fixed order (the guide sample first), and the pass's sum goes into the
        // fixed-point sums once: a conversion per pixel and pass, not per sample.
        let mut pass: Vec<(Rgb, Rgb)> = Vec::with_capacity(accs.len());
        for (k, a) in accs.iter_mut().enumerate() {
            let i = (y0 + k / rw) * w + rx + k % rw;
            let g = &guides[i].sample;
            let indirect = filtered.filtered(i);
            pass.push((g.rest + g.albedo * indirect, g.direct));
            if path.aovs {
                fixed::add_rgb(&mut a.indirect, indirect);
            }
            a.covered += g.covered as u32;
            a.samples += 1;
        }
        let request = |k: usize, s: u64| Request {
            x: rx + k % rw,
            y: y0 + k / rw,
            index: base + 1 + s,
            centre: false,
            mode: IndirectMode::Lookup,
        };
        tracer.samples(accs.len(), further, request, |k, _, offset, cs| {
            let a = &mut accs[k];
            a.samples += 1;
            let Some(cs) = cs.admitted(&mut rejected, &mut clamped) else { return };
            // The image position, formed as the camera ray's was.
            let pos = Vec2::new((rx + k % rw) as f32, (y0 + k / rw) as f32) + offset;
            let indirect = match cs.guide {
                Some(q) => map.choose(pos, q.normal, q.depth).map_or(Rgb::ZERO, |j| filtered.filtered(j)),
                None => Rgb::ZERO,
            };
            let p = &mut pass[k];
            p.0 += cs.rest + cs.albedo * indirect;
            p.1 += cs.direct;
            a.covered += cs.covered as u32;
        });
        for (a, (colour, direct)) in accs.iter_mut().zip(&pass) {
            fixed::add_rgb(&mut a.colour, *colour);
            if path.aovs {
                fixed::add_rgb(&mut a.direct, *direct);
            }
        }
        hooks.report((accs.len() / rw) as u64);
        BandStats { rays: tracer.counts(), rejected, clamped }
    })?;
    MAP_NORMALS.give(normals);
    MAP_DEPTHS.give(depths);
    stats.rays.add(&totals.rays);
    stats.rejected_samples += totals.rejected;
    stats.clamped_samples += totals.clamped;
    Ok(())
}

/// The planes [`filter_indirect`] fills and the filter writes into, kept between calls by a
/// caller that filters every frame (fresh pages cost more than filling them).
#[derive(Clone, Debug, Default)]
pub(crate) struct FilterBuffers {
    indirect: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    depth: Vec<f32>,
    out: [Vec<f32>; 3],
}

impl FilterBuffers {
    /// Every plane at `n` pixels (grown on every thread; what they held is kept).
    fn size(&mut self, n: usize) {
        let FilterBuffers { indirect, normal, depth, out } = self;
        for v in indirect.iter_mut().chain(normal.iter_mut()).chain([depth]).chain(out.iter_mut()) {
            crate::first_touch::resize(v, n, 0.0);
        }
    }

    /// The input planes at `n` pixels, split into bands of `band_len` pixels.
    fn bands(&mut self, n: usize, band_len: usize) -> Vec<InputBand<'_>> {
        self.size(n);
        let FilterBuffers { indirect, normal, depth, .. } = self;
        let [p0, p1, p2] = indirect;
        let [n0, n1, n2] = normal;
        let mut planes = [p0, p1, p2, n0, n1, n2, depth].map(|p| p.chunks_mut(band_len.max(1)));
        let mut bands = Vec::with_capacity(n.div_ceil(band_len.max(1)));
        // The seven planes are equally long, so they run out of bands together.
        while let [Some(a), Some(b), Some(c), Some(d), Some(e), Some(f), Some(g)] =
            planes.each_mut().map(Iterator::next)
        {
            bands.push(InputBand([a, b, c, d, e, f, g]));
        }
        bands
    }

    /// The filtered indirect light of pixel `i` (after [`filter_indirect`]).
    #[inline]
    pub(crate) fn filtered(&self, i: usize) -> Rgb {
        Rgb::new(self.out[0][i], self.out[1][i], self.out[2][i])
    }
}

/// One band's rows of a [`FilterBuffers`]'s input planes: demodulated indirect light (3),
/// guide normal (3) and depth, as [`FilterBuffers::bands`] splits them.
pub(crate) struct InputBand<'a>([&'a mut [f32]; 7]);

impl InputBand<'_> {
    /// Pixel `k` of the band: indirect light `indirect` at guide vertex `guide` (depth times
    /// `depth_scale`), or, without one, a zero normal and [`MISSING`] depth. Returns the
    /// depth written.
    #[inline]
    fn put(&mut self, k: usize, indirect: Rgb, guide: Option<integrator::GuideGeometry>, depth_scale: f32) -> f32 {
        let (ind, nrm, z) = match guide {
            Some(q) => (indirect, q.normal, q.depth * depth_scale),
            None => (Rgb::ZERO, Vec3::ZERO, MISSING),
        };
        let [p0, p1, p2, n0, n1, n2, d] = &mut self.0;
        (p0[k], p1[k], p2[k]) = (ind.x, ind.y, ind.z);
        (n0[k], n1[k], n2[k]) = (nrm.x, nrm.y, nrm.z);
        d[k] = z;
        z
    }
}

/// The depth [`InputBand::put`] writes for a pixel without a guide vertex until
/// [`filter_inputs`] knows the farthest guide (depths are never negative).
const MISSING: f32 = -1.0;

/// Fill `buffers`' input planes from `indirect(i)` and `guide(i)` for every pixel, in
/// parallel bands, and return the largest guide depth (times `depth_scale`; 0 if none).
fn fill_inputs(
    indirect: impl Fn(usize) -> Rgb + Sync,
    guide: impl Fn(usize) -> Option<integrator::GuideGeometry> + Sync,
    n: usize,
    band_len: usize,
    depth_scale: f32,
    buffers: &mut FilterBuffers,
) -> f32 {
    let bands = buffers.bands(n, band_len);
    bands
        .into_par_iter()
        .enumerate()
        .map(|(b, mut band)| {
            let mut far = 0.0f32;
            for k in 0..band.0[6].len() {
                let i = b * band_len + k;
                far = far.max(band.put(k, indirect(i), guide(i), depth_scale));
            }
            far
        })
        .reduce(|| 0.0f32, f32::max)
}

/// Filter the demodulated indirect light in `buffers`' input planes (filled by
/// [`InputBand::put`], whose largest depth is `far`), guided by their normals and depths,
/// into `buffers` (read with [`FilterBuffers::filtered`]). Depth is divided by the scene's
/// diagonal (a constant of the scene, not of the view); pixels without a guide vertex get a
/// zero normal and a depth one scene diagonal beyond the farthest guide, set here in one
/// pass over the depth plane.
fn filter_inputs(
    width: usize,
    height: usize,
    far: f32,
    filter: &Filter,
    buffers: &mut FilterBuffers,
) -> Result<(), RenderError> {
    let FilterBuffers { indirect: planes, normal, depth, out } = buffers;
    let far = far + 1.0;
    depth.par_chunks_mut(1 << 14).for_each(|d| {
        for z in d {
            if *z == MISSING {
                *z = far;
            }
        }
    });
    let guide = glint_filter::Guide { width, height, normal: [&normal[0], &normal[1], &normal[2]], depth: &depth[..] };
    let [o0, o1, o2] = &mut *out;
    glint_filter::apply_into(filter, [&planes[0], &planes[1], &planes[2]], &guide, [o0, o1, o2])
        .map_err(|e| RenderError::Filter(e.to_string()))
}

/// Filter demodulated indirect light (`indirect(i)` for pixel i, used where the pixel has a
/// guide vertex `guide(i)`) as [`filter_inputs`] does, its planes filled first.
fn filter_indirect(
    indirect: impl Fn(usize) -> Rgb + Sync,
    guide: impl Fn(usize) -> Option<integrator::GuideGeometry> + Sync,
    width: usize,
    height: usize,
    depth_scale: f32,
    filter: &Filter,
    buffers: &mut FilterBuffers,
) -> Result<(), RenderError> {
    let n = width * height;
    let far = fill_inputs(indirect, guide, n, width * 8, depth_scale, buffers);
    filter_inputs(width, height, far, filter, buffers)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::expect_used)] // test code: a failure is the report

    use super::*;
    use crate::settings::ImageSettings;

    /// A time budget's steps: none once a pass no longer fits, a pass at a time with a filter,
    /// half of what fits without one.
    #[test]
    fn a_time_budget_steps_through_half_of_what_fits() {
        let ms = Duration::from_millis;
        assert_eq!(next_step(ms(9), ms(10), false), 0, "no pass fits");
        assert_eq!(next_step(ms(9), ms(10), true), 0);
        assert_eq!(next_step(ms(95), ms(10), true), 1, "a filtered pass at a time");
        assert_eq!(next_step(ms(95), ms(10), false), 4);
        assert_eq!(next_step(ms(15), ms(10), false), 1);
        assert_eq!(next_step(ms(15), Duration::ZERO, false), 7_500_000, "no time measured: 1 ns a pass");
    }

    /// A splatted pixel sums up to (2·reach + 1)² terms per sample: the samples per pixel are
    /// capped so that no fixed-point sum can overflow, with a message naming the way out;
    /// drawing positions from the filter, or a filtered frame, keeps the usual cap.
    #[test]
    fn splatted_sample_counts_are_capped_so_no_sum_can_overflow() {
        let gaussian = PathSettings { pixel_filter: PixelFilter::Gaussian { stddev: 0.5 }, ..PathSettings::default() };
        assert_eq!((gaussian.splat_reach(), gaussian.splat_footprint()), (2, 25));
        let at = |spp: u32, passes: u32, p: PathSettings| PathSettings { spp, passes, ..p }.validate();
        let cap = (fixed::MAX_TERMS / 25) as u32;
        assert!(at(cap, 1, gaussian).is_ok());
        let e = at(cap + 1, 1, gaussian).expect_err("over the cap").to_string();
        assert!(e.contains("at most 41943 samples per pixel") && e.contains("--reconstruction sample"), "{e}");
        assert!(at(cap / 2 + 1, 2, gaussian).is_err(), "passes count");
        let sampled = PathSettings { reconstruction: Reconstruction::Sample, ..gaussian };
        assert_eq!(sampled.splat_reach(), 0);
        assert!(at(65_536, 16, sampled).is_ok());
        let filtered = PathSettings { filter: Filter::Guided(glint_filter::GuidedParams::for_width(64)), ..gaussian };
        assert_eq!(filtered.splat_reach(), 0);
        assert!(at(65_536, 1, filtered).is_ok());
        let wide = PathSettings { pixel_filter: PixelFilter::Tent { radius: 16.0 }, ..gaussian };
        assert!(at(962, 1, wide).is_ok() && at(963, 1, wide).is_err(), "33 x 33 pixels a sample");
    }

    /// The wavefront's lanes kernels (vertices without delta lobes, mesh hits) give the same
    /// picture bit for bit on the SSE baseline and with AVX2 (where the CPU has it): Mitsuba's
    /// Cornell box, and the same box glossy under a sky and a sun, plain and guided.
    #[test]
    fn the_lanes_kernels_give_the_same_bits_on_every_instruction_set() {
        use std::sync::atomic::Ordering::Relaxed;
        let dir = std::path::Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes"));
        let text = include_str!("../../../../scenes/mitsuba-cbox.toml");
        let scene = glint_formats::load_scene_str(text, dir, "mitsuba-cbox.toml").expect("scene").scene;
        let mut sunlit = scene.clone();
        sunlit.sky =
            glint_scene::Sky::Gradient { zenith: Rgb::new(0.2, 0.3, 0.8), horizon: Rgb::ONE, ground: Rgb::ZERO };
        let (direction, colour) = (Vec3::new(0.3, -0.4, -1.0).normalize(), Rgb::new(1.0, 0.9, 0.8));
        sunlit.lights.push(glint_scene::Light::Directional { direction, colour, intensity: 2.0 });
        for m in &mut sunlit.materials {
            (m.specular, m.shininess) = (0.4, 20.0);
        }
        let schedule = crate::bands::Schedule::WorkStealing;
        let image = ImageSettings { width: 48, height: 40, seed: 5, schedule, window: None };
        let guided = Filter::Guided(glint_filter::GuidedParams::for_width(48));
        for world in [World::new(scene), World::new(sunlit)] {
            assert!(crate::path::lights_in_lanes(&world));
            for path in [
                PathSettings { spp: 3, max_bounces: 4, rr_start: 1, ..PathSettings::default() },
                PathSettings { spp: 2, filter: guided, filter_area_direct: true, ..PathSettings::default() },
            ] {
                let frame = |baseline: bool| {
                    crate::LANES_BASELINE.store(baseline, Relaxed);
                    let mut film = Film::new(1, 1);
                    let camera = &world.scene().camera;
                    render_path(&world, camera, &image, &path, &Hooks::default(), &mut film).expect("render");
                    crate::LANES_BASELINE.store(false, Relaxed);
                    film.pixels.iter().map(|p| p.colour.to_array().map(f32::to_bits)).collect::<Vec<_>>()
                };
                let (avx, sse) = (frame(false), frame(true));
                assert_eq!(avx, sse, "{path:?}");
                assert!(avx.iter().filter(|p| p.iter().any(|&b| f32::from_bits(b) > 0.01)).count() > 1000);
            }
        }
    }

    #[test]
    fn the_guide_rays_write_the_inputs_a_fill_from_their_samples_writes() {
        // Sky shows between the spheres, so some pixels have no guide vertex.
        let text = include_str!("../../../../scenes/whitted-bench.toml");
        let scene = glint_formats::load_scene_str(text, std::path::Path::new("."), "bench.toml").expect("scene").scene;
        let world = World::new(scene);
        let (w, h) = (40usize, 26usize);
        let schedule = crate::bands::Schedule::WorkStealing;
        let image = ImageSettings { width: w as u32, height: h as u32, seed: 3, schedule, window: None };
        let filter = Filter::Guided(glint_filter::GuidedParams::for_width(w));
        let path = PathSettings { filter, ..PathSettings::default() };
        let frame = Frame::new(&world, &world.scene().camera, &image, &path);
        let mut acc = vec![PixelSums::default(); w * h];
        let sums = Sums { acc: &mut acc, stale: true };
        let mut traced = FilterBuffers::default();
        let mut stats = FrameStats::default();
        let (guides, far) =
            trace_guides(&world, &frame, &path, 0, 1, sums, Some(&mut traced), &Hooks::default(), &mut stats)
                .expect("trace");
        let mut filled = FilterBuffers::default();
        let scale = depth_scale(&world);
        let want =
            fill_inputs(|i| guides[i].sample.indirect, |i| guides[i].sample.guide, w * h, 7 * w, scale, &mut filled);
        assert_eq!(far.to_bits(), want.to_bits());
        assert!(far > 0.0);
        let bits = |b: &FilterBuffers| {
            let planes = b.indirect.iter().chain(&b.normal).chain([&b.depth]);
            planes.map(|p| p.iter().map(|v| v.to_bits()).collect::<Vec<_>>()).collect::<Vec<_>>()
        };
        assert_eq!(bits(&traced), bits(&filled));
        let missing = traced.depth.iter().filter(|&&z| z == MISSING).count();
        assert!(missing > 0 && missing < w * h, "{missing} pixels without a guide vertex");
        // Filtering sets them one scene diagonal beyond the farthest guide.
        filter_inputs(w, h, far, &path.filter, &mut traced).expect("filter");
        assert!(traced.depth.iter().all(|&z| z != MISSING && z <= far + 1.0));
        assert_eq!(traced.depth.iter().filter(|&&z| z == far + 1.0).count(), missing);
    }
}
