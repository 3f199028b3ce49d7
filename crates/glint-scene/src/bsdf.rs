//! Physically based surface models (pipeline: files → **Scene** → integrators): the BSDFs of
//! Mitsuba 3's plugins and glTF's metallic-roughness model as plain data, a closed set of kinds
//! with parameter structs (no trait objects), so a batched integrator can shade each kind
//! across lanes. A [`Material`](crate::Material) whose `bsdf` names one of these is shaded by
//! it in path mode; without one, the path mode reads the material's Phong parameters as before
//! (DESIGN.md §2), and the Whitted mode always reads Phong parameters (loaders set the closest
//! ones).
//!
//! Conventions (Mitsuba 3's): `eta` is the interior index over the exterior one; a conductor's
//! `eta` and `k` are per RGB channel, relative to the exterior; roughness `alpha` is the
//! microfacet distribution's α (not perceptual roughness); reflectance factors multiply the
//! Fresnel terms. Textured values read the texture at the hit's uv (float values: its
//! luminance, as Mitsuba's `eval_1` of an RGB bitmap).

use glint_core::Rgb;

/// Index into [`crate::Scene::bsdfs`].
pub type BsdfId = usize;

/// A value that a texture may vary over the surface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tex<T> {
    Value(T),
    /// Index into [`crate::Scene::textures`].
    Texture(usize),
}

impl<T: Default> Default for Tex<T> {
    fn default() -> Self {
        Tex::Value(T::default())
    }
}

/// Microfacet normal distribution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Distribution {
    Beckmann,
    /// Trowbridge–Reitz (GGX).
    Ggx,
}

/// A microfacet distribution and its roughness along the tangent (u) and bitangent (v).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Roughness {
    pub distribution: Distribution,
    pub alpha_u: Tex<f32>,
    pub alpha_v: Tex<f32>,
    /// Sample the distribution of visible normals (Heitz and d'Eon 2014) rather than of all
    /// normals (Mitsuba's default: true).
    pub sample_visible: bool,
}

/// A scattering model.
#[derive(Clone, Debug, PartialEq)]
pub enum BsdfKind {
    /// Lambertian: `ρ/π`.
    Diffuse { reflectance: Tex<Rgb> },
    /// Smooth metal: a mirror weighted by the conductor Fresnel term of complex index `eta + ik`.
    Conductor { eta: Rgb, k: Rgb, specular_reflectance: Tex<Rgb> },
    /// Rough metal: a microfacet model with the conductor Fresnel term.
    RoughConductor { roughness: Roughness, eta: Rgb, k: Rgb, specular_reflectance: Tex<Rgb> },
    /// Smooth glass interface: reflection and refraction by the exact dielectric Fresnel terms.
    Dielectric { eta: f32, specular_reflectance: Tex<Rgb>, specular_transmittance: Tex<Rgb> },
    /// A thin glass sheet: internal reflections summed, light passes without bending.
    ThinDielectric { eta: f32, specular_reflectance: Tex<Rgb>, specular_transmittance: Tex<Rgb> },
    /// Rough glass interface (Walter et al. 2007).
    RoughDielectric { roughness: Roughness, eta: f32, specular_reflectance: Tex<Rgb>, specular_transmittance: Tex<Rgb> },
    /// A diffuse base under a smooth dielectric coating, internal scattering accounted.
    Plastic { diffuse_reflectance: Tex<Rgb>, specular_reflectance: Tex<Rgb>, eta: f32, nonlinear: bool },
    /// A diffuse base under a rough dielectric coating.
    RoughPlastic {
        roughness: Roughness,
        diffuse_reflectance: Tex<Rgb>,
        specular_reflectance: Tex<Rgb>,
        eta: f32,
        nonlinear: bool,
    },
    /// Different models on the two faces (Mitsuba's `twosided`: one model seen from both
    /// sides when `front == back`).
    TwoSided { front: BsdfId, back: BsdfId },
    /// Partly transparent: light passes straight through with probability `1 − opacity`
    /// (Mitsuba's `mask`: a scalar opacity, an RGB texture read as its luminance). With a
    /// `cutoff` (glTF's alpha mode MASK), the opacity is 1 where the looked-up value is at least
    /// the cutoff and 0 below it (compared after filtering, as glTF specifies).
    Mask { opacity: Tex<f32>, inner: BsdfId, cutoff: Option<f32> },
    /// Shading normals from the gradient of a height texture times `scale`.
    BumpMap { height: usize, scale: f32, inner: BsdfId },
    /// Shading normals from a tangent-space normal map (`2 rgb − 1`).
    NormalMap { normals: usize, inner: BsdfId },
    /// `(1 − weight) a + weight b`.
    Blend { weight: Tex<f32>, a: BsdfId, b: BsdfId },
    /// Mitsuba's `principled` (Disney 2015 with its sheen, clearcoat and specular
    /// transmission); `thin` is `principledthin` (with `diff_trans`).
    Principled(Box<Principled>),
}

