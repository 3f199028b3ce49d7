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
//! counts), partitions run sequentially, and nodes are written in pre-order (a subtree built on
//! another thread goes into a vector of its own, appended in its place with its indices moved).
//!
//! Degenerate inputs never recurse forever: when all centroids coincide, or past a depth limit,
//! the node is split in the middle by count (after ordering by centroid when they differ).
//!
//! Takes one box per primitive (the mesh and instance BVHs supply them) and drops boxes that
//! are empty or not finite — those primitives are never hit. Over triangles, the top of the
//! tree may also split triangles at planes ([`spatial`], when
//! [`BuildOptions::spatial_splits`] allows references to be added): a triangle is then in
//! more than one leaf.

mod spatial;

use crate::bvh2::{Bvh2, Bvh2Node};
use glint_core::glam::BVec3A;
use glint_core::{Bounds3, Vec3, Vec3A, Vec4};
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
    /// Spatial splits over triangles: at most this many references added per triangle
    /// (clamped to 0..=2; 0 turns them off). Boxes of other primitives are never split.
    pub spatial_splits: f32,
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

/// The references [`BuildOptions::spatial`] may add per triangle. Sponza's path frame was
/// fastest with 0.1–0.3 (0.3: −3 %; 1.0 gained less, its trees are bigger; BENCHMARKS.md
/// §13.14).
pub const SPATIAL_SPLITS: f32 = 0.3;

impl BuildOptions {
    /// The defaults with spatial splits ([`SPATIAL_SPLITS`]): the renderer's static meshes,
    /// built once and traced many times. A build takes three to four times as long.
    #[must_use]
    pub fn spatial() -> Self {
        Self { spatial_splits: SPATIAL_SPLITS, ..Self::default() }
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
            spatial_splits: 0.0,
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

/// One primitive as the builder sees it: its box and its index in the caller's input. Each
/// corner is one aligned 16-byte vector (the id rides in the min corner's fourth lane, as bits),
/// so the hot loops load a corner with one instruction and use it as a `Vec3A` as it is. The
/// fourth lanes go through the same arithmetic, so the id's bits are flipped by [`ID_FLIP`] to
/// make a normal float of any id below 127·2²³ (over a billion; ids as they are would be
/// subnormal, which some CPUs compute with slow microcode).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct PrimRef {
    lo: Vec4,
    hi: Vec4,
}
const _: () = assert!(size_of::<PrimRef>() == 32);

/// Sets the exponent's top bit of an id's bits: ids below 127·2²³ become normal floats ≥ 2.
const ID_FLIP: u32 = 0x4000_0000;

impl PrimRef {
    fn new(b: &Bounds3, id: u32) -> Self {
        Self { lo: b.min.extend(f32::from_bits(id ^ ID_FLIP)), hi: b.max.extend(0.0) }
    }

    fn from_corners((lo, hi): (Vec3A, Vec3A), id: u32) -> Self {
        Self { lo: lo.extend(f32::from_bits(id ^ ID_FLIP)), hi: hi.extend(0.0) }
    }

    #[inline(always)]
    fn id(&self) -> u32 {
        self.lo.w.to_bits() ^ ID_FLIP
    }

    /// The box's corners (the fourth lane is ignored by every `Vec3A` operation used here).
    #[inline(always)]
    fn corners(&self) -> (Vec3A, Vec3A) {
        (Vec3A::from_vec4(self.lo), Vec3A::from_vec4(self.hi))
    }

    /// Twice the centroid (saves a multiply; the bins are scaled accordingly).
    #[inline(always)]
    fn centroid2(&self) -> Vec3A {
        let (lo, hi) = self.corners();
        lo + hi
    }
}

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
        // loop. round(b − 0.5) stays in [0, last]. Binning uses this, partitioning `bin_of`:
        // the same IEEE operations per axis, so they always agree.
        let b = ((c2 - self.base) * self.scale).max(Vec3A::ZERO).min(Vec3A::splat(self.last));
        let r = (b - Vec3A::splat(0.5)) + Vec3A::splat(ROUND);
        [r.x, r.y, r.z].map(rounded_bin)
    }

    /// `bins_of(c2)[axis]`, the same arithmetic on one axis.
    #[inline]
    fn bin_of(&self, c2: Vec3A, axis: usize) -> usize {
        let b = ((c2[axis] - self.base[axis]) * self.scale[axis]).max(0.0).min(self.last);
        rounded_bin((b - 0.5) + ROUND)
    }
}

