//! Spatial splits: the top of a triangle mesh's tree may cut triangles at a plane and put a
//! reference to each part on its side (Stich, Friedrich, Dietrich, "Spatial Splits in Bounding
//! Volume Hierarchies", HPG 2009, the "SBVH").
//!
//! An object split puts every triangle on one side whole; where long triangles cross (a
//! floor, the columns and arches of an atrium) both children's boxes reach across each other
//! and a ray must walk both. A spatial split cuts at a plane instead: each side's box ends at
//! the plane, and a triangle that crosses it is referenced on both sides, each reference's box
//! that of the triangle's part on its side (clipped exactly, then padded by the rounding of the
//! edge–plane points, so that a box always holds its part: every hit is still found).
//!
//! Per node, as in the paper (§4):
//! 1. the best binned object split ([`super::best_split`]);
//! 2. where its children overlap by more than `ALPHA` of the root's area (§4.5: spatial splits
//!    go where they can pay, and the references they add stay few), the best spatial split:
//!    [`SPATIAL_BINS`] equal slices of the node's box per axis; each reference is clipped into
//!    every bin it crosses ("chopped binning"), counted entering its first bin and leaving its
//!    last; a sweep gives each plane's `A_L ⌈N_L/4⌉ + A_R ⌈N_R/4⌉`, the object splits' measure;
//! 3. the cheaper split (or a leaf, by the same test as the object builder); a spatial
//!    partition keeps a crossing reference whole on one side instead of cutting it when that
//!    costs the SAH less ("reference unsplitting", §4.4).
//!
//! The references a tree may add are a budget, a fraction of the triangles
//! ([`super::BuildOptions::spatial_splits`]); a split's children share what is left in
//! proportion to their references, so the tree does not depend on the thread count. A subtree
//! left without budget, or too small for a split to pass `ALPHA`, is built in place by the
//! object builder ([`super::build_rec`]).

use super::{
    BIN_CHUNK, BLOCK, BinMap, PARALLEL_BINNING, PrimRef, ROUND, SAH_DEPTH_LIMIT, Settings, area, best_split, bin_refs,
    blocks, bounds_of, build_rec, partition, rounded_bin,
};
use crate::bvh2::Bvh2Node;
use glint_core::{Bounds3, Vec3, Vec3A};
use rayon::prelude::*;

/// Stich et al.'s α: a node tries spatial splits only where its best object split's children
/// overlap by more than this fraction of the root's area. The paper takes 10⁻⁵; on Sponza
/// 10⁻³ traces diffuse rays as fast (8.9 M rays/s on 2 threads with either) and builds in
/// half the time (BENCHMARKS.md §13.14).
pub(super) const ALPHA: f32 = 1e-3;

/// Slices of a node's box per axis for spatial splits.
const SPATIAL_BINS: usize = 32;

/// Relative padding of an edge–plane point: `p = v0 + t (v1 − v0)` is off by at most a few
/// roundings of `max(|v0|, |v1|)` per coordinate (2⁻²⁴ each); 2⁻¹⁹ is eight of them and more.
const PAD: f32 = 1.0 / (1 << 19) as f32;

/// A box as its two corners.
type Corners = (Vec3A, Vec3A);
const NO_BOX: Corners = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);

fn is_empty(b: &Corners) -> bool {
    b.0.cmpgt(b.1).any()
}

fn union(a: Corners, b: Corners) -> Corners {
    (a.0.min(b.0), a.1.max(b.1))
}

/// What the spatial builder reads and decides with.
pub(super) struct Ctx<'a> {
    pub s: Settings,
    pub positions: &'a [Vec3],
    pub triangles: &'a [[u32; 3]],
    /// `ALPHA` times the root's area.
    pub min_overlap: f32,
}

impl Ctx<'_> {
    fn triangle(&self, id: u32) -> Option<[Vec3A; 3]> {
        crate::fetch_triangle(self.positions, self.triangles, id).map(|t| t.map(Vec3A::from_array))
    }
}

