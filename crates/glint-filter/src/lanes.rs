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

/// `N` f32 lanes: eight ([`F8`]) in every kernel, sixteen in the AVX-512 build of A-Trous.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Wide<const N: usize>(pub [f32; N]);

/// Eight f32 lanes.
pub(crate) type F8 = Wide<LANES>;

impl<const N: usize> Wide<N> {
    pub(crate) const ZERO: Self = Wide([0.0; N]);

    #[inline(always)]
    pub(crate) fn splat(v: f32) -> Self {
        Wide([v; N])
    }

    /// `s[i..i + N]`.
    #[inline(always)]
    pub(crate) fn load(s: &[f32], i: usize) -> Self {
        let mut a = [0.0; N];
        a.copy_from_slice(&s[i..i + N]);
        Wide(a)
    }

    /// Lane-wise maximum; NaN lanes of `self` become `o`.
    #[inline(always)]
    pub(crate) fn max(self, o: Self) -> Self {
        let mut r = o.0;
        for i in 0..N {
            if self.0[i] > o.0[i] {
                r[i] = self.0[i];
            }
        }
        Wide(r)
    }

    /// Lane-wise minimum; NaN lanes of `self` become `o`.
    #[inline(always)]
    pub(crate) fn min(self, o: Self) -> Self {
        let mut r = o.0;
        for i in 0..N {
            if self.0[i] < o.0[i] {
                r[i] = self.0[i];
            }
        }
        Wide(r)
    }

    /// `v − v` per lane: 0 where v is finite, NaN where it is NaN or ±∞. Summed over a plane it
    /// tells whether the plane is finite, without a branch per value.
    #[inline(always)]
    #[allow(clippy::eq_op)]
    pub(crate) fn nan_if_not_finite(self) -> Self {
        self - self
    }

    /// 1.0 in lane l where `start + l` lies in `lo..hi`, else 0.0: a mask to multiply by.
    /// (Floats compared, not integers, so it stays in vector registers; positions are small
    /// integers, exact in f32.)
    #[inline(always)]
    pub(crate) fn window_mask(start: f32, lo: f32, hi: f32) -> Self {
        let mut r = [0.0; N];
        for (l, v) in r.iter_mut().enumerate() {
            let x = start + l as f32;
            *v = if x >= lo && x < hi { 1.0 } else { 0.0 };
        }
        Wide(r)
    }

    /// `2^−s` for `s >= 0` (above 126, and NaN, give 2^−126), relative error below 4e-6 (2.6e-6
    /// from the polynomial, the rest f32 rounding): the integer part goes into the exponent
    /// bits, a degree-4 minimax polynomial covers the fraction in [−1/2, 1/2]. Vectorises on
    /// any x86-64 (no libm call, no `floor`). `mul_add(a, b, c)` evaluates the polynomial (see
    /// [`crate::simd::Kernels::mul_add`]).
    #[inline(always)]
    pub(crate) fn exp2_neg(self, mul_add: impl Fn(Self, Self, Self) -> Self) -> Self {
        self.exp2_neg_below::<false>(126.0, mul_add)
    }

    /// [`Wide::exp2_neg`], but exactly 0 from s = 40 on (and for NaN); every nonzero result
    /// is a normal number. One compare and select more, for filters that iterate.
    ///
    /// Why zero below 2^−40: a weighted filter divides by a weight sum of at least its centre
    /// tap's (0.14 for A-Trous), so such a weight moves a pixel by at most 2^−37 of its
    /// partner's colour, far below f32's rounding of any visible value. Carried into the sums,
    /// though, weights of 2^−60…2^−126 turn black pixels next to bright ones into values near
    /// 1e-20…1e-37; the next iteration squares their differences, and every product that
    /// underflows costs a microcode assist: on this Zen 5, A-Trous's second iteration took
    /// 6.5 ms on one thread instead of 4.9 (BENCHMARKS.md §13.5).
    #[inline(always)]
    pub(crate) fn exp2_neg_or_zero(self, mul_add: impl Fn(Self, Self, Self) -> Self) -> Self {
        self.exp2_neg_below::<true>(40.0, mul_add)
    }

