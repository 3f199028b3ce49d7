//! Wide BVH layouts: the binary tree collapsed into nodes of `N` children (4 or 8) with the
//! child boxes stored as structure-of-arrays, so that one SIMD instruction tests all children
//! of a node against a ray (Wald, Benthin, Boulos, "Getting Rid of Packets", IEEE RT 2008;
//! Dammertz et al., "Shallow Bounding Volume Hierarchies for Fast SIMD Ray Tracing of
//! Incoherent Rays", EGSR 2008).
//!
//! Collapse: starting from a binary node's two children, the child with the largest surface area
//! is replaced by its two children until `N` slots are filled or only leaves remain.
//! Leaves: triangles reordered into packets of 4 ([`TriPacket`]) holding the vertices as SoA;
//! the packet test is the watertight test of Woop et al. 2013 on four lanes, operation for
//! operation the same as the scalar [`crate::primitives`] test (no FMA), so it stays watertight.
//!
//! Traversal: `walk` (the closest-hit and any-hit loops, written once, generic over a kernel
//! that brings the node and leaf tests), with the kernels `scalar` (generic over `N`, the
//! oracle and the non-x86 path) and `traverse` (SIMD, generic over `N` and the vector),
//! instantiated as `sse` (4-wide, SSE2 is the x86-64 baseline: no detection needed) and `avx2`
//! (8-wide, and 4-wide recompiled with VEX encoding; only after runtime detection); `packet`
//! (8 coherent rays walking the 8-wide tree together, AVX2; `intersect8_isa` /
//! `occluded8_isa` loop over single rays elsewhere) and `frustum` (its closest-hit walk for
//! rays from one origin: one interval test per node for the whole packet); `dispatch` (the public queries, and which
//! kernel each instruction set runs). This module owns the layout and knows no ISA.

#[cfg(target_arch = "x86_64")]
mod avx2;
mod dispatch;
#[cfg(target_arch = "x86_64")]
mod frustum;
pub(crate) mod one_node;
#[cfg(target_arch = "x86_64")]
mod packet;
mod scalar;
#[cfg(target_arch = "x86_64")]
mod sse;
#[cfg(target_arch = "x86_64")]
mod traverse;
mod walk;

pub(crate) use walk::{Entry, Stack};

use crate::bvh2::Bvh2;
use crate::fetch_triangle;
use glint_core::{Bounds3, Vec3};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Lanes of a triangle packet.
pub const PACKET: usize = 4;

/// A node with `N` child slots. `bounds[2a]` / `bounds[2a + 1]` hold the min / max along axis `a`
/// of every child; an empty slot has the empty box (`+inf`, `-inf`), which no ray meets.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct WideNode<const N: usize> {
    pub bounds: [[f32; N]; 6],
    /// Per slot: an inner node index, or `LEAF | packets << 27 | first packet` (0 packets: empty).
    pub child: [u32; N],
}
const _: () = assert!(size_of::<WideNode<4>>() == 128);
const _: () = assert!(size_of::<WideNode<8>>() == 224);

pub(crate) const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 27;
const FIRST_MASK: u32 = (1 << COUNT_SHIFT) - 1;
/// Most packets one leaf can reference.
pub(crate) const MAX_LEAF_PACKETS: usize = 15;
pub(crate) const EMPTY_SLOT: u32 = LEAF;

#[inline(always)]
pub(crate) fn leaf_packets(child: u32) -> std::ops::Range<usize> {
    let first = (child & FIRST_MASK) as usize;
    let count = ((child >> COUNT_SHIFT) & 0xf) as usize;
    first..first + count
}

impl<const N: usize> WideNode<N> {
    const EMPTY: Self = {
        let mut bounds = [[f32::INFINITY; N]; 6];
        let mut a = 0;
        while a < 3 {
            bounds[2 * a + 1] = [f32::NEG_INFINITY; N];
            a += 1;
        }
        Self { bounds, child: [EMPTY_SLOT; N] }
    };

    fn set_bounds(&mut self, slot: usize, b: &Bounds3) {
        for a in 0..3 {
            self.bounds[2 * a][slot] = b.min[a];
            self.bounds[2 * a + 1][slot] = b.max[a];
        }
    }

    pub fn slot_bounds(&self, slot: usize) -> Bounds3 {
        let v = |k: usize| Vec3::new(self.bounds[k][slot], self.bounds[k + 2][slot], self.bounds[k + 4][slot]);
        Bounds3::new(v(0), v(1))
    }
}

/// Four triangles with their vertices as SoA: `v[vertex][axis][lane]`; `prim` the original
/// triangle index per lane. Unused lanes repeat the leaf's last triangle.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(16))]
pub struct TriPacket {
    pub v: [[[f32; PACKET]; 3]; 3],
    pub prim: [u32; PACKET],
}
const _: () = assert!(size_of::<TriPacket>() == 160);

