//! AVX2: eight lanes in one 256-bit register. The type is private to this module and only
//! instantiated by [`run`], inside a `#[target_feature(enable = "avx2,fma")]` function that
//! [`super::dispatch`] enters after runtime detection: every intrinsic below runs on a CPU that
//! has it.

#![cfg(target_arch = "x86_64")]

use super::{Isa, LANES, LaneKernel};
use std::arch::x86_64::*;

// SAFETY (every `unsafe` block in this file): the intrinsics need AVX or AVX2, and `Avx2` is
// only ever a type argument of kernels entered through `run_avx2`, whose caller detected AVX2
// and FMA; the array views reinterpret 32-byte registers as [f32; 8] / [u32; 8] (same size,
// alignment 32 ≥ 4, every bit pattern valid).

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Avx2;

/// Run `kernel` with 256-bit lanes. Only called by [`super::dispatch`] after
/// [`super::avx2_available`].
pub(super) fn run<K: LaneKernel>(kernel: K) -> K::Output {
    debug_assert!(super::avx2_available());
    // SAFETY: `dispatch` calls this only after detecting AVX2 and FMA on this CPU.
    unsafe { run_avx2(kernel) }
}

#[target_feature(enable = "avx2,fma")]
fn run_avx2<K: LaneKernel>(kernel: K) -> K::Output {
    kernel.run::<Avx2>()
}

impl Isa for Avx2 {
    type F = __m256;
    type U = __m256i;
    type M = __m256;

    #[inline(always)]
    fn f_splat(v: f32) -> __m256 {
        unsafe { _mm256_set1_ps(v) }
    }
    #[inline(always)]
    fn f_from_array(a: [f32; LANES]) -> __m256 {
        unsafe { _mm256_loadu_ps(a.as_ptr()) }
    }
    #[inline(always)]
    fn f_as_array(f: &__m256) -> &[f32; LANES] {
        unsafe { &*(f as *const __m256).cast::<[f32; LANES]>() }
    }
    #[inline(always)]
    fn f_as_array_mut(f: &mut __m256) -> &mut [f32; LANES] {
        unsafe { &mut *(f as *mut __m256).cast::<[f32; LANES]>() }
    }
    #[inline(always)]
    fn f_add(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_add_ps(a, b) }
    }
    #[inline(always)]
    fn f_sub(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_sub_ps(a, b) }
    }
    #[inline(always)]
    fn f_mul(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_mul_ps(a, b) }
    }
    #[inline(always)]
    fn f_div(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_div_ps(a, b) }
    }
    #[inline(always)]
    fn f_sqrt(a: __m256) -> __m256 {
        unsafe { _mm256_sqrt_ps(a) }
    }
    #[inline(always)]
    fn f_floor(a: __m256) -> __m256 {
        unsafe { _mm256_floor_ps(a) }
    }
    #[inline(always)]
    fn f_and(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_and_ps(a, b) }
    }
    #[inline(always)]
    fn f_or(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_or_ps(a, b) }
    }
    #[inline(always)]
    fn f_andnot(a: __m256, b: __m256) -> __m256 {
        // _mm256_andnot_ps(x, y) is !x & y.
        unsafe { _mm256_andnot_ps(b, a) }
    }
    #[inline(always)]
    fn f_xor(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_xor_ps(a, b) }
    }
    #[inline(always)]
    fn f_lt(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_LT_OQ>(a, b) }
    }
    #[inline(always)]
    fn f_le(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_LE_OQ>(a, b) }
    }
    #[inline(always)]
    fn f_eq(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_EQ_OQ>(a, b) }
    }
    #[inline(always)]
    fn f_ordered(a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_cmp_ps::<_CMP_ORD_Q>(a, b) }
    }
    #[inline(always)]
    fn f_select(m: __m256, a: __m256, b: __m256) -> __m256 {
        unsafe { _mm256_blendv_ps(b, a, m) }
    }
    #[inline(always)]
    fn f_to_bits(a: __m256) -> __m256i {
        unsafe { _mm256_castps_si256(a) }
    }
    #[inline(always)]
    fn f_from_bits(a: __m256i) -> __m256 {
        unsafe { _mm256_castsi256_ps(a) }
    }
    #[inline(always)]
    fn f_trunc(a: __m256) -> __m256i {
        unsafe { _mm256_cvttps_epi32(a) }
    }

    #[inline(always)]
    fn u_splat(v: u32) -> __m256i {
        unsafe { _mm256_set1_epi32(v as i32) }
    }
    #[inline(always)]
    fn u_from_array(a: [u32; LANES]) -> __m256i {
        unsafe { _mm256_loadu_si256(a.as_ptr().cast()) }
    }
    #[inline(always)]
    fn u_as_array(u: &__m256i) -> &[u32; LANES] {
        unsafe { &*(u as *const __m256i).cast::<[u32; LANES]>() }
    }
    #[inline(always)]
    fn u_as_array_mut(u: &mut __m256i) -> &mut [u32; LANES] {
        unsafe { &mut *(u as *mut __m256i).cast::<[u32; LANES]>() }
    }
    #[inline(always)]
    fn u_add(a: __m256i, b: __m256i) -> __m256i {
        unsafe { _mm256_add_epi32(a, b) }
    }
    #[inline(always)]
    fn u_sub(a: __m256i, b: __m256i) -> __m256i {
        unsafe { _mm256_sub_epi32(a, b) }
    }
    #[inline(always)]
    fn u_and(a: __m256i, b: __m256i) -> __m256i {
        unsafe { _mm256_and_si256(a, b) }
    }
    #[inline(always)]
    fn u_or(a: __m256i, b: __m256i) -> __m256i {
        unsafe { _mm256_or_si256(a, b) }
    }
    #[inline(always)]
    fn u_xor(a: __m256i, b: __m256i) -> __m256i {
        unsafe { _mm256_xor_si256(a, b) }
    }
    #[inline(always)]
    fn u_mul(a: __m256i, b: __m256i) -> __m256i {
        unsafe { _mm256_mullo_epi32(a, b) }
    }
    #[inline(always)]
    fn u_shr(a: __m256i, n: u32) -> __m256i {
        unsafe { _mm256_srl_epi32(a, _mm_cvtsi32_si128(n as i32)) }
    }
    #[inline(always)]
    fn u_shl(a: __m256i, n: u32) -> __m256i {
        unsafe { _mm256_sll_epi32(a, _mm_cvtsi32_si128(n as i32)) }
    }
    #[inline(always)]
    fn u_eq(a: __m256i, b: __m256i) -> __m256 {
        unsafe { _mm256_castsi256_ps(_mm256_cmpeq_epi32(a, b)) }
    }
    #[inline(always)]
    fn u_to_f32(a: __m256i) -> __m256 {
        unsafe { _mm256_cvtepi32_ps(a) }
    }

    #[inline(always)]
    fn m_from_f(f: __m256) -> __m256 {
        f
    }
    #[inline(always)]
    fn m_to_f(m: __m256) -> __m256 {
        m
    }
    #[inline(always)]
    fn m_bits(m: __m256) -> u32 {
        unsafe { _mm256_movemask_ps(m) as u32 }
    }
    #[inline(always)]
    fn m_from_bits(b: u32) -> __m256 {
        unsafe {
            let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
            _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(b as i32), bits), bits))
        }
    }
}
