//! The x86-64 baseline: eight lanes as two SSE registers, through the `wide` crate (safe code;
//! `wide` chooses its SSE2 paths when the crate is built without AVX, as the default build is).

use super::{Isa, LANES};
use wide::{f32x8, i32x8, u32x8};

/// Eight lanes in two SSE registers (any x86-64, and any other target through `wide`'s
/// portable fallbacks).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Sse;

const BITS: u32x8 = u32x8::new([1, 2, 4, 8, 16, 32, 64, 128]);

impl Isa for Sse {
    type F = f32x8;
    type U = u32x8;
    type M = f32x8;

    #[inline(always)]
    fn f_splat(v: f32) -> f32x8 {
        f32x8::splat(v)
    }
    #[inline(always)]
    fn f_from_array(a: [f32; LANES]) -> f32x8 {
        f32x8::new(a)
    }
    #[inline(always)]
    fn f_as_array(f: &f32x8) -> &[f32; LANES] {
        f.as_array()
    }
    #[inline(always)]
    fn f_as_array_mut(f: &mut f32x8) -> &mut [f32; LANES] {
        f.as_mut_array()
    }
    #[inline(always)]
    fn f_add(a: f32x8, b: f32x8) -> f32x8 {
        a + b
    }
    #[inline(always)]
    fn f_sub(a: f32x8, b: f32x8) -> f32x8 {
        a - b
    }
    #[inline(always)]
    fn f_mul(a: f32x8, b: f32x8) -> f32x8 {
        a * b
    }
    #[inline(always)]
    fn f_div(a: f32x8, b: f32x8) -> f32x8 {
        a / b
    }
    #[inline(always)]
    fn f_sqrt(a: f32x8) -> f32x8 {
        a.sqrt()
    }
    #[inline(always)]
    fn f_floor(a: f32x8) -> f32x8 {
        a.floor()
    }
    #[inline(always)]
    fn f_and(a: f32x8, b: f32x8) -> f32x8 {
        a & b
    }
    #[inline(always)]
    fn f_or(a: f32x8, b: f32x8) -> f32x8 {
        a | b
    }
    #[inline(always)]
    fn f_andnot(a: f32x8, b: f32x8) -> f32x8 {
        a & !b
    }
    #[inline(always)]
    fn f_xor(a: f32x8, b: f32x8) -> f32x8 {
        a ^ b
    }
    #[inline(always)]
    fn f_lt(a: f32x8, b: f32x8) -> f32x8 {
        a.simd_lt(b)
    }
    #[inline(always)]
    fn f_le(a: f32x8, b: f32x8) -> f32x8 {
        a.simd_le(b)
    }
    #[inline(always)]
    fn f_eq(a: f32x8, b: f32x8) -> f32x8 {
        a.simd_eq(b)
    }
    #[inline(always)]
    fn f_ordered(a: f32x8, b: f32x8) -> f32x8 {
        !(a.is_nan() | b.is_nan())
    }
    #[inline(always)]
    fn f_select(m: f32x8, a: f32x8, b: f32x8) -> f32x8 {
        m.select(a, b)
    }
    #[inline(always)]
    fn f_to_bits(a: f32x8) -> u32x8 {
        bytemuck::cast(a)
    }
    #[inline(always)]
    fn f_from_bits(a: u32x8) -> f32x8 {
        bytemuck::cast(a)
    }
    #[inline(always)]
    fn f_trunc(a: f32x8) -> u32x8 {
        bytemuck::cast(a.trunc_int())
    }

    #[inline(always)]
    fn u_splat(v: u32) -> u32x8 {
        u32x8::splat(v)
    }
    #[inline(always)]
    fn u_from_array(a: [u32; LANES]) -> u32x8 {
        u32x8::new(a)
    }
    #[inline(always)]
    fn u_as_array(u: &u32x8) -> &[u32; LANES] {
        u.as_array()
    }
    #[inline(always)]
    fn u_as_array_mut(u: &mut u32x8) -> &mut [u32; LANES] {
        u.as_mut_array()
    }
    #[inline(always)]
    fn u_add(a: u32x8, b: u32x8) -> u32x8 {
        a + b
    }
    #[inline(always)]
    fn u_sub(a: u32x8, b: u32x8) -> u32x8 {
        a - b
    }
    #[inline(always)]
    fn u_and(a: u32x8, b: u32x8) -> u32x8 {
        a & b
    }
    #[inline(always)]
    fn u_or(a: u32x8, b: u32x8) -> u32x8 {
        a | b
    }
    #[inline(always)]
    fn u_xor(a: u32x8, b: u32x8) -> u32x8 {
        a ^ b
    }
    #[inline(always)]
    fn u_mul(a: u32x8, b: u32x8) -> u32x8 {
        a * b
    }
    #[inline(always)]
    fn u_shr(a: u32x8, n: u32) -> u32x8 {
        a >> n
    }
    #[inline(always)]
    fn u_shl(a: u32x8, n: u32) -> u32x8 {
        a << n
    }
    #[inline(always)]
    fn u_eq(a: u32x8, b: u32x8) -> f32x8 {
        bytemuck::cast(a.simd_eq(b))
    }
    #[inline(always)]
    fn u_to_f32(a: u32x8) -> f32x8 {
        f32x8::from_i32x8(bytemuck::cast::<u32x8, i32x8>(a))
    }

    #[inline(always)]
    fn m_from_f(f: f32x8) -> f32x8 {
        f
    }
    #[inline(always)]
    fn m_to_f(m: f32x8) -> f32x8 {
        m
    }
    #[inline(always)]
    fn m_bits(m: f32x8) -> u32 {
        m.to_bitmask()
    }
    #[inline(always)]
    fn m_from_bits(b: u32) -> f32x8 {
        bytemuck::cast((u32x8::splat(b) & BITS).simd_eq(BITS))
    }
}
