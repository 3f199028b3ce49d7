//! Texture images from files, decoded to linear RGB by glint-image.
//!
//! glint-image owns image decoding (PNG/JPEG sRGB-decoded to linear, HDR/EXR linear, sizes
//! checked before allocating); this module turns its result into a [`TextureImage`] (rows top
//! to bottom) and its errors into [`FormatError`]s. glTF images embedded in buffers are decoded
//! from memory in `gltf_file` (glint-image reads files only).

use crate::error::FormatError;
use glint_core::Rgb;
use glint_image::ImageError;
use glint_scene::TextureImage;
use std::path::Path;

/// Largest texture side accepted (a 16384² RGB f32 texture is already 3 GiB).
const MAX_TEXTURE_SIDE: u32 = 16_384;

/// Reads an image file as a linear-RGB texture.
pub(crate) fn read_texture_image(path: &Path) -> Result<TextureImage, FormatError> {
    let image = read_image_file(path)?;
    let (width, height, texels) = glint_image::texture_from_image(path, image).map_err(|e| image_error(path, e))?;
    check_size(path, width, height)?;
    let texels = texels.into_iter().map(|c| Rgb::from_array(c.map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 })));
    Ok(TextureImage { width, height, texels: texels.collect() })
}

/// Decodes an image file opened through [`crate::files`] (regular files only, inside the
/// sandbox), refused after its first bytes when they start no image glint reads.
pub(crate) fn read_image_file(path: &Path) -> Result<glint_image::Image, FormatError> {
    let bytes = crate::files::read_sniffed(path, None, |head| {
        if glint_image::is_image_start(path, head) {
            Ok(())
        } else {
            Err("not a PNG, JPEG, TGA, BMP, Radiance HDR or OpenEXR image".to_string())
        }
    })?;
    check_budget(path, "image", &bytes)?;
    glint_image::decode_image(path, &bytes).map_err(|e| image_error(path, e))
}

/// Bytes a texel takes from decoding to the scene: the decoder's pixels (at most 8, RGBA16),
/// the f32 planes of the decoded image (16, RGBA) and the texture's linear RGB (12).
const BYTES_PER_TEXEL: u64 = 36;

/// Refuses, before decoding, an image whose header claims more texels than the memory budget
/// holds (`glint_core::memory`: --max-memory, RAM, `ulimit -v`, the cgroup). A header the
/// reader cannot parse is left to the decoder, which says why. `place`: where in `path` the
/// image is (a glTF's `images[i]`), or "image" for an image file.
pub(crate) fn check_budget(path: &Path, place: &str, bytes: &[u8]) -> Result<(), FormatError> {
    let reader = image::ImageReader::new(std::io::Cursor::new(bytes)).with_guessed_format();
    let Some((w, h)) = reader.ok().and_then(|r| r.into_dimensions().ok()) else { return Ok(()) };
    let texels = u64::from(w) * u64::from(h);
    let what = || format!("the texture {place} ({w} x {h})");
    glint_core::memory::check(what, texels.saturating_mul(BYTES_PER_TEXEL))
        .map_err(|e| FormatError::limits(path, e.to_string()))
}

pub(crate) fn image_error(path: &Path, e: ImageError) -> FormatError {
    match e {
        ImageError::Io { source, .. } => FormatError::io(path, source),
        ImageError::Limits { message, .. } => FormatError::limits(path, format!("image too large: {message}")),
        ImageError::Decode { message, .. } => FormatError::malformed(path, "image data", message),
        ImageError::UnsupportedFormat { .. } => {
            FormatError::malformed(path, "image data", "not a PNG, JPEG, TGA, BMP, Radiance HDR or OpenEXR image")
        }
        other => FormatError::malformed(path, "image data", other.to_string()),
    }
}

pub(crate) fn check_size(path: &Path, width: u32, height: u32) -> Result<(), FormatError> {
    if width == 0 || height == 0 || width > MAX_TEXTURE_SIDE || height > MAX_TEXTURE_SIDE {
        return Err(FormatError::limits(
            path,
            format!("texture size {width}x{height} is outside 1..={MAX_TEXTURE_SIDE} per side"),
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_image_is_an_io_error_naming_it() {
        let err = read_texture_image(Path::new("/nonexistent/tex.png")).expect_err("missing");
        assert!(err.to_string().starts_with("/nonexistent/tex.png"), "{err}");
    }
}
