//! Linear image → 8-bit sRGB (exposure, tone map, OETF, rounding) and PNG / JPEG writing.
//!
//! The per-value chain is documented in the crate docs. Encoding is the one hot path here
//! (the viewer and the CLI encode every frame), so the OETF and rounding go through a table
//! that reproduces exact round-to-nearest of `255 · oetf(x)` without a `powf` per value.

use std::path::Path;
use std::sync::OnceLock;

use glint_core::colour::srgb_to_linear;
use image::ImageEncoder;
use image::codecs::jpeg::JpegEncoder;
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use rayon::prelude::*;

use crate::atomic::atomic_write;
use crate::error::ImageError;
use crate::planar::Image;
use crate::tonemap::{self, ToneMap};

/// How [`encode_srgb8`] / [`crate::write_png`] turn linear values into display pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PngOptions {
    /// Stops: colour values are scaled by `2^exposure` before tone mapping.
    pub exposure: f32,
    /// Applied per channel after exposure, before the sRGB OETF.
    pub tone_map: ToneMap,
    /// Write RGBA with the image's `A` channel (coverage) as alpha, linear and not tone mapped.
    /// The colour channels are written as they are (see the crate docs on premultiplication).
    pub alpha: bool,
}

impl Default for PngOptions {
    fn default() -> Self {
        PngOptions { exposure: 0.0, tone_map: ToneMap::Clamp, alpha: false }
    }
}

/// Encodes `image` as interleaved 8-bit sRGB: `RGB` per pixel, or `RGBA` with
/// `options.alpha`. Per colour value: exposure → tone map → sRGB OETF → round to nearest;
/// NaN → 0. Needs channels `R`, `G`, `B` (and `A` with `options.alpha`), else
/// [`ImageError::Mismatch`].
pub fn encode_srgb8(image: &Image, options: &PngOptions) -> Result<Vec<u8>, ImageError> {
    image.validate()?;
    let (r, g, b) = image.rgb_planes().ok_or_else(|| {
        ImageError::mismatch(format!("cannot encode as sRGB: the image has no R, G, B channels ({})", names(image)))
    })?;
    let alpha = if options.alpha {
        Some(image.channel("A").ok_or_else(|| {
            ImageError::mismatch(format!("alpha requested, but the image has no A channel ({})", names(image)))
        })?)
    } else {
        None
    };
    let planes = [r, g, b, alpha.unwrap_or(&[])];
    Ok(encode_srgb8_blocks(image.pixel_count(), options, |start, block| {
        let len = block.len();
        for (dst, src) in block.planes.iter_mut().zip(planes) {
            if let Some(src) = src.get(start..start + len) {
                dst[..len].copy_from_slice(src);
            }
        }
    }))
}

/// Pixels per block of the 8-bit encoders ([`encode_srgb8_blocks`]).
pub const ENCODE_BLOCK: usize = 256;

/// One block of linear pixels for [`encode_srgb8_blocks`]: R, G, B and coverage (A) planes,
/// the first [`LinearBlock::len`] values of each in use.
pub struct LinearBlock {
    pub planes: [[f32; ENCODE_BLOCK]; 4],
    len: usize,
}

