//! Radiance `.hdr` (RGBE) out, through the `image` crate's encoder; reading is in `read.rs`.
//!
//! RGBE stores one shared 8-bit exponent and three 8-bit mantissas per pixel (Ward, "Real
//! Pixels", Graphics Gems II, 1991), so each channel keeps about 1/256 of the pixel's largest
//! channel. The `image` encoder truncates the mantissas; glint rounds them to nearest first
//! (feeding the encoder values it then stores exactly), which halves the error and removes
//! the truncation's darkening bias. Only `R`, `G`, `B` are written.

use std::path::Path;

use image::ImageEncoder;
use image::codecs::hdr::HdrEncoder;

use crate::atomic::atomic_write;
use crate::error::ImageError;
use crate::planar::Image;

/// Largest value RGBE can hold: mantissa 255 at the top exponent (e = 255 → 2^127 / 256).
const RGBE_MAX: f32 = 255.0 * (1u128 << 119) as f32;
/// Pixels whose largest channel is below this become black (the smallest exponents are
/// awkward for decoders, and nothing visible lives down there).
const RGBE_MIN: f32 = 1.0e-30;

/// Writes the `R`, `G`, `B` planes of `image` as a run-length-encoded Radiance HDR file,
/// atomically. Values are linear as given; NaN and negative values are stored as 0, values
/// beyond RGBE's range (including +∞) as its largest value. Needs channels `R`, `G`, `B`
/// (else [`ImageError::Mismatch`]) and a non-empty image (else [`ImageError::Encode`]).
pub fn write_hdr(path: &Path, image: &Image) -> Result<(), ImageError> {
    image.validate()?;
    let (r, g, b) = image.rgb_planes().ok_or_else(|| {
        ImageError::mismatch(format!("cannot write {}: the image has no R, G, B channels", path.display()))
    })?;
    if image.width == 0 || image.height == 0 {
        return Err(ImageError::encode(path, format!("an HDR image cannot be {}x{}", image.width, image.height)));
    }
    let mut floats = Vec::with_capacity(image.pixel_count() * 3);
    for ((&r, &g), &b) in r.iter().zip(g).zip(b) {
        floats.extend(rgbe_nearest([r, g, b]));
    }
    let bytes: Vec<u8> = floats.iter().flat_map(|v| v.to_ne_bytes()).collect();
    let mut out = Vec::with_capacity(bytes.len() / 3 + 128);
    HdrEncoder::new(&mut out)
        .write_image(&bytes, image.width, image.height, image::ExtendedColorType::Rgb32F)
        .map_err(|e| ImageError::encode(path, e.to_string()))?;
    atomic_write(path, &out)
}

/// The RGBE-representable colour nearest to `rgb` (per channel, sharing the exponent the
/// largest channel needs), after sanitising: NaN/negative → 0, too large → [`RGBE_MAX`].
/// The `image` encoder stores such a value exactly.
fn rgbe_nearest(rgb: [f32; 3]) -> [f32; 3] {
    let rgb = rgb.map(|v| if v.is_nan() || v <= 0.0 { 0.0 } else { v.min(RGBE_MAX) });
    let max = rgb[0].max(rgb[1]).max(rgb[2]);
    if max < RGBE_MIN {
        return [0.0; 3];
    }
    // max ∈ [2^(e−1), 2^e): mantissas are v / 2^e · 256, in [128, 256) for the largest channel.
    let mut step = 2f32.powi(max.log2().floor() as i32 + 1 - 8);
    if (max / step).round() >= 256.0 {
        step *= 2.0;
    }
    rgb.map(|v| (v / step).round().min(255.0) * step)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::read::read_image;
    use crate::test_dir::TestDir;

    /// Each channel within half an RGBE step of the original (relative to the pixel's largest
    /// channel: a step is at most max/128).
    fn assert_within_rgbe(original: &[[f32; 3]], back: &[[f32; 3]]) {
        for (a, b) in original.iter().zip(back) {
            let max = a[0].max(a[1]).max(a[2]);
            for k in 0..3 {
                let tolerance = max / 256.0 + 1e-30;
                assert!((a[k] - b[k]).abs() <= tolerance, "{a:?} -> {b:?}");
            }
        }
    }

    #[test]
    fn round_trip_within_rgbe_precision() {
        let dir = TestDir::new("hdr-round-trip");
        // Wide enough (≥ 8) for the run-length path, plus a narrow one for the flat path.
        for (w, h) in [(37u32, 5u32), (3, 2)] {
            let pixels: Vec<[f32; 3]> = (0..w * h)
                .map(|i| {
                    let t = i as f32 / (w * h) as f32;
                    [t * 6496.0, 0.18 + t, 1.0e-3 * (1.0 - t) + 1.0e-6]
                })
                .collect();
            let image = Image::from_rgb(w, h, &pixels);
            let path = dir.join(&format!("rt-{w}.hdr"));
            write_hdr(&path, &image).expect("write");
            let back = read_image(&path).expect("read");
            assert_eq!((back.width, back.height), (w, h));
            assert_within_rgbe(&pixels, &back.rgb().expect("rgb"));
        }
    }

    #[test]
    fn representable_values_are_exact_and_specials_are_sanitised() {
        let dir = TestDir::new("hdr-specials");
        let pixels = [
            [1.0, 0.5, 0.25],
            [0.0, 0.0, 0.0],
            [f32::NAN, -1.0, 2.0],
            [f32::INFINITY, 1.0, 0.0],
            [1.0e-40, 0.0, 0.0],
            [0.999_999, 0.0, 0.0], // rounds up into the next exponent
        ];
        let image = Image::from_rgb(pixels.len() as u32, 1, &pixels);
        let path = dir.join("specials.hdr");
        write_hdr(&path, &image).expect("write");
        let back = read_image(&path).expect("read").rgb().expect("rgb");
        assert_eq!(back[0], [1.0, 0.5, 0.25]);
        assert_eq!(back[1], [0.0; 3]);
        assert_eq!(back[2], [0.0, 0.0, 2.0]);
        assert_eq!(back[3][0], RGBE_MAX);
        assert!(back[3][1] >= 0.0 && back[3][1] < 1.0e30);
        assert_eq!(back[4], [0.0; 3]);
        assert_eq!(back[5], [1.0, 0.0, 0.0]);
    }

    #[test]
    fn needs_rgb_and_pixels_and_leaves_nothing_on_failure() {
        let dir = TestDir::new("hdr-bad");
        let path = dir.join("z.hdr");
        let mut z = Image::new(1, 1);
        z.add_channel("Z", vec![1.0]).expect("Z");
        assert!(matches!(write_hdr(&path, &z), Err(ImageError::Mismatch { .. })));
        let empty = Image::from_rgb(0, 0, &[]);
        let err = write_hdr(&path, &empty).expect_err("empty");
        assert!(err.to_string().contains("z.hdr"), "{err}");
        assert!(!path.exists());
    }
}
