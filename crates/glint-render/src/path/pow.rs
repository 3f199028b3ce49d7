//! `xʸ` for the Phong lobe (`cosⁿ α`, and `u^(1/(n+1))` when it is sampled), in eight lanes:
//! `exp2(y · log2 x)` from two polynomials, written once on the lane types of
//! `glint_accel::lanes`. No operation is fused, so every lane has the same bits on every
//! instruction set, and [`pow`] (the recursive integrator's, one lane of the same code) agrees
//! bit for bit with the wavefront's lanes ([`pow8`]). libm's `powf`, called lane by lane, was
//! 2.5 % of a Sponza path frame.
//!
//! Accuracy (tested against f64): within 2 · 10⁻⁷ relative where `|y log2 x| ≤ 1`, and within
//! `|y log2 x| · 2 · 10⁻⁷` beyond (the exponent's absolute error, scaled by the result), far below
//! what a lobe's sampling noise can show.
//!
//! 1. `log2 x = e + log2 m` with `x = m · 2ᵉ`, `m ∈ [√½, √2)`; `log2 m = (2 / ln 2) · atanh t`,
//!    `t = (m − 1) / (m + 1)`, `|t| ≤ 0.172`: the odd series to `t⁹` (the next term is below
//!    4 · 10⁻¹⁰).
//! 2. `exp2 z = 2ᵏ · e^(f ln 2)` with `k = ⌊z + ½⌋`, `f = z − k ∈ [−½, ½)`: Taylor to the 7th
//!    power (the next term is below 6 · 10⁻⁹); `2ᵏ` built from its exponent bits.

use glint_accel::lanes::{F8, Isa, Sse, U8x};
use std::f32::consts::{LN_2, SQRT_2};

/// `xʸ` in every lane, for `y > 0` and `x ≤ 1` (up to rounding: a cosine). Lanes where `x` is
/// below the smallest normal float, not positive, or NaN give 0.
#[inline(always)]
pub(super) fn pow8<I: Isa>(x: F8<I>, y: F8<I>) -> F8<I> {
    let z = (y * log2(x)).max(F8::splat(-126.0)).min(F8::splat(64.0));
    F8::select(x.ge(F8::splat(f32::MIN_POSITIVE)), exp2(z), F8::zero())
}

/// `xʸ` for one `x` and `y`: lane 0 of [`pow8`] (same bits).
#[inline]
pub(super) fn pow(x: f32, y: f32) -> f32 {
    pow8::<Sse>(F8::splat(x), F8::splat(y))[0]
}

/// Step 1 for normal positive `x` (other lanes: any value).
#[inline(always)]
fn log2<I: Isa>(x: F8<I>) -> F8<I> {
    let bits = x.to_bits();
    let e = bits.shift_right(23).to_f32() - F8::splat(127.0);
    let m = F8::from_bits(bits.and(0x007f_ffff).or(0x3f80_0000));
    let big = m.gt(F8::splat(SQRT_2));
    let m = F8::select(big, m * F8::splat(0.5), m);
    let e = F8::select(big, e + F8::one(), e);
    let t = (m - F8::one()) / (m + F8::one());
    let t2 = t * t;
    let c = |k: f32| F8::splat(2.0 / (k * LN_2));
    let p = ((((c(9.0) * t2 + c(7.0)) * t2 + c(5.0)) * t2 + c(3.0)) * t2) + c(1.0);
    e + t * p
}

/// Step 2 for `z ∈ [−126, 64]`.
#[inline(always)]
fn exp2<I: Isa>(z: F8<I>) -> F8<I> {
    let k = (z + F8::splat(0.5)).floor();
    let g = (z - k) * F8::splat(LN_2);
    let mut p = F8::splat(1.0 / 5040.0);
    for c in [1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 0.5, 1.0, 1.0] {
        p = p * g + F8::splat(c);
    }
    // k + 127 ∈ [1, 191]: a normal float's exponent field.
    let scale = F8::from_bits(k.trunc_to_u32().wrapping_add(U8x::splat(127)).shift_left(23));
    p * scale
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_accel::lanes::{LANES, LaneKernel, dispatch};
    use glint_core::random::{hash4, unit_float};

    /// Inputs across the range: cosines from 1e-30 to 1 (and a rounding past 1), exponents of
    /// Phong lobes and of their sampling (1 / (n + 1)).
    fn cases() -> Vec<(f32, f32)> {
        let mut out = Vec::new();
        let ys = [1e-4, 1.0 / 10001.0, 1.0 / 33.0, 0.5, 1.0, 1.5, 2.0, 7.0, 32.0, 100.0, 1000.0, 10000.0];
        for i in 0..4000u64 {
            let r = unit_float(hash4(i, 0, 0, 11));
            let x = if i % 4 == 0 { 10f32.powf(-30.0 * r) } else { r };
            out.push((x, ys[i as usize % ys.len()]));
        }
        for y in ys {
            out.extend([(1.0, y), (1.0 + f32::EPSILON, y), (f32::MIN_POSITIVE, y), (0.5, y), (0.999_999, y)]);
        }
        out
    }

    #[test]
    fn pow_is_close_to_libm() {
        for (x, y) in cases() {
            let want = (x as f64).powf(y as f64);
            let got = pow(x, y) as f64;
            let z = (y as f64 * (x as f64).log2()).abs();
            if want < 1e-37 {
                assert!(got < 1e-36, "pow({x}, {y}) = {got}, want {want}");
                continue;
            }
            let tolerance = 2e-7 * z.max(1.0);
            assert!(((got - want) / want).abs() <= tolerance, "pow({x}, {y}) = {got}, want {want}");
        }
    }

    #[test]
    fn below_normal_zero_and_nan_give_zero() {
        for x in [0.0, -0.0, -0.5, f32::MIN_POSITIVE / 2.0, f32::NAN] {
            assert_eq!(pow(x, 3.0), 0.0, "pow({x}, 3)");
        }
        assert_eq!(pow(1.0, 50.0), 1.0);
    }

    /// Eight lanes on each instruction set give lane 0's bits: the scalar oracle and the
    /// wavefront's lanes agree bit for bit.
    #[test]
    fn lanes_equal_the_scalar_pow_on_every_instruction_set() {
        struct Kernel(Vec<(f32, f32)>);
        impl LaneKernel for Kernel {
            type Output = Vec<u32>;
            fn run<I: Isa>(self) -> Vec<u32> {
                let mut out = Vec::new();
                for chunk in self.0.chunks(LANES) {
                    let x = F8::<I>::from_fn(|i| chunk[i % chunk.len()].0);
                    let y = F8::<I>::from_fn(|i| chunk[i % chunk.len()].1);
                    let r = pow8(x, y);
                    out.extend((0..chunk.len()).map(|i| r[i].to_bits()));
                }
                out
            }
        }
        let cases = cases();
        let scalar: Vec<u32> = cases.iter().map(|&(x, y)| pow(x, y).to_bits()).collect();
        for baseline in [true, false] {
            assert_eq!(dispatch(Kernel(cases.clone()), baseline), scalar, "baseline {baseline}");
        }
    }
}
