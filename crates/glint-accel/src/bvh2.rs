//! The canonical binary BVH: what the builder produces and what the wide layouts are collapsed
//! from. Kept public as a readable layout with its own scalar traversal, which the tests use as a
//! second oracle beside brute force.
//!
//! Nodes are in pre-order: an inner node's left child is the next node, its right child is
//! `first`. A leaf holds `count ≥ 1` primitives `prim_indices[first..first + count]`.
//!
//! Box test: slabs with an exact reciprocal direction (Ize, "Robust BVH Ray Traversal", JCGT
//! 2(2), 2013), the far distance enlarged so that rounding never culls a box the ray touches:
//! its reciprocal is scaled by [`FAR_SCALE`] ahead of time ([`BoxRay::inv_far`]), which takes a
//! multiply off every box test's critical path. A NaN slab distance (origin on a slab plane of
//! an axis the ray runs parallel to) is ignored, which keeps that slab open.

use crate::primitives::{WoopRay, woop};
use crate::wide::{Entry, Stack};
use crate::{Hit, fetch_triangle};
use glint_core::float::gamma;
use glint_core::{Bounds3, Ray, Vec3};

/// One node of the binary BVH (32 bytes).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bvh2Node {
    pub bounds: Bounds3,
    /// Leaf: first index into the primitive order; inner: index of the right child.
    pub first: u32,
    /// Leaf: number of primitives; inner: 0.
    pub count: u32,
}
const _: () = assert!(size_of::<Bvh2Node>() == 32);

impl Bvh2Node {
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// Binary BVH: nodes in pre-order and the primitive order its leaves index into.
#[derive(Clone, Debug, PartialEq)]
pub struct Bvh2 {
    nodes: Vec<Bvh2Node>,
    prims: Vec<u32>,
    depth: usize,
    sah_cost: f32,
}

/// `1 + 2γ(4)`: the factor on the reciprocal of the far slab distances (Ize 2013 scales the far
/// distance itself by `1 + 2γ(3)`). An entry distance `fl(fl(b − o) · inv)` has three roundings
/// (the reciprocal's included), so it is at most `t_near (1 + γ(3))`; an exit distance
/// `fl(fl(b − o) · fl(inv · F))` has four, so it is at least `t_far F (1 − γ(4))`. A box the
/// ray meets (`0 ≤ t_near ≤ t_far`) passes `entry ≤ exit` whenever `F (1 − γ(4)) ≥ 1 + γ(3)`,
/// which `F = 1 + 2γ(4)` meets with room to spare (`γ(4) − γ(3) ≈ ε/2 ≫ 2γ(4)²`), also as the
/// f32 `1 + 2⁻²¹` it rounds to. Scaled this way, the far planes' distances come out of the same
/// subtract and multiply as the near planes', and no multiply follows the `min` chain.
pub(crate) const FAR_SCALE: f32 = 1.0 + 2.0 * gamma(4);

/// Per-ray constants of the slab test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxRay {
    pub org: Vec3,
    pub inv: Vec3,
    /// `inv · FAR_SCALE`: the far planes' reciprocal.
    pub inv_far: Vec3,
    /// Per axis: the direction's sign bit is set, so the near slab plane is the box's max.
    pub neg: [bool; 3],
}

impl BoxRay {
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        // Exact division, no approximate reciprocal (Ize 2013, section 3).
        let d = ray.dir;
        let inv = Vec3::ONE / d;
        Self {
            org: ray.origin,
            inv,
            inv_far: inv * FAR_SCALE,
            neg: [d.x.is_sign_negative(), d.y.is_sign_negative(), d.z.is_sign_negative()],
        }
    }

    /// Entry distance if the ray meets `b` within `[tmin, tmax]`.
    #[inline]
    pub fn hit(&self, b: &Bounds3, tmin: f32, tmax: f32) -> Option<f32> {
        // Near and far planes by the direction's sign, not by min/max of the two distances, so
        // that a NaN (origin on a plane of an axis the ray is parallel to) survives to the
        // reductions below, where f32::max/min drop it: that slab stays open.
        let plane = |a: usize, far: bool| if self.neg[a] ^ far { b.max[a] } else { b.min[a] };
        let near = |a: usize| (plane(a, false) - self.org[a]) * self.inv[a];
        let far = |a: usize| (plane(a, true) - self.org[a]) * self.inv_far[a];
        let tn = tmin.max(near(0)).max(near(1)).max(near(2));
        let tf = tmax.min(far(0)).min(far(1)).min(far(2));
        (tn <= tf).then_some(tn)
    }
}

