//! Binned SAH builder → canonical binary BVH ([`Bvh2`]).
//!
//! Top-down, binned surface area heuristic on centroid bounds (Wald, "On fast Construction of
//! SAH-based Bounding Volume Hierarchies", IEEE RT 2007): each node's primitives are sorted into
//! `bins` equal slices of the centroid box along each axis, the SAH cost
//! `C_trav + C_isect (A_l N_l + A_r N_r) / A` of every bin boundary is swept in O(bins), and the
//! primitives are partitioned in place. Subtrees above a size threshold are built in parallel with
//! `rayon::join`, binning of big nodes is split over chunks.
//!
//! Deterministic whatever the thread count: every reduction is exact (min/max of boxes, integer
//! counts), partitions run sequentially, and each subtree of `n` primitives writes into a fixed
//! slot range of `2n − 1` nodes (pre-order with gaps), compacted afterwards in index order.
//!
//! Degenerate inputs never recurse forever: when all centroids coincide, or past a depth limit,
//! the node is split in the middle by count (after ordering by centroid when they differ).
//!
//! Knows nothing about triangles: it takes one box per primitive (the mesh and instance BVHs
//! supply them) and drops boxes that are empty or not finite — those primitives are never hit.

use crate::bvh2::{Bvh2, Bvh2Node};
use glint_core::{Bounds3, Vec3, Vec3A};
use rayon::prelude::*;

/// Builder settings.
#[derive(Clone, Debug, PartialEq)]
pub struct BuildOptions {
    /// Largest leaf (clamped to 1..=32). Leaves are made smaller when the SAH says so.
    pub max_leaf_size: usize,
    /// SAH bins per axis (clamped to 2..=32).
    pub bins: usize,
    /// SAH cost of visiting an inner node, relative to `intersection_cost`.
    pub traversal_cost: f32,
    /// SAH cost of one primitive test.
    pub intersection_cost: f32,
    /// Subtrees with more primitives than this are built with `rayon::join`.
    pub parallel_threshold: usize,
    /// Node width of [`crate::MeshBvh`].
    pub width: Width,
}

/// Node width of the wide layout.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Width {
    /// The measured-fastest width for the machine's instruction set (see `BENCH_NOTES.md`).
    Auto,
    Four,
    Eight,
}

impl Width {
    pub fn preferred(isa: crate::wide::Isa) -> Width {
        match isa {
            crate::wide::Isa::Avx2 => Width::Eight,
            _ => Width::Four,
        }
    }
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            max_leaf_size: 8,
            bins: 16,
            traversal_cost: 1.0,
            intersection_cost: 1.0,
            parallel_threshold: 8192,
            width: Width::Auto,
        }
    }
}

pub(crate) const MAX_BINS: usize = 32;
pub(crate) const MAX_LEAF: usize = 32;
/// Past this depth the builder splits by count, which bounds the depth by `64 + log2(n)`.
const SAH_DEPTH_LIMIT: u32 = 64;
/// Nodes with more primitives than this bin their primitives in parallel chunks.
const PARALLEL_BINNING: usize = 1 << 16;
const BIN_CHUNK: usize = 1 << 14;

/// One primitive as the builder sees it: its box and its index in the caller's input.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct PrimRef {
    min: Vec3,
    id: u32,
    max: Vec3,
    _pad: u32,
}
const _: () = assert!(size_of::<PrimRef>() == 32);

impl PrimRef {
    /// Twice the centroid (saves a multiply; the bins are scaled accordingly).
    #[inline]
    fn centroid2(&self) -> Vec3A {
        Vec3A::from(self.min) + Vec3A::from(self.max)
    }
}

/// A slot of the gapped pre-order node array during the build.
#[derive(Clone, Copy, Debug)]
struct Slot {
    bounds: Bounds3,
    /// Leaf: first primitive; inner: slot index of the right child (left is the next slot).
    first: u32,
    /// Leaf: primitive count (≥ 1); inner: 0; unused slot: `u32::MAX`.
    count: u32,
}
const UNUSED: u32 = u32::MAX;

