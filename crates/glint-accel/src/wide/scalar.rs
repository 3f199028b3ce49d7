//! The portable kernel for any width: the oracle of the SIMD kernels and the path on targets
//! without one. Its tests are the binary tree's box test per slot (`bvh2::BoxRay`) and the
//! scalar watertight triangle test per lane (`primitives::woop`); the walks are `walk.rs`'s,
//! the same as the SIMD kernels', so the visiting order and the leaf arithmetic match theirs.

use super::walk::{Entry, Kernel, Stack, closer, push_farther};
use super::{PACKET, TriPacket, WideNode};
use crate::Hit;
use crate::bvh2::BoxRay;
use crate::primitives::{WoopRay, woop};
use glint_core::Ray;

/// The portable kernel.
pub(super) struct ScalarKernel;

/// A ray's constants for the binary tree's slab test.
pub(super) struct ScalarNodeRay {
    boxes: BoxRay,
    tmin: f32,
}

/// A ray's constants for the scalar watertight test.
pub(super) struct ScalarLeafRay {
    triangles: WoopRay,
    tmin: f32,
}

impl<const N: usize> Kernel<N> for ScalarKernel {
    type NodeRay = ScalarNodeRay;
    type LeafRay = ScalarLeafRay;

    #[inline(always)]
    fn node_ray(ray: &Ray) -> ScalarNodeRay {
        ScalarNodeRay { boxes: BoxRay::new(ray), tmin: ray.tmin }
    }

    #[inline(always)]
    fn leaf_ray(ray: &Ray) -> ScalarLeafRay {
        ScalarLeafRay { triangles: WoopRay::new(ray), tmin: ray.tmin }
    }

    #[inline(always)]
    fn nearest_child(r: &ScalarNodeRay, node: &WideNode<N>, tmax: f32, stack: &mut Stack<Entry>) -> Option<u32> {
        let mut keys = [0u64; N];
        let mut k = 0;
        let mut dist = [0.0f32; N];
        for (slot, d) in dist.iter_mut().enumerate() {
            if let Some(t) = r.boxes.hit(&node.slot_bounds(slot), r.tmin, tmax) {
                *d = t;
                keys[k] = (t.to_bits() as u64) << 32 | slot as u64;
                k += 1;
            }
        }
        if k == 0 {
            return None;
        }
        Some(push_farther(node, &mut keys[..k], &dist, stack))
    }

    #[inline(always)]
    fn any_child(r: &ScalarNodeRay, node: &WideNode<N>, tmax: f32, stack: &mut Stack<u32>) -> Option<u32> {
        // Slots from the last: the children met are visited in slot order (as the SIMD kernel
        // visits them).
        let mut first = None;
        for slot in (0..N).rev() {
            if r.boxes.hit(&node.slot_bounds(slot), r.tmin, tmax).is_some()
                && let Some(later) = first.replace(node.child[slot])
            {
                stack.push(later);
            }
        }
        first
    }

    #[inline(always)]
    fn closest_in_leaf(r: &ScalarLeafRay, packets: &[TriPacket], mut tmax: f32, best: &mut Option<Hit>) -> f32 {
        for p in packets {
            for lane in 0..PACKET {
                let [a, b, c] = p.lane(lane);
                if let Some(h) = woop(&r.triangles, a, b, c, r.tmin, tmax)
                    && closer(h.t, p.prim[lane], best)
                {
                    tmax = h.t;
                    *best = Some(Hit { t: h.t, prim: p.prim[lane], u: h.u, v: h.v });
                }
            }
        }
        tmax
    }

    #[inline(always)]
    fn any_in_leaf(r: &ScalarLeafRay, packets: &[TriPacket], tmax: f32) -> bool {
        for p in packets {
            for lane in 0..PACKET {
                let [a, b, c] = p.lane(lane);
                if woop(&r.triangles, a, b, c, r.tmin, tmax).is_some() {
                    return true;
                }
            }
        }
        false
    }
}
