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
//! is its cost as one leaf, or the least `best(left, j) + best(right, k − j)`. The cut is
//! bound to the fine tree's subtrees, whose upper splits were chosen for a binary tree: a
//! floor's triangles can share a subtree with the bottom face of a block standing on it.
//! [`refine`] then moves single triangles between the leaves while that lowers the cost (a
//! local search, as in k-means: every move lowers the cost, so it ends). `MeshBvh` keeps
//! whichever of the result and the builder's own leaves costs less. Which triangles a ray
//! hits does not change: only which of them it tests.

use crate::build::MAX_LEAF;
use crate::bvh2::{Bvh2, Bvh2Node};
use glint_core::Bounds3;

/// The most leaves a cut may have (the widest node).
const MAX_WIDTH: usize = 8;

/// `Σ half-area · triangles` over the leaves of `bvh` (the walk cost of its one-node
/// collapse, up to a constant).
pub(crate) fn leaf_cost(bvh: &Bvh2) -> f64 {
    bvh.nodes().iter().filter(|n| n.is_leaf()).map(|n| cost_as_leaf(&n.bounds, n.count)).sum()
}

fn cost_as_leaf(bounds: &Bounds3, count: u32) -> f64 {
    f64::from(bounds.half_area()) * f64::from(count)
}

/// The leaves of a one-node tree over the triangles of `fine` (boxes `boxes[prim]`): the best
/// cut of `fine` ([`best_cut`]) refined by single moves ([`refine`]), as a binary tree with
/// its cost; `None` as for [`best_cut`].
pub(crate) fn best_leaves(fine: &Bvh2, boxes: &[Bounds3], width: usize, ct: f32, ci: f32) -> Option<(Bvh2, f64)> {
    let (cut, _) = best_cut(fine, width)?;
    let order = fine.prim_indices();
    let mut groups: Vec<Vec<u32>> =
        cut.iter().map(|l| order[l.first as usize..(l.first + l.count) as usize].to_vec()).collect();
    refine(&mut groups, boxes, width);
    Some(tree_of(&groups, boxes, ct, ci))
}

/// Moves one primitive at a time to the leaf (or a new leaf, while there are fewer than
/// `width`) where `Σ half-area · primitives` falls most, until no move lowers it by more than
/// a millionth (or after a few dozen passes). Deterministic: groups and primitives are
/// visited in order.
pub(crate) fn refine(groups: &mut Vec<Vec<u32>>, boxes: &[Bounds3], width: usize) {
    let bounds = |g: &[u32]| g.iter().fold(Bounds3::EMPTY, |b, &p| b.union(boxes[p as usize]));
    let cost = |b: &Bounds3, n: usize| f64::from(b.half_area()) * n as f64;
    for _pass in 0..64 {
        let mut moved = false;
        let total: f64 = groups.iter().map(|g| cost(&bounds(g), g.len())).sum();
        let eps = total * 1e-6;
        let mut gi = 0;
        while gi < groups.len() {
            let mut ti = 0;
            while ti < groups[gi].len() {
                let p = groups[gi][ti];
                let here = &groups[gi];
                let without: Bounds3 = here
                    .iter()
                    .enumerate()
                    .filter(|&(i, _)| i != ti)
                    .fold(Bounds3::EMPTY, |b, (_, &q)| b.union(boxes[q as usize]));
                let saved = cost(&bounds(here), here.len()) - cost(&without, here.len() - 1);
                // The best place for `p`: another leaf, or a leaf of its own.
                let mut best: Option<(usize, f64)> = None;
                for (hi, h) in groups.iter().enumerate() {
                    if hi == gi || h.len() >= MAX_LEAF {
                        continue;
                    }
                    let hb = bounds(h);
                    let added = cost(&hb.union(boxes[p as usize]), h.len() + 1) - cost(&hb, h.len());
                    if best.is_none_or(|(_, a)| added < a) {
                        best = Some((hi, added));
                    }
                }
                if groups.len() < width && groups[gi].len() > 1 {
                    let added = cost(&boxes[p as usize], 1);
                    if best.is_none_or(|(_, a)| added < a) {
                        best = Some((groups.len(), added));
                    }
                }
                match best {
                    Some((hi, added)) if added - saved < -eps => {
                        groups[gi].remove(ti);
                        if hi == groups.len() {
                            groups.push(vec![p]);
                        } else {
                            groups[hi].push(p);
                        }
                        moved = true;
                    }
                    _ => ti += 1,
                }
            }
            gi += 1;
        }
        groups.retain(|g| !g.is_empty());
        if !moved {
            break;
        }
    }
}

