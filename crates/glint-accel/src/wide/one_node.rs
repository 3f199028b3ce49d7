//! The leaves of a tree of one wide node, chosen for the cost of its walks rather than by the
//! builder's leaf rule.
//!
//! A mesh whose binary tree has at most `N` leaves collapses into one `N`-wide node
//! (`WideBvh::from_bvh2`): every ray tests the node's boxes, then the triangles of each leaf
//! whose box it meets. So a walk costs, in expectation, the sum over leaves of the
//! probability that a ray meets the leaf's box times its triangles: by the surface area
//! heuristic (Goldsmith and Salmon 1987; MacDonald and Booth 1990), `Σ area(leaf) ·
//! triangles(leaf)` up to a constant. The builder stops at a block of four triangles whatever
//! their boxes (`build::build_rec`: right for big meshes, where a split costs a node visit),
//! which can make one leaf of a room's floor and ceiling: a box as big as the room, whose
//! triangles every ray tests. Here a split costs a slot of the same node and nothing else.
//!
//! [`best_cut`] finds, on a binary tree built down to single triangles, the cut into at most
//! `N` subtrees (each at most [`MAX_LEAF`] triangles) of least `Σ area · triangles`, by
//! dynamic programming over the tree (the one-node case of the optimal wide collapse of
//! Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on GPUs Through Compressed
//! Wide BVHs", HPG 2017): `best(b, k)`, the least cost of subtree `b` in at most `k` leaves,
//! is its cost as one leaf, or the least `best(left, j) + best(right, k − j)`. `MeshBvh`
//! keeps whichever of that cut and the builder's own leaves costs less. Which triangles a ray
//! hits does not change: only which of them it tests.

use crate::build::MAX_LEAF;
use crate::bvh2::{Bvh2, Bvh2Node};

/// The most leaves a cut may have (the widest node).
const MAX_WIDTH: usize = 8;

/// `Σ half-area · triangles` over the leaves of `bvh` (the walk cost of its one-node
/// collapse, up to a constant).
pub(crate) fn leaf_cost(bvh: &Bvh2) -> f64 {
    bvh.nodes().iter().filter(|n| n.is_leaf()).map(|n| cost_as_leaf(&n.bounds, n.count)).sum()
}

fn cost_as_leaf(bounds: &glint_core::Bounds3, count: u32) -> f64 {
    f64::from(bounds.half_area()) * f64::from(count)
}

/// The cut of `fine` into at most `width` (≤ 8) subtrees of at most [`MAX_LEAF`] primitives
/// each that minimises `Σ half-area · primitives`, as a binary tree whose leaves are those
/// subtrees (the primitive order is `fine`'s), with its cost. `None` when no such cut exists
/// (too many primitives), or when a subtree's primitives are not one run of the order.
pub(crate) fn best_cut(fine: &Bvh2, width: usize, ct: f32, ci: f32) -> Option<(Bvh2, f64)> {
    let nodes = fine.nodes();
    let width = width.min(MAX_WIDTH);
    if nodes.is_empty() || width == 0 {
        return None;
    }
    // Per node: its primitives' run (start, count); `best[k]`, the least cost in at most `k`
    // leaves (index 0 unused); `left_k[k]`, how many of them the left subtree gets (0: the
    // node is one leaf).
    let n = nodes.len();
    let mut run = vec![(0u32, 0u32); n];
    let mut best = vec![[f64::INFINITY; MAX_WIDTH + 1]; n];
    let mut left_k = vec![[0u8; MAX_WIDTH + 1]; n];
    // Pre-order: both children of a node come after it.
    for b in (0..n).rev() {
        let node = &nodes[b];
        let children = (!node.is_leaf()).then(|| (b + 1, node.first as usize));
        run[b] = match children {
            None => (node.first, node.count),
            Some((l, r)) => {
                let ((ls, lc), (rs, rc)) = (run[l], run[r]);
                if rs != ls + lc {
                    return None;
                }
                (ls, lc + rc)
            }
        };
        let count = run[b].1;
        let as_leaf = if count as usize <= MAX_LEAF { cost_as_leaf(&node.bounds, count) } else { f64::INFINITY };
        best[b][1..=width].fill(as_leaf);
        if let Some((l, r)) = children {
            for k in 2..=width {
                for j in 1..k {
                    let c = best[l][j] + best[r][k - j];
                    if c < best[b][k] {
                        best[b][k] = c;
                        left_k[b][k] = j as u8;
                    }
                }
            }
        }
    }
    let cost = best[0][width];
    if !cost.is_finite() {
        return None;
    }
    // The cut's tree, in pre-order, right children's indices patched once known.
    let mut out: Vec<Bvh2Node> = Vec::new();
    let depth = emit(nodes, &run, &left_k, 0, width, &mut out);
    Some((Bvh2::from_parts(out, fine.prim_indices().to_vec(), depth, ct, ci), cost))
}

