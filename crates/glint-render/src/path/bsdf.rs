//! The path tracer's reading of glint's material: the thesis's Phong parameters as an
//! energy-conserving BSDF with delta lobes.
//!
//! - Diffuse: `ρd/π` with `ρd = K_d · colour` (texture included).
//! - Glossy: the normalised (modified) Phong lobe of Lafortune and Willems 1994,
//!   `ρs (n+2)/(2π) cos^n α`, α between `wi` and the mirror direction of `wo`; white.
//!   When `K_d · max(colour) + K_s` exceeds 1 both are scaled down so that the surface never
//!   reflects more than it receives.
//! - Mirror (delta): `K_refl`, or Schlick's `F` for materials with `f0`.
//! - Transmission (delta): `K_refr` split by the exact dielectric Fresnel equations (total
//!   internal reflection goes to the mirror), as the Whitted mode splits it.
//! - The Phong part is weighted by `1 − K_refl − K_refr` (by `1 − F` with `f0`), so the lobes
//!   sum to at most 1.
//!
//! A material that names a physically based model (`Material::bsdf`) is shaded by it instead
//! ([`super::shading::Physical`]): the same interface, its diffuse lobe the demodulated part.
//!
//! Lobes are chosen for sampling in proportion to their albedos; the non-delta part is one
//! mixture density (diffuse and glossy pdfs weighted by their choice probabilities), so a
//! sampled direction is weighted by the whole non-delta BSDF (one-sample MIS over the lobes).

use super::shading::Physical;
use crate::whitted::optics::{fresnel_dielectric, reflect, refract};
use glint_core::colour::luminance;
use glint_core::sampling::sample_cosine_hemisphere;
use glint_core::{Frame, Rgb, Vec2, Vec3};
use glint_scene::Material;
use std::f32::consts::{FRAC_1_PI, TAU};

/// The most delta lobes a BSDF has (a physically based mixture's; the Phong reading has two).
pub const DELTA_LOBES: usize = super::models::MIXTURE_DELTA_LOBES;

/// A material at one hit, seen from one direction.
#[derive(Clone, Copy, Debug)]
pub struct Bsdf {
    /// Shading normal on the side of `wo`.
    pub normal: Vec3,
    /// Geometric normal on the side of `wo`.
    pub geometric: Vec3,
    /// ρd: the diffuse albedo (the Albedo AOV and the demodulation factor).
    pub diffuse: Rgb,
    /// ρs: the glossy lobe's albedo at normal incidence.
    pub glossy: f32,
    pub exponent: f32,
    pub mirror: Rgb,
    pub transmit: Rgb,
    /// Refracted direction (None when there is no transmission or under total reflection).
    refracted: Option<Vec3>,
    mirror_dir: Vec3,
    /// Choice probabilities of the four lobes (sum 1 unless the surface is black).
    p_diffuse: f32,
    p_glossy: f32,
    p_mirror: f32,
    /// A physically based model, which then answers every query.
    physical: Option<Physical>,
}

/// What a BSDF without delta lobes and without a physically based model is made of (the
/// Phong reading's diffuse and glossy lobes, Mitsuba's `diffuse`): the wavefront shades
/// vertices on such surfaces eight at a time from these.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhongParts {
    /// ρd.
    pub diffuse: Rgb,
    /// Shading and geometric normals on the viewer's side.
    pub normal: Vec3,
    pub geometric: Vec3,
    /// ρs and the Phong exponent (`glossy` 0: no glossy lobe).
    pub glossy: f32,
    pub exponent: f32,
    /// The mirror direction of the viewer's.
    pub mirror_dir: Vec3,
    /// The lobes' choice probabilities.
    pub p_diffuse: f32,
    pub p_glossy: f32,
}

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// `f · cos / pdf` (for delta lobes: the lobe's weight over its choice probability).
    pub weight: Rgb,
    /// Solid-angle pdf of the non-delta mixture; 0 for a delta lobe.
    pub pdf: f32,
    pub delta: bool,
}

