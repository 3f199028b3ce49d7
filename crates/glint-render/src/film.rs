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

/// The beauty of one pixel, in every mode: the box-filtered average of its samples' colour and
/// its coverage (the fraction of samples that hit a surface, written as alpha). 16 bytes: a
/// Whitted frame written to PNG streams nothing else ([`SurfacePixel`] is a plane of its own).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FilmPixel {
    pub colour: Rgb,
    pub coverage: f32,
}

/// The first-hit AOVs of one pixel ([`Film::surface`]): normal and albedo averaged over the
/// samples that hit a surface, depth too (linear eye-space distance along the view axis, +inf
/// where no sample hit). 28 bytes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePixel {
    pub normal: Vec3,
    pub albedo: Rgb,
    pub depth: f32,
}

impl Default for SurfacePixel {
    fn default() -> Self {
        Self { normal: Vec3::ZERO, albedo: Rgb::ZERO, depth: f32::INFINITY }
    }
}

/// A pixel's beauty and first-hit AOVs in one record: what a Whitted sample leaves
/// ([`crate::whitted::Samples::One`]) and a Whitted chunk file holds (44 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelRecord {
    pub colour: Rgb,
    pub normal: Vec3,
    pub albedo: Rgb,
    pub depth: f32,
    pub coverage: f32,
}

impl Default for PixelRecord {
    fn default() -> Self {
        Self::join(FilmPixel::default(), SurfacePixel::default())
    }
}

impl PixelRecord {
    #[inline]
    #[must_use]
    pub fn join(beauty: FilmPixel, surface: SurfacePixel) -> Self {
        let FilmPixel { colour, coverage } = beauty;
        let SurfacePixel { normal, albedo, depth } = surface;
        Self { colour, normal, albedo, depth, coverage }
    }

    #[inline]
    #[must_use]
    pub fn beauty(&self) -> FilmPixel {
        FilmPixel { colour: self.colour, coverage: self.coverage }
    }

    #[inline]
    #[must_use]
    pub fn surface(&self) -> SurfacePixel {
        SurfacePixel { normal: self.normal, albedo: self.albedo, depth: self.depth }
    }
}

/// Rows of a film to be written (a band's): the beauty, and the first-hit AOVs when the film
/// holds them (else `surface` is empty and [`FilmRows::set`] writes the beauty alone).
pub struct FilmRows<'a> {
    pub pixels: &'a mut [FilmPixel],
    pub surface: &'a mut [SurfacePixel],
}

