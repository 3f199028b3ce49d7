//! The two walks of a wide BVH, closest hit and any hit, written once for every kernel; and the
//! traversal state they share with the binary tree's walks (`bvh2.rs`): the stack, its
//! entries, the visiting order and the rule between equally near hits.
//!
//! A kernel ([`Kernel`]) brings the per-ray tests: which children of a node the ray meets, and
//! which triangles of a leaf it hits. The portable kernel (`scalar.rs`) and the SIMD kernel
//! (`traverse.rs`, instantiated per ISA by `sse.rs` and `avx2.rs`) implement it. The walks and
//! the kernels' methods are `#[inline(always)]`: each kernel's entry point compiles into one
//! loop with its own tests inside it (no call per node, and within the ISA's target features).
//!
//! Closest hit: children met by the ray are visited nearest entry first (keys
//! `entry-distance bits << 32 | slot`, sorted by insertion), the farther ones pushed with their
//! entry distance and skipped when popped behind the current hit. Any hit: no ordering, first
//! hit returns.
//!
//! `Kernel`, `Stack` and `Entry` are `pub` in this private module only because the public
//! queries are bounded by `dispatch::Kernels`, whose signatures name them (see `dispatch.rs`).

use super::{LEAF, TriPacket, WideBvh, WideNode, leaf_packets};
use crate::Hit;
use glint_core::Ray;
use std::mem::MaybeUninit;

/// The per-ray tests of one kernel, for nodes of `N` children. A ray's constants are split as
/// the tests use them (node test, triangle test), so that each walk keeps them in registers.
pub trait Kernel<const N: usize> {
    /// A ray's constants for the node test (reciprocals, splatted origin, `tmin`).
    type NodeRay;
    /// A ray's constants for the triangle test (shear, `tmin`).
    type LeafRay;
    fn node_ray(ray: &Ray) -> Self::NodeRay;
    fn leaf_ray(ray: &Ray) -> Self::LeafRay;
    /// The children of `node` the ray meets before `tmax`, nearest first: pushes all but the
    /// nearest onto `stack` ([`push_farther`]) and returns the nearest; `None` when it meets
    /// none.
    fn nearest_child(r: &Self::NodeRay, node: &WideNode<N>, tmax: f32, stack: &mut Stack<Entry>) -> Option<u32>;
    /// A child of `node` the ray meets before `tmax`, the others it meets pushed onto `stack`;
    /// `None` when it meets none.
    fn any_child(r: &Self::NodeRay, node: &WideNode<N>, tmax: f32, stack: &mut Stack<u32>) -> Option<u32>;
    /// Tests a leaf's packets for hits nearer than `tmax`, updates `best` (by [`closer`]) and
    /// returns the new `tmax`.
    fn closest_in_leaf(r: &Self::LeafRay, packets: &[TriPacket], tmax: f32, best: &mut Option<Hit>) -> f32;
    /// Whether the ray hits a triangle of a leaf's packets before `tmax`.
    fn any_in_leaf(r: &Self::LeafRay, packets: &[TriPacket], tmax: f32) -> bool;
}

/// Closest hit. The tree is not empty and the ray is traceable.
#[inline(always)]
pub(super) fn closest<const N: usize, K: Kernel<N>>(bvh: &WideBvh<N>, ray: &Ray) -> Option<Hit> {
    let node_ray = K::node_ray(ray);
    let leaf_ray = K::leaf_ray(ray);
    let mut tmax = ray.tmax;
    let mut best = None;
    let mut stack = Stack::<Entry>::new();
    let mut cur = 0u32;
    loop {
        if cur & LEAF == 0 {
            if let Some(child) = K::nearest_child(&node_ray, &bvh.nodes[cur as usize], tmax, &mut stack) {
                cur = child;
                continue;
            }
        } else {
            tmax = K::closest_in_leaf(&leaf_ray, &bvh.packets[leaf_packets(cur)], tmax, &mut best);
        }
        match stack.pop_within(tmax) {
            Some(child) => cur = child,
            None => return best,
        }
    }
}

