//! Settings of a frame: the image every mode draws ([`ImageSettings`]) and the Whitted
//! integrator's own ([`WhittedSettings`]). The path and points modes keep theirs beside their
//! code (`PathSettings`, `PointSettings`); each is checked against `glint_scene::limits`, the one
//! place the ranges are written.

use crate::RenderError;
use crate::bands::Schedule;
use glint_scene::RenderDefaults;
use glint_scene::limits::{self, MAX_IMAGE_SIDE, image_size_ok};

/// The image of a frame, whatever the mode: its size, the seed of every random number in it,
/// and how its bands are handed to threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImageSettings {
    pub width: u32,
    pub height: u32,
    /// The only source of randomness: every sample stream is `hash(pixel, sample, dim, seed)`.
    pub seed: u64,
    pub schedule: Schedule,
    /// The part of a larger film this image is (a crop window: pbrt's `--pixelbounds`,
    /// Mitsuba's film crop); None: the image is the whole film.
    pub window: Option<Window>,
}

/// Where an image lies in its film: pixel (x, y) of the image is pixel (x0 + x, y0 + y) of a
/// `full_width × full_height` film, traced through the same camera ray with the same random
/// numbers, so a crop's pixels are the film's own, bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub full_width: u32,
    pub full_height: u32,
    pub x0: u32,
    pub y0: u32,
}

/// A rectangle of an image's pixels: a tile of a frame split for a cluster (`glint render
/// --tile I/N`), in the image's own coordinates.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Region {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl Region {
    /// The whole of a `width × height` image.
    #[must_use]
    pub fn whole(width: u32, height: u32) -> Region {
        Region { x0: 0, y0: 0, width, height }
    }

    /// Tile `index` of `count` of a `width × height` image: a grid of `c × r = count` tiles
    /// whose shape is the squarest of the ways `count` factors (the fewest columns on a
    /// tie), tiles in row-major order, column j spanning `⌊j·width/c⌋ .. ⌊(j+1)·width/c⌋`
    /// (rows alike). Deterministic: the same split in every process.
    ///
    /// # Errors
    /// [`RenderError::InvalidSetting`] when the index is not below the count or the image has
    /// fewer pixels than the grid needs (a tile would be empty).
    pub fn tile(width: u32, height: u32, index: u32, count: u32) -> Result<Region, RenderError> {
        if count == 0 || index >= count {
            return Err(RenderError::InvalidSetting(format!(
                "tile {index}/{count}: the index must be below the count (0-based)"
            )));
        }
        let squareness = |c: u32| {
            let r = count / c;
            ((f64::from(width) / f64::from(c)) / (f64::from(height) / f64::from(r))).ln().abs()
        };
        let columns = (1..=count)
            .filter(|c| count.is_multiple_of(*c) && *c <= width && count / c <= height)
            .min_by(|&a, &b| squareness(a).total_cmp(&squareness(b)))
            .ok_or_else(|| {
                RenderError::InvalidSetting(format!(
                    "{count} tiles of a {width}x{height} image: no grid of {count} tiles fits (a tile would be empty)"
                ))
            })?;
        let rows = count / columns;
        let (j, i) = (index % columns, index / columns);
        let at = |k: u32, n: u32, side: u32| (u64::from(k) * u64::from(side) / u64::from(n)) as u32;
        let (x0, y0) = (at(j, columns, width), at(i, rows, height));
        Ok(Region { x0, y0, width: at(j + 1, columns, width) - x0, height: at(i + 1, rows, height) - y0 })
    }

    pub(crate) fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

impl ImageSettings {
    /// The image of `region`'s pixels: a window of this image's film with the same camera
    /// rays and random numbers, so its pixels are this image's own.
    #[must_use]
    pub fn sub(&self, region: Region) -> ImageSettings {
        let (fx, fy) = self.film_origin();
        let (full_width, full_height) =
            self.window.map_or((self.width, self.height), |w| (w.full_width, w.full_height));
        ImageSettings {
            width: region.width,
            height: region.height,
            window: Some(Window { full_width, full_height, x0: fx as u32 + region.x0, y0: fy as u32 + region.y0 }),
            ..*self
        }
    }
    /// This image grown by `margin` pixels on every side, as far as its film goes, and where
    /// this image lies in it. The grown image is a window of the same film (its pixels are
    /// the film's own); the film itself (no window) once it covers it.
    #[must_use]
    pub fn grown(&self, margin: u32) -> (ImageSettings, Region) {
        let (fx, fy) = self.film_origin();
        let (fx, fy) = (fx as u32, fy as u32);
        let (full_width, full_height) =
            self.window.map_or((self.width, self.height), |w| (w.full_width, w.full_height));
        let (x0, y0) = (fx.saturating_sub(margin), fy.saturating_sub(margin));
        let x1 = (fx + self.width).saturating_add(margin).min(full_width);
        let y1 = (fy + self.height).saturating_add(margin).min(full_height);
        let (width, height) = (x1 - x0, y1 - y0);
        let window =
            ((width, height) != (full_width, full_height)).then_some(Window { full_width, full_height, x0, y0 });
        let inner = Region { x0: fx - x0, y0: fy - y0, width: self.width, height: self.height };
        (ImageSettings { width, height, window, ..*self }, inner)
    }

