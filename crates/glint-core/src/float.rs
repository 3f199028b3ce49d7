//! Floating-point error bounds and robust ray-origin offsets.
//!
//! Self-intersection is avoided the way pbrt-v3/v4 do it (Pharr, Jakob, Humphreys, "Physically
//! Based Rendering", §3.9): each intersection reports a conservative bound on the absolute error
//! of its computed point, and a spawned ray starts at the point pushed along the geometric normal
//! by just that bound, rounded away from the surface. No fixed epsilon, so it works at every
//! scale.

#[cfg(test)]
use crate::lanes::LANES;
use crate::lanes::{F8, U8x, V8};
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
    let d = n.abs().dot(p_error);
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

/// [`offset_ray_origin`] of eight points at once: lane by lane the same operations and the
/// same one-ulp rounding (as bit arithmetic across lanes), so the same bits.
#[inline(always)]
#[must_use]
pub fn offset_ray_origin8(p: V8, p_error: V8, n: V8, w: V8) -> V8 {
    let d = n.abs().dot(p_error);
    let offset = n.scale(d);
    let offset = V8::select(w.dot(n).lt(F8::ZERO), -offset, offset);
    let po = p + offset;
    V8::new(round_away8(po.x, offset.x), round_away8(po.y, offset.y), round_away8(po.z, offset.z))
}

/// Per lane: [`next_float_up`] of `v` where `o` > 0, [`next_float_down`] where `o` < 0, `v`
/// itself where `o` is 0 or NaN.
#[inline(always)]
fn round_away8(v: F8, o: F8) -> F8 {
    let bits = v.to_bits();
    let one = U8x::splat(1);
    let (plus, minus) = (bits.wrapping_add(one), bits.wrapping_sub(one));
    let zero = v.eq(F8::ZERO);
    let (pos, neg) = (v.gt(F8::ZERO), v.lt(F8::ZERO));
    // Up: away from −∞ (±0 → the smallest positive subnormal); +∞ and NaN stay.
    let up = U8x::select(pos, plus, U8x::select(neg, minus, U8x::select(zero, one, bits)));
    let up = U8x::select(v.eq(F8::splat(f32::INFINITY)), bits, up);
    // Down: toward −∞ (±0 → the smallest negative subnormal); −∞ and NaN stay.
    let down = U8x::select(pos, minus, U8x::select(neg, plus, U8x::select(zero, U8x::splat(0x8000_0001), bits)));
    let down = U8x::select(v.eq(F8::splat(f32::NEG_INFINITY)), bits, down);
    let rounded = U8x::select(o.gt(F8::ZERO), up, U8x::select(o.lt(F8::ZERO), down, bits));
    F8::from_bits(rounded)
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

    #[test]
    fn eight_offsets_equal_the_scalar_offset() {
        let p = V8::from_fn(|i| Vec3::new(i as f32 * 1.7 - 3.0, 0.25 * i as f32, -(i as f32).powi(3)));
        let e = V8::from_fn(|i| Vec3::splat(gamma(5) * (1.0 + i as f32)));
        let n = V8::from_fn(|i| Vec3::new((i as f32).sin(), (i as f32).cos(), 0.3).normalize());
        let w = V8::from_fn(|i| if i % 2 == 0 { Vec3::Y } else { -Vec3::X });
        let o = offset_ray_origin8(p, e, n, w);
        for i in 0..LANES {
            assert_eq!(o.lane(i), offset_ray_origin(p.lane(i), e.lane(i), n.lane(i), w.lane(i)), "lane {i}");
        }
    }

    #[test]
    fn eight_roundings_equal_the_scalar_steps() {
        let specials = [
            0.0f32,
            -0.0,
            1.0,
            -1.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            3.5e7,
            -2.25,
        ];
        for &v in &specials {
            for o in [1.0f32, -1.0, 0.0] {
                let got = round_away8(F8::splat(v), F8::splat(o))[0];
                let want = if o > 0.0 {
                    next_float_up(v)
                } else if o < 0.0 {
                    next_float_down(v)
                } else {
                    v
                };
                assert_eq!(got.to_bits(), want.to_bits(), "v {v:e} o {o}");
            }
        }
    }
}
