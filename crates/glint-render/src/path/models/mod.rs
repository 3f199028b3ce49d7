//! Physically based BSDF models with Mitsuba 3's semantics (src/bsdfs/*.cpp of
//! mitsuba-renderer/mitsuba3): the path tracer's reading of [`glint_scene::bsdf`] once every
//! texture is read at a hit. [`Model`] is one leaf model; [`Mixture`] a flattened tree of
//! `blendbsdf` and `mask` nodes over up to four of them.
//!
//! Conventions: vectors are in the local shading frame (z = shading normal, x = the tangent
//! ∂p/∂u), unit length. Names follow glint's path tracer, not Mitsuba: `wo` points toward the
//! viewer (Mitsuba's `si.wi`), `wi` toward the light (Mitsuba's `wo`). `eval` includes the
//! cosine `|cos θi|` as Mitsuba's does; `pdf` is the solid-angle density with which `sample`
//! returns `wi` through a non-delta lobe (lobe choice included); a delta lobe's sample weight is
//! its value over its choice probability. Transmission is in radiance mode (scaled by `1/η²`).
//!
//! One-sided models (diffuse, conductors, plastics, `principled` without transmission) are zero
//! for `wo.z ≤ 0`; dielectrics and thin models work from both sides. Two-sidedness, bump and
//! normal maps and the shading frame are the caller's. The module depends on glint-core and
//! glint-scene's `Distribution` only.

mod conductor;
mod dielectric;
mod fresnel;
mod microfacet;
#[cfg(test)]
mod mitsuba_reference;
mod plastic;
mod principled;

pub use glint_scene::presets::{conductor_preset, ior_preset};
pub use microfacet::Microfacet;
pub use principled::PrincipledParams;

use glint_core::{Rgb, Vec2, Vec3};
use microfacet::{cosine_hemisphere, cosine_hemisphere_pdf};
use std::f32::consts::FRAC_1_PI;

/// A leaf scattering model with every texture already read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Model {
    /// `diffuse`: `ρ/π`.
    Diffuse { reflectance: Rgb },
    /// `conductor`: a mirror times the conductor Fresnel term.
    Conductor { eta: Rgb, k: Rgb, specular_reflectance: Rgb },
    /// `roughconductor`.
    RoughConductor { micro: Microfacet, eta: Rgb, k: Rgb, specular_reflectance: Rgb },
    /// `dielectric`: `eta` is inside over outside.
    Dielectric { eta: f32, specular_reflectance: Rgb, specular_transmittance: Rgb },
    /// `thindielectric`.
    ThinDielectric { eta: f32, specular_reflectance: Rgb, specular_transmittance: Rgb },
    /// `roughdielectric`.
    RoughDielectric { micro: Microfacet, eta: f32, specular_reflectance: Rgb, specular_transmittance: Rgb },
    /// `plastic`.
    Plastic { diffuse_reflectance: Rgb, specular_reflectance: Rgb, eta: f32, nonlinear: bool },
    /// `roughplastic` (isotropic: α = `micro.alpha_u`).
    RoughPlastic { micro: Microfacet, diffuse_reflectance: Rgb, specular_reflectance: Rgb, eta: f32, nonlinear: bool },
    /// `principled`, or `principledthin` with `thin`.
    Principled(PrincipledParams),
}

/// A sampled direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Direction toward the light.
    pub wi: Vec3,
    /// `eval / pdf`; for a delta lobe its value over its choice probability.
    pub weight: Rgb,
    /// Solid-angle pdf of the non-delta lobes; 0 for a delta lobe.
    pub pdf: f32,
    pub delta: bool,
}

impl Sample {
    fn delta(wi: Vec3, weight: Rgb) -> Sample {
        Sample { wi, weight, pdf: 0.0, delta: true }
    }

    /// A non-delta sample, or none when its colourless part `shape` or its pdf vanish (a
    /// direction Mitsuba returns with zero weight).
    fn glossy(wi: Vec3, weight: Rgb, shape: f32, pdf: f32) -> Option<Sample> {
        (shape > 0.0 && pdf > 0.0 && pdf.is_finite() && weight.is_finite()).then_some(Sample {
            wi,
            weight,
            pdf,
            delta: false,
        })
    }
}