impl LinearBlock {
    /// Pixels in this block (the last block of an image may be short).
    #[must_use]
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the block holds no pixel (never, for a block handed to a `fill`).
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// Encodes `count` pixels as interleaved 8-bit sRGB (`RGB`, or `RGBA` with `options.alpha`),
/// exactly as [`encode_srgb8`] does, reading them from `fill`: `fill(start, block)` writes the
/// linear R, G, B (and, with alpha, the coverage) of pixels `start..start + block.len()` into
/// the block's planes. Blocks are filled and encoded in parallel, each output byte from its
/// own pixel only, so the result does not depend on threading. This lets a renderer encode
/// its film where it lies, without a planar float copy of the image in between.
pub fn encode_srgb8_blocks(
    count: usize,
    options: &PngOptions,
    fill: impl Fn(usize, &mut LinearBlock) + Sync,
) -> Vec<u8> {
    let scale = options.exposure.exp2();
    let channels = if options.alpha { 4 } else { 3 };
    let mut out = vec![0u8; count * channels];
    match options.tone_map {
        ToneMap::Clamp => encode_blocks(tonemap::clamp, scale, options.alpha, &fill, &mut out),
        ToneMap::Reinhard => encode_blocks(tonemap::reinhard, scale, options.alpha, &fill, &mut out),
        ToneMap::Aces => encode_blocks(tonemap::aces, scale, options.alpha, &fill, &mut out),
    }
    out
}

/// Encodes pixels `first..` (as many as `out` holds: `out.len()` over 3, or 4 with
/// `options.alpha`) into `out` on the calling thread, exactly as [`encode_srgb8_blocks`]
/// encodes them (each output byte from its own pixel only), reading them from `fill` as it
/// does. This lets a renderer encode each band of rows where it made it, while the band is in
/// its cache, with no whole-image float film at all.
pub fn encode_srgb8_into(options: &PngOptions, first: usize, fill: impl Fn(usize, &mut LinearBlock), out: &mut [u8]) {
    let scale = options.exposure.exp2();
    let channels = if options.alpha { 4 } else { 3 };
    let lut = SrgbLut::get();
    let blocks = out.chunks_mut(ENCODE_BLOCK * channels);
    for (block, pixels) in blocks.enumerate() {
        let start = first + block * ENCODE_BLOCK;
        match options.tone_map {
            ToneMap::Clamp => encode_block(tonemap::clamp, scale, options.alpha, lut, start, &fill, pixels),
            ToneMap::Reinhard => encode_block(tonemap::reinhard, scale, options.alpha, lut, start, &fill, pixels),
            ToneMap::Aces => encode_block(tonemap::aces, scale, options.alpha, lut, start, &fill, pixels),
        }
    }
}

/// The encode loop, monomorphised per tone map. Works in blocks of [`ENCODE_BLOCK`] pixels, in
/// parallel ([`encode_block`] each).
fn encode_blocks(
    tone_map: impl Fn(f32) -> f32 + Sync,
    scale: f32,
    alpha: bool,
    fill: &(impl Fn(usize, &mut LinearBlock) + Sync),
    out: &mut [u8],
) {
    let lut = SrgbLut::get();
    let channels = if alpha { 4 } else { 3 };
    out.par_chunks_mut(ENCODE_BLOCK * channels).with_min_len(16).enumerate().for_each(|(block, pixels)| {
        encode_block(&tone_map, scale, alpha, lut, block * ENCODE_BLOCK, fill, pixels);
    });
}

/// One block (at most [`ENCODE_BLOCK`] pixels from pixel `start`, as many as `pixels` holds):
/// its planes are filled, exposure + tone map run over each colour plane (contiguous,
/// branch-free, so it vectorises), then table lookups and interleaving.
#[inline]
fn encode_block(
    tone_map: impl Fn(f32) -> f32,
    scale: f32,
    alpha: bool,
    lut: &SrgbLut,
    start: usize,
    fill: &impl Fn(usize, &mut LinearBlock),
    pixels: &mut [u8],
) {
    let channels = if alpha { 4 } else { 3 };
    let len = pixels.len() / channels;
    let mut buf = LinearBlock { planes: [[0.0; ENCODE_BLOCK]; 4], len };
    fill(start, &mut buf);
    let [mut tr, mut tg, mut tb, a] = buf.planes;
    for plane in [&mut tr, &mut tg, &mut tb] {
        for t in &mut plane[..len] {
            *t = tone_map(*t * scale);
        }
    }
    let toned = tr[..len].iter().zip(&tg[..len]).zip(&tb[..len]);
    if alpha {
        let (pixels, _) = pixels.as_chunks_mut::<4>();
        for ((px, ((&r, &g), &b)), &a) in pixels.iter_mut().zip(toned).zip(&a[..len]) {
            *px = [lut.encode(r), lut.encode(g), lut.encode(b), alpha_u8(a)];
        }
    } else {
        let (pixels, _) = pixels.as_chunks_mut::<3>();
        for (px, ((&r, &g), &b)) in pixels.iter_mut().zip(toned) {
            *px = [lut.encode(r), lut.encode(g), lut.encode(b)];
        }
    }
}

/// Writes `image` as an 8-bit sRGB PNG (RGB, or RGBA with `options.alpha`), atomically.
/// Compression is the fast deflate setting with the Paeth filter on every row: on renders it
/// gives the adaptive filter's size in about half the time (1080p: ≈ 20 ms, measured).
pub fn write_png(path: &Path, image: &Image, options: &PngOptions) -> Result<(), ImageError> {
    let pixels = encode_srgb8(image, options)?;
    write_png_srgb8(path, image.width, image.height, options.alpha, &pixels)
}

/// Writes pixels encoded by [`encode_srgb8`] or [`encode_srgb8_blocks`] (`RGBA` when `alpha`,
/// else `RGB`; `width × height` of them) as a PNG, atomically, compressed as [`write_png`]
/// does. A buffer of the wrong length is an encode error naming `path`.
pub fn write_png_srgb8(path: &Path, width: u32, height: u32, alpha: bool, pixels: &[u8]) -> Result<(), ImageError> {
    let channels: u64 = if alpha { 4 } else { 3 };
    let expected = u64::from(width) * u64::from(height) * channels;
    if pixels.len() as u64 != expected {
        return Err(ImageError::encode(
            path,
            format!(
                "{} bytes of pixels for a {width} x {height} image of {channels} channels ({expected} expected)",
                pixels.len()
            ),
        ));
    }
    let colour = if alpha { image::ExtendedColorType::Rgba8 } else { image::ExtendedColorType::Rgb8 };
    let mut bytes = Vec::with_capacity(pixels.len() / 2 + 1024);
    PngEncoder::new_with_quality(&mut bytes, CompressionType::Fast, FilterType::Paeth)
        .write_image(pixels, width, height, colour)
        .map_err(|e| ImageError::encode(path, e.to_string()))?;
    atomic_write(path, &bytes)
}

/// JPEG quality of [`write_jpeg`]: high enough that sky faces and crosses show no blocking.
pub const JPEG_QUALITY: u8 = 95;

/// Writes `image` as an 8-bit sRGB baseline JPEG (quality [`JPEG_QUALITY`]), atomically, with
/// the same exposure and tone map as [`write_png`]. JPEG has no alpha: `options.alpha` is
/// ignored and only `R`, `G`, `B` are written.
pub fn write_jpeg(path: &Path, image: &Image, options: &PngOptions) -> Result<(), ImageError> {
    let options = PngOptions { alpha: false, ..*options };
    let pixels = encode_srgb8(image, &options)?;
    let mut bytes = Vec::with_capacity(pixels.len() / 4 + 1024);
    JpegEncoder::new_with_quality(&mut bytes, JPEG_QUALITY)
        .write_image(&pixels, image.width, image.height, image::ExtendedColorType::Rgb8)
        .map_err(|e| ImageError::encode(path, e.to_string()))?;
    atomic_write(path, &bytes)
}

/// Linear coverage in `[0, 1]` → byte; NaN → 0.
#[inline]
fn alpha_u8(a: f32) -> u8 {
    if a.is_nan() { 0 } else { (a.clamp(0.0, 1.0) * 255.0).round() as u8 }
}

fn names(image: &Image) -> String {
    if image.channels.is_empty() {
        return "it has no channels".to_string();
    }
    let list: Vec<&str> = image.channels.iter().map(|c| c.name.as_str()).collect();
    format!("it has {}", list.join(", "))
}

/// Exact linear → sRGB byte quantisation without `powf`.
///
/// `code(x)` = the number of thresholds `t_k = oetf⁻¹((k − ½)/255)`, k = 1..=255, that `x`
/// reaches — round-to-nearest of `255 · oetf(x)`. The table splits [2⁻¹⁴, 1] into buckets by
/// the float's exponent and top 8 mantissa bits (relative width 1/256). Successive thresholds
/// are at least ≈ 0.9 % apart relatively (the OETF's power segment at 1; more below), so a
/// bucket holds at most one: `code = base[bucket] + (x ≥ threshold[bucket])`, no branch, no
/// search. Everything below 2⁻¹⁴ is below `t_1 ≈ 1.5·10⁻⁴`, hence code 0.
struct SrgbLut {
    base: [u8; BUCKETS],
    threshold: [f32; BUCKETS],
}

/// Mantissa bits kept in the bucket index.
const SHIFT: u32 = 23 - 8;
/// Bucket index of 2⁻¹⁴ (biased exponent 113, zero mantissa).
const FIRST: u32 = (127 - 14) << 8;
/// Buckets from 2⁻¹⁴ up to and including 1.0 (whose index is 14 · 256).
const BUCKETS: usize = 14 * 256 + 1;

impl SrgbLut {
    fn get() -> &'static SrgbLut {
        static LUT: OnceLock<SrgbLut> = OnceLock::new();
        LUT.get_or_init(SrgbLut::build)
    }

