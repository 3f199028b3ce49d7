//! Eight lanes: the vocabulary of batched kernels (eight rays, eight hits, eight shading
//! points at once, structure of arrays).
//!
//! [`F8`] (f32), [`U8x`] (u32) and [`M8`] (a lane mask) are plain arrays with element-wise
//! operations, every one `#[inline(always)]`. They hold no `unsafe` and name no instruction
//! set: a kernel written on them is compiled once for the x86-64 baseline (LLVM turns each
//! operation into an SSE pair) and once inside a `#[target_feature(enable = "avx2,fma")]`
//! entry point (one AVX register), the instruction set chosen at run time by the caller. Rust
//! never contracts `a * b + c` into a fused multiply-add, so both builds give the same bits,
//! and every lane performs exactly the operations, in the order, of the scalar code it mirrors.

use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Index, IndexMut, Mul, MulAssign, Neg, Not, Sub};
use wide::{f32x8, i32x8, u32x8};

/// Lanes per vector.
pub const LANES: usize = 8;

/// Eight f32 lanes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[repr(transparent)]
pub struct F8(pub f32x8);

/// Eight u32 lanes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(transparent)]
pub struct U8x(pub u32x8);

/// A lane mask: all ones where true, zero where false (what a vector compare yields), kept
/// in float lanes so that selecting floats needs no conversion.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M8(f32x8);

/// Masks compare by their lanes' truth (their float view would be NaN).
impl PartialEq for M8 {
    fn eq(&self, o: &M8) -> bool {
        self.bits() == o.bits()
    }
}

impl std::fmt::Debug for M8 {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "M8({:08b})", self.bits().reverse_bits() >> 24)
    }
}

impl Index<usize> for F8 {
    type Output = f32;
    #[inline(always)]
    fn index(&self, i: usize) -> &f32 {
        &self.0.as_array()[i]
    }
}

impl IndexMut<usize> for F8 {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut self.0.as_mut_array()[i]
    }
}

impl Index<usize> for U8x {
    type Output = u32;
    #[inline(always)]
    fn index(&self, i: usize) -> &u32 {
        &self.0.as_array()[i]
    }
}

impl IndexMut<usize> for U8x {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut u32 {
        &mut self.0.as_mut_array()[i]
    }
}

macro_rules! binary {
    ($t:ident, $tr:ident, $f:ident) => {
        impl $tr for $t {
            type Output = $t;
            #[inline(always)]
            fn $f(self, o: $t) -> $t {
                $t(self.0.$f(o.0))
            }
        }
    };
}

binary!(F8, Add, add);
binary!(F8, Sub, sub);
binary!(F8, Mul, mul);
binary!(F8, Div, div);
binary!(M8, BitAnd, bitand);
binary!(M8, BitOr, bitor);

impl Neg for F8 {
    type Output = F8;
    #[inline(always)]
    fn neg(self) -> F8 {
        F8(-self.0)
    }
}

impl AddAssign for F8 {
    #[inline(always)]
    fn add_assign(&mut self, o: F8) {
        *self = *self + o;
    }
}

impl MulAssign for F8 {
    #[inline(always)]
    fn mul_assign(&mut self, o: F8) {
        *self = *self * o;
    }
}

impl Not for M8 {
    type Output = M8;
    #[inline(always)]
    fn not(self) -> M8 {
        M8(self.0 ^ M8::ALL.0)
    }
}

impl F8 {
    pub const ZERO: F8 = F8(f32x8::ZERO);
    pub const ONE: F8 = F8(f32x8::ONE);

    #[inline(always)]
    #[must_use]
    pub fn splat(v: f32) -> F8 {
        F8(f32x8::splat(v))
    }