/// Appends subtree `b` cut into at most `k` leaves (by `left_k`) to `out` in pre-order;
/// returns its depth.
fn emit(
    nodes: &[Bvh2Node],
    run: &[(u32, u32)],
    left_k: &[[u8; MAX_WIDTH + 1]],
    b: usize,
    k: usize,
    out: &mut Vec<Bvh2Node>,
) -> usize {
    let node = &nodes[b];
    let j = left_k[b][k] as usize;
    if j == 0 {
        let (first, count) = run[b];
        out.push(Bvh2Node { bounds: node.bounds, first, count });
        return 1;
    }
    let me = out.len();
    out.push(Bvh2Node { bounds: node.bounds, first: 0, count: 0 });
    let dl = emit(nodes, run, left_k, b + 1, j, out);
    out[me].first = out.len() as u32;
    let dr = emit(nodes, run, left_k, node.first as usize, k - j, out);
    1 + dl.max(dr)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::procedural::triangle_soup;
    use glint_core::Vec3;

    /// Every cut into at most `width` leaves of `fine`, by brute force: the least cost.
    fn brute_force(fine: &Bvh2, b: usize, k: usize) -> f64 {
        let node = &fine.nodes()[b];
        let count = subtree_count(fine, b);
        let mut best = if count as usize <= MAX_LEAF { cost_as_leaf(&node.bounds, count) } else { f64::INFINITY };
        if !node.is_leaf() {
            for j in 1..k {
                best = best.min(brute_force(fine, b + 1, j) + brute_force(fine, node.first as usize, k - j));
            }
        }
        best
    }

    fn subtree_count(fine: &Bvh2, b: usize) -> u32 {
        let node = &fine.nodes()[b];
        if node.is_leaf() { node.count } else { subtree_count(fine, b + 1) + subtree_count(fine, node.first as usize) }
    }

    fn leaves_of(bvh: &Bvh2) -> Vec<(u32, u32)> {
        let mut v: Vec<_> = bvh.nodes().iter().filter(|n| n.is_leaf()).map(|n| (n.first, n.count)).collect();
        v.sort_unstable();
        v
    }

    #[test]
    fn the_cut_is_the_cheapest_and_covers_every_primitive_once() {
        for round in 0..30 {
            let m = triangle_soup(6 + round * 2, 0.3 + round as f32 * 0.05, round as u64);
            let opts = BuildOptions { max_leaf_size: 1, traversal_cost: 0.0, ..BuildOptions::default() };
            let fine = Bvh2::build(&m.positions, &m.triangles, &opts);
            for width in [2usize, 4, 8] {
                let expected = brute_force(&fine, 0, width);
                let Some((cut, cost)) = best_cut(&fine, width, 1.0, 1.0) else {
                    // Only where no cut has leaves small enough.
                    assert!(expected.is_infinite(), "round {round}: no cut into {width}, brute force {expected}");
                    continue;
                };
                assert!((cost - expected).abs() <= 1e-9 * expected.max(1.0), "round {round}: {cost} vs {expected}");
                assert!((leaf_cost(&cut) - cost).abs() <= 1e-9 * cost.max(1.0));
                let leaves = leaves_of(&cut);
                assert!(leaves.len() <= width);
                // The leaves' runs tile the primitive order.
                let mut next = 0;
                for (first, count) in leaves {
                    assert_eq!(first, next);
                    assert!(count as usize <= MAX_LEAF);
                    next += count;
                }
                assert_eq!(next as usize, fine.prim_indices().len());
                // Every box holds its leaf's triangles.
                for n in cut.nodes().iter().filter(|n| n.is_leaf()) {
                    for &p in &fine.prim_indices()[n.first as usize..(n.first + n.count) as usize] {
                        for &v in &m.triangles[p as usize] {
                            let q: Vec3 = m.positions[v as usize];
                            assert!(n.bounds.min.cmple(q).all() && q.cmple(n.bounds.max).all());
                        }
                    }
                }
            }
        }
    }

    #[test]
    fn too_many_primitives_for_the_leaves_give_no_cut() {
        let m = triangle_soup(3 * MAX_LEAF, 0.5, 5);
        let opts = BuildOptions { max_leaf_size: 1, traversal_cost: 0.0, ..BuildOptions::default() };
        let fine = Bvh2::build(&m.positions, &m.triangles, &opts);
        assert!(best_cut(&fine, 2, 1.0, 1.0).is_none());
        assert!(best_cut(&fine, 4, 1.0, 1.0).is_some());
    }
}
