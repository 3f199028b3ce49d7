//! Synthetic skies with known content, for tests of sky files, lookups and renders.

use glint_core::Rgb;
use glint_image::Image;
use glint_scene::TextureImage;

/// A smooth synthetic HDR lat-long map (values up to ~3), `width × width/2`.
#[must_use]
pub fn smooth_latlong(width: u32) -> Image {
    let height = width / 2;
    let pixels: Vec<[f32; 3]> = (0..width * height)
        .map(|i| {
            let (u, v) = ((i % width) as f32 / width as f32, (i / width) as f32 / height as f32);
            let phi = u * std::f32::consts::TAU;
            let theta = v * std::f32::consts::PI;
            [
                0.6 + 0.5 * (2.0 * phi).sin() * theta.sin(),
                0.5 + 0.4 * (3.0 * theta).cos(),
                0.4 + 2.5 * (1.0 - v).powi(4) + 0.2 * phi.cos() * theta.sin(),
            ]
        })
        .collect();
    Image::from_rgb(width, height, &pixels)
}

/// An `n × n` face of one-texel black and white checks (its mean is grey 0.5): what a sky
/// lookup must not alias when minified.
#[must_use]
pub fn checker_face(n: usize) -> TextureImage {
    TextureImage {
        width: n as u32,
        height: n as u32,
        texels: (0..n * n).map(|i| if (i % n + i / n).is_multiple_of(2) { Rgb::ZERO } else { Rgb::ONE }).collect(),
    }
}
