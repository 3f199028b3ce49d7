//! The SIMD kernel, generic over the node width `N` and the SIMD vector `S` that holds one
//! float per child: the node test of all `N` children at once, and the 4-lane triangle packet
//! test of `sse.rs` in the leaves. Every function here is `#[inline(always)]` and free of
//! `#[target_feature]`, so the ISA files instantiate the walks of `walk.rs` with [`SimdKernel`]
//! inside their own (target-feature) entry points: the same source becomes SSE2 code in
//! `sse.rs` and VEX/AVX2 code in `avx2.rs`.
//!
//! The visiting order is `walk.rs`'s: nearest entry first for the closest hit, found from the
//! node test's entry distances ([`order_children`]: one child met goes straight down, two or
//! three are ordered without a key sort). Leaves go through [`Simd::closest_in_leaf`], so that
//! a vector of 8 lanes tests two triangle packets at once.

use super::sse::{TriRay4, packet_any, packet_closest};
use super::walk::{Entry, Kernel, Stack, order_children};
use super::{TriPacket, WideNode};
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

    /// [`Kernel::closest_in_leaf`] with this vector's instruction set: one packet at a time
    /// unless the vector holds two (AVX's 8 lanes, `avx2.rs`).
    #[inline(always)]
    fn closest_in_leaf(r: &TriRay4, packets: &[TriPacket], mut tmax: f32, best: &mut Option<Hit>) -> f32 {
        for p in packets {
            tmax = packet_closest(p, r, tmax, best);
        }
        tmax
    }

    /// [`Kernel::any_in_leaf`], as [`Simd::closest_in_leaf`].
    // A loop, not an iterator adapter: a closure handed to a library function cannot be
    // inlined into it from a `#[target_feature]` caller, and the leaf test would become a call.
    #[inline(always)]
    fn any_in_leaf(r: &TriRay4, packets: &[TriPacket], tmax: f32) -> bool {
        for p in packets {
            if packet_any(p, r, tmax) {
                return true;
            }
        }
        false
    }
}

/// Per-ray constants of the box test.
pub(super) struct NodeRay<S> {
    org: [S; 3],
    inv: [S; 3],
    inv_far: [S; 3],
    neg: [bool; 3],
    tmin: S,
}

impl<S> NodeRay<S> {
    #[inline(always)]
    pub fn new<const N: usize>(ray: &Ray) -> Self
    where
        S: Simd<N>,
    {
        // Exact reciprocal (Ize 2013): no rcp approximation; one SIMD division for the three
        // lanes (the same correctly rounded quotients as three scalar ones).
        let inv = glint_core::Vec3A::ONE / glint_core::Vec3A::from(ray.dir);
        let (o, d) = (ray.origin, ray.dir);
        Self {
            org: [S::splat(o.x), S::splat(o.y), S::splat(o.z)],
            inv: [S::splat(inv.x), S::splat(inv.y), S::splat(inv.z)],
            inv_far: {
                let f = inv * FAR_SCALE;
                [S::splat(f.x), S::splat(f.y), S::splat(f.z)]
            },
            neg: [d.x.is_sign_negative(), d.y.is_sign_negative(), d.z.is_sign_negative()],
            tmin: S::splat(ray.tmin),
        }
    }
}

/// Hit mask and entry distances of the `N` children: `bvh2::BoxRay::hit` in lanes, the far
/// planes' reciprocal scaled ahead of time ([`FAR_SCALE`]), so that each chain is three
/// subtract-multiply slabs into three max (min) operations. Folding the scale into the
/// reciprocal took a multiply and a `min` off the dependency chain from one node's loads to the
/// next node's address: incoherent rays 3–6 % faster (BENCHMARKS.md §13.12). Near/far planes
/// are picked by the direction's sign so that a NaN slab distance reaches the max/min chains as
/// the first operand, where it is dropped: that slab stays open.
#[inline(always)]
pub(super) fn node_test<const N: usize, S: Simd<N>>(n: &WideNode<N>, r: &NodeRay<S>, tmax: S) -> (u32, S) {
    let slab = |a: usize, far: bool, inv: &[S; 3]| {
        let plane = &n.bounds[2 * a + (r.neg[a] ^ far) as usize];
        S::load(plane).sub(r.org[a]).mul(inv[a])
    };
    let tn = slab(0, false, &r.inv).max(slab(1, false, &r.inv).max(slab(2, false, &r.inv).max(r.tmin)));
    let tf = slab(0, true, &r.inv_far).min(slab(1, true, &r.inv_far).min(slab(2, true, &r.inv_far).min(tmax)));
    (tn.le_mask(tf), tn)
}

/// The SIMD kernel with vector `S`.
pub(super) struct SimdKernel<S>(std::marker::PhantomData<S>);

impl<const N: usize, S: Simd<N>> Kernel<N> for SimdKernel<S> {
    type NodeRay = NodeRay<S>;
    type LeafRay = TriRay4;

    #[inline(always)]
    fn node_ray(ray: &Ray) -> NodeRay<S> {
        NodeRay::new(ray)
    }

    #[inline(always)]
    fn leaf_ray(ray: &Ray) -> TriRay4 {
        TriRay4::new(ray)
    }

    #[inline(always)]
    fn nearest_child(r: &NodeRay<S>, node: &WideNode<N>, tmax: f32, stack: &mut Stack<Entry>) -> Option<u32> {
        let (mask, tn) = node_test(node, r, S::splat(tmax));
        if mask == 0 {
            return None;
        }
        if mask & (mask - 1) == 0 {
            return Some(node.child[mask.trailing_zeros() as usize % N]);
        }
        let d = tn.store();
        let near = order_children(mask, &d, |slot| stack.push(Entry { child: node.child[slot], t: d[slot] }));
        Some(node.child[near])
    }

    #[inline(always)]
    fn any_child(r: &NodeRay<S>, node: &WideNode<N>, tmax: f32, stack: &mut Stack<u32>) -> Option<u32> {
        let (mut mask, _) = node_test(node, r, S::splat(tmax));
        if mask == 0 {
            return None;
        }
        let first = node.child[mask.trailing_zeros() as usize % N];
        mask &= mask - 1;
        // The others pushed from the highest slot down, so that they pop in slot order: the
        // children met are visited largest box first (`WideBvh::from_bvh2`). Pushed lowest
        // first, they popped smallest first: Sponza's incoherent any-hit rays 8.0 / 8.4 / 8.6
        // -> 10.4 / 11.0 / 10.9 M rays/s (BENCHMARKS.md §13.12).
        while mask != 0 {
            let top = 31 - mask.leading_zeros();
            stack.push(node.child[top as usize % N]);
            mask &= !(1 << top);
        }
        Some(first)
    }

    #[inline(always)]
    fn closest_in_leaf(r: &TriRay4, packets: &[TriPacket], tmax: f32, best: &mut Option<Hit>) -> f32 {
        S::closest_in_leaf(r, packets, tmax, best)
    }

    #[inline(always)]
    fn any_in_leaf(r: &TriRay4, packets: &[TriPacket], tmax: f32) -> bool {
        S::any_in_leaf(r, packets, tmax)
    }
}
