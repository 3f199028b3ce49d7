//! x86-64 SSE2: the 4-lane vector [`F4`] (node test of 4-wide nodes, and the triangle packet
//! test of every width). SSE2 is part of the x86-64 baseline, so the 4-wide SSE2 kernel
//! (`SimdKernel<F4>`, chosen in `dispatch.rs`) runs everywhere without detection; the same
//! `#[inline(always)]` code is recompiled with VEX encoding when `avx2.rs` inlines it.
//!
//! Packet test: Woop, Benthin, Wald 2013 on four lanes, the same operations in the same order
//! as `primitives::woop` and no FMA, so lanes are bit-identical to the scalar test; lanes
//! whose edge functions come out exactly zero are handed to the scalar test and its f64
//! recomputation.

use super::traverse::Simd;
use super::walk::closer;
use super::{PACKET, TriPacket};
use crate::Hit;
use crate::primitives::{WoopRay, woop};
use glint_core::Ray;
use std::arch::x86_64::*;

// SAFETY (every `unsafe` block in this file that calls an SSE/SSE2 intrinsic): SSE and SSE2 are
// part of the x86-64 baseline, so every CPU this code can run on has them.

/// Four f32 lanes in an SSE register.
#[derive(Clone, Copy)]
pub(super) struct F4(pub(super) __m128);

