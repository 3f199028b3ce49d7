//! x86-64 AVX2 + FMA, entered only after runtime detection ([`super::Isa::detect`]): the
//! 8-lane vector [`F8`] for 8-wide nodes, and the walks of `walk.rs` with the SIMD kernel
//! instantiated inside one `#[target_feature(enable = "avx2,fma")]` function, generic over the
//! width and the query (8-wide, and 4-wide recompiled with VEX encoding). Leaves test two
//! packets of 4 triangles at once in the 8 lanes ([`tri8`]: `sse.rs`'s watertight arithmetic
//! lane for lane, no FMA) and a last odd packet with the 4-lane test.

use super::dispatch::Query;
use super::scalar::ScalarKernel;
use super::sse::{F4, Lanes, TriRay4, finish_any, finish_closest, packet_any, packet_closest};
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

/// The lane operations of the triangle test that the node test does not use. Each is the
/// 8-lane form of `sse.rs`'s `F4` operation of the same name (the same predicate: `ne` is
/// unordered, true for NaN, as `cmpneq`), so a lane computes what the 4-lane test computes.
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
    fn cmp<const P: i32>(self, o: Self) -> Self {
        // SAFETY: AVX2 detected.
        F8(unsafe { _mm256_cmp_ps::<P>(self.0, o.0) })
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
    /// `!self & o`.
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

/// The watertight test of `sse.rs`'s `tri4` on two packets at once (`p0` in lanes 0–3, `p1` in
/// 4–7): the same operations in the same order per lane, so every lane's bits are the 4-lane
/// test's. A leaf of more than four triangles (two packets: 40 % of the leaves of a 100 k
/// dragon) is tested with half the instructions.
#[inline(always)]
fn tri8(p0: &TriPacket, p1: &TriPacket, r: &TriRay4, tmax: F8) -> Lanes<F8> {
    let [kx, ky, kz] = r.k;
    let org = [F8::both(r.org[0]), F8::both(r.org[1]), F8::both(r.org[2])];
    let (sx, sy, sz) = (F8::both(r.s[0]), F8::both(r.s[1]), F8::both(r.s[2]));
    let rel = |vert: usize, a: usize, o: usize| F8::pair(&p0.v[vert][a], &p1.v[vert][a]).sub(org[o]);
    let (ax, ay, az) = (rel(0, kx, 0), rel(0, ky, 1), rel(0, kz, 2));
    let (bx, by, bz) = (rel(1, kx, 0), rel(1, ky, 1), rel(1, kz, 2));
    let (cx, cy, cz) = (rel(2, kx, 0), rel(2, ky, 1), rel(2, kz, 2));
    let ax = ax.sub(sx.mul(az));
    let ay = ay.sub(sy.mul(az));
    let bx = bx.sub(sx.mul(bz));
    let by = by.sub(sy.mul(bz));
    let cx = cx.sub(sx.mul(cz));
    let cy = cy.sub(sy.mul(cz));
    let u = cx.mul(by).sub(cy.mul(bx));
    let v = ax.mul(cy).sub(ay.mul(cx));
    let w = bx.mul(ay).sub(by.mul(ax));
    let zero = F8::splat(0.0);
    let eq = |a: F8| a.cmp::<_CMP_EQ_OQ>(zero);
    let any_zero = eq(u).or(eq(v)).or(eq(w));
    let any_neg = u.cmp::<_CMP_LT_OS>(zero).or(v.cmp::<_CMP_LT_OS>(zero)).or(w.cmp::<_CMP_LT_OS>(zero));
    let any_pos = u.cmp::<_CMP_GT_OS>(zero).or(v.cmp::<_CMP_GT_OS>(zero)).or(w.cmp::<_CMP_GT_OS>(zero));
    let det = u.add(v).add(w);
    let t = u.mul(sz.mul(az)).add(v.mul(sz.mul(bz))).add(w.mul(sz.mul(cz)));
    let t = t.div(det);
    let ok = t.cmp::<_CMP_GT_OS>(F8::both(r.tmin)).and(t.cmp::<_CMP_LE_OS>(tmax)).and(det.cmp::<_CMP_NEQ_UQ>(zero));
    let ok = any_neg.and(any_pos).andnot(ok);
    let zero_bits = any_zero.bits();
    Lanes { hit: ok.bits() & !zero_bits, zero: zero_bits, t, v, w, det }
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
