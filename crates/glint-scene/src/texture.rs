//! Diffuse textures: an image (bilinear or nearest, repeating, mirrored or clamped, on an
//! affinely transformed uv) or a procedural checker, both on uv.

use glint_core::glam::Affine2;
use glint_core::{Rgb, Vec2};
use std::sync::Arc;

/// How lookups outside [0, 1] are brought back into an image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Wrap {
    #[default]
    Repeat,
    /// Every other copy mirrored, so edges meet themselves.
    Mirror,
    /// The border texels extend outward.
    Clamp,
}

/// How an image is read between texel centres.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TexelFilter {
    #[default]
    Bilinear,
    /// The texel the point falls in.
    Nearest,
}

/// Where and how an image texture is read: `uv_transform` maps the surface's uv (glint's:
/// v = 0 is the image's bottom row) to the image's, before `scale` (Mitsuba's `to_uv`,
/// conjugated into glint's v direction by the loader).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ImageSampling {
    pub uv_transform: Affine2,
    pub wrap: Wrap,
    pub filter: TexelFilter,
}

impl Default for ImageSampling {
    fn default() -> Self {
        Self { uv_transform: Affine2::IDENTITY, wrap: Wrap::Repeat, filter: TexelFilter::Bilinear }
    }
}

fn wrap_index(i: i64, n: i64, wrap: Wrap) -> usize {
    let i = match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m < n { m } else { 2 * n - 1 - m }
        }
    };
    i as usize
}

/// A linear-RGB texture image, rows top to bottom; v = 0 is the bottom row (OBJ/glTF
/// conventions differ: loaders flip glTF's v so that this holds for every mesh).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Rgb>,
}

impl TextureImage {
    /// Lookup with the given wrapping and filter (texel centres at `(i + ½)/width`, as in
    /// [`TextureImage::sample`]).
    pub fn sample_with(&self, uv: Vec2, wrap: Wrap, filter: TexelFilter) -> Rgb {
        if wrap == Wrap::Repeat && filter == TexelFilter::Bilinear {
            return self.sample(uv);
        }
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * w as f32;
        let y = (1.0 - uv.y) * h as f32;
        let texel = |xi: i64, yi: i64| self.texels[wrap_index(yi, h, wrap) * w as usize + wrap_index(xi, w, wrap)];
        match filter {
            TexelFilter::Nearest => texel(x.floor() as i64, y.floor() as i64),
            TexelFilter::Bilinear => {
                let (x, y) = (x - 0.5, y - 0.5);
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
                let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
                top.lerp(bottom, fy)
            }
        }
    }

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
    /// Read at `sampling.uv_transform(uv) · scale`.
    Image { image: Arc<TextureImage>, scale: Vec2, sampling: ImageSampling },
    /// Squares of side `size` (in uv units) alternating `even` and `odd`.
    Checker { size: f32, even: Rgb, odd: Rgb },
}

impl Texture {
    #[inline]
    pub fn evaluate(&self, uv: Vec2) -> Rgb {
        match self {
            Texture::Image { image, scale, sampling } => {
                let uv = sampling.uv_transform.transform_point2(uv) * *scale;
                image.sample_with(uv, sampling.wrap, sampling.filter)
            }
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
    fn wrap_modes_and_nearest_filtering() {
        let img = TextureImage { width: 2, height: 1, texels: vec![Rgb::ZERO, Rgb::ONE] };
        let near = |u: f32, wrap| img.sample_with(Vec2::new(u, 0.5), wrap, TexelFilter::Nearest);
        assert_eq!(near(0.4, Wrap::Repeat), Rgb::ZERO);
        assert_eq!(near(0.6, Wrap::Repeat), Rgb::ONE);
        assert_eq!(near(1.2, Wrap::Repeat), Rgb::ZERO);
        assert_eq!(near(1.2, Wrap::Mirror), Rgb::ONE);
        assert_eq!(near(1.7, Wrap::Mirror), Rgb::ZERO);
        assert_eq!(near(3.0, Wrap::Clamp), Rgb::ONE);
        assert_eq!(near(-3.0, Wrap::Clamp), Rgb::ZERO);
        let clamped = img.sample_with(Vec2::new(0.99, 0.5), Wrap::Clamp, TexelFilter::Bilinear);
        assert_eq!(clamped, Rgb::ONE);
        let t = Texture::Image {
            image: Arc::new(img),
            scale: Vec2::ONE,
            sampling: ImageSampling {
                uv_transform: Affine2::from_scale(Vec2::new(0.5, 1.0)),
                filter: TexelFilter::Nearest,
                ..ImageSampling::default()
            },
        };
        assert_eq!(t.evaluate(Vec2::new(1.5, 0.5)), Rgb::ONE);
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