#[derive(Clone, Copy)]
struct Settings {
    max_leaf: usize,
    bins: usize,
    ct: f32,
    ci: f32,
    par: usize,
}

/// Bins of one axis: box (as SIMD min/max) and count.
#[derive(Clone, Copy)]
struct Bins {
    min: [[Vec3A; MAX_BINS]; 3],
    max: [[Vec3A; MAX_BINS]; 3],
    count: [[u32; MAX_BINS]; 3],
}

impl Bins {
    fn new() -> Self {
        Self {
            min: [[Vec3A::INFINITY; MAX_BINS]; 3],
            max: [[Vec3A::NEG_INFINITY; MAX_BINS]; 3],
            count: [[0; MAX_BINS]; 3],
        }
    }
    fn merge(mut self, o: &Bins) -> Self {
        for a in 0..3 {
            for b in 0..MAX_BINS {
                self.min[a][b] = self.min[a][b].min(o.min[a][b]);
                self.max[a][b] = self.max[a][b].max(o.max[a][b]);
                self.count[a][b] += o.count[a][b];
            }
        }
        self
    }
}

/// Maps twice-centroids to bin indices along all three axes.
#[derive(Clone, Copy)]
struct BinMap {
    base: Vec3A,
    scale: Vec3A,
    last: f32,
}

impl BinMap {
    fn new(cbounds: &Bounds3, bins: usize) -> Self {
        let base = Vec3A::from(cbounds.min) * 2.0;
        let ext = (Vec3A::from(cbounds.max) * 2.0 - base).max(Vec3A::ZERO);
        // Slightly less than bins / extent so that the maximum maps inside the last bin.
        let k = bins as f32 * (1.0 - 1e-6);
        let scale = Vec3A::select(ext.cmpgt(Vec3A::ZERO), Vec3A::splat(k) / ext, Vec3A::ZERO);
        Self { base, scale, last: (bins - 1) as f32 }
    }
    #[inline]
    fn bins_of(&self, c2: Vec3A) -> [usize; 3] {
        // Clamped to [0, last], then rounded with the 1.5·2^23 trick (adding it leaves
        // round(x) in the low mantissa bits): no saturating float→int conversion in the hot
        // loop. round(b − 0.5) stays in [0, last]. Binning and partitioning call this same
        // function, so they always agree.
        let b = ((c2 - self.base) * self.scale).max(Vec3A::ZERO).min(Vec3A::splat(self.last));
        let r = (b - Vec3A::splat(0.5)) + Vec3A::splat(12_582_912.0);
        let idx = |x: f32| ((x.to_bits() & 0x7f_ffff).wrapping_sub(0x40_0000) as usize) % MAX_BINS;
        [idx(r.x), idx(r.y), idx(r.z)]
    }
}

fn bin_slice(refs: &[PrimRef], map: &BinMap) -> Bins {
    let mut bins = Bins::new();
    for r in refs {
        let (lo, hi) = (Vec3A::from(r.min), Vec3A::from(r.max));
        let b = map.bins_of(lo + hi);
        for (a, &i) in b.iter().enumerate() {
            bins.min[a][i] = bins.min[a][i].min(lo);
            bins.max[a][i] = bins.max[a][i].max(hi);
            bins.count[a][i] += 1;
        }
    }
    bins
}

