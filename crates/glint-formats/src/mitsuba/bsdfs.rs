//! BSDF plugins → [`BsdfKind`] with Mitsuba 3's defaults (src/bsdfs/*.cpp,
//! include/mitsuba/render/microfacet.h, ior.h), and the nearest Phong parameters of each for
//! the Whitted mode ([`phong`]). Nested and referenced BSDFs become their own entries of
//! `Scene::bsdfs`; a referenced one is converted once.

use super::Builder;
use super::props::{Props, Value};
use super::spectrum::{Use, to_rgb};
use super::xml::Element;
use crate::error::FormatError;
use glint_core::Rgb;
use glint_scene::presets;
use glint_scene::{BsdfKind, Distribution, Material, Principled, Roughness, Scene, Tex};

fn rgb(c: [f64; 3]) -> Rgb {
    Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32)
}

impl<'a> Builder<'a> {
    /// The index of a BSDF element in `Scene::bsdfs` (converted on first use).
    pub(super) fn bsdf(&mut self, el: &'a Element) -> Result<usize, FormatError> {
        let k = super::key(el);
        if let Some(&i) = self.bsdf_cache.get(&k) {
            return Ok(i);
        }
        if self.bsdf_busy.contains(&k) {
            return Err(el.loc.error(format!("{} contains itself (through a <ref>)", el.describe())));
        }
        self.bsdf_busy.push(k);
        let kind = self.bsdf_kind(el);
        self.bsdf_busy.pop();
        self.scene.bsdfs.push(kind?);
        let i = self.scene.bsdfs.len() - 1;
        self.bsdf_cache.insert(k, i);
        Ok(i)
    }