impl Bsdf {
    /// The BSDF at a hit with shading normal `ns` and geometric normal `ng` (both already on
    /// the side of `wo`), `entering` when `wo` is outside the surface.
    pub fn new(m: &Material, albedo: Rgb, wo: Vec3, ns: Vec3, ng: Vec3, entering: bool) -> Bsdf {
        let cos_o = ns.dot(wo).clamp(0.0, 1.0);
        let mirror_dir = reflect(-wo, ns);
        let (mut mirror, mut transmit, phong, mut refracted);
        refracted = None;
        if let Some(f) = m.schlick(cos_o) {
            mirror = f;
            transmit = Rgb::ZERO;
            phong = Rgb::ONE - f;
        } else {
            let (eta_i, eta_t) = if entering { (1.0, m.ior) } else { (m.ior, 1.0) };
            let (mut k_refl, mut k_refr) = (m.reflectivity, m.transparency);
            if m.is_transparent() {
                refracted = refract(-wo, ns, eta_i / eta_t);
                let f = match refracted {
                    Some(_) if m.fresnel => fresnel_dielectric(cos_o, eta_i, eta_t),
                    Some(_) => 0.0,
                    None => 1.0,
                };
                k_refl = (m.reflectivity + m.transparency * f).min(1.0);
                k_refr = m.transparency * (1.0 - f);
            }
            mirror = Rgb::splat(k_refl);
            transmit = Rgb::splat(k_refr);
            phong = Rgb::splat((1.0 - m.reflectivity - m.transparency).clamp(0.0, 1.0));
        }
        if transmit == Rgb::ZERO {
            refracted = None;
        }
        // Energy conservation of the Phong pair.
        let (mut kd, mut ks) = (m.diffuse.max(0.0), m.specular.max(0.0));
        let total = kd * albedo.max_element() + ks;
        if total > 1.0 {
            kd /= total;
            ks /= total;
        }
        let diffuse = phong * albedo * kd;
        let glossy = ks * phong.element_sum() / 3.0;
        if refracted.is_none() {
            transmit = Rgb::ZERO;
        }
        if !mirror.is_finite() {
            mirror = Rgb::ZERO;
        }
        let (wd, wg, wm, wt) = (luminance(diffuse), glossy, luminance(mirror), luminance(transmit));
        let sum = wd + wg + wm + wt;
        let (p_diffuse, p_glossy, p_mirror) = if sum > 0.0 { (wd / sum, wg / sum, wm / sum) } else { (0.0, 0.0, 0.0) };
        Bsdf {
            normal: ns,
            geometric: ng,
            diffuse,
            glossy,
            exponent: m.shininess.max(0.0),
            mirror,
            transmit,
            refracted,
            mirror_dir,
            p_diffuse,
            p_glossy,
            p_mirror,
            physical: None,
        }
    }

    /// A Lambertian surface of reflectance `diffuse` with shading normal `normal` (on the
    /// viewer's side), reflecting toward every `wi` above it: `shading::lambertian_at`'s
    /// reading of Mitsuba's `diffuse`, which checks the shading frame alone (so the geometric
    /// normal is taken to be the shading one).
    pub fn lambertian(diffuse: Rgb, normal: Vec3) -> Bsdf {
        let p_diffuse = if diffuse.max_element() > 0.0 { 1.0 } else { 0.0 };
        Bsdf {
            normal,
            geometric: normal,
            diffuse,
            glossy: 0.0,
            exponent: 0.0,
            mirror: Rgb::ZERO,
            transmit: Rgb::ZERO,
            refracted: None,
            mirror_dir: Vec3::ZERO,
            p_diffuse,
            p_glossy: 0.0,
            p_mirror: 0.0,
            physical: None,
        }
    }