    fn thresholds() -> Vec<f32> {
        (1..=255).map(|k| srgb_to_linear((k as f32 - 0.5) / 255.0)).collect()
    }

    fn build() -> SrgbLut {
        let thresholds = Self::thresholds();
        let mut base = [0u8; BUCKETS];
        let mut threshold = [f32::INFINITY; BUCKETS];
        for b in 0..BUCKETS as u32 {
            let lo = f32::from_bits((FIRST + b) << SHIFT);
            let hi = f32::from_bits((FIRST + b + 1) << SHIFT);
            base[b as usize] = thresholds.iter().filter(|&&t| t <= lo).count() as u8;
            let inside: Vec<f32> = thresholds.iter().copied().filter(|&t| lo < t && t < hi).collect();
            debug_assert!(inside.len() <= 1, "bucket {b} holds {} thresholds", inside.len());
            if let Some(&t) = inside.first() {
                threshold[b as usize] = t;
            }
        }
        SrgbLut { base, threshold }
    }

    /// `x` in `[0, 1]` (as produced by a tone map, never −0 or NaN) → nearest sRGB byte.
    #[inline(always)]
    fn encode(&self, x: f32) -> u8 {
        let i = ((x.to_bits() >> SHIFT).saturating_sub(FIRST) as usize).min(BUCKETS - 1);
        self.base[i] + u8::from(x >= self.threshold[i])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::colour::linear_to_srgb;

    /// The reference the table must agree with.
    fn encode_reference(x: f32) -> u8 {
        (linear_to_srgb(x) * 255.0).round() as u8
    }
    use crate::read::read_image;
    use crate::test_dir::TestDir;

    fn grey(values: &[f32]) -> Image {
        let pixels: Vec<[f32; 3]> = values.iter().map(|&v| [v; 3]).collect();
        Image::from_rgb(values.len() as u32, 1, &pixels)
    }

    fn encode_one(v: f32, options: &PngOptions) -> u8 {
        encode_srgb8(&grey(&[v]), options).expect("encode")[0]
    }

    #[test]
    fn known_values() {
        let o = PngOptions::default();
        assert_eq!(encode_one(0.0, &o), 0);
        assert_eq!(encode_one(1.0, &o), 255);
        assert_eq!(encode_one(0.5, &o), 188);
        assert_eq!(encode_one(f32::NAN, &o), 0);
        assert_eq!(encode_one(-1.0, &o), 0);
        assert_eq!(encode_one(5.0, &o), 255);
        assert_eq!(encode_one(f32::INFINITY, &o), 255);
        assert_eq!(encode_one(0.2, &o), 124); // oetf(0.2) · 255 = 123.55
    }

    #[test]
    fn exposure_plus_one_doubles() {
        let plus_one = PngOptions { exposure: 1.0, ..PngOptions::default() };
        for v in [0.01, 0.1, 0.25, 0.4] {
            assert_eq!(encode_one(v, &plus_one), encode_one(2.0 * v, &PngOptions::default()), "{v}");
        }
        let minus_two = PngOptions { exposure: -2.0, ..PngOptions::default() };
        assert_eq!(encode_one(2.0, &minus_two), encode_one(0.5, &PngOptions::default()));
    }

    #[test]
    fn tone_maps_apply_before_the_oetf() {
        for tone_map in ToneMap::ALL {
            let o = PngOptions { tone_map, ..PngOptions::default() };
            for v in [0.05, 0.3, 1.0, 3.0, 20.0] {
                assert_eq!(encode_one(v, &o), encode_reference(tone_map.apply(v)), "{tone_map} {v}");
            }
        }
        let reinhard = PngOptions { tone_map: ToneMap::Reinhard, ..PngOptions::default() };
        assert_eq!(encode_one(1.0, &reinhard), 188); // 1/(1+1) = 0.5 → 188
    }

    #[test]
    fn table_matches_direct_oetf_everywhere() {
        let lut = SrgbLut::get();
        let oetf64 = |x: f64| if x <= 0.003_130_8 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 };
        let n = 1 << 22;
        for i in 0..=n {
            let x = i as f32 / n as f32;
            let (fast, slow) = (lut.encode(x), encode_reference(x));
            if fast != slow {
                // Table and f32 formula may disagree only where the exact value is within f32
                // rounding of a tie (k + ½), and then by one code.
                let exact = 255.0 * oetf64(f64::from(x));
                let from_tie = (exact - exact.floor() - 0.5).abs();
                assert!(
                    fast.abs_diff(slow) == 1 && from_tie < 1e-4,
                    "x = {x}: table {fast}, direct {slow}, exact {exact}"
                );
            }
        }
        for code in 0..=255u8 {
            let x = srgb_to_linear(code as f32 / 255.0);
            assert_eq!(lut.encode(x), code, "exact code {code}");
        }
        // Exactly at each rounding threshold and one float below it.
        for (k, t) in SrgbLut::thresholds().into_iter().enumerate() {
            assert_eq!(lut.encode(t), k as u8 + 1, "threshold {}", k + 1);
            assert_eq!(lut.encode(f32::from_bits(t.to_bits() - 1)), k as u8, "below threshold {}", k + 1);
        }
        assert_eq!(lut.encode(0.0), 0);
        assert_eq!(lut.encode(1.0e-30), 0);
        assert_eq!(lut.encode(1.0), 255);
    }