    fn bsdf_kind(&mut self, el: &'a Element) -> Result<BsdfKind, FormatError> {
        let p = self.props(el)?;
        p.ignore(&["id"]);
        let kind = match p.plugin {
            "diffuse" => BsdfKind::Diffuse { reflectance: self.rgb_tex(&p, "reflectance", 0.5, Use::Bounded)? },
            "conductor" | "roughconductor" => {
                let (eta, k) = self.conductor_ior(&p)?;
                let specular_reflectance = self.rgb_tex(&p, "specular_reflectance", 1.0, Use::Bounded)?;
                if p.plugin == "conductor" {
                    BsdfKind::Conductor { eta, k, specular_reflectance }
                } else {
                    let roughness = self.roughness(&p, true)?;
                    BsdfKind::RoughConductor { roughness, eta, k, specular_reflectance }
                }
            }
            "dielectric" | "thindielectric" | "roughdielectric" => {
                let eta = self.eta(&p, "bk7")?;
                let specular_reflectance = self.rgb_tex(&p, "specular_reflectance", 1.0, Use::Bounded)?;
                let specular_transmittance = self.rgb_tex(&p, "specular_transmittance", 1.0, Use::Bounded)?;
                match p.plugin {
                    "dielectric" => BsdfKind::Dielectric { eta, specular_reflectance, specular_transmittance },
                    "thindielectric" => BsdfKind::ThinDielectric { eta, specular_reflectance, specular_transmittance },
                    _ => {
                        if eta == 1.0 {
                            return Err(el.loc.error("roughdielectric: int_ior and ext_ior must differ"));
                        }
                        let roughness = self.roughness(&p, true)?;
                        BsdfKind::RoughDielectric { roughness, eta, specular_reflectance, specular_transmittance }
                    }
                }
            }
            "plastic" | "roughplastic" => {
                let eta = self.eta(&p, "polypropylene")?;
                let diffuse_reflectance = self.rgb_tex(&p, "diffuse_reflectance", 0.5, Use::Bounded)?;
                let specular_reflectance = self.rgb_tex(&p, "specular_reflectance", 1.0, Use::Bounded)?;
                let nonlinear = p.boolean("nonlinear", false)?;
                if p.plugin == "plastic" {
                    BsdfKind::Plastic { diffuse_reflectance, specular_reflectance, eta, nonlinear }
                } else {
                    let roughness = self.roughness(&p, false)?;
                    BsdfKind::RoughPlastic { roughness, diffuse_reflectance, specular_reflectance, eta, nonlinear }
                }
            }
            "twosided" => {
                let inner = p.objects("bsdf");
                match inner.as_slice() {
                    [(_, a)] => {
                        let a = self.bsdf(a)?;
                        BsdfKind::TwoSided { front: a, back: a }
                    }
                    [(_, a), (_, b)] => BsdfKind::TwoSided { front: self.bsdf(a)?, back: self.bsdf(b)? },
                    _ => return Err(el.loc.error("twosided needs one or two nested BSDFs")),
                }
            }
            "mask" => {
                let opacity = self.float_tex(&p, "opacity", 0.5)?;
                BsdfKind::Mask { opacity, inner: self.one_inner(&p)?, cutoff: None }
            }
            "bumpmap" => {
                let scale = p.float("scale", 1.0)? as f32;
                let textures = p.objects("texture");
                let [(_, t)] = textures.as_slice() else {
                    return Err(el.loc.error("bumpmap needs one nested height texture"));
                };
                let height = self.uv_texture(t, "bumpmap")?;
                BsdfKind::BumpMap { height, scale, inner: self.one_inner(&p)? }
            }
            "normalmap" => {
                let textures = p.objects("texture");
                let [(_, t)] = textures.as_slice() else {
                    return Err(el.loc.error("normalmap needs one nested normal texture"));
                };
                let normals = self.uv_texture(t, "normalmap")?;
                BsdfKind::NormalMap { normals, inner: self.one_inner(&p)? }
            }
            "blendbsdf" => {
                let weight = self.float_tex(&p, "weight", 0.5)?;
                let inner = p.objects("bsdf");
                let [(_, a), (_, b)] = inner.as_slice() else {
                    return Err(el.loc.error("blendbsdf needs two nested BSDFs"));
                };
                BsdfKind::Blend { weight, a: self.bsdf(a)?, b: self.bsdf(b)? }
            }
            "principled" | "principledthin" => {
                let thin = p.plugin == "principledthin";
                let f = |s: &mut Self, name: &str, default: f64| s.float_tex(&p, name, default);
                let principled = Principled {
                    thin,
                    base_color: self.rgb_tex(&p, "base_color", 0.5, Use::Bounded)?,
                    roughness: f(self, "roughness", 0.5)?,
                    anisotropic: f(self, "anisotropic", 0.0)?,
                    metallic: if thin { Tex::Value(0.0) } else { f(self, "metallic", 0.0)? },
                    spec_trans: f(self, "spec_trans", 0.0)?,
                    specular: p.float("specular", 0.5)? as f32,
                    spec_tint: f(self, "spec_tint", 0.0)?,
                    sheen: f(self, "sheen", 0.0)?,
                    sheen_tint: f(self, "sheen_tint", 0.0)?,
                    flatness: f(self, "flatness", 0.0)?,
                    clearcoat: if thin { Tex::Value(0.0) } else { f(self, "clearcoat", 0.0)? },
                    clearcoat_gloss: if thin { Tex::Value(0.0) } else { f(self, "clearcoat_gloss", 0.0)? },
                    diff_trans: if thin { f(self, "diff_trans", 0.0)? } else { Tex::Value(0.0) },
                    eta: p.float_opt("eta")?.map(|e| e as f32),
                };
                p.ignore(&[
                    "main_specular_sampling_rate",
                    "clearcoat_sampling_rate",
                    "diffuse_reflectance_sampling_rate",
                    "spec_srate",
                    "clearcoat_srate",
                    "diff_trans_srate",
                ]);
                BsdfKind::Principled(Box::new(principled))
            }
            other => {
                self.unsupported(&el.loc, format!("BSDF '{other}' is not supported: a diffuse 0.5 is used"))?;
                return Ok(BsdfKind::Diffuse { reflectance: Tex::Value(Rgb::splat(0.5)) });
            }
        };
        self.finish(&p)?;
        Ok(kind)
    }

    fn one_inner(&mut self, p: &Props<'a>) -> Result<usize, FormatError> {
        let inner = p.objects("bsdf");
        let [(_, b)] = inner.as_slice() else {
            return Err(p.loc().error(format!("{} needs one nested BSDF", p.el.describe())));
        };
        self.bsdf(b)
    }

    /// A colour parameter: a value, or a texture (nested or `<ref name=…>`).
    pub(super) fn rgb_tex(
        &mut self,
        p: &Props<'a>,
        name: &str,
        default: f64,
        usage: Use,
    ) -> Result<Tex<Rgb>, FormatError> {
        let Some(prop) = p.get(name) else { return Ok(Tex::Value(Rgb::splat(default as f32))) };
        if let Value::Object(t) = prop.value {
            if t.tag != "texture" {
                return Err(prop.at.loc.error(format!("'{name}' is {}, expected a colour or texture", t.describe())));
            }
            return Ok(Tex::Texture(self.texture(t)?));
        }
        to_rgb(&prop.value, usage).map(|c| Tex::Value(rgb(c))).ok_or_else(|| {
            prop.at.loc.error(format!("'{name}' of {} must be a colour, float or texture", p.el.describe()))
        })
    }

