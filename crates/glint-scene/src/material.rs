//! The material: the thesis's Phong parameter set, plus reflection and refraction weights.
//!
//! One struct, not an enum: every mode reads the same parameters (Whitted uses them directly;
//! the path tracer maps them to a normalised Phong BRDF and delta lobes).

use glint_core::Rgb;

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Base (diffuse) colour, linear RGB. Multiplied by the texture when there is one.
    pub colour: Rgb,
    /// Index into `Scene::textures`.
    pub texture: Option<usize>,
    /// K_a: weight of the ambient term (ambient light is the scene's `ambient` colour).
    pub ambient: f32,
    /// K_d.
    pub diffuse: f32,
    /// K_s (white highlights).
    pub specular: f32,
    /// Phong exponent n.
    pub shininess: f32,
    /// K_refl: constant mirror weight.
    pub reflectivity: f32,
    /// K_refr: how much light passes through (0 = opaque).
    pub transparency: f32,
    /// Index of refraction of the inside of the object.
    pub ior: f32,
    /// Weight reflection/refraction of transparent materials by the exact dielectric Fresnel
    /// equations (default). When false, `reflectivity` and `transparency` are used as given.
    pub fresnel: bool,
    /// Emitted radiance (area lights in path mode; added as-is in Whitted mode), from the front
    /// face only — the side the geometric normal points to (triangles: by winding; spheres:
    /// outward), as Mitsuba and pbrt emit — unless `two_sided`.
    pub emission: Rgb,
    /// Index into `Scene::textures`: the emission is `emission` × this texture at the hit's uv
    /// (glTF's emissiveTexture; [`Material::emission_at`]). `None`: `emission` everywhere.
    pub emission_texture: Option<usize>,
    /// Emit from both faces.
    pub two_sided: bool,
    /// Fresnel reflection of the surroundings (DESIGN.md §4): the shaded colour is blended with
    /// a traced reflection ray by Schlick's `F = f0 + (1 − f0)(1 − n·v)^5`, i.e.
    /// `lerp(shaded, reflected, F)`. f0 = 0.04 for dielectrics (plastic, paint, glazed
    /// ceramic); a metal's own reflectance (gold ≈ (1.0, 0.71, 0.29)). Excludes the constant
    /// `reflectivity` and `transparency` (which has its exact Fresnel weights).
    pub reflection_f0: Option<Rgb>,
    /// A physically based model ([`crate::bsdf`], index into `Scene::bsdfs`) that shades this
    /// material in path mode instead of the Phong parameters above (which the Whitted mode
    /// keeps reading).
    pub bsdf: Option<crate::BsdfId>,
}

impl Default for Material {
    fn default() -> Self {
        Self {
            name: "default".into(),
            colour: Rgb::splat(0.8),
            texture: None,
            ambient: 0.1,
            diffuse: 0.8,
            specular: 0.2,
            shininess: 32.0,
            reflectivity: 0.0,
            transparency: 0.0,
            ior: 1.5,
            fresnel: true,
            emission: Rgb::ZERO,
            emission_texture: None,
            two_sided: false,
            reflection_f0: None,
            bsdf: None,
        }
    }
}

impl Material {
    /// The radiance this material emits toward `wo` from a surface whose geometric normal is
    /// `ng` (unflipped): its emission on the front face, and on the back only when two-sided.
    #[inline]
    #[must_use]
    pub fn emitted(&self, ng: glint_core::Vec3, wo: glint_core::Vec3) -> Rgb {
        // Most surfaces emit nothing, and then the normal is not read: a hit's normal just
        // written lane by lane (`World::intersect8`) stalled this load (3 % of a Cornell box
        // frame).
        if self.emission == Rgb::ZERO {
            return Rgb::ZERO;
        }
        if self.two_sided || ng.dot(wo) > 0.0 { self.emission } else { Rgb::ZERO }
    }

    /// The emitted radiance at texture coordinates `uv` (`textures` is `Scene::textures`):
    /// `emission`, times the emission texture when there is one.
    #[must_use]
    pub fn emission_at(&self, uv: glint_core::Vec2, textures: &[crate::Texture]) -> Rgb {
        match self.emission_texture.and_then(|t| textures.get(t)) {
            Some(t) => self.emission * t.evaluate(uv),
            None => self.emission,
        }
    }

    pub fn is_transparent(&self) -> bool {
        self.transparency > 0.0
    }

    /// Schlick's Fresnel reflectance for the cosine between the normal and the outgoing
    /// direction, when the material opts into Fresnel reflection.
    #[inline]
    pub fn schlick(&self, cos_o: f32) -> Option<Rgb> {
        let f0 = self.reflection_f0?;
        let m = (1.0 - cos_o.clamp(0.0, 1.0)).powi(5);
        Some(f0 + (Rgb::ONE - f0) * m)
    }
}
