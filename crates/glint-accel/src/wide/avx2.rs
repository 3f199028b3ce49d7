//! x86-64 AVX2 + FMA, entered only after runtime detection ([`super::Isa::detect`]): the
//! 8-lane vector [`F8`] for 8-wide nodes, and the walks of `walk.rs` with the SIMD kernel
//! instantiated inside one `#[target_feature(enable = "avx2,fma")]` function, generic over the
//! width and the query (8-wide, and 4-wide recompiled with VEX encoding). Leaves use the
//! 4-lane packet test of `sse.rs` (watertight arithmetic, no FMA).

use super::dispatch::Query;
use super::scalar::ScalarKernel;
use super::sse::F4;
use super::traverse::{Simd, SimdKernel};
use super::{Isa, WideBvh};
use glint_core::Ray;
use std::arch::x86_64::*;

// SAFETY (every `unsafe` block in this file that calls an AVX intrinsic): `F8` is private to
// this module and only used by the kernels instantiated in the `#[target_feature(enable =
// "avx2,fma")]` functions below, which are only called after `Isa::detect()` found AVX2 and FMA.

/// Eight f32 lanes in an AVX register.
#[derive(Clone, Copy)]
struct F8(__m256);

impl Simd<8> for F8 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: AVX2 detected (see the top of the file).
        F8(unsafe { _mm256_set1_ps(x) })
    }
    #[inline(always)]
    fn load(a: &[f32; 8]) -> Self {
        // SAFETY: `a` is 32 readable bytes, `loadu` needs no alignment; AVX2 detected.
        F8(unsafe { _mm256_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    fn store(self) -> [f32; 8] {
        let mut a = [0.0f32; 8];
        // SAFETY: `a` is 32 writable bytes, `storeu` needs no alignment; AVX2 detected.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_sub_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_mul_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_max_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn le_mask(self, o: Self) -> u32 {
        // SAFETY: AVX2 detected. Ordered compare: NaN lanes are false.
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(self.0, o.0)) as u32 }
    }
}

#[target_feature(enable = "avx2,fma")]
fn walk<const N: usize, S: Simd<N>, Q: Query>(bvh: &WideBvh<N>, ray: &Ray) -> Q::Out {
    Q::walk::<N, SimdKernel<S>>(bvh, ray)
}

/// `Q` with the AVX2 kernel of vector `S`, or with `fallback` on a machine without AVX2 and FMA
/// (a caller may ask for [`Isa::Avx2`] anywhere).
#[inline(always)]
fn checked<const N: usize, S: Simd<N>, Q: Query>(
    bvh: &WideBvh<N>,
    ray: &Ray,
    fallback: impl FnOnce(&WideBvh<N>, &Ray) -> Q::Out,
) -> Q::Out {
    if Isa::detect() != Isa::Avx2 {
        return fallback(bvh, ray);
    }
    // SAFETY: AVX2 and FMA were detected at runtime just above.
    unsafe { walk::<N, S, Q>(bvh, ray) }
}

/// 8-wide nodes with the 8-lane [`F8`]; the scalar kernel without AVX2.
pub(super) fn run8<Q: Query>(bvh: &WideBvh<8>, ray: &Ray) -> Q::Out {
    checked::<8, F8, Q>(bvh, ray, Q::walk::<8, ScalarKernel>)
}

/// 4-wide nodes with SSE's [`F4`] recompiled with VEX encoding; the SSE2 kernel without AVX2.
pub(super) fn run4<Q: Query>(bvh: &WideBvh<4>, ray: &Ray) -> Q::Out {
    checked::<4, F4, Q>(bvh, ray, Q::walk::<4, SimdKernel<F4>>)
}
