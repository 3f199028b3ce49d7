//! Reading images: PNG/JPEG (sRGB, decoded to linear), Radiance HDR and OpenEXR (linear).
//!
//! The file is read once into memory and its format recognised by its first bytes (the
//! extension is only a fallback). Sizes claimed by a header are checked against [`MAX_SIDE`],
//! [`MAX_PIXELS`], [`MAX_SAMPLES`] (EXR) and the `image` crate's allocation limit before pixels
//! are allocated.

use std::io::Cursor;
use std::path::Path;

use glint_core::colour::srgb_to_linear;
use image::{DynamicImage, ImageDecoder, ImageFormat, ImageReader};

use crate::error::ImageError;
use crate::exr_io::read_exr;
use crate::planar::Image;

/// Largest width or height glint reads.
pub const MAX_SIDE: u64 = 1 << 16;
/// Largest pixel count glint reads (e.g. 16384 × 8192).
pub const MAX_PIXELS: u64 = 1 << 27;
/// Largest number of f32 values (pixels × channels, all layers) glint reads from one file.
pub const MAX_SAMPLES: u64 = 1 << 30;
/// Largest decoder allocation (bytes) allowed to the `image` crate.
const MAX_ALLOC: u64 = 3 << 30;

const EXR_MAGIC: [u8; 4] = [0x76, 0x2f, 0x31, 0x01];

/// Rejects a claimed `width × height` beyond [`MAX_SIDE`] / [`MAX_PIXELS`].
pub(crate) fn check_size(path: &Path, width: u64, height: u64) -> Result<(), ImageError> {
    if width > MAX_SIDE || height > MAX_SIDE || width * height > MAX_PIXELS {
        return Err(ImageError::Limits {
            path: path.to_path_buf(),
            message: format!(
                "the header claims {width}x{height} pixels; glint reads at most {MAX_SIDE} per side and \
                 {MAX_PIXELS} in total"
            ),
        });
    }
    Ok(())
}

/// Reads an image as linear f32 planes:
///
/// - PNG / JPEG: sRGB-decoded to linear, channels `R`,`G`,`B` (grey is replicated) and `A`
///   when the file has alpha (kept linear, in `[0, 1]`); 16-bit PNGs keep their precision.
/// - Radiance `.hdr`: `R`,`G`,`B`, linear as stored.
/// - OpenEXR: every channel by name as f32 (`layer.channel` for named layers).
///
/// Errors name the path: missing or unreadable file ([`ImageError::Io`]), corrupt or truncated
/// contents ([`ImageError::Decode`]), unknown format, or a header beyond the size limits.
pub fn read_image(path: &Path) -> Result<Image, ImageError> {
    let bytes = std::fs::read(path).map_err(|e| ImageError::io(path, e))?;
    decode_image(path, &bytes)
}

/// True when `head`, the first bytes of a file, can start an image glint reads (by its
/// magic number; TGA, which has none, by the extension of `path`). Lets a caller refuse a
/// file of another kind before reading all of it.
pub fn is_image_start(path: &Path, head: &[u8]) -> bool {
    let tga = path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("tga"));
    head.starts_with(&EXR_MAGIC)
        || tga
        || matches!(
            image::guess_format(head),
            Ok(ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::Hdr | ImageFormat::Bmp)
        )
}

/// A JPEG cut short: the `image` crate fills the missing rows with grey and reports nothing,
/// so glint checks that the last scan (after the last start-of-scan marker `FF DA`) is followed
/// by the end-of-image marker `FF D9`. Entropy-coded data cannot hold either marker (an `FF`
/// byte in it is stuffed as `FF 00`).
fn check_jpeg_complete(path: &Path, bytes: &[u8]) -> Result<(), ImageError> {
    if jpeg_is_complete(bytes) {
        Ok(())
    } else {
        Err(ImageError::decode(path, "the JPEG is truncated: its image data ends without the end-of-image marker"))
    }
}

/// False for a JPEG cut short (see `check_jpeg_complete`): for callers that decode JPEGs
/// themselves (images embedded in glTF files).
pub fn jpeg_is_complete(bytes: &[u8]) -> bool {
    let last_scan = bytes.windows(2).rposition(|w| w == [0xff, 0xda]);
    last_scan.is_some_and(|s| bytes[s..].windows(2).any(|w| w == [0xff, 0xd9]))
}

