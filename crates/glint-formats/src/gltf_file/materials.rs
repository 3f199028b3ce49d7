//! glTF materials → glint materials: a physically based model for the path mode
//! ([`BsdfKind`], in `Model::bsdfs`) and the closest Phong parameters for the Whitted mode.
//!
//! **Path mode.** Metallic-roughness is Mitsuba's `principled` (Disney 2015) with base colour,
//! metallic and roughness as given (both use α = roughness², the metal's F0 = base colour),
//! `specular` from the index of refraction (0.5 for glTF's 1.5; KHR_materials_ior), no sheen,
//! clearcoat or tint. Textures multiply their factors (the factor is baked into a texture of
//! its own when it is not 1): base colour (sRGB decoded), metallic = blue and roughness = green
//! of metallicRoughnessTexture (linear). KHR_materials_transmission is `spec_trans`; glTF's
//! transmission is thin-walled unless KHR_materials_volume gives a thickness, so it is
//! `principledthin` (which has no metallic: a metallic transmissive material blends a thin
//! dielectric and a metal by metallic), or the solid `principled` with a thickness. Then, from
//! the inside out: normalTexture → [`BsdfKind::NormalMap`] (its scale baked into the map:
//! `normalize((2t − 1)·(s, s, 1))`, exact up to filtering; tangent frame from the uvs, +Y up
//! the image), doubleSided → [`BsdfKind::TwoSided`] (transmissive models are two-sided by
//! nature and are not wrapped), alpha MASK → [`BsdfKind::Mask`] with glTF's cutoff, BLEND →
//! [`BsdfKind::Mask`] with opacity = alpha. Emission: emissiveFactor × KHR_materials_emissive_
//! strength → `Material::emission`, emissiveTexture → `Material::emission_texture`.
//! occlusionTexture is not read: a path tracer computes occlusion itself.
//!
//! **Whitted mode.** Base colour factor → colour, base colour texture → texture; roughness r →
//! shininess 2/r⁴ − 2 (the Blinn-Phong exponent matching GGX's α = r², clamped to [1, 2000])
//! and specular weight 1 − r; metallic m → diffuse weight (1 − 0.9 m); an opaque material
//! reflects by Schlick with f0 = lerp(0.04, base colour, m)·(1 − r) (sharp reflections fade as
//! the surface roughens); transmission t → transparency t·(1 − m) with the ior; BLEND →
//! transparency 1 − alpha without bending (ior 1); MASK with a constant alpha below the
//! cutoff → fully transparent. Per-texel alpha is the path mode's alone.
//!
//! Every texture reference honours KHR_texture_transform (offset, rotation, scale, texCoord)
//! and its sampler's wrap modes and magnification filter ([`Sampler`]); glint reads one
//! texture coordinate set per material (the base colour's, or its first texture's).

use super::buffers::{RawImage, read_image};
use crate::error::FormatError;
use crate::model::file_name;
use glint_core::colour::srgb_to_linear;
use glint_core::glam::Affine2;
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::{BsdfId, BsdfKind, Filter, Material, Principled, Sampler, Tex, Texture, TextureImage, Wrap};
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;

/// The file's materials, the models and textures they use.
pub(super) struct Materials {
    pub materials: Vec<Material>,
    pub bsdfs: Vec<BsdfKind>,
    pub textures: Vec<Texture>,
    /// The texture coordinate set (TEXCOORD_n) each material's textures read.
    pub uv_sets: Vec<u32>,
}

pub(super) fn read_materials(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    warnings: &mut Vec<String>,
) -> Result<Materials, FormatError> {
    let mut reader = TextureReader {
        path,
        base,
        buffers,
        images: HashMap::new(),
        derived: HashMap::new(),
        textures: Vec::new(),
        warnings,
    };
    let mut out = Materials { materials: Vec::new(), bsdfs: Vec::new(), textures: Vec::new(), uv_sets: Vec::new() };
    for m in document.materials() {
        let index = m.index().unwrap_or(out.materials.len());
        let (material, uv_set) = convert(&mut reader, &mut out.bsdfs, index, &m)?;
        out.materials.push(material);
        out.uv_sets.push(uv_set);
    }
    out.textures = reader.textures;
    Ok(out)
}