/// A subtree: its nodes in pre-order and the primitive ids its leaves index.
#[derive(Default)]
pub(super) struct Tree {
    pub nodes: Vec<Bvh2Node>,
    pub prims: Vec<u32>,
}

/// The parts of a reference's box on either side of the plane `x[axis] = p`: the triangle's
/// part on each side (its corners there and its edges' points on the plane, padded), cut by
/// the plane and kept inside the reference's box. Without its triangle (not expected: every
/// reference's triangle was fetched to make it) the box itself is cut.
fn clip(tri: Option<&[Vec3A; 3]>, piece: Corners, axis: usize, p: f32) -> (Corners, Corners) {
    let (mut l, mut r) = (NO_BOX, NO_BOX);
    match tri {
        Some(tri) => {
            for i in 0..3 {
                let (v0, v1) = (tri[i], tri[(i + 1) % 3]);
                let (x0, x1) = (v0[axis], v1[axis]);
                if x0 <= p {
                    l = union(l, (v0, v0));
                }
                if x0 >= p {
                    r = union(r, (v0, v0));
                }
                if (x0 < p && p < x1) || (x1 < p && p < x0) {
                    let t = ((p - x0) / (x1 - x0)).clamp(0.0, 1.0);
                    let q = v0 + (v1 - v0) * t;
                    let pad = v0.abs().max(v1.abs()) * PAD;
                    // An edge across most of the float range overflows (`v1 − v0` infinite,
                    // `∞ · 0` NaN): its point is then only known to be in the piece.
                    let at = if (q - pad).is_finite() && (q + pad).is_finite() { (q - pad, q + pad) } else { piece };
                    l = union(l, at);
                    r = union(r, at);
                }
            }
        }
        None => (l, r) = (piece, piece),
    }
    l.1[axis] = l.1[axis].min(p);
    r.0[axis] = r.0[axis].max(p);
    ((l.0.max(piece.0), l.1.min(piece.1)), (r.0.max(piece.0), r.1.min(piece.1)))
}

/// Equal slices of a node's box along each axis.
struct Grid {
    origin: Vec3A,
    width: Vec3A,
    /// Slices per unit length; 0 along an axis the box is flat in (no spatial split there).
    scale: Vec3A,
}

impl Grid {
    fn new(b: &Bounds3) -> Self {
        let ext = Vec3A::from(b.extent());
        let n = SPATIAL_BINS as f32;
        let usable = ext.cmpgt(Vec3A::ZERO) & ext.cmplt(Vec3A::INFINITY);
        Self { origin: b.min.into(), width: ext / n, scale: Vec3A::select(usable, Vec3A::splat(n) / ext, Vec3A::ZERO) }
    }

    /// The slices holding `p` along the three axes (clamped: references may poke out by their
    /// padding). Rounded as the object bins are (`BinMap::bins_of`, no float→int conversion):
    /// a point on a plane may land in the slice below it, whose part is then empty, which only
    /// makes the estimate of that plane's counts a reference off.
    #[inline]
    fn bins(&self, p: Vec3A) -> [usize; 3] {
        let b = ((p - self.origin) * self.scale).max(Vec3A::ZERO).min(Vec3A::splat((SPATIAL_BINS - 1) as f32));
        let r = (b - Vec3A::splat(0.5)) + Vec3A::splat(ROUND);
        [rounded_bin(r.x), rounded_bin(r.y), rounded_bin(r.z)]
    }

    /// The plane between slices `i − 1` and `i`.
    fn plane(&self, axis: usize, i: usize) -> f32 {
        self.origin[axis] + self.width[axis] * i as f32
    }
}

/// Per axis and slice: the box of the references' parts in it, how many references start in
/// it and how many end in it.
#[derive(Clone)]
struct Slices {
    boxes: [[Corners; SPATIAL_BINS]; 3],
    enter: [[u32; SPATIAL_BINS]; 3],
    exit: [[u32; SPATIAL_BINS]; 3],
}

impl Slices {
    fn new() -> Self {
        Self { boxes: [[NO_BOX; SPATIAL_BINS]; 3], enter: [[0; SPATIAL_BINS]; 3], exit: [[0; SPATIAL_BINS]; 3] }
    }

