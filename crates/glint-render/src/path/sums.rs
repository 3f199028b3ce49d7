//! A path-traced frame's per-pixel sums (pipeline: passes → **sums** → film): what every pass
//! adds to, in fixed point ([`crate::fixed`]), so that the sums of a frame's passes are the
//! same whether one process traced them all or chunks of them were traced apart and added
//! ([`PathSums::add`]); [`PathSums::resolve`] then makes the film. The single-process render
//! goes through the same two steps, so a merged frame equals it bit for bit by construction.

use crate::RenderError;
use crate::film::{Film, FilmPixel, FilmRows, PathAovs, SurfacePixel};
use crate::first_touch::Pool;
use crate::fixed::{self, Square};
use glint_core::{Rgb, Vec3};
use rayon::prelude::*;

/// One pixel's sums over the samples of the passes it holds. When samples are splatted
/// ([`PathSums::splat`]) the colour, direct and indirect sums are of the samples that reach
/// the pixel, each weighted by the pixel filter, and `weight` sums those weights; the counts
/// are of the pixel's own samples, and the squares are not kept. The direct and indirect
/// sums and the squares are the path AOVs' ([`PathSums::aovs`]): a frame without them leaves
/// them zero. The fields a frame always writes come first (together in cache).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PixelSums {
    pub colour: [i128; 3],
    /// Splatted: the sum of the filter weights of the samples that reach the pixel.
    pub weight: i128,
    pub covered: u32,
    pub samples: u32,
    pub direct: [i128; 3],
    /// Without a filter: each sample's demodulated indirect light; with one: each pass's
    /// filtered indirect light at the pixel centre.
    pub indirect: [i128; 3],
    /// Without a filter: the squares of each sample's colour (the variance AOV).
    pub square: [Square; 3],
}

impl PixelSums {
    /// Add an unfiltered sample that stays in its pixel: its colour, and when `aovs` its
    /// direct and indirect light and its colour's square (the variance's moments).
    #[inline]
    pub(crate) fn add_sample(&mut self, colour: Rgb, direct: Rgb, indirect: Rgb, aovs: bool) {
        fixed::add_rgb(&mut self.colour, colour);
        if aovs {
            for (s, v) in self.square.iter_mut().zip(colour.to_array()) {
                s.add_square(v);
            }
            fixed::add_rgb(&mut self.direct, direct);
            fixed::add_rgb(&mut self.indirect, indirect);
        }
    }

    pub(super) fn add(&mut self, o: &PixelSums) {
        for k in 0..3 {
            self.colour[k] += o.colour[k];
            self.direct[k] += o.direct[k];
            self.indirect[k] += o.indirect[k];
            self.square[k].add(o.square[k]);
        }
        self.covered += o.covered;
        self.samples += o.samples;
        self.weight += o.weight;
    }

    /// Add a splat of weight `w` in (0, 1]: the sample's terms weighted by it (each
    /// `trunc(v · w · 2^56)` exactly: its colour, and its direct and indirect light when they
    /// are summed), and the weight.
    #[inline]
    pub(crate) fn add_splat(&mut self, w: f32, terms: &SplatTerms) {
        let w64 = f64::from(w);
        let sums = [&mut self.colour, &mut self.direct, &mut self.indirect];
        let scaled = &terms.scaled[..terms.len];
        if terms.small {
            // Every |term| < 120 · 2^56 < 2^63: the machine's conversion, no range checks.
            for (sum, v) in sums.into_iter().zip(scaled.chunks_exact(3)) {
                for (s, &x) in sum.iter_mut().zip(v) {
                    *s += i128::from((x * w64) as i64);
                }
            }
        } else {
            for (sum, v) in sums.into_iter().zip(scaled.chunks_exact(3)) {
                for (s, &x) in sum.iter_mut().zip(v) {
                    *s += fixed::on_grid(x * w64);
                }
            }
        }
        self.weight += i128::from(fixed::scaled(w) as i64);
    }