    /// This BSDF's [`PhongParts`] when it has neither delta lobes nor a physically based
    /// model (a Lambertian lobe, a glossy one, or both) and reflects something: every query
    /// then equals [`Bsdf::from_phong`]'s of those parts (what `integrator::phong_parts_at`
    /// finds without building the BSDF; a test holds the two together).
    #[cfg(test)]
    pub fn phong_parts(&self) -> Option<PhongParts> {
        let alone = self.physical.is_none()
            && self.mirror == Rgb::ZERO
            && self.transmit == Rgb::ZERO
            && self.p_mirror == 0.0
            && self.refracted.is_none()
            && self.p_non_delta() > 0.0;
        alone.then_some(PhongParts {
            diffuse: self.diffuse,
            normal: self.normal,
            geometric: self.geometric,
            glossy: self.glossy,
            exponent: self.exponent,
            mirror_dir: self.mirror_dir,
            p_diffuse: self.p_diffuse,
            p_glossy: self.p_glossy,
        })
    }

    /// The BSDF of a diffuse and a glossy lobe without delta lobes, from its parts.
    pub fn from_phong(p: &PhongParts) -> Bsdf {
        Bsdf {
            normal: p.normal,
            geometric: p.geometric,
            diffuse: p.diffuse,
            glossy: p.glossy,
            exponent: p.exponent,
            mirror: Rgb::ZERO,
            transmit: Rgb::ZERO,
            refracted: None,
            mirror_dir: p.mirror_dir,
            p_diffuse: p.p_diffuse,
            p_glossy: p.p_glossy,
            p_mirror: 0.0,
            physical: None,
        }
    }

    /// A physically based model at a hit whose geometric normal (on the viewer's side) is `ng`.
    pub fn physical(p: Physical, ng: Vec3) -> Bsdf {
        let base = Bsdf::lambertian(p.diffuse_albedo(), p.normal());
        // The model answers every query: the Phong reading's choice probabilities stay zero.
        Bsdf { geometric: ng, p_diffuse: 0.0, physical: Some(p), ..base }
    }

    /// Probability that sampling picks a delta lobe.
    #[inline]
    pub fn p_delta(&self) -> f32 {
        match &self.physical {
            Some(p) => p.p_delta(),
            None => (1.0 - self.p_diffuse - self.p_glossy).max(0.0),
        }
    }

    /// Probability that sampling picks the non-delta part.
    #[inline]
    pub fn p_non_delta(&self) -> f32 {
        match &self.physical {
            Some(p) => 1.0 - p.p_delta(),
            None => self.p_diffuse + self.p_glossy,
        }
    }

    pub fn has_non_delta(&self) -> bool {
        self.p_non_delta() > 0.0
    }

    /// Mostly a mirror or glass: the guide follows it to the next vertex (DESIGN.md §2).
    pub fn is_delta_dominant(&self) -> bool {
        self.p_delta() >= 0.5
    }

    /// Whether `wi` leaves on the reflecting side (by both normals: light from under the
    /// geometric surface is never reflected, whatever the shading normal says).
    #[inline]
    fn reflects(&self, wi: Vec3) -> Option<f32> {
        let cos = self.normal.dot(wi);
        (cos > 0.0 && self.geometric.dot(wi) > 0.0).then_some(cos)
    }

    #[inline]
    fn glossy_lobe(&self, wi: Vec3) -> f32 {
        let c = self.mirror_dir.dot(wi);
        if c <= 0.0 { 0.0 } else { super::pow::pow(c, self.exponent) }
    }

    /// The non-delta BSDF times the cosine, split in (diffuse part demodulated = cos/π,
    /// glossy part), for a direction `wi` toward the light.
    #[inline]
    pub fn eval_cos(&self, wi: Vec3) -> Rgb {
        if let Some(p) = &self.physical {
            return p.eval(wi);
        }
        self.phong_eval_cos(wi, &|| self.glossy_lobe(wi))
    }

    /// `(eval_cos(wi), pdf(wi))`, the same bits as the two calls, with a Phong glossy lobe's
    /// `cosⁿ α` ([`super::pow`]) evaluated once for both (light samples weighed by MIS, BSDF
    /// samples).
    #[inline]
    pub fn eval_cos_and_pdf(&self, wi: Vec3) -> (Rgb, f32) {
        if let Some(p) = &self.physical {
            return (p.eval(wi), p.pdf(wi));
        }
        let lobe = std::cell::OnceCell::new();
        let lobe = || *lobe.get_or_init(|| self.glossy_lobe(wi));
        (self.phong_eval_cos(wi, &lobe), self.phong_pdf(wi, &lobe))
    }

