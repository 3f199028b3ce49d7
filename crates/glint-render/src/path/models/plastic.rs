//! Coated diffuse surfaces as Mitsuba 3's `plastic` and `roughplastic` (src/bsdfs/plastic.cpp,
//! roughplastic.cpp): a dielectric coating of index `eta` over a Lambertian base, the light
//! bouncing between base and coating summed in closed form (Weidlich and Wilkie 2007's layered
//! model as Mitsuba simplifies it): the base's `ρ` becomes `ρ / (1 − Fdr)` (`ρ / (1 − ρ Fdr)`
//! with `nonlinear`), where `Fdr` is the coating's internal diffuse reflectance.
//!
//! - smooth: a delta mirror `R F(θo)` and a diffuse lobe `ρ' (1 − F(θo)) (1 − F(θi)) cos θi / (π η²)`;
//! - rough: a microfacet coating (`F D G / (4 cos θo)`, isotropic: α = `alpha_u`) and a diffuse
//!   lobe `ρ' t(θo) t(θi) cos θi / (π η²)`, where `t` is the coating's rough transmittance and
//!   `Fdr` its internal reflectance, both integrated numerically as Mitsuba does (64 cosines,
//!   Gauss–Legendre over the visible normals) once per (distribution, α, η) and per thread.
//!
//! Lobes are chosen with Mitsuba's specular sampling weight `s̄ / (d̄ + s̄)` (channel means of the
//! specular and diffuse reflectances as given; Mitsuba takes a texture's mean over the image).
//! One-sided.

use super::Sample;
use super::fresnel::{self, reflect, reflect_z, refract};
use super::microfacet::{Microfacet, cosine_hemisphere, cosine_hemisphere_pdf, gauss_legendre};
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::bsdf::Distribution;
use std::cell::RefCell;
use std::f32::consts::FRAC_1_PI;
use std::rc::Rc;

/// Cosines at which the rough coating's transmittance is tabulated (Mitsuba's
/// `MI_ROUGH_TRANSMITTANCE_RES`).
const TRANSMITTANCE_RES: usize = 64;

/// Share of samples sent to the specular lobe before the Fresnel weighting.
pub(super) fn specular_sampling_weight(diffuse_reflectance: Rgb, specular_reflectance: Rgb) -> f32 {
    let (d, s) = (diffuse_reflectance.element_sum() / 3.0, specular_reflectance.element_sum() / 3.0);
    if d + s > 0.0 { s / (d + s) } else { 0.5 }
}

/// `ρ / (1 − Fdr)`, or `ρ / (1 − ρ Fdr)` with `nonlinear`.
fn diffuse_scaled(diffuse_reflectance: Rgb, fdr: f32, nonlinear: bool) -> Rgb {
    if nonlinear {
        diffuse_reflectance / (Rgb::ONE - diffuse_reflectance * fdr)
    } else {
        diffuse_reflectance / (1.0 - fdr)
    }
}

/// Probability of the specular lobe given the coating's reflectance toward `wo`.
fn p_specular(reflect: f32, weight: f32) -> f32 {
    let (s, d) = (reflect * weight, (1.0 - reflect) * (1.0 - weight));
    if s + d > 0.0 { s / (s + d) } else { 0.0 }
}

/// A smooth plastic's parameters.
#[derive(Clone, Copy, Debug)]
pub(super) struct Smooth {
    pub diffuse: Rgb,
    pub specular: Rgb,
    pub eta: f32,
    pub nonlinear: bool,
}

impl Smooth {
    fn p_specular(&self, wo: Vec3) -> f32 {
        p_specular(fresnel::dielectric(wo.z, self.eta).f, specular_sampling_weight(self.diffuse, self.specular))
    }

    pub fn p_delta(&self, wo: Vec3) -> f32 {
        if wo.z <= 0.0 { 0.0 } else { self.p_specular(wo) }
    }

    pub fn delta_lobe(&self, wo: Vec3) -> Option<(Vec3, Rgb)> {
        (wo.z > 0.0).then(|| (reflect_z(wo), self.specular * fresnel::dielectric(wo.z, self.eta).f))
    }

    /// The diffuse lobe's colour seen from `wo`: `ρ' (1 − F(θo)) / η²`.
    pub fn diffuse_albedo(&self, wo: Vec3) -> Rgb {
        if wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let fdr_int = fresnel::diffuse_reflectance(1.0 / self.eta);
        let f_o = fresnel::dielectric(wo.z, self.eta).f;
        diffuse_scaled(self.diffuse, fdr_int, self.nonlinear) * ((1.0 - f_o) / (self.eta * self.eta))
    }

