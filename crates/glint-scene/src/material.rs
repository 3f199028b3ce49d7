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
    /// Emitted radiance (area lights in path mode; added as-is in Whitted mode).
    pub emission: Rgb,
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
        }
    }
}

impl Material {
    pub fn is_transparent(&self) -> bool {
        self.transparency > 0.0
    }
}