    fn merge(mut self, o: &Slices) -> Self {
        for a in 0..3 {
            for i in 0..SPATIAL_BINS {
                self.boxes[a][i] = union(self.boxes[a][i], o.boxes[a][i]);
                self.enter[a][i] += o.enter[a][i];
                self.exit[a][i] += o.exit[a][i];
            }
        }
        self
    }

    /// Chops a reference into the slices it crosses, along every axis the grid has.
    fn add(&mut self, c: &Ctx, r: &PrimRef, grid: &Grid) {
        let whole = r.corners();
        let (firsts, lasts) = (grid.bins(whole.0), grid.bins(whole.1));
        // Fetched for the first reference that crosses a plane (most lie in one slice).
        let mut tri = None;
        for a in 0..3 {
            if grid.scale[a] == 0.0 {
                continue;
            }
            let (first, last) = (firsts[a], lasts[a]);
            self.enter[a][first] += 1;
            self.exit[a][last] += 1;
            let mut piece = whole;
            if first < last {
                let tri = tri.get_or_insert_with(|| c.triangle(r.id()));
                for i in first..last {
                    let (l, r) = clip(tri.as_ref(), piece, a, grid.plane(a, i + 1));
                    self.boxes[a][i] = union(self.boxes[a][i], l);
                    piece = r;
                }
            }
            self.boxes[a][last] = union(self.boxes[a][last], piece);
        }
    }
}

fn slice_refs(c: &Ctx, refs: &[PrimRef], grid: &Grid) -> Slices {
    let bin = |chunk: &[PrimRef]| {
        // Two sets of slices, alternating, as `bin_slice` does: neighbouring references fall in
        // the same slices, and each update waited on the last one's store.
        let (mut even, mut odd) = (Slices::new(), Slices::new());
        let (pairs, rest) = chunk.as_chunks::<2>();
        for [a, b] in pairs {
            even.add(c, a, grid);
            odd.add(c, b, grid);
        }
        for r in rest {
            even.add(c, r, grid);
        }
        even.merge(&odd)
    };
    if refs.len() > PARALLEL_BINNING {
        // Exact reductions (boxes' minima and maxima, counts): the same slices on any thread count.
        refs.par_chunks(BIN_CHUNK).map(bin).reduce(Slices::new, |a, b| a.merge(&b))
    } else {
        bin(refs)
    }
}

/// A spatial split: the plane, its SAH measure (as [`super::Split::cost`]), the sides' boxes
/// and reference counts as the slices estimate them.
struct SpatialSplit {
    axis: usize,
    plane: f32,
    cost: f32,
    left: Corners,
    right: Corners,
    nl: u32,
    nr: u32,
}

/// The best spatial split of a node whose references would add at most `budget` references.
#[allow(clippy::needless_range_loop)] // two sweeps over the same slice index
fn best_spatial(c: &Ctx, refs: &[PrimRef], bounds: &Bounds3, budget: usize) -> Option<SpatialSplit> {
    let grid = Grid::new(bounds);
    let s = slice_refs(c, refs, &grid);
    let n = refs.len() as u64;
    let mut best: Option<SpatialSplit> = None;
    for a in 0..3 {
        if grid.scale[a] == 0.0 {
            continue;
        }
        let mut right = [(f32::INFINITY, NO_BOX, 0u32); SPATIAL_BINS];
        let (mut acc, mut cnt) = (NO_BOX, 0u32);
        for i in (1..SPATIAL_BINS).rev() {
            acc = union(acc, s.boxes[a][i]);
            cnt += s.exit[a][i];
            if cnt > 0 {
                right[i] = (area(acc.0, acc.1) * blocks(cnt), acc, cnt);
            }
        }
        let (mut acc, mut cnt) = (NO_BOX, 0u32);
        for i in 1..SPATIAL_BINS {
            acc = union(acc, s.boxes[a][i - 1]);
            cnt += s.enter[a][i - 1];
            let (rcost, rbox, rcnt) = right[i];
            if cnt == 0 || rcnt == 0 || u64::from(cnt) + u64::from(rcnt) > n + budget as u64 {
                continue;
            }
            let cost = area(acc.0, acc.1) * blocks(cnt) + rcost;
            if best.as_ref().is_none_or(|b| cost < b.cost) {
                let plane = grid.plane(a, i);
                best = Some(SpatialSplit { axis: a, plane, cost, left: acc, right: rbox, nl: cnt, nr: rcnt });
            }
        }
    }
    best
}