    /// A scalar parameter: a number (an RGB value counts by its luminance), or a texture.
    pub(super) fn float_tex(&mut self, p: &Props<'a>, name: &str, default: f64) -> Result<Tex<f32>, FormatError> {
        match self.rgb_tex(p, name, default, Use::Unbounded)? {
            Tex::Texture(i) => Ok(Tex::Texture(self.float_twins.get(&i).copied().unwrap_or(i))),
            Tex::Value(c) => Ok(Tex::Value(c.x * 0.212_671 + c.y * 0.715_160 + c.z * 0.072_169)),
        }
    }

    /// `int_ior / ext_ior`, each a number or a name from Mitsuba's table.
    fn eta(&mut self, p: &Props<'a>, int_default: &str) -> Result<f32, FormatError> {
        let int = ior(p, "int_ior", int_default)?;
        let ext = ior(p, "ext_ior", "air")?;
        if !(int > 0.0 && ext > 0.0) {
            return Err(p.loc().error("int_ior and ext_ior must be positive"));
        }
        Ok((int / ext) as f32)
    }

    /// A conductor's eta and k: given (default 0 and 1, a perfect mirror) or a `material`.
    fn conductor_ior(&mut self, p: &Props<'a>) -> Result<(Rgb, Rgb), FormatError> {
        let material = p.string("material")?.unwrap_or("none");
        if p.has("eta") || material == "none" {
            if material != "none" {
                return Err(p.loc().error("give either eta and k or a material, not both"));
            }
            let value = |s: &mut Self, name: &str, d: f64| match s.rgb_tex(p, name, d, Use::Unbounded)? {
                Tex::Value(c) => Ok(c),
                Tex::Texture(_) => {
                    Err(p.loc().error(format!("a textured conductor '{name}' is not supported by glint")))
                }
            };
            return Ok((value(self, "eta", 0.0)?, value(self, "k", 1.0)?));
        }
        let Some((eta, k)) = presets::conductor_preset(material) else {
            let names: Vec<&str> = presets::conductor_names().collect();
            return Err(p
                .loc()
                .error(format!("unknown conductor material '{material}' (known: {})", names.join(", "))));
        };
        Ok((eta, k))
    }

    /// Mitsuba's microfacet parameters: `distribution` (default beckmann), `alpha` (0.1) or
    /// `alpha_u` and `alpha_v`, `sample_visible` (true).
    fn roughness(&mut self, p: &Props<'a>, anisotropic_ok: bool) -> Result<Roughness, FormatError> {
        let distribution = match p.string("distribution")?.map(str::to_ascii_lowercase).as_deref() {
            None | Some("beckmann") => Distribution::Beckmann,
            Some("ggx") => Distribution::Ggx,
            Some(other) => return Err(p.loc().error(format!("distribution '{other}' is neither beckmann nor ggx"))),
        };
        let (alpha_u, alpha_v) = if p.has("alpha_u") || p.has("alpha_v") {
            if !(p.has("alpha_u") && p.has("alpha_v")) || p.has("alpha") {
                return Err(p.loc().error("give alpha, or both alpha_u and alpha_v"));
            }
            if !anisotropic_ok {
                return Err(p.loc().error(format!("{} does not support anisotropic roughness", p.el.describe())));
            }
            (self.float_tex(p, "alpha_u", 0.1)?, self.float_tex(p, "alpha_v", 0.1)?)
        } else {
            let a = self.float_tex(p, "alpha", 0.1)?;
            (a, a)
        };
        let sample_visible = p.boolean("sample_visible", true)?;
        Ok(Roughness { distribution, alpha_u, alpha_v, sample_visible })
    }
}

/// An index of refraction: a number, or a name from Mitsuba's table.
fn ior(p: &Props, name: &str, default: &str) -> Result<f64, FormatError> {
    let Some(prop) = p.get(name) else { return named_ior(p, default) };
    match prop.value {
        Value::Float(v) => Ok(v),
        Value::Int(v) => Ok(v as f64),
        Value::Str(s) => named_ior(p, s),
        _ => Err(prop.at.loc.error(format!("'{name}' must be a number or a material name"))),
    }
}

fn named_ior(p: &Props, name: &str) -> Result<f64, FormatError> {
    let lower = name.to_ascii_lowercase();
    presets::ior_preset(&lower).map(f64::from).ok_or_else(|| {
        let names: Vec<&str> = presets::ior_names().collect();
        p.loc().error(format!("unknown index of refraction '{name}' (known: {})", names.join(", ")))
    })
}

/// Normal-incidence Fresnel reflectance of a conductor.
fn conductor_f0(eta: Rgb, k: Rgb) -> Rgb {
    let one = Rgb::ONE;
    let num = (eta - one) * (eta - one) + k * k;
    let den = (eta + one) * (eta + one) + k * k;
    (num / den.max(Rgb::splat(1e-6))).clamp(Rgb::ZERO, one)
}

