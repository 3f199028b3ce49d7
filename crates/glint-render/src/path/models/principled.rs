//! Mitsuba 3's `principled` and `principledthin` (src/bsdfs/principled.cpp, principledthin.cpp,
//! principledhelpers.h): the Disney BSDF (Burley 2012, 2015) as Mitsuba implements it.
//!
//! - `principled`: a retro-reflective diffuse lobe (with Hanrahan–Krueger `flatness`), sheen,
//!   a GGX specular reflection whose Fresnel term blends the dielectric one with Schlick's for
//!   `metallic` and `spec_tint`, a GGX rough refraction (`spec_trans`, tinted by √base colour,
//!   Walter et al. 2007) and a GTR1 clearcoat (with Mitsuba's `clearcoat · 0.25 · F D G cos`
//!   form, no `1/(4 cos)`). From inside only the dielectric reflection and refraction remain.
//! - `principledthin`: a sheet seen from both sides: specular reflection and a transmission
//!   lobe reflected through the sheet (roughness scaled by `0.65 η − 0.35`), diffuse reflection
//!   and Lambertian diffuse transmission (`diff_trans / 2`), sheen.
//!
//! Lobes are sampled with Mitsuba's probabilities (all sampling rates 1). A parameter equal to
//! zero behaves as Mitsuba's absent parameter (its `get_flag`): the two agree everywhere but in
//! the pdf from inside a surface with no transmission, which Mitsuba never uses (eval and
//! sample are zero there) and which is zero here.

use super::Sample;
use super::fresnel::{self, reflect};
use super::microfacet::{Microfacet, cosine_hemisphere, cosine_hemisphere_pdf};
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::bsdf::Distribution;
use std::f32::consts::{FRAC_1_PI, PI, TAU};

/// The parameters of `principled` / `principledthin`, every texture read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrincipledParams {
    /// `principledthin` rather than `principled`.
    pub thin: bool,
    pub base_color: Rgb,
    pub roughness: f32,
    pub anisotropic: f32,
    pub metallic: f32,
    pub spec_trans: f32,
    pub spec_tint: f32,
    pub sheen: f32,
    pub sheen_tint: f32,
    pub flatness: f32,
    pub clearcoat: f32,
    pub clearcoat_gloss: f32,
    /// Diffuse transmission in [0, 2] (`principledthin` only).
    pub diff_trans: f32,
    /// Index of refraction as [`PrincipledParams::resolve_eta`] gives it.
    pub eta: f32,
}

impl Default for PrincipledParams {
    /// Mitsuba's defaults (`specular` 0.5: η = 1.5).
    fn default() -> Self {
        PrincipledParams {
            thin: false,
            base_color: Rgb::splat(0.5),
            roughness: 0.5,
            anisotropic: 0.0,
            metallic: 0.0,
            spec_trans: 0.0,
            spec_tint: 0.0,
            sheen: 0.0,
            sheen_tint: 0.0,
            flatness: 0.0,
            clearcoat: 0.0,
            clearcoat_gloss: 0.0,
            diff_trans: 0.0,
            eta: 1.5,
        }
    }
}

impl PrincipledParams {
    /// The index Mitsuba uses: `principledthin`'s `eta` (default 1.5); `principled`'s `eta`
    /// (1 becomes 1.001 when `spec_trans` is given) or, without it, the one of `specular`
    /// (`2 / (1 − √(0.08 s)) − 1`, with 0 becoming 10⁻³ when `spec_trans` is given).
    #[must_use]
    pub fn resolve_eta(thin: bool, eta: Option<f32>, specular: f32, has_spec_trans: bool) -> f32 {
        match (thin, eta) {
            (true, eta) => eta.unwrap_or(1.5),
            (false, Some(eta)) if has_spec_trans && eta == 1.0 => 1.001,
            (false, Some(eta)) => eta,
            (false, None) => {
                let s = if has_spec_trans && specular == 0.0 { 1e-3 } else { specular };
                2.0 / (1.0 - (0.08 * s).sqrt()) - 1.0
            }
        }
    }