impl FilmRows<'_> {
    /// Pixels in these rows.
    #[inline]
    #[must_use]
    pub fn len(&self) -> usize {
        self.pixels.len()
    }

    #[inline]
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.pixels.is_empty()
    }

    /// Write pixel `i`'s record: its beauty, and its AOVs when the film holds them.
    #[inline]
    pub fn set(&mut self, i: usize, record: PixelRecord) {
        self.pixels[i] = record.beauty();
        if let Some(s) = self.surface.get_mut(i) {
            *s = record.surface();
        }
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
type SurfaceChannelReader = Reader<SurfacePixel>;
type PathChannelReader = Reader<PathAovs>;

/// A frame's picture as planes of per-pixel records, each written only when a frame needs it:
/// the beauty always ([`FilmPixel`], 16 bytes a pixel), the first-hit AOVs when the film holds
/// them ([`SurfacePixel`], 28), the path mode's own AOVs in path frames ([`PathAovs`], 40).
/// A band of rows is a contiguous slice of each plane a thread can own.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<FilmPixel>,
    /// The first-hit AOVs, one per pixel when the film holds them ([`Film::has_surface`]),
    /// else empty: a film made by [`Film::beauty_only`] (a Whitted frame written to PNG) neither
    /// writes nor first-touches them. The path and points modes always write them.
    pub surface: Vec<SurfacePixel>,
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

    /// A `width × height` film with the first-hit AOVs, checked against the memory budget and
    /// allocated fallibly.
    ///
    /// # Errors
    /// [`MemoryError`] naming the film's size when the budget or the allocator refuses it.
    pub fn try_new(width: u32, height: u32) -> Result<Self, MemoryError> {
        Self::with_planes(width, height, true)
    }

    /// A `width × height` film of the beauty alone (no first-hit AOVs): 16 bytes a pixel
    /// instead of 44, for output that shows only the picture (PNG).
    ///
    /// # Errors
    /// As [`Film::try_new`].
    pub fn beauty_only(width: u32, height: u32) -> Result<Self, MemoryError> {
        Self::with_planes(width, height, false)
    }

    fn with_planes(width: u32, height: u32, surface: bool) -> Result<Self, MemoryError> {
        let mut film = Self {
            width,
            height,
            pixels: Vec::new(),
            surface: Vec::new(),
            path: Vec::new(),
            path_aovs: false,
            variance: false,
        };
        let count = film.count();
        let bytes = size_of::<FilmPixel>() + if surface { size_of::<SurfacePixel>() } else { 0 };
        let what = || format!("the film of a {width} x {height} image ({bytes} bytes per pixel)");
        memory::check(what, (count as u64).saturating_mul(bytes as u64))?;
        film.pixels = grown(count, FilmPixel::default(), &what)?;
        if surface {
            film.surface = grown(count, SurfacePixel::default(), &what)?;
        }
        Ok(film)
    }

    fn count(&self) -> usize {
        self.width as usize * self.height as usize
    }

    /// Whether the film holds the first-hit AOVs (normal, albedo, depth); a film of no pixels
    /// counts as holding them (there is nothing to hold).
    #[must_use]
    pub fn has_surface(&self) -> bool {
        self.surface.len() == self.pixels.len()
    }

    /// Make this a `width × height` film for a new frame, with the planes it has now, reusing
    /// its memory when the size is the same: the pixels are left as they are (every mode writes
    /// each one), the path AOVs are off.
    ///
    /// # Errors
    /// As [`Film::try_new`], when the size changes.
    pub fn reset(&mut self, width: u32, height: u32) -> Result<(), MemoryError> {
        let surface = self.has_surface();
        self.reset_with(width, height, surface)
    }

    /// [`Film::reset`], with the first-hit AOVs when `surface` (else without them).
    ///
    /// # Errors
    /// As [`Film::try_new`], when the size or the planes change.
    pub fn reset_with(&mut self, width: u32, height: u32, surface: bool) -> Result<(), MemoryError> {
        if (self.width, self.height) != (width, height) || self.has_surface() != surface {
            // Free the old planes first: both at once could be what does not fit.
            *self = Film::with_planes(0, 0, surface)?;
            *self = Film::with_planes(width, height, surface)?;
        }
        self.path_aovs = false;
        self.variance = false;
        Ok(())
    }

    /// The film's rows to be written, cut into bands of `pixels_per_band` pixels (a whole number
    /// of rows).
    pub fn bands_mut(&mut self, pixels_per_band: usize) -> Vec<FilmRows<'_>> {
        let step = pixels_per_band.max(1);
        let bands = self.pixels.chunks_mut(step);
        if self.surface.is_empty() {
            bands.map(|pixels| FilmRows { pixels, surface: &mut [] }).collect()
        } else {
            bands.zip(self.surface.chunks_mut(step)).map(|(pixels, surface)| FilmRows { pixels, surface }).collect()
        }
    }

    /// All of the film's rows to be written.
    pub fn rows_mut(&mut self) -> FilmRows<'_> {
        FilmRows { pixels: &mut self.pixels, surface: &mut self.surface }
    }

    /// The pixels, their first-hit AOVs (made when the film has none) and their path AOVs, to
    /// be written (the path AOVs marked meaningful): the AOVs are sized to the film on first use
    /// (in the memory budget, grown on every thread), then reused.
    ///
    /// # Errors
    /// [`MemoryError`] when the budget or the allocator refuses them.
    pub fn path_aovs_mut(&mut self) -> Result<(FilmRows<'_>, &mut [PathAovs]), MemoryError> {
        self.surface_mut()?;
        let count = self.pixels.len();
        if self.path.len() != count {
            let (w, h) = (self.width, self.height);
            let what = || format!("the path AOVs of a {w} x {h} image ({} bytes per pixel)", size_of::<PathAovs>());
            self.path = Vec::new();
            self.path = grown(count, PathAovs::default(), &what)?;
        }
        self.path_aovs = true;
        Ok((FilmRows { pixels: &mut self.pixels, surface: &mut self.surface }, &mut self.path))
    }

    /// The first-hit AOVs to be written, made first when the film has none.
    ///
    /// # Errors
    /// [`MemoryError`] when the budget or the allocator refuses them.
    pub fn surface_mut(&mut self) -> Result<FilmRows<'_>, MemoryError> {
        if !self.has_surface() {
            let (w, h) = (self.width, self.height);
            let what = || format!("the AOVs of a {w} x {h} image ({} bytes per pixel)", size_of::<SurfacePixel>());
            self.surface = Vec::new();
            self.surface = grown(self.pixels.len(), SurfacePixel::default(), &what)?;
        }
        Ok(self.rows_mut())
    }

    /// The path AOVs of pixel (x, y) when the film holds them.
    #[must_use]
    pub fn path_pixel(&self, x: u32, y: u32) -> Option<&PathAovs> {
        self.path_aovs.then(|| &self.path[y as usize * self.width as usize + x as usize])
    }

    /// Take `other`'s pixel wherever it saw a surface nearer than this film's (both of one
    /// size, both with first-hit AOVs; depth is eye depth in both): how the points mode lays
    /// traced meshes over clouds.
    pub fn composite_nearer(&mut self, other: &Film) {
        debug_assert_eq!((self.width, self.height), (other.width, other.height));
        debug_assert!(self.has_surface() && other.has_surface());
        let mine = self.pixels.iter_mut().zip(&mut self.surface);
        for ((p, s), (o, t)) in mine.zip(other.pixels.iter().zip(&other.surface)) {
            if o.coverage > 0.0 && t.depth < s.depth {
                (*p, *s) = (*o, *t);
            }
        }
    }

    #[must_use]
    pub fn pixel(&self, x: u32, y: u32) -> &FilmPixel {
        &self.pixels[self.index(x, y)]
    }

    /// Pixel (x, y)'s first-hit AOVs (the defaults, depth +inf, when the film holds none).
    #[must_use]
    pub fn surface_pixel(&self, x: u32, y: u32) -> SurfacePixel {
        self.surface.get(self.index(x, y)).copied().unwrap_or_default()
    }

    fn index(&self, x: u32, y: u32) -> usize {
        y as usize * self.width as usize + x as usize
    }

    /// Pixel `i`'s beauty and first-hit AOVs as one record.
    #[must_use]
    pub fn record(&self, i: usize) -> PixelRecord {
        PixelRecord::join(self.pixels[i], self.surface.get(i).copied().unwrap_or_default())
    }

    /// Every pixel's record, in order (a Whitted chunk's pixels).
    #[must_use]
    pub fn records(&self) -> Vec<PixelRecord> {
        (0..self.pixels.len()).map(|i| self.record(i)).collect()
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

    /// Beauty and every AOV the film holds as named channels (EXR names: pbrt-v4's where it
    /// has them): R G B A, with first-hit AOVs Albedo.R/G/B, Ns.X/Y/Z, Z, and in path mode
    /// Direct.R/G/B, Indirect.R/G/B, SampleCount, and without a filter Variance.R/G/B
    /// (docs/aovs.md).
    #[must_use]
    pub fn aov_image(&self) -> Image {
        let chans: [ChannelReader; 4] =
            [("R", |p| p.colour.x), ("G", |p| p.colour.y), ("B", |p| p.colour.z), ("A", |p| p.coverage)];
        let surface: [SurfaceChannelReader; 7] = [
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
        if self.has_surface() {
            let extra = planes_of(&self.surface, self.width, self.height, &surface);
            img.channels.extend(extra.channels);
        }
        if self.path_aovs {
            let len = if self.variance { 10 } else { 7 };
            let extra = planes_of(&self.path, self.width, self.height, &path[..len]);
            img.channels.extend(extra.channels);
        }
        img
    }
}

/// `count` copies of `value` in a fallibly allocated buffer, written (and so first touched,
/// page by page) on every thread: a single frame's film is 91 MB at 1920 × 1080 with every
/// AOV, whose page faults on one thread cost about as much as the whole Whitted frame.
fn grown<T: Clone + Send + Sync>(count: usize, value: T, what: &impl Fn() -> String) -> Result<Vec<T>, MemoryError> {
    let mut v = memory::try_with_capacity(what, count)?;
    crate::first_touch::resize(&mut v, count, value);
    Ok(v)
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
    use super::{Film, FilmPixel, PixelRecord, SurfacePixel};
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

    #[test]
    fn a_beauty_only_film_holds_and_writes_no_aovs() {
        let record = PixelRecord {
            colour: Rgb::new(1.0, 2.0, 3.0),
            normal: Vec3::Z,
            albedo: Rgb::splat(0.5),
            depth: 4.0,
            coverage: 1.0,
        };
        let mut lean = Film::beauty_only(5, 4).expect("small");
        assert!(!lean.has_surface() && lean.surface.is_empty());
        let mut full = Film::new(5, 4);
        assert!(full.has_surface());
        for film in [&mut lean, &mut full] {
            let mut bands = film.bands_mut(10);
            assert_eq!(bands.iter().map(super::FilmRows::len).collect::<Vec<_>>(), [10, 10]);
            bands[1].set(3, record);
        }
        assert_eq!(lean.pixels[13], record.beauty());
        assert_eq!(full.record(13), record);
        assert_eq!(lean.record(13), PixelRecord { ..PixelRecord::join(record.beauty(), SurfacePixel::default()) });
        assert_eq!(lean.surface_pixel(3, 2), SurfacePixel::default());
        // EXR channels: the beauty alone, or with the AOVs.
        let names = |f: &Film| f.aov_image().channels.iter().map(|c| c.name.clone()).collect::<Vec<_>>();
        assert_eq!(names(&lean), ["R", "G", "B", "A"]);
        assert_eq!(names(&full).len(), 11);
        // A reset keeps the planes; asking for AOVs makes them.
        lean.reset(6, 4).expect("small");
        assert!(!lean.has_surface() && lean.pixels.len() == 24);
        lean.surface_mut().expect("small");
        assert!(lean.has_surface() && lean.surface.len() == 24);
        full.reset_with(5, 4, false).expect("small");
        assert!(!full.has_surface());
    }
}