    /// The sample variance of one sample's colour (Bessel-corrected; 0 below two samples).
    fn variance(&self) -> Rgb {
        if self.samples < 2 {
            return Rgb::ZERO;
        }
        let n = f64::from(self.samples);
        let v = |k: usize| {
            let sum = fixed::value(self.colour[k]);
            ((self.square[k].value() - sum * sum / n) / (n - 1.0)).max(0.0) as f32
        };
        Rgb::new(v(0), v(1), v(2))
    }
}

/// A sample's colour, direct and indirect light on the fixed grid's scale, ready to be
/// weighted into the pixels its splat reaches ([`PixelSums::add_splat`]).
pub(crate) struct SplatTerms {
    scaled: [f64; 9],
    /// The terms summed: the colour's 3, or all 9 when the path AOVs are.
    len: usize,
    /// Every summed value's magnitude is below [`fixed::SMALL`] (the fast conversion
    /// suffices).
    small: bool,
}

impl SplatTerms {
    /// The terms of a sample's `colour`, and of its `direct` and `indirect` light when `aovs`.
    pub(crate) fn new(colour: Rgb, direct: Rgb, indirect: Rgb, aovs: bool) -> Self {
        let values = [colour.to_array(), direct.to_array(), indirect.to_array()];
        let len = if aovs { 9 } else { 3 };
        let flat = &values.as_flattened()[..len];
        let small = flat.iter().all(|v| v.abs() < fixed::SMALL);
        let mut scaled = [0.0; 9];
        for (s, &v) in scaled.iter_mut().zip(flat) {
            *s = fixed::scaled(v);
        }
        Self { scaled, len, small }
    }
}

/// The AOVs of a pixel's first sample (the frame's first guide ray, through the centre).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FirstSample {
    pub normal: Vec3,
    pub albedo: Rgb,
    /// +inf where the first sample found no guide vertex.
    pub depth: f32,
}

impl Default for FirstSample {
    fn default() -> Self {
        Self { normal: Vec3::ZERO, albedo: Rgb::ZERO, depth: f32::INFINITY }
    }
}

/// What a share of a frame's passes adds up to (the whole frame, or a chunk of it).
#[derive(Clone, Debug, PartialEq)]
pub struct PathSums {
    pub width: u32,
    pub height: u32,
    /// A filter ran (the indirect sums are per pass, no squares).
    pub filtered: bool,
    /// Samples were splatted through the pixel filter: a pixel is its weighted sums over its
    /// weight ([`PixelSums`]).
    pub splat: bool,
    /// The path AOVs' sums (direct, indirect light, squares) were kept
    /// ([`super::PathSettings::aovs`]); without them the film has the beauty and the first
    /// sample's AOVs alone.
    pub aovs: bool,
    /// Passes (filtered) or samples (unfiltered) these sums hold: the frame's units of work.
    pub units: u64,
    pub pixels: Vec<PixelSums>,
    /// The first sample's AOVs, when these sums hold the frame's first unit.
    pub first: Option<Vec<FirstSample>>,
}

