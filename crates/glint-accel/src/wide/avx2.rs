//! x86-64 AVX2 + FMA, entered only after runtime detection ([`super::Isa::detect`]): the
//! 8-lane vector [`F8`] for 8-wide nodes, and the generic kernels instantiated inside
//! `#[target_feature(enable = "avx2,fma")]` functions (8-wide, and 4-wide recompiled with VEX
//! encoding). Leaves use the 4-lane packet test of `sse.rs` (watertight arithmetic, no FMA).

use super::sse::F4;
use super::traverse::{self, Simd};
use super::{Isa, WideBvh, scalar};
use crate::Hit;
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
fn closest8(bvh: &WideBvh<8>, ray: &Ray) -> Option<Hit> {
    traverse::closest::<8, F8>(bvh, ray)
}

#[target_feature(enable = "avx2,fma")]
fn any8(bvh: &WideBvh<8>, ray: &Ray) -> bool {
    traverse::occluded::<8, F8>(bvh, ray)
}

#[target_feature(enable = "avx2,fma")]
fn closest4(bvh: &WideBvh<4>, ray: &Ray) -> Option<Hit> {
    traverse::closest::<4, F4>(bvh, ray)
}

#[target_feature(enable = "avx2,fma")]
fn any4(bvh: &WideBvh<4>, ray: &Ray) -> bool {
    traverse::occluded::<4, F4>(bvh, ray)
}

pub(super) fn intersect8(bvh: &WideBvh<8>, ray: &Ray) -> Option<Hit> {
    if Isa::detect() != Isa::Avx2 {
        return scalar::intersect(bvh, ray);
    }
    // SAFETY: AVX2 and FMA were detected at runtime just above.
    unsafe { closest8(bvh, ray) }
}

pub(super) fn occluded8(bvh: &WideBvh<8>, ray: &Ray) -> bool {
    if Isa::detect() != Isa::Avx2 {
        return scalar::occluded(bvh, ray);
    }
    // SAFETY: AVX2 and FMA were detected at runtime just above.
    unsafe { any8(bvh, ray) }
}

pub(super) fn intersect4(bvh: &WideBvh<4>, ray: &Ray) -> Option<Hit> {
    if Isa::detect() != Isa::Avx2 {
        return super::sse::intersect(bvh, ray);
    }
    // SAFETY: AVX2 and FMA were detected at runtime just above.
    unsafe { closest4(bvh, ray) }
}

pub(super) fn occluded4(bvh: &WideBvh<4>, ray: &Ray) -> bool {
    if Isa::detect() != Isa::Avx2 {
        return super::sse::occluded(bvh, ray);
    }
    // SAFETY: AVX2 and FMA were detected at runtime just above.
    unsafe { any4(bvh, ray) }
}