    #[test]
    fn every_bucket_holds_at_most_one_threshold() {
        let thresholds = SrgbLut::thresholds();
        for b in 0..BUCKETS as u32 {
            let lo = f32::from_bits((FIRST + b) << SHIFT);
            let hi = f32::from_bits((FIRST + b + 1) << SHIFT);
            let inside = thresholds.iter().filter(|&&t| lo < t && t < hi).count();
            assert!(inside <= 1, "bucket {b} [{lo}, {hi}) holds {inside}");
        }
        assert!(f32::from_bits(FIRST << SHIFT) == 2f32.powi(-14) && thresholds[0] > 2f32.powi(-14));
        assert_eq!(f32::from_bits((FIRST + BUCKETS as u32 - 1) << SHIFT), 1.0);
    }

    #[test]
    fn rgba_when_alpha() {
        let mut image = Image::from_rgb(2, 1, &[[1.0, 0.0, 0.5], [4.0, 4.0, 4.0]]);
        image.add_channel("A", vec![0.5, f32::NAN]).expect("A");
        let o = PngOptions { alpha: true, exposure: 1.0, tone_map: ToneMap::Reinhard };
        let bytes = encode_srgb8(&image, &o).expect("encode");
        // Alpha is linear and ignores exposure and tone map: 0.5 → 128; NaN → 0.
        let c = |v: f32| encode_reference(ToneMap::Reinhard.apply(2.0 * v));
        assert_eq!(bytes, [c(1.0), 0, c(0.5), 128, c(4.0), c(4.0), c(4.0), 0]);
        let rgb = encode_srgb8(&image, &PngOptions::default()).expect("rgb");
        assert_eq!(rgb.len(), 6);
    }

