//! Eight lanes, one generic kernel per instruction set: the vocabulary of batched kernels
//! (eight rays, eight hits, eight shading points at once, structure of arrays).
//!
//! A kernel is written once on [`F8`], [`U8x`], [`M8`] and [`V8`], generic over an [`Isa`]
//! that says how eight lanes live in registers: [`Sse`] (the x86-64 baseline, two SSE
//! registers through the `wide` crate, safe code) or `Avx2` (one AVX register; private to this
//! crate). [`dispatch`] runs a [`LaneKernel`] with the best one this CPU has, entering the
//! AVX2 instantiation through a `#[target_feature(enable = "avx2,fma")]` function after
//! runtime detection — the only way an `Avx2` kernel can be reached, so the intrinsics it runs
//! are always supported. Kernels and every lane operation are `#[inline(always)]`, so a
//! kernel's whole body is compiled inside that function with 256-bit registers.
//!
//! No operation here fuses a multiply and an add, and each performs the IEEE operation of the
//! scalar code it mirrors, so both instruction sets give the same bits, and every lane gives
//! the bits of the scalar computation written in the same order.

mod avx2;
mod sse;

pub use sse::Sse;

use std::ops::{Add, AddAssign, BitAnd, BitOr, Div, Index, IndexMut, Mul, MulAssign, Neg, Not, Sub};

/// Lanes per vector.
pub const LANES: usize = 8;

/// How eight lanes of f32, u32 and masks live in registers, and the operations on them.
/// Implemented by [`Sse`] and by the crate-private `Avx2`; write kernels generic over it.
pub trait Isa: Copy + Send + Sync + std::fmt::Debug + Default + PartialEq + 'static {
    type F: Copy + Send + Sync;
    type U: Copy + Send + Sync;
    /// A mask: all ones where true, zero where false, in float lanes.
    type M: Copy + Send + Sync;

    fn f_splat(v: f32) -> Self::F;
    fn f_from_array(a: [f32; LANES]) -> Self::F;
    fn f_as_array(f: &Self::F) -> &[f32; LANES];
    fn f_as_array_mut(f: &mut Self::F) -> &mut [f32; LANES];
    fn f_add(a: Self::F, b: Self::F) -> Self::F;
    fn f_sub(a: Self::F, b: Self::F) -> Self::F;
    fn f_mul(a: Self::F, b: Self::F) -> Self::F;
    fn f_div(a: Self::F, b: Self::F) -> Self::F;
    fn f_sqrt(a: Self::F) -> Self::F;
    fn f_floor(a: Self::F) -> Self::F;
    /// Bitwise and, or, and-not (`a & !b`) of the lanes' bit patterns.
    fn f_and(a: Self::F, b: Self::F) -> Self::F;
    fn f_or(a: Self::F, b: Self::F) -> Self::F;
    fn f_andnot(a: Self::F, b: Self::F) -> Self::F;
    fn f_xor(a: Self::F, b: Self::F) -> Self::F;
    fn f_lt(a: Self::F, b: Self::F) -> Self::M;
    fn f_le(a: Self::F, b: Self::F) -> Self::M;
    fn f_eq(a: Self::F, b: Self::F) -> Self::M;
    /// Lanes that are not NaN in either (`a == a && b == b`).
    fn f_ordered(a: Self::F, b: Self::F) -> Self::M;
    fn f_select(m: Self::M, a: Self::F, b: Self::F) -> Self::F;
    fn f_to_bits(a: Self::F) -> Self::U;
    fn f_from_bits(a: Self::U) -> Self::F;
    /// Truncated toward zero to i32 (lanes in its range), as bit patterns.
    fn f_trunc(a: Self::F) -> Self::U;

    fn u_splat(v: u32) -> Self::U;
    fn u_from_array(a: [u32; LANES]) -> Self::U;
    fn u_as_array(u: &Self::U) -> &[u32; LANES];
    fn u_as_array_mut(u: &mut Self::U) -> &mut [u32; LANES];
    fn u_add(a: Self::U, b: Self::U) -> Self::U;
    fn u_sub(a: Self::U, b: Self::U) -> Self::U;
    fn u_and(a: Self::U, b: Self::U) -> Self::U;
    fn u_or(a: Self::U, b: Self::U) -> Self::U;
    fn u_xor(a: Self::U, b: Self::U) -> Self::U;
    /// The low 32 bits of the product (`u32::wrapping_mul`).
    fn u_mul(a: Self::U, b: Self::U) -> Self::U;
    fn u_shr(a: Self::U, n: u32) -> Self::U;
    fn u_shl(a: Self::U, n: u32) -> Self::U;
    fn u_eq(a: Self::U, b: Self::U) -> Self::M;
    /// Lanes as signed integers, to f32.
    fn u_to_f32(a: Self::U) -> Self::F;

    fn m_from_f(f: Self::F) -> Self::M;
    fn m_to_f(m: Self::M) -> Self::F;
    fn m_bits(m: Self::M) -> u32;
    fn m_from_bits(b: u32) -> Self::M;
}