/// [`read_image`] of bytes already in memory; `path` names them in messages and, for a file
/// without a magic number (TGA), gives the format by its extension.
pub fn decode_image(path: &Path, bytes: &[u8]) -> Result<Image, ImageError> {
    let extension = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if bytes.starts_with(&EXR_MAGIC) || extension.as_deref() == Some("exr") {
        return read_exr(path, bytes);
    }
    let format = image::guess_format(bytes).ok().or_else(|| ImageFormat::from_path(path).ok());
    let format = match format {
        Some(f @ (ImageFormat::Png | ImageFormat::Jpeg | ImageFormat::Hdr | ImageFormat::Tga | ImageFormat::Bmp)) => f,
        _ => return Err(ImageError::UnsupportedFormat { path: path.to_path_buf() }),
    };
    if format == ImageFormat::Jpeg {
        check_jpeg_complete(path, bytes)?;
    }
    let mut reader = ImageReader::with_format(Cursor::new(bytes), format);
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(MAX_SIDE as u32);
    limits.max_image_height = Some(MAX_SIDE as u32);
    limits.max_alloc = Some(MAX_ALLOC);
    reader.limits(limits);
    let decoder = reader.into_decoder().map_err(|e| image_error(path, e))?;
    let (width, height) = decoder.dimensions();
    check_size(path, width.into(), height.into())?;
    let dynamic = DynamicImage::from_decoder(decoder).map_err(|e| image_error(path, e))?;
    Ok(to_planar(dynamic, format == ImageFormat::Hdr))
}

/// Reads an image for use as a texture or sky: linear RGB, row-major, top row first.
/// LDR files are decoded from sRGB; an EXR needs `R`,`G`,`B` (or a single `Y`, replicated).
pub fn read_texture(path: &Path) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    texture_from_image(path, read_image(path)?)
}

/// [`read_texture`] of an image already decoded (by [`decode_image`]).
pub fn texture_from_image(path: &Path, image: Image) -> Result<(u32, u32, Vec<[f32; 3]>), ImageError> {
    let pixels = match (image.rgb(), image.channel("Y")) {
        (Some(rgb), _) => rgb,
        (None, Some(y)) => y.iter().map(|&v| [v; 3]).collect(),
        (None, None) => {
            let names: Vec<&str> = image.channels.iter().map(|c| c.name.as_str()).collect();
            return Err(ImageError::decode(
                path,
                format!("a texture needs R, G, B (or Y) channels, the file has: {}", names.join(", ")),
            ));
        }
    };
    Ok((image.width, image.height, pixels))
}

fn image_error(path: &Path, error: image::ImageError) -> ImageError {
    match error {
        image::ImageError::Limits(e) => ImageError::Limits { path: path.to_path_buf(), message: e.to_string() },
        image::ImageError::IoError(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            ImageError::decode(path, "the file is truncated")
        }
        image::ImageError::IoError(e) => ImageError::decode(path, e.to_string()),
        other => ImageError::decode(path, other.to_string()),
    }
}

