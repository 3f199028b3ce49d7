//! Texture plugins → [`Texture::Image`] (src/textures/*.cpp): `bitmap` (sRGB-decoded unless
//! `raw` or a linear format, bilinear or nearest, repeat/mirror/clamp, `to_uv`),
//! `checkerboard` (as a 2 × 2 image read nearest and repeating, which is exactly Mitsuba's
//! rule: `color0` where `frac(u) > ½` equals `frac(v) > ½`) and constants (1 × 1 images).
//!
//! Mitsuba's uv has v = 0 at the image's top and glint's at its bottom: with F(u, v) = (u, 1 − v)
//! a Mitsuba `to_uv` transform T becomes F ∘ T ∘ F on glint's uv, which reads the same texel.

use super::Builder;
use super::props::{Props, Value};
use super::spectrum::{Use, to_rgb};
use super::xml::Element;
use crate::error::FormatError;
use glint_core::glam::{Affine2, DMat4, Mat2};
use glint_core::{Rgb, Vec2};
use glint_scene::{Filter, Sampler, Texture, TextureImage, Wrap};
use std::sync::Arc;

/// A Mitsuba `to_uv` (4 × 4, its x/y rows and columns) as a transform of glint's uv.
pub(super) fn glint_uv_transform(m: &DMat4) -> Affine2 {
    let m = m.as_mat4();
    let mitsuba = Affine2::from_mat2_translation(
        Mat2::from_cols(Vec2::new(m.x_axis.x, m.x_axis.y), Vec2::new(m.y_axis.x, m.y_axis.y)),
        Vec2::new(m.w_axis.x, m.w_axis.y),
    );
    let flip = Affine2::from_mat2_translation(Mat2::from_diagonal(Vec2::new(1.0, -1.0)), Vec2::new(0.0, 1.0));
    flip * mitsuba * flip
}

/// The sRGB transfer function (for `raw` 8-bit images, which glint-image decodes to linear).
fn srgb_encode(v: f32) -> f32 {
    if v <= 0.003_130_8 { v * 12.92 } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 }
}

impl<'a> Builder<'a> {
    /// The index of a texture element in `Scene::textures` (converted on first use).
    pub(super) fn texture(&mut self, el: &'a Element) -> Result<usize, FormatError> {
        let k = super::key(el);
        if let Some(&i) = self.texture_cache.get(&k) {
            return Ok(i);
        }
        let p = self.props(el)?;
        p.ignore(&["id"]);
        let uv_transform = p.transform("to_uv")?.map_or(Affine2::IDENTITY, |m| glint_uv_transform(&m));
        let texture = match p.plugin {
            "bitmap" => self.bitmap(&p, uv_transform)?,
            "checkerboard" => {
                let c0 = self.constant_colour(&p, "color0", 0.4)?;
                let c1 = self.constant_colour(&p, "color1", 0.2)?;
                // Rows top to bottom, as Mitsuba indexes them by v.
                let image = TextureImage { width: 2, height: 2, texels: vec![c0, c1, c1, c0] };
                let sampler =
                    Sampler { texture_from_surface: uv_transform, filter: Filter::Nearest, ..Sampler::default() };
                // Mitsuba's checkerboard read as a float (`eval_1`) has the other parity than
                // as a colour (`eval`: color0 where both halves agree; `eval_1`: where they
                // differ). Its float reading is a twin with the colours swapped, right after it.
                let twin = TextureImage { width: 2, height: 2, texels: vec![c1, c0, c0, c1] };
                let twin = Texture::Image { image: Arc::new(twin), scale: Vec2::ONE, sampler };
                self.finish(&p)?;
                self.scene.textures.push(Texture::Image { image: Arc::new(image), scale: Vec2::ONE, sampler });
                let i = self.scene.textures.len() - 1;
                self.scene.textures.push(twin);
                self.float_twins.insert(i, i + 1);
                self.texture_cache.insert(k, i);
                return Ok(i);
            }
            "mesh_attribute" => {
                let Some(name) = p.string("name")? else {
                    return Err(el.loc.error("mesh_attribute needs a name (vertex_… or face_…)"));
                };
                if !(name.starts_with("vertex_") || name.starts_with("face_")) {
                    return Err(el
                        .loc
                        .error(format!("mesh_attribute name '{name}' starts with neither vertex_ nor face_")));
                }
                Texture::MeshAttribute { name: name.to_string(), scale: p.float("scale", 1.0)? as f32 }
            }
            "rawconstant" | "uniform" | "srgb" => {
                let name = if p.plugin == "srgb" { "color" } else { "value" };
                let c = self.constant_colour(&p, name, 1.0)?;
                let image = TextureImage { width: 1, height: 1, texels: vec![c] };
                Texture::Image { image: Arc::new(image), scale: Vec2::ONE, sampler: Sampler::default() }
            }
            other => {
                self.unsupported(&el.loc, format!("texture '{other}' is not supported: a constant 0.5 is used"))?;
                let image = TextureImage { width: 1, height: 1, texels: vec![Rgb::splat(0.5)] };
                self.scene.textures.push(Texture::Image {
                    image: Arc::new(image),
                    scale: Vec2::ONE,
                    sampler: Sampler::default(),
                });
                let i = self.scene.textures.len() - 1;
                self.texture_cache.insert(k, i);
                return Ok(i);
            }
        };
        self.finish(&p)?;
        self.scene.textures.push(texture);
        let i = self.scene.textures.len() - 1;
        self.texture_cache.insert(k, i);
        Ok(i)
    }