/// 1.5 · 2²³: adding it to x in [−0.5, 2²²) leaves round(x) in the low mantissa bits.
const ROUND: f32 = 12_582_912.0;

/// The bin index held in the low mantissa bits of `r = x + ROUND`.
#[inline(always)]
fn rounded_bin(r: f32) -> usize {
    ((r.to_bits() & 0x7f_ffff).wrapping_sub(0x40_0000) as usize) % MAX_BINS
}

impl Bins {
    #[inline(always)]
    fn add(&mut self, r: &PrimRef, map: &BinMap) {
        let (lo, hi) = r.corners();
        let b = map.bins_of(lo + hi);
        for (a, &i) in b.iter().enumerate() {
            self.min[a][i] = self.min[a][i].min(lo);
            self.max[a][i] = self.max[a][i].max(hi);
            self.count[a][i] += 1;
        }
    }
}

/// The bins of a node's references (in parallel chunks for a big node; merged exactly).
fn bin_refs(refs: &[PrimRef], map: &BinMap) -> Bins {
    if refs.len() > PARALLEL_BINNING {
        refs.par_chunks(BIN_CHUNK).map(|c| bin_slice(c, map)).reduce(Bins::new, |a, b| a.merge(&b))
    } else {
        bin_slice(refs, map)
    }
}

/// Below this many primitives one set of bins is used, above it two.
const TWO_BIN_SETS: usize = 64;