    #[inline(always)]
    #[must_use]
    pub const fn from_array(a: [f32; LANES]) -> F8 {
        F8(f32x8::new(a))
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    #[must_use]
    pub fn from_fn(f: impl FnMut(usize) -> f32) -> F8 {
        F8::from_array(std::array::from_fn(f))
    }

    #[inline(always)]
    #[must_use]
    pub fn to_array(self) -> [f32; LANES] {
        self.0.to_array()
    }

    #[inline(always)]
    #[must_use]
    pub fn sqrt(self) -> F8 {
        F8(self.0.sqrt())
    }

    #[inline(always)]
    #[must_use]
    pub fn abs(self) -> F8 {
        F8(self.0.abs())
    }

    #[inline(always)]
    #[must_use]
    pub fn floor(self) -> F8 {
        F8(self.0.floor())
    }

    /// `self` with the sign of `o`.
    #[inline(always)]
    #[must_use]
    pub fn copysign(self, o: F8) -> F8 {
        let sign = f32x8::splat(-0.0);
        F8((self.0 & !sign) | (o.0 & sign))
    }

    /// Lane-wise maximum with x86 `maxps` semantics: `o` where either is NaN or they are
    /// equal, so `v.max(F8::ZERO)` maps NaN to 0 (as the scalar code's `if v > o`).
    #[inline(always)]
    #[must_use]
    pub fn max(self, o: F8) -> F8 {
        F8::select(self.gt(o), self, o)
    }

    /// Lane-wise minimum with `minps` semantics (`o` where either is NaN).
    #[inline(always)]
    #[must_use]
    pub fn min(self, o: F8) -> F8 {
        F8::select(self.lt(o), self, o)
    }

    #[inline(always)]
    #[must_use]
    pub fn lt(self, o: F8) -> M8 {
        M8(self.0.simd_lt(o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn le(self, o: F8) -> M8 {
        M8(self.0.simd_le(o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn gt(self, o: F8) -> M8 {
        M8(self.0.simd_gt(o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn ge(self, o: F8) -> M8 {
        M8(self.0.simd_ge(o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn eq(self, o: F8) -> M8 {
        M8(self.0.simd_eq(o.0))
    }

    /// NaN lanes (false for everything else).
    #[inline(always)]
    #[must_use]
    pub fn is_nan(self) -> M8 {
        M8(self.0.is_nan())
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8, a: F8, b: F8) -> F8 {
        F8(m.0.select(a.0, b.0))
    }

    /// The bit patterns.
    #[inline(always)]
    #[must_use]
    pub fn to_bits(self) -> U8x {
        U8x(bytemuck::cast(self.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn from_bits(b: U8x) -> F8 {
        F8(bytemuck::cast(b.0))
    }

    /// Sum of the lanes in order (lane 0 first).
    #[must_use]
    pub fn sum(self) -> f32 {
        self.to_array().iter().sum()
    }
}

impl U8x {
    #[inline(always)]
    #[must_use]
    pub fn splat(v: u32) -> U8x {
        U8x(u32x8::splat(v))
    }

    #[inline(always)]
    #[must_use]
    pub const fn from_array(a: [u32; LANES]) -> U8x {
        U8x(u32x8::new(a))
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8, a: U8x, b: U8x) -> U8x {
        U8x(m.as_u32().select(a.0, b.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn eq(self, o: U8x) -> M8 {
        M8(bytemuck::cast(self.0.simd_eq(o.0)))
    }

    /// Lane-wise `self >> n`.
    #[inline(always)]
    #[must_use]
    pub fn shift_right(self, n: u32) -> U8x {
        U8x(self.0 >> n)
    }

    /// Lane-wise `self & mask`.
    #[inline(always)]
    #[must_use]
    pub fn and(self, mask: u32) -> U8x {
        U8x(self.0 & u32x8::splat(mask))
    }

    /// Lane-wise `self | bits`.
    #[inline(always)]
    #[must_use]
    pub fn or(self, bits: u32) -> U8x {
        U8x(self.0 | u32x8::splat(bits))
    }

    /// Lane-wise `self << n`.
    #[inline(always)]
    #[must_use]
    pub fn shift_left(self, n: u32) -> U8x {
        U8x(self.0 << n)
    }

    /// The lanes as f32, for values below 2^31 (converted as signed integers, one vector
    /// instruction).
    #[inline(always)]
    #[must_use]
    pub fn to_f32(self) -> F8 {
        F8(f32x8::from_i32x8(bytemuck::cast::<u32x8, i32x8>(self.0)))
    }

    /// Lane-wise wrapping sum.
    #[inline(always)]
    #[must_use]
    pub fn wrapping_add(self, o: U8x) -> U8x {
        U8x(self.0 + o.0)
    }

    /// Lane-wise wrapping difference.
    #[inline(always)]
    #[must_use]
    pub fn wrapping_sub(self, o: U8x) -> U8x {
        U8x(self.0 - o.0)
    }
}

impl F8 {
    /// Truncated to integers (lanes in the i32 range), as u32 bit patterns.
    #[inline(always)]
    #[must_use]
    pub fn trunc_to_u32(self) -> U8x {
        U8x(bytemuck::cast(self.0.trunc_int()))
    }
}

impl M8 {
    pub const NONE: M8 = M8(f32x8::ZERO);
    pub const ALL: M8 = M8(f32x8::new([f32::from_bits(u32::MAX); LANES]));

    #[inline(always)]
    fn as_u32(self) -> u32x8 {
        bytemuck::cast(self.0)
    }

    /// Lanes `0..n` set.
    #[inline(always)]
    #[must_use]
    pub fn first(n: usize) -> M8 {
        M8::from_bits(if n >= LANES { 0xff } else { (1u32 << n) - 1 })
    }

    /// The mask of the bits of `b` (bit i = lane i).
    #[inline(always)]
    #[must_use]
    pub fn from_bits(b: u32) -> M8 {
        let bit = u32x8::new([1, 2, 4, 8, 16, 32, 64, 128]);
        M8(bytemuck::cast((u32x8::splat(b) & bit).simd_eq(bit)))
    }

    /// Lane `i` set where `f(i)`.
    #[inline(always)]
    #[must_use]
    pub fn from_fn(mut f: impl FnMut(usize) -> bool) -> M8 {
        let mut b = 0;
        for i in 0..LANES {
            b |= u32::from(f(i)) << i;
        }
        M8::from_bits(b)
    }

    /// Bit i set where lane i is.
    #[inline(always)]
    #[must_use]
    pub fn bits(self) -> u32 {
        self.0.to_bitmask()
    }

    #[inline(always)]
    #[must_use]
    pub fn any(self) -> bool {
        self.0.any()
    }

    #[inline(always)]
    #[must_use]
    pub fn none(self) -> bool {
        !self.0.any()
    }

    #[inline(always)]
    #[must_use]
    pub fn all(self) -> bool {
        self.0.all()
    }

    #[inline(always)]
    #[must_use]
    pub fn lane(self, i: usize) -> bool {
        self.0.as_array()[i].to_bits() != 0
    }

    /// `self` and not `o`.
    #[inline(always)]
    #[must_use]
    pub fn and_not(self, o: M8) -> M8 {
        self & !o
    }
}

/// `x^y` per lane for `x` in [0, 1] and `y` > 0 (Phong's `max(R·V, 0)^n`), by
/// `exp2(y · log2 x)` with polynomials: relative error below 3e-5 against f64 where the result
/// is above 1e-30 (tested), 0 where it underflows and for `x = 0`. Lanes outside that domain
/// (`x` > 1, NaN, `y` ≤ 0) are unspecified: callers take [`f32::powf`] there.
#[inline(always)]
#[must_use]
pub fn pow8_unit(x: F8, y: F8) -> F8 {
    exp2_8(y * log2_8(x))
}

/// `log2 x` for finite `x` > 0 (−∞ for 0): exponent from the bits, the mantissa m in
/// [√½, √2) through the odd series of `2·atanh((m − 1)/(m + 1)) / ln 2` up to the 11th power
/// (|error| < 3e-8 absolute over that range).
#[inline(always)]
#[must_use]
pub fn log2_8(x: F8) -> F8 {
    let bits = x.to_bits();
    // Mantissa in [1, 2), moved to [√½, √2) so the series argument stays small.
    let mant = F8::from_bits(bits.and(0x007f_ffff).or(0x3f80_0000));
    let big = mant.gt(F8::splat(std::f32::consts::SQRT_2));
    let m = F8::select(big, mant * F8::splat(0.5), mant);
    let e = bits.shift_right(23).and(0xff).to_f32() - F8::splat(127.0) + F8::select(big, F8::ONE, F8::ZERO);
    let t = (m - F8::ONE) / (m + F8::ONE);
    let t2 = t * t;
    let series = F8::splat(1.0 / 11.0);
    let series = series * t2 + F8::splat(1.0 / 9.0);
    let series = series * t2 + F8::splat(1.0 / 7.0);
    let series = series * t2 + F8::splat(1.0 / 5.0);
    let series = series * t2 + F8::splat(1.0 / 3.0);
    let series = series * t2 + F8::ONE;
    let log = e + t * series * F8::splat(2.0 * std::f32::consts::LOG2_E);
    F8::select(x.eq(F8::ZERO), F8::splat(f32::NEG_INFINITY), log)
}

/// `2^y` for `y` ≤ 0 (0 below −126, where f32 would go subnormal): the integer part into the
/// exponent bits, the fraction f in [0, 1) by the Taylor series of `e^(f ln 2)` to the 8th
/// power (relative error < 2e-7).
#[inline(always)]
#[must_use]
pub fn exp2_8(y: F8) -> F8 {
    // −∞ (and anything that far down) becomes −127: a zero scale below.
    let y = y.max(F8::splat(-127.0));
    let whole = y.floor();
    let f = (y - whole) * F8::splat(std::f32::consts::LN_2);
    let mut p = F8::splat(1.0 / 40320.0);
    for k in (1..=7).rev() {
        let inv_fact = 1.0 / (1..=k).map(|j| j as f32).product::<f32>();
        p = p * f + F8::splat(inv_fact);
    }
    let p = p * f + F8::ONE;
    // 2^whole from the exponent bits; below −126 (subnormal) the scale is 0.
    let biased = (whole + F8::splat(127.0)).max(F8::ZERO);
    let scale = F8::from_bits(biased.trunc_to_u32().shift_left(23));
    p * F8::select(whole.ge(F8::splat(-126.0)), scale, F8::ZERO)
}

/// Three f32 lanes vectors: eight 3-vectors (positions, directions, colours) as x, y, z planes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct V8 {
    pub x: F8,
    pub y: F8,
    pub z: F8,
}

impl V8 {
    pub const ZERO: V8 = V8 { x: F8::ZERO, y: F8::ZERO, z: F8::ZERO };

    #[inline(always)]
    #[must_use]
    pub fn new(x: F8, y: F8, z: F8) -> V8 {
        V8 { x, y, z }
    }

    /// Every lane `v`.
    #[inline(always)]
    #[must_use]
    pub fn splat(v: glam::Vec3) -> V8 {
        V8 { x: F8::splat(v.x), y: F8::splat(v.y), z: F8::splat(v.z) }
    }

    /// Every lane `s` in all three components.
    #[inline(always)]
    #[must_use]
    pub fn splat1(s: f32) -> V8 {
        V8 { x: F8::splat(s), y: F8::splat(s), z: F8::splat(s) }
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    #[must_use]
    pub fn from_fn(mut f: impl FnMut(usize) -> glam::Vec3) -> V8 {
        let mut v = V8::ZERO;
        for i in 0..LANES {
            v.set(i, f(i));
        }
        v
    }

    #[inline(always)]
    #[must_use]
    pub fn lane(&self, i: usize) -> glam::Vec3 {
        glam::Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    #[inline(always)]
    pub fn set(&mut self, i: usize, v: glam::Vec3) {
        (self.x[i], self.y[i], self.z[i]) = (v.x, v.y, v.z);
    }

    /// `(x·x + y·y) + z·z`, glam's order.
    #[inline(always)]
    #[must_use]
    pub fn dot(self, o: V8) -> F8 {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    #[inline(always)]
    #[must_use]
    pub fn cross(self, o: V8) -> V8 {
        V8 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    #[inline(always)]
    #[must_use]
    pub fn scale(self, s: F8) -> V8 {
        V8 { x: self.x * s, y: self.y * s, z: self.z * s }
    }

    #[inline(always)]
    #[must_use]
    pub fn abs(self) -> V8 {
        V8 { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }

    /// glam's `normalize`: `self * (1 / sqrt(dot))`.
    #[inline(always)]
    #[must_use]
    pub fn normalize(self) -> V8 {
        self.scale(F8::ONE / self.dot(self).sqrt())
    }

    #[inline(always)]
    #[must_use]
    pub fn max_element(self) -> F8 {
        self.x.max(self.y).max(self.z)
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8, a: V8, b: V8) -> V8 {
        V8 { x: F8::select(m, a.x, b.x), y: F8::select(m, a.y, b.y), z: F8::select(m, a.z, b.z) }
    }
}

impl Add for V8 {
    type Output = V8;
    #[inline(always)]
    fn add(self, o: V8) -> V8 {
        V8 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

/// Component-wise product.
impl Mul for V8 {
    type Output = V8;
    #[inline(always)]
    fn mul(self, o: V8) -> V8 {
        V8 { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
}

impl Sub for V8 {
    type Output = V8;
    #[inline(always)]
    fn sub(self, o: V8) -> V8 {
        V8 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

impl Neg for V8 {
    type Output = V8;
    #[inline(always)]
    fn neg(self) -> V8 {
        V8 { x: -self.x, y: -self.y, z: -self.z }
    }
}

impl AddAssign for V8 {
    #[inline(always)]
    fn add_assign(&mut self, o: V8) {
        *self = *self + o;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn lanes_do_what_the_scalar_code_does() {
        let a = F8::from_fn(|i| i as f32 - 3.5);
        let b = F8::from_fn(|i| (i as f32 * 0.7).sin());
        for i in 0..LANES {
            assert_eq!((a + b)[i], a[i] + b[i]);
            assert_eq!((a * b - a / b)[i], a[i] * b[i] - a[i] / b[i]);
            assert_eq!(a.lt(b).lane(i), a[i] < b[i]);
            assert_eq!(F8::select(a.gt(b), a, b)[i], a[i].max(b[i]));
        }
        let nan = F8::splat(f32::NAN);
        assert_eq!(nan.max(F8::ZERO), F8::ZERO, "maxps: NaN gives the second operand");
        assert_eq!(nan.is_nan(), M8::ALL);
        assert_eq!(M8::first(3).bits(), 0b111);
        assert_eq!(M8::from_bits(0b1010_0101).bits(), 0b1010_0101);
        let v = V8::from_fn(|i| Vec3::new(i as f32, 1.0, -2.0 * i as f32));
        for i in 0..LANES {
            let s = v.lane(i);
            assert_eq!(v.dot(v)[i], s.dot(s));
            if s.length() > 0.0 {
                assert_eq!(v.normalize().lane(i), s.normalize(), "glam's normalize, bit for bit");
            }
            assert_eq!(v.cross(V8::splat(Vec3::Y)).lane(i), s.cross(Vec3::Y));
        }
    }

    /// The fast power against f64 over Phong's domain: relative error below 3e-5 (a thousandth of
    /// an 8-bit step on a highlight of 1).
    #[test]
    fn fast_power_is_within_its_bound() {
        let mut worst = 0.0f64;
        for a in 0..=2000 {
            let x = a as f32 / 2000.0;
            for n in [1.0f32, 2.0, 5.5, 20.0, 60.0, 128.0, 300.0, 1000.0] {
                let got = pow8_unit(F8::splat(x), F8::splat(n))[0] as f64;
                let want = (x as f64).powf(n as f64);
                if want > 1e-30 {
                    worst = worst.max((got - want).abs() / want);
                } else {
                    assert!(got <= 1e-29, "x {x} n {n}: {got}");
                }
            }
        }
        assert!(worst < 3e-5, "worst relative error {worst:e}");
        assert_eq!(pow8_unit(F8::ZERO, F8::splat(3.0)), F8::ZERO);
        assert_eq!(pow8_unit(F8::ONE, F8::splat(77.0)), F8::ONE);
    }
}