impl Simd<4> for F4 {
    #[inline(always)]
    fn splat(x: f32) -> Self {
        // SAFETY: SSE2 baseline (see the top of the file).
        F4(unsafe { _mm_set1_ps(x) })
    }
    #[inline(always)]
    fn load(a: &[f32; 4]) -> Self {
        // SAFETY: `a` is 16 readable bytes, `loadu` needs no alignment; SSE2 baseline.
        F4(unsafe { _mm_loadu_ps(a.as_ptr()) })
    }
    #[inline(always)]
    fn store(self) -> [f32; 4] {
        let mut a = [0.0f32; 4];
        // SAFETY: `a` is 16 writable bytes, `storeu` needs no alignment; SSE2 baseline.
        unsafe { _mm_storeu_ps(a.as_mut_ptr(), self.0) };
        a
    }
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_sub_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_mul_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn max(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_max_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn min(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_min_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn le_mask(self, o: Self) -> u32 {
        // SAFETY: SSE2 baseline.
        unsafe { _mm_movemask_ps(_mm_cmple_ps(self.0, o.0)) as u32 }
    }
}

/// The vector operations of the watertight triangle test beyond the node test's ([`Simd`]):
/// lane masks (all ones / all zeros) of comparisons with x86's predicates (`ne` unordered:
/// true for NaN, as `cmpneq`), their bit logic, and the arithmetic. `F4` here, `avx2.rs`'s
/// `F8` for two packets at once.
pub(super) trait TriOps<const L: usize>: Simd<L> {
    fn add(self, o: Self) -> Self;
    fn div(self, o: Self) -> Self;
    fn eq(self, o: Self) -> Self;
    fn lt(self, o: Self) -> Self;
    fn gt(self, o: Self) -> Self;
    fn le(self, o: Self) -> Self;
    fn ne(self, o: Self) -> Self;
    fn or(self, o: Self) -> Self;
    fn and(self, o: Self) -> Self;
    /// `!self & o`.
    fn andnot(self, o: Self) -> Self;
    /// Bit `i` set where lane `i`'s sign bit is.
    fn bits(self) -> u32;
}

impl TriOps<4> for F4 {
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_add_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn div(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_div_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn eq(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_cmpeq_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn lt(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_cmplt_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn gt(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_cmpgt_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn le(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_cmple_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn ne(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_cmpneq_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn or(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_or_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn and(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_and_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn andnot(self, o: Self) -> Self {
        // SAFETY: SSE2 baseline.
        F4(unsafe { _mm_andnot_ps(self.0, o.0) })
    }
    #[inline(always)]
    fn bits(self) -> u32 {
        // SAFETY: SSE2 baseline.
        unsafe { _mm_movemask_ps(self.0) as u32 }
    }
}

/// Per-ray constants of the packet test.
pub(super) struct TriRay4 {
    pub(super) k: [usize; 3],
    pub(super) org: [F4; 3],
    pub(super) s: [F4; 3],
    pub(super) tmin: F4,
    woop: WoopRay,
    tmin_s: f32,
}

impl TriRay4 {
    #[inline(always)]
    pub fn new(ray: &Ray) -> Self {
        let w = WoopRay::new(ray);
        let k = [w.kx, w.ky, w.kz];
        Self {
            k,
            org: k.map(|a| F4::splat(w.org[a])),
            s: [F4::splat(w.sx), F4::splat(w.sy), F4::splat(w.sz)],
            tmin: F4::splat(ray.tmin),
            woop: w,
            tmin_s: ray.tmin,
        }
    }
}

/// The lanes after the watertight test, `L` of them in vectors `V` (one packet in an [`F4`], or
/// two side by side in AVX's 8 lanes): hits (lanes with a zero edge function excluded), lanes
/// needing the exact fallback, and t, V, W, det.
pub(super) struct Lanes<V> {
    pub(super) hit: u32,
    pub(super) zero: u32,
    pub(super) t: V,
    pub(super) v: V,
    pub(super) w: V,
    pub(super) det: V,
}

/// The watertight test (Woop, Benthin, Wald 2013, steps 3–6) on `L` lanes: `rel[v][a]` holds
/// vertex `v`'s coordinate along the ray's permuted axis `a` (`kx, ky, kz`) relative to the
/// ray's origin, `s` the shear. The operations of `primitives::woop` in its order, multiplies
/// and subtractions never fused, so every lane has the scalar test's bits whatever the width.
#[inline(always)]
pub(super) fn woop_lanes<const L: usize, V: TriOps<L>>(rel: [[V; 3]; 3], s: [V; 3], tmin: V, tmax: V) -> Lanes<V> {
    let [[ax, ay, az], [bx, by, bz], [cx, cy, cz]] = rel;
    let [sx, sy, sz] = s;
    // Shear, then the 2-D edge functions: multiply and subtract, never fused.
    let ax = ax.sub(sx.mul(az));
    let ay = ay.sub(sy.mul(az));
    let bx = bx.sub(sx.mul(bz));
    let by = by.sub(sy.mul(bz));
    let cx = cx.sub(sx.mul(cz));
    let cy = cy.sub(sy.mul(cz));
    let u = cx.mul(by).sub(cy.mul(bx));
    let v = ax.mul(cy).sub(ay.mul(cx));
    let w = bx.mul(ay).sub(by.mul(ax));
    let zero = V::splat(0.0);
    let any_zero = u.eq(zero).or(v.eq(zero)).or(w.eq(zero));
    let any_neg = u.lt(zero).or(v.lt(zero)).or(w.lt(zero));
    let any_pos = u.gt(zero).or(v.gt(zero)).or(w.gt(zero));
    let det = u.add(v).add(w);
    let t = u.mul(sz.mul(az)).add(v.mul(sz.mul(bz))).add(w.mul(sz.mul(cz)));
    let t = t.div(det);
    let ok = t.gt(tmin).and(t.le(tmax)).and(det.ne(zero));
    let ok = any_neg.and(any_pos).andnot(ok);
    let zero_bits = any_zero.bits();
    Lanes { hit: ok.bits() & !zero_bits, zero: zero_bits, t, v, w, det }
}

#[inline(always)]
fn tri4(p: &TriPacket, r: &TriRay4, tmax: F4) -> Lanes<F4> {
    let [kx, ky, kz] = r.k;
    let rel = |vert: usize| {
        let v = &p.v[vert];
        [F4::load(&v[kx]).sub(r.org[0]), F4::load(&v[ky]).sub(r.org[1]), F4::load(&v[kz]).sub(r.org[2])]
    };
    woop_lanes([rel(0), rel(1), rel(2)], r.s, r.tmin, tmax)
}

const _: () = assert!(PACKET == 4);

/// Closest-hit leaf step: tests one packet, updates `best`, returns the new `tmax`.
#[inline(always)]
pub(super) fn packet_closest(p: &TriPacket, r: &TriRay4, tmax: f32, best: &mut Option<Hit>) -> f32 {
    finish_closest(std::slice::from_ref(p), tri4(p, r, F4::splat(tmax)), r, tmax, best)
}

/// Any-hit leaf step.
#[inline(always)]
pub(super) fn packet_any(p: &TriPacket, r: &TriRay4, tmax: f32) -> bool {
    let l = tri4(p, r, F4::splat(tmax));
    finish_any(std::slice::from_ref(p), l.hit, l.zero, r, tmax)
}

/// The closest-hit step after the lane test `l` of `packets` (lane `i` is lane `i % 4` of packet
/// `i / 4`): the nearest hit lane (lowest primitive among equals) replaces `best` by
/// [`closer`], then the zero lanes are decided by the scalar test. Returns the new `tmax`.
#[inline(always)]
pub(super) fn finish_closest<const L: usize, V: Simd<L>>(
    packets: &[TriPacket],
    l: Lanes<V>,
    r: &TriRay4,
    tmax: f32,
    best: &mut Option<Hit>,
) -> f32 {
    let prim = |i: usize| packets[i / PACKET].prim[i % PACKET];
    let mut tmax = tmax;
    if l.hit != 0 {
        let t = l.t.store();
        let mut m = l.hit;
        let mut lane = m.trailing_zeros() as usize % L;
        m &= m - 1;
        while m != 0 {
            let i = m.trailing_zeros() as usize % L;
            if t[i] < t[lane] || (t[i] == t[lane] && prim(i) < prim(lane)) {
                lane = i;
            }
            m &= m - 1;
        }
        if closer(t[lane], prim(lane), best) {
            let (v, w, det) = (l.v.store(), l.w.store(), l.det.store());
            tmax = t[lane];
            *best = Some(Hit { t: t[lane], prim: prim(lane), u: v[lane] / det[lane], v: w[lane] / det[lane] });
        }
    }
    let mut z = l.zero;
    while z != 0 {
        let lane = z.trailing_zeros() as usize % L;
        let [a, b, c] = packets[lane / PACKET].lane(lane % PACKET);
        if let Some(h) = woop(&r.woop, a, b, c, r.tmin_s, tmax)
            && closer(h.t, prim(lane), best)
        {
            tmax = h.t;
            *best = Some(Hit { t: h.t, prim: prim(lane), u: h.u, v: h.v });
        }
        z &= z - 1;
    }
    tmax
}

/// The any-hit step after a lane test of `packets` (lanes numbered as in [`finish_closest`]).
#[inline(always)]
pub(super) fn finish_any(packets: &[TriPacket], hit: u32, zero: u32, r: &TriRay4, tmax: f32) -> bool {
    if hit != 0 {
        return true;
    }
    let mut z = zero;
    while z != 0 {
        let lane = z.trailing_zeros() as usize;
        let Some(p) = packets.get(lane / PACKET) else { break };
        let [a, b, c] = p.lane(lane % PACKET);
        if woop(&r.woop, a, b, c, r.tmin_s, tmax).is_some() {
            return true;
        }
        z &= z - 1;
    }
    false
}