impl Model {
    fn smooth_plastic(&self) -> Option<plastic::Smooth> {
        match *self {
            Model::Plastic { diffuse_reflectance, specular_reflectance, eta, nonlinear } => {
                Some(plastic::Smooth { diffuse: diffuse_reflectance, specular: specular_reflectance, eta, nonlinear })
            }
            _ => None,
        }
    }

    fn rough_plastic(&self) -> Option<plastic::Rough> {
        match *self {
            Model::RoughPlastic { micro, diffuse_reflectance, specular_reflectance, eta, nonlinear } => {
                Some(plastic::Rough {
                    micro,
                    diffuse: diffuse_reflectance,
                    specular: specular_reflectance,
                    eta,
                    nonlinear,
                })
            }
            _ => None,
        }
    }

    /// `f · |cos θi|` of the non-delta lobes (Mitsuba's `eval`).
    #[must_use]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        match self {
            Model::Diffuse { reflectance } => *reflectance * self.eval_diffuse(wo, wi),
            Model::Conductor { .. } | Model::Dielectric { .. } | Model::ThinDielectric { .. } => Rgb::ZERO,
            Model::RoughConductor { micro, eta, k, specular_reflectance } => {
                conductor::rough_eval(micro, *eta, *k, *specular_reflectance, wo, wi)
            }
            Model::RoughDielectric { micro, eta, specular_reflectance, specular_transmittance } => {
                dielectric::rough_eval(micro, *eta, *specular_reflectance, *specular_transmittance, wo, wi)
            }
            Model::Plastic { .. } => self.smooth_plastic().map_or(Rgb::ZERO, |p| p.eval(wo, wi)),
            Model::RoughPlastic { .. } => self.rough_plastic().map_or(Rgb::ZERO, |p| p.eval(wo, wi)),
            Model::Principled(p) => p.eval(wo, wi),
        }
    }

    /// Solid-angle density with which [`Model::sample`] returns `wi` through a non-delta lobe.
    #[must_use]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Model::Diffuse { .. } => {
                if wo.z > 0.0 && wi.z > 0.0 {
                    cosine_hemisphere_pdf(wi)
                } else {
                    0.0
                }
            }
            Model::Conductor { .. } | Model::Dielectric { .. } | Model::ThinDielectric { .. } => 0.0,
            Model::RoughConductor { micro, .. } => conductor::rough_pdf(micro, wo, wi),
            Model::RoughDielectric { micro, eta, .. } => dielectric::rough_pdf(micro, *eta, wo, wi),
            Model::Plastic { .. } => self.smooth_plastic().map_or(0.0, |p| p.pdf(wo, wi)),
            Model::RoughPlastic { .. } => self.rough_plastic().map_or(0.0, |p| p.pdf(wo, wi)),
            Model::Principled(p) => p.pdf(wo, wi),
        }
    }

    /// Sample a lobe with `u_lobe` and a direction in it with `u` (Mitsuba's `sample`).
    #[must_use]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Sample> {
        match self {
            Model::Diffuse { reflectance } => {
                if wo.z <= 0.0 {
                    return None;
                }
                let wi = cosine_hemisphere(u);
                let pdf = cosine_hemisphere_pdf(wi);
                Sample::glossy(wi, *reflectance, pdf, pdf)
            }
            Model::Conductor { eta, k, specular_reflectance } => {
                conductor::smooth_lobe(wo, *eta, *k, *specular_reflectance).map(|(wi, w)| Sample::delta(wi, w))
            }
            Model::RoughConductor { micro, eta, k, specular_reflectance } => {
                conductor::rough_sample(micro, *eta, *k, *specular_reflectance, wo, u)
            }
            Model::Dielectric { eta, specular_reflectance, specular_transmittance } => {
                dielectric::smooth_sample(wo, *eta, *specular_reflectance, *specular_transmittance, u_lobe)
            }
            Model::ThinDielectric { eta, specular_reflectance, specular_transmittance } => {
                dielectric::thin_sample(wo, *eta, *specular_reflectance, *specular_transmittance, u_lobe)
            }
            Model::RoughDielectric { micro, eta, specular_reflectance, specular_transmittance } => {
                dielectric::rough_sample(micro, *eta, *specular_reflectance, *specular_transmittance, wo, u_lobe, u)
            }
            Model::Plastic { .. } => self.smooth_plastic()?.sample(wo, u_lobe, u),
            Model::RoughPlastic { .. } => self.rough_plastic()?.sample(wo, u_lobe, u),
            Model::Principled(p) => p.sample(wo, u_lobe, u),
        }
    }

    /// Probability that [`Model::sample`] picks a delta lobe.
    #[must_use]
    pub fn p_delta(&self, wo: Vec3) -> f32 {
        match self {
            Model::Conductor { .. } if wo.z > 0.0 => 1.0,
            Model::Dielectric { .. } | Model::ThinDielectric { .. } => 1.0,
            Model::Plastic { .. } => self.smooth_plastic().map_or(0.0, |p| p.p_delta(wo)),
            _ => 0.0,
        }
    }

    /// Each smooth lobe's direction and full weight (value, not over a choice probability),
    /// for tracing them deterministically.
    #[must_use]
    pub fn delta_lobes(&self, wo: Vec3) -> [Option<(Vec3, Rgb)>; 2] {
        match self {
            Model::Conductor { eta, k, specular_reflectance } => {
                [conductor::smooth_lobe(wo, *eta, *k, *specular_reflectance), None]
            }
            Model::Dielectric { eta, specular_reflectance, specular_transmittance } => {
                dielectric::smooth_lobes(wo, *eta, *specular_reflectance, *specular_transmittance)
            }
            Model::ThinDielectric { eta, specular_reflectance, specular_transmittance } => {
                dielectric::thin_lobes(wo, *eta, *specular_reflectance, *specular_transmittance)
            }
            Model::Plastic { .. } => [self.smooth_plastic().and_then(|p| p.delta_lobe(wo)), None],
            _ => [None, None],
        }
    }

    /// The colour of the Lambert-like lobe seen from `wo` (0 if none): that lobe's eval is
    /// `diffuse_albedo(wo) * eval_diffuse(wo, wi)`.
    #[must_use]
    pub fn diffuse_albedo(&self, wo: Vec3) -> Rgb {
        match self {
            Model::Diffuse { reflectance } => {
                if wo.z > 0.0 {
                    *reflectance
                } else {
                    Rgb::ZERO
                }
            }
            Model::Plastic { .. } => self.smooth_plastic().map_or(Rgb::ZERO, |p| p.diffuse_albedo(wo)),
            Model::RoughPlastic { .. } => self.rough_plastic().map_or(Rgb::ZERO, |p| p.diffuse_albedo(wo)),
            Model::Principled(p) => p.diffuse_albedo(wo),
            _ => Rgb::ZERO,
        }
    }

    /// The scalar shape (cosine included) of the Lambert-like lobe.
    #[must_use]
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Model::Diffuse { .. } if wo.z > 0.0 && wi.z > 0.0 => FRAC_1_PI * wi.z,
            Model::Plastic { .. } => self.smooth_plastic().map_or(0.0, |p| p.eval_diffuse(wo, wi)),
            Model::RoughPlastic { .. } => self.rough_plastic().map_or(0.0, |p| p.eval_diffuse(wo, wi)),
            Model::Principled(p) => p.eval_diffuse(wo, wi),
            _ => 0.0,
        }
    }
}