/// A kernel [`dispatch`] runs with the best instruction set: `run` is instantiated once per
/// ISA; make it `#[inline(always)]` so its body compiles inside the ISA's entry point.
pub trait LaneKernel {
    type Output;
    fn run<I: Isa>(self) -> Self::Output;
}

/// Whether this CPU runs the AVX2 kernels (AVX2 and FMA, detected once by std).
#[must_use]
pub fn avx2_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Run `kernel` with AVX2 where the CPU has it (and `baseline` is false), else with [`Sse`].
pub fn dispatch<K: LaneKernel>(kernel: K, baseline: bool) -> K::Output {
    #[cfg(target_arch = "x86_64")]
    if !baseline && avx2_available() {
        return avx2::run(kernel);
    }
    kernel.run::<Sse>()
}

/// Eight f32 lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct F8<I: Isa>(pub I::F);

/// Eight u32 lanes.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct U8x<I: Isa>(pub I::U);

/// A lane mask.
#[derive(Clone, Copy)]
#[repr(transparent)]
pub struct M8<I: Isa>(pub I::M);

impl<I: Isa> std::fmt::Debug for F8<I> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "F8{:?}", I::f_as_array(&self.0))
    }
}

impl<I: Isa> std::fmt::Debug for U8x<I> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "U8x{:?}", I::u_as_array(&self.0))
    }
}

impl<I: Isa> std::fmt::Debug for M8<I> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "M8({:08b})", self.bits().reverse_bits() >> 24)
    }
}

/// Masks compare by their lanes' truth.
impl<I: Isa> PartialEq for M8<I> {
    fn eq(&self, o: &Self) -> bool {
        self.bits() == o.bits()
    }
}

impl<I: Isa> PartialEq for F8<I> {
    fn eq(&self, o: &Self) -> bool {
        self.to_array() == o.to_array()
    }
}

impl<I: Isa> PartialEq for U8x<I> {
    fn eq(&self, o: &Self) -> bool {
        self.to_array() == o.to_array()
    }
}

impl<I: Isa> Index<usize> for F8<I> {
    type Output = f32;
    #[inline(always)]
    fn index(&self, i: usize) -> &f32 {
        &I::f_as_array(&self.0)[i]
    }
}

impl<I: Isa> IndexMut<usize> for F8<I> {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut f32 {
        &mut I::f_as_array_mut(&mut self.0)[i]
    }
}

impl<I: Isa> Index<usize> for U8x<I> {
    type Output = u32;
    #[inline(always)]
    fn index(&self, i: usize) -> &u32 {
        &I::u_as_array(&self.0)[i]
    }
}

impl<I: Isa> IndexMut<usize> for U8x<I> {
    #[inline(always)]
    fn index_mut(&mut self, i: usize) -> &mut u32 {
        &mut I::u_as_array_mut(&mut self.0)[i]
    }
}