    #[test]
    fn missing_channels_are_errors() {
        let image = Image::from_rgb(1, 1, &[[0.0; 3]]);
        let err = encode_srgb8(&image, &PngOptions { alpha: true, ..PngOptions::default() }).expect_err("no A");
        assert!(err.to_string().contains("no A channel"), "{err}");
        let mut z = Image::new(1, 1);
        z.add_channel("Z", vec![1.0]).expect("Z");
        let err = encode_srgb8(&z, &PngOptions::default()).expect_err("no RGB");
        assert!(err.to_string().contains("it has Z"), "{err}");
    }

    #[test]
    fn png_round_trip_within_quantisation() {
        let dir = TestDir::new("png-round-trip");
        let (w, h) = (17, 5);
        let pixels: Vec<[f32; 3]> =
            (0..w * h).map(|i| [i as f32 / (w * h) as f32, 1.0 - i as f32 / (w * h) as f32, 0.18]).collect();
        let mut image = Image::from_rgb(w, h, &pixels);
        image.add_channel("A", (0..w * h).map(|i| (i % 7) as f32 / 6.0).collect()).expect("A");
        for alpha in [false, true] {
            let path = dir.join(&format!("rt-{alpha}.png"));
            write_png(&path, &image, &PngOptions { alpha, ..PngOptions::default() }).expect("write");
            let back = read_image(&path).expect("read");
            assert_eq!((back.width, back.height), (w, h));
            assert_eq!(back.channel("A").is_some(), alpha);
            for name in ["R", "G", "B"] {
                let (a, b) = (image.channel(name).expect("in"), back.channel(name).expect("out"));
                for (&x, &y) in a.iter().zip(b) {
                    // Half an 8-bit sRGB step, measured in sRGB.
                    let err = (linear_to_srgb(x) - linear_to_srgb(y)).abs();
                    assert!(err <= 0.5 / 255.0 + 1e-6, "{name}: {x} -> {y}");
                }
            }
            if alpha {
                for (&x, &y) in image.channel("A").expect("A").iter().zip(back.channel("A").expect("A")) {
                    assert!((x - y).abs() <= 0.5 / 255.0 + 1e-6, "A: {x} -> {y}");
                }
            }
        }
    }