/// Decoded pixels → planes. `linear` files (HDR) are taken as stored; others are sRGB.
fn to_planar(dynamic: DynamicImage, linear: bool) -> Image {
    let (width, height) = (dynamic.width(), dynamic.height());
    let colour = dynamic.color();
    let alpha = colour.has_alpha();
    let eight_bit = colour.bytes_per_pixel() == colour.channel_count();
    let mut image = Image::new(width, height);
    let mut planes: Vec<Vec<f32>> = Vec::new();
    if eight_bit && !linear {
        let table: Vec<f32> = (0..=255u8).map(|v| srgb_to_linear(f32::from(v) / 255.0)).collect();
        let (data, n) = if alpha { (dynamic.into_rgba8().into_raw(), 4) } else { (dynamic.into_rgb8().into_raw(), 3) };
        for k in 0..n {
            let decode = |v: u8| if k == 3 { f32::from(v) / 255.0 } else { table[v as usize] };
            planes.push(data.iter().skip(k).step_by(n).map(|&v| decode(v)).collect());
        }
    } else {
        let (data, n) =
            if alpha { (dynamic.into_rgba32f().into_raw(), 4) } else { (dynamic.into_rgb32f().into_raw(), 3) };
        for k in 0..n {
            let decode = |v: f32| if k == 3 || linear { v } else { srgb_to_linear(v) };
            planes.push(data.iter().skip(k).step_by(n).map(|&v| decode(v)).collect());
        }
    }
    for (name, data) in ["R", "G", "B", "A"].into_iter().zip(planes) {
        image.channels.push(crate::planar::Channel { name: name.to_string(), data });
    }
    image
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_dir::TestDir;

    const SHARED: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

    fn shared(relative: &str) -> Option<std::path::PathBuf> {
        let path = Path::new(SHARED).join(relative);
        if path.exists() {
            Some(path)
        } else {
            eprintln!("note: {} is absent; skipped", path.display());
            None
        }
    }

    #[test]
    fn missing_file_names_it() {
        let err = read_image(Path::new("/definitely/not/here.png")).expect_err("missing");
        assert!(matches!(err, ImageError::Io { .. }), "{err}");
        assert!(err.to_string().starts_with("/definitely/not/here.png: "), "{err}");
        let err = read_texture(Path::new("nope.exr")).expect_err("missing");
        assert!(err.to_string().contains("nope.exr"), "{err}");
    }

    #[test]
    fn garbage_and_truncated_files_are_decode_errors() {
        let dir = TestDir::new("read-garbage");
        let garbage = dir.join("garbage.png");
        std::fs::write(&garbage, b"this is not a png at all, just text").expect("write");
        let err = read_image(&garbage).expect_err("garbage");
        assert!(matches!(err, ImageError::Decode { .. }), "{err}");
        assert!(err.to_string().starts_with(&garbage.display().to_string()), "{err}");

        let empty = dir.join("empty.jpg");
        std::fs::write(&empty, b"").expect("write");
        assert!(matches!(read_image(&empty), Err(ImageError::Decode { .. })));

        let image = Image::from_rgb(40, 30, &vec![[0.3, 0.6, 0.9]; 1200]);
        let full = dir.join("full.png");
        crate::write_png(&full, &image, &Default::default()).expect("write png");
        let bytes = std::fs::read(&full).expect("read");
        for cut in [8, 20, bytes.len() / 2, bytes.len() - 13] {
            let cut_path = dir.join("cut.png");
            std::fs::write(&cut_path, &bytes[..cut]).expect("write");
            let err = read_image(&cut_path).expect_err("truncated");
            assert!(matches!(err, ImageError::Decode { .. }), "cut {cut}: {err}");
        }
    }

    /// TGA (how many skyboxes and game textures ship, hipshot's Miramar among them) and BMP
    /// read as sRGB like PNG; a TGA cut short is a decode error naming the file.
    #[test]
    fn tga_and_bmp_read_as_srgb() {
        let dir = TestDir::new("read-tga");
        let rgb = image::RgbImage::from_fn(3, 2, |x, y| image::Rgb([(x * 100) as u8, (y * 255) as u8, 188]));
        for name in ["face.tga", "face.bmp"] {
            let path = dir.join(name);
            rgb.save(&path).expect("encode");
            let img = read_image(&path).expect(name);
            assert_eq!((img.width, img.height), (3, 2));
            let r = img.channel("R").expect("R");
            assert!((r[2] - srgb_to_linear(200.0 / 255.0)).abs() < 1e-6, "{name}: {}", r[2]);
            assert!((img.channel("G").expect("G")[3] - 1.0).abs() < 1e-6);
        }
        let path = dir.join("cut.tga");
        let bytes = std::fs::read(dir.join("face.tga")).expect("read");
        std::fs::write(&path, &bytes[..bytes.len() - 6]).expect("write");
        let err = read_image(&path).expect_err("truncated");
        assert!(err.to_string().starts_with(&path.display().to_string()), "{err}");
    }

    #[test]
    fn unknown_format_is_unsupported() {
        let dir = TestDir::new("read-unknown");
        let path = dir.join("notes.txt");
        std::fs::write(&path, b"hello").expect("write");
        let err = read_image(&path).expect_err("unsupported");
        assert!(matches!(err, ImageError::UnsupportedFormat { .. }), "{err}");
    }

    /// A minimal PNG whose IHDR claims `width × height` (valid CRCs), with a tiny, useless IDAT.
    fn png_header(width: u32, height: u32) -> Vec<u8> {
        fn crc32(bytes: &[u8]) -> u32 {
            let mut crc = !0u32;
            for &b in bytes {
                crc ^= u32::from(b);
                for _ in 0..8 {
                    crc = if crc & 1 != 0 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
                }
            }
            !crc
        }
        let mut chunk = b"IHDR".to_vec();
        chunk.extend_from_slice(&width.to_be_bytes());
        chunk.extend_from_slice(&height.to_be_bytes());
        chunk.extend_from_slice(&[8, 2, 0, 0, 0]); // 8-bit RGB
        let mut png = b"\x89PNG\r\n\x1a\n".to_vec();
        png.extend_from_slice(&13u32.to_be_bytes());
        png.extend_from_slice(&chunk);
        png.extend_from_slice(&crc32(&chunk).to_be_bytes());
        let idat = b"IDAT\x78\x01\x01\x00\x00";
        png.extend_from_slice(&(idat.len() as u32 - 4).to_be_bytes());
        png.extend_from_slice(idat);
        png.extend_from_slice(&crc32(idat).to_be_bytes());
        png.extend_from_slice(&[0, 0, 0, 0]);
        png.extend_from_slice(b"IEND");
        png.extend_from_slice(&crc32(b"IEND").to_be_bytes());
        png
    }

    #[test]
    fn huge_png_header_is_rejected_as_limits() {
        let dir = TestDir::new("read-huge");
        for (w, h) in [(1_000_000, 1_000_000), (60_000, 60_000)] {
            let path = dir.join("huge.png");
            std::fs::write(&path, png_header(w, h)).expect("write");
            let err = read_image(&path).expect_err("must reject");
            assert!(matches!(err, ImageError::Limits { .. }), "{w}x{h}: {err}");
            assert!(err.to_string().contains("huge.png"), "{err}");
        }
        // The same header at a sane size gets past the limits and fails on the missing pixels.
        let path = dir.join("small.png");
        std::fs::write(&path, png_header(4, 4)).expect("write");
        assert!(matches!(read_image(&path), Err(ImageError::Decode { .. })));
    }

    #[test]
    fn grey_and_sixteen_bit_pngs_decode_to_linear_rgb() {
        let dir = TestDir::new("read-grey");
        let path = dir.join("grey16.png");
        let grey = image::ImageBuffer::<image::Luma<u16>, _>::from_raw(2, 1, vec![0u16, 32768]).expect("buffer");
        grey.save(&path).expect("save");
        let image = read_image(&path).expect("read");
        assert_eq!(image.channels.len(), 3);
        let expected = srgb_to_linear(32768.0 / 65535.0);
        for name in ["R", "G", "B"] {
            let c = image.channel(name).expect(name);
            assert_eq!(c[0], 0.0);
            assert!((c[1] - expected).abs() < 1e-6, "{name}: {}", c[1]);
        }
    }

    #[test]
    fn real_hdr_envmaps_read() {
        for name in ["envmaps/venice_sunset_1k.hdr", "envmaps/overcast_soil_puresky_1k.hdr"] {
            let Some(path) = shared(name) else { continue };
            let image = read_image(&path).expect("read hdr");
            assert_eq!(image.width, 2 * image.height, "{name} is lat-long 2:1");
            assert_eq!(image.channels.len(), 3);
            let rgb = image.rgb().expect("rgb");
            assert!(rgb.iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "{name}");
            let max = rgb.iter().flatten().fold(0.0f32, |m, &v| m.max(v));
            assert!(max > 1.0, "{name}: an HDR sky should exceed 1 somewhere (max {max})");
            let (w, h, texels) = read_texture(&path).expect("texture");
            assert_eq!((w, h, texels.len()), (image.width, image.height, rgb.len()));
        }
    }

    #[test]
    fn real_jpeg_and_png_skyboxes_read_as_linear() {
        for name in ["skyboxes/humus_magnum_512/posx.jpg", "skyboxes/hipshot_miramar_1024/front.png"] {
            let Some(path) = shared(name) else { continue };
            let (w, h, texels) = read_texture(&path).expect("read");
            assert!(w > 0 && h > 0 && texels.len() == (w * h) as usize, "{name}");
            assert!(texels.iter().flatten().all(|v| (0.0..=1.0).contains(v)), "{name}");
            let mean = texels.iter().flatten().sum::<f32>() / (3 * texels.len()) as f32;
            assert!(mean > 0.0 && mean < 1.0, "{name}: mean {mean}");
        }
        if let Some(path) = shared("skyboxes/cross/humus_storforsen4_cross.jpg") {
            let image = read_image(&path).expect("cross");
            assert_eq!(image.width * 3, image.height * 4, "a horizontal cross is 4:3");
        }
    }
}