macro_rules! float_op {
    ($tr:ident, $f:ident, $isa:ident) => {
        impl<I: Isa> $tr for F8<I> {
            type Output = F8<I>;
            #[inline(always)]
            fn $f(self, o: F8<I>) -> F8<I> {
                F8(I::$isa(self.0, o.0))
            }
        }
    };
}

float_op!(Add, add, f_add);
float_op!(Sub, sub, f_sub);
float_op!(Mul, mul, f_mul);
float_op!(Div, div, f_div);

impl<I: Isa> Neg for F8<I> {
    type Output = F8<I>;
    #[inline(always)]
    fn neg(self) -> F8<I> {
        F8(I::f_xor(self.0, I::f_splat(-0.0)))
    }
}

impl<I: Isa> AddAssign for F8<I> {
    #[inline(always)]
    fn add_assign(&mut self, o: F8<I>) {
        *self = *self + o;
    }
}

impl<I: Isa> MulAssign for F8<I> {
    #[inline(always)]
    fn mul_assign(&mut self, o: F8<I>) {
        *self = *self * o;
    }
}

impl<I: Isa> BitAnd for M8<I> {
    type Output = M8<I>;
    #[inline(always)]
    fn bitand(self, o: M8<I>) -> M8<I> {
        M8(I::m_from_f(I::f_and(I::m_to_f(self.0), I::m_to_f(o.0))))
    }
}

impl<I: Isa> BitOr for M8<I> {
    type Output = M8<I>;
    #[inline(always)]
    fn bitor(self, o: M8<I>) -> M8<I> {
        M8(I::m_from_f(I::f_or(I::m_to_f(self.0), I::m_to_f(o.0))))
    }
}

impl<I: Isa> Not for M8<I> {
    type Output = M8<I>;
    #[inline(always)]
    fn not(self) -> M8<I> {
        M8(I::m_from_f(I::f_xor(I::m_to_f(self.0), I::m_to_f(M8::<I>::all().0))))
    }
}

impl<I: Isa> Default for F8<I> {
    fn default() -> Self {
        F8::splat(0.0)
    }
}

impl<I: Isa> Default for U8x<I> {
    fn default() -> Self {
        U8x::splat(0)
    }
}

impl<I: Isa> F8<I> {
    #[inline(always)]
    #[must_use]
    pub fn zero() -> F8<I> {
        F8::splat(0.0)
    }

    #[inline(always)]
    #[must_use]
    pub fn one() -> F8<I> {
        F8::splat(1.0)
    }

    #[inline(always)]
    #[must_use]
    pub fn splat(v: f32) -> F8<I> {
        F8(I::f_splat(v))
    }

