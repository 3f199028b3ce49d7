//! Eight f32 lanes as a plain array, and the instruction-set switch.
//!
//! The filters' kernels are written once on [`F8`] (element-wise loops over `[f32; 8]` that
//! LLVM turns into one SSE pair or one AVX register) and compiled twice: for the x86-64
//! baseline and, inside `#[target_feature(enable = "avx2,fma")]` wrappers, for AVX2 (see
//! `simd.rs`). Rust never contracts `a * b + c` on its own, so only explicit
//! [`crate::simd::Kernels::mul_add`] calls round differently between the two builds.

use std::ops::{Add, AddAssign, Div, Mul, Sub};
use std::sync::OnceLock;

/// Lanes per vector.
pub(crate) const LANES: usize = 8;

/// Eight f32 as stored in row buffers (`Vec<Chunk>` flattens to `&[f32]` for unaligned access).
pub(crate) type Chunk = [f32; LANES];

/// Eight f32 lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct F8(pub [f32; LANES]);

impl F8 {
    pub(crate) const ZERO: F8 = F8([0.0; LANES]);

    #[inline(always)]
    pub(crate) fn splat(v: f32) -> F8 {
        F8([v; LANES])
    }

    /// `s[i..i + 8]`.
    #[inline(always)]
    pub(crate) fn load(s: &[f32], i: usize) -> F8 {
        let mut a = [0.0; LANES];
        a.copy_from_slice(&s[i..i + LANES]);
        F8(a)
    }

    /// Lane-wise maximum; NaN lanes of `self` become `o`.
    #[inline(always)]
    pub(crate) fn max(self, o: F8) -> F8 {
        let mut r = o.0;
        for i in 0..LANES {
            if self.0[i] > o.0[i] {
                r[i] = self.0[i];
            }
        }
        F8(r)
    }

    /// Lane-wise minimum; NaN lanes of `self` become `o`.
    #[inline(always)]
    pub(crate) fn min(self, o: F8) -> F8 {
        let mut r = o.0;
        for i in 0..LANES {
            if self.0[i] < o.0[i] {
                r[i] = self.0[i];
            }
        }
        F8(r)
    }

    /// `v − v` per lane: 0 where v is finite, NaN where it is NaN or ±∞. Summed over a plane it
    /// tells whether the plane is finite, without a branch per value.
    #[inline(always)]
    #[allow(clippy::eq_op)]
    pub(crate) fn nan_if_not_finite(self) -> F8 {
        self - self
    }

    /// 1.0 in lane l where `start + l` lies in `lo..hi`, else 0.0: a mask to multiply by.
    /// (Floats compared, not integers, so it stays in vector registers; positions are small
    /// integers, exact in f32.)
    #[inline(always)]
    pub(crate) fn window_mask(start: f32, lo: f32, hi: f32) -> F8 {
        let mut r = [0.0; LANES];
        for (l, v) in r.iter_mut().enumerate() {
            let x = start + l as f32;
            *v = if x >= lo && x < hi { 1.0 } else { 0.0 };
        }
        F8(r)
    }