    /// The GGX roughness of a (possibly scaled) `roughness`.
    fn distribution(&self, roughness: f32) -> Microfacet {
        let r2 = roughness * roughness;
        let (ax, ay) = if self.anisotropic != 0.0 {
            let aspect = (1.0 - 0.9 * self.anisotropic).sqrt();
            ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
        } else {
            (r2.max(0.001), r2.max(0.001))
        };
        Microfacet::new(Distribution::Ggx, ax, ay, true)
    }

    /// The colour of the diffuse lobe.
    #[must_use]
    pub fn diffuse_albedo(&self, wo: Vec3) -> Rgb {
        let front = if self.thin { wo.z != 0.0 } else { wo.z > 0.0 };
        if front { self.base_color } else { Rgb::ZERO }
    }

    #[must_use]
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> Rgb {
        let (other, diffuse) = if self.thin { self.thin_lobes(wo, wi) } else { self.lobes(wo, wi) };
        other + self.base_color * diffuse
    }

    #[must_use]
    pub fn eval_diffuse(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.thin { self.thin_lobes(wo, wi).1 } else { self.lobes(wo, wi).1 }
    }

    #[must_use]
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if self.thin { self.thin_pdf(wo, wi) } else { self.full_pdf(wo, wi) }
    }

    #[must_use]
    pub fn sample(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Sample> {
        let wi = if self.thin { self.thin_direction(wo, u_lobe, u)? } else { self.direction(wo, u_lobe, u)? };
        let pdf = self.pdf(wo, wi);
        Sample::glossy(wi, self.eval(wo, wi) / pdf, 1.0, pdf)
    }

    /// `principled`: (every lobe but the diffuse one, the diffuse lobe's scalar shape).
    fn lobes(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        let cos_i = wo.z;
        if cos_i == 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let base = self.base_color;
        let (metallic, spec_trans) = (self.metallic, self.spec_trans);
        let brdf = (1.0 - metallic) * (1.0 - spec_trans);
        let bsdf = (1.0 - metallic) * spec_trans;
        let cos_o = wi.z;
        let (reflect, refract) = (cos_i * cos_o > 0.0, cos_i * cos_o < 0.0);
        let front = cos_i > 0.0;
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let inv_eta_path = if front { 1.0 / self.eta } else { self.eta };
        let spec = self.distribution(self.roughness);
        let wh = upper((wo + wi * if reflect { 1.0 } else { eta_path }).normalize());
        let f_d = fresnel::dielectric(wo.dot(wh), self.eta).f;
        let refl_ok = compatible(wh, wo, wi, cos_i, true);
        let refr_ok = compatible(wh, wo, wi, cos_i, false);
        let d = spec.d(wh);
        let g = spec.g(wo, wi, wh);
        let mut value = Rgb::ZERO;
        if reflect && refl_ok && f_d > 0.0 {
            let f = self.principled_fresnel(f_d, wo.dot(wh), front, bsdf);
            value += f * (d * g / (4.0 * cos_i.abs()));
        }
        if bsdf > 0.0 && refract && refr_ok && f_d < 1.0 {
            let (dot_o, dot_i) = (wo.dot(wh), wi.dot(wh));
            let denom = dot_o + eta_path * dot_i;
            let t = (inv_eta_path * inv_eta_path * (1.0 - f_d) * d * g * eta_path * eta_path * dot_o * dot_i)
                / (cos_i * denom * denom);
            value += sqrt_rgb(base) * (bsdf * t.abs());
        }
        if self.clearcoat > 0.0 && reflect && refl_ok && front {
            let f_cc = schlick(Rgb::splat(0.04), wo.dot(wh), self.eta).x;
            let d_cc = gtr1_eval(clearcoat_alpha(self.clearcoat_gloss), wh);
            let g_cc = smith_ggx1(wo, wh, 0.25) * smith_ggx1(wi, wh, 0.25);
            value += Rgb::splat(self.clearcoat * 0.25 * f_cc * d_cc * g_cc * cos_o.abs());
        }
        let mut diffuse = 0.0;
        if brdf > 0.0 && reflect && front {
            let (fo, fi) = (schlick_weight(cos_o.abs()), schlick_weight(cos_i.abs()));
            let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
            let cos_d = wh.dot(wi);
            let rr = 2.0 * self.roughness * cos_d * cos_d;
            let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
            let shape = if self.flatness != 0.0 {
                let f_ss = subsurface(rr, fo, fi, cos_o, cos_i);
                lerp(f_diff + f_retro, f_ss, self.flatness)
            } else {
                f_diff + f_retro
            };
            diffuse = brdf * cos_o.abs() * FRAC_1_PI * shape;
            if self.sheen > 0.0 && 1.0 - metallic > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                value += self.sheen_colour() * (self.sheen * (1.0 - metallic) * fd * cos_o.abs());
            }
        }
        (value, diffuse)
    }

    /// Mitsuba's `principled_fresnel`: front side blends the dielectric term with Schlick's for
    /// the metal and the specular tint; the back side is the dielectric term times `bsdf`.
    fn principled_fresnel(&self, f_d: f32, cos_i: f32, front: bool, bsdf: f32) -> Rgb {
        if !front {
            return Rgb::splat(bsdf * f_d);
        }
        let (metallic, spec_tint) = (self.metallic, self.spec_tint);
        let eta_it = if cos_i >= 0.0 { self.eta } else { 1.0 / self.eta };
        let mut f_schlick = Rgb::ZERO;
        if metallic != 0.0 {
            f_schlick += schlick(self.base_color, cos_i, self.eta) * metallic;
        }
        if spec_tint != 0.0 {
            let f0 = self.tint() * r0(eta_it);
            f_schlick += schlick(f0, cos_i, self.eta) * ((1.0 - metallic) * spec_tint);
        }
        Rgb::splat((1.0 - metallic) * (1.0 - spec_tint) * f_d) + f_schlick
    }

    /// Base colour over its luminance (white for black).
    fn tint(&self) -> Rgb {
        let lum = luminance(self.base_color);
        if lum > 0.0 { self.base_color / lum } else { Rgb::ONE }
    }

    fn sheen_colour(&self) -> Rgb {
        if self.sheen_tint != 0.0 { Rgb::ONE + (self.tint() - Rgb::ONE) * self.sheen_tint } else { Rgb::ONE }
    }

    /// Lobe choice probabilities (diffuse, clearcoat, transmission, reflection), normalised,
    /// given the dielectric Fresnel term of the microfacet.
    fn probabilities(&self, front: bool, f_d: f32) -> [f32; 4] {
        let brdf = (1.0 - self.metallic) * (1.0 - self.spec_trans);
        let bsdf = (1.0 - self.metallic) * self.spec_trans;
        let has_trans = self.spec_trans != 0.0;
        let reflect = if front { 1.0 - bsdf * (1.0 - f_d) } else { f_d };
        let trans = match (has_trans, front) {
            (false, _) => 0.0,
            (true, true) => bsdf * (1.0 - f_d),
            (true, false) => 1.0 - f_d,
        };
        let clearcoat = if self.clearcoat != 0.0 && front { 0.25 * self.clearcoat } else { 0.0 };
        let diffuse = if front { brdf } else { 0.0 };
        let rcp = 1.0 / (reflect + trans + clearcoat + diffuse);
        [diffuse * rcp, clearcoat * rcp, trans * rcp, reflect * rcp]
    }

    fn full_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        let cos_i = wo.z;
        let bsdf = (1.0 - self.metallic) * self.spec_trans;
        let front = cos_i > 0.0;
        if cos_i == 0.0 || !(front || bsdf > 0.0) {
            return 0.0;
        }
        let eta_path = if front { self.eta } else { 1.0 / self.eta };
        let cos_o = wi.z;
        let (reflect, refract) = (cos_i * cos_o > 0.0, cos_i * cos_o < 0.0);
        let wh = upper((wo + wi * if reflect { 1.0 } else { eta_path }).normalize());
        let spec = self.distribution(self.roughness);
        let f_d = fresnel::dielectric(wo.dot(wh), self.eta).f;
        let [p_diffuse, p_clearcoat, p_trans, p_reflect] = self.probabilities(front, f_d);
        let (dot_i, dot_o) = (wi.dot(wh), wo.dot(wh));
        let dwh_dwi = if self.spec_trans != 0.0 && !reflect {
            let denom = dot_o + eta_path * dot_i;
            (eta_path * eta_path * dot_i / (denom * denom)).abs()
        } else {
            (1.0 / (4.0 * dot_i)).abs()
        };
        let wo_up = if cos_i < 0.0 { -wo } else { wo };
        let mut pdf = 0.0;
        let refl_ok = compatible(wh, wo, wi, cos_i, true) && reflect;
        if refl_ok {
            pdf += p_reflect * spec.pdf(wo_up, wh) * dwh_dwi;
        }
        if reflect {
            pdf += p_diffuse * cosine_hemisphere_pdf(wi);
        }
        if self.spec_trans != 0.0 && compatible(wh, wo, wi, cos_i, false) && refract {
            pdf += p_trans * spec.pdf(wo_up, wh) * dwh_dwi;
        }
        if self.clearcoat != 0.0 && refl_ok {
            pdf += p_clearcoat * gtr1_pdf(clearcoat_alpha(self.clearcoat_gloss), wh) * dwh_dwi;
        }
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    fn direction(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        let cos_i = wo.z;
        let bsdf = (1.0 - self.metallic) * self.spec_trans;
        let front = cos_i > 0.0;
        if cos_i == 0.0 || !(front || bsdf > 0.0) {
            return None;
        }
        let wo_up = if cos_i < 0.0 { -wo } else { wo };
        let m = self.distribution(self.roughness).sample(wo_up, u).0;
        let fr = fresnel::dielectric(wo.dot(m), self.eta);
        let [p_diffuse, p_clearcoat, p_trans, _] = self.probabilities(front, fr.f);
        let wi = if u_lobe < p_diffuse {
            let wi = cosine_hemisphere(u);
            (cos_i * wi.z > 0.0).then_some(wi)?
        } else if u_lobe < p_diffuse + p_clearcoat {
            let m = gtr1_sample(clearcoat_alpha(self.clearcoat_gloss), u);
            let wi = reflect(wo, m);
            (compatible(m, wo, wi, cos_i, true) && cos_i * wi.z > 0.0).then_some(wi)?
        } else if u_lobe < p_diffuse + p_clearcoat + p_trans {
            let wi = fresnel::refract(wo, m, fr.cos_t, fr.eta_ti);
            (compatible(m, wo, wi, cos_i, false) && cos_i * wi.z < 0.0).then_some(wi)?
        } else {
            let wi = reflect(wo, m);
            (compatible(m, wo, wi, cos_i, true) && cos_i * wi.z > 0.0).then_some(wi)?
        };
        Some(wi)
    }

    /// `principledthin`: (every lobe but the diffuse ones, the diffuse lobes' scalar shape).
    fn thin_lobes(&self, wo: Vec3, wi: Vec3) -> (Rgb, f32) {
        let cos_i = wo.z;
        if cos_i == 0.0 {
            return (Rgb::ZERO, 0.0);
        }
        let spec_trans = self.spec_trans;
        let diff_trans = self.diff_trans / 2.0;
        let (wo_f, wi_t) = if cos_i < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let cos_i = cos_i.abs();
        let cos_o = wi_t.z;
        let (reflect, refract) = (cos_o > 0.0, cos_o < 0.0);
        let wi_r = Vec3::new(wi_t.x, wi_t.y, wi_t.z.abs());
        let wh = (wo_f + wi_r).normalize();
        let mut value = Rgb::ZERO;
        if spec_trans != 0.0 {
            let f_d = fresnel::dielectric(wo_f.dot(wh), self.eta).f;
            if spec_trans > 0.0 && reflect && compatible(wh, wo_f, wi_t, wo_f.z, true) {
                let spec = self.distribution(self.roughness);
                let f_thin = self.thin_fresnel(f_d, wo_f.dot(wh));
                let (d, g) = (spec.d(wh), spec.g(wo_f, wi_t, wh));
                value += f_thin * (spec_trans * d * g / (4.0 * cos_i));
            }
            if refract && spec_trans > 0.0 && compatible(wh, wo_f, wi_t, wo_f.z, false) {
                let spec = self.distribution((0.65 * self.eta - 0.35) * self.roughness);
                let (d, g) = (spec.d(wh), spec.g(wo_f, wi_t, wh));
                value += self.base_color * (spec_trans * (1.0 - f_d) * d * g / (4.0 * cos_i));
            }
        }
        let mut diffuse = 0.0;
        if reflect && spec_trans < 1.0 && diff_trans < 1.0 {
            let (fo, fi) = (schlick_weight(cos_o.abs()), schlick_weight(cos_i));
            let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
            let cos_d = wh.dot(wi_t);
            let rr = 2.0 * self.roughness * cos_d * cos_d;
            let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
            let shape = if self.flatness != 0.0 {
                lerp(f_diff + f_retro, subsurface(rr, fo, fi, cos_o, cos_i), self.flatness)
            } else {
                f_diff + f_retro
            };
            diffuse += (1.0 - spec_trans) * cos_o * FRAC_1_PI * (1.0 - diff_trans) * shape;
            if self.sheen > 0.0 {
                let fd = schlick_weight(cos_d.abs());
                value +=
                    self.sheen_colour() * (self.sheen * (1.0 - spec_trans) * fd * (1.0 - diff_trans) * cos_o.abs());
            }
        }
        if diff_trans != 0.0 && refract && spec_trans < 1.0 && diff_trans > 0.0 {
            diffuse += (1.0 - spec_trans) * diff_trans * FRAC_1_PI * cos_o.abs();
        }
        (value, diffuse)
    }

    /// Mitsuba's `thin_fresnel`: the dielectric term blended with Schlick's tinted one.
    fn thin_fresnel(&self, f_d: f32, cos_i: f32) -> Rgb {
        let f_schlick =
            if self.spec_tint != 0.0 { schlick(self.tint() * r0(self.eta), cos_i, self.eta) } else { Rgb::ZERO };
        Rgb::splat(f_d) + (f_schlick - Rgb::splat(f_d)) * self.spec_tint
    }

    fn thin_probabilities(&self) -> [f32; 4] {
        let (spec_trans, diff_trans) = (self.spec_trans, self.diff_trans / 2.0);
        let has_spec = spec_trans != 0.0;
        let reflect = if has_spec { spec_trans / 2.0 } else { 0.0 };
        let trans = reflect;
        let diffuse = (1.0 - spec_trans) * (1.0 - diff_trans);
        let diffuse_trans = if diff_trans != 0.0 { (1.0 - spec_trans) * diff_trans } else { 0.0 };
        let rcp = 1.0 / (reflect + trans + diffuse + diffuse_trans);
        [reflect * rcp, trans * rcp, diffuse * rcp, diffuse_trans * rcp]
    }

    fn thin_pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        if wo.z == 0.0 {
            return 0.0;
        }
        let (wo_f, wi_t) = if wo.z < 0.0 { (-wo, -wi) } else { (wo, wi) };
        let cos_o = wi_t.z;
        let (reflect, refract) = (cos_o > 0.0, cos_o < 0.0);
        let [p_reflect, p_trans, p_diffuse, p_diffuse_trans] = self.thin_probabilities();
        let mut pdf = 0.0;
        if self.spec_trans != 0.0 {
            let wi_r = Vec3::new(wi_t.x, wi_t.y, wi_t.z.abs());
            let wh = (wo_f + wi_r).normalize();
            let dwh_dwi = (1.0 / (4.0 * wi_r.dot(wh))).abs();
            if compatible(wh, wo_f, wi_t, wo_f.z, true) && reflect {
                pdf += p_reflect * self.distribution(self.roughness).pdf(wo_f, wh) * dwh_dwi;
            }
            if compatible(wh, wo_f, wi_t, wo_f.z, false) && refract {
                let spec = self.distribution((0.65 * self.eta - 0.35) * self.roughness);
                pdf += p_trans * spec.pdf(wo_f, wh) * dwh_dwi;
            }
        }
        if reflect {
            pdf += p_diffuse * cosine_hemisphere_pdf(wi_t);
        }
        if self.diff_trans != 0.0 && refract {
            pdf += p_diffuse_trans * cosine_hemisphere_pdf(-wi_t);
        }
        if pdf.is_finite() { pdf } else { 0.0 }
    }

    fn thin_direction(&self, wo: Vec3, u_lobe: f32, u: Vec2) -> Option<Vec3> {
        if wo.z == 0.0 {
            return None;
        }
        let wo_f = if wo.z < 0.0 { -wo } else { wo };
        let [p_reflect, p_trans, p_diffuse, _] = self.thin_probabilities();
        let has_spec = self.spec_trans != 0.0;
        let wi = if has_spec && u_lobe < p_reflect {
            let m = self.distribution(self.roughness).sample(wo_f, u).0;
            let wi = reflect(wo_f, m);
            (wi.z > 0.0 && compatible(m, wo_f, wi, wo_f.z, true)).then_some(wi)?
        } else if has_spec && u_lobe < p_reflect + p_trans {
            let m = self.distribution((0.65 * self.eta - 0.35) * self.roughness).sample(wo_f, u).0;
            let r = reflect(wo_f, m);
            let wi = Vec3::new(r.x, r.y, -r.z);
            (wi.z < 0.0 && compatible(m, wo_f, wi, wo_f.z, false)).then_some(wi)?
        } else if u_lobe < p_reflect + p_trans + p_diffuse {
            cosine_hemisphere(u)
        } else if self.diff_trans != 0.0 {
            -cosine_hemisphere(u)
        } else {
            return None;
        };
        Some(if wo.z < 0.0 { -wi } else { wi })
    }
}

