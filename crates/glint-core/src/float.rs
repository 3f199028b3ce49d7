//! Floating-point error bounds and robust ray-origin offsets.
//!
//! Self-intersection is avoided the way pbrt-v3/v4 do it (Pharr, Jakob, Humphreys, "Physically
//! Based Rendering", §3.9): each intersection reports a conservative bound on the absolute error
//! of its computed point, and a spawned ray starts at the point pushed along the geometric normal
//! by just that bound, rounded away from the surface. No fixed epsilon, so it works at every
//! scale.

use glam::Vec3;

/// Half an ulp of 1.0 in f32: the relative error bound of one rounded operation.
pub const MACHINE_EPSILON: f32 = f32::EPSILON * 0.5;

/// `gamma(n) = n ε / (1 - n ε)`: bounds the relative error of `n` successive rounded operations.
#[inline]
pub const fn gamma(n: i32) -> f32 {
    (n as f32 * MACHINE_EPSILON) / (1.0 - n as f32 * MACHINE_EPSILON)
}

/// The next representable f32 above `v` (identity on +inf and NaN).
#[inline]
pub fn next_float_up(v: f32) -> f32 {
    if v.is_infinite() && v > 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == -0.0 { 0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v >= 0.0 { bits + 1 } else { bits - 1 };
    f32::from_bits(bits)
}

/// The next representable f32 below `v` (identity on -inf and NaN).
#[inline]
pub fn next_float_down(v: f32) -> f32 {
    if v.is_infinite() && v < 0.0 || v.is_nan() {
        return v;
    }
    let v = if v == 0.0 { -0.0 } else { v };
    let bits = v.to_bits();
    let bits = if v > 0.0 { bits - 1 } else { bits + 1 };
    f32::from_bits(bits)
}

/// Origin for a ray leaving the surface point `p` (absolute error bound `p_error`, geometric
/// normal `n`) in direction `w`: `p` moved along `±n` past its error box, each component
/// rounded away from the surface so the offset survives rounding. Forced inline: across the
/// crate boundary it stayed a call in the Whitted loop, where every hit spawns 3–4 rays
/// (6 % of a frame, BENCHMARKS §3).
#[inline(always)]
pub fn offset_ray_origin(p: Vec3, p_error: Vec3, n: Vec3, w: Vec3) -> Vec3 {
    // pbrt's offset is the error bound projected on the normal; on an axis-aligned surface at
    // coordinate 0 that bound is 0 along the normal (the coordinate is exact) while the ray's
    // intersection test still errs by the other coordinates' bounds, and a shadow ray would
    // find its own surface at t ≈ 1e-5 (Mitsuba's Cornell box: its wall at x = 0 lost 30 % of
    // its direct light). So the offset is at least the largest error component.
    let d = n.abs().dot(p_error).max(p_error.max_element());
    let mut offset = n * d;
    if w.dot(n) < 0.0 {
        offset = -offset;
    }
    let po = p + offset;
    let round = |v: f32, o: f32| {
        if o > 0.0 {
            next_float_up(v)
        } else if o < 0.0 {
            next_float_down(v)
        } else {
            v
        }
    };
    Vec3::new(round(po.x, offset.x), round(po.y, offset.y), round(po.z, offset.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn next_float_steps_one_ulp() {
        assert!(next_float_up(1.0) > 1.0);
        assert_eq!(next_float_down(next_float_up(1.0)), 1.0);
        assert!(next_float_up(0.0) > 0.0);
        assert!(next_float_down(0.0) < 0.0);
        assert!(next_float_up(-1.0) > -1.0);
        assert_eq!(next_float_up(f32::INFINITY), f32::INFINITY);
    }

    #[test]
    fn offset_moves_to_the_side_of_w() {
        let p = Vec3::new(1000.0, 0.0, 0.0);
        let err = Vec3::splat(1e-3);
        let n = Vec3::Y;
        let up = offset_ray_origin(p, err, n, Vec3::Y);
        let down = offset_ray_origin(p, err, n, -Vec3::Y);
        assert!(up.y > 1e-3);
        assert!(down.y < -1e-3);
        assert_eq!(up.x, 1000.0);
    }

    #[test]
    fn gamma_grows_with_n() {
        assert!(gamma(3) > gamma(2));
        assert!(gamma(1) > MACHINE_EPSILON * 0.99);
    }
}
