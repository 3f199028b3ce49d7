//! Path tracing that refines from frame to frame (the viewer's path mode at rest).
//!
//! Each [`PathAccumulator::add_pass`] traces `spp` new samples per pixel, every one a full path
//! whose diffuse indirect light at the guide vertex is kept *demodulated* (divided by the
//! albedo there). [`PathAccumulator::resolve`] then filters the accumulated mean of that
//! indirect light, guided by the first pass's normals and depths (traced through the pixel
//! centres, so the guide does not flicker), and modulates it again by the mean albedo:
//!
//!   colour = mean(rest) + mean(albedo) ⊙ filter(mean(indirect)),
//!
//! the demodulate–filter–remodulate scheme of the paper's first step, run on an accumulation
//! that gets less noisy with every pass (so the filter blurs less and less of what it sees; with
//! the filter off the colour is the exact running average, `render_path` with N·spp samples).
//! Sample k of pixel p uses the same hash stream as `render_path`'s sample k: the first pass's
//! first sample goes through the centre, every other one is jittered, and the image is the same
//! whatever the thread count. A film filter wider than a pixel is applied by drawing each
//! sample's position from it (`Reconstruction::Sample`), never by splatting: a pixel's sums are
//! its own samples'.
//!
//! A viewer calls this every frame, so nothing is allocated per frame once the size is set: the
//! first pass after a reset clears each pixel's sums as it traces it, and the filter's planes
//! are kept between frames. Samples are traced by the settings' [`super::PathKernel`] (the
//! wavefront tracer by default).

use super::integrator::{GuideGeometry, IndirectMode};
use super::wavefront::Request;
use super::{BAND_ROWS, FilterBuffers, Frame, PathSettings, Tracer, depth_scale, filter_indirect};
use crate::bands::{self, Hooks};
use crate::film::{Film, FilmPixel, FilmRows, PathAovs, SurfacePixel};
use crate::fixed;
use crate::settings::ImageSettings;
use crate::stats::{BandStats, FrameStats};
use crate::{RenderError, World};
use glint_core::{Reconstruction, Rgb, Vec3};
use glint_filter::Filter;
use glint_scene::Camera;
use rayon::prelude::*;
use std::time::{Duration, Instant};

/// Per-pixel sums over every sample of every pass.
#[derive(Clone, Copy, Debug, Default)]
struct Sums {
    /// rest + albedo ⊙ indirect, sample by sample (the unfiltered beauty), in fixed point as
    /// `render_path` sums it, so that N passes are its N samples bit for bit.
    colour: [i128; 3],
    rest: Rgb,
    albedo: Rgb,
    direct: Rgb,
    indirect: Rgb,
    /// Samples with a guide vertex (the ones whose indirect light counts).
    guided: u32,
    covered: u32,
    samples: u32,
}

/// The running sums of a progressive path-traced image (see the module comment).
#[derive(Clone, Debug, Default)]
pub struct PathAccumulator {
    width: u32,
    height: u32,
    passes: u32,
    sums: Vec<Sums>,
    /// The first pass's first sample of each pixel (through its centre): the filter's guide and
    /// the normal/depth AOVs.
    guides: Vec<Option<GuideGeometry>>,
    centre_albedo: Vec<Rgb>,
    /// The filter's planes, kept between frames.
    filter_buffers: FilterBuffers,
}

impl PathAccumulator {
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Forget every pass (the camera, the scene or a setting changed).
    pub fn reset(&mut self) {
        self.passes = 0;
    }

    /// Passes accumulated since the last reset.
    #[must_use]
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// Samples per pixel accumulated since the last reset.
    #[must_use]
    pub fn samples_per_pixel(&self) -> u32 {
        self.sums.first().map_or(0, |s| if self.passes == 0 { 0 } else { s.samples })
    }

