//! Glass as Mitsuba 3's `dielectric` (a smooth interface: mirror and refraction split by the
//! exact Fresnel term), `thindielectric` (a thin sheet: the internal reflections summed,
//! `R' = 2R/(1 + R)`, light passing without bending) and `roughdielectric` (the microfacet
//! reflection and refraction model of Walter et al. 2007, "Microfacet models for refraction
//! through rough surfaces", eqs. 20 and 21, with Mitsuba's `1/η²` radiance scaling and its
//! roughness widening `1.2 − 0.2 √|cos θo|` when sampling all normals, their §5.3),
//! src/bsdfs/dielectric.cpp, thindielectric.cpp and roughdielectric.cpp.
//!
//! Two-sided: `eta` is inside over outside, and from inside (`wo.z < 0`) the interface is seen
//! with `1/eta`. Transmitted radiance is scaled by `1/η²` along the path (radiance mode).

use super::Sample;
use super::fresnel::{self, reflect, reflect_z, refract, refract_z};
use super::microfacet::Microfacet;
use glint_core::{Rgb, Vec2, Vec3};

/// The two lobes of a smooth interface: reflection `R · F` and refraction `T (1 − F) / η²`.
pub(super) fn smooth_lobes(wo: Vec3, eta: f32, reflectance: Rgb, transmittance: Rgb) -> [Option<(Vec3, Rgb)>; 2] {
    let fr = fresnel::dielectric(wo.z, eta);
    let r = (fr.f > 0.0).then(|| (reflect_z(wo), reflectance * fr.f));
    let t = (fr.f < 1.0)
        .then(|| (refract_z(wo, fr.cos_t, fr.eta_ti), transmittance * ((1.0 - fr.f) * fr.eta_ti * fr.eta_ti)));
    [r, t]
}

/// Sample a smooth interface: reflection with probability F.
pub(super) fn smooth_sample(wo: Vec3, eta: f32, reflectance: Rgb, transmittance: Rgb, u_lobe: f32) -> Option<Sample> {
    let fr = fresnel::dielectric(wo.z, eta);
    if u_lobe <= fr.f {
        Some(Sample::delta(reflect_z(wo), reflectance))
    } else {
        Some(Sample::delta(refract_z(wo, fr.cos_t, fr.eta_ti), transmittance * (fr.eta_ti * fr.eta_ti)))
    }
}

/// Reflectance of a thin sheet with its internal reflections.
fn thin_reflectance(wo: Vec3, eta: f32) -> f32 {
    let r = fresnel::dielectric(wo.z.abs(), eta).f;
    r * 2.0 / (1.0 + r)
}

/// The lobes of a thin sheet: reflection `R r'` and straight transmission `T (1 − r')`.
pub(super) fn thin_lobes(wo: Vec3, eta: f32, reflectance: Rgb, transmittance: Rgb) -> [Option<(Vec3, Rgb)>; 2] {
    let r = thin_reflectance(wo, eta);
    [(r > 0.0).then(|| (reflect_z(wo), reflectance * r)), (r < 1.0).then(|| (-wo, transmittance * (1.0 - r)))]
}

pub(super) fn thin_sample(wo: Vec3, eta: f32, reflectance: Rgb, transmittance: Rgb, u_lobe: f32) -> Option<Sample> {
    let r = thin_reflectance(wo, eta);
    if u_lobe <= r { Some(Sample::delta(reflect_z(wo), reflectance)) } else { Some(Sample::delta(-wo, transmittance)) }
}

/// The distribution sampled: widened by Walter et al.'s factor when not sampling visible
/// normals.
fn sample_distribution(micro: &Microfacet, cos_o: f32) -> Microfacet {
    if micro.sample_visible { *micro } else { micro.scaled(1.2 - 0.2 * cos_o.abs().sqrt()) }
}

/// The generalised half vector of `wo` and `wi` (toward the macro normal's side) and the
/// relative index along the path.
fn half_vector(wo: Vec3, wi: Vec3, eta: f32) -> (Vec3, bool, f32) {
    let reflect = wo.z * wi.z > 0.0;
    let eta_path = if wo.z > 0.0 { eta } else { 1.0 / eta };
    let m = (wo + wi * if reflect { 1.0 } else { eta_path }).normalize();
    (if m.z < 0.0 { -m } else { m }, reflect, eta_path)
}

/// `f · |cos θi|` of a rough interface.
pub(super) fn rough_eval(
    micro: &Microfacet,
    eta: f32,
    reflectance: Rgb,
    transmittance: Rgb,
    wo: Vec3,
    wi: Vec3,
) -> Rgb {
    if wo.z == 0.0 {
        return Rgb::ZERO;
    }
    let (m, reflect, eta_path) = half_vector(wo, wi, eta);
    let d = micro.d(m);
    let f = fresnel::dielectric(wo.dot(m), eta).f;
    let g = micro.g(wo, wi, m);
    if reflect {
        reflectance * (f * d * g / (4.0 * wo.z.abs()))
    } else {
        let scale = 1.0 / (eta_path * eta_path);
        let (dot_o, dot_i) = (wo.dot(m), wi.dot(m));
        let denom = dot_o + eta_path * dot_i;
        let value = (scale * (1.0 - f) * d * g * eta_path * eta_path * dot_o * dot_i) / (wo.z * denom * denom);
        transmittance * value.abs()
    }
}

