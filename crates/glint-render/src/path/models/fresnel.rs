//! Fresnel terms as Mitsuba 3 computes them (include/mitsuba/render/fresnel.h): the exact
//! unpolarised dielectric reflectance with the refracted cosine and the relative indices along
//! the path, the conductor reflectance for a complex index `eta + i k` per RGB channel, and the
//! diffuse Fresnel reflectance `Fdr` that `plastic` uses for the light bouncing inside its
//! coating (fits of Egan and Hilgeman 1973 and d'Eon and Irving 2011).
//!
//! Directions are local (z = normal) and point away from the surface.

use glint_core::{Rgb, Vec3};

/// The dielectric Fresnel term of an interface of relative index `eta` (inside over outside)
/// for a direction at cosine `cos_i` to the normal (negative: from inside).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Reflectance (1 under total internal reflection).
    pub f: f32,
    /// Cosine of the refracted direction, on the other side (sign opposite to `cos_i`).
    pub cos_t: f32,
    /// Relative index along the path (`eta` from outside, `1/eta` from inside).
    pub eta_it: f32,
    /// Its reciprocal: the scale of the tangential components of the refracted direction.
    pub eta_ti: f32,
}

/// Mitsuba's `fresnel(cos_theta_i, eta)`.
pub fn dielectric(cos_i: f32, eta: f32) -> Dielectric {
    let outside = cos_i >= 0.0;
    let rcp_eta = 1.0 / eta;
    let (eta_it, eta_ti) = if outside { (eta, rcp_eta) } else { (rcp_eta, eta) };
    // Snell's law: the squared cosine of the refracted direction.
    let cos_t_sqr = 1.0 - (1.0 - cos_i * cos_i) * (eta_ti * eta_ti);
    let cos_i_abs = cos_i.abs();
    let cos_t_abs = cos_t_sqr.max(0.0).sqrt();
    let index_matched = eta == 1.0;
    let f = if index_matched {
        0.0
    } else if cos_i_abs == 0.0 {
        1.0
    } else {
        let a_s = (cos_i_abs - eta_it * cos_t_abs) / (cos_i_abs + eta_it * cos_t_abs);
        let a_p = (cos_t_abs - eta_it * cos_i_abs) / (cos_t_abs + eta_it * cos_i_abs);
        0.5 * (a_s * a_s + a_p * a_p)
    };
    // Under total internal reflection cos_t_abs = 0 and a_s = a_p = ±1: f = 1.
    let cos_t = if cos_i >= 0.0 { -cos_t_abs } else { cos_t_abs };
    Dielectric { f, cos_t, eta_it, eta_ti }
}

/// Mitsuba's `fresnel_conductor`: the unpolarised reflectance of a conductor of complex
/// relative index `eta + i k` (per channel) at cosine `cos_i` (assumed positive).
pub fn conductor(cos_i: f32, eta: Rgb, k: Rgb) -> Rgb {
    let channel = |eta_r: f32, eta_i: f32| {
        let cos_i_2 = cos_i * cos_i;
        let sin_i_2 = 1.0 - cos_i_2;
        let sin_i_4 = sin_i_2 * sin_i_2;
        let temp_1 = eta_r * eta_r - eta_i * eta_i - sin_i_2;
        let a_2_pb_2 = (temp_1 * temp_1 + 4.0 * eta_i * eta_i * eta_r * eta_r).max(0.0).sqrt();
        let a = (0.5 * (a_2_pb_2 + temp_1)).max(0.0).sqrt();
        let term_1 = a_2_pb_2 + cos_i_2;
        let term_2 = 2.0 * cos_i * a;
        let r_s = (term_1 - term_2) / (term_1 + term_2);
        let term_3 = a_2_pb_2 * cos_i_2 + sin_i_4;
        let term_4 = term_2 * sin_i_2;
        let r_p = r_s * (term_3 - term_4) / (term_3 + term_4);
        0.5 * (r_s + r_p)
    };
    Rgb::new(channel(eta.x, k.x), channel(eta.y, k.y), channel(eta.z, k.z))
}

/// Mitsuba's `fresnel_diffuse_reflectance`: the share of uniformly diffuse light reflected by
/// an interface of relative index `eta` (Egan and Hilgeman's fit below 1, d'Eon and Irving's
/// above).
pub fn diffuse_reflectance(eta: f32) -> f32 {
    let inv_eta = 1.0 / eta;
    if eta < 1.0 {
        0.0636 * inv_eta + (eta * (eta * -1.4399 + 0.7099) + 0.6681)
    } else {
        // Horner in 1/eta of 0.919317 − 3.4793 x + 6.75335 x² − 7.80989 x³ + 4.98554 x⁴ − 1.36881 x⁵.
        let c = [0.919317, -3.4793, 6.75335, -7.80989, 4.98554, -1.36881];
        c.iter().rev().fold(0.0, |acc, &ci| acc * inv_eta + ci)
    }
}

/// Mirror `v` about the normal `m`.
#[inline]
pub fn reflect(v: Vec3, m: Vec3) -> Vec3 {
    m * (2.0 * v.dot(m)) - v
}

/// Mirror about the shading normal (z): `(−x, −y, z)`.
#[inline]
pub fn reflect_z(v: Vec3) -> Vec3 {
    Vec3::new(-v.x, -v.y, v.z)
}

/// Refract `v` through the microfacet `m` with `cos_t` and `eta_ti` from [`dielectric`].
#[inline]
pub fn refract(v: Vec3, m: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    m * (v.dot(m) * eta_ti + cos_t) - v * eta_ti
}

/// Refract `v` through the shading normal (z).
#[inline]
pub fn refract_z(v: Vec3, cos_t: f32, eta_ti: f32) -> Vec3 {
    Vec3::new(-eta_ti * v.x, -eta_ti * v.y, cos_t)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_matches_known_values_and_is_symmetric() {
        // Normal incidence: ((η − 1)/(η + 1))².
        let d = dielectric(1.0, 1.5);
        assert!((d.f - 0.04).abs() < 1e-6, "{d:?}");
        assert!((d.cos_t + 1.0).abs() < 1e-6);
        // Same reflectance from inside along the refracted direction (Stokes relations).
        let d = dielectric(0.6, 1.5);
        let back = dielectric(d.cos_t, 1.5);
        assert!((d.f - back.f).abs() < 1e-5, "{} {}", d.f, back.f);
        assert!((back.cos_t - 0.6).abs() < 1e-5);
        // Total internal reflection beyond the critical angle.
        let tir = dielectric(-0.3, 1.5);
        assert_eq!(tir.f, 1.0);
        assert_eq!(tir.cos_t, 0.0);
    }

    #[test]
    fn conductor_reduces_to_dielectric_without_absorption() {
        for cos in [0.1, 0.5, 0.9, 1.0] {
            let c = conductor(cos, Rgb::splat(1.5), Rgb::ZERO);
            let d = dielectric(cos, 1.5).f;
            assert!((c.x - d).abs() < 1e-5, "{cos}: {c} vs {d}");
        }
        // A perfect absorber limit: large k reflects almost everything.
        assert!(conductor(0.7, Rgb::splat(0.2), Rgb::splat(50.0)).min_element() > 0.99);
    }

    #[test]
    fn diffuse_reflectance_fits_agree_near_one() {
        assert!(diffuse_reflectance(1.0).abs() < 0.01);
        // Internal reflection is large: 1 − (1 − Fdr(η))/η² for η = 1.5 ≈ 0.596.
        let internal = diffuse_reflectance(1.0 / 1.5);
        assert!((internal - 0.596).abs() < 0.01, "{internal}");
    }
}