/// Mitsuba's RGB luminance.
fn luminance(c: Rgb) -> f32 {
    0.212_671 * c.x + 0.715_160 * c.y + 0.072_169 * c.z
}

fn sqrt_rgb(c: Rgb) -> Rgb {
    Rgb::new(c.x.sqrt(), c.y.sqrt(), c.z.sqrt())
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a * (1.0 - t) + b * t
}

#[inline]
fn upper(m: Vec3) -> Vec3 {
    if m.z < 0.0 { -m } else { m }
}

/// Hanrahan–Krueger's fake subsurface term (Burley 2012).
fn subsurface(rr: f32, fo: f32, fi: f32, cos_o: f32, cos_i: f32) -> f32 {
    let fss90 = rr / 2.0;
    let fss = lerp(1.0, fss90, fo) * lerp(1.0, fss90, fi);
    1.25 * (fss * (1.0 / (cos_o.abs() + cos_i.abs()) - 0.5) + 0.5)
}

/// `(1 − cos)⁵`, clamped.
fn schlick_weight(cos: f32) -> f32 {
    let m = (1.0 - cos).clamp(0.0, 1.0);
    m * m * m * m * m
}

/// `((η − 1)/(η + 1))²`.
fn r0(eta: f32) -> f32 {
    ((eta - 1.0) / (eta + 1.0)).powi(2)
}

