//! Diffuse textures: an image (bilinear, repeating) or a procedural checker, both on uv.

use glint_core::{Rgb, Vec2};
use std::sync::Arc;

/// A linear-RGB texture image, rows top to bottom; v = 0 is the bottom row (OBJ/glTF
/// conventions differ: loaders flip glTF's v so that this holds for every mesh).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Rgb>,
}

impl TextureImage {
    /// Bilinear lookup with repeat wrapping.
    pub fn sample(&self, uv: Vec2) -> Rgb {
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x.rem_euclid(1.0) * w as f32 - 0.5;
        let y = (1.0 - uv.y.rem_euclid(1.0)) * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let texel = |xi: i64, yi: i64| {
            let xi = xi.rem_euclid(w) as usize;
            let yi = yi.rem_euclid(h) as usize;
            self.texels[yi * w as usize + xi]
        };
        let (x0, y0) = (x0 as i64, y0 as i64);
        let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
        let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
        top.lerp(bottom, fy)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    Image {
        image: Arc<TextureImage>,
        scale: Vec2,
    },
    /// Squares of side `size` (in uv units) alternating `even` and `odd`.
    Checker {
        size: f32,
        even: Rgb,
        odd: Rgb,
    },
}

impl Texture {
    #[inline]
    pub fn evaluate(&self, uv: Vec2) -> Rgb {
        match self {
            Texture::Image { image, scale } => image.sample(uv * *scale),
            Texture::Checker { size, even, odd } => {
                let c = (uv / *size).floor();
                if (c.x as i64 + c.y as i64).rem_euclid(2) == 0 { *even } else { *odd }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_alternates() {
        let t = Texture::Checker { size: 1.0, even: Rgb::ONE, odd: Rgb::ZERO };
        assert_eq!(t.evaluate(Vec2::new(0.5, 0.5)), Rgb::ONE);
        assert_eq!(t.evaluate(Vec2::new(1.5, 0.5)), Rgb::ZERO);
        assert_eq!(t.evaluate(Vec2::new(-0.5, 0.5)), Rgb::ZERO);
    }

    #[test]
    fn bilinear_image_is_exact_at_texel_centres() {
        let img = TextureImage { width: 2, height: 1, texels: vec![Rgb::ZERO, Rgb::ONE] };
        assert_eq!(img.sample(Vec2::new(0.25, 0.5)), Rgb::ZERO);
        assert_eq!(img.sample(Vec2::new(0.75, 0.5)), Rgb::ONE);
        let mid = img.sample(Vec2::new(0.5, 0.5));
        assert!((mid.x - 0.5).abs() < 1e-6);
    }
}