/// The parameters of Mitsuba's `principled` and `principledthin`.
#[derive(Clone, Debug, PartialEq)]
pub struct Principled {
    pub thin: bool,
    pub base_color: Tex<Rgb>,
    pub roughness: Tex<f32>,
    pub anisotropic: Tex<f32>,
    pub metallic: Tex<f32>,
    pub spec_trans: Tex<f32>,
    pub specular: f32,
    pub spec_tint: Tex<f32>,
    pub sheen: Tex<f32>,
    pub sheen_tint: Tex<f32>,
    pub flatness: Tex<f32>,
    pub clearcoat: Tex<f32>,
    pub clearcoat_gloss: Tex<f32>,
    pub diff_trans: Tex<f32>,
    /// Index of refraction; None: from `specular` (`eta = 2/(1 − sqrt(0.08 specular)) − 1`).
    pub eta: Option<f32>,
}

impl BsdfKind {
    /// The BSDFs this one wraps (none for the leaf models).
    #[must_use]
    pub fn children(&self) -> Vec<BsdfId> {
        match *self {
            BsdfKind::TwoSided { front, back } => vec![front, back],
            BsdfKind::Mask { inner, .. } | BsdfKind::BumpMap { inner, .. } | BsdfKind::NormalMap { inner, .. } => {
                vec![inner]
            }
            BsdfKind::Blend { a, b, .. } => vec![a, b],
            _ => Vec::new(),
        }
    }

    /// This model with every BSDF reference passed through `bsdf` and every texture reference
    /// through `texture` (to append one scene's models to another's).
    #[must_use]
    pub fn remapped(&self, bsdf: impl Fn(BsdfId) -> BsdfId, texture: impl Fn(usize) -> usize) -> BsdfKind {
        let rgb = |t: &Tex<Rgb>| match *t {
            Tex::Texture(i) => Tex::Texture(texture(i)),
            v => v,
        };
        let scalar = |t: &Tex<f32>| match *t {
            Tex::Texture(i) => Tex::Texture(texture(i)),
            v => v,
        };
        let rough = |r: &Roughness| Roughness { alpha_u: scalar(&r.alpha_u), alpha_v: scalar(&r.alpha_v), ..*r };
        match self {
            BsdfKind::Diffuse { reflectance } => BsdfKind::Diffuse { reflectance: rgb(reflectance) },
            BsdfKind::Conductor { eta, k, specular_reflectance } => {
                BsdfKind::Conductor { eta: *eta, k: *k, specular_reflectance: rgb(specular_reflectance) }
            }
            BsdfKind::RoughConductor { roughness, eta, k, specular_reflectance } => BsdfKind::RoughConductor {
                roughness: rough(roughness),
                eta: *eta,
                k: *k,
                specular_reflectance: rgb(specular_reflectance),
            },
            BsdfKind::Dielectric { eta, specular_reflectance, specular_transmittance } => BsdfKind::Dielectric {
                eta: *eta,
                specular_reflectance: rgb(specular_reflectance),
                specular_transmittance: rgb(specular_transmittance),
            },
            BsdfKind::ThinDielectric { eta, specular_reflectance, specular_transmittance } => {
                BsdfKind::ThinDielectric {
                    eta: *eta,
                    specular_reflectance: rgb(specular_reflectance),
                    specular_transmittance: rgb(specular_transmittance),
                }
            }
            BsdfKind::RoughDielectric { roughness, eta, specular_reflectance, specular_transmittance } => {
                BsdfKind::RoughDielectric {
                    roughness: rough(roughness),
                    eta: *eta,
                    specular_reflectance: rgb(specular_reflectance),
                    specular_transmittance: rgb(specular_transmittance),
                }
            }
            BsdfKind::Plastic { diffuse_reflectance, specular_reflectance, eta, nonlinear } => BsdfKind::Plastic {
                diffuse_reflectance: rgb(diffuse_reflectance),
                specular_reflectance: rgb(specular_reflectance),
                eta: *eta,
                nonlinear: *nonlinear,
            },
            BsdfKind::RoughPlastic { roughness, diffuse_reflectance, specular_reflectance, eta, nonlinear } => {
                BsdfKind::RoughPlastic {
                    roughness: rough(roughness),
                    diffuse_reflectance: rgb(diffuse_reflectance),
                    specular_reflectance: rgb(specular_reflectance),
                    eta: *eta,
                    nonlinear: *nonlinear,
                }
            }
            BsdfKind::TwoSided { front, back } => BsdfKind::TwoSided { front: bsdf(*front), back: bsdf(*back) },
            BsdfKind::Mask { opacity, inner, cutoff } => {
                BsdfKind::Mask { opacity: scalar(opacity), inner: bsdf(*inner), cutoff: *cutoff }
            }
            BsdfKind::BumpMap { height, scale, inner } => {
                BsdfKind::BumpMap { height: texture(*height), scale: *scale, inner: bsdf(*inner) }
            }
            BsdfKind::NormalMap { normals, inner } => {
                BsdfKind::NormalMap { normals: texture(*normals), inner: bsdf(*inner) }
            }
            BsdfKind::Blend { weight, a, b } => BsdfKind::Blend { weight: scalar(weight), a: bsdf(*a), b: bsdf(*b) },
            BsdfKind::Principled(p) => BsdfKind::Principled(Box::new(Principled {
                base_color: rgb(&p.base_color),
                roughness: scalar(&p.roughness),
                anisotropic: scalar(&p.anisotropic),
                metallic: scalar(&p.metallic),
                spec_trans: scalar(&p.spec_trans),
                spec_tint: scalar(&p.spec_tint),
                sheen: scalar(&p.sheen),
                sheen_tint: scalar(&p.sheen_tint),
                flatness: scalar(&p.flatness),
                clearcoat: scalar(&p.clearcoat),
                clearcoat_gloss: scalar(&p.clearcoat_gloss),
                diff_trans: scalar(&p.diff_trans),
                ..(**p).clone()
            })),
        }
    }