/// Mitsuba's `calc_schlick`: Schlick's approximation from the side of the lower index.
fn schlick(r0: Rgb, cos_i: f32, eta: f32) -> Rgb {
    let outside = cos_i >= 0.0;
    let (eta_it, eta_ti) = if outside { (eta, 1.0 / eta) } else { (1.0 / eta, eta) };
    let cos_t = (1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti)).max(0.0).sqrt();
    let w = if eta_it > 1.0 { schlick_weight(cos_i.abs()) } else { schlick_weight(cos_t) };
    Rgb::splat(w) * (Rgb::ONE - r0) + r0
}

/// Mitsuba's `mac_mic_compatibility`: both directions on the microfacet's proper sides.
fn compatible(m: Vec3, wo: Vec3, wi: Vec3, cos_i: f32, reflection: bool) -> bool {
    let m = if cos_i < 0.0 { -m } else { m };
    if reflection { wo.dot(m) > 0.0 && wi.dot(m) > 0.0 } else { wo.dot(m) > 0.0 && wi.dot(-m) > 0.0 }
}

fn clearcoat_alpha(gloss: f32) -> f32 {
    lerp(0.1, 0.001, gloss)
}

/// Burley's GTR1 (γ = 1) normal distribution, isotropic.
fn gtr1_eval(alpha: f32, m: Vec3) -> f32 {
    let (cos, a2) = (m.z, alpha * alpha);
    let result = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * cos * cos));
    if result * cos > 1e-20 { result } else { 0.0 }
}