    #[test]
    fn encoded_pixels_of_the_wrong_length_are_refused_and_nothing_is_written() {
        let dir = TestDir::new("png-srgb8-length");
        let path = dir.join("short.png");
        std::fs::write(&path, b"keep").expect("seed");
        for (alpha, len) in [(false, 3 * 4 * 2 - 1), (true, 3 * 4 * 2), (false, 0)] {
            let err = write_png_srgb8(&path, 4, 2, alpha, &vec![7u8; len]).expect_err("wrong length");
            assert!(err.to_string().contains("short.png"), "{err}");
            assert!(err.to_string().contains("expected"), "{err}");
        }
        assert_eq!(std::fs::read(&path).expect("still there"), b"keep");
        write_png_srgb8(&path, 4, 2, true, &[9u8; 32]).expect("right length");
        let back = read_image(&path).expect("read");
        assert_eq!((back.width, back.height, back.channel("A").is_some()), (4, 2, true));
    }

    #[test]
    fn full_hd_encode_is_fast() {
        let (w, h) = (1920u32, 1080u32);
        let pixels: Vec<[f32; 3]> =
            (0..w * h).map(|i| [(i % 1920) as f32 / 1920.0, (i / 1920) as f32 / 540.0, 0.3]).collect();
        let image = Image::from_rgb(w, h, &pixels);
        let o = PngOptions { tone_map: ToneMap::Aces, ..PngOptions::default() };
        let _ = encode_srgb8(&image, &o).expect("warm up");
        let t = std::time::Instant::now();
        let bytes = encode_srgb8(&image, &o).expect("encode");
        let elapsed = t.elapsed();
        assert_eq!(bytes.len(), (w * h * 3) as usize);
        eprintln!("1920x1080 encode_srgb8 (aces): {elapsed:?}");
        // Generous bound so a loaded machine does not fail; the expected figure is a few ms.
        assert!(elapsed.as_millis() < 500, "{elapsed:?}");
    }
}
