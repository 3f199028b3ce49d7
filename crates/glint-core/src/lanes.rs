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

// Index loops over lanes read like the element-wise operations they are.
#![allow(clippy::needless_range_loop)]

use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Mul, MulAssign, Neg, Not, Sub};

/// Lanes per vector.
pub const LANES: usize = 8;

/// Eight f32 lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct F8(pub [f32; LANES]);

/// Eight u32 lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct U8x(pub [u32; LANES]);

/// A lane mask: all ones where true, zero where false (what a vector compare yields).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct M8(pub [u32; LANES]);

macro_rules! lanewise {
    ($t:ident, $tr:ident, $f:ident, $op:tt) => {
        impl $tr for $t {
            type Output = $t;
            #[inline(always)]
            fn $f(self, o: $t) -> $t {
                let mut r = self.0;
                for i in 0..LANES {
                    r[i] = self.0[i] $op o.0[i];
                }
                $t(r)
            }
        }
    };
}

lanewise!(F8, Add, add, +);
lanewise!(F8, Sub, sub, -);
lanewise!(F8, Mul, mul, *);
lanewise!(F8, Div, div, /);
lanewise!(M8, BitAnd, bitand, &);
lanewise!(M8, BitOr, bitor, |);

impl Neg for F8 {
    type Output = F8;
    #[inline(always)]
    fn neg(self) -> F8 {
        F8(self.0.map(|v| -v))
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
        M8(self.0.map(|v| !v))
    }
}

impl Default for F8 {
    fn default() -> Self {
        F8::ZERO
    }
}

impl F8 {
    pub const ZERO: F8 = F8([0.0; LANES]);
    pub const ONE: F8 = F8([1.0; LANES]);

    #[inline(always)]
    #[must_use]
    pub fn splat(v: f32) -> F8 {
        F8([v; LANES])
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    #[must_use]
    pub fn from_fn(f: impl FnMut(usize) -> f32) -> F8 {
        F8(std::array::from_fn(f))
    }

    #[inline(always)]
    #[must_use]
    pub fn sqrt(self) -> F8 {
        F8(self.0.map(f32::sqrt))
    }

    #[inline(always)]
    #[must_use]
    pub fn abs(self) -> F8 {
        F8(self.0.map(f32::abs))
    }

    #[inline(always)]
    #[must_use]
    pub fn floor(self) -> F8 {
        F8(self.0.map(f32::floor))
    }

    /// `self` with the sign of `o`.
    #[inline(always)]
    #[must_use]
    pub fn copysign(self, o: F8) -> F8 {
        let mut r = self.0;
        for i in 0..LANES {
            r[i] = self.0[i].copysign(o.0[i]);
        }
        F8(r)
    }

    /// Lane-wise maximum with x86 `maxps` semantics: `o` where either is NaN or they are
    /// equal, so `v.max(F8::ZERO)` maps NaN to 0 (as the scalar code's `if v > o`).
    #[inline(always)]
    #[must_use]
    pub fn max(self, o: F8) -> F8 {
        let mut r = o.0;
        for i in 0..LANES {
            if self.0[i] > o.0[i] {
                r[i] = self.0[i];
            }
        }
        F8(r)
    }

    /// Lane-wise minimum with `minps` semantics (`o` where either is NaN).
    #[inline(always)]
    #[must_use]
    pub fn min(self, o: F8) -> F8 {
        let mut r = o.0;
        for i in 0..LANES {
            if self.0[i] < o.0[i] {
                r[i] = self.0[i];
            }
        }
        F8(r)
    }

    #[inline(always)]
    #[must_use]
    pub fn lt(self, o: F8) -> M8 {
        self.cmp(o, |a, b| a < b)
    }

    #[inline(always)]
    #[must_use]
    pub fn le(self, o: F8) -> M8 {
        self.cmp(o, |a, b| a <= b)
    }

    #[inline(always)]
    #[must_use]
    pub fn gt(self, o: F8) -> M8 {
        self.cmp(o, |a, b| a > b)
    }

    #[inline(always)]
    #[must_use]
    pub fn ge(self, o: F8) -> M8 {
        self.cmp(o, |a, b| a >= b)
    }

    #[inline(always)]
    #[must_use]
    pub fn eq(self, o: F8) -> M8 {
        self.cmp(o, |a, b| a == b)
    }

    #[inline(always)]
    fn cmp(self, o: F8, f: impl Fn(f32, f32) -> bool) -> M8 {
        let mut r = [0u32; LANES];
        for i in 0..LANES {
            r[i] = if f(self.0[i], o.0[i]) { u32::MAX } else { 0 };
        }
        M8(r)
    }

    /// NaN lanes (false for everything else).
    #[inline(always)]
    #[must_use]
    pub fn is_nan(self) -> M8 {
        #[allow(clippy::eq_op)]
        self.cmp(self, |a, b| a != b)
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8, a: F8, b: F8) -> F8 {
        let mut r = b.0;
        for i in 0..LANES {
            if m.0[i] != 0 {
                r[i] = a.0[i];
            }
        }
        F8(r)
    }

    /// The bit patterns.
    #[inline(always)]
    #[must_use]
    pub fn to_bits(self) -> U8x {
        U8x(self.0.map(f32::to_bits))
    }

    #[inline(always)]
    #[must_use]
    pub fn from_bits(b: U8x) -> F8 {
        F8(b.0.map(f32::from_bits))
    }

    /// Sum of the lanes in order (lane 0 first).
    #[must_use]
    pub fn sum(self) -> f32 {
        self.0.iter().sum()
    }
}

impl U8x {
    #[inline(always)]
    #[must_use]
    pub fn splat(v: u32) -> U8x {
        U8x([v; LANES])
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8, a: U8x, b: U8x) -> U8x {
        let mut r = b.0;
        for i in 0..LANES {
            if m.0[i] != 0 {
                r[i] = a.0[i];
            }
        }
        U8x(r)
    }