fn area(min: Vec3A, max: Vec3A) -> f32 {
    let e = (max - min).max(Vec3A::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

/// Bounds and centroid bounds of a slice (used after count splits).
fn bounds_of(refs: &[PrimRef]) -> (Bounds3, Bounds3) {
    let mut b = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let mut c = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for r in refs {
        let (lo, hi) = (Vec3A::from(r.min), Vec3A::from(r.max));
        b = (b.0.min(lo), b.1.max(hi));
        let c2 = (lo + hi) * 0.5;
        c = (c.0.min(c2), c.1.max(c2));
    }
    (Bounds3::new(b.0.into(), b.1.into()), Bounds3::new(c.0.into(), c.1.into()))
}

struct Split {
    axis: usize,
    /// Primitives in bins `< pos` go left.
    pos: usize,
    cost: f32,
    left: Bounds3,
    right: Bounds3,
}

/// Primitives are intersected in blocks of this many (the SIMD packet width): the SAH counts
/// blocks, `⌈n / 4⌉`, not primitives (as Embree's builders do), since a packet costs the same
/// with one triangle or four.
const BLOCK: u32 = 4;

#[inline]
fn blocks(n: u32) -> f32 {
    n.div_ceil(BLOCK) as f32
}

#[allow(clippy::needless_range_loop)] // two sweeps over the same bin index
fn best_split(bins: &Bins, n_bins: usize) -> Option<Split> {
    let mut best: Option<(usize, usize, f32)> = None;
    for a in 0..3 {
        // Right-to-left sweep: area × blocks of the right part starting at bin i.
        let mut right_cost = [f32::INFINITY; MAX_BINS];
        let mut acc = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        let mut cnt = 0u32;
        for i in (1..n_bins).rev() {
            acc = (acc.0.min(bins.min[a][i]), acc.1.max(bins.max[a][i]));
            cnt += bins.count[a][i];
            if cnt > 0 {
                right_cost[i] = area(acc.0, acc.1) * blocks(cnt);
            }
        }
        let mut acc = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        let mut cnt = 0u32;
        for i in 1..n_bins {
            acc = (acc.0.min(bins.min[a][i - 1]), acc.1.max(bins.max[a][i - 1]));
            cnt += bins.count[a][i - 1];
            if cnt == 0 || right_cost[i].is_infinite() {
                continue;
            }
            let cost = area(acc.0, acc.1) * blocks(cnt) + right_cost[i];
            if best.is_none_or(|b| cost < b.2) {
                best = Some((a, i, cost));
            }
        }
    }
    let (axis, pos, cost) = best?;
    let side = |r: std::ops::Range<usize>| {
        let b = r.fold((Vec3A::INFINITY, Vec3A::NEG_INFINITY), |b, i| {
            (b.0.min(bins.min[axis][i]), b.1.max(bins.max[axis][i]))
        });
        Bounds3::new(b.0.into(), b.1.into())
    };
    Some(Split { axis, pos, cost, left: side(0..pos), right: side(pos..n_bins) })
}

/// In-place partition; returns the left count and the centroid bounds of both sides.
fn partition(refs: &mut [PrimRef], map: &BinMap, split: &Split) -> (usize, Bounds3, Bounds3) {
    let (mut i, mut j) = (0, refs.len());
    let mut lc = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let mut rc = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    while i < j {
        let c2 = refs[i].centroid2();
        if map.bins_of(c2)[split.axis] < split.pos {
            lc = (lc.0.min(c2), lc.1.max(c2));
            i += 1;
        } else {
            rc = (rc.0.min(c2), rc.1.max(c2));
            j -= 1;
            refs.swap(i, j);
        }
    }
    let half = |c: (Vec3A, Vec3A)| Bounds3::new((c.0 * 0.5).into(), (c.1 * 0.5).into());
    (i, half(lc), half(rc))
}

/// Builds the subtree of `refs` into `slots` (exactly `2 refs.len() − 1` slots, the first is the
/// subtree root). `base` is the global index of `slots[0]`, `first` that of `refs[0]`.
/// Returns the subtree depth.
#[allow(clippy::too_many_arguments)]
fn build_rec(
    s: &Settings,
    refs: &mut [PrimRef],
    slots: &mut [Slot],
    base: u32,
    first: u32,
    bounds: Bounds3,
    cbounds: Bounds3,
    depth: u32,
) -> u32 {
    let n = refs.len();
    let leaf = |slots: &mut [Slot]| {
        slots[0] = Slot { bounds, first, count: n as u32 };
        1
    };
    if n == 1 {
        return leaf(slots);
    }
    let centroids_equal = cbounds.min == cbounds.max;
    let mut split = None;
    let mut map = None;
    if !centroids_equal && depth < SAH_DEPTH_LIMIT {
        let m = BinMap::new(&cbounds, s.bins);
        let bins = if n > PARALLEL_BINNING {
            refs.par_chunks(BIN_CHUNK).map(|c| bin_slice(c, &m)).reduce(Bins::new, |a, b| a.merge(&b))
        } else {
            bin_slice(refs, &m)
        };
        split = best_split(&bins, s.bins);
        map = Some(m);
    }
    let (nl, lb, lcb, rb, rcb) = match (split, map) {
        (Some(sp), Some(m)) => {
            let a = bounds.half_area();
            let split_cost = s.ct + s.ci * sp.cost / a.max(f32::MIN_POSITIVE);
            let leaf_cost = s.ci * blocks(n as u32);
            if n <= s.max_leaf && (leaf_cost <= split_cost || a == 0.0) {
                return leaf(slots);
            }
            let (nl, lcb, rcb) = partition(refs, &m, &sp);
            (nl, sp.left, lcb, sp.right, rcb)
        }
        _ => {
            if n <= s.max_leaf {
                return leaf(slots);
            }
            // Split by count: in the middle of the centroid order along the largest axis.
            let mid = n / 2;
            if !centroids_equal {
                let axis = cbounds.largest_axis();
                refs.select_nth_unstable_by(mid, |a, b| {
                    a.centroid2()[axis].total_cmp(&b.centroid2()[axis]).then(a.id.cmp(&b.id))
                });
            }
            let (lb, lcb) = bounds_of(&refs[..mid]);
            let (rb, rcb) = bounds_of(&refs[mid..]);
            (mid, lb, lcb, rb, rcb)
        }
    };
    let nr = n - nl;
    let right_slot = 2 * nl; // relative to slots[0]
    slots[0] = Slot { bounds, first: base + right_slot as u32, count: 0 };
    let (head, rest) = slots.split_at_mut(right_slot);
    let lslots = &mut head[1..];
    let rslots = &mut rest[..2 * nr - 1];
    let (lrefs, rrefs) = refs.split_at_mut(nl);
    let (lbase, rbase) = (base + 1, base + right_slot as u32);
    let (lfirst, rfirst) = (first, first + nl as u32);
    let (dl, dr) = if n > s.par {
        rayon::join(
            || build_rec(s, lrefs, lslots, lbase, lfirst, lb, lcb, depth + 1),
            || build_rec(s, rrefs, rslots, rbase, rfirst, rb, rcb, depth + 1),
        )
    } else {
        (
            build_rec(s, lrefs, lslots, lbase, lfirst, lb, lcb, depth + 1),
            build_rec(s, rrefs, rslots, rbase, rfirst, rb, rcb, depth + 1),
        )
    };
    1 + dl.max(dr)
}

/// Builds a binary BVH over primitive boxes (index = primitive id). Boxes that are empty or not
/// finite are left out.
pub(crate) fn build_bvh2(boxes: &[Bounds3], options: &BuildOptions) -> Bvh2 {
    let refs: Vec<PrimRef> = boxes
        .par_iter()
        .enumerate()
        .filter(|(_, b)| !b.is_empty() && b.min.is_finite() && b.max.is_finite())
        .map(|(i, b)| PrimRef { min: b.min, id: i as u32, max: b.max, _pad: 0 })
        .collect();
    build_from_refs(refs, options)
}

fn build_from_refs(mut refs: Vec<PrimRef>, options: &BuildOptions) -> Bvh2 {
    let s = Settings {
        max_leaf: options.max_leaf_size.clamp(1, MAX_LEAF),
        bins: options.bins.clamp(2, MAX_BINS),
        ct: if options.traversal_cost.is_finite() { options.traversal_cost.max(0.0) } else { 1.0 },
        ci: if options.intersection_cost.is_finite() && options.intersection_cost > 0.0 {
            options.intersection_cost
        } else {
            1.0
        },
        par: options.parallel_threshold.max(64),
    };
    let n = refs.len();
    if n == 0 {
        return Bvh2::empty();
    }
    let (bounds, cbounds) = if n > PARALLEL_BINNING {
        refs.par_chunks(BIN_CHUNK)
            .map(bounds_of)
            .reduce(|| (Bounds3::EMPTY, Bounds3::EMPTY), |a, b| (a.0.union(b.0), a.1.union(b.1)))
    } else {
        bounds_of(&refs)
    };
    let mut slots = vec![Slot { bounds: Bounds3::EMPTY, first: 0, count: UNUSED }; 2 * n - 1];
    let depth = build_rec(&s, &mut refs, &mut slots, 0, 0, bounds, cbounds, 1);

    // Compact the gapped pre-order array in place: used slots keep their order, so a left child
    // still follows its parent; right-child indices are remapped.
    let mut remap = vec![0u32; slots.len()];
    let mut used = 0u32;
    for (i, slot) in slots.iter().enumerate() {
        remap[i] = used;
        if slot.count != UNUSED {
            used += 1;
        }
    }
    let mut nodes = Vec::with_capacity(used as usize);
    for slot in slots.iter().filter(|s| s.count != UNUSED) {
        let first = if slot.count == 0 { remap[slot.first as usize] } else { slot.first };
        nodes.push(Bvh2Node { bounds: slot.bounds, first, count: slot.count });
    }
    drop(slots);
    let prims = refs.iter().map(|r| r.id).collect();
    Bvh2::from_parts(nodes, prims, depth as usize, s.ct, s.ci)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn boxes(n: usize) -> Vec<Bounds3> {
        (0..n)
            .map(|i| {
                let h = glint_core::random::mix64(i as u64);
                let p = Vec3::new(
                    (h & 0xffff) as f32 / 65535.0,
                    ((h >> 16) & 0xffff) as f32 / 65535.0,
                    ((h >> 32) & 0xffff) as f32 / 65535.0,
                ) * 10.0;
                Bounds3::new(p, p + Vec3::splat(0.05))
            })
            .collect()
    }

    #[test]
    fn every_primitive_lands_in_exactly_one_leaf() {
        for n in [1, 2, 3, 7, 100, 5000] {
            let b = boxes(n);
            let bvh = build_bvh2(&b, &BuildOptions::default());
            let mut seen = vec![0u32; n];
            for node in bvh.nodes().iter().filter(|nd| nd.count > 0) {
                for &p in &bvh.prim_indices()[node.first as usize..(node.first + node.count) as usize] {
                    seen[p as usize] += 1;
                    assert!(node.bounds.contains(b[p as usize].min));
                    assert!(node.bounds.contains(b[p as usize].max));
                }
            }
            assert!(seen.iter().all(|&c| c == 1), "n = {n}");
        }
    }

    #[test]
    fn leaves_respect_max_size_and_children_nest() {
        let b = boxes(3000);
        let opts = BuildOptions { max_leaf_size: 3, ..BuildOptions::default() };
        let bvh = build_bvh2(&b, &opts);
        for (i, node) in bvh.nodes().iter().enumerate() {
            if node.count > 0 {
                assert!(node.count <= 3);
            } else {
                for c in [i + 1, node.first as usize] {
                    let cb = bvh.nodes()[c].bounds;
                    assert_eq!(node.bounds.union(cb), node.bounds);
                }
            }
        }
    }

    #[test]
    fn coincident_and_invalid_boxes() {
        let p = Bounds3::from_point(Vec3::ONE);
        let mut b = vec![p; 1000];
        b.push(Bounds3::EMPTY);
        b.push(Bounds3::new(Vec3::splat(f32::NAN), Vec3::ONE));
        let bvh = build_bvh2(&b, &BuildOptions::default());
        assert_eq!(bvh.prim_indices().len(), 1000);
        assert!(bvh.depth() <= 12);
        assert!(build_bvh2(&[], &BuildOptions::default()).nodes().is_empty());
    }
}