/// Sends each reference to the side of the plane it lies on; one that crosses it is cut in two,
/// or kept whole on one side where that costs the SAH less (reference unsplitting, with the
/// sides' boxes and counts as they grow). `None` when a side would be empty.
fn partition_spatial(c: &Ctx, refs: &[PrimRef], sp: &SpatialSplit) -> Option<(Vec<PrimRef>, Vec<PrimRef>)> {
    let (a, p) = (sp.axis, sp.plane);
    let mut left = Vec::with_capacity(sp.nl as usize);
    let mut right = Vec::with_capacity(sp.nr as usize);
    let (mut lb, mut rb) = (sp.left, sp.right);
    let (mut nl, mut nr) = (sp.nl as f32, sp.nr as f32);
    for &r in refs {
        let whole = r.corners();
        if whole.1[a] <= p {
            left.push(r);
        } else if whole.0[a] >= p {
            right.push(r);
        } else {
            let (lp, rp) = clip(c.triangle(r.id()).as_ref(), whole, a, p);
            let (al, ar) = (area(lb.0, lb.1), area(rb.0, rb.1));
            let split = al * nl + ar * nr;
            let l_whole = union(lb, whole);
            let r_whole = union(rb, whole);
            let keep_left = area(l_whole.0, l_whole.1) * nl + ar * (nr - 1.0);
            let keep_right = al * (nl - 1.0) + area(r_whole.0, r_whole.1) * nr;
            if is_empty(&rp) || (keep_left < split && keep_left <= keep_right) {
                left.push(r);
                lb = l_whole;
                nr -= 1.0;
            } else if is_empty(&lp) || keep_right < split {
                right.push(r);
                rb = r_whole;
                nl -= 1.0;
            } else {
                left.push(PrimRef::from_corners(lp, r.id()));
                right.push(PrimRef::from_corners(rp, r.id()));
                lb = union(lb, lp);
                rb = union(rb, rp);
            }
        }
    }
    (!left.is_empty() && !right.is_empty()).then_some((left, right))
}