/// One texture reference of a material (a glTF textureInfo).
struct TexRef<'a> {
    texture: gltf::Texture<'a>,
    tex_coord: u32,
    /// KHR_texture_transform: offset, rotation (radians), scale, in glTF's uv space.
    transform: Option<([f32; 2], f32, [f32; 2])>,
    /// Where it is, for messages: "materials[2].normalTexture".
    place: String,
}

impl<'a> TexRef<'a> {
    fn from_info(info: gltf::texture::Info<'a>, place: String) -> Self {
        let t = info.texture_transform();
        TexRef {
            texture: info.texture(),
            tex_coord: t.as_ref().and_then(|t| t.tex_coord()).unwrap_or(info.tex_coord()),
            transform: t.map(|t| (t.offset(), t.rotation(), t.scale())),
            place,
        }
    }

    /// A normal or occlusion texture, whose KHR_texture_transform the `gltf` crate leaves as
    /// JSON.
    fn from_json(
        path: &Path,
        texture: gltf::Texture<'a>,
        tex_coord: u32,
        transform: Option<&gltf::json::Value>,
        place: String,
    ) -> Result<Self, FormatError> {
        let Some(t) = transform else { return Ok(TexRef { texture, tex_coord, transform: None, place }) };
        let bad = |what: &str| FormatError::malformed(path, format!("{place}.KHR_texture_transform"), what.to_string());
        let pair = |key: &str, default: [f32; 2]| -> Result<[f32; 2], FormatError> {
            match t.get(key) {
                None => Ok(default),
                Some(v) => match v.as_array().map(|a| a.iter().map(gltf::json::Value::as_f64).collect::<Vec<_>>()) {
                    Some(a) if a.len() == 2 && a.iter().all(Option::is_some) => {
                        Ok([a[0].unwrap_or(0.0) as f32, a[1].unwrap_or(0.0) as f32])
                    }
                    _ => Err(bad(&format!("`{key}` must be two numbers"))),
                },
            }
        };
        let offset = pair("offset", [0.0, 0.0])?;
        let scale = pair("scale", [1.0, 1.0])?;
        let rotation = match t.get("rotation") {
            None => 0.0,
            Some(v) => v.as_f64().ok_or_else(|| bad("`rotation` must be a number"))? as f32,
        };
        let tex_coord = match t.get("texCoord") {
            None => tex_coord,
            Some(v) => v
                .as_u64()
                .and_then(|v| u32::try_from(v).ok())
                .ok_or_else(|| bad("`texCoord` must be a non-negative integer"))?,
        };
        Ok(TexRef { texture, tex_coord, transform: Some((offset, rotation, scale)), place })
    }
}

/// How a glint texture's texels are made from its image's.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum Texels {
    /// RGB, sRGB-decoded, times a factor (f32 bits): base colour, emission.
    Colour([u32; 3]),
    /// One linear channel (0 = R … 3 = A) times a factor, in all three channels: a scalar
    /// texture, which glint reads as luminance.
    Channel(u8, u32),
    /// A tangent-space normal map with x and y scaled by a factor and renormalised.
    Normal(u32),
}

impl Texels {
    fn colour(factor: Rgb) -> Self {
        Texels::Colour(factor.to_array().map(f32::to_bits))
    }

    fn channel(channel: u8, factor: f32) -> Self {
        Texels::Channel(channel, factor.to_bits())
    }

    fn texel(self, t: [f32; 4]) -> Rgb {
        match self {
            Texels::Colour(f) => Rgb::new(
                srgb_to_linear(t[0]) * f32::from_bits(f[0]),
                srgb_to_linear(t[1]) * f32::from_bits(f[1]),
                srgb_to_linear(t[2]) * f32::from_bits(f[2]),
            ),
            Texels::Channel(c, f) => Rgb::splat(t[c as usize] * f32::from_bits(f)),
            Texels::Normal(s) => {
                let s = f32::from_bits(s);
                let n = (Vec3::new(t[0], t[1], t[2]) * 2.0 - Vec3::ONE) * Vec3::new(s, s, 1.0);
                (n.normalize_or(Vec3::Z) + Vec3::ONE) * 0.5
            }
        }
    }
}

/// Reads images once, derives each texel variant once, and makes one glint texture per
/// (texels, sampler) pair.
struct TextureReader<'a> {
    path: &'a Path,
    base: &'a Path,
    buffers: &'a [Vec<u8>],
    images: HashMap<usize, Option<Arc<RawImage>>>,
    derived: HashMap<(usize, Texels), Arc<TextureImage>>,
    textures: Vec<Texture>,
    warnings: &'a mut Vec<String>,
}