    /// A texture read by uv (a bump or normal map's): a mesh_attribute is refused.
    pub(super) fn uv_texture(&mut self, el: &'a Element, user: &str) -> Result<usize, FormatError> {
        let t = self.texture(el)?;
        if self.scene.textures[t].reads_mesh() {
            return Err(el
                .loc
                .error(format!("a {user} reads its texture by uv: mesh_attribute is not supported there")));
        }
        Ok(t)
    }

    fn constant_colour(&mut self, p: &Props<'a>, name: &str, default: f64) -> Result<Rgb, FormatError> {
        let Some(prop) = p.get(name) else { return Ok(Rgb::splat(default as f32)) };
        if let Value::Object(o) = prop.value {
            self.unsupported(&o.loc, format!("a texture as '{name}' of {}: 0.5 is used", p.el.describe()))?;
            return Ok(Rgb::splat(0.5));
        }
        if let Value::Vector(v) = prop.value {
            // rawconstant's vector values (a flat normal map: 0.5 0.5 1).
            return Ok(Rgb::new(v.x as f32, v.y as f32, v.z as f32));
        }
        let c = to_rgb(&prop.value, Use::Unbounded)
            .ok_or_else(|| prop.at.loc.error(format!("'{name}' of {} must be a colour or float", p.el.describe())))?;
        Ok(Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32))
    }

    fn bitmap(&mut self, p: &Props<'a>, uv_transform: Affine2) -> Result<Texture, FormatError> {
        let name = p.string("filename")?.ok_or_else(|| p.loc().error("a bitmap texture needs a filename"))?;
        let file = self.resolve(name, p.el)?;
        let raw = p.boolean("raw", false)?;
        let filter = match p.string("filter_type")?.unwrap_or("bilinear") {
            "bilinear" => Filter::Bilinear,
            "nearest" => Filter::Nearest,
            other => return Err(p.loc().error(format!("filter_type '{other}' is neither bilinear nor nearest"))),
        };
        let wrap = match p.string("wrap_mode")?.unwrap_or("repeat") {
            "repeat" => Wrap::Repeat,
            "mirror" => Wrap::MirroredRepeat,
            "clamp" => Wrap::Clamp,
            other => return Err(p.loc().error(format!("wrap_mode '{other}' is none of repeat, mirror, clamp"))),
        };
        p.ignore(&["format", "accel"]);
        let mut image = crate::texture_file::read_texture_image(&file)?;
        let ext = crate::model::extension(&file).to_ascii_lowercase();
        if raw && !matches!(ext.as_str(), "exr" | "hdr") {
            for t in &mut image.texels {
                *t = Rgb::new(srgb_encode(t.x), srgb_encode(t.y), srgb_encode(t.z));
            }
        }
        Ok(Texture::Image {
            image: Arc::new(image),
            scale: Vec2::ONE,
            sampler: Sampler { texture_from_surface: uv_transform, wrap_u: wrap, wrap_v: wrap, filter },
        })
    }
}