/// A binary tree whose leaves are `groups` (in their order, the primitive order their
/// concatenation), split halfway down the list of groups.
fn tree_of(groups: &[Vec<u32>], boxes: &[Bounds3], ct: f32, ci: f32) -> (Bvh2, f64) {
    fn emit_groups(groups: &[(Bounds3, u32, u32)], out: &mut Vec<Bvh2Node>) -> (Bounds3, usize) {
        if let [(bounds, first, count)] = groups {
            out.push(Bvh2Node { bounds: *bounds, first: *first, count: *count });
            return (*bounds, 1);
        }
        let me = out.len();
        out.push(Bvh2Node { bounds: Bounds3::EMPTY, first: 0, count: 0 });
        let (left, right) = groups.split_at(groups.len() / 2);
        let (lb, dl) = emit_groups(left, out);
        out[me].first = out.len() as u32;
        let (rb, dr) = emit_groups(right, out);
        out[me].bounds = lb.union(rb);
        (out[me].bounds, 1 + dl.max(dr))
    }
    let mut prims = Vec::new();
    let mut leaves = Vec::new();
    let mut cost = 0.0;
    for g in groups {
        let b = g.iter().fold(Bounds3::EMPTY, |b, &p| b.union(boxes[p as usize]));
        leaves.push((b, prims.len() as u32, g.len() as u32));
        cost += cost_as_leaf(&b, g.len() as u32);
        prims.extend_from_slice(g);
    }
    let mut nodes = Vec::new();
    let (_, depth) = emit_groups(&leaves, &mut nodes);
    (Bvh2::from_parts(nodes, prims, depth, ct, ci), cost)
}