    /// Trace `path.spp` more samples per pixel of the world seen by `camera` (the time budget
    /// is ignored). The filter is applied by [`PathAccumulator::resolve`]; here it
    /// only decides, with `filter_area_direct`, whether area lights' diffuse direct light joins
    /// the filtered part: pass the same filter to every pass and to `resolve`. A new image
    /// size starts over.
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] for settings outside their limits;
    /// [`RenderError::Cancelled`] when `hooks` cancel it (the pass is then not counted).
    pub fn add_pass(
        &mut self,
        world: &World,
        camera: &Camera,
        image: &ImageSettings,
        path: &PathSettings,
        hooks: &Hooks,
    ) -> Result<FrameStats, RenderError> {
        image.validate()?;
        path.validate()?;
        let start = Instant::now();
        let (w, h) = (image.width as usize, image.height as usize);
        if (image.width, image.height) != (self.width, self.height) {
            self.width = image.width;
            self.height = image.height;
            self.passes = 0;
            // The first pass clears every pixel it traces (in parallel, while its sums are in
            // cache), so only the sizes matter here.
            self.sums.resize(w * h, Sums::default());
            self.guides.resize(w * h, None);
            self.centre_albedo.resize(w * h, Rgb::ZERO);
        }
        // Each pixel's sums here are its own samples': a film filter wider than a pixel is
        // applied by drawing positions from it (the frame `render_path` would splat has the
        // same image in expectation).
        let path = &PathSettings { reconstruction: Reconstruction::Sample, ..*path };
        let frame = Frame::new(world, camera, image, path);
        let base = self.passes as u64 * path.spp as u64;
        let first = self.passes == 0;
        let band_len = w * BAND_ROWS;
        let parts: Vec<_> = self
            .sums
            .chunks_mut(band_len)
            .zip(self.guides.chunks_mut(band_len))
            .zip(self.centre_albedo.chunks_mut(band_len))
            .collect();
        let band_stats = bands::run(parts, image.schedule, hooks, |band, ((sums, guides), albedos)| {
            let mut tracer = Tracer::new(world, &frame, path.kernel);
            let (mut rejected, mut clamped) = (0, 0);
            if first {
                // The first pass clears every pixel it traces (in parallel, while its sums are
                // in cache).
                sums.fill(Sums::default());
                guides.fill(None);
                albedos.fill(Rgb::ZERO);
            }
            let request = |k: usize, s: u64| {
                let index = base + s;
                Request { x: k % w, y: band * BAND_ROWS + k / w, index, centre: index == 0, mode: IndirectMode::Trace }
            };
            tracer.samples(sums.len(), path.spp as u64, request, |k, s, _, cs| {
                let a = &mut sums[k];
                a.samples += 1;
                let Some(cs) = cs.admitted(&mut rejected, &mut clamped) else { return };
                if first && s == 0 {
                    guides[k] = cs.guide;
                    albedos[k] = cs.albedo;
                }
                fixed::add_rgb(&mut a.colour, cs.rest + cs.albedo * cs.indirect);
                a.rest += cs.rest;
                a.albedo += cs.albedo;
                a.direct += cs.direct;
                if cs.guide.is_some() {
                    a.indirect += cs.indirect;
                    a.guided += 1;
                }
                a.covered += cs.covered as u32;
            });
            hooks.report((sums.len() / w) as u64);
            BandStats { rays: tracer.counts(), rejected, clamped }
        });
        let band_stats = match band_stats {
            Ok(totals) => totals,
            Err(e) => {
                // A cancelled pass left the sums half updated: start over next time.
                self.passes = 0;
                return Err(e);
            }
        };
        self.passes += 1;
        let trace = start.elapsed();
        Ok(FrameStats {
            elapsed: trace,
            stages: vec![("trace", trace)],
            rays: band_stats.rays,
            rejected_samples: band_stats.rejected,
            clamped_samples: band_stats.clamped,
            passes: self.passes,
            samples_per_pixel: self.samples_per_pixel(),
            paths: (w * h) as u64 * u64::from(path.spp),
            ..FrameStats::default()
        })
    }

    /// The image so far of the world's scene: filtered as `filter` says (see the module
    /// comment), into `film` (resized). Returns the time the filter took. Nothing accumulated:
    /// an empty film.
    ///
    /// # Errors
    /// [`RenderError::Filter`] when the filter refuses its input.
    pub fn resolve(&mut self, world: &World, filter: &Filter, film: &mut Film) -> Result<Duration, RenderError> {
        let (w, h) = (self.width as usize, self.height as usize);
        if film.width != self.width || film.height != self.height {
            *film = Film::try_new(self.width, self.height)?;
        }
        if self.passes == 0 {
            let (FilmRows { pixels, surface }, path) = film.path_aovs_mut()?;
            pixels.fill(FilmPixel::default());
            surface.fill(SurfacePixel::default());
            path.fill(PathAovs::default());
            return Ok(Duration::ZERO);
        }
        let mean_indirect = |s: &Sums| if s.guided == 0 { Rgb::ZERO } else { s.indirect / s.guided as f32 };
        let start = Instant::now();
        let filtered = match filter {
            Filter::None => false,
            f => {
                let (sums, guides) = (&self.sums, &self.guides);
                filter_indirect(
                    |i| mean_indirect(&sums[i]),
                    |i| guides[i],
                    w,
                    h,
                    depth_scale(world),
                    f,
                    &mut self.filter_buffers,
                )?;
                true
            }
        };
        let filter_time = start.elapsed();
        let buffers = &self.filter_buffers;
        let (FilmRows { pixels, surface }, path) = film.path_aovs_mut()?;
        let records = pixels.par_iter_mut().zip(surface).zip(path);
        records.enumerate().for_each(|(i, ((p, t), q))| {
            let s = &self.sums[i];
            let n = s.samples.max(1) as f32;
            let guide = self.guides[i];
            let (colour, indirect) = if filtered {
                let f = buffers.filtered(i);
                (s.rest / n + s.albedo / n * f, f)
            } else {
                (fixed::mean(&s.colour, u64::from(s.samples)), mean_indirect(s))
            };
            *p = FilmPixel { colour, coverage: s.covered as f32 / n };
            *t = SurfacePixel {
                normal: guide.map_or(Vec3::ZERO, |q| q.normal),
                albedo: self.centre_albedo[i],
                depth: guide.map_or(f32::INFINITY, |q| q.depth),
            };
            *q = PathAovs { direct: s.direct / n, indirect, samples: s.samples as f32, variance: Rgb::ZERO };
        });
        Ok(filter_time)
    }
}