/// Rays that can hit anything: finite origin and direction, non-zero direction, ordered interval.
#[inline]
pub(crate) fn ray_is_traceable(ray: &Ray) -> bool {
    ray.origin.is_finite()
        && ray.dir.is_finite()
        && ray.dir != Vec3::ZERO
        && !ray.tmin.is_nan()
        && !ray.tmax.is_nan()
        && ray.tmin <= ray.tmax
}

impl Bvh2 {
    pub(crate) fn empty() -> Self {
        Self { nodes: Vec::new(), prims: Vec::new(), depth: 0, sah_cost: 0.0 }
    }

    pub(crate) fn from_parts(nodes: Vec<Bvh2Node>, prims: Vec<u32>, depth: usize, ct: f32, ci: f32) -> Self {
        let mut bvh = Self { nodes, prims, depth, sah_cost: 0.0 };
        bvh.sah_cost = bvh.compute_sah_cost(ct, ci);
        bvh
    }

    /// Builds over triangles (`prim` = index into `triangles`). Triangles with an out-of-range
    /// index or a non-finite vertex are left out: they are never hit.
    pub fn build(positions: &[Vec3], triangles: &[[u32; 3]], options: &crate::BuildOptions) -> Self {
        crate::build::build_bvh2_triangles(positions, triangles, options)
    }

    /// Builds over arbitrary primitive boxes (`prim` = index into `boxes`); empty or non-finite
    /// boxes are left out.
    pub fn build_from_boxes(boxes: &[Bounds3], options: &crate::BuildOptions) -> Self {
        crate::build::build_bvh2(boxes, options)
    }

    pub fn nodes(&self) -> &[Bvh2Node] {
        &self.nodes
    }

    /// Primitive ids in leaf order.
    pub fn prim_indices(&self) -> &[u32] {
        &self.prims
    }

    pub fn depth(&self) -> usize {
        self.depth
    }

    pub fn bounds(&self) -> Bounds3 {
        self.nodes.first().map_or(Bounds3::EMPTY, |n| n.bounds)
    }

    /// SAH cost relative to the root area: `Σ_inner A/A_root C_trav + Σ_leaf A/A_root ⌈n/4⌉ C_isect`
    /// (leaves are intersected in packets of 4).
    pub fn sah_cost(&self) -> f32 {
        self.sah_cost
    }

    pub(crate) fn compute_sah_cost(&self, ct: f32, ci: f32) -> f32 {
        let root = self.bounds().half_area();
        if root <= 0.0 {
            return 0.0;
        }
        let mut cost = 0.0f64;
        for n in &self.nodes {
            let a = (n.bounds.half_area() / root) as f64;
            cost += if n.is_leaf() { a * n.count.div_ceil(4) as f64 * ci as f64 } else { a * ct as f64 };
        }
        cost as f32
    }

    pub fn leaf_count(&self) -> usize {
        self.nodes.iter().filter(|n| n.is_leaf()).count()
    }