    /// The diffuse lobe's shape: `(1 − F(θi)) cos θi / π`.
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        (1.0 - fresnel::dielectric(wi.z, self.eta).f) * cosine_hemisphere_pdf(wi)
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.diffuse_albedo(wo) * self.eval_diffuse(wo, wi)
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        cosine_hemisphere_pdf(wi) * (1.0 - self.p_specular(wo))
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Sample> {
        if wo.z <= 0.0 {
            return None;
        }
        let p_spec = self.p_specular(wo);
        if u_lobe < p_spec {
            let f_o = fresnel::dielectric(wo.z, self.eta).f;
            return Some(Sample::delta(reflect_z(wo), self.specular * (f_o / p_spec)));
        }
        let wi = cosine_hemisphere(u);
        let pdf = (1.0 - p_spec) * cosine_hemisphere_pdf(wi);
        let shape = self.eval_diffuse(wo, wi);
        Sample::glossy(wi, self.diffuse_albedo(wo) * (shape / pdf), shape, pdf)
    }
}

/// The numerically integrated optics of a rough coating.
#[derive(Debug)]
struct Coating {
    /// Transmittance into the coating against the cosine (64 samples over [0, 1]).
    transmittance: [f32; TRANSMITTANCE_RES],
    /// Diffuse reflectance of the coating's inside.
    internal_reflectance: f32,
}

type CoatingKey = (Distribution, u32, u32);

thread_local! {
    /// Coatings already integrated on this thread (few per scene: α and η are not textured).
    static COATINGS: RefCell<Vec<(CoatingKey, Rc<Coating>)>> = const { RefCell::new(Vec::new()) };
}

impl Coating {
    fn cached(distribution: Distribution, alpha: f32, eta: f32) -> Rc<Coating> {
        let key = (distribution, alpha.to_bits(), eta.to_bits());
        COATINGS.with(|c| {
            let mut c = c.borrow_mut();
            if let Some((_, coating)) = c.iter().find(|(k, _)| *k == key) {
                return coating.clone();
            }
            let coating = Rc::new(Coating::integrate(distribution, alpha, eta));
            c.push((key, coating.clone()));
            coating
        })
    }

    /// Mitsuba's `eval_transmittance` and `eval_reflectance` (microfacet.h): Gauss–Legendre
    /// quadrature over the unit square of visible-normal samples (32² nodes for η > 1,
    /// 128² otherwise), `G1 (1 − F)` of the refracted and `G1 F` of the reflected direction.
    fn integrate(distribution: Distribution, alpha: f32, eta: f32) -> Coating {
        let micro = Microfacet::new(distribution, alpha, alpha, true);
        let quadrature = |eta: f32, wi: Vec3, reflect_side: bool| -> f32 {
            let (nodes, weights) = gauss_legendre(if eta > 1.0 { 32 } else { 128 });
            let mut sum = 0.0f32;
            for (&ny, &wy) in nodes.iter().zip(&weights) {
                for (&nx, &wx) in nodes.iter().zip(&weights) {
                    let u = Vec2::new((nx * 0.5 + 0.5) as f32, (ny * 0.5 + 0.5) as f32);
                    let (m, _) = micro.sample(wi, u);
                    let fr = fresnel::dielectric(wi.dot(m), eta);
                    let value = if reflect_side {
                        let wo = reflect(wi, m);
                        if wo.z <= 0.0 || wi.z <= 0.0 { 0.0 } else { micro.smith_g1(wo, m) * fr.f }
                    } else {
                        let wo = refract(wi, m, fr.cos_t, fr.eta_ti);
                        if wo.z * wi.z >= 0.0 { 0.0 } else { micro.smith_g1(wo, m) * (1.0 - fr.f) }
                    };
                    sum += value * (wx * wy) as f32 * 0.25;
                }
            }
            sum
        };
        let mut transmittance = [0.0; TRANSMITTANCE_RES];
        let mut internal = 0.0;
        for (i, t) in transmittance.iter_mut().enumerate() {
            let mu = (i as f32 / (TRANSMITTANCE_RES - 1) as f32).max(1e-6);
            let wi = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            *t = quadrature(eta, wi, false);
            internal += quadrature(1.0 / eta, wi, true) * wi.z;
        }
        Coating { transmittance, internal_reflectance: internal / TRANSMITTANCE_RES as f32 * 2.0 }
    }

    /// Linear interpolation of the table at a cosine (Mitsuba's `lerp_gather`).
    fn transmittance(&self, cos: f32) -> f32 {
        let x = cos * (TRANSMITTANCE_RES - 1) as f32;
        let i = (x.max(0.0) as usize).min(TRANSMITTANCE_RES - 2);
        let (v0, v1) = (self.transmittance[i], self.transmittance[i + 1]);
        v0 + (v1 - v0) * (x - i as f32)
    }
}