impl TextureReader<'_> {
    /// The glint texture for `r` with `texels`; `None` when its image file is missing (warned).
    fn texture(&mut self, r: &TexRef, texels: Texels) -> Result<Option<usize>, FormatError> {
        let image = r.texture.source();
        let index = image.index();
        let raw = match self.images.get(&index) {
            Some(raw) => raw.clone(),
            None => {
                let raw = read_image(self.path, self.base, &image, self.buffers, self.warnings)?.map(Arc::new);
                self.images.insert(index, raw.clone());
                raw
            }
        };
        let Some(raw) = raw else { return Ok(None) };
        let derived = self
            .derived
            .entry((index, texels))
            .or_insert_with(|| {
                Arc::new(TextureImage {
                    width: raw.width,
                    height: raw.height,
                    texels: raw.texels.iter().map(|&t| texels.texel(t)).collect(),
                })
            })
            .clone();
        let sampler = sampler(self.path, r)?;
        let existing = self.textures.iter().position(
            |t| matches!(t, Texture::Image { image, sampler: s, .. } if Arc::ptr_eq(image, &derived) && *s == sampler),
        );
        Ok(Some(existing.unwrap_or_else(|| {
            self.textures.push(Texture::Image { image: derived, scale: Vec2::ONE, sampler });
            self.textures.len() - 1
        })))
    }
}

/// The sampler of a texture reference: its KHR_texture_transform in glint's uv convention
/// (glint's v is glTF's 1 − v, so the transform is conjugated by that flip), its wraps and its
/// magnification filter (mipmapped minification is read as the base level).
fn sampler(path: &Path, r: &TexRef) -> Result<Sampler, FormatError> {
    let texture_from_surface = match r.transform {
        None => Affine2::IDENTITY,
        Some((offset, rotation, scale)) => {
            let (offset, scale) = (Vec2::from_array(offset), Vec2::from_array(scale));
            if !(offset.is_finite() && scale.is_finite() && rotation.is_finite()) {
                return Err(FormatError::malformed(
                    path,
                    format!("{}.KHR_texture_transform", r.place),
                    "offset, rotation and scale must be finite numbers",
                ));
            }
            // KHR_texture_transform: uv' = T(offset) · R(rotation) · S(scale) · uv.
            let gltf = Affine2::from_scale_angle_translation(scale, rotation, offset);
            let flip = Affine2::from_cols(Vec2::X, -Vec2::Y, Vec2::Y);
            flip * gltf * flip
        }
    };
    let s = r.texture.sampler();
    let wrap = |w| match w {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
    };
    let filter = match s.mag_filter() {
        Some(gltf::texture::MagFilter::Nearest) => Filter::Nearest,
        _ => Filter::Bilinear,
    };
    Ok(Sampler { texture_from_surface, wrap_u: wrap(s.wrap_s()), wrap_v: wrap(s.wrap_t()), filter })
}

fn push(bsdfs: &mut Vec<BsdfKind>, b: BsdfKind) -> BsdfId {
    bsdfs.push(b);
    bsdfs.len() - 1
}

/// A number of the file that must be finite (JSON cannot say NaN, but 1e39 is ∞ as f32).
fn finite(path: &Path, place: &str, what: &str, values: &[f32]) -> Result<(), FormatError> {
    if values.iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(FormatError::malformed(path, place, format!("{what} is not a finite number")))
    }
}

/// Principled's `specular` for an index of refraction (its inverse: eta = 2/(1 − √(0.08 s)) − 1).
fn specular_for_eta(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).powi(2) / 0.08
}