    /// Closest-hit traversal with a caller-supplied leaf test: `leaf(prim, tmax)` returns the
    /// distance of a hit closer than `tmax`, which then shrinks the ray. Children are visited
    /// nearest entry first; stack-based.
    pub fn traverse_closest(&self, ray: &Ray, mut leaf: impl FnMut(u32, f32) -> Option<f32>) {
        if self.nodes.is_empty() || !ray_is_traceable(ray) {
            return;
        }
        let br = BoxRay::new(ray);
        let mut tmax = ray.tmax;
        if br.hit(&self.nodes[0].bounds, ray.tmin, tmax).is_none() {
            return;
        }
        let mut stack = Stack::<Entry>::new();
        let mut cur = 0usize;
        loop {
            let node = &self.nodes[cur];
            if node.is_leaf() {
                for &p in &self.prims[node.first as usize..(node.first + node.count) as usize] {
                    if let Some(t) = leaf(p, tmax) {
                        tmax = tmax.min(t);
                    }
                }
            } else {
                let (l, r) = (cur + 1, node.first as usize);
                let hl = br.hit(&self.nodes[l].bounds, ray.tmin, tmax);
                let hr = br.hit(&self.nodes[r].bounds, ray.tmin, tmax);
                match (hl, hr) {
                    (Some(a), Some(b)) => {
                        let (near, far, tf) = if a <= b { (l, r, b) } else { (r, l, a) };
                        stack.push(Entry { child: far as u32, t: tf });
                        cur = near;
                        continue;
                    }
                    (Some(_), None) => {
                        cur = l;
                        continue;
                    }
                    (None, Some(_)) => {
                        cur = r;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            match stack.pop_within(tmax) {
                Some(child) => cur = child as usize,
                None => return,
            }
        }
    }

    /// Any-hit traversal: stops as soon as `leaf(prim)` returns true.
    pub fn traverse_any(&self, ray: &Ray, mut leaf: impl FnMut(u32) -> bool) -> bool {
        if self.nodes.is_empty() || !ray_is_traceable(ray) {
            return false;
        }
        let br = BoxRay::new(ray);
        let mut stack = Stack::<u32>::new();
        stack.push(0);
        while let Some(i) = stack.pop() {
            let node = &self.nodes[i as usize];
            if br.hit(&node.bounds, ray.tmin, ray.tmax).is_none() {
                continue;
            }
            if node.is_leaf() {
                for &p in &self.prims[node.first as usize..(node.first + node.count) as usize] {
                    if leaf(p) {
                        return true;
                    }
                }
            } else {
                stack.push(node.first);
                stack.push(i + 1);
            }
        }
        false
    }

    /// Closest triangle hit; `positions`/`triangles` must be the ones the BVH was built over.
    pub fn intersect(&self, positions: &[Vec3], triangles: &[[u32; 3]], ray: &Ray) -> Option<Hit> {
        let wr = WoopRay::new(ray);
        let mut best: Option<Hit> = None;
        self.traverse_closest(ray, |p, tmax| {
            let [a, b, c] = fetch_triangle(positions, triangles, p)?;
            let h = woop(&wr, a, b, c, ray.tmin, tmax)?;
            best = Some(Hit { t: h.t, prim: p, u: h.u, v: h.v });
            Some(h.t)
        });
        best
    }

    /// Any triangle hit in `(tmin, tmax]`.
    pub fn occluded(&self, positions: &[Vec3], triangles: &[[u32; 3]], ray: &Ray) -> bool {
        let wr = WoopRay::new(ray);
        self.traverse_any(ray, |p| {
            fetch_triangle(positions, triangles, p)
                .is_some_and(|[a, b, c]| woop(&wr, a, b, c, ray.tmin, ray.tmax).is_some())
        })
    }

    /// Recomputes every box bottom-up from new primitive boxes (same primitives).
    pub fn refit(&mut self, prim_box: impl Fn(u32) -> Bounds3) {
        for i in (0..self.nodes.len()).rev() {
            let n = self.nodes[i];
            let b = if n.is_leaf() {
                self.prims[n.first as usize..(n.first + n.count) as usize]
                    .iter()
                    .fold(Bounds3::EMPTY, |b, &p| b.union(prim_box(p)))
            } else {
                self.nodes[i + 1].bounds.union(self.nodes[n.first as usize].bounds)
            };
            self.nodes[i].bounds = b;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn box_test_is_conservative_on_faces_and_parallel_rays() {
        let b = Bounds3::new(Vec3::ZERO, Vec3::ONE);
        // Parallel to x, origin on the y = 0 slab plane: touches the face.
        let r = Ray::new(Vec3::new(-1.0, 0.0, 0.5), Vec3::X);
        assert!(BoxRay::new(&r).hit(&b, r.tmin, r.tmax).is_some());
        // Parallel, outside.
        let r = Ray::new(Vec3::new(-1.0, -0.1, 0.5), Vec3::X);
        assert!(BoxRay::new(&r).hit(&b, r.tmin, r.tmax).is_none());
        // Negative zero direction components.
        let r = Ray::new(Vec3::new(0.5, 0.5, 2.0), Vec3::new(-0.0, -0.0, -1.0));
        assert_eq!(BoxRay::new(&r).hit(&b, r.tmin, r.tmax), Some(1.0));
        // Origin inside: entry at tmin.
        let r = Ray::new(Vec3::splat(0.5), Vec3::new(0.3, -0.2, 0.1));
        assert_eq!(BoxRay::new(&r).hit(&b, r.tmin, r.tmax), Some(0.0));
        // tmax before the box.
        let r = Ray::segment(Vec3::new(0.5, 0.5, 2.0), -Vec3::Z, 0.0, 0.5);
        assert!(BoxRay::new(&r).hit(&b, r.tmin, r.tmax).is_none());
        // Flat box (a triangle in the z = 0 plane).
        let flat = Bounds3::new(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0));
        let r = Ray::new(Vec3::new(0.5, 0.5, 2.0), -Vec3::Z);
        assert_eq!(BoxRay::new(&r).hit(&flat, r.tmin, r.tmax), Some(2.0));
    }
}