    /// `2^−s` for `s >= 0` (above 126, and NaN, give 2^−126), relative error below 4e-6 (2.6e-6 from the
    /// polynomial, the rest f32 rounding): the
    /// integer part goes into the exponent bits, a degree-4 minimax polynomial covers the
    /// fraction in [−1/2, 1/2]. Vectorises on any x86-64 (no libm call, no `floor`).
    /// `mul_add(a, b, c)` evaluates the polynomial (see [`crate::simd::Kernels::mul_add`]).
    #[inline(always)]
    pub(crate) fn exp2_neg(self, mul_add: impl Fn(F8, F8, F8) -> F8) -> F8 {
        const ROUND: f32 = 12_582_912.0; // 1.5 · 2^23: ROUND − s rounds −s to an integer
        let mut s = self;
        for v in &mut s.0 {
            // NaN fails the comparison and is clamped too.
            if (*v).partial_cmp(&126.0) != Some(std::cmp::Ordering::Less) {
                *v = 126.0;
            }
        }
        let t = F8::splat(ROUND) - s;
        let f = (F8::splat(ROUND) - t) - s; // −s − round(−s), in [−1/2, 1/2]
        let mut p = F8::splat(0.009_570_024);
        for c in [0.055_917_68, 0.240_247_44, 0.693_121_85, 0.999_999_3] {
            p = mul_add(p, f, F8::splat(c));
        }
        // t's low mantissa bits hold round(−s) in two's complement; shifted by 23 they add it
        // to p's exponent (the constant's own bits shift out of the word).
        for i in 0..LANES {
            p.0[i] = f32::from_bits(p.0[i].to_bits().wrapping_add(t.0[i].to_bits() << 23));
        }
        p
    }
}

/// `[f(0), f(1), …]` — `std::array::from_fn` without its out-of-line machinery, which LLVM
/// does not always inline (an outlined call would also lose the AVX2 code generation).
#[inline(always)]
pub(crate) fn array<T: Copy + Default, const N: usize>(mut f: impl FnMut(usize) -> T) -> [T; N] {
    let mut a = [T::default(); N];
    for (i, v) in a.iter_mut().enumerate() {
        *v = f(i);
    }
    a
}

impl Default for F8 {
    fn default() -> Self {
        F8::ZERO
    }
}

/// Scalar twin of [`F8::nan_if_not_finite`].
pub(crate) trait NanIfNotFinite {
    fn nan_if_not_finite(self) -> Self;
}

impl NanIfNotFinite for f32 {
    #[inline(always)]
    #[allow(clippy::eq_op)]
    fn nan_if_not_finite(self) -> f32 {
        self - self
    }
}

macro_rules! lane_op {
    ($trait:ident, $method:ident, $op:tt) => {
        impl $trait for F8 {
            type Output = F8;
            #[inline(always)]
            fn $method(self, o: F8) -> F8 {
                let mut r = self.0;
                for (a, b) in r.iter_mut().zip(o.0) {
                    *a $op b;
                }
                F8(r)
            }
        }
    };
}
lane_op!(Add, add, +=);
lane_op!(Sub, sub, -=);
lane_op!(Mul, mul, *=);
lane_op!(Div, div, /=);

impl AddAssign for F8 {
    #[inline(always)]
    fn add_assign(&mut self, o: F8) {
        *self = *self + o;
    }
}

/// The instruction set a kernel runs with.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// Portable code for the target's baseline (SSE2 on x86-64): the oracle.
    Portable,
    /// The same code compiled with AVX2 and FMA (8 lanes per instruction, fused multiply-adds
    /// in the weighted filters), plus AVX2 intrinsics in the guided filter's horizontal box
    /// sums. Chosen when the CPU reports both.
    Avx2,
}

impl Isa {
    /// The best instruction set of this machine, detected once.
    pub fn detect() -> Isa {
        static ISA: OnceLock<Isa> = OnceLock::new();
        *ISA.get_or_init(|| if crate::simd::Avx2::detect().is_some() { Isa::Avx2 } else { Isa::Portable })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp2_matches_libm_where_it_matters() {
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let s = (i as f32) * 0.000_63; // 0 ..= 126
            let got = F8::splat(s).exp2_neg(|a, b, c| a * b + c).0[0] as f64;
            let want = (-s as f64).exp2();
            worst = worst.max(((got - want) / want).abs());
        }
        assert!(worst < 4e-6, "relative error {worst}");
        let e = |s: f32| F8::splat(s).exp2_neg(|a, b, c| a * b + c).0[0];
        assert_eq!(e(0.0), 0.999_999_3);
        assert!(e(1e30) > 0.0 && e(1e30) < 1.2e-38);
        assert!(e(f32::NAN) < 1.2e-38);
    }
}
