//! The film: linear HDR beauty plus AOVs (normal, depth, albedo, coverage), one record per pixel
//! so that a band of rows is one contiguous slice a thread can own.

use glint_core::memory::{self, MemoryError};
use glint_core::{Rgb, Vec3};
use glint_image::Image;
use rayon::prelude::*;

/// The largest radiance one camera sample of any mode may carry, per channel (docs/limits.md). Brighter
/// samples are clamped to it and counted: the filters square and sum radiance over windows
/// of up to 2049² pixels, which stays finite in f32 below 1e15² · 4.2e6 ≈ 4e36 < 3.4e38, and a
/// pixel's sum of 65 536 samples stays far below f32's range. No physical scene comes near it
/// (the sun's radiance is about 1.6e9 W sr⁻¹ m⁻²).
pub const MAX_SAMPLE_RADIANCE: f32 = 1e15;

/// What one pixel accumulated, in every mode. Colour is the box-filtered average of its
/// samples; normal and albedo average over the samples that hit a surface, depth too (linear
/// eye-space distance along the view axis, +inf where no sample hit); coverage is the fraction
/// of samples that hit. 44 bytes: the path mode's own AOVs live beside it in [`PathAovs`], so
/// a Whitted or points frame neither writes nor first-touches them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilmPixel {
    pub colour: Rgb,
    pub normal: Vec3,
    pub albedo: Rgb,
    pub depth: f32,
    pub coverage: f32,
}

impl Default for FilmPixel {
    fn default() -> Self {
        Self { colour: Rgb::ZERO, normal: Vec3::ZERO, albedo: Rgb::ZERO, depth: f32::INFINITY, coverage: 0.0 }
    }
}

/// The path mode's AOVs of one pixel ([`Film::path`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PathAovs {
    /// Direct light (next-event estimation at the first non-delta vertex).
    pub direct: Rgb,
    /// Diffuse indirect light, incident and demodulated (the beauty's diffuse indirect part is
    /// `albedo × indirect`), as it went into the beauty (filtered or not).
    pub indirect: Rgb,
    /// Samples that went into the pixel.
    pub samples: f32,
    /// Without a filter: the variance of one sample's radiance at this pixel (the sample
    /// variance of its samples, as Mitsuba's `moment` integrator gives it), so that
    /// `variance / samples` is the variance of `colour`. Zero elsewhere.
    pub variance: Rgb,
}

/// A named channel and how to read it from a per-pixel record.
type Reader<T> = (&'static str, fn(&T) -> f32);
type ChannelReader = Reader<FilmPixel>;
type PathChannelReader = Reader<PathAovs>;

#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<FilmPixel>,
    /// The path mode's AOVs, one per pixel when `path_aovs` (else stale or empty): written
    /// through [`Film::path_aovs_mut`].
    pub path: Vec<PathAovs>,
    /// The path mode's AOVs (Direct, Indirect, SampleCount) are meaningful and written.
    pub path_aovs: bool,
    /// The per-pixel sample variance is meaningful (path mode without a filter) and written
    /// (`Variance.R/G/B`).
    pub variance: bool,
}

impl Film {
    /// A small film (tests, placeholders). Sizes that come from a user go through
    /// [`Film::try_new`].
    ///
    /// # Panics
    /// When the allocation fails.
    #[must_use]
    pub fn new(width: u32, height: u32) -> Self {
        Self::try_new(width, height).expect("a film small enough to allocate")
    }

    /// A `width × height` film, checked against the memory budget and allocated fallibly.
    ///
    /// # Errors
    /// [`MemoryError`] naming the film's size when the budget or the allocator refuses it.
    pub fn try_new(width: u32, height: u32) -> Result<Self, MemoryError> {
        let what = || format!("the film of a {width} x {height} image ({} bytes per pixel)", size_of::<FilmPixel>());
        let count = width as usize * height as usize;
        let mut pixels = memory::try_with_capacity(what, count)?;
        // Filled (and so first touched, page by page) on every thread: a single frame's film
        // is 91 MB at 1920 × 1080, whose page faults on one thread cost about as much as the
        // whole Whitted frame.
        crate::first_touch::resize(&mut pixels, count, FilmPixel::default());
        Ok(Self { width, height, pixels, path: Vec::new(), path_aovs: false, variance: false })
    }