impl PathSums {
    /// Add `other`'s units (of the same frame: size and filter; other units). The first
    /// sample's AOVs come from whichever holds them.
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] when the two are of different frames' shapes or both
    /// hold the first unit.
    pub fn add(&mut self, other: &PathSums) -> Result<(), RenderError> {
        let shape = |s: &PathSums| (s.width, s.height, s.filtered, s.splat, s.aovs);
        if shape(self) != shape(other) {
            return Err(RenderError::InvalidSetting(format!(
                "cannot add the sums of a {}x{} frame (filtered: {}, splatted: {}, AOVs: {}) to a {}x{} one \
                 (filtered: {}, splatted: {}, AOVs: {})",
                other.width,
                other.height,
                other.filtered,
                other.splat,
                other.aovs,
                self.width,
                self.height,
                self.filtered,
                self.splat,
                self.aovs
            )));
        }
        if self.first.is_some() && other.first.is_some() {
            return Err(RenderError::InvalidSetting("two shares both hold the frame's first pass".into()));
        }
        for (a, b) in self.pixels.iter_mut().zip(&other.pixels) {
            a.add(b);
        }
        self.units += other.units;
        if self.first.is_none() {
            self.first.clone_from(&other.first);
        }
        Ok(())
    }

    /// The film of these sums: means over each pixel's samples (the indirect light, filtered,
    /// over the passes), the AOVs of the first sample; the path AOVs when the sums hold them.
    ///
    /// # Errors
    /// [`RenderError::Memory`] when the film cannot be allocated.
    pub fn resolve(&self, film: &mut Film) -> Result<(), RenderError> {
        film.reset(self.width, self.height)?;
        // A splatted pixel's samples are its neighbours' too: no per-sample variance.
        film.variance = self.aovs && !self.filtered && !self.splat;
        let none = FirstSample::default();
        let beauty = |i: usize, a: &PixelSums| {
            let n = u64::from(a.samples);
            let first = self.first.as_ref().map_or(&none, |f| &f[i]);
            let coverage = a.covered as f32 / n.max(1) as f32;
            let surface = SurfacePixel { normal: first.normal, albedo: first.albedo, depth: first.depth };
            let colour = if self.splat { fixed::ratio(&a.colour, a.weight) } else { fixed::mean(&a.colour, n) };
            (FilmPixel { colour, coverage }, surface)
        };
        // Independent pixels, on every thread (a 1024 × 768 frame's nine 128-bit means per pixel
        // took ~30 ms on one).
        if !self.aovs {
            let FilmRows { pixels, surface } = film.surface_mut()?;
            let records = pixels.par_iter_mut().zip(surface);
            records.zip(&self.pixels).enumerate().with_min_len(1024).for_each(|(i, ((p, t), a))| {
                (*p, *t) = beauty(i, a);
            });
            return Ok(());
        }
        let (FilmRows { pixels, surface }, path) = film.path_aovs_mut()?;
        let records = pixels.par_iter_mut().zip(surface).zip(path);
        records.zip(&self.pixels).enumerate().with_min_len(1024).for_each(|(i, (((p, t), q), a))| {
            (*p, *t) = beauty(i, a);
            let n = u64::from(a.samples);
            *q = if self.splat {
                let (direct, indirect) = (fixed::ratio(&a.direct, a.weight), fixed::ratio(&a.indirect, a.weight));
                PathAovs { direct, indirect, samples: a.samples as f32, variance: Rgb::ZERO }
            } else {
                PathAovs {
                    direct: fixed::mean(&a.direct, n),
                    indirect: fixed::mean(&a.indirect, if self.filtered { self.units } else { n }),
                    samples: a.samples as f32,
                    variance: if self.filtered { Rgb::ZERO } else { a.variance() },
                }
            };
        });
        Ok(())
    }

    /// The sums of `region`'s pixels (inside these sums' image), this frame's memory given
    /// back to [`POOL`].
    #[must_use]
    pub(crate) fn crop(self, region: crate::settings::Region) -> PathSums {
        if region == crate::settings::Region::whole(self.width, self.height) {
            return self;
        }
        let rows = |w: usize| {
            (region.y0 as usize..(region.y0 + region.height) as usize)
                .map(move |y| y * w + region.x0 as usize..y * w + (region.x0 + region.width) as usize)
        };
        let width = self.width as usize;
        let (filtered, splat, aovs, units) = (self.filtered, self.splat, self.aovs, self.units);
        let first = self.first.as_deref().map(|f| rows(width).flat_map(|r| f[r].iter().copied()).collect());
        let pixels = rows(width).flat_map(|r| self.pixels[r].iter().copied()).collect();
        let (width, height) = (region.width, region.height);
        let cropped = PathSums { width, height, filtered, splat, aovs, units, pixels, first };
        self.recycle();
        cropped
    }

    /// Give the pixels' and the first sample's memory back for the next frame's sums
    /// ([`POOL`], [`FIRST`]).
    pub(crate) fn recycle(self) {
        POOL.give(self.pixels);
        if let Some(first) = self.first {
            FIRST.give(first);
        }
    }
}

/// The last frame's sums (a 1024 × 768 frame's are 200 MB: their page faults were ~4 % of a
/// Sponza path frame).
pub(crate) static POOL: Pool<PixelSums> = Pool::new();

/// The last frame's first-sample AOVs (25 MB at 1024 × 768, mapped afresh every frame when
/// they were collected into a new vector).
pub(crate) static FIRST: Pool<FirstSample> = Pool::new();
