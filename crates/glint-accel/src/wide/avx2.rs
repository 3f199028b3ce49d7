//! x86-64 AVX2 + FMA, entered only after runtime detection ([`super::Isa::detect`]): the
//! 8-lane vector [`F8`] for 8-wide nodes, and the walks of `walk.rs` with the SIMD kernel
//! instantiated inside one `#[target_feature(enable = "avx2,fma")]` function, generic over the
//! width and the query (8-wide, and 4-wide recompiled with VEX encoding). Leaves test two
//! packets of 4 triangles at once in the 8 lanes ([`tri8`]: `sse.rs`'s watertight arithmetic
//! lane for lane, no FMA) and a last odd packet with the 4-lane test.

use super::dispatch::Query;
use super::scalar::ScalarKernel;
use super::sse::{F4, Lanes, TriOps, TriRay4, finish_any, finish_closest, packet_any, packet_closest, woop_lanes};
use super::traverse::{Simd, SimdKernel};
use super::{Isa, TriPacket, WideBvh};
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

    /// Two packets per test ([`tri8`]) while two remain, then one.
    #[inline(always)]
    fn closest_in_leaf(r: &TriRay4, packets: &[TriPacket], mut tmax: f32, best: &mut Option<Hit>) -> f32 {
        let mut i = 0;
        while i + 1 < packets.len() {
            let pair = &packets[i..i + 2];
            tmax = finish_closest(pair, tri8(&pair[0], &pair[1], r, F8::splat(tmax)), r, tmax, best);
            i += 2;
        }
        if let Some(p) = packets.get(i) {
            tmax = packet_closest(p, r, tmax, best);
        }
        tmax
    }

    #[inline(always)]
    fn any_in_leaf(r: &TriRay4, packets: &[TriPacket], tmax: f32) -> bool {
        let mut i = 0;
        while i + 1 < packets.len() {
            let pair = &packets[i..i + 2];
            let l = tri8(&pair[0], &pair[1], r, F8::splat(tmax));
            if finish_any(pair, l.hit, l.zero, r, tmax) {
                return true;
            }
            i += 2;
        }
        packets.get(i).is_some_and(|p| packet_any(p, r, tmax))
    }
}

/// A leaf's closest-hit test for one ray with the AVX lanes (two packets at a time), for the
/// packet kernels' per-ray leaf steps; only called from AVX2 + FMA code.
#[inline(always)]
pub(super) fn leaf_closest(r: &TriRay4, packets: &[TriPacket], tmax: f32, best: &mut Option<Hit>) -> f32 {
    F8::closest_in_leaf(r, packets, tmax, best)
}

/// [`leaf_closest`] for any hit.
#[inline(always)]
pub(super) fn leaf_any(r: &TriRay4, packets: &[TriPacket], tmax: f32) -> bool {
    F8::any_in_leaf(r, packets, tmax)
}

/// The 8-lane forms of the triangle test's operations (`sse::TriOps`), the same x86 predicates
/// as `F4`'s.
impl F8 {
    /// One 4-lane vector in both halves.
    #[inline(always)]
    fn both(x: F4) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_set_m128(x.0, x.0) })
    }
    /// `lo` in lanes 0–3, `hi` in lanes 4–7.
    #[inline(always)]
    fn pair(lo: &[f32; 4], hi: &[f32; 4]) -> Self {
        // SAFETY: AVX2 detected; each load reads 16 bytes of a `[f32; 4]`, `loadu` needs no
        // alignment.
        F8(unsafe { _mm256_set_m128(_mm_loadu_ps(hi.as_ptr()), _mm_loadu_ps(lo.as_ptr())) })
    }
    #[inline(always)]
    fn cmp<const P: i32>(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_cmp_ps::<P>(self.0, o.0) })
    }
}

impl TriOps<8> for F8 {
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_add_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_div_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Self {
        self.cmp::<_CMP_EQ_OQ>(o)
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self {
        self.cmp::<_CMP_LT_OS>(o)
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self {
        self.cmp::<_CMP_GT_OS>(o)
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self {
        self.cmp::<_CMP_LE_OS>(o)
    }
    #[inline(always)]
    fn ne(self, o: Self) -> Self {
        self.cmp::<_CMP_NEQ_UQ>(o)
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_or_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_and_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn andnot(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_andnot_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        // SAFETY: AVX2 detected.
        unsafe { _mm256_movemask_ps(self.0) as u32 }
    }
}

/// The watertight test on two packets at once (`p0` in lanes 0–3, `p1` in 4–7): `sse.rs`'s
/// `woop_lanes` on 8 lanes, so every lane's bits are the 4-lane test's. A leaf of more than
/// four triangles (two packets: 40 % of the leaves of a 100 k dragon) is tested with half the
/// instructions.
#[inline(always)]
fn tri8(p0: &TriPacket, p1: &TriPacket, r: &TriRay4, tmax: F8) -> Lanes<F8> {
    let org = [F8::both(r.org[0]), F8::both(r.org[1]), F8::both(r.org[2])];
    let rel = [rel8(p0, p1, 0, r.k, &org), rel8(p0, p1, 1, r.k, &org), rel8(p0, p1, 2, r.k, &org)];
    let s = [F8::both(r.s[0]), F8::both(r.s[1]), F8::both(r.s[2])];
    woop_lanes(rel, s, F8::both(r.tmin), tmax)
}

/// Vertex `vert` of both packets along the ray's permuted axes `k`, relative to its origin.
// A function, not a closure: a closure is compiled without the caller's AVX features, and its
// intrinsics became calls (diffuse rays 4.9 -> 3.3 Mrays/s).
#[inline(always)]
fn rel8(p0: &TriPacket, p1: &TriPacket, vert: usize, k: [usize; 3], org: &[F8; 3]) -> [F8; 3] {
    let (a, b) = (&p0.v[vert], &p1.v[vert]);
    [
        F8::pair(&a[k[0]], &b[k[0]]).sub(org[0]),
        F8::pair(&a[k[1]], &b[k[1]]).sub(org[1]),
        F8::pair(&a[k[2]], &b[k[2]]).sub(org[2]),
    ]
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
