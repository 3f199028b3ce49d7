//! Textures: an image (bilinear or nearest, repeating, mirrored or clamped, with an affine uv
//! transform: glTF's samplers and KHR_texture_transform) or a procedural checker, both on uv.

use glint_core::glam::Affine2;
use glint_core::{Rgb, Vec2};
use std::sync::Arc;

/// How an image is addressed outside [0, 1] along one axis (glTF's sampler wrap modes).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Wrap {
    #[default]
    Repeat,
    /// Every other repetition mirrored.
    MirroredRepeat,
    /// The edge texels extend outward.
    Clamp,
}

/// How texels are interpolated (no mipmaps: a minifying filter is read as its base level).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Filter {
    #[default]
    Bilinear,
    Nearest,
}

/// How an image texture is read: where a surface uv lands on the image (an affine map applied
/// after `Texture::Image::scale`, in glint's uv convention: v = 0 the bottom row), then wrap
/// and filter. The default is the identity, repeating, bilinear.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampler {
    pub texture_from_surface: Affine2,
    pub wrap_u: Wrap,
    pub wrap_v: Wrap,
    pub filter: Filter,
}

impl Default for Sampler {
    fn default() -> Self {
        Self {
            texture_from_surface: Affine2::IDENTITY,
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::Repeat,
            filter: Filter::Bilinear,
        }
    }
}

/// Texel index `i` of a row or column of `n` texels, wrapped as `wrap` says.
fn wrap_texel(i: i64, n: i64, wrap: Wrap) -> usize {
    (match wrap {
        Wrap::Repeat => i.rem_euclid(n),
        Wrap::Clamp => i.clamp(0, n - 1),
        Wrap::MirroredRepeat => {
            let k = i.rem_euclid(2 * n);
            if k < n { k } else { 2 * n - 1 - k }
        }
    }) as usize
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

    /// Lookup at `uv` (already transformed) with the sampler's wraps and filter.
    pub fn sample_with(&self, uv: Vec2, sampler: &Sampler) -> Rgb {
        if sampler.wrap_u == Wrap::Repeat && sampler.wrap_v == Wrap::Repeat && sampler.filter == Filter::Bilinear {
            return self.sample(uv);
        }
        let (w, h) = (self.width as i64, self.height as i64);
        let x = uv.x * w as f32 - 0.5;
        let y = (1.0 - uv.y) * h as f32 - 0.5;
        let texel = |xi: i64, yi: i64| {
            self.texels[wrap_texel(yi, h, sampler.wrap_v) * w as usize + wrap_texel(xi, w, sampler.wrap_u)]
        };
        match sampler.filter {
            Filter::Nearest => texel((x + 0.5).floor() as i64, (y + 0.5).floor() as i64),
            Filter::Bilinear => {
                let (x0, y0) = (x.floor(), y.floor());
                let (fx, fy) = (x - x0, y - y0);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let top = texel(x0, y0).lerp(texel(x0 + 1, y0), fx);
                let bottom = texel(x0, y0 + 1).lerp(texel(x0 + 1, y0 + 1), fx);
                top.lerp(bottom, fy)
            }
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Texture {
    /// Read at `sampler.texture_from_surface(uv · scale)`.
    Image { image: Arc<TextureImage>, scale: Vec2, sampler: Sampler },
    /// Squares of side `size` (in uv units) alternating `even` and `odd`.
    Checker { size: f32, even: Rgb, odd: Rgb },
    /// The hit mesh's attribute `name` ([`crate::MeshAttribute`]: a face's value or its
    /// vertices' values interpolated), times `scale` (Mitsuba's `mesh_attribute`). Not a
    /// function of uv: renderers read it through the hit; [`Texture::evaluate`] sees only
    /// uv and gives `scale` (what a surface without the attribute shows, as Mitsuba's 1).
    MeshAttribute { name: String, scale: f32 },
}

impl Texture {
    /// Does this texture read the hit's mesh rather than its uv?
    #[must_use]
    pub fn reads_mesh(&self) -> bool {
        matches!(self, Texture::MeshAttribute { .. })
    }

    #[inline]
    pub fn evaluate(&self, uv: Vec2) -> Rgb {
        match self {
            Texture::Image { image, scale, sampler } => {
                image.sample_with(sampler.texture_from_surface.transform_point2(uv * *scale), sampler)
            }
            Texture::Checker { size, even, odd } => {
                let c = (uv / *size).floor();
                if (c.x as i64 + c.y as i64).rem_euclid(2) == 0 { *even } else { *odd }
            }
            Texture::MeshAttribute { scale, .. } => Rgb::splat(*scale),
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

    #[test]
    fn wraps_filters_and_transform_address_the_right_texels() {
        // Four texels in a row: 0, 1, 2, 3.
        let img =
            Arc::new(TextureImage { width: 4, height: 1, texels: (0..4).map(|i| Rgb::splat(i as f32)).collect() });
        let at = |wrap_u, filter, u: f32| {
            let sampler = Sampler { wrap_u, filter, ..Sampler::default() };
            Texture::Image { image: img.clone(), scale: Vec2::ONE, sampler }.evaluate(Vec2::new(u, 0.5)).x
        };
        // Texel 0's centre is u = 1/8; beyond 1 a repeat starts over, a mirror runs back, a
        // clamp stays on the last texel.
        assert_eq!(at(Wrap::Repeat, Filter::Nearest, 1.0 + 0.125), 0.0);
        assert_eq!(at(Wrap::MirroredRepeat, Filter::Nearest, 1.0 + 0.125), 3.0);
        assert_eq!(at(Wrap::MirroredRepeat, Filter::Nearest, 1.0 + 0.375), 2.0);
        assert_eq!(at(Wrap::Clamp, Filter::Nearest, 1.7), 3.0);
        assert_eq!(at(Wrap::Clamp, Filter::Nearest, -0.3), 0.0);
        // Nearest picks a texel; bilinear blends the two around u.
        assert_eq!(at(Wrap::Clamp, Filter::Nearest, 0.3), 1.0);
        assert!((at(Wrap::Clamp, Filter::Bilinear, 0.25) - 0.5).abs() < 1e-6);
        // Default sampler: the same as the plain repeating lookup.
        assert_eq!(at(Wrap::Repeat, Filter::Bilinear, 1.3), img.sample(Vec2::new(1.3, 0.5)).x);
        // An offset of half the image moves texel 2 to u = 1/8.
        let sampler = Sampler {
            texture_from_surface: Affine2::from_translation(Vec2::new(0.5, 0.0)),
            filter: Filter::Nearest,
            ..Sampler::default()
        };
        let t = Texture::Image { image: img.clone(), scale: Vec2::ONE, sampler };
        assert_eq!(t.evaluate(Vec2::new(0.125, 0.5)).x, 2.0);
    }
}