impl TriPacket {
    fn set_lane(&mut self, lane: usize, tri: Option<[[f32; 3]; 3]>, prim: u32) {
        let tri = tri.unwrap_or([[f32::NAN; 3]; 3]);
        for (vert, p) in tri.iter().enumerate() {
            for (a, &x) in p.iter().enumerate() {
                self.v[vert][a][lane] = x;
            }
        }
        self.prim[lane] = prim;
    }

    #[inline]
    pub(crate) fn lane(&self, lane: usize) -> [[f32; 3]; 3] {
        let v = |k: usize| [self.v[k][0][lane], self.v[k][1][lane], self.v[k][2][lane]];
        [v(0), v(1), v(2)]
    }

    fn bounds(&self) -> Bounds3 {
        let mut b = Bounds3::EMPTY;
        for lane in 0..PACKET {
            for p in self.lane(lane) {
                b = b.grow(Vec3::from_array(p));
            }
        }
        b
    }
}

/// Instruction sets the kernels are compiled for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// Portable Rust, any target: the oracle.
    Scalar,
    /// x86-64 baseline (4-wide only).
    Sse2,
    /// AVX2 + FMA, chosen by runtime detection.
    Avx2,
}

impl Isa {
    /// The best instruction set of this machine, detected once.
    pub fn detect() -> Isa {
        static ISA: OnceLock<Isa> = OnceLock::new();
        *ISA.get_or_init(|| {
            #[cfg(target_arch = "x86_64")]
            {
                if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
                    return Isa::Avx2;
                }
                Isa::Sse2
            }
            #[cfg(not(target_arch = "x86_64"))]
            Isa::Scalar
        })
    }
}

/// An `N`-wide BVH over one triangle mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct WideBvh<const N: usize> {
    pub(crate) nodes: Vec<WideNode<N>>,
    pub(crate) packets: Vec<TriPacket>,
    triangles: Vec<[u32; 3]>,
    bounds: Bounds3,
    depth: usize,
    leaves: usize,
}

pub type Bvh4 = WideBvh<4>;
pub type Bvh8 = WideBvh<8>;