/// Models a [`Mixture`] holds at most.
pub const MIXTURE_TERMS: usize = 4;

/// Distinct delta directions a [`Mixture`] can have: one mirror, one straight-through, one
/// refraction per term.
pub const MIXTURE_DELTA_LOBES: usize = MIXTURE_TERMS + 2;

/// A mixture is full.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("a BSDF mixture holds at most {MIXTURE_TERMS} models")]
pub struct MixtureFull;

/// A flattened tree of `blendbsdf` and `mask` nodes: weighted models plus light passing
/// straight through (a mask's `1 − opacity`, a delta lobe `wi = −wo` of weight 1). Mitsuba's
/// trees give weights summing to 1; choices are made in proportion to the weights (over their
/// sum), as `blendbsdf` and `mask` sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mixture {
    terms: [(f32, Model); MIXTURE_TERMS],
    len: usize,
    pass_through: f32,
}

impl Default for Mixture {
    fn default() -> Self {
        Mixture { terms: [(0.0, Model::Diffuse { reflectance: Rgb::ZERO }); MIXTURE_TERMS], len: 0, pass_through: 0.0 }
    }
}

impl From<Model> for Mixture {
    fn from(model: Model) -> Self {
        let mut m = Mixture::default();
        m.terms[0] = (1.0, model);
        m.len = 1;
        m
    }
}

