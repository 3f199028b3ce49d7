//! Mirror reflection, Snell refraction and the dielectric Fresnel equations (DESIGN.md §1).

use glint_core::Vec3;

/// `R = I − 2 N (N·I)`, for an incident direction `i` travelling toward the surface.
#[inline]
#[must_use]
pub fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    i - n * (2.0 * n.dot(i))
}

/// Snell refraction of incident direction `i` (unit, toward the surface) through the surface
/// with unit normal `n` on the incident side, `eta = n1 / n2`. `None` on total internal
/// reflection (`k < 0`).
#[inline]
#[must_use]
pub fn refract(i: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cos_i = -n.dot(i);
    let k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
    if k < 0.0 {
        return None;
    }
    Some((i * eta + n * (eta * cos_i - k.sqrt())).normalize())
}

/// Exact unpolarised Fresnel reflectance of a dielectric interface, light arriving from the
/// medium of index `eta_i` at cosine `cos_i` (≥ 0) into `eta_t`. 1 under total internal reflection.
#[inline]
#[must_use]
pub fn fresnel_dielectric(cos_i: f32, eta_i: f32, eta_t: f32) -> f32 {
    let cos_i = cos_i.clamp(0.0, 1.0);
    let sin_t = eta_i / eta_t * (1.0 - cos_i * cos_i).max(0.0).sqrt();
    if sin_t >= 1.0 {
        return 1.0;
    }
    let cos_t = (1.0 - sin_t * sin_t).max(0.0).sqrt();
    let r_par = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    let r_perp = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    0.5 * (r_par * r_par + r_perp * r_perp)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflection_preserves_angle_and_length() {
        let i = Vec3::new(1.0, -1.0, 0.0).normalize();
        let r = reflect(i, Vec3::Y);
        assert!((r - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
    }

    #[test]
    fn refraction_obeys_snell() {
        for deg in [0.0f32, 10.0, 30.0, 60.0, 85.0] {
            let th = deg.to_radians();
            let i = Vec3::new(th.sin(), -th.cos(), 0.0);
            let t = refract(i, Vec3::Y, 1.0 / 1.5).expect("air to glass never reflects totally");
            let sin_t = t.x;
            assert!((th.sin() - 1.5 * sin_t).abs() < 1e-5, "{deg}: {sin_t}");
            assert!(t.y < 0.0);
        }
    }

    #[test]
    fn total_internal_reflection_beyond_the_critical_angle() {
        let critical = (1.0f32 / 1.5).asin();
        let th = critical + 0.01;
        let i = Vec3::new(th.sin(), -th.cos(), 0.0);
        assert!(refract(i, Vec3::Y, 1.5).is_none());
        assert_eq!(fresnel_dielectric(th.cos(), 1.5, 1.0), 1.0);
        let th = critical - 0.01;
        let i = Vec3::new(th.sin(), -th.cos(), 0.0);
        assert!(refract(i, Vec3::Y, 1.5).is_some());
    }

    #[test]
    fn fresnel_at_normal_incidence_and_symmetry() {
        // ((n1 - n2) / (n1 + n2))² = 0.04 for glass, from both sides.
        assert!((fresnel_dielectric(1.0, 1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((fresnel_dielectric(1.0, 1.5, 1.0) - 0.04).abs() < 1e-6);
        // Grazing incidence reflects everything.
        assert!(fresnel_dielectric(0.0, 1.0, 1.5) > 0.999);
    }

    #[test]
    fn reflectance_plus_transmittance_is_one_from_both_sides() {
        // Energy: R + T = 1 where T is computed independently from the Fresnel transmission
        // amplitudes, T = (n_t cos_t)/(n_i cos_i) (t_s² + t_p²)/2.
        for (ei, et) in [(1.0f32, 1.5f32), (1.5, 1.0), (1.0, 2.4), (1.33, 1.0)] {
            for k in 0..=20 {
                let cos_i = (k as f32 / 20.0).max(1e-3);
                let sin_t = ei / et * (1.0 - cos_i * cos_i).sqrt();
                if sin_t >= 1.0 {
                    assert_eq!(fresnel_dielectric(cos_i, ei, et), 1.0);
                    continue;
                }
                let cos_t = (1.0 - sin_t * sin_t).sqrt();
                let ts = 2.0 * ei * cos_i / (ei * cos_i + et * cos_t);
                let tp = 2.0 * ei * cos_i / (et * cos_i + ei * cos_t);
                let t = (et * cos_t) / (ei * cos_i) * 0.5 * (ts * ts + tp * tp);
                let r = fresnel_dielectric(cos_i, ei, et);
                assert!((r + t - 1.0).abs() < 1e-4, "{ei}->{et} cos {cos_i}: R {r} T {t}");
            }
        }
    }
}