/// Appends the subtree of `refs` to `out` in pre-order, inner nodes naming their right child by
/// its index as it will be when `out.nodes` starts at `base`, leaves their primitives by index
/// as it will be when `out.prims` starts at `prim_base`. `budget`: the references the subtree
/// may add. Returns the subtree's depth.
#[allow(clippy::too_many_arguments)]
pub(super) fn build(
    c: &Ctx,
    mut refs: Vec<PrimRef>,
    out: &mut Tree,
    base: u32,
    prim_base: u32,
    bounds: Bounds3,
    cbounds: Bounds3,
    depth: u32,
    budget: usize,
) -> u32 {
    let n = refs.len();
    let a = bounds.half_area();
    // The object builder, in place: where no reference may be added, where no split can pass
    // the overlap test (its children's overlap is no bigger than the node), where the builder
    // would split by count, and for a block or less (a leaf when a visit costs no less than a
    // block test, as `build_rec` decides).
    let in_place = budget == 0
        || a <= c.min_overlap
        || depth >= SAH_DEPTH_LIMIT
        || cbounds.min == cbounds.max
        || n <= BLOCK as usize;
    let at = Place { base, prim_base, bounds, cbounds, depth };
    if in_place {
        return object_subtree(c, refs, out, &at);
    }
    let map = BinMap::new(&cbounds, c.s.bins);
    let object = best_split(&bin_refs(&refs, &map), c.s.bins);
    let spatial = match &object {
        Some(o) if overlap(&o.left, &o.right) > c.min_overlap => best_spatial(c, &refs, &bounds, budget),
        _ => None,
    };
    let object_cost = object.as_ref().map_or(f32::INFINITY, |o| o.cost);
    let spatial = spatial.filter(|sp| sp.cost < object_cost);
    let cost = spatial.as_ref().map_or(object_cost, |sp| sp.cost);
    let s = &c.s;
    if !cost.is_finite() {
        // No split the bins can name (every reference in one bin): the object builder's way.
        return object_subtree(c, refs, out, &at);
    }
    let split_cost = s.ct + s.ci * cost / a.max(f32::MIN_POSITIVE);
    if n <= s.max_leaf && (s.ci * blocks(n as u32) <= split_cost || a == 0.0) {
        out.nodes.push(Bvh2Node { bounds, first: prim_base + out.prims.len() as u32, count: n as u32 });
        out.prims.extend(refs.iter().map(PrimRef::id));
        return 1;
    }
    // A spatial partition that would leave a side empty falls back to the object split.
    let sides = spatial.and_then(|sp| partition_spatial(c, &refs, &sp)).map(|(l, r)| {
        let (lb, lcb) = bounds_of(&l);
        let (rb, rcb) = bounds_of(&r);
        ((l, lb, lcb), (r, rb, rcb))
    });
    let (left, right) = match sides {
        Some(sides) => sides,
        None => {
            // `cost` is finite, so the object split exists (a spatial split is kept only when
            // cheaper than it, and without it the cost is infinite).
            let Some(o) = object else {
                return object_subtree(c, refs, out, &at);
            };
            let (nl, lcb, rcb) = partition(&mut refs, &map, &o);
            let r = refs.split_off(nl);
            ((refs, o.left, lcb), (r, o.right, rcb))
        }
    };
    let (nl, nr) = (left.0.len(), right.0.len());
    // What is left of the budget, shared in proportion to the sides' references.
    let rest = budget.saturating_sub(nl + nr - n);
    let lbudget = (rest as u64 * nl as u64 / (nl + nr) as u64) as usize;
    let rbudget = rest - lbudget;
    let me = out.nodes.len();
    out.nodes.push(Bvh2Node { bounds, first: 0, count: 0 });
    let (dl, dr) = if nl + nr > s.par {
        let mut other = Tree::default();
        let (dl, dr) = rayon::join(
            || build(c, left.0, out, base, prim_base, left.1, left.2, depth + 1, lbudget),
            || build(c, right.0, &mut other, 0, 0, right.1, right.2, depth + 1, rbudget),
        );
        let node_shift = base + out.nodes.len() as u32;
        let prim_shift = prim_base + out.prims.len() as u32;
        out.nodes[me].first = node_shift;
        out.nodes.extend(other.nodes.into_iter().map(|mut node| {
            node.first += if node.count == 0 { node_shift } else { prim_shift };
            node
        }));
        out.prims.extend(other.prims);
        (dl, dr)
    } else {
        let dl = build(c, left.0, out, base, prim_base, left.1, left.2, depth + 1, lbudget);
        out.nodes[me].first = base + out.nodes.len() as u32;
        let dr = build(c, right.0, out, base, prim_base, right.1, right.2, depth + 1, rbudget);
        (dl, dr)
    };
    1 + dl.max(dr)
}

/// Where a subtree goes: its offsets in the output (as [`build`] takes them), its box, its
/// centroids' box and its depth.
struct Place {
    base: u32,
    prim_base: u32,
    bounds: Bounds3,
    cbounds: Bounds3,
    depth: u32,
}

/// The subtree of `refs` by the object builder, in place (its leaves index the references in
/// the order it leaves them, appended to `out.prims`).
fn object_subtree(c: &Ctx, mut refs: Vec<PrimRef>, out: &mut Tree, at: &Place) -> u32 {
    let first = at.prim_base + out.prims.len() as u32;
    let d = build_rec(&c.s, &mut refs, &mut out.nodes, at.base, first, at.bounds, at.cbounds, at.depth);
    out.prims.extend(refs.iter().map(PrimRef::id));
    d
}