impl Mixture {
    /// An empty mixture (black, opaque).
    #[must_use]
    pub fn new() -> Self {
        Mixture::default()
    }

    /// Add a weighted model.
    ///
    /// # Errors
    /// [`MixtureFull`] when it already holds [`MIXTURE_TERMS`] models.
    pub fn push(&mut self, weight: f32, model: Model) -> Result<(), MixtureFull> {
        if self.len == MIXTURE_TERMS {
            return Err(MixtureFull);
        }
        self.terms[self.len] = (weight, model);
        self.len += 1;
        Ok(())
    }

    #[must_use]
    pub fn terms(&self) -> &[(f32, Model)] {
        &self.terms[..self.len]
    }

    #[must_use]
    pub fn pass_through(&self) -> f32 {
        self.pass_through
    }

    pub fn set_pass_through(&mut self, weight: f32) {
        self.pass_through = weight;
    }

    /// Mitsuba's `blendbsdf`: `(1 − weight) a + weight b`.
    ///
    /// # Errors
    /// [`MixtureFull`] when `a` and `b` hold more than [`MIXTURE_TERMS`] models together.
    pub fn blend(a: &Mixture, b: &Mixture, weight: f32) -> Result<Mixture, MixtureFull> {
        let mut out = Mixture::new();
        for (w, m) in a.terms() {
            out.push(w * (1.0 - weight), *m)?;
        }
        for (w, m) in b.terms() {
            out.push(w * weight, *m)?;
        }
        out.pass_through = a.pass_through * (1.0 - weight) + b.pass_through * weight;
        Ok(out)
    }

    /// Mitsuba's `mask`: `opacity · inner`, the rest passing straight through.
    #[must_use]
    pub fn mask(inner: &Mixture, opacity: f32) -> Mixture {
        let mut out = *inner;
        for t in &mut out.terms[..out.len] {
            t.0 *= opacity;
        }
        out.pass_through = inner.pass_through * opacity + (1.0 - opacity);
        out
    }

    fn total(&self) -> f32 {
        self.terms().iter().map(|t| t.0).sum::<f32>() + self.pass_through
    }