    /// The Phong `eval_cos`, the glossy lobe's value toward `wi` from `lobe` (asked only when
    /// there is a glossy lobe and `wi` is reflected).
    #[inline]
    fn phong_eval_cos(&self, wi: Vec3, lobe: &impl Fn() -> f32) -> Rgb {
        let Some(cos) = self.reflects(wi) else { return Rgb::ZERO };
        let mut f = self.diffuse * FRAC_1_PI;
        if self.glossy > 0.0 {
            f += Rgb::splat(self.glossy * (self.exponent + 2.0) / TAU * lobe());
        }
        f * cos
    }

    /// The Phong `pdf`, the glossy lobe from `lobe` as in [`Bsdf::phong_eval_cos`].
    #[inline]
    fn phong_pdf(&self, wi: Vec3, lobe: &impl Fn() -> f32) -> f32 {
        let mut p = 0.0;
        if self.p_diffuse > 0.0 {
            p += self.p_diffuse * self.pdf_diffuse(wi);
        }
        if self.p_glossy > 0.0 {
            p += self.p_glossy * ((self.exponent + 1.0) / TAU * lobe());
        }
        p
    }

    /// Everything of `eval_cos` but the diffuse lobe.
    #[inline]
    pub fn eval_glossy_cos(&self, wi: Vec3) -> Rgb {
        if let Some(p) = &self.physical {
            return p.eval(wi) - self.diffuse * p.eval_diffuse(wi);
        }
        // A Phong material without a glossy lobe (every diffuse surface) skips the lobe's power.
        if self.glossy <= 0.0 {
            return Rgb::ZERO;
        }
        let Some(cos) = self.reflects(wi) else { return Rgb::ZERO };
        Rgb::splat(self.glossy * (self.exponent + 2.0) / TAU * self.glossy_lobe(wi) * cos)
    }

    /// The diffuse lobe's shape toward `wi` with the cosine: the diffuse lobe of `eval_cos`
    /// is `diffuse × diffuse_shape` (Phong: `cos/π`).
    #[inline]
    pub fn diffuse_shape(&self, wi: Vec3) -> f32 {
        match &self.physical {
            Some(p) => p.eval_diffuse(wi),
            None => self.normal.dot(wi).max(0.0) * FRAC_1_PI,
        }
    }

    #[inline]
    fn pdf_diffuse(&self, wi: Vec3) -> f32 {
        self.reflects(wi).map_or(0.0, |c| c * FRAC_1_PI)
    }

    /// Solid-angle pdf of sampling `wi` from the whole BSDF (its non-delta part).
    pub fn pdf(&self, wi: Vec3) -> f32 {
        if let Some(p) = &self.physical {
            return p.pdf(wi);
        }
        self.phong_pdf(wi, &|| self.glossy_lobe(wi))
    }

    /// Solid-angle pdf of [`Bsdf::sample_non_delta`].
    #[cfg(test)]
    pub fn pdf_non_delta(&self, wi: Vec3) -> f32 {
        let nd = self.p_non_delta();
        if nd <= 0.0 { 0.0 } else { self.pdf(wi) / nd }
    }

    fn sample_diffuse(&self, u: Vec2) -> Vec3 {
        Frame::from_z(self.normal).to_world(sample_cosine_hemisphere(u))
    }

