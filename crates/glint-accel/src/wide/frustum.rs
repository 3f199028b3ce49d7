//! Frustum traversal of packets from one point (AVX2 + FMA, entered only after runtime
//! detection): the rays of one direction octant that leave the same origin (a pinhole camera's
//! primary rays) walk the 8-wide tree as one beam. An inner node tests its 8 children against
//! the whole packet at once with the interval bounds of the packet's slab distances (the
//! frusta of Reshetov, Soupikov and Hurley, "Multi-Level Ray Tracing Algorithm", SIGGRAPH 2005,
//! and of Embree's coherent mode): one SIMD operation per slab serves every ray, where
//! `packet.rs` spends one per slab per child. A leaf tests its rays one by one, first against
//! the leaf's own box, then against its triangles.
//!
//! Exactness. A ray's slab distance is `fl(fl(b - o) · inv)`. With one origin, `x = b - o` is
//! the same for every ray, and `fl(x · inv)` is monotone in `inv` (rounding is monotone), so
//! over the packet's reciprocals `[imin, imax]` (one sign per axis within an octant) it lies
//! between `fl(x · imin)` and `fl(x · imax)`. The frustum's entry distance is therefore at most
//! every ray's and its exit at least every ray's (`FAR_SCALE` and `tmax` are monotone too): a
//! child any ray's own test accepts, the frustum accepts. Leaves run the single-ray box and
//! triangle tests per ray, and equally near hits resolve by primitive index, so each ray's
//! answer is the single-ray kernel's bit for bit; visiting more inner nodes than a ray would
//! costs time, never a different hit. Packets whose origins differ (shadow rays from spread
//! hit points: a frustum over their origin box is loose, and measured 25 % slower on a Sponza
//! path frame) or whose reciprocals are not finite and non-zero take `packet.rs`'s kernel.
//!
//! Measured (BENCHMARKS §1.1): Sponza's primary rays 7.1 → 9.9 Mrays/s on one thread, its
//! Whitted frame 111 → 98 ms.

use super::packet::{Lanes, LeafRays, PacketRay, box8, load};
use super::sse::packet_closest;
use super::walk::sort_keys;
use super::{LEAF, Stack, WideBvh, leaf_packets};
use crate::Hit;
use crate::bvh2::FAR_SCALE;
use glint_core::Ray;
use std::arch::x86_64::*;

// SAFETY (every `unsafe` block in this file): the `#[target_feature(enable = "avx2,fma")]`
// function is only called from `packet::closest_packet`, itself only reached after
// `Isa::detect()` found AVX2 and FMA; the intrinsics touch registers and 32-byte arrays only.

/// The interval bounds of a packet's slab distances, splatted across the 8 children.
pub(super) struct Frustum {
    /// The rays' common origin.
    org: [__m256; 3],
    /// Per axis: the smallest and largest reciprocal direction.
    imin: [__m256; 3],
    imax: [__m256; 3],
    tmin: __m256,
}

impl Frustum {
    /// The frustum of `group`'s rays (one octant), or `None` when their origins differ or a
    /// ray's reciprocal direction is not finite and non-zero.
    #[inline(always)]
    pub(super) fn new(pr: &PacketRay, rays: &[Ray; 8], group: u32) -> Option<Self> {
        let inv = pr.inv.map(store);
        let org = rays[group.trailing_zeros() as usize % 8].origin;
        let mut imin = [f32::INFINITY; 3];
        let mut imax = [f32::NEG_INFINITY; 3];
        let mut tmin = f32::INFINITY;
        for i in Lanes(group) {
            let r = &rays[i];
            if r.origin.to_array().map(f32::to_bits) != org.to_array().map(f32::to_bits) {
                return None;
            }
            for a in 0..3 {
                let v = inv[a][i];
                if !v.is_finite() || v == 0.0 {
                    return None;
                }
                imin[a] = imin[a].min(v);
                imax[a] = imax[a].max(v);
            }
            tmin = tmin.min(r.tmin);
        }
        Some(Self { org: org.to_array().map(splat), imin: imin.map(splat), imax: imax.map(splat), tmin: splat(tmin) })
    }

    /// The 8 children of a node against the frustum: the mask of those some ray may meet
    /// before `tmax` (the largest `tmax` of the packet's rays), and entry distances no larger
    /// than any ray's.
    #[inline(always)]
    fn test(&self, pr: &PacketRay, bounds: &[[f32; 8]; 6], tmax: __m256) -> (u32, __m256) {
        let (mut tn, mut tf) = (self.tmin, splat(f32::INFINITY));
        for a in 0..3 {
            let near = interval(load(&bounds[pr.near[a]]), self.org[a], self.imin[a], self.imax[a]);
            let far = interval(load(&bounds[pr.far[a]]), self.org[a], self.imin[a], self.imax[a]);
            // SAFETY: AVX only; inlined into the `avx2,fma` kernel below (see the top of the file).
            unsafe {
                tn = _mm256_max_ps(tn, _mm256_min_ps(near.0, near.1));
                tf = _mm256_min_ps(tf, _mm256_max_ps(far.0, far.1));
            }
        }
        // SAFETY: as above.
        unsafe {
            let tf = _mm256_min_ps(_mm256_mul_ps(tf, _mm256_set1_ps(FAR_SCALE)), tmax);
            (_mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32, tn)
        }
    }
}

