//! Fixed-point sums of radiance: integers add in any order, so a pixel's sum over a frame's
//! passes is the same however the passes are grouped (one process, or chunks rendered on
//! several machines and merged: `chunk.rs`). Film → here → film/chunk files.
//!
//! **The grid.** A sample's value `v` (f32) becomes `trunc(v · 2^56)` in an `i128`. Multiplying
//! by a power of two is exact, so every f32 of magnitude at least 2^-33 (≈ 1.2e-10) is kept
//! bit for bit (its 24-bit mantissa sits above the grid); smaller magnitudes lose the bits
//! below 2^-56. One sample's term is saturated at ±2^106, which only values beyond
//! [`crate::MAX_SAMPLE_RADIANCE`] reach (1e15 · 2^56 < 2^105.9; the path tracer bounds every
//! sample's radiance by it; only a filter's output could exceed it; with a filter a term is a
//! pass's sum over its samples, saturated alike, so only a pass mean above 1e15 / spp reaches
//! it). A pixel sums at most
//! [`MAX_TERMS`] = 2^20 terms (`limits::SPP`'s 65 536 × 16 passes, the path settings' cap), so
//! |sum| ≤ 2^126 < 2^127: **no sum can overflow**.
//!
//! **Squares** (the variance AOV) need twice the range: `v²` (exact in f64: 48 mantissa bits)
//! becomes `trunc(v² · 2^64)` in an unsigned 192-bit [`Square`]: at most 2^100 · 2^64 = 2^164
//! per term below the radiance bound (saturated there), 2^184 < 2^192 for 2^20 terms.
//!
//! Converting a term costs one f64 multiply and a truncation (`cvttsd2si` for the common
//! |v| < 128; the wide conversion otherwise); adding is two machine adds. BENCHMARKS.md
//! measures it on a whole frame.

use glint_core::Rgb;

/// Bits of a fixed-point value below the binary point.
pub const FRACTION_BITS: i32 = 56;
/// The most terms one pixel's sum may hold (so that the sum cannot overflow).
pub const MAX_TERMS: u64 = 1 << 20;
const SCALE: f64 = (1u64 << FRACTION_BITS) as f64;
/// The largest magnitude of one term (2^106).
const TERM_LIMIT: f64 = 81_129_638_414_606_681_695_789_005_144_064.0;
/// Below this magnitude a term fits an i64: the fast conversion.
const FAST_LIMIT: f64 = 9.0e18;

/// `v` on the grid (see the module comment); NaN gives 0, beyond ±2^106 saturates.
#[inline]
#[must_use]
pub fn quantise(v: f32) -> i128 {
    on_grid(scaled(v))
}

/// `v` on the grid's scale, `v · 2^56` in f64: exact (a power of two), and exact again when
/// multiplied by another f32 (24 + 24 mantissa bits fit f64's 53), so a weighted term
/// `on_grid(scaled(v) * f64::from(w))` is `trunc(v · w · 2^56)` exactly.
#[inline]
#[must_use]
pub fn scaled(v: f32) -> f64 {
    f64::from(v) * SCALE
}

/// A value already on the grid's scale (see [`scaled`]) as a term: truncated; NaN gives 0,
/// beyond ±2^106 saturates.
#[inline]
#[must_use]
pub fn on_grid(x: f64) -> i128 {
    if x.abs() < FAST_LIMIT { x as i64 as i128 } else { x.clamp(-TERM_LIMIT, TERM_LIMIT) as i128 }
}

/// The largest magnitude of a value whose [`scaled`] form, times a weight in [0, 1], fits the
/// fast conversion (`on_grid` without its range check): 2^63 / 2^56 = 128, less a margin.
pub const SMALL: f32 = 120.0;

/// Add an RGB value to a sum.
#[inline]
pub fn add_rgb(sum: &mut [i128; 3], v: Rgb) {
    sum[0] += quantise(v.x);
    sum[1] += quantise(v.y);
    sum[2] += quantise(v.z);
}

/// The sum's value in f64 (rounded to nearest).
#[inline]
#[must_use]
pub fn value(sum: i128) -> f64 {
    // Both conversions round to nearest, so within i64's range the machine's one-instruction
    // conversion gives the same f64 as the 128-bit library call (`__floattidf`, 1.5 % of a
    // Sponza path frame when every pixel's sums took it). LLVM knows they agree and folds the
    // fast branch back into the library call; `black_box` keeps the 64-bit value apart.
    match i64::try_from(sum) {
        Ok(s) => std::hint::black_box(s) as f64 / SCALE,
        Err(_) => sum as f64 / SCALE,
    }
}