/// One glTF material: the glint material (its `bsdf` pushed onto `bsdfs`) and the texture
/// coordinate set it reads.
fn convert(
    reader: &mut TextureReader,
    bsdfs: &mut Vec<BsdfKind>,
    index: usize,
    m: &gltf::Material,
) -> Result<(Material, u32), FormatError> {
    let path = reader.path;
    let place = format!("materials[{index}]");
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, alpha] = pbr.base_color_factor();
    finite(path, &place, "baseColorFactor", &[r, g, b, alpha])?;
    finite(path, &place, "metallicFactor or roughnessFactor", &[pbr.metallic_factor(), pbr.roughness_factor()])?;
    let base_colour = Rgb::new(r, g, b).max(Rgb::ZERO);
    let alpha = alpha.clamp(0.0, 1.0);
    let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
    let roughness = pbr.roughness_factor().clamp(0.0, 1.0);

    fn tex<'a>(info: Option<gltf::texture::Info<'a>>, place: &str, name: &str) -> Option<TexRef<'a>> {
        info.map(|i| TexRef::from_info(i, format!("{place}.{name}")))
    }
    let base_ref = tex(pbr.base_color_texture(), &place, "pbrMetallicRoughness.baseColorTexture");
    let mr_ref = tex(pbr.metallic_roughness_texture(), &place, "pbrMetallicRoughness.metallicRoughnessTexture");
    let emissive_ref = tex(m.emissive_texture(), &place, "emissiveTexture");
    let transmission = m.transmission();
    let transmission_ref =
        tex(transmission.as_ref().and_then(|t| t.transmission_texture()), &place, "transmissionTexture");
    let normal_ref = match m.normal_texture() {
        Some(n) => Some((
            n.scale(),
            TexRef::from_json(
                path,
                n.texture(),
                n.tex_coord(),
                n.extension_value("KHR_texture_transform"),
                format!("{place}.normalTexture"),
            )?,
        )),
        None => None,
    };

    // One texture coordinate set per material: the base colour's, else the first texture's.
    let refs: Vec<&TexRef> = [&base_ref, &mr_ref, &emissive_ref, &transmission_ref]
        .into_iter()
        .flatten()
        .chain(normal_ref.as_ref().map(|(_, r)| r))
        .collect();
    let uv_set = refs.first().map_or(0, |r| r.tex_coord);
    if let Some(other) = refs.iter().find(|r| r.tex_coord != uv_set) {
        reader.warnings.push(format!(
            "{}: {} reads TEXCOORD_{} but the material's other textures TEXCOORD_{uv_set}; glint reads one set \
             per material, TEXCOORD_{uv_set}",
            file_name(path),
            other.place,
            other.tex_coord
        ));
    }

    let mut material = Material {
        name: m.name().map_or_else(|| format!("material {index}"), str::to_string),
        colour: base_colour,
        // glTF's doubleSided: both faces are seen (and emit).
        two_sided: m.double_sided(),
        ..Material::default()
    };

    // Base colour: the Whitted mode multiplies the factor itself; the model gets it baked in.
    let mut base_color = Tex::Value(base_colour);
    if let Some(r) = &base_ref {
        material.texture = reader.texture(r, Texels::colour(Rgb::ONE))?;
        if material.texture.is_some() {
            let baked = if base_colour == Rgb::ONE {
                material.texture
            } else {
                reader.texture(r, Texels::colour(base_colour))?
            };
            base_color = baked.map_or(base_color, Tex::Texture);
        }
    }
    let scalar = |reader: &mut TextureReader, r: &Option<TexRef>, channel: u8, factor: f32| match r {
        Some(r) => {
            reader.texture(r, Texels::channel(channel, factor)).map(|t| t.map_or(Tex::Value(factor), Tex::Texture))
        }
        None => Ok(Tex::Value(factor)),
    };
    let metallic_tex = scalar(reader, &mr_ref, 2, metallic)?;
    let roughness_tex = scalar(reader, &mr_ref, 1, roughness)?;

    let transmission_factor = transmission.as_ref().map_or(0.0, |t| t.transmission_factor());
    finite(path, &place, "transmissionFactor", &[transmission_factor])?;
    let transmission_factor = transmission_factor.clamp(0.0, 1.0);
    let spec_trans = scalar(reader, &transmission_ref, 0, transmission_factor)?;
    let transmissive = transmission_factor > 0.0;
    let ior = m.ior().unwrap_or(1.5);
    if !(ior.is_finite() && ior >= 1.0) {
        return Err(FormatError::malformed(
            path,
            format!("{place}.KHR_materials_ior"),
            format!("ior {ior} must be >= 1"),
        ));
    }
    let thick = m.volume().is_some_and(|v| v.thickness_factor() > 0.0);

    let principled = |thin: bool, metallic: Tex<f32>, spec_trans: Tex<f32>| {
        BsdfKind::Principled(Box::new(Principled {
            thin,
            base_color,
            roughness: roughness_tex,
            anisotropic: Tex::Value(0.0),
            metallic,
            spec_trans,
            specular: specular_for_eta(ior),
            spec_tint: Tex::Value(0.0),
            sheen: Tex::Value(0.0),
            sheen_tint: Tex::Value(0.0),
            flatness: Tex::Value(0.0),
            clearcoat: Tex::Value(0.0),
            clearcoat_gloss: Tex::Value(0.0),
            diff_trans: Tex::Value(0.0),
            eta: Some(ior),
        }))
    };
    let mut top = if transmissive && !thick {
        // principledthin has no metallic: blend the thin dielectric with a metal by metallic.
        let thin = push(bsdfs, principled(true, Tex::Value(0.0), spec_trans));
        if metallic_tex == Tex::Value(0.0) {
            thin
        } else {
            let metal = push(bsdfs, principled(false, Tex::Value(1.0), Tex::Value(0.0)));
            push(bsdfs, BsdfKind::Blend { weight: metallic_tex, a: thin, b: metal })
        }
    } else {
        push(bsdfs, principled(false, metallic_tex, spec_trans))
    };
    if let Some((scale, r)) = &normal_ref {
        finite(path, &r.place, "scale", &[*scale])?;
        if let Some(normals) = reader.texture(r, Texels::Normal(scale.to_bits()))? {
            top = push(bsdfs, BsdfKind::NormalMap { normals, inner: top });
        }
    }
    if m.double_sided() && !transmissive {
        top = push(bsdfs, BsdfKind::TwoSided { front: top, back: top });
    }

    // Alpha: the base colour texture's alpha times the factor's.
    let alpha_tex = match &base_ref {
        Some(r) => reader.texture(r, Texels::channel(3, alpha))?.map_or(Tex::Value(alpha), Tex::Texture),
        None => Tex::Value(alpha),
    };
    let cutoff = m.alpha_cutoff().unwrap_or(0.5);
    finite(path, &place, "alphaCutoff", &[cutoff])?;
    match m.alpha_mode() {
        gltf::material::AlphaMode::Opaque => {}
        gltf::material::AlphaMode::Mask => {
            if !(alpha_tex == Tex::Value(alpha) && alpha >= cutoff) {
                top = push(
                    bsdfs,
                    BsdfKind::Mask { opacity: alpha_tex, inner: top, cutoff: Some(cutoff.clamp(0.0, 1.0)) },
                );
            }
            if alpha_tex == Tex::Value(alpha) && alpha < cutoff {
                material.transparency = 1.0;
                material.ior = 1.0;
                material.specular = 0.0;
            }
        }
        gltf::material::AlphaMode::Blend => {
            if alpha_tex != Tex::Value(1.0) {
                top = push(bsdfs, BsdfKind::Mask { opacity: alpha_tex, inner: top, cutoff: None });
            }
            material.transparency = 1.0 - alpha;
            material.ior = 1.0;
        }
    }
    material.bsdf = Some(top);

    // Emission.
    let strength = m.emissive_strength().unwrap_or(1.0);
    let emissive = m.emissive_factor();
    finite(
        path,
        &place,
        "emissiveFactor or KHR_materials_emissive_strength",
        &[emissive[0], emissive[1], emissive[2], strength],
    )?;
    material.emission = (Rgb::from_array(emissive) * strength).max(Rgb::ZERO);
    if let Some(r) = &emissive_ref
        && material.emission != Rgb::ZERO
    {
        material.emission_texture = reader.texture(r, Texels::colour(Rgb::ONE))?;
    }

    // The Whitted mode's Phong parameters.
    material.diffuse = (1.0 - 0.9 * metallic) * (1.0 - transmission_factor);
    if material.transparency == 0.0 || m.alpha_mode() == gltf::material::AlphaMode::Blend {
        material.specular = 1.0 - roughness;
    }
    material.shininess = (2.0 / roughness.powi(4).max(1e-3) - 2.0).clamp(1.0, 2000.0);
    if transmissive {
        material.transparency = material.transparency.max(transmission_factor * (1.0 - metallic));
        material.ior = ior.min(10.0);
    }
    if material.transparency == 0.0 {
        let f0 = Rgb::splat(0.04).lerp(base_colour.min(Rgb::ONE), metallic) * (1.0 - roughness);
        material.reflection_f0 = Some(f0);
    }
    Ok((material, uv_set))
}