/// Solid-angle density of [`rough_sample`].
pub(super) fn rough_pdf(micro: &Microfacet, eta: f32, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z == 0.0 {
        return 0.0;
    }
    let (m, reflect, eta_path) = half_vector(wo, wi, eta);
    let (dot_o, dot_i) = (wo.dot(m), wi.dot(m));
    if !(dot_o * wo.z > 0.0 && dot_i * wi.z > 0.0) {
        return 0.0;
    }
    let dwh_dwi = if reflect {
        1.0 / (4.0 * dot_i)
    } else {
        let denom = dot_o + eta_path * dot_i;
        eta_path * eta_path * dot_i / (denom * denom)
    };
    let wo_up = if wo.z < 0.0 { -wo } else { wo };
    let prob = sample_distribution(micro, wo.z).pdf(wo_up, m);
    let f = fresnel::dielectric(dot_o, eta).f;
    let p = prob * if reflect { f } else { 1.0 - f } * dwh_dwi.abs();
    if p.is_finite() { p } else { 0.0 }
}

/// Sample a microfacet normal, then reflect about it with probability F or refract.
pub(super) fn rough_sample(
    micro: &Microfacet,
    eta: f32,
    reflectance: Rgb,
    transmittance: Rgb,
    wo: Vec3,
    u_lobe: f32,
    u: Vec2,
) -> Option<Sample> {
    if wo.z == 0.0 {
        return None;
    }
    let wo_up = if wo.z < 0.0 { -wo } else { wo };
    let (m, pdf_m) = sample_distribution(micro, wo.z).sample(wo_up, u);
    if pdf_m == 0.0 {
        return None;
    }
    let fr = fresnel::dielectric(wo.dot(m), eta);
    let (wi, colour, lobe_pdf, dwh_dwi) = if u_lobe <= fr.f {
        let wi = reflect(wo, m);
        (wi, reflectance, fr.f, 1.0 / (4.0 * wi.dot(m)))
    } else {
        let wi = refract(wo, m, fr.cos_t, fr.eta_ti);
        let denom = wo.dot(m) + fr.eta_it * wi.dot(m);
        (wi, transmittance * (fr.eta_ti * fr.eta_ti), 1.0 - fr.f, fr.eta_it * fr.eta_it * wi.dot(m) / (denom * denom))
    };
    let g = if micro.sample_visible { micro.smith_g1(wi, m) } else { micro.g(wo, wi, m) * wo.dot(m) / (wo.z * m.z) };
    Sample::glossy(wi, colour * g, g, pdf_m * lobe_pdf * dwh_dwi.abs())
}

#[cfg(test)]
mod tests {
    use super::super::tests::{check_model, directions_out};
    use super::super::{Microfacet, Model};
    use super::*;
    use glint_scene::bsdf::Distribution;

    #[test]
    fn smooth_lobes_split_energy_and_sampling_picks_them_by_fresnel() {
        for wo in [
            Vec3::new(0.3, 0.1, 0.9).normalize(),
            Vec3::new(0.5, -0.2, -0.6).normalize(),
            Vec3::new(0.9, 0.0, -0.3).normalize(),
        ] {
            let m = Model::Dielectric { eta: 1.5, specular_reflectance: Rgb::ONE, specular_transmittance: Rgb::ONE };
            let [r, t] = m.delta_lobes(wo);
            let (rd, rw) = r.expect("reflection");
            assert_eq!(rd, Vec3::new(-wo.x, -wo.y, wo.z));
            // Energy: R + T·η² (undoing the radiance scale) = 1.
            let t_energy = t.map_or(0.0, |(d, w)| {
                assert!((d.length() - 1.0).abs() < 1e-5 && d.z * wo.z < 0.0);
                let fr = fresnel::dielectric(wo.z, 1.5);
                w.x / (fr.eta_ti * fr.eta_ti)
            });
            assert!((rw.x + t_energy - 1.0).abs() < 1e-5, "{wo}: {rw} {t_energy}");
            let below = m.sample(wo, rw.x * 0.999, Vec2::ZERO).expect("sample");
            assert!(below.delta && below.wi == rd && below.pdf == 0.0);
            assert_eq!(m.p_delta(wo), 1.0);
        }
        let thin = Model::ThinDielectric { eta: 1.5, specular_reflectance: Rgb::ONE, specular_transmittance: Rgb::ONE };
        let wo = Vec3::new(0.0, 0.6, -0.8);
        let [r, t] = thin.delta_lobes(wo);
        let (r, t) = (r.expect("r"), t.expect("t"));
        assert_eq!(t.0, -wo);
        assert!((r.1.x + t.1.x - 1.0).abs() < 1e-6 && r.1.x > 0.04);
    }

    #[test]
    fn rough_dielectric_samples_its_pdf_from_both_sides() {
        let mut models = Vec::new();
        for distribution in [Distribution::Beckmann, Distribution::Ggx] {
            for (au, av) in [(0.08, 0.08), (0.5, 0.5), (0.1, 0.4)] {
                for sample_visible in [true, false] {
                    for eta in [1.5, 1.0 / 1.33] {
                        models.push(Model::RoughDielectric {
                            micro: Microfacet::new(distribution, au, av, sample_visible),
                            eta,
                            specular_reflectance: Rgb::ONE,
                            specular_transmittance: Rgb::ONE,
                        });
                    }
                }
            }
        }
        let tests = models.len() * directions_out(true).len();
        for m in &models {
            for wo in directions_out(true) {
                check_model(m, wo, tests, false);
            }
        }
    }
}
