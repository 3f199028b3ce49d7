//! glint-image: planar f32 images with named channels, their files, tone mapping and metrics.
//!
//! The renderer's film ends here: [`Image`] holds any number of named f32 planes (EXR-style
//! names such as `R`, `A`, `Z`, `Albedo.R`, `Ns.X`), [`write_exr`] stores all of them losslessly,
//! and [`write_png`] turns the `R`,`G`,`B` planes into a display image. Scenes read textures and
//! sky maps through [`read_image`] / [`read_texture`]; [`write_hdr`] (Radiance RGBE) and
//! [`write_jpeg`] serve the sky converter; tests and `glint compare` measure
//! differences with [`metrics`]. Depends on glint-core only (for the sRGB transfer function).
//!
//! # From radiance to an 8-bit pixel
//!
//! [`encode_srgb8`] (and so [`write_png`]) maps each linear colour channel value `v` as follows:
//!
//! 1. **Exposure**: `x = v · 2^exposure` (exposure in stops; `+1` doubles).
//! 2. **Sanitise**: NaN and values `≤ 0` become `0`; values above `10⁹` (including `+∞`) are
//!    treated as `10⁹`.
//! 3. **Tone map** ([`ToneMap`]), per channel:
//!    - `clamp`: `x ↦ min(x, 1)`.
//!    - `reinhard`: `x ↦ x / (1 + x)` (Reinhard et al. 2002, the simple global operator).
//!    - `aces`: `x ↦ clamp(x·(2.51x + 0.03) / (x·(2.43x + 0.59) + 0.14), 0, 1)` — Narkowicz's
//!      2015 fit of the ACES filmic curve. Note it is applied to `x` as given, without the
//!      `0.6` pre-scale some engines apply; use exposure `≈ −0.74` for that look.
//! 4. **sRGB OETF** (IEC 61966-2-1): `c ≤ 0.0031308 ↦ 12.92c`, else `1.055c^(1/2.4) − 0.055`.
//! 5. **Quantise**: round to the nearest of 0..=255.
//!
//! With `alpha`, the `A` channel is written as the PNG alpha: linear, not exposed, not tone
//! mapped, clamped to `[0, 1]` (NaN → 0), rounded.
//!
//! The colour channels are written exactly as they are in the image: glint neither
//! premultiplies nor un-premultiplies. The film's colour is the average over all samples of a
//! pixel, background included, and `A` is the fraction of samples that hit geometry. So:
//!
//! - rendered over a visible background, RGB already contains that background at the edges;
//!   `A` is then only a coverage mask;
//! - rendered with a black background, RGB is premultiplied by `A`. PNG defines straight
//!   (unpremultiplied) alpha, so viewers will show edge pixels slightly too dark; a caller
//!   wanting a correct straight-alpha PNG divides RGB by `A` (where `A > 0`) before writing.
//!   EXR, which stores premultiplied colour by convention, is the right format for compositing.
//!
//! # Reading
//!
//! PNG and JPEG are assumed sRGB-encoded (gamma/ICC chunks are ignored) and decoded to linear;
//! alpha is kept linear. Radiance `.hdr` and OpenEXR are linear already. Headers claiming more
//! than [`MAX_SIDE`] pixels per side, [`MAX_PIXELS`] in total or (EXR) [`MAX_SAMPLES`] values
//! in all channels are rejected before any pixel memory is allocated.
#![forbid(unsafe_code)]

mod atomic;
pub mod error;
mod exr_io;
mod hdr_io;
pub mod memory;
pub mod metrics;
mod planar;
mod png_io;
mod read;
pub mod tonemap;
pub mod ztest;

pub use atomic::atomic_write;
pub use error::{ImageError, UnknownToneMap};
pub use exr_io::{ExrTable, TableData, read_exr_table, write_exr, write_exr_owned, write_exr_table};
pub use hdr_io::write_hdr;
pub use planar::{Channel, Image, RgbPlanes};
pub use png_io::{
    ENCODE_BLOCK, JPEG_QUALITY, LinearBlock, PngOptions, encode_srgb8, encode_srgb8_blocks, encode_srgb8_into,
    write_jpeg, write_png, write_png_srgb8,
};
pub use read::{
    MAX_PIXELS, MAX_SAMPLES, MAX_SIDE, decode_image, is_image_start, jpeg_is_complete, read_image, read_texture,
    texture_from_image,
};
pub use tonemap::ToneMap;

use std::path::Path;

/// Writes `image` in the format its extension names, case-insensitive: `.png` or
/// `.jpg`/`.jpeg` (8-bit sRGB, using `options`), `.hdr` (Radiance RGBE, linear `R`,`G`,`B`,
/// `options` ignored) or `.exr` (all channels, linear, `options` ignored). Anything else is
/// [`ImageError::UnsupportedFormat`]. The write is atomic (see [`atomic_write`]).
pub fn write_image(path: &Path, image: &Image, options: &PngOptions) -> Result<(), ImageError> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match extension.as_deref() {
        Some("png") => write_png(path, image, options),
        Some("jpg" | "jpeg") => write_jpeg(path, image, options),
        Some("hdr") => write_hdr(path, image),
        Some("exr") => write_exr(path, image),
        _ => Err(ImageError::UnsupportedFormat { path: path.to_path_buf() }),
    }
}

#[cfg(test)]
pub(crate) mod test_dir {
    //! A fresh scratch directory per test, under the system temp dir, removed on drop.
    use std::path::{Path, PathBuf};
    use std::sync::atomic::{AtomicU32, Ordering};

    pub struct TestDir(PathBuf);

    impl TestDir {
        pub fn new(name: &str) -> TestDir {
            static COUNTER: AtomicU32 = AtomicU32::new(0);
            let n = COUNTER.fetch_add(1, Ordering::Relaxed);
            let dir = std::env::temp_dir().join(format!("glint-image-{name}-{}-{n}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).expect("create test dir");
            TestDir(dir)
        }

        pub fn path(&self) -> &Path {
            &self.0
        }

        pub fn join(&self, name: &str) -> PathBuf {
            self.0.join(name)
        }
    }

    impl Drop for TestDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_dir::TestDir;

    #[test]
    fn write_image_dispatches_on_extension_case_insensitively() {
        let dir = TestDir::new("dispatch");
        let image = Image::from_rgb(2, 1, &[[0.25, 0.5, 1.0], [0.0, 0.0, 0.0]]);
        for name in ["a.png", "b.PNG", "c.exr", "d.ExR", "e.hdr", "f.HDR", "g.jpg", "h.jpeg"] {
            let path = dir.join(name);
            write_image(&path, &image, &PngOptions::default()).expect("write");
            let back = read_image(&path).expect("read back");
            assert_eq!((back.width, back.height), (2, 1));
        }
    }

    #[test]
    fn unsupported_extension_names_the_path() {
        let dir = TestDir::new("unsupported");
        let image = Image::from_rgb(1, 1, &[[0.0; 3]]);
        for name in ["out.tga", "out", "out.bmp", "out.tiff"] {
            let path = dir.join(name);
            let err = write_image(&path, &image, &PngOptions::default()).expect_err("must fail");
            assert!(matches!(err, ImageError::UnsupportedFormat { .. }), "{err}");
            assert!(err.to_string().contains(name), "{err}");
            assert!(!path.exists());
        }
    }
}
