//! Portable kernels for any width: the oracle of the SIMD kernels and the path on targets
//! without one. Same traversal order and the same leaf arithmetic as the SIMD kernels.

use super::{Entry, LEAF, PACKET, Stack, WideBvh, leaf_packets};
use crate::Hit;
use crate::bvh2::BoxRay;
use crate::primitives::{WoopRay, woop};
use glint_core::Ray;

/// Sorts a few `(distance bits << 32 | slot)` keys ascending (insertion sort: n ≤ 8).
#[inline(always)]
pub(crate) fn sort_keys(keys: &mut [u64]) {
    for i in 1..keys.len() {
        let k = keys[i];
        let mut j = i;
        while j > 0 && keys[j - 1] > k {
            keys[j] = keys[j - 1];
            j -= 1;
        }
        keys[j] = k;
    }
}

pub(super) fn intersect<const N: usize>(bvh: &WideBvh<N>, ray: &Ray) -> Option<Hit> {
    let br = BoxRay::new(ray);
    let wr = WoopRay::new(ray);
    let mut tmax = ray.tmax;
    let mut best = None;
    let mut stack = Stack::<Entry>::new();
    let mut cur = 0u32;
    loop {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let mut keys = [0u64; N];
            let mut k = 0;
            let mut dist = [0.0f32; N];
            for (slot, d) in dist.iter_mut().enumerate() {
                if let Some(t) = br.hit(&node.slot_bounds(slot), ray.tmin, tmax) {
                    *d = t;
                    keys[k] = (t.to_bits() as u64) << 32 | slot as u64;
                    k += 1;
                }
            }
            if k > 0 {
                sort_keys(&mut keys[..k]);
                for &key in keys[1..k].iter().rev() {
                    let slot = key as u32 as usize;
                    stack.push(Entry { child: node.child[slot], t: dist[slot] });
                }
                cur = node.child[keys[0] as u32 as usize];
                continue;
            }
        } else {
            for p in &bvh.packets[leaf_packets(cur)] {
                for lane in 0..PACKET {
                    let [a, b, c] = p.lane(lane);
                    if let Some(h) = woop(&wr, a, b, c, ray.tmin, tmax)
                        && super::closer(h.t, p.prim[lane], &best)
                    {
                        tmax = h.t;
                        best = Some(Hit { t: h.t, prim: p.prim[lane], u: h.u, v: h.v });
                    }
                }
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

pub(super) fn occluded<const N: usize>(bvh: &WideBvh<N>, ray: &Ray) -> bool {
    let br = BoxRay::new(ray);
    let wr = WoopRay::new(ray);
    let mut stack = Stack::<u32>::new();
    stack.push(0);
    while let Some(cur) = stack.pop() {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            for slot in 0..N {
                if br.hit(&node.slot_bounds(slot), ray.tmin, ray.tmax).is_some() {
                    stack.push(node.child[slot]);
                }
            }
        } else {
            for p in &bvh.packets[leaf_packets(cur)] {
                for lane in 0..PACKET {
                    let [a, b, c] = p.lane(lane);
                    if woop(&wr, a, b, c, ray.tmin, ray.tmax).is_some() {
                        return true;
                    }
                }
            }
        }
    }
    false
}