    #[inline(always)]
    #[must_use]
    pub fn from_array(a: [f32; LANES]) -> F8<I> {
        F8(I::f_from_array(a))
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    #[must_use]
    pub fn from_fn(f: impl FnMut(usize) -> f32) -> F8<I> {
        F8::from_array(std::array::from_fn(f))
    }

    #[inline(always)]
    #[must_use]
    pub fn to_array(self) -> [f32; LANES] {
        *I::f_as_array(&self.0)
    }

    #[inline(always)]
    #[must_use]
    pub fn sqrt(self) -> F8<I> {
        F8(I::f_sqrt(self.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn abs(self) -> F8<I> {
        F8(I::f_andnot(self.0, I::f_splat(-0.0)))
    }

    #[inline(always)]
    #[must_use]
    pub fn floor(self) -> F8<I> {
        F8(I::f_floor(self.0))
    }

    /// `self` with the sign of `o`.
    #[inline(always)]
    #[must_use]
    pub fn copysign(self, o: F8<I>) -> F8<I> {
        let sign = I::f_splat(-0.0);
        F8(I::f_or(I::f_andnot(self.0, sign), I::f_and(o.0, sign)))
    }

    /// Lane-wise maximum with x86 `maxps` semantics: `o` where either is NaN or they are
    /// equal, so `v.max(zero)` maps NaN to 0 (as the scalar code's `if v > o`).
    #[inline(always)]
    #[must_use]
    pub fn max(self, o: F8<I>) -> F8<I> {
        F8::select(self.gt(o), self, o)
    }

    /// Lane-wise minimum with `minps` semantics (`o` where either is NaN).
    #[inline(always)]
    #[must_use]
    pub fn min(self, o: F8<I>) -> F8<I> {
        F8::select(self.lt(o), self, o)
    }

    #[inline(always)]
    #[must_use]
    pub fn lt(self, o: F8<I>) -> M8<I> {
        M8(I::f_lt(self.0, o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn le(self, o: F8<I>) -> M8<I> {
        M8(I::f_le(self.0, o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn gt(self, o: F8<I>) -> M8<I> {
        M8(I::f_lt(o.0, self.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn ge(self, o: F8<I>) -> M8<I> {
        M8(I::f_le(o.0, self.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn eq(self, o: F8<I>) -> M8<I> {
        M8(I::f_eq(self.0, o.0))
    }

    /// NaN lanes.
    #[inline(always)]
    #[must_use]
    pub fn is_nan(self) -> M8<I> {
        !M8(I::f_ordered(self.0, self.0))
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8<I>, a: F8<I>, b: F8<I>) -> F8<I> {
        F8(I::f_select(m.0, a.0, b.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn to_bits(self) -> U8x<I> {
        U8x(I::f_to_bits(self.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn from_bits(b: U8x<I>) -> F8<I> {
        F8(I::f_from_bits(b.0))
    }

    /// Truncated toward zero to integers (lanes in the i32 range), as bit patterns.
    #[inline(always)]
    #[must_use]
    pub fn trunc_to_u32(self) -> U8x<I> {
        U8x(I::f_trunc(self.0))
    }
}

impl<I: Isa> U8x<I> {
    #[inline(always)]
    #[must_use]
    pub fn splat(v: u32) -> U8x<I> {
        U8x(I::u_splat(v))
    }

    #[inline(always)]
    #[must_use]
    pub fn from_array(a: [u32; LANES]) -> U8x<I> {
        U8x(I::u_from_array(a))
    }

    #[inline(always)]
    #[must_use]
    pub fn to_array(self) -> [u32; LANES] {
        *I::u_as_array(&self.0)
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8<I>, a: U8x<I>, b: U8x<I>) -> U8x<I> {
        U8x(I::f_to_bits(I::f_select(m.0, I::f_from_bits(a.0), I::f_from_bits(b.0))))
    }

    #[inline(always)]
    #[must_use]
    pub fn eq(self, o: U8x<I>) -> M8<I> {
        M8(I::u_eq(self.0, o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn shift_right(self, n: u32) -> U8x<I> {
        U8x(I::u_shr(self.0, n))
    }

    #[inline(always)]
    #[must_use]
    pub fn shift_left(self, n: u32) -> U8x<I> {
        U8x(I::u_shl(self.0, n))
    }

    #[inline(always)]
    #[must_use]
    pub fn and(self, mask: u32) -> U8x<I> {
        U8x(I::u_and(self.0, I::u_splat(mask)))
    }

    #[inline(always)]
    #[must_use]
    pub fn or(self, bits: u32) -> U8x<I> {
        U8x(I::u_or(self.0, I::u_splat(bits)))
    }

    #[inline(always)]
    #[must_use]
    pub fn xor(self, o: U8x<I>) -> U8x<I> {
        U8x(I::u_xor(self.0, o.0))
    }

    /// Lane by lane `u32::wrapping_mul`.
    #[inline(always)]
    #[must_use]
    pub fn wrapping_mul(self, o: U8x<I>) -> U8x<I> {
        U8x(I::u_mul(self.0, o.0))
    }

    /// `self | o`, lane by lane.
    #[inline(always)]
    #[must_use]
    pub fn or_lanes(self, o: U8x<I>) -> U8x<I> {
        U8x(I::u_or(self.0, o.0))
    }

    /// Lane by lane `u32::reverse_bits` (halves, bytes, nibbles, pairs, bits swapped).
    #[inline(always)]
    #[must_use]
    pub fn reverse_bits(self) -> U8x<I> {
        let x = self.shift_right(16).or_lanes(self.shift_left(16));
        let x = x.shift_right(8).and(0x00ff_00ff).or_lanes(x.and(0x00ff_00ff).shift_left(8));
        let x = x.shift_right(4).and(0x0f0f_0f0f).or_lanes(x.and(0x0f0f_0f0f).shift_left(4));
        let x = x.shift_right(2).and(0x3333_3333).or_lanes(x.and(0x3333_3333).shift_left(2));
        x.shift_right(1).and(0x5555_5555).or_lanes(x.and(0x5555_5555).shift_left(1))
    }

    /// The lanes as f32, for values below 2^31.
    #[inline(always)]
    #[must_use]
    pub fn to_f32(self) -> F8<I> {
        F8(I::u_to_f32(self.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn wrapping_add(self, o: U8x<I>) -> U8x<I> {
        U8x(I::u_add(self.0, o.0))
    }

    #[inline(always)]
    #[must_use]
    pub fn wrapping_sub(self, o: U8x<I>) -> U8x<I> {
        U8x(I::u_sub(self.0, o.0))
    }
}

impl<I: Isa> M8<I> {
    #[inline(always)]
    #[must_use]
    pub fn none_set() -> M8<I> {
        M8(I::m_from_bits(0))
    }

    #[inline(always)]
    #[must_use]
    pub fn all() -> M8<I> {
        M8(I::m_from_bits(0xff))
    }

    /// Lanes `0..n` set.
    #[inline(always)]
    #[must_use]
    pub fn first(n: usize) -> M8<I> {
        M8::from_bits(if n >= LANES { 0xff } else { (1u32 << n) - 1 })
    }

    /// The mask of the bits of `b` (bit i = lane i).
    #[inline(always)]
    #[must_use]
    pub fn from_bits(b: u32) -> M8<I> {
        M8(I::m_from_bits(b))
    }

    /// Lane `i` set where `f(i)`.
    #[inline(always)]
    #[must_use]
    pub fn from_fn(mut f: impl FnMut(usize) -> bool) -> M8<I> {
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
        I::m_bits(self.0)
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
        self.bits() >> i & 1 != 0
    }

    /// `self` and not `o`.
    #[inline(always)]
    #[must_use]
    pub fn and_not(self, o: M8<I>) -> M8<I> {
        M8(I::m_from_f(I::f_andnot(I::m_to_f(self.0), I::m_to_f(o.0))))
    }
}

/// Eight 3-vectors (positions, directions, colours) as x, y, z lane planes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct V8<I: Isa> {
    pub x: F8<I>,
    pub y: F8<I>,
    pub z: F8<I>,
}

impl<I: Isa> V8<I> {
    #[inline(always)]
    #[must_use]
    pub fn zero() -> V8<I> {
        V8::splat1(0.0)
    }

    #[inline(always)]
    #[must_use]
    pub fn new(x: F8<I>, y: F8<I>, z: F8<I>) -> V8<I> {
        V8 { x, y, z }
    }

    /// Every lane `v`.
    #[inline(always)]
    #[must_use]
    pub fn splat(v: glint_core::Vec3) -> V8<I> {
        V8 { x: F8::splat(v.x), y: F8::splat(v.y), z: F8::splat(v.z) }
    }

    /// Every lane `s` in all three components.
    #[inline(always)]
    #[must_use]
    pub fn splat1(s: f32) -> V8<I> {
        V8 { x: F8::splat(s), y: F8::splat(s), z: F8::splat(s) }
    }

    /// Lane `i` is `f(i)`.
    #[inline(always)]
    #[must_use]
    pub fn from_fn(mut f: impl FnMut(usize) -> glint_core::Vec3) -> V8<I> {
        let mut v = V8::zero();
        for i in 0..LANES {
            v.set(i, f(i));
        }
        v
    }

    #[inline(always)]
    #[must_use]
    pub fn lane(&self, i: usize) -> glint_core::Vec3 {
        glint_core::Vec3::new(self.x[i], self.y[i], self.z[i])
    }

    #[inline(always)]
    pub fn set(&mut self, i: usize, v: glint_core::Vec3) {
        (self.x[i], self.y[i], self.z[i]) = (v.x, v.y, v.z);
    }

    /// `(x·x + y·y) + z·z`, glam's order.
    #[inline(always)]
    #[must_use]
    pub fn dot(self, o: V8<I>) -> F8<I> {
        self.x * o.x + self.y * o.y + self.z * o.z
    }

    /// glam's `cross`, term for term.
    #[inline(always)]
    #[must_use]
    pub fn cross(self, o: V8<I>) -> V8<I> {
        V8 { x: self.y * o.z - o.y * self.z, y: self.z * o.x - o.z * self.x, z: self.x * o.y - o.x * self.y }
    }

    #[inline(always)]
    #[must_use]
    pub fn scale(self, s: F8<I>) -> V8<I> {
        V8 { x: self.x * s, y: self.y * s, z: self.z * s }
    }

    #[inline(always)]
    #[must_use]
    pub fn abs(self) -> V8<I> {
        V8 { x: self.x.abs(), y: self.y.abs(), z: self.z.abs() }
    }

    /// glam's `normalize`: `self * (1 / sqrt(dot))`.
    #[inline(always)]
    #[must_use]
    pub fn normalize(self) -> V8<I> {
        self.scale(F8::one() / self.dot(self).sqrt())
    }

    #[inline(always)]
    #[must_use]
    pub fn max_element(self) -> F8<I> {
        self.x.max(self.y).max(self.z)
    }

    /// `a` where `m`, else `b`.
    #[inline(always)]
    #[must_use]
    pub fn select(m: M8<I>, a: V8<I>, b: V8<I>) -> V8<I> {
        V8 { x: F8::select(m, a.x, b.x), y: F8::select(m, a.y, b.y), z: F8::select(m, a.z, b.z) }
    }
}

impl<I: Isa> Add for V8<I> {
    type Output = V8<I>;
    #[inline(always)]
    fn add(self, o: V8<I>) -> V8<I> {
        V8 { x: self.x + o.x, y: self.y + o.y, z: self.z + o.z }
    }
}

impl<I: Isa> Sub for V8<I> {
    type Output = V8<I>;
    #[inline(always)]
    fn sub(self, o: V8<I>) -> V8<I> {
        V8 { x: self.x - o.x, y: self.y - o.y, z: self.z - o.z }
    }
}

/// Component-wise product.
impl<I: Isa> Mul for V8<I> {
    type Output = V8<I>;
    #[inline(always)]
    fn mul(self, o: V8<I>) -> V8<I> {
        V8 { x: self.x * o.x, y: self.y * o.y, z: self.z * o.z }
    }
}

impl<I: Isa> Neg for V8<I> {
    type Output = V8<I>;
    #[inline(always)]
    fn neg(self) -> V8<I> {
        V8 { x: -self.x, y: -self.y, z: -self.z }
    }
}

impl<I: Isa> AddAssign for V8<I> {
    #[inline(always)]
    fn add_assign(&mut self, o: V8<I>) {
        *self = *self + o;
    }
}

/// `x^y` per lane for `x` in [0, 1] and `y` > 0 (Phong's `max(R·V, 0)^n`), by
/// `exp2(y · log2 x)` with polynomials: relative error below 3e-5 against f64 where the result
/// is above 1e-30 (tested), 0 where it underflows and for `x = 0`. Lanes outside that domain
/// (`x` > 1, NaN, `y` ≤ 0) are unspecified: callers take [`f32::powf`] there.
#[inline(always)]
#[must_use]
pub fn pow_unit<I: Isa>(x: F8<I>, y: F8<I>) -> F8<I> {
    exp2(y * log2(x))
}

/// `log2 x` for finite `x` > 0 (−∞ for 0): exponent from the bits, the mantissa m in
/// [√½, √2) through the odd series of `2·atanh((m − 1)/(m + 1)) / ln 2` up to the 11th power.
#[inline(always)]
#[must_use]
pub fn log2<I: Isa>(x: F8<I>) -> F8<I> {
    let bits = x.to_bits();
    let mant = F8::from_bits(bits.and(0x007f_ffff).or(0x3f80_0000));
    let big = mant.gt(F8::splat(std::f32::consts::SQRT_2));
    let m = F8::select(big, mant * F8::splat(0.5), mant);
    let e = bits.shift_right(23).and(0xff).to_f32() - F8::splat(127.0) + F8::select(big, F8::one(), F8::zero());
    let t = (m - F8::one()) / (m + F8::one());
    let t2 = t * t;
    let mut series = F8::splat(1.0 / 11.0);
    for c in [1.0 / 9.0, 1.0 / 7.0, 1.0 / 5.0, 1.0 / 3.0, 1.0] {
        series = series * t2 + F8::splat(c);
    }
    let log = e + t * series * F8::splat(2.0 * std::f32::consts::LOG2_E);
    F8::select(x.eq(F8::zero()), F8::splat(f32::NEG_INFINITY), log)
}

/// `2^y` for `y` ≤ 0 (0 below −126, where f32 would go subnormal): the integer part into the
/// exponent bits, the fraction f in [0, 1) by the Taylor series of `e^(f ln 2)` to the 8th
/// power (relative error < 2e-7).
#[inline(always)]
#[must_use]
pub fn exp2<I: Isa>(y: F8<I>) -> F8<I> {
    // −∞ (and anything that far down) becomes −127: a zero scale below.
    let y = y.max(F8::splat(-127.0));
    let whole = y.floor();
    let f = (y - whole) * F8::splat(std::f32::consts::LN_2);
    const INV_FACT: [f32; 8] =
        [1.0 / 40320.0, 1.0 / 5040.0, 1.0 / 720.0, 1.0 / 120.0, 1.0 / 24.0, 1.0 / 6.0, 1.0 / 2.0, 1.0];
    let mut p = F8::splat(INV_FACT[0]);
    for c in &INV_FACT[1..] {
        p = p * f + F8::splat(*c);
    }
    let p = p * f + F8::one();
    let biased = (whole + F8::splat(127.0)).max(F8::zero());
    let scale = F8::from_bits(biased.trunc_to_u32().shift_left(23));
    p * F8::select(whole.ge(F8::splat(-126.0)), scale, F8::zero())
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)] // lanes indexed as kernels index them
mod tests {
    use super::*;
    use glint_core::Vec3;

    struct Check;

    impl LaneKernel for Check {
        type Output = ();
        #[inline(always)]
        fn run<I: Isa>(self) {
            lanes_do_what_the_scalar_code_does::<I>();
            fast_power_is_within_its_bound::<I>();
        }
    }

    /// Both instruction sets (where the CPU has AVX2) through the same checks.
    #[test]
    fn every_isa_passes_the_lane_checks() {
        dispatch(Check, true);
        dispatch(Check, false);
    }

    fn lanes_do_what_the_scalar_code_does<I: Isa>() {
        let a = F8::<I>::from_fn(|i| i as f32 - 3.5);
        let b = F8::<I>::from_fn(|i| (i as f32 * 0.7).sin());
        for i in 0..LANES {
            assert_eq!((a + b)[i], a[i] + b[i]);
            assert_eq!((a * b - a / b)[i], a[i] * b[i] - a[i] / b[i]);
            assert_eq!(a.lt(b).lane(i), a[i] < b[i]);
            assert_eq!(F8::select(a.gt(b), a, b)[i], a[i].max(b[i]));
            assert_eq!(a.copysign(-b)[i], a[i].copysign(-b[i]));
            assert_eq!((-a).abs()[i], a[i].abs());
            assert_eq!(a.floor()[i], a[i].floor());
            assert_eq!(a.sqrt()[i].to_bits(), a[i].sqrt().to_bits());
        }
        let nan = F8::<I>::splat(f32::NAN);
        assert_eq!(nan.max(F8::zero()), F8::zero(), "maxps: NaN gives the second operand");
        assert_eq!(nan.is_nan(), M8::all());
        assert_eq!(M8::<I>::first(3).bits(), 0b111);
        assert_eq!(M8::<I>::from_bits(0b1010_0101).bits(), 0b1010_0101);
        assert_eq!((!M8::<I>::from_bits(0b1010_0101)).bits(), 0b0101_1010);
        let u = U8x::<I>::from_array([0, 1, 2, 3, 0xff, 1 << 31, 7, 9]);
        assert_eq!(u.eq(U8x::splat(3)).bits(), 0b1000);
        assert_eq!(u.shift_right(1).to_array(), [0, 0, 1, 1, 0x7f, 1 << 30, 3, 4]);
        assert_eq!(U8x::<I>::splat(5).to_f32(), F8::splat(5.0));
        let w = U8x::<I>::from_array([0x9e37_79b9, 3, 0xffff_ffff, 1 << 31, 12345, 0xdead_beef, 0, 77]);
        let (ua, wa) = (u.to_array(), w.to_array());
        for i in 0..LANES {
            assert_eq!(u.wrapping_mul(w).to_array()[i], ua[i].wrapping_mul(wa[i]));
            assert_eq!(u.wrapping_add(w).to_array()[i], ua[i].wrapping_add(wa[i]));
            assert_eq!(u.xor(w).to_array()[i], ua[i] ^ wa[i]);
            assert_eq!(w.reverse_bits().to_array()[i], wa[i].reverse_bits());
        }
        let v = V8::<I>::from_fn(|i| Vec3::new(i as f32, 1.0, -2.0 * i as f32));
        for i in 0..LANES {
            let s = v.lane(i);
            assert_eq!(v.dot(v)[i], s.dot(s));
            if s.length() > 0.0 {
                assert_eq!(v.normalize().lane(i), s.normalize(), "glam's normalize, bit for bit");
            }
            assert_eq!(v.cross(V8::splat(Vec3::Y)).lane(i), s.cross(Vec3::Y));
        }
    }

    /// The fast power against f64 over Phong's domain: relative error below 3e-5 (a
    /// thousandth of an 8-bit step on a highlight of 1).
    fn fast_power_is_within_its_bound<I: Isa>() {
        let mut worst = 0.0f64;
        for a in 0..=2000 {
            let x = a as f32 / 2000.0;
            for n in [1.0f32, 2.0, 5.5, 20.0, 60.0, 128.0, 300.0, 1000.0] {
                let got = f64::from(pow_unit(F8::<I>::splat(x), F8::splat(n))[0]);
                let want = f64::from(x).powf(f64::from(n));
                if want > 1e-30 {
                    worst = worst.max((got - want).abs() / want);
                } else {
                    assert!(got <= 1e-29, "x {x} n {n}: {got}");
                }
            }
        }
        assert!(worst < 3e-5, "worst relative error {worst:e}");
        assert_eq!(pow_unit(F8::<I>::zero(), F8::splat(3.0)), F8::zero());
        assert_eq!(pow_unit(F8::<I>::one(), F8::splat(77.0)), F8::one());
    }
}