/// The mean of `n` terms whose sum is `sum` (n = 0 reads as 1), rounded once to f32. One term
/// gives its value back bit for bit when it was on the grid.
#[inline]
#[must_use]
pub fn mean(sum: &[i128; 3], n: u64) -> Rgb {
    let n = n.max(1) as f64;
    Rgb::new((value(sum[0]) / n) as f32, (value(sum[1]) / n) as f32, (value(sum[2]) / n) as f32)
}

/// The weighted mean `sum / weight` of a splatted pixel ([`crate::path::PathSums::splat`]),
/// rounded once to f32; 0 where nothing reached the pixel (`weight` ≤ 0).
#[inline]
#[must_use]
pub fn ratio(sum: &[i128; 3], weight: i128) -> Rgb {
    if weight <= 0 {
        return Rgb::ZERO;
    }
    let w = value(weight);
    Rgb::new((value(sum[0]) / w) as f32, (value(sum[1]) / w) as f32, (value(sum[2]) / w) as f32)
}

/// A sum of squares: `trunc(v² · 2^64)` per term, in 192 bits (`hi · 2^128 + lo`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Square {
    pub lo: u128,
    pub hi: u64,
}

/// Below this square (2^63) the integer part fits a u64: the fast conversion.
const FAST_SQUARE: f64 = 9_223_372_036_854_775_808.0;

/// The largest square term, 2^164 (the radiance bound's square on the grid), as an integer
/// part (of v²) below 2^100.
const SQUARE_INT_LIMIT: f64 = 1_267_650_600_228_229_401_496_703_205_376.0; // 2^100

impl Square {
    /// Add `v²`.
    #[inline]
    pub fn add_square(&mut self, v: f32) {
        let s = f64::from(v) * f64::from(v);
        if s < FAST_SQUARE {
            // The common case in machine words: integer and fraction parts below 2^64.
            let int = s as u64;
            let frac = ((s - int as f64) * 18_446_744_073_709_551_616.0) as u64;
            self.add(Square { lo: u128::from(int) << 64 | u128::from(frac), hi: 0 });
            return;
        }
        let (int, frac) = if s < SQUARE_INT_LIMIT {
            let int = s.trunc();
            (int as u128, ((s - int) * 18_446_744_073_709_551_616.0) as u64)
        } else if s.is_nan() {
            (0, 0)
        } else {
            (1u128 << 100, 0)
        };
        self.add(Square { lo: (int << 64) | u128::from(frac), hi: (int >> 64) as u64 });
    }

    /// Add another sum.
    #[inline]
    pub fn add(&mut self, other: Square) {
        let (lo, carry) = self.lo.overflowing_add(other.lo);
        self.lo = lo;
        self.hi = self.hi.wrapping_add(other.hi).wrapping_add(u64::from(carry));
    }

    /// The sum's value in f64.
    #[must_use]
    pub fn value(&self) -> f64 {
        (self.hi as f64 * 2f64.powi(128) + self.lo as f64) / 2f64.powi(64)
    }
}

/// Little-endian 32-bit words of a value (how chunk files store it losslessly).
#[must_use]
pub fn words_i128(v: i128) -> [u32; 4] {
    let u = v as u128;
    [u as u32, (u >> 32) as u32, (u >> 64) as u32, (u >> 96) as u32]
}

/// The value of [`words_i128`]'s words.
#[must_use]
pub fn from_words_i128(w: [u32; 4]) -> i128 {
    (u128::from(w[0]) | u128::from(w[1]) << 32 | u128::from(w[2]) << 64 | u128::from(w[3]) << 96) as i128
}

impl Square {
    /// Little-endian 32-bit words (lo's four, then hi's two).
    #[must_use]
    pub fn words(&self) -> [u32; 6] {
        let l = words_i128(self.lo as i128);
        [l[0], l[1], l[2], l[3], self.hi as u32, (self.hi >> 32) as u32]
    }

