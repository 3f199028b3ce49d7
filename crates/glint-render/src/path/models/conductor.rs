//! Metals as Mitsuba 3's `conductor` (a mirror weighted by the conductor Fresnel term of the
//! complex index `eta + i k`, per RGB channel) and `roughconductor` (the microfacet model of
//! Cook and Torrance 1982 in Walter et al. 2007's form, `F D G / (4 cos θo)`, sampled by the
//! distribution's normals), src/bsdfs/conductor.cpp and roughconductor.cpp.
//!
//! One-sided: nothing from below the shading normal (`wo.z ≤ 0`) nor toward it (`wi.z ≤ 0`).

use super::Sample;
use super::fresnel::{self, reflect, reflect_z};
use super::microfacet::Microfacet;
use glint_core::{Rgb, Vec2, Vec3};

/// The mirror lobe of a smooth conductor: direction and weight `R · F(cos θo)`.
pub(super) fn smooth_lobe(wo: Vec3, eta: Rgb, k: Rgb, specular_reflectance: Rgb) -> Option<(Vec3, Rgb)> {
    (wo.z > 0.0).then(|| (reflect_z(wo), specular_reflectance * fresnel::conductor(wo.z, eta, k)))
}

/// `f · cos θi` of a rough conductor.
pub(super) fn rough_eval(micro: &Microfacet, eta: Rgb, k: Rgb, specular_reflectance: Rgb, wo: Vec3, wi: Vec3) -> Rgb {
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Rgb::ZERO;
    }
    let h = (wo + wi).normalize();
    let d = micro.d(h);
    if d == 0.0 {
        return Rgb::ZERO;
    }
    let g = micro.g(wo, wi, h);
    let value = d * g / (4.0 * wo.z);
    specular_reflectance * fresnel::conductor(wo.dot(h), eta, k) * value
}

/// Solid-angle density of [`rough_sample`].
pub(super) fn rough_pdf(micro: &Microfacet, wo: Vec3, wi: Vec3) -> f32 {
    let h = (wo + wi).normalize();
    if !(wo.z > 0.0 && wi.z > 0.0 && wo.dot(h) > 0.0 && wi.dot(h) > 0.0) {
        return 0.0;
    }
    if micro.sample_visible {
        micro.d(h) * micro.smith_g1(wo, h) / (4.0 * wo.z)
    } else {
        micro.pdf(wo, h) / (4.0 * wi.dot(h))
    }
}

/// Sample a microfacet normal and reflect about it.
pub(super) fn rough_sample(
    micro: &Microfacet,
    eta: Rgb,
    k: Rgb,
    specular_reflectance: Rgb,
    wo: Vec3,
    u: Vec2,
) -> Option<Sample> {
    if wo.z <= 0.0 {
        return None;
    }
    let (m, pdf_m) = micro.sample(wo, u);
    let wi = reflect(wo, m);
    if pdf_m == 0.0 || wi.z <= 0.0 {
        return None;
    }
    let g = if micro.sample_visible { micro.smith_g1(wi, m) } else { micro.g(wo, wi, m) * wo.dot(m) / (wo.z * m.z) };
    let pdf = pdf_m / (4.0 * wi.dot(m));
    let weight = fresnel::conductor(wo.dot(m), eta, k) * specular_reflectance * g;
    Sample::glossy(wi, weight, g, pdf)
}

#[cfg(test)]
mod tests {
    use super::super::tests::{check_model, directions_out};
    use super::super::{Microfacet, Model};
    use glint_core::Rgb;
    use glint_scene::bsdf::Distribution;

    #[test]
    fn rough_conductor_samples_its_pdf_and_conserves_energy() {
        let mut models = Vec::new();
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for (au, av) in [(0.05, 0.05), (0.4, 0.4), (0.1, 0.6)] {
                for sample_visible in [true, false] {
                    models.push(Model::RoughConductor {
                        micro: Microfacet::new(distribution, au, av, sample_visible),
                        eta: Rgb::new(0.2, 0.9, 1.1),
                        k: Rgb::new(3.9, 2.4, 2.2),
                        specular_reflectance: Rgb::ONE,
                    });
                }
            }
        }
        let tests = models.len() * directions_out(false).len();
        for m in &models {
            for wo in directions_out(false) {
                check_model(m, wo, tests, true);
            }
        }
    }
}