/// Any hit. The tree is not empty and the ray is traceable.
#[inline(always)]
pub(super) fn occluded<const N: usize, K: Kernel<N>>(bvh: &WideBvh<N>, ray: &Ray) -> bool {
    let node_ray = K::node_ray(ray);
    let leaf_ray = K::leaf_ray(ray);
    let tmax = ray.tmax;
    let mut stack = Stack::<u32>::new();
    let mut cur = 0u32;
    loop {
        // The next node: a child the ray meets, else the top of the stack.
        let child = if cur & LEAF == 0 {
            K::any_child(&node_ray, &bvh.nodes[cur as usize], tmax, &mut stack)
        } else if K::any_in_leaf(&leaf_ray, &bvh.packets[leaf_packets(cur)], tmax) {
            return true;
        } else {
            None
        };
        cur = match child {
            Some(child) => child,
            None => match stack.pop() {
                Some(next) => next,
                None => return false,
            },
        };
    }
}

/// The children of a node a ray (or a packet) meets, nearest first: bit `i` of `mask` (not 0)
/// marks child `i`, `d[i]` its entry distance. Returns the nearest child's slot and hands the
/// others to `push` farthest first (so that they pop nearest first), in the order of the keys
/// `(entry distance bits, slot)` that [`push_farther`] sorts. Incoherent rays meet one, two
/// or three children at most nodes: one goes straight down, two take one comparison, three a
/// branch-free network of three compare-exchanges; more take the insertion sort.
#[inline(always)]
pub(crate) fn order_children<const N: usize>(mask: u32, d: &[f32; N], mut push: impl FnMut(usize)) -> usize {
    let key = |i: usize| (d[i].to_bits() as u64) << 32 | i as u64;
    let first = mask.trailing_zeros() as usize % N;
    let rest = mask & mask.wrapping_sub(1);
    if rest == 0 {
        return first;
    }
    let second = rest.trailing_zeros() as usize % N;
    let last = rest & (rest - 1);
    if last == 0 {
        let (near, far) = if key(second) < key(first) { (second, first) } else { (first, second) };
        push(far);
        return near;
    }
    if last & (last - 1) == 0 {
        let (a, b, c) = (key(first), key(second), key(last.trailing_zeros() as usize % N));
        let (a, b) = (a.min(b), a.max(b));
        let (b, c) = (b.min(c), b.max(c));
        let (a, b) = (a.min(b), a.max(b));
        push(c as usize % N);
        push(b as usize % N);
        return a as usize % N;
    }
    let mut keys = [0u64; N];
    let mut k = 0;
    let mut m = mask;
    while m != 0 {
        keys[k % N] = key(m.trailing_zeros() as usize % N);
        k += 1;
        m &= m - 1;
    }
    let keys = &mut keys[..k.min(N)];
    sort_keys(keys);
    for &key in keys[1..].iter().rev() {
        push(key as usize % N);
    }
    keys[0] as usize % N
}

/// Sorts the keys of the children a ray meets (`entry distance bits << 32 | slot`), pushes all
/// but the nearest onto `stack` farthest first (so that they pop nearest first), each with its
/// entry distance `dist[slot]`, and returns the nearest child.
#[inline(always)]
pub(crate) fn push_farther<const N: usize>(
    node: &WideNode<N>,
    keys: &mut [u64],
    dist: &[f32; N],
    stack: &mut Stack<Entry>,
) -> u32 {
    sort_keys(keys);
    for &key in keys[1..].iter().rev() {
        let slot = key as usize % N;
        stack.push(Entry { child: node.child[slot], t: dist[slot] });
    }
    node.child[keys[0] as usize % N]
}

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

/// Traversal stack: a fixed array for the common case, spilling to the heap for deep trees, so
/// no tree depth can overflow it. The array is not initialised (a walk that pushes a few
/// entries would otherwise first clear all of them: 384 bytes per single ray, 1.9 KB per
/// packet, 5 % of a packet query).
pub struct Stack<T: Copy> {
    fixed: [MaybeUninit<T>; STACK_FIXED],
    len: usize,
    spill: Vec<T>,
}
const STACK_FIXED: usize = 48;