fn gtr1_pdf(alpha: f32, m: Vec3) -> f32 {
    if m.z < 0.0 { 0.0 } else { m.z * gtr1_eval(alpha, m) }
}

fn gtr1_sample(alpha: f32, u: Vec2) -> Vec3 {
    let (sin_phi, cos_phi) = (TAU * u.x).sin_cos();
    let a2 = alpha * alpha;
    let cos_2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
    let (sin, cos) = ((1.0 - cos_2).max(0.0).sqrt(), cos_2.max(0.0).sqrt());
    Vec3::new(cos_phi * sin, sin_phi * sin, cos)
}

/// Smith's GGX masking of the clearcoat (isotropic α).
fn smith_ggx1(v: Vec3, wh: Vec3, alpha: f32) -> f32 {
    let a2 = alpha * alpha;
    let cos_2 = v.z * v.z;
    let tan_2 = (1.0 - cos_2) / cos_2;
    let mut result = 2.0 / (1.0 + (1.0 + a2 * tan_2).sqrt());
    if v.z == 1.0 {
        result = 1.0;
    }
    if v.dot(wh) * v.z <= 0.0 {
        result = 0.0;
    }
    result
}

#[cfg(test)]
mod tests {
    use super::super::Model;
    use super::super::tests::{check_model, directions_out};
    use super::*;