fn bin_slice(refs: &[PrimRef], map: &BinMap) -> Bins {
    let mut bins = Bins::new();
    if refs.len() < TWO_BIN_SETS {
        for r in refs {
            bins.add(r, map);
        }
        return bins;
    }
    // Neighbouring primitives of a mesh mostly fall in the same bins, and each update of a bin
    // waits for the previous one's store: alternating between two sets of bins halves those
    // chains. Merging is exact (minima, maxima, counts), so the bins are the same.
    let mut odd = Bins::new();
    let (pairs, rest) = refs.as_chunks::<2>();
    for [a, b] in pairs {
        bins.add(a, map);
        odd.add(b, map);
    }
    for r in rest {
        bins.add(r, map);
    }
    bins.merge(&odd)
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
        let (lo, hi) = r.corners();
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
///
/// Branch-free (Lomuto with an unconditional swap): `refs[..j]` holds the left primitives and
/// `refs[j..i]` the right ones; the element at `i` is swapped to `j` and `j` advances when it
/// goes left. A right element swaps with itself or with another right one, which keeps the
/// invariant. Which side a primitive goes to is as unpredictable as the mesh, so a branch
/// per primitive mispredicted about half the time.
fn partition(refs: &mut [PrimRef], map: &BinMap, split: &Split) -> (usize, Bounds3, Bounds3) {
    let mut j = 0;
    let (axis, pos) = (split.axis, split.pos);
    let mut lc = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    let mut rc = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
    for i in 0..refs.len() {
        let c2 = refs[i].centroid2();
        let left = map.bin_of(c2, axis) < pos;
        // Each side's centroid box grows by c2 or by an empty box (blends, not branches).
        let m = BVec3A::splat(left);
        let (inf, ninf) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
        lc = (lc.0.min(Vec3A::select(m, c2, inf)), lc.1.max(Vec3A::select(m, c2, ninf)));
        rc = (rc.0.min(Vec3A::select(m, inf, c2)), rc.1.max(Vec3A::select(m, ninf, c2)));
        refs.swap(i, j);
        j += usize::from(left);
    }
    let half = |c: (Vec3A, Vec3A)| Bounds3::new((c.0 * 0.5).into(), (c.1 * 0.5).into());
    (j, half(lc), half(rc))
}

/// Appends the subtree of `refs` to `out` in pre-order (a node, its left subtree, its right
/// subtree), inner nodes naming their right child by its index in `out` as it will be when
/// `out` starts at `base`. `first` is the global index of `refs[0]`. Returns the subtree depth.
///
/// Above the parallel threshold the right subtree is built on another thread into a vector of
/// its own and appended when both are done, its indices moved by where it lands: the nodes
/// come out in the same order whatever the thread count.
#[allow(clippy::too_many_arguments)]
fn build_rec(
    s: &Settings,
    refs: &mut [PrimRef],
    out: &mut Vec<Bvh2Node>,
    base: u32,
    first: u32,
    bounds: Bounds3,
    cbounds: Bounds3,
    depth: u32,
) -> u32 {
    let n = refs.len();
    let leaf = |out: &mut Vec<Bvh2Node>| {
        out.push(Bvh2Node { bounds, first, count: n as u32 });
        1
    };
    // A leaf of one block costs `ci`, any split at least `ct` more than nothing: when a
    // visit costs no less than a block test, at most a block's worth of primitives is a leaf
    // whatever the bins would say (the bins and their sweep were most of a small node's cost).
    if n == 1 || (n <= s.max_leaf && n as u32 <= BLOCK && s.ct >= s.ci) {
        return leaf(out);
    }
    let centroids_equal = cbounds.min == cbounds.max;
    let mut split = None;
    let mut map = None;
    if !centroids_equal && depth < SAH_DEPTH_LIMIT {
        let m = BinMap::new(&cbounds, s.bins);
        split = best_split(&bin_refs(refs, &m), s.bins);
        map = Some(m);
    }
    let (nl, lb, lcb, rb, rcb) = match (split, map) {
        (Some(sp), Some(m)) => {
            let a = bounds.half_area();
            let split_cost = s.ct + s.ci * sp.cost / a.max(f32::MIN_POSITIVE);
            let leaf_cost = s.ci * blocks(n as u32);
            if n <= s.max_leaf && (leaf_cost <= split_cost || a == 0.0) {
                return leaf(out);
            }
            let (nl, lcb, rcb) = partition(refs, &m, &sp);
            (nl, sp.left, lcb, sp.right, rcb)
        }
        _ => {
            if n <= s.max_leaf {
                return leaf(out);
            }
            // Split by count: in the middle of the centroid order along the largest axis.
            let mid = n / 2;
            if !centroids_equal {
                let axis = cbounds.largest_axis();
                refs.select_nth_unstable_by(mid, |a, b| {
                    a.centroid2()[axis].total_cmp(&b.centroid2()[axis]).then(a.id().cmp(&b.id()))
                });
            }
            let (lb, lcb) = bounds_of(&refs[..mid]);
            let (rb, rcb) = bounds_of(&refs[mid..]);
            (mid, lb, lcb, rb, rcb)
        }
    };
    let me = out.len();
    // The right child's index is known once the left subtree is in place.
    out.push(Bvh2Node { bounds, first: 0, count: 0 });
    let (lrefs, rrefs) = refs.split_at_mut(nl);
    let (lfirst, rfirst) = (first, first + nl as u32);
    let (dl, dr) = if n > s.par {
        let mut right = Vec::with_capacity(2 * rrefs.len() - 1);
        let (dl, dr) = rayon::join(
            || build_rec(s, lrefs, out, base, lfirst, lb, lcb, depth + 1),
            || build_rec(s, rrefs, &mut right, 0, rfirst, rb, rcb, depth + 1),
        );
        let shift = base + out.len() as u32;
        out[me].first = shift;
        out.extend(right.into_iter().map(|mut node| {
            if node.count == 0 {
                node.first += shift;
            }
            node
        }));
        (dl, dr)
    } else {
        let dl = build_rec(s, lrefs, out, base, lfirst, lb, lcb, depth + 1);
        out[me].first = base + out.len() as u32;
        let dr = build_rec(s, rrefs, out, base, rfirst, rb, rcb, depth + 1);
        (dl, dr)
    };
    1 + dl.max(dr)
}

/// Builds a binary BVH over primitive boxes (index = primitive id). Boxes that are empty or not
/// finite are left out.
pub(crate) fn build_bvh2(boxes: &[Bounds3], options: &BuildOptions) -> Bvh2 {
    build_from_refs(prim_refs(boxes.len(), |i| boxes[i]), options, None)
}

/// Builds a binary BVH over triangles (vertex indices into `positions`); triangles with an
/// index out of range or a vertex that is not finite are left out. The same tree as
/// `build_bvh2` over their boxes, without a frame of boxes in between.
pub(crate) fn build_bvh2_triangles(positions: &[Vec3], triangles: &[[u32; 3]], options: &BuildOptions) -> Bvh2 {
    let refs = prim_refs(triangles.len(), |i| triangle_box(positions, triangles, i));
    build_from_refs(refs, options, Some((positions, triangles)))
}

/// The box of triangle `i`; empty where an index is out of range.
pub(crate) fn triangle_box(positions: &[Vec3], triangles: &[[u32; 3]], i: usize) -> Bounds3 {
    match crate::fetch_triangle(positions, triangles, i as u32) {
        Some([a, b, c]) => Bounds3::from_points([a, b, c].map(Vec3::from_array)),
        None => Bounds3::EMPTY,
    }
}

/// One reference per primitive whose box is neither empty nor non-finite, in index order. Made
/// in place by every thread (an indexed map writes straight into the vector, so its pages are
/// first touched in parallel), then the rare unusable boxes are dropped.
fn prim_refs(n: usize, bounds: impl Fn(usize) -> Bounds3 + Sync) -> Vec<PrimRef> {
    let usable = |b: &Bounds3| !b.is_empty() && b.min.is_finite() && b.max.is_finite();
    let mut refs: Vec<PrimRef> = (0..n)
        .into_par_iter()
        .map(|i| {
            let b = bounds(i);
            // An unusable box keeps an id past the end, so that it is found and dropped below.
            let id = if usable(&b) { i as u32 } else { u32::MAX };
            PrimRef::new(&b, id)
        })
        .collect();
    if refs.par_iter().any(|r| r.id() == u32::MAX) {
        refs.retain(|r| r.id() != u32::MAX);
    }
    refs
}

/// The tree over `refs`; with `triangles` (positions and vertex indices) spatial splits may cut
/// them, as far as `options` allow.
fn build_from_refs(mut refs: Vec<PrimRef>, options: &BuildOptions, triangles: Option<(&[Vec3], &[[u32; 3]])>) -> Bvh2 {
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
    let extra = options.spatial_splits;
    let extra = if extra.is_finite() { extra.clamp(0.0, 2.0) } else { 0.0 };
    let budget = (extra as f64 * n as f64) as usize;
    if let Some((positions, triangles)) = triangles
        && budget > 0
    {
        let c = spatial::Ctx { s, positions, triangles, min_overlap: spatial::ALPHA * bounds.half_area() };
        let mut tree =
            spatial::Tree { nodes: Vec::with_capacity(2 * (n + budget) - 1), prims: Vec::with_capacity(n + budget) };
        let depth = spatial::build(&c, refs, &mut tree, 0, 0, bounds, cbounds, 1, budget);
        return Bvh2::from_parts(tree.nodes, tree.prims, depth as usize, s.ct, s.ci);
    }
    // At most 2n − 1 nodes; only the pages the nodes use are ever touched.
    let mut nodes = Vec::with_capacity(2 * n - 1);
    let depth = build_rec(&s, &mut refs, &mut nodes, 0, 0, bounds, cbounds, 1);
    let prims = refs.par_iter().map(PrimRef::id).collect();
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
    fn a_reference_keeps_its_box_and_id() {
        let b = Bounds3::new(Vec3::new(-1.0, 2.0, 3.5), Vec3::new(4.0, 5.0, 6.0));
        for id in [0, 1, 5, (1 << 23) - 1, 1 << 23, (127 << 23) - 1, 127 << 23, 1 << 30, u32::MAX - 1, u32::MAX] {
            let r = PrimRef::new(&b, id);
            assert_eq!(r.id(), id);
            let (lo, hi) = r.corners();
            assert_eq!((Vec3::from(lo), Vec3::from(hi)), (b.min, b.max));
            // Ids below 127·2^23 ride as normal floats (no subnormal arithmetic in the fourth lane).
            if id < 127 << 23 {
                assert!(r.lo.w.is_normal(), "{id}");
            }
        }
    }

    #[test]
    fn the_tree_is_the_same_on_any_thread_count() {
        let b = boxes(60_000);
        let opts = BuildOptions { parallel_threshold: 64, ..BuildOptions::default() };
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            pool.install(|| build_bvh2(&b, &opts))
        };
        let (one, two, three) = (build(1), build(2), build(3));
        for other in [&two, &three] {
            assert_eq!(one.prim_indices(), other.prim_indices());
            assert_eq!(one.nodes(), other.nodes());
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
