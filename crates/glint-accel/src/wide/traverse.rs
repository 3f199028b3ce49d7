//! The traversal kernels, generic over the node width `N` and the SIMD vector `S` that holds
//! one float per child. Every function here is `#[inline(always)]` and free of
//! `#[target_feature]`, so the ISA files instantiate them inside their own (target-feature)
//! entry points: the same source becomes SSE2 code in `sse.rs` and VEX/AVX2 code in `avx2.rs`.
//!
//! Closest hit: children met by the ray are visited nearest entry first (keys
//! `entry-distance bits << 32 | slot`, sorted by insertion), the farther ones pushed with their
//! entry distance and skipped when popped behind the current hit. Any hit: no ordering, first
//! hit returns.

use super::scalar::sort_keys;
use super::sse::{TriRay4, packet_any, packet_closest};
use super::{Entry, LEAF, Stack, WideBvh, WideNode, leaf_packets};
use crate::Hit;
use crate::bvh2::FAR_SCALE;
use glint_core::Ray;

/// The lane operations the node test needs, `N` floats per vector.
pub(super) trait Simd<const N: usize>: Copy {
    fn splat(x: f32) -> Self;
    fn load(a: &[f32; N]) -> Self;
    fn store(self) -> [f32; N];
    fn sub(self, o: Self) -> Self;
    fn mul(self, o: Self) -> Self;
    /// `o` where `self` is NaN (x86 `maxps` semantics with the accumulator second).
    fn max(self, o: Self) -> Self;
    fn min(self, o: Self) -> Self;
    /// Bit `i` set where `self[i] <= o[i]`.
    fn le_mask(self, o: Self) -> u32;
}

/// Per-ray constants of the box test.
pub(super) struct NodeRay<S> {
    org: [S; 3],
    inv: [S; 3],
    neg: [bool; 3],
    tmin: S,
}

impl<S> NodeRay<S> {
    #[inline(always)]
    pub fn new<const N: usize>(ray: &Ray) -> Self
    where
        S: Simd<N>,
    {
        // Exact reciprocal (Ize 2013): no rcp approximation.
        let inv = glint_core::Vec3::ONE / ray.dir;
        let (o, d) = (ray.origin, ray.dir);
        Self {
            org: [S::splat(o.x), S::splat(o.y), S::splat(o.z)],
            inv: [S::splat(inv.x), S::splat(inv.y), S::splat(inv.z)],
            neg: [d.x.is_sign_negative(), d.y.is_sign_negative(), d.z.is_sign_negative()],
            tmin: S::splat(ray.tmin),
        }
    }
}

/// Hit mask and entry distances of the `N` children (Ize 2013: far × (1 + 2γ(3))). Near/far
/// planes are picked by the direction's sign so that a NaN slab distance reaches the max/min
/// chains as the first operand, where it is dropped: that slab stays open.
#[inline(always)]
pub(super) fn node_test<const N: usize, S: Simd<N>>(n: &WideNode<N>, r: &NodeRay<S>, tmax: S) -> (u32, S) {
    let slab = |a: usize, far: bool| {
        let plane = &n.bounds[2 * a + (r.neg[a] ^ far) as usize];
        S::load(plane).sub(r.org[a]).mul(r.inv[a])
    };
    let tn = slab(0, false).max(slab(1, false).max(slab(2, false).max(r.tmin)));
    let tf = slab(0, true).min(slab(1, true).min(slab(2, true).min(S::splat(f32::INFINITY))));
    let tf = tf.mul(S::splat(FAR_SCALE)).min(tmax);
    (tn.le_mask(tf), tn)
}

#[inline(always)]
pub(super) fn closest<const N: usize, S: Simd<N>>(bvh: &WideBvh<N>, ray: &Ray) -> Option<Hit> {
    let nr = NodeRay::<S>::new(ray);
    let tr = TriRay4::new(ray);
    let mut tmax = ray.tmax;
    let mut best = None;
    let mut stack = Stack::<Entry>::new();
    let mut cur = 0u32;
    loop {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let (mask, tn) = node_test(node, &nr, S::splat(tmax));
            if mask != 0 {
                if mask & (mask - 1) == 0 {
                    cur = node.child[mask.trailing_zeros() as usize % N];
                    continue;
                }
                let d = tn.store();
                let mut keys = [0u64; N];
                let mut k = 0;
                let mut m = mask;
                while m != 0 {
                    let i = m.trailing_zeros() as usize % N;
                    keys[k % N] = (d[i].to_bits() as u64) << 32 | i as u64;
                    k += 1;
                    m &= m - 1;
                }
                let keys = &mut keys[..k.min(N)];
                sort_keys(keys);
                for &key in keys[1..].iter().rev() {
                    let i = key as usize % N;
                    stack.push(Entry { child: node.child[i], t: d[i] });
                }
                cur = node.child[keys[0] as usize % N];
                continue;
            }
        } else {
            for p in &bvh.packets[leaf_packets(cur)] {
                tmax = packet_closest(p, &tr, tmax, &mut best);
            }
        }
        loop {
            match stack.pop() {
                None => return best,
                Some(e) if e.t <= tmax => {
                    cur = e.child;
                    break;
                }
                Some(_) => {}
            }
        }
    }
}

#[inline(always)]
pub(super) fn occluded<const N: usize, S: Simd<N>>(bvh: &WideBvh<N>, ray: &Ray) -> bool {
    let nr = NodeRay::<S>::new(ray);
    let tr = TriRay4::new(ray);
    let tmax = S::splat(ray.tmax);
    let mut stack = Stack::<u32>::new();
    let mut cur = 0u32;
    loop {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let (mut mask, _) = node_test(node, &nr, tmax);
            if mask != 0 {
                cur = node.child[mask.trailing_zeros() as usize % N];
                mask &= mask - 1;
                while mask != 0 {
                    stack.push(node.child[mask.trailing_zeros() as usize % N]);
                    mask &= mask - 1;
                }
                continue;
            }
        } else {
            for p in &bvh.packets[leaf_packets(cur)] {
                if packet_any(p, &tr, ray.tmax) {
                    return true;
                }
            }
        }
        match stack.pop() {
            Some(c) => cur = c,
            None => return false,
        }
    }
}