/// A Phong exponent with a highlight as wide as a Beckmann lobe of roughness α.
fn shininess(alpha: &Tex<f32>) -> f32 {
    let a = match *alpha {
        Tex::Value(a) => a.max(1e-3),
        Tex::Texture(_) => 0.1,
    };
    (2.0 / (a * a) - 2.0).clamp(1.0, 10_000.0)
}

fn colour(t: &Tex<Rgb>) -> Rgb {
    match *t {
        Tex::Value(c) => c,
        Tex::Texture(_) => Rgb::ONE,
    }
}

/// The closest Phong parameters to a BSDF, for the Whitted mode (path mode reads the BSDF).
pub(super) fn phong(scene: &Scene, bsdf: usize) -> Material {
    let mut m = Material { ambient: 0.0, diffuse: 1.0, specular: 0.0, ..Material::default() };
    let texture = |t: &Tex<Rgb>| if let Tex::Texture(i) = *t { Some(i) } else { None };
    let mut depth = 0;
    let mut b = bsdf;
    // Wrappers: follow the (first) inner model.
    while depth < 32 {
        depth += 1;
        match &scene.bsdfs[b] {
            BsdfKind::TwoSided { front, .. } => b = *front,
            BsdfKind::Mask { inner, .. } | BsdfKind::BumpMap { inner, .. } | BsdfKind::NormalMap { inner, .. } => {
                b = *inner
            }
            BsdfKind::Blend { weight, a, b: second } => {
                b = if matches!(weight, Tex::Value(w) if *w < 0.5) { *a } else { *second }
            }
            _ => break,
        }
    }
    let dielectric_f0 = |eta: f32| {
        let r = (eta - 1.0) / (eta + 1.0);
        Rgb::splat(r * r)
    };
    match &scene.bsdfs[b] {
        BsdfKind::Diffuse { reflectance } => {
            m.colour = colour(reflectance);
            m.texture = texture(reflectance);
        }
        BsdfKind::Conductor { eta, k, specular_reflectance } => {
            let f0 = (conductor_f0(*eta, *k) * colour(specular_reflectance)).clamp(Rgb::ZERO, Rgb::ONE);
            m.colour = f0;
            m.diffuse = 0.0;
            m.reflection_f0 = Some(f0);
        }
        BsdfKind::RoughConductor { roughness, eta, k, specular_reflectance } => {
            m.colour = (conductor_f0(*eta, *k) * colour(specular_reflectance)).clamp(Rgb::ZERO, Rgb::ONE);
            m.diffuse = 0.2;
            m.specular = 1.0;
            m.shininess = shininess(&roughness.alpha_u);
        }
        BsdfKind::Dielectric { eta, .. }
        | BsdfKind::ThinDielectric { eta, .. }
        | BsdfKind::RoughDielectric { eta, .. } => {
            m.colour = Rgb::ONE;
            m.diffuse = 0.0;
            m.transparency = 1.0;
            m.ior = if matches!(scene.bsdfs[b], BsdfKind::ThinDielectric { .. }) {
                1.0
            } else {
                eta.max(1.0 / eta).clamp(1.0, 10.0)
            };
            if let BsdfKind::RoughDielectric { roughness, .. } = &scene.bsdfs[b] {
                m.specular = 1.0;
                m.shininess = shininess(&roughness.alpha_u);
            }
        }
        BsdfKind::Plastic { diffuse_reflectance, eta, .. } => {
            m.colour = colour(diffuse_reflectance);
            m.texture = texture(diffuse_reflectance);
            m.reflection_f0 = Some(dielectric_f0(*eta));
        }
        BsdfKind::RoughPlastic { roughness, diffuse_reflectance, .. } => {
            m.colour = colour(diffuse_reflectance);
            m.texture = texture(diffuse_reflectance);
            m.specular = 0.5;
            m.shininess = shininess(&roughness.alpha_u);
        }
        BsdfKind::Principled(p) => {
            m.colour = colour(&p.base_color);
            m.texture = texture(&p.base_color);
            m.specular = 0.5;
            let r = match p.roughness {
                Tex::Value(r) => r,
                Tex::Texture(_) => 0.5,
            };
            m.shininess = shininess(&Tex::Value(r * r));
            if matches!(p.spec_trans, Tex::Value(t) if t > 0.5) {
                m.transparency = 1.0;
                m.diffuse = 0.0;
                m.ior = p.eta.unwrap_or(1.5).clamp(1.0, 10.0);
            }
        }
        // Wrappers deeper than the walk above: a neutral grey.
        _ => m.colour = Rgb::splat(0.5),
    }
    m
}