    /// The value of [`Square::words`]'s words.
    #[must_use]
    pub fn from_words(w: [u32; 6]) -> Self {
        Square { lo: from_words_i128([w[0], w[1], w[2], w[3]]) as u128, hi: u64::from(w[4]) | u64::from(w[5]) << 32 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_above_the_grid_come_back_bit_for_bit() {
        for v in [0.0f32, 1.0, -1.0, 0.1, 3.7e-9, 1.2e-10, 127.9, 128.0, 6.5e4, 1e15, -1e15, f32::MIN_POSITIVE * 1e30] {
            let q = quantise(v);
            assert_eq!(mean(&[q, q, q], 1).x.to_bits(), v.to_bits(), "{v:e}");
        }
        // Below 2^-56 the grid has nothing; NaN is nothing; beyond the term limit saturates.
        assert_eq!(quantise(1e-20), 0);
        assert_eq!(quantise(f32::NAN), 0);
        assert_eq!(quantise(f32::INFINITY), 1i128 << 106);
        assert_eq!(quantise(f32::NEG_INFINITY), -(1i128 << 106));
        assert_eq!(quantise(f32::MAX), 1i128 << 106);
    }

    #[test]
    fn the_largest_sums_do_not_overflow() {
        // MAX_TERMS saturated terms of either sign.
        let most = (1i128 << 106) * MAX_TERMS as i128;
        assert!(most.checked_add(0).is_some() && most < i128::MAX && -most > i128::MIN);
        let mut s = Square::default();
        let top = {
            let mut t = Square::default();
            t.add_square(f32::INFINITY);
            t
        };
        assert_eq!(top, Square { lo: 0, hi: 1 << 36 }, "2^164");
        for _ in 0..MAX_TERMS {
            s.add(top);
        }
        assert_eq!(s, Square { lo: 0, hi: 1 << 56 }, "2^184, no wrap");
    }

    #[test]
    fn values_convert_as_the_wide_conversion_does() {
        // Around i64's ends (where the fast path stops) and at halfway cases of f64 rounding.
        let edges =
            [i128::from(i64::MAX), i128::from(i64::MIN), (1i128 << 53) + 1, (1i128 << 54) + 2, (1i128 << 54) + 6];
        for base in edges {
            for d in -3..=3i128 {
                for sum in [base + d, -(base + d)] {
                    assert_eq!(value(sum).to_bits(), (sum as f64 / SCALE).to_bits(), "{sum}");
                }
            }
        }
        for sum in [0i128, 1, -1, 1i128 << 126, -(1i128 << 126), 12_345_678_901_234_567_890_123] {
            assert_eq!(value(sum).to_bits(), (sum as f64 / SCALE).to_bits(), "{sum}");
        }
    }

    #[test]
    fn sums_do_not_depend_on_grouping() {
        // Float sums do (this set is chosen so that they do); the fixed-point sums do not.
        let v: Vec<f32> = (0..1000).map(|i| ((i * 7919 % 1000) as f32 * 0.37).powf(1.7) * 1e-3 + 1e-7).collect();
        let whole: i128 = v.iter().map(|&x| quantise(x)).sum();
        for chunks in [2, 3, 7, 13] {
            let part = v.len().div_ceil(chunks);
            let grouped: i128 = v.chunks(part).map(|c| c.iter().map(|&x| quantise(x)).sum::<i128>()).rev().sum();
            assert_eq!(grouped, whole, "{chunks} chunks");
        }
        let (fwd, back) = (v.iter().sum::<f32>(), v.iter().rev().sum::<f32>());
        assert_ne!(fwd, back, "the float sums agree: a weak test set");
    }

    #[test]
    fn squares_add_exactly_and_round_trip_as_words() {
        let mut s = Square::default();
        for v in [0.5f32, 3.0, 1e10, 1e-3] {
            s.add_square(v);
        }
        let expect = 0.25 + 9.0 + 1e20 + (1e-3f32 as f64).powi(2);
        assert!((s.value() - expect).abs() <= expect * 1e-15, "{} vs {expect}", s.value());
        assert_eq!(Square::from_words(s.words()), s);
        // The fast (below 2^63) and the wide conversion agree where both apply.
        for v in [1.5f32, 0.1, 7.3e4, 2.9e9, 3.0e9] {
            let mut fast = Square::default();
            fast.add_square(v);
            let sq = f64::from(v) * f64::from(v);
            let int = sq.trunc();
            let wide = Square { lo: (int as u128) << 64 | u128::from(((sq - int) * 2f64.powi(64)) as u64), hi: 0 };
            assert_eq!(fast, wide, "{v}");
        }
        for v in [0i128, -1, 1 << 100, -(1 << 126), i128::MAX] {
            assert_eq!(from_words_i128(words_i128(v)), v);
        }
    }
}