impl<T: Copy> Stack<T> {
    #[inline(always)]
    pub fn new() -> Self {
        Self { fixed: [const { MaybeUninit::uninit() }; STACK_FIXED], len: 0, spill: Vec::new() }
    }
    #[inline(always)]
    pub fn push(&mut self, v: T) {
        if self.len < STACK_FIXED {
            self.fixed[self.len].write(v);
        } else {
            self.spill.push(v);
        }
        self.len += 1;
    }
    #[inline(always)]
    pub fn pop(&mut self) -> Option<T> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        if self.len < STACK_FIXED {
            // SAFETY: invariant: every slot below `min(len, STACK_FIXED)` holds a value, since
            // `push` writes slot `len` before raising `len` past it and only `pop` lowers `len`
            // (test `the_stack_returns_what_was_pushed_across_the_spill`).
            Some(unsafe { self.fixed[self.len].assume_init() })
        } else {
            self.spill.pop()
        }
    }
}

impl Stack<Entry> {
    /// The child of the topmost entry not behind `tmax` (entries behind it were pushed before
    /// a nearer hit was found, and are dropped); `None` when the stack runs out.
    #[inline(always)]
    pub fn pop_within(&mut self, tmax: f32) -> Option<u32> {
        loop {
            match self.pop() {
                None => return None,
                Some(e) if e.t <= tmax => return Some(e.child),
                Some(_) => {}
            }
        }
    }
}

/// A stack entry of the closest-hit walks: a child reference and its entry distance.
#[derive(Clone, Copy, Default)]
pub struct Entry {
    pub child: u32,
    pub t: f32,
}

/// Whether a candidate hit at `t` (already known to be within the current `tmax`) replaces
/// `best`: a nearer one does, and among equally near ones the lowest primitive index (the
/// brute-force oracle's rule). This makes the closest hit independent of the order in which
/// leaves are visited, so the packet kernels return what the single-ray kernels return.
#[inline(always)]
pub(crate) fn closer(t: f32, prim: u32, best: &Option<Hit>) -> bool {
    best.is_none_or(|b| t < b.t || (t == b.t && prim < b.prim))
}

#[cfg(test)]
mod tests {
    use super::{Stack, order_children, sort_keys};
    use crate::procedural::Rng;

    #[test]
    fn children_come_in_the_order_of_the_sorted_keys() {
        let mut rng = Rng::new(3);
        for round in 0..40 {
            // Distances from a few values, so that ties (broken by slot) are common.
            let d: [f32; 8] = std::array::from_fn(|_| (rng.next_f32() * 4.0).floor() + round as f32);
            for mask in 1u32..256 {
                let mut keys: Vec<u64> =
                    (0..8).filter(|i| mask >> i & 1 == 1).map(|i| (d[i].to_bits() as u64) << 32 | i as u64).collect();
                sort_keys(&mut keys);
                let expected: Vec<usize> = keys.iter().map(|k| (*k % 8) as usize).collect();
                let mut pushed = Vec::new();
                let near = order_children(mask, &d, |slot| pushed.push(slot));
                // The stack pops the pushed children last first.
                let order: Vec<usize> = std::iter::once(near).chain(pushed.into_iter().rev()).collect();
                assert_eq!(order, expected, "mask {mask:08b}, distances {d:?}");
            }
        }
    }

    #[test]
    fn the_stack_returns_what_was_pushed_across_the_spill() {
        let mut s = Stack::<u64>::new();
        assert_eq!(s.pop(), None);
        // Up and down across the fixed part's end, twice, with pops in between.
        for round in 0..2u64 {
            for i in 0..120 {
                s.push(round * 1000 + i);
                if i % 7 == 3 {
                    assert_eq!(s.pop(), Some(round * 1000 + i));
                    s.push(round * 1000 + i);
                }
            }
            for i in (0..120).rev() {
                assert_eq!(s.pop(), Some(round * 1000 + i));
            }
            assert_eq!(s.pop(), None);
        }
    }
}