    fn sample_glossy(&self, u: Vec2) -> Vec3 {
        let cos_a = super::pow::pow(u.x, 1.0 / (self.exponent + 1.0));
        let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
        let phi = TAU * u.y;
        Frame::from_z(self.mirror_dir).to_world(Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a))
    }

    /// Sample every lobe (delta lobes included) by its choice probability.
    pub fn sample(&self, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if let Some(p) = &self.physical {
            let (wi, weight, pdf, delta) = p.sample(u_lobe, u)?;
            return Some(BsdfSample { wi, weight, pdf, delta });
        }
        if u_lobe < self.p_non_delta() {
            return self.non_delta_direction(u_lobe / self.p_non_delta(), u, true);
        }
        let u_delta = u_lobe - self.p_non_delta();
        if u_delta < self.p_mirror || self.refracted.is_none() {
            if self.p_mirror <= 0.0 {
                return None;
            }
            return Some(BsdfSample {
                wi: self.mirror_dir,
                weight: self.mirror / self.p_mirror,
                pdf: 0.0,
                delta: true,
            });
        }
        let p_transmit = self.p_delta() - self.p_mirror;
        let wi = self.refracted?;
        (p_transmit > 0.0).then(|| BsdfSample { wi, weight: self.transmit / p_transmit, pdf: 0.0, delta: true })
    }

    /// A delta lobe, given `u_lobe ≥ p_non_delta()` (the delta part was chosen): weight = the
    /// lobe's value over the probability of choosing it (the delta part's included). A
    /// physically based model's delta lobes are chosen in proportion to their luminance.
    pub fn sample_delta(&self, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        let Some(_) = &self.physical else { return self.sample(u_lobe, u) };
        let p_delta = self.p_delta();
        if p_delta <= 0.0 {
            return None;
        }
        let lobes = self.delta_lobes();
        let lum = lobes.map(|l| l.map_or(0.0, |(_, w)| luminance(w).max(0.0)));
        let total: f32 = lum.iter().sum();
        if total.is_nan() || total <= 0.0 {
            return None;
        }
        let mut v = ((u_lobe - self.p_non_delta()) / p_delta).clamp(0.0, 1.0) * total;
        let mut k = lum.iter().rposition(|&l| l > 0.0)?;
        for (i, &l) in lum.iter().enumerate() {
            if l > 0.0 && v < l {
                k = i;
                break;
            }
            v -= l;
        }
        let (wi, w) = lobes[k]?;
        Some(BsdfSample { wi, weight: w * (total / (lum[k] * p_delta)), pdf: 0.0, delta: true })
    }

    /// Sample the non-delta mixture only (the guide vertex's indirect ray): `weight` is the
    /// whole non-delta `f · cos / pdf`.
    pub fn sample_non_delta(&self, u_lobe: f32, u: Vec2) -> Option<BsdfSample> {
        if !self.has_non_delta() {
            return None;
        }
        if let Some(p) = &self.physical {
            let (wi, weight, pdf) = p.sample_non_delta(u_lobe, u)?;
            return Some(BsdfSample { wi, weight, pdf, delta: false });
        }
        self.non_delta_direction(u_lobe, u, false)
    }

    /// Pick diffuse or glossy with `u_lobe` ∈ [0,1) over the non-delta part. With
    /// `all_lobes` the delta lobes competed for the choice, so the pdf is the mixture's
    /// `p_d pdf_d + p_g pdf_g`; otherwise it is that over `p_d + p_g`.
    fn non_delta_direction(&self, u_lobe: f32, u: Vec2, all_lobes: bool) -> Option<BsdfSample> {
        let nd = self.p_non_delta();
        let wi = if u_lobe < self.p_diffuse / nd { self.sample_diffuse(u) } else { self.sample_glossy(u) };
        self.reflects(wi)?;
        let (f, pdf) = self.eval_cos_and_pdf(wi);
        let pdf = if all_lobes { pdf } else { pdf / nd };
        if !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(BsdfSample { wi, weight: f / pdf, pdf, delta: false })
    }

    /// Sample what is not diffuse among the non-delta lobes: direction and its
    /// `f_glossy · cos / pdf` (Phong: the glossy lobe alone; a physically based model: its
    /// non-delta lobes sampled together, weighted by their non-diffuse part).
    pub fn sample_glossy_only(&self, u_lobe: f32, u: Vec2) -> Option<(Vec3, Rgb)> {
        if let Some(p) = &self.physical {
            let (wi, _, pdf) = p.sample_non_delta(u_lobe, u)?;
            let w = self.eval_glossy_cos(wi) / pdf;
            return (w.max_element() > 0.0).then_some((wi, w));
        }
        if self.glossy <= 0.0 {
            return None;
        }
        let wi = self.sample_glossy(u);
        let cos = self.reflects(wi)?;
        Some((wi, Rgb::splat(self.glossy * (self.exponent + 2.0) / (self.exponent + 1.0) * cos)))
    }

    /// The delta lobes as (direction, weight) pairs, for deterministic tracing.
    pub fn delta_lobes(&self) -> [Option<(Vec3, Rgb)>; DELTA_LOBES] {
        if let Some(p) = &self.physical {
            return p.delta_lobes();
        }
        let m = (self.mirror.max_element() > 0.0).then_some((self.mirror_dir, self.mirror));
        let t = self.refracted.map(|d| (d, self.transmit));
        let mut out = [None; DELTA_LOBES];
        out[0] = m;
        out[1] = t;
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::chi2::chi2_sphere;
    use glint_core::random::SampleStream;

    fn bsdf(m: &Material) -> Bsdf {
        let wo = Vec3::new(0.3, 0.2, 0.9).normalize();
        Bsdf::new(m, m.colour, wo, Vec3::Z, Vec3::Z, true)
    }

    fn samples(b: &Bsdf, n: usize, non_delta: bool) -> Vec<Vec3> {
        let mut out = Vec::new();
        for i in 0..n {
            let mut s = SampleStream::new(i as u64, 0, 7);
            let (ul, u) = (s.next_1d(), s.next_2d());
            let r = if non_delta { b.sample_non_delta(ul, u) } else { b.sample(ul, u) };
            if let Some(r) = r.filter(|r| !r.delta) {
                out.push(r.wi);
            }
        }
        out
    }

    #[test]
    fn mixture_sampling_matches_its_pdf() {
        let m = Material { diffuse: 0.5, specular: 0.4, shininess: 20.0, reflectivity: 0.2, ..Material::default() };
        let b = bsdf(&m);
        let n = 200_000;
        let s = samples(&b, n, false);
        let out = chi2_sphere(&s, n, |d| b.pdf(d) as f64, 16, 32);
        assert!(out.p_value > 0.01 / 2.0, "{out:?}");
        let s = samples(&b, n, true);
        let out = chi2_sphere(&s, n, |d| b.pdf_non_delta(d) as f64, 16, 32);
        assert!(out.p_value > 0.01 / 2.0, "{out:?}");
    }

    #[test]
    fn weights_are_f_cos_over_pdf_and_energy_is_conserved() {
        let m = Material { colour: Rgb::ONE, diffuse: 0.9, specular: 0.7, shininess: 8.0, ..Material::default() };
        let b = bsdf(&m);
        // Albedo by Monte Carlo: E[weight] ≤ 1.
        let n = 100_000;
        let mut sum = Rgb::ZERO;
        for i in 0..n {
            let mut s = SampleStream::new(i, 1, 3);
            if let Some(r) = b.sample(s.next_1d(), s.next_2d()) {
                assert!((r.weight - b.eval_cos(r.wi) / r.pdf).abs().max_element() < 1e-4);
                sum += r.weight;
            }
        }
        let albedo = sum / n as f32;
        assert!(albedo.max_element() <= 1.0 + 0.01, "{albedo}");
        assert!(albedo.min_element() > 0.5, "{albedo}");
    }

    #[test]
    fn glass_splits_by_fresnel_and_mirror_is_delta() {
        let glass = Material { transparency: 1.0, diffuse: 0.0, specular: 0.0, ..Material::default() };
        let b = bsdf(&glass);
        assert!(b.is_delta_dominant() && !b.has_non_delta());
        let [m, t, ..] = b.delta_lobes();
        let (m, t) = (m.expect("reflects"), t.expect("refracts"));
        assert!((m.1.x + t.1.x - 1.0).abs() < 1e-6 && m.1.x < 0.1);
        let mirror = Material { reflectivity: 1.0, ..Material::default() };
        let b = bsdf(&mirror);
        let s = b.sample(0.5, Vec2::splat(0.5)).expect("mirror");
        assert!(s.delta && (s.weight - Rgb::ONE).abs().max_element() < 1e-6);
    }
}