    /// Make this a `width × height` film for a new frame, reusing its memory when the size is
    /// the same: the pixels are left as they are (every mode writes each one), the path AOVs
    /// are off.
    ///
    /// # Errors
    /// As [`Film::try_new`], when the size changes.
    pub fn reset(&mut self, width: u32, height: u32) -> Result<(), MemoryError> {
        if (self.width, self.height) != (width, height) {
            // Free the old pixels first: both at once could be what does not fit.
            *self = Film::try_new(0, 0)?;
            *self = Film::try_new(width, height)?;
        }
        self.path_aovs = false;
        self.variance = false;
        Ok(())
    }

    /// The pixels and their path AOVs, to be written (the AOVs marked meaningful): the AOVs are
    /// sized to the film on first use (in the memory budget, grown on every thread), then
    /// reused.
    ///
    /// # Errors
    /// [`MemoryError`] when the budget or the allocator refuses them.
    pub fn path_aovs_mut(&mut self) -> Result<(&mut [FilmPixel], &mut [PathAovs]), MemoryError> {
        let count = self.pixels.len();
        if self.path.len() != count {
            let (w, h) = (self.width, self.height);
            let what = || format!("the path AOVs of a {w} x {h} image ({} bytes per pixel)", size_of::<PathAovs>());
            self.path = Vec::new();
            self.path = memory::try_with_capacity(what, count)?;
            crate::first_touch::resize(&mut self.path, count, PathAovs::default());
        }
        self.path_aovs = true;
        Ok((&mut self.pixels, &mut self.path))
    }

    /// The path AOVs of pixel (x, y) when the film holds them.
    #[must_use]
    pub fn path_pixel(&self, x: u32, y: u32) -> Option<&PathAovs> {
        self.path_aovs.then(|| &self.path[y as usize * self.width as usize + x as usize])
    }

    /// Take `other`'s pixel wherever it saw a surface nearer than this film's (both of one
    /// size; depth is eye depth in both): how the points mode lays traced meshes over clouds.
    pub fn composite_nearer(&mut self, other: &Film) {
        debug_assert_eq!((self.width, self.height), (other.width, other.height));
        for (p, o) in self.pixels.iter_mut().zip(&other.pixels) {
            if o.coverage > 0.0 && o.depth < p.depth {
                *p = *o;
            }
        }
    }

    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> &FilmPixel {
        &self.pixels[y as usize * self.width as usize + x as usize]
    }

    /// Beauty only, as channels R, G, B (and A = coverage when `alpha`).
    #[must_use]
    pub fn beauty_image(&self, alpha: bool) -> Image {
        let chans: [ChannelReader; 4] =
            [("R", |p| p.colour.x), ("G", |p| p.colour.y), ("B", |p| p.colour.z), ("A", |p| p.coverage)];
        planes_of(&self.pixels, self.width, self.height, &chans[..if alpha { 4 } else { 3 }])
    }

    /// The beauty as interleaved 8-bit sRGB (`RGB`, or `RGBA` with `options.alpha`, alpha =
    /// coverage), the bytes [`glint_image::encode_srgb8`] gives for
    /// [`beauty_image`](Self::beauty_image), encoded straight from the film's pixels without
    /// the planar float image in between (a 1080p PNG: 25 MB fewer bytes written and faulted in).
    #[must_use]
    pub fn encode_srgb8(&self, options: &glint_image::PngOptions) -> Vec<u8> {
        glint_image::encode_srgb8_blocks(self.pixels.len(), options, |start, block| {
            let len = block.len();
            let Some(pixels) = self.pixels.get(start..start + len) else { return };
            let [r, g, b, a] = &mut block.planes;
            for (i, p) in pixels.iter().enumerate() {
                r[i] = p.colour.x;
                g[i] = p.colour.y;
                b[i] = p.colour.z;
                a[i] = p.coverage;
            }
        })
    }