impl<const N: usize> WideBvh<N> {
    /// Collapses a binary BVH built over `triangles` into `N`-wide nodes and packs the leaves.
    /// Binary leaves must hold at most `4 · MAX_LEAF_PACKETS` triangles (the builder's limit
    /// is 32).
    pub fn from_bvh2(bvh2: &Bvh2, positions: &[Vec3], triangles: &[[u32; 3]]) -> Self {
        let mut out = Self {
            nodes: Vec::new(),
            packets: Vec::new(),
            triangles: triangles.par_iter().copied().collect(),
            bounds: bvh2.bounds(),
            depth: 0,
            leaves: 0,
        };
        let b2 = bvh2.nodes();
        if b2.is_empty() {
            return out;
        }
        let prims = bvh2.prim_indices();
        // The tree's shape first, on one thread, with no triangle data: each leaf gets its
        // packets' slots (a packet is named by the run of primitive ids it will hold); then
        // every thread fills the packets straight into their places.
        let mut runs: Vec<(u32, u32)> = Vec::new();
        let mut leaf_ref = |out: &mut Self, n: usize| {
            let node = &b2[n];
            let first = runs.len();
            let end = node.first + node.count;
            runs.extend((node.first..end).step_by(PACKET).map(|start| (start, (end - start).min(PACKET as u32))));
            out.leaves += 1;
            let count = (runs.len() - first).min(MAX_LEAF_PACKETS) as u32;
            LEAF | count << COUNT_SHIFT | first as u32
        };
        out.nodes.push(WideNode::EMPTY);
        if b2[0].is_leaf() {
            out.nodes[0].set_bounds(0, &b2[0].bounds);
            out.nodes[0].child[0] = leaf_ref(&mut out, 0);
            out.depth = 1;
        } else {
            // (binary node, wide node, depth)
            let mut work = vec![(0usize, 0usize, 1usize)];
            let mut kids: Vec<usize> = Vec::with_capacity(N);
            while let Some((b, w, depth)) = work.pop() {
                out.depth = out.depth.max(depth);
                kids.clear();
                kids.extend([b + 1, b2[b].first as usize]);
                while kids.len() < N {
                    let widest = kids.iter().enumerate().filter(|(_, k)| !b2[**k].is_leaf()).max_by(|x, y| {
                        b2[*x.1].bounds.half_area().total_cmp(&b2[*y.1].bounds.half_area()).then(y.0.cmp(&x.0))
                    });
                    let Some((i, &k)) = widest else { break };
                    kids[i] = k + 1;
                    kids.push(b2[k].first as usize);
                }
                // Largest box first: the any-hit walks take a node's children in slot order, and a
                // ray that meets several boxes is likelier to be stopped by a triangle of the
                // largest (Sponza's incoherent any-hit rays, the sky light's shadow rays, 7.8 ->
                // 8.4 Mrays/s; its shadow rays toward a point above the roof 21.3 -> 26.3). The
                // closest-hit walks order by distance and do not notice. The nodes are still
                // stored in the collapse's order: storing them in slot order made Sponza's
                // Whitted frame 1.5 % slower (BENCHMARKS.md §13.12). Ties by binary node index.
                let mut by_area: Vec<usize> = (0..kids.len()).collect();
                by_area.sort_by(|&x, &y| {
                    b2[kids[y]]
                        .bounds
                        .half_area()
                        .total_cmp(&b2[kids[x]].bounds.half_area())
                        .then(kids[x].cmp(&kids[y]))
                });
                let mut slots = [0; N];
                for (slot, &i) in by_area.iter().enumerate() {
                    slots[i] = slot;
                }
                for (&slot, &k) in slots.iter().zip(kids.iter()) {
                    out.nodes[w].set_bounds(slot, &b2[k].bounds);
                    out.nodes[w].child[slot] = if b2[k].is_leaf() {
                        leaf_ref(&mut out, k)
                    } else {
                        out.nodes.push(WideNode::EMPTY);
                        let idx = out.nodes.len() - 1;
                        work.push((k, idx, depth + 1));
                        idx as u32
                    };
                }
            }
        }
        out.packets = runs
            .par_iter()
            .map(|&(start, len)| {
                let ids = &prims[start as usize..(start + len) as usize];
                let mut p = TriPacket { v: [[[0.0; PACKET]; 3]; 3], prim: [0; PACKET] };
                for lane in 0..PACKET {
                    // Short packets repeat their last triangle.
                    let id = ids[lane.min(ids.len() - 1)];
                    p.set_lane(lane, fetch_triangle(positions, triangles, id), id);
                }
                p
            })
            .collect();
        out
    }

    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }
    pub fn nodes(&self) -> &[WideNode<N>] {
        &self.nodes
    }
    pub fn packets(&self) -> &[TriPacket] {
        &self.packets
    }
    pub fn depth(&self) -> usize {
        self.depth
    }
    /// A tree of one node (every child a leaf: up to `N` leaves, a few dozen triangles), where
    /// the 8-ray queries walk every octant group as a packet, coherent or not
    /// (`packet.rs`).
    #[must_use]
    pub fn packs_any_rays(&self) -> bool {
        self.nodes.len() == 1
    }
    pub fn leaf_count(&self) -> usize {
        self.leaves
    }
    pub fn node_bytes(&self) -> usize {
        std::mem::size_of_val(self.nodes.as_slice())
    }

    /// Same triangles, moved vertices: rewrites the packets and recomputes every child box
    /// bottom-up (children always have larger indices than their parent).
    pub fn refit(&mut self, positions: &[Vec3]) {
        let tris = &self.triangles;
        self.packets.par_iter_mut().for_each(|p| {
            for lane in 0..PACKET {
                let id = p.prim[lane];
                p.set_lane(lane, fetch_triangle(positions, tris, id), id);
            }
        });
        let mut node_box = vec![Bounds3::EMPTY; self.nodes.len()];
        for i in (0..self.nodes.len()).rev() {
            let mut total = Bounds3::EMPTY;
            for slot in 0..N {
                let c = self.nodes[i].child[slot];
                let b = if c & LEAF != 0 {
                    let r = leaf_packets(c);
                    if r.is_empty() {
                        continue;
                    }
                    self.packets[r].iter().fold(Bounds3::EMPTY, |b, p| b.union(p.bounds()))
                } else {
                    node_box[c as usize]
                };
                self.nodes[i].set_bounds(slot, &b);
                total = total.union(b);
            }
            node_box[i] = total;
        }
        self.bounds = node_box.first().copied().unwrap_or(Bounds3::EMPTY);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BuildOptions;
    use crate::procedural::{Rng, icosphere, triangle_soup};
    use crate::test_util::{random_rays, same_hit};
    use crate::{brute_force_intersect, brute_force_occluded};
    use glint_core::Ray;
    use proptest::prelude::*;

    fn isas() -> Vec<Isa> {
        let mut v = vec![Isa::Scalar];
        #[cfg(target_arch = "x86_64")]
        v.push(Isa::Sse2);
        if Isa::detect() == Isa::Avx2 {
            v.push(Isa::Avx2);
        }
        v
    }

    fn check(positions: &[Vec3], triangles: &[[u32; 3]], b4: &Bvh4, b8: &Bvh8, seed: u64) {
        for (i, ray) in random_rays(96, seed).iter().enumerate() {
            let want = brute_force_intersect(positions, triangles, ray);
            let occ = brute_force_occluded(positions, triangles, ray);
            for isa in isas() {
                let g4 = b4.intersect_isa(isa, ray);
                assert!(same_hit(g4, want), "{isa:?} ray {i} {ray:?}: bvh4 {g4:?} brute {want:?}");
                let g8 = b8.intersect_isa(isa, ray);
                assert!(same_hit(g8, want), "{isa:?} ray {i} {ray:?}: bvh8 {g8:?} brute {want:?}");
                assert_eq!(b4.occluded_isa(isa, ray), occ, "{isa:?} bvh4 ray {i} {ray:?}");
                assert_eq!(b8.occluded_isa(isa, ray), occ, "{isa:?} bvh8 ray {i} {ray:?}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        #[test]
        fn wide_layouts_match_brute_force(n in 1usize..300, size in 0.01f32..0.8, seed in any::<u64>(), leaf in 1usize..20) {
            let m = triangle_soup(n, size, seed);
            let opts = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
            let b2 = Bvh2::build(&m.positions, &m.triangles, &opts);
            let b4 = Bvh4::from_bvh2(&b2, &m.positions, &m.triangles);
            let b8 = Bvh8::from_bvh2(&b2, &m.positions, &m.triangles);
            check(&m.positions, &m.triangles, &b4, &b8, seed ^ 3);
        }

        #[test]
        fn wide_refit_matches_brute_force(n in 1usize..200, seed in any::<u64>()) {
            let m = triangle_soup(n, 0.2, seed);
            let b2 = Bvh2::build(&m.positions, &m.triangles, &BuildOptions::default());
            let mut b4 = Bvh4::from_bvh2(&b2, &m.positions, &m.triangles);
            let mut b8 = Bvh8::from_bvh2(&b2, &m.positions, &m.triangles);
            let mut rng = Rng::new(seed);
            let moved: Vec<Vec3> = m.positions.iter().map(|p| *p + (rng.next_vec3() - 0.5) * 0.5).collect();
            b4.refit(&moved);
            b8.refit(&moved);
            check(&moved, &m.triangles, &b4, &b8, seed ^ 4);
        }
    }

    #[test]
    fn every_kernel_is_watertight() {
        let ico = icosphere(4);
        let b2 = Bvh2::build(&ico.positions, &ico.triangles, &BuildOptions::default());
        let b4 = Bvh4::from_bvh2(&b2, &ico.positions, &ico.triangles);
        let b8 = Bvh8::from_bvh2(&b2, &ico.positions, &ico.triangles);
        for isa in isas() {
            crate::test_util::shoot_at_edges(&ico, 100_000, 3, |r| {
                (b4.intersect_isa(isa, r).is_some(), b4.occluded_isa(isa, r))
            });
            crate::test_util::shoot_at_edges(&ico, 100_000, 4, |r| {
                (b8.intersect_isa(isa, r).is_some(), b8.occluded_isa(isa, r))
            });
        }
    }

    #[test]
    fn every_triangle_is_in_one_leaf_lane() {
        let m = icosphere(3);
        let b2 = Bvh2::build(&m.positions, &m.triangles, &BuildOptions::default());
        let b8 = Bvh8::from_bvh2(&b2, &m.positions, &m.triangles);
        let mut seen = vec![false; m.triangles.len()];
        for p in b8.packets() {
            for id in p.prim {
                seen[id as usize] = true;
            }
        }
        assert!(seen.iter().all(|&s| s));
        assert!(b8.node_bytes() < 32 * m.triangles.len());
    }

    #[test]
    fn vertex_aimed_rays_take_the_exact_fallback_in_every_kernel() {
        // Rays through shared vertices make edge functions exactly zero: the SIMD kernels hand
        // those lanes to the scalar f64 path. Results must equal the scalar kernel's bit for bit.
        let m = icosphere(2);
        let b2 = Bvh2::build(&m.positions, &m.triangles, &BuildOptions::default());
        let b4 = Bvh4::from_bvh2(&b2, &m.positions, &m.triangles);
        let b8 = Bvh8::from_bvh2(&b2, &m.positions, &m.triangles);
        let mut rng = Rng::new(1);
        for (i, &v) in m.positions.iter().enumerate() {
            let origin = v * 3.0 + (rng.next_vec3() - 0.5) * 0.1;
            let ray = Ray::new(origin, v - origin);
            let want = b4.intersect_isa(Isa::Scalar, &ray).map(|h| h.t);
            assert!(want.is_some(), "vertex {i}");
            for isa in isas() {
                assert_eq!(b4.intersect_isa(isa, &ray).map(|h| h.t), want, "{isa:?} vertex {i}");
                assert_eq!(b8.intersect_isa(isa, &ray).map(|h| h.t), want, "{isa:?} vertex {i}");
                assert!(b4.occluded_isa(isa, &ray) && b8.occluded_isa(isa, &ray));
            }
        }
    }
}