    fn variants() -> Vec<PrincipledParams> {
        let base = PrincipledParams { base_color: Rgb::new(0.9, 0.6, 0.3), ..PrincipledParams::default() };
        vec![
            base,
            PrincipledParams { roughness: 0.2, metallic: 0.7, spec_tint: 0.5, sheen: 0.8, sheen_tint: 0.5, ..base },
            PrincipledParams {
                roughness: 0.4,
                anisotropic: 0.7,
                clearcoat: 1.0,
                clearcoat_gloss: 0.6,
                flatness: 0.5,
                ..base
            },
            PrincipledParams { roughness: 0.3, spec_trans: 0.8, eta: 1.33, ..base },
            PrincipledParams { thin: true, roughness: 0.35, spec_trans: 0.6, diff_trans: 0.8, sheen: 0.5, ..base },
            PrincipledParams { thin: true, roughness: 0.6, anisotropic: 0.5, spec_tint: 0.4, flatness: 0.3, ..base },
        ]
    }

    #[test]
    fn principled_samples_its_pdf() {
        let models: Vec<Model> = variants().into_iter().map(Model::Principled).collect();
        let tests = models.len() * directions_out(true).len();
        for m in &models {
            let two_sided = matches!(m, Model::Principled(p) if p.thin || p.spec_trans > 0.0);
            for wo in directions_out(true) {
                if wo.z > 0.0 || two_sided {
                    check_model(m, wo, tests, !two_sided);
                }
            }
        }
    }

    #[test]
    fn resolve_eta_follows_specular() {
        assert!((PrincipledParams::resolve_eta(false, None, 0.5, false) - 1.5).abs() < 1e-6);
        assert_eq!(PrincipledParams::resolve_eta(false, Some(1.0), 0.5, true), 1.001);
        assert_eq!(PrincipledParams::resolve_eta(true, None, 0.5, false), 1.5);
        assert!(PrincipledParams::resolve_eta(false, None, 0.0, true) > 1.0);
    }
}