    #[must_use]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        self.terms().iter().filter(|t| t.0 > 0.0).map(|(w, m)| m.eval(wo, wi) * *w).sum()
    }

    #[must_use]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let total = self.total();
        if total <= 0.0 {
            return 0.0;
        }
        self.terms().iter().filter(|t| t.0 > 0.0).map(|(w, m)| m.pdf(wo, wi) * (w / total)).sum()
    }

    /// Pick a term by its weight and sample it; a non-delta direction is weighted by the whole
    /// mixture (`eval / pdf`, one-sample MIS over the terms as `blendbsdf` does).
    #[must_use]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Sample> {
        let total = self.total();
        if total <= 0.0 {
            return None;
        }
        let mut x = u_lobe * total;
        for (w, m) in self.terms() {
            if *w <= 0.0 {
                continue;
            }
            if x < *w {
                let s = m.sample(wo, (x / w).min(1.0 - f32::EPSILON / 2.0), u)?;
                if s.delta {
                    return Some(Sample { weight: s.weight * total, ..s });
                }
                if self.len == 1 && self.pass_through == 0.0 {
                    return Some(s);
                }
                let pdf = self.pdf(wo, s.wi);
                let weight = self.eval(wo, s.wi) / pdf;
                return (pdf > 0.0 && weight.is_finite()).then_some(Sample { weight, pdf, ..s });
            }
            x -= w;
        }
        (self.pass_through > 0.0).then(|| Sample::delta(-wo, Rgb::splat(total)))
    }

    /// Probability that [`Mixture::sample`] picks a delta lobe (pass-through included).
    #[must_use]
    pub fn p_delta(&self, wo: Vec3) -> f32 {
        let total = self.total();
        if total <= 0.0 {
            return 0.0;
        }
        let terms: f32 = self.terms().iter().filter(|t| t.0 > 0.0).map(|(w, m)| w * m.p_delta(wo)).sum();
        (terms + self.pass_through) / total
    }

    /// The delta lobes of every term and the pass-through, those with the same direction
    /// merged (mirrors all reflect to `(−x, −y, z)`; thin sheets and masks pass to `−wo`).
    #[must_use]
    pub fn delta_lobes(&self, wo: Vec3) -> [Option<(Vec3, Rgb)>; MIXTURE_DELTA_LOBES] {
        let mut out = [None; MIXTURE_DELTA_LOBES];
        let mut add = |dir: Vec3, weight: Rgb| {
            for slot in out.iter_mut() {
                match slot {
                    Some((d, w)) if *d == dir => {
                        *w += weight;
                        return;
                    }
                    None => {
                        *slot = Some((dir, weight));
                        return;
                    }
                    _ => {}
                }
            }
        };
        for (w, m) in self.terms() {
            for (dir, weight) in m.delta_lobes(wo).into_iter().flatten() {
                add(dir, weight * *w);
            }
        }
        if self.pass_through > 0.0 {
            add(-wo, Rgb::splat(self.pass_through));
        }
        out
    }

    /// The summed colours of the terms' diffuse lobes.
    #[must_use]
    pub fn diffuse_albedo(&self, wo: Vec3) -> Rgb {
        self.terms().iter().map(|(w, m)| m.diffuse_albedo(wo) * *w).sum()
    }

    /// The diffuse lobes' shape: exact (`diffuse_albedo · eval_diffuse` = the diffuse lobes'
    /// eval) when one term has a diffuse lobe or all shapes agree; otherwise their average
    /// weighted by the luminance of each term's albedo.
    #[must_use]
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> f32 {
        let (mut num, mut den) = (0.0, 0.0);
        for (w, m) in self.terms() {
            let a = glint_core::colour::luminance(m.diffuse_albedo(wo)) * w;
            if a > 0.0 {
                num += a * m.eval_diffuse(wo, wi);
                den += a;
            }
        }
        if den > 0.0 { num / den } else { 0.0 }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use glint_core::chi2::{chi2_sphere, significance_level};
    use glint_core::random::SampleStream;

    /// Outgoing directions of the tests (below the surface too with `both_sides`).
    pub fn directions_out(both_sides: bool) -> Vec<Vec3> {
        let mut v =
            vec![Vec3::new(0.0, 0.0, 1.0), Vec3::new(0.4, 0.3, 0.8).normalize(), Vec3::new(-0.7, 0.5, 0.2).normalize()];
        if both_sides {
            v.push(Vec3::new(0.3, -0.2, -0.9).normalize());
            v.push(Vec3::new(-0.8, -0.3, -0.35).normalize());
        }
        v
    }

    /// For `model` seen from `wo`: χ² of its non-delta samples against `pdf` (as one of `tests`
    /// tests), non-delta weights equal to `eval / pdf`, the Monte-Carlo albedo at most 1 (with
    /// transmitted weights unscaled by η²) and, with `reciprocal`, `f` symmetric.
    pub fn check_model(model: &Model, wo: Vec3, tests: usize, reciprocal: bool) {
        // Mitsuba's roughdielectric, sampling all normals from a widened distribution, weights
        // a sample by G·(wo·m)/(cos θo cos θm), leaving out D/D_widened: that weight is not
        // eval/pdf. glint keeps Mitsuba's weight (samples_match_mitsuba checks it).
        let exact_weight = !matches!(model, Model::RoughDielectric { micro, .. } if !micro.sample_visible);
        // Burley's retro-reflection and fake subsurface (`flatness`) add energy at grazing
        // angles (Burley 2012, §5.3; 1.16 for a red base seen at cos θ = 0.23): a looser bound.
        let max_albedo = if matches!(model, Model::Principled(_)) { 1.25 } else { 1.03 };
        check_sampler(
            &format!("{model:?}"),
            wo,
            tests,
            |ul, u| model.sample(wo, ul, u),
            |wi| model.pdf(wo, wi),
            |wi| model.eval(wo, wi),
            Checks { unscale_transmission: unscale(model, wo), exact_weight, max_albedo },
        );
        if reciprocal {
            let mut s = SampleStream::new(5, 5, 5);
            for _ in 0..64 {
                let wi = microfacet::cosine_hemisphere(s.next_2d());
                if wi.z < 1e-3 || wo.z < 1e-3 {
                    continue;
                }
                let a = model.eval(wo, wi) / wi.z;
                let b = model.eval(wi, wo) / wo.z;
                assert!(
                    (a - b).abs().max_element() <= 2e-3 * a.max_element().max(b.max_element()).max(1e-3),
                    "{model:?} not reciprocal: wo {wo} wi {wi}: {a} vs {b}"
                );
            }
        }
    }

    /// The factor undoing the radiance scaling of transmitted weights (for the energy test).
    fn unscale(model: &Model, wo: Vec3) -> f32 {
        match model {
            Model::RoughDielectric { eta, .. } | Model::Dielectric { eta, .. } => {
                if wo.z > 0.0 {
                    eta * eta
                } else {
                    1.0 / (eta * eta)
                }
            }
            Model::Principled(p) if !p.thin => {
                if wo.z > 0.0 {
                    p.eta * p.eta
                } else {
                    1.0 / (p.eta * p.eta)
                }
            }
            _ => 1.0,
        }
    }

    /// What [`check_sampler`] checks besides χ².
    pub struct Checks {
        /// Factor applied to transmitted weights before summing the albedo (undoing `1/η²`).
        pub unscale_transmission: f32,
        /// Whether non-delta weights must equal eval/pdf.
        pub exact_weight: bool,
        /// Largest Monte-Carlo albedo allowed.
        pub max_albedo: f32,
    }

    pub fn check_sampler(
        name: &str,
        wo: Vec3,
        tests: usize,
        sample: impl Fn(f32, Vec2) -> Option<Sample>,
        pdf: impl Fn(Vec3) -> f32,
        eval: impl Fn(Vec3) -> Rgb,
        checks: Checks,
    ) {
        let n = 40_000;
        let mut dirs = Vec::with_capacity(n);
        let mut albedo = Rgb::ZERO;
        for i in 0..n {
            let mut s = SampleStream::new(i as u64, 17, 23);
            let (ul, u) = (s.next_1d(), s.next_2d());
            let Some(r) = sample(ul, u) else { continue };
            let t = if r.wi.z * wo.z < 0.0 { checks.unscale_transmission } else { 1.0 };
            albedo += r.weight * t;
            assert!((r.wi.length() - 1.0).abs() < 1e-3, "{name}: wi {} not unit", r.wi);
            if r.delta {
                continue;
            }
            let p = pdf(r.wi);
            assert!(
                (r.pdf - p).abs() <= 2e-3 * p.max(1e-3),
                "{name}: wo {wo} wi {}: sample pdf {} vs pdf {p}",
                r.wi,
                r.pdf
            );
            let expected = eval(r.wi) / p;
            assert!(
                !checks.exact_weight
                    || (r.weight - expected).abs().max_element() <= 2e-3 * expected.max_element().max(1.0),
                "{name}: wo {wo} wi {}: weight {} vs eval/pdf {expected}",
                r.wi,
                r.weight
            );
            dirs.push(r.wi);
        }
        let albedo = albedo / n as f32;
        assert!(albedo.max_element() <= checks.max_albedo, "{name}: wo {wo}: albedo {albedo}");
        // The non-delta draws against the pdf; the delta draws count as draws that return no
        // direction, so the pdf must integrate to the non-delta share.
        let out = chi2_sphere(&dirs, n, |d| f64::from(pdf(d)), 12, 24);
        assert!(out.p_value > significance_level(tests), "{name}: wo {wo}: {out}");
    }

    fn close(a: f32, b: f32, rel: f32) -> bool {
        (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-5
    }

    /// eval and pdf of every model at fixed directions equal Mitsuba 3's (mitsuba_values.py).
    #[test]
    fn eval_and_pdf_match_mitsuba() {
        let cases = mitsuba_reference::eval_cases();
        assert!(cases.len() > 400);
        let mut failures = Vec::new();
        for (model, wo, wi, eval, pdf) in cases {
            let (e, p) = (model.eval(wo, wi), model.pdf(wo, wi));
            // Mitsuba's principled keeps a pdf from inside a surface with no transmission,
            // where its eval and sample are zero; glint's is zero there (module doc).
            let unused_pdf = matches!(model, Model::Principled(q) if !q.thin && q.spec_trans == 0.0 && wo.z < 0.0);
            let pdf_ok = close(p, pdf, 1e-3) || (unused_pdf && p == 0.0);
            if !(close(e.x, eval.x, 1e-3) && close(e.y, eval.y, 1e-3) && close(e.z, eval.z, 1e-3) && pdf_ok) {
                failures.push(format!("{model:?}\n  wo {wo} wi {wi}: eval {e} vs {eval}, pdf {p} vs {pdf}"));
            }
        }
        assert!(failures.is_empty(), "{} mismatches:\n{}", failures.len(), failures.join("\n"));
    }

    /// Samples drawn with the same random numbers equal Mitsuba 3's (direction, weight, pdf).
    #[test]
    fn samples_match_mitsuba() {
        let cases = mitsuba_reference::sample_cases();
        assert!(cases.len() > 100);
        let mut failures = Vec::new();
        for (model, wo, u_lobe, u, wi, weight, pdf) in cases {
            let s = model.sample(wo, u_lobe, u);
            let ok = s.is_some_and(|s| {
                (s.wi - wi).abs().max_element() < 1e-3
                    && close(s.weight.x, weight.x, 2e-3)
                    && close(s.weight.y, weight.y, 2e-3)
                    && close(s.weight.z, weight.z, 2e-3)
                    && (if s.delta { s.pdf == 0.0 } else { close(s.pdf, pdf, 2e-3) })
            });
            if !ok {
                failures
                    .push(format!("{model:?}\n  wo {wo} u {u_lobe} {u}: {s:?} vs wi {wi} weight {weight} pdf {pdf}"));
            }
        }
        assert!(failures.is_empty(), "{} mismatches:\n{}", failures.len(), failures.join("\n"));
    }

    #[test]
    fn diffuse_is_lambert() {
        let m = Model::Diffuse { reflectance: Rgb::new(0.8, 0.5, 0.2) };
        for wo in directions_out(true) {
            check_model(&m, wo, 4, true);
        }
        let wo = Vec3::new(0.0, 0.6, 0.8);
        let wi = Vec3::new(0.6, 0.0, 0.8);
        assert!((m.eval(wo, wi) - Rgb::new(0.8, 0.5, 0.2) * 0.8 / std::f32::consts::PI).abs().max_element() < 1e-7);
        assert_eq!(m.eval(-wo, wi), Rgb::ZERO);
        assert_eq!(m.diffuse_albedo(wo) * m.eval_diffuse(wo, wi), m.eval(wo, wi));
    }

    #[test]
    fn diffuse_lobes_factor_exactly() {
        let wo = Vec3::new(0.3, 0.2, 0.9).normalize();
        let models = [
            Model::Plastic {
                diffuse_reflectance: Rgb::new(0.7, 0.3, 0.1),
                specular_reflectance: Rgb::ONE,
                eta: 1.5,
                nonlinear: true,
            },
            Model::Principled(PrincipledParams {
                base_color: Rgb::new(0.2, 0.5, 0.9),
                roughness: 0.4,
                ..Default::default()
            }),
        ];
        let mut s = SampleStream::new(1, 2, 3);
        for m in &models {
            for _ in 0..32 {
                let wi = microfacet::cosine_hemisphere(s.next_2d());
                let diffuse = m.diffuse_albedo(wo) * m.eval_diffuse(wo, wi);
                assert!(diffuse.min_element() > 0.0);
                // Plastic (smooth) is only its diffuse lobe off the mirror direction.
                if let Model::Plastic { .. } = m {
                    assert!((diffuse - m.eval(wo, wi)).abs().max_element() < 1e-6);
                } else {
                    assert!((m.eval(wo, wi) - diffuse).min_element() >= -1e-6);
                }
            }
        }
    }

    #[test]
    fn mixtures_blend_and_mask_like_mitsuba() {
        let diffuse = Model::Diffuse { reflectance: Rgb::new(0.8, 0.6, 0.4) };
        let glossy = Model::RoughConductor {
            micro: Microfacet::new(glint_scene::bsdf::Distribution::Ggx, 0.2, 0.2, true),
            eta: Rgb::splat(0.2),
            k: Rgb::splat(3.0),
            specular_reflectance: Rgb::ONE,
        };
        let glass = Model::Dielectric { eta: 1.5, specular_reflectance: Rgb::ONE, specular_transmittance: Rgb::ONE };
        let blend = Mixture::blend(&diffuse.into(), &glossy.into(), 0.3).expect("fits");
        let masked = Mixture::mask(&blend, 0.7);
        let mut with_glass = masked;
        with_glass.push(0.0, glass).expect("fits");
        let wo = Vec3::new(0.2, 0.3, 0.9).normalize();
        let wi = Vec3::new(-0.3, -0.3, 0.9).normalize();
        let expected = (diffuse.eval(wo, wi) * 0.7 + glossy.eval(wo, wi) * 0.3) * 0.7;
        assert!((masked.eval(wo, wi) - expected).abs().max_element() < 1e-6);
        assert!((masked.p_delta(wo) - 0.3).abs() < 1e-6);
        let lobes = masked.delta_lobes(wo);
        assert_eq!(lobes[0], Some((-wo, Rgb::splat(0.3))));
        assert!(lobes[1..].iter().all(Option::is_none));
        for m in [blend, masked] {
            check_sampler(
                "mixture",
                wo,
                2,
                |ul, u| m.sample(wo, ul, u),
                |wi| m.pdf(wo, wi),
                |wi| m.eval(wo, wi),
                Checks { unscale_transmission: 1.0, exact_weight: true, max_albedo: 1.0 },
            );
        }
        let mut full = Mixture::new();
        for _ in 0..MIXTURE_TERMS {
            full.push(0.25, diffuse).expect("room");
        }
        assert_eq!(full.push(0.1, diffuse), Err(MixtureFull));
        // Glass and a mask: one mirror, one straight-through, one refraction.
        let glassy = Mixture::mask(&glass.into(), 0.5);
        let lobes: Vec<_> = glassy.delta_lobes(wo).into_iter().flatten().collect();
        assert_eq!(lobes.len(), 3);
        let sum: f32 = lobes.iter().map(|l| l.1.x).sum();
        assert!(sum > 0.5 && sum < 1.0);
        assert!((glassy.p_delta(wo) - 1.0).abs() < 1e-6);
    }
}