    /// The whole film's camera rays: image pixel (x, y) is traced at film position
    /// [`ImageSettings::film_origin`] + (x, y) (integers added first, so a crop's rays are the
    /// film's bit for bit).
    #[must_use]
    pub fn camera_rays(&self, camera: &glint_scene::Camera) -> glint_scene::camera::CameraRays {
        match self.window {
            None => camera.rays(self.width, self.height),
            Some(w) => camera.rays(w.full_width, w.full_height),
        }
    }

    /// The film pixel of image pixel (0, 0).
    #[inline]
    #[must_use]
    pub fn film_origin(&self) -> (usize, usize) {
        self.window.map_or((0, 0), |w| (w.x0 as usize, w.y0 as usize))
    }

    /// The film-wide index of image pixel (x, y): what every random stream of the pixel is
    /// hashed from.
    #[inline]
    #[must_use]
    pub fn pixel_id(&self, x: usize, y: usize) -> u64 {
        match self.window {
            None => (y * self.width as usize + x) as u64,
            Some(w) => (y as u64 + u64::from(w.y0)) * u64::from(w.full_width) + x as u64 + u64::from(w.x0),
        }
    }

    /// A `width × height` image, seed 0, work stealing.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        Self { width, height, seed: 0, schedule: Schedule::WorkStealing, window: None }
    }

    /// # Errors
    /// [`RenderError::InvalidSetting`] when the size is outside the limits.
    pub fn validate(&self) -> Result<(), RenderError> {
        if !image_size_ok(self.width, self.height) {
            return Err(RenderError::InvalidSetting(format!(
                "image size {}x{} (each side must be 1..={MAX_IMAGE_SIDE}, at most 2^27 pixels in all)",
                self.width, self.height
            )));
        }
        if let Some(w) = self.window
            && (!image_size_ok(w.full_width, w.full_height)
                || u64::from(w.x0) + u64::from(self.width) > u64::from(w.full_width)
                || u64::from(w.y0) + u64::from(self.height) > u64::from(w.full_height))
        {
            return Err(RenderError::InvalidSetting(format!(
                "crop window {}x{} at ({}, {}) is not inside the {}x{} film",
                self.width, self.height, w.x0, w.y0, w.full_width, w.full_height
            )));
        }
        Ok(())
    }

    pub(crate) fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

/// How the Whitted integrator traces (the same picture either way, to well below one 8-bit
/// step; BENCHMARKS.md §3 compares their speed).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum WhittedKernel {
    /// Eight rays at a time in structure of arrays: tiles of ray streams, compacted per depth,
    /// shaded across lanes, AVX2 where the machine has it.
    #[default]
    Batched,
    /// The same batched code, compiled for the x86-64 baseline only (SSE2).
    BatchedBaseline,
    /// One ray at a time (the oracle).
    Scalar,
}

/// The Whitted integrator's settings (DESIGN.md §1).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WhittedSettings {
    /// N for N×N stratified supersampling; 1 = a single ray through each pixel centre.
    pub samples_per_side: u32,
    /// The deepest reflection/refraction chain.
    pub max_depth: u32,
    /// A branch whose accumulated weight falls below this is not traced.
    pub min_contribution: f32,
    pub kernel: WhittedKernel,
}

impl Default for WhittedSettings {
    fn default() -> Self {
        Self::from_defaults(&RenderDefaults::default())
    }
}

impl WhittedSettings {
    /// The settings a scene file gives (its `[image]` samples and `[render]` section).
    #[must_use]
    pub fn from_defaults(d: &RenderDefaults) -> Self {
        Self {
            samples_per_side: d.samples_per_side,
            max_depth: d.max_depth,
            min_contribution: d.min_contribution,
            kernel: WhittedKernel::default(),
        }
    }

    /// # Errors
    /// [`RenderError::InvalidSetting`] naming the value out of its range.
    pub fn validate(&self) -> Result<(), RenderError> {
        limits::check("samples per side", self.samples_per_side, &limits::SAMPLES_PER_SIDE)
            .and_then(|()| limits::check("max depth", self.max_depth, &limits::MAX_DEPTH))
            .map_err(RenderError::InvalidSetting)?;
        if !(self.min_contribution.is_finite() && self.min_contribution >= 0.0) {
            return Err(RenderError::InvalidSetting("min contribution must be a finite number >= 0".into()));
        }
        Ok(())
    }
}