/// Half the area of the boxes' intersection; 0 where they do not meet.
fn overlap(a: &Bounds3, b: &Bounds3) -> f32 {
    let (lo, hi) = (Vec3A::from(a.min.max(b.min)), Vec3A::from(a.max.min(b.max)));
    if lo.cmpgt(hi).any() { 0.0 } else { area(lo, hi) }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [Vec3A; 3] {
        [a, b, c].map(Vec3A::from_array)
    }

    fn box_of(t: &[Vec3A; 3]) -> Corners {
        (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2]))
    }

    #[test]
    fn a_cut_triangle_parts_stay_in_their_halves_and_cover_it() {
        let t = tri([0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 2.0, 1.0]);
        let (l, r) = clip(Some(&t), box_of(&t), 0, 1.0);
        assert_eq!(l.1.x, 1.0);
        assert_eq!(r.0.x, 1.0);
        // Left: x in [0, 1]; the edge (4,0,0)–(0,2,1) meets x = 1 at y = 1.5, z = 0.75.
        assert_eq!(l.0, Vec3A::ZERO);
        assert!((l.1.y - 2.0).abs() < 1e-6 && (l.1.z - 1.0).abs() < 1e-6);
        // Right: x in [1, 4], y up to 1.5 (padded), z up to 0.75 (padded).
        assert!(r.1.y >= 1.5 && r.1.y < 1.5 + 1e-5, "{r:?}");
        assert!(r.1.z >= 0.75 && r.1.z < 0.75 + 1e-5, "{r:?}");
        assert_eq!(r.0.y, 0.0);
        // Sampled points of the triangle lie in the part of their side.
        let mut rng = crate::procedural::Rng::new(3);
        for _ in 0..2000 {
            let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            let p = t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v;
            let side = if p.x <= 1.0 { l } else { r };
            assert!(p.cmpge(side.0).all() && p.cmple(side.1).all(), "{p:?} outside {side:?}");
        }
    }

    #[test]
    fn a_part_stays_inside_the_reference_box() {
        let t = tri([0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 4.0, 0.0]);
        let piece = (Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(4.0, 1.0, 0.0));
        let (l, r) = clip(Some(&t), piece, 0, 2.0);
        assert_eq!(l, (Vec3A::new(1.0, 0.0, 0.0), Vec3A::new(2.0, 1.0, 0.0)));
        assert_eq!(r, (Vec3A::new(2.0, 0.0, 0.0), Vec3A::new(4.0, 1.0, 0.0)));
        // A triangle wholly on one side leaves the other part empty.
        let (l, r) = clip(Some(&t), box_of(&t), 0, 5.0);
        assert_eq!(l, box_of(&t));
        assert!(is_empty(&r));
    }

    /// Sampled points of every triangle lie in the box of a leaf that references it (every hit
    /// is found), no leaf references a triangle twice, and the references stay within budget.
    fn check_cover(m: &crate::procedural::Mesh, options: &super::super::BuildOptions) -> crate::Bvh2 {
        let bvh = crate::Bvh2::build(&m.positions, &m.triangles, options);
        let n = m.triangles.len();
        let mut leaves_of = vec![Vec::new(); n];
        for node in bvh.nodes().iter().filter(|nd| nd.is_leaf()) {
            let ids = &bvh.prim_indices()[node.first as usize..(node.first + node.count) as usize];
            for (k, &p) in ids.iter().enumerate() {
                assert!(!ids[..k].contains(&p), "triangle {p} twice in a leaf");
                leaves_of[p as usize].push(node.bounds);
            }
        }
        let budget = (options.spatial_splits.clamp(0.0, 2.0) as f64 * n as f64) as usize;
        assert!(bvh.prim_indices().len() <= n + budget);
        let mut rng = crate::procedural::Rng::new(9);
        for (i, t) in m.triangles.iter().enumerate() {
            let [a, b, c] = t.map(|v| m.positions[v as usize]);
            if !(a.is_finite() && b.is_finite() && c.is_finite()) {
                continue; // never hit: left out of every tree
            }
            assert!(!leaves_of[i].is_empty(), "triangle {i} in no leaf");
            for k in 0..64 {
                let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                // The corners, the edges' midpoints, then random points.
                let (u, v) = [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.5, 0.0), (0.5, 0.5), (0.0, 0.5)]
                    .get(k)
                    .copied()
                    .unwrap_or((u, v));
                // In f64: an f32 point of the triangle may round out of its box.
                let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
                let p = a + (b - a) * f64::from(u) + (c - a) * f64::from(v);
                let inside = |l: &Bounds3| {
                    let tol = 1e-9 * (p.abs().max_element() + 1.0);
                    p.cmpge(l.min.as_dvec3() - tol).all() && p.cmple(l.max.as_dvec3() + tol).all()
                };
                assert!(
                    leaves_of[i].iter().any(inside),
                    "triangle {i}: {p:?} in none of its leaves {:?}",
                    leaves_of[i]
                );
            }
        }
        bvh
    }

    #[test]
    fn every_part_of_every_triangle_is_in_a_leaf_that_references_it() {
        let options = super::super::BuildOptions { spatial_splits: 1.0, ..Default::default() };
        for (n, size, seed) in [(400, 0.8, 1), (3000, 0.3, 2), (20_000, 0.05, 3)] {
            let m = crate::procedural::triangle_soup(n, size, seed);
            let bvh = check_cover(&m, &options);
            // Long crossing triangles: the tree did split some (the test is not vacuous).
            assert!(bvh.prim_indices().len() > n, "{n}: no spatial split");
        }
        check_cover(&crate::procedural::icosphere(4), &options);
        let tight = super::super::BuildOptions { spatial_splits: 0.01, ..Default::default() };
        check_cover(&crate::procedural::triangle_soup(2000, 0.8, 4), &tight);
    }

    #[test]
    fn the_split_tree_is_the_same_on_any_thread_count() {
        let m = crate::procedural::triangle_soup(30_000, 0.1, 5);
        let options = super::super::BuildOptions { parallel_threshold: 64, ..super::super::BuildOptions::spatial() };
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a pool");
            pool.install(|| crate::Bvh2::build(&m.positions, &m.triangles, &options))
        };
        let (one, two, three) = (build(1), build(2), build(3));
        assert!(one.prim_indices().len() > m.triangles.len());
        for other in [&two, &three] {
            assert_eq!(one.prim_indices(), other.prim_indices());
            assert_eq!(one.nodes(), other.nodes());
        }
    }

    #[test]
    fn edges_across_the_float_range_keep_their_parts_in_the_boxes() {
        // `v1 − v0` overflows on these edges; the parts are still held (and never NaN).
        let big = f32::MAX * 0.75;
        let t = tri([-big, -big, 0.0], [big, -big, 1.0], [-big, big, 2.0]);
        let (l, r) = clip(Some(&t), box_of(&t), 0, 0.0);
        for b in [l, r] {
            assert!(!b.0.is_nan() && !b.1.is_nan(), "{b:?}");
        }
        assert!(l.0.cmple(Vec3A::new(-big, -big, 0.0)).all() && l.1.y >= big * 0.99, "{l:?}");
        assert!(r.1.x >= big && r.0.x == 0.0, "{r:?}");
        let mut m = crate::procedural::triangle_soup(300, 0.8, 6);
        for p in &mut m.positions {
            *p = (*p - 0.5) * 1.8e38 * 2.0;
        }
        assert!(m.positions.iter().all(|p| p.is_finite()));
        check_cover(&m, &super::super::BuildOptions { spatial_splits: 1.0, ..Default::default() });
    }

    #[test]
    fn without_its_triangle_a_box_is_cut() {
        let b = (Vec3A::ZERO, Vec3A::splat(2.0));
        let (l, r) = clip(None, b, 1, 0.5);
        assert_eq!(l, (Vec3A::ZERO, Vec3A::new(2.0, 0.5, 2.0)));
        assert_eq!(r, (Vec3A::new(0.0, 0.5, 0.0), Vec3A::splat(2.0)));
    }
}