/// The cut of `fine` into at most `width` (≤ 8) subtrees of at most [`MAX_LEAF`] primitives
/// each that minimises `Σ half-area · primitives`: the subtrees as leaves (box and run of
/// `fine`'s primitive order), with its cost. `None` when no such cut exists (too many
/// primitives), or when a subtree's primitives are not one run of the order.
pub(crate) fn best_cut(fine: &Bvh2, width: usize) -> Option<(Vec<Bvh2Node>, f64)> {
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
    // The cut's subtrees, read back from the choices made.
    let mut leaves = Vec::new();
    let mut todo = vec![(0usize, width)];
    while let Some((b, k)) = todo.pop() {
        match left_k[b][k] as usize {
            0 => {
                let (first, count) = run[b];
                leaves.push(Bvh2Node { bounds: nodes[b].bounds, first, count });
            }
            j => todo.extend([(nodes[b].first as usize, k - j), (b + 1, j)]),
        }
    }
    Some((leaves, cost))
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
                let Some((cut, cost)) = best_cut(&fine, width) else {
                    // Only where no cut has leaves small enough.
                    assert!(expected.is_infinite(), "round {round}: no cut into {width}, brute force {expected}");
                    continue;
                };
                assert!((cost - expected).abs() <= 1e-9 * expected.max(1.0), "round {round}: {cost} vs {expected}");
                let cut_cost: f64 = cut.iter().map(|l| cost_as_leaf(&l.bounds, l.count)).sum();
                assert!((cut_cost - cost).abs() <= 1e-9 * cost.max(1.0));
                let mut leaves: Vec<(u32, u32)> = cut.iter().map(|l| (l.first, l.count)).collect();
                leaves.sort_unstable();
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
                for n in &cut {
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
    fn refining_never_raises_the_cost_and_keeps_every_primitive_once() {
        for round in 0..30u64 {
            let m = triangle_soup(8 + round as usize * 3, 0.2 + round as f32 * 0.03, 100 + round);
            let boxes: Vec<Bounds3> =
                m.triangles.iter().map(|t| Bounds3::from_points(t.iter().map(|&v| m.positions[v as usize]))).collect();
            let opts = BuildOptions { max_leaf_size: 1, traversal_cost: 0.0, ..BuildOptions::default() };
            let fine = Bvh2::build(&m.positions, &m.triangles, &opts);
            for width in [2usize, 4, 8] {
                let Some((_, cut_cost)) = best_cut(&fine, width) else { continue };
                let (refined, cost) = best_leaves(&fine, &boxes, width, 1.0, 1.0).expect("a cut exists");
                assert!(cost <= cut_cost * (1.0 + 1e-9), "round {round}: {cost} > {cut_cost}");
                assert!((leaf_cost(&refined) - cost).abs() <= 1e-9 * cost.max(1.0));
                let leaves = leaves_of(&refined);
                assert!(leaves.len() <= width && leaves.iter().all(|l| l.1 as usize <= MAX_LEAF));
                let mut prims = refined.prim_indices().to_vec();
                prims.sort_unstable();
                let mut expected = fine.prim_indices().to_vec();
                expected.sort_unstable();
                assert_eq!(prims, expected);
            }
        }
    }

    #[test]
    fn a_room_gets_a_leaf_per_wall_and_one_per_block() {
        // A closed room (two triangles a wall) and two blocks standing on its floor: the best
        // eight leaves are the six walls and the two blocks.
        let mut positions = Vec::new();
        let mut triangles = Vec::new();
        let mut quad = |q: [Vec3; 4]| {
            let i = positions.len() as u32;
            positions.extend(q);
            triangles.extend([[i, i + 1, i + 2], [i, i + 2, i + 3]]);
        };
        let cuboid = |quad: &mut dyn FnMut([Vec3; 4]), lo: Vec3, hi: Vec3| {
            let c = |x: bool, y: bool, z: bool| {
                Vec3::new(if x { hi.x } else { lo.x }, if y { hi.y } else { lo.y }, if z { hi.z } else { lo.z })
            };
            for a in [false, true] {
                quad([c(a, false, false), c(a, true, false), c(a, true, true), c(a, false, true)]);
                quad([c(false, a, false), c(true, a, false), c(true, a, true), c(false, a, true)]);
                quad([c(false, false, a), c(true, false, a), c(true, true, a), c(false, true, a)]);
            }
        };
        cuboid(&mut quad, Vec3::ZERO, Vec3::splat(10.0));
        cuboid(&mut quad, Vec3::new(1.0, 0.0, 1.0), Vec3::new(3.0, 2.0, 3.0));
        cuboid(&mut quad, Vec3::new(6.0, 0.0, 5.0), Vec3::new(8.0, 5.0, 7.0));
        let bvh = crate::MeshBvh::build(
            &positions,
            &triangles,
            &BuildOptions { width: crate::Width::Eight, ..BuildOptions::default() },
        );
        assert_eq!(bvh.stats().nodes, 1);
        let boxes: Vec<Bounds3> =
            triangles.iter().map(|t| Bounds3::from_points(t.iter().map(|&v| positions[v as usize]))).collect();
        let opts = BuildOptions { max_leaf_size: 1, traversal_cost: 0.0, ..BuildOptions::default() };
        let fine = Bvh2::build(&positions, &triangles, &opts);
        let (tree, _) = best_leaves(&fine, &boxes, 8, 1.0, 1.0).expect("a cut exists");
        let mut sizes: Vec<u32> = tree.nodes().iter().filter(|n| n.is_leaf()).map(|n| n.count).collect();
        sizes.sort_unstable();
        assert_eq!(sizes, [2, 2, 2, 2, 2, 2, 12, 12]);
    }

    #[test]
    fn too_many_primitives_for_the_leaves_give_no_cut() {
        let m = triangle_soup(3 * MAX_LEAF, 0.5, 5);
        let opts = BuildOptions { max_leaf_size: 1, traversal_cost: 0.0, ..BuildOptions::default() };
        let fine = Bvh2::build(&m.positions, &m.triangles, &opts);
        assert!(best_cut(&fine, 2).is_none());
        assert!(best_cut(&fine, 4).is_some());
    }
}