    /// 2^−min(s, `limit`), or 0 where s ≥ `limit` if `ZERO` (NaN counts as beyond `limit`).
    #[inline(always)]
    fn exp2_neg_below<const ZERO: bool>(self, limit: f32, mul_add: impl Fn(Self, Self, Self) -> Self) -> Self {
        const ROUND: f32 = 12_582_912.0; // 1.5 · 2^23: ROUND − s rounds −s to an integer
        let mut s = self;
        for v in &mut s.0 {
            // NaN fails the comparison and is clamped too.
            if (*v).partial_cmp(&limit) != Some(std::cmp::Ordering::Less) {
                *v = limit;
            }
        }
        let t = Self::splat(ROUND) - s;
        let f = (Self::splat(ROUND) - t) - s; // −s − round(−s), in [−1/2, 1/2]
        let mut p = Self::splat(0.009_570_024);
        for c in [0.055_917_68, 0.240_247_44, 0.693_121_85, 0.999_999_3] {
            p = mul_add(p, f, Self::splat(c));
        }
        // t's low mantissa bits hold round(−s) in two's complement; shifted by 23 they add it
        // to p's exponent (the constant's own bits shift out of the word).
        for i in 0..N {
            let v = f32::from_bits(p.0[i].to_bits().wrapping_add(t.0[i].to_bits() << 23));
            p.0[i] = if ZERO && s.0[i] >= limit { 0.0 } else { v };
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

impl<const N: usize> Default for Wide<N> {
    fn default() -> Self {
        Self::ZERO
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
        impl<const N: usize> $trait for Wide<N> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                let mut r = self.0;
                for (a, b) in r.iter_mut().zip(o.0) {
                    *a $op b;
                }
                Wide(r)
            }
        }
    };
}
lane_op!(Add, add, +=);
lane_op!(Sub, sub, -=);
lane_op!(Mul, mul, *=);
lane_op!(Div, div, /=);

impl<const N: usize> AddAssign for Wide<N> {
    #[inline(always)]
    fn add_assign(&mut self, o: Self) {
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
    /// AVX2's kernels, and A-Trous in 16 lanes with AVX-512 F and VL (the same operations lane
    /// for lane, so the same bits as AVX2). Chosen when the CPU reports AVX-512 F and VL too.
    Avx512,
}

impl Isa {
    /// The best instruction set of this machine, detected once.
    pub fn detect() -> Isa {
        static ISA: OnceLock<Isa> = OnceLock::new();
        *ISA.get_or_init(|| {
            if crate::simd::Avx512::detect().is_some() {
                Isa::Avx512
            } else if crate::simd::Avx2::detect().is_some() {
                Isa::Avx2
            } else {
                Isa::Portable
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exp2_matches_libm_where_it_matters() {
        let e = |s: f32| F8::splat(s).exp2_neg(|a, b, c| a * b + c).0[0];
        let z = |s: f32| F8::splat(s).exp2_neg_or_zero(|a, b, c| a * b + c).0[0];
        let mut worst = 0.0f64;
        for i in 0..=200_000 {
            let s = (i as f32) * 0.000_63; // 0 ..= 126
            let want = (-s as f64).exp2();
            worst = worst.max(((f64::from(e(s)) - want) / want).abs());
            // The same bits as far as the cut.
            if s < 40.0 {
                assert_eq!(z(s).to_bits(), e(s).to_bits(), "2^-{s}");
            }
        }
        assert!(worst < 4e-6, "relative error {worst}");
        assert_eq!(e(0.0), 0.999_999_3);
        assert!(e(1e30) > 0.0 && e(1e30) < 1.2e-38);
        assert!(e(f32::NAN) < 1.2e-38);
        // Past the cut, and undefined, exponents give zero with the cut; never a subnormal.
        for s in [40.0, 40.5, 125.0, 126.0, 1e30, f32::INFINITY, f32::NAN] {
            assert_eq!(z(s).to_bits(), 0, "2^-{s}");
        }
        for i in 0..1000 {
            let s = 35.0 + i as f32 * 0.005;
            assert!(z(s).is_normal(), "2^-{s} gave {}", z(s));
        }
    }
}