    #[inline(always)]
    #[must_use]
    pub fn eq(self, o: U8x) -> M8 {
        let mut r = [0u32; LANES];
        for i in 0..LANES {
            r[i] = if self.0[i] == o.0[i] { u32::MAX } else { 0 };
        }
        M8(r)
    }
}

impl M8 {
    pub const NONE: M8 = M8([0; LANES]);
    pub const ALL: M8 = M8([u32::MAX; LANES]);

    /// Lanes `0..n` set.
    #[inline(always)]
    #[must_use]
    pub fn first(n: usize) -> M8 {
        M8(std::array::from_fn(|i| if i < n { u32::MAX } else { 0 }))
    }

    /// The mask of the bits of `b` (bit i = lane i).
    #[inline(always)]
    #[must_use]
    pub fn from_bits(b: u32) -> M8 {
        M8(std::array::from_fn(|i| if b >> i & 1 != 0 { u32::MAX } else { 0 }))
    }

    /// Bit i set where lane i is.
    #[inline(always)]
    #[must_use]
    pub fn bits(self) -> u32 {
        let mut b = 0;
        for i in 0..LANES {
            b |= (self.0[i] >> 31) << i;
        }
        b
    }

    #[inline(always)]
    #[must_use]
    pub fn any(self) -> bool {
        self.bits() != 0
    }

    #[inline(always)]
    #[must_use]
    pub fn none(self) -> bool {
        self.bits() == 0
    }

    #[inline(always)]
    #[must_use]
    pub fn lane(self, i: usize) -> bool {
        self.0[i] != 0
    }

    /// `self` and not `o`.
    #[inline(always)]
    #[must_use]
    pub fn and_not(self, o: M8) -> M8 {
        self & !o
    }
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
        glam::Vec3::new(self.x.0[i], self.y.0[i], self.z.0[i])
    }

    #[inline(always)]
    pub fn set(&mut self, i: usize, v: glam::Vec3) {
        (self.x.0[i], self.y.0[i], self.z.0[i]) = (v.x, v.y, v.z);
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
            assert_eq!((a + b).0[i], a.0[i] + b.0[i]);
            assert_eq!((a * b - a / b).0[i], a.0[i] * b.0[i] - a.0[i] / b.0[i]);
            assert_eq!(a.lt(b).lane(i), a.0[i] < b.0[i]);
            assert_eq!(F8::select(a.gt(b), a, b).0[i], a.0[i].max(b.0[i]));
        }
        let nan = F8::splat(f32::NAN);
        assert_eq!(nan.max(F8::ZERO), F8::ZERO, "maxps: NaN gives the second operand");
        assert_eq!(nan.is_nan(), M8::ALL);
        assert_eq!(M8::first(3).bits(), 0b111);
        assert_eq!(M8::from_bits(0b1010_0101).bits(), 0b1010_0101);
        let v = V8::from_fn(|i| Vec3::new(i as f32, 1.0, -2.0 * i as f32));
        for i in 0..LANES {
            let s = v.lane(i);
            assert_eq!(v.dot(v).0[i], s.dot(s));
            if s.length() > 0.0 {
                assert_eq!(v.normalize().lane(i), s.normalize(), "glam's normalize, bit for bit");
            }
            assert_eq!(v.cross(V8::splat(Vec3::Y)).lane(i), s.cross(Vec3::Y));
        }
    }
}