/// `(b - o) · lo` and `(b - o) · hi`: a slab distance at both ends of the reciprocal interval.
/// (A function, not a closure: a closure is compiled without the caller's AVX features and its
/// intrinsics would become calls.)
#[inline(always)]
fn interval(b: __m256, o: __m256, lo: __m256, hi: __m256) -> (__m256, __m256) {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels below (see the top of the file).
    unsafe {
        let x = _mm256_sub_ps(b, o);
        (_mm256_mul_ps(x, lo), _mm256_mul_ps(x, hi))
    }
}

#[inline(always)]
fn splat(x: f32) -> __m256 {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels below (see the top of the file).
    unsafe { _mm256_set1_ps(x) }
}

#[inline(always)]
fn store(v: __m256) -> [f32; 8] {
    let mut a = [0.0f32; 8];
    // SAFETY: 32 writable bytes, `storeu` needs no alignment; AVX detected (top of the file).
    unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v) };
    a
}

/// The largest lane (the packet's farthest `tmax`; finished lanes hold `-inf`).
#[inline(always)]
fn lane_max(v: __m256) -> f32 {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels below (see the top of the file).
    unsafe {
        let x = _mm256_max_ps(v, _mm256_permute2f128_ps::<1>(v, v));
        let x = _mm256_max_ps(x, _mm256_shuffle_ps::<0b0100_1110>(x, x));
        let x = _mm256_max_ps(x, _mm256_shuffle_ps::<0b1011_0001>(x, x));
        _mm256_cvtss_f32(x)
    }
}

/// A node to visit: the child reference, where its box is stored (parent node and slot: a
/// leaf tests its rays against it) and the frustum's entry distance.
#[derive(Clone, Copy, Default)]
struct Entry {
    child: u32,
    parent: u32,
    slot: u32,
    tn: f32,
}

/// Closest hits of `group` (one octant, one origin) by frustum traversal.
#[target_feature(enable = "avx2,fma")]
pub(super) fn closest_frustum(
    bvh: &WideBvh<8>,
    pr: &mut PacketRay,
    f: &Frustum,
    rays: &[Ray; 8],
    group: u32,
    out: &mut [Option<Hit>; 8],
) {
    let mut leaf_rays = LeafRays::new(rays);
    let mut tmax = load(&pr.tmax);
    let mut far = lane_max(tmax);
    let mut stack = Stack::<Entry>::new();
    let mut cur = Entry { child: 0, parent: 0, slot: 0, tn: 0.0 };
    'walk: loop {
        if cur.child & LEAF == 0 {
            let node = &bvh.nodes[cur.child as usize];
            let (mask, tn) = f.test(pr, &node.bounds, splat(far));
            if mask != 0 {
                let d = store(tn);
                let entry = |c: usize| Entry { child: node.child[c], parent: cur.child, slot: c as u32, tn: d[c] };
                if mask & (mask - 1) == 0 {
                    cur = entry(mask.trailing_zeros() as usize % 8);
                    continue;
                }
                let mut keys = [0u64; 8];
                let mut k = 0;
                for c in Lanes(mask) {
                    keys[k % 8] = (d[c].to_bits() as u64) << 32 | c as u64;
                    k += 1;
                }
                let keys = &mut keys[..k.min(8)];
                sort_keys(keys);
                for &key in keys[1..].iter().rev() {
                    stack.push(entry(key as usize % 8));
                }
                cur = entry(keys[0] as usize % 8);
                continue;
            }
        } else {
            let (m, _) = box8(&bvh.nodes[cur.parent as usize].bounds, cur.slot as usize, pr, tmax);
            if m & group != 0 {
                for i in Lanes(m & group) {
                    let tr = leaf_rays.get(i);
                    for p in &bvh.packets[leaf_packets(cur.child)] {
                        pr.tmax[i] = packet_closest(p, tr, pr.tmax[i], &mut out[i]);
                    }
                }
                tmax = load(&pr.tmax);
                far = lane_max(tmax);
            }
        }
        loop {
            let Some(e) = stack.pop() else { break 'walk };
            if e.tn <= far {
                cur = e;
                break;
            }
        }
    }
}