    /// Beauty and every AOV as named channels (EXR names: pbrt-v4's where it has them):
    /// R G B A, Albedo.R/G/B, Ns.X/Y/Z, Z, and in path mode Direct.R/G/B, Indirect.R/G/B,
    /// SampleCount, and without a filter Variance.R/G/B (docs/aovs.md).
    #[must_use]
    pub fn aov_image(&self) -> Image {
        let chans: [ChannelReader; 11] = [
            ("R", |p| p.colour.x),
            ("G", |p| p.colour.y),
            ("B", |p| p.colour.z),
            ("A", |p| p.coverage),
            ("Albedo.R", |p| p.albedo.x),
            ("Albedo.G", |p| p.albedo.y),
            ("Albedo.B", |p| p.albedo.z),
            ("Ns.X", |p| p.normal.x),
            ("Ns.Y", |p| p.normal.y),
            ("Ns.Z", |p| p.normal.z),
            ("Z", |p| p.depth),
        ];
        let path: [PathChannelReader; 10] = [
            ("Direct.R", |p| p.direct.x),
            ("Direct.G", |p| p.direct.y),
            ("Direct.B", |p| p.direct.z),
            ("Indirect.R", |p| p.indirect.x),
            ("Indirect.G", |p| p.indirect.y),
            ("Indirect.B", |p| p.indirect.z),
            ("SampleCount", |p| p.samples),
            ("Variance.R", |p| p.variance.x),
            ("Variance.G", |p| p.variance.y),
            ("Variance.B", |p| p.variance.z),
        ];
        let mut img = planes_of(&self.pixels, self.width, self.height, &chans);
        if self.path_aovs {
            let len = if self.variance { 10 } else { 7 };
            let extra = planes_of(&self.path, self.width, self.height, &path[..len]);
            img.channels.extend(extra.channels);
        }
        img
    }
}

/// The named planes of `records` (one per pixel), filled in parallel (one pass over the records
/// per band of rows).
fn planes_of<T: Sync>(records: &[T], width: u32, height: u32, chans: &[Reader<T>]) -> Image {
    let n = records.len();
    let mut planes: Vec<Vec<f32>> = chans.iter().map(|_| vec![0.0; n]).collect();
    let rows = (width as usize).max(1) * 16;
    let mut bands: Vec<Vec<&mut [f32]>> = (0..n.div_ceil(rows)).map(|_| Vec::new()).collect();
    for plane in &mut planes {
        for (band, chunk) in bands.iter_mut().zip(plane.chunks_mut(rows)) {
            band.push(chunk);
        }
    }
    bands.into_par_iter().enumerate().for_each(|(b, mut outs)| {
        let records = &records[b * rows..(b * rows + rows).min(n)];
        for ((_, read), out) in chans.iter().zip(outs.iter_mut()) {
            for (o, p) in out.iter_mut().zip(records) {
                *o = read(p);
            }
        }
    });
    let mut img = Image::new(width, height);
    for ((name, _), data) in chans.iter().zip(planes) {
        img.channels.push(glint_image::Channel { name: (*name).into(), data });
    }
    img
}

#[cfg(test)]
mod tests {
    use super::{Film, FilmPixel};
    use glint_core::{Rgb, Vec3};
    use glint_image::{PngOptions, ToneMap, encode_srgb8};

    /// A film whose pixels run through dark, bright, negative, NaN and infinite values, with
    /// partial coverage.
    fn film(width: u32, height: u32) -> Film {
        let mut film = Film::new(width, height);
        for (i, p) in film.pixels.iter_mut().enumerate() {
            let t = i as f32 * 0.37;
            let odd = match i % 97 {
                0 => f32::NAN,
                1 => f32::INFINITY,
                2 => -1.0,
                _ => 0.0,
            };
            *p = FilmPixel {
                colour: Rgb::new(t.sin().abs() * 3.0 + odd, (t * 0.1).fract(), 1e-5 * i as f32),
                coverage: (i % 5) as f32 / 4.0,
                normal: Vec3::Z,
                ..FilmPixel::default()
            };
        }
        film
    }

    #[test]
    fn the_film_encodes_to_the_bytes_of_its_beauty_image() {
        // 300 × 7 pixels: several encode blocks and a short last one.
        for (w, h) in [(300, 7), (1, 1), (16, 16)] {
            let film = film(w, h);
            for tone_map in [ToneMap::Clamp, ToneMap::Reinhard, ToneMap::Aces] {
                for alpha in [false, true] {
                    for exposure in [0.0, 1.5, -2.0] {
                        let options = PngOptions { exposure, tone_map, alpha };
                        let want = encode_srgb8(&film.beauty_image(alpha), &options).expect("encode");
                        assert_eq!(film.encode_srgb8(&options), want, "{w}x{h} {options:?}");
                    }
                }
            }
        }
    }
}