    /// The textures this model reads.
    #[must_use]
    pub fn textures(&self) -> Vec<usize> {
        let mut out = Vec::new();
        let mut rgb = |t: &Tex<Rgb>| {
            if let Tex::Texture(i) = *t {
                out.push(i);
            }
        };
        match self {
            BsdfKind::Diffuse { reflectance } => rgb(reflectance),
            BsdfKind::Conductor { specular_reflectance, .. }
            | BsdfKind::RoughConductor { specular_reflectance, .. } => {
                rgb(specular_reflectance);
            }
            BsdfKind::Dielectric { specular_reflectance, specular_transmittance, .. }
            | BsdfKind::ThinDielectric { specular_reflectance, specular_transmittance, .. }
            | BsdfKind::RoughDielectric { specular_reflectance, specular_transmittance, .. } => {
                rgb(specular_reflectance);
                rgb(specular_transmittance);
            }
            BsdfKind::Plastic { diffuse_reflectance, specular_reflectance, .. }
            | BsdfKind::RoughPlastic { diffuse_reflectance, specular_reflectance, .. } => {
                rgb(diffuse_reflectance);
                rgb(specular_reflectance);
            }
            BsdfKind::Principled(p) => rgb(&p.base_color),
            BsdfKind::TwoSided { .. }
            | BsdfKind::Mask { .. }
            | BsdfKind::BumpMap { .. }
            | BsdfKind::NormalMap { .. }
            | BsdfKind::Blend { .. } => {}
        }
        let mut scalar = |t: &Tex<f32>| {
            if let Tex::Texture(i) = *t {
                out.push(i);
            }
        };
        match self {
            BsdfKind::RoughConductor { roughness, .. }
            | BsdfKind::RoughDielectric { roughness, .. }
            | BsdfKind::RoughPlastic { roughness, .. } => {
                scalar(&roughness.alpha_u);
                scalar(&roughness.alpha_v);
            }
            BsdfKind::Blend { weight, .. } | BsdfKind::Mask { opacity: weight, .. } => scalar(weight),
            BsdfKind::Principled(p) => {
                for t in [
                    &p.roughness,
                    &p.anisotropic,
                    &p.metallic,
                    &p.spec_trans,
                    &p.spec_tint,
                    &p.sheen,
                    &p.sheen_tint,
                    &p.flatness,
                    &p.clearcoat,
                    &p.clearcoat_gloss,
                    &p.diff_trans,
                ] {
                    scalar(t);
                }
            }
            _ => {}
        }
        match *self {
            BsdfKind::BumpMap { height, .. } => out.push(height),
            BsdfKind::NormalMap { normals, .. } => out.push(normals),
            _ => {}
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn remapped_moves_every_reference_and_nothing_else() {
        let p = BsdfKind::Principled(Box::new(Principled {
            thin: false,
            base_color: Tex::Texture(1),
            roughness: Tex::Texture(2),
            anisotropic: Tex::Value(0.0),
            metallic: Tex::Value(0.5),
            spec_trans: Tex::Texture(0),
            specular: 0.5,
            spec_tint: Tex::Value(0.0),
            sheen: Tex::Value(0.0),
            sheen_tint: Tex::Value(0.0),
            flatness: Tex::Value(0.0),
            clearcoat: Tex::Value(0.0),
            clearcoat_gloss: Tex::Value(0.0),
            diff_trans: Tex::Value(0.0),
            eta: Some(1.5),
        }));
        let q = p.remapped(|b| b + 100, |t| t + 10);
        let mut textures = q.textures();
        textures.sort_unstable();
        assert_eq!(textures, vec![10, 11, 12]);
        let BsdfKind::Principled(q) = q else { panic!("principled") };
        assert_eq!((q.metallic, q.eta, q.specular), (Tex::Value(0.5), Some(1.5), 0.5));
        let m = BsdfKind::Mask { opacity: Tex::Texture(3), inner: 4, cutoff: Some(0.5) };
        assert_eq!(
            m.remapped(|b| b + 1, |t| t * 2),
            BsdfKind::Mask { opacity: Tex::Texture(6), inner: 5, cutoff: Some(0.5) }
        );
        let n = BsdfKind::NormalMap { normals: 1, inner: 0 }.remapped(|b| b + 7, |t| t + 2);
        assert_eq!((n.children(), n.textures()), (vec![7], vec![3]));
    }
}