/// A rough plastic's parameters.
#[derive(Clone, Copy, Debug)]
pub(super) struct Rough {
    pub micro: Microfacet,
    pub diffuse: Rgb,
    pub specular: Rgb,
    pub eta: f32,
    pub nonlinear: bool,
}

impl Rough {
    /// Mitsuba's roughplastic is isotropic: α = `alpha_u`.
    fn micro(&self) -> Microfacet {
        Microfacet { alpha_v: self.micro.alpha_u, ..self.micro }
    }

    fn coating(&self) -> Rc<Coating> {
        Coating::cached(self.micro.distribution, self.micro.alpha_u.max(1e-4), self.eta)
    }

    fn p_specular(&self, coating: &Coating, wo: Vec3) -> f32 {
        p_specular(1.0 - coating.transmittance(wo.z), specular_sampling_weight(self.diffuse, self.specular))
    }

    /// The diffuse lobe's colour seen from `wo`: `ρ' t(θo) / η²`.
    pub fn diffuse_albedo(&self, wo: Vec3) -> Rgb {
        if wo.z <= 0.0 {
            return Rgb::ZERO;
        }
        let c = self.coating();
        diffuse_scaled(self.diffuse, c.internal_reflectance, self.nonlinear)
            * (c.transmittance(wo.z) / (self.eta * self.eta))
    }

    /// The diffuse lobe's shape: `t(θi) cos θi / π`.
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        self.coating().transmittance(wi.z) * FRAC_1_PI * wi.z
    }

    fn eval_specular(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let micro = self.micro();
        let h = (wo + wi).normalize();
        let f = fresnel::dielectric(wo.dot(h), self.eta).f;
        self.specular * (f * micro.d(h) * micro.g(wo, wi, h) / (4.0 * wo.z))
    }

    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return Rgb::ZERO;
        }
        self.eval_specular(wo, wi) + self.diffuse_albedo(wo) * self.eval_diffuse(wo, wi)
    }

    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z <= 0.0 || wi.z <= 0.0 {
            return 0.0;
        }
        let p_spec = self.p_specular(&self.coating(), wo);
        let micro = self.micro();
        let h = (wo + wi).normalize();
        let spec = if micro.sample_visible {
            micro.d(h) * micro.smith_g1(wo, h) / (4.0 * wo.z)
        } else {
            micro.pdf(wo, h) / (4.0 * wi.dot(h))
        };
        p_spec * spec + (1.0 - p_spec) * cosine_hemisphere_pdf(wi)
    }

    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Sample> {
        if wo.z <= 0.0 {
            return None;
        }
        let wi = if u_lobe < self.p_specular(&self.coating(), wo) {
            reflect(wo, self.micro().sample(wo, u).0)
        } else {
            cosine_hemisphere(u)
        };
        let pdf = self.pdf(wo, wi);
        let value = self.eval(wo, wi);
        Sample::glossy(wi, value / pdf, 1.0, pdf)
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{check_model, directions_out};
    use super::super::{Microfacet, Model};
    use super::*;

    #[test]
    fn plastics_sample_their_pdfs_and_conserve_energy() {
        let mut models = Vec::new();
        for nonlinear in [false, true] {
            models.push(Model::Plastic {
                diffuse_reflectance: Rgb::ONE,
                specular_reflectance: Rgb::ONE,
                eta: 1.49,
                nonlinear,
            });
            for distribution in [Distribution::Beckmann, Distribution::Ggx] {
                for (alpha, sample_visible) in [(0.05, true), (0.3, false), (0.6, true)] {
                    models.push(Model::RoughPlastic {
                        micro: Microfacet::new(distribution, alpha, alpha, sample_visible),
                        diffuse_reflectance: Rgb::new(0.9, 0.5, 0.2),
                        specular_reflectance: Rgb::ONE,
                        eta: 1.49,
                        nonlinear,
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

    #[test]
    fn rough_coating_transmits_what_it_does_not_reflect() {
        // A smooth-ish coating transmits about 1 − F; the inside reflects about Fdr(1/η).
        let c = Coating::integrate(Distribution::Ggx, 0.01, 1.5);
        let t = c.transmittance(1.0);
        assert!((t - 0.96).abs() < 0.005, "{t}");
        let fdr = fresnel::diffuse_reflectance(1.0 / 1.5);
        assert!((c.internal_reflectance - fdr).abs() < 0.03, "{} vs {fdr}", c.internal_reflectance);
    }
}
