//! [`MeshBvh`]: the production acceleration structure of one triangle mesh — the binned SAH
//! binary tree ([`crate::build`]) collapsed into a wide layout ([`crate::wide`]) and traversed
//! by the fastest kernel of the machine.

use crate::build::{BuildOptions, Width};
use crate::bvh2::Bvh2;
use crate::wide::{Bvh4, Bvh8, Isa, one_node};
use crate::{BvhStats, Hit};
use glint_core::{Bounds3, Ray, Vec3};
use std::time::Instant;

#[derive(Clone, Debug, PartialEq)]
enum Layout {
    Four(Bvh4),
    Eight(Bvh8),
}

impl Layout {
    /// Nodes, leaves, depth and node bytes.
    fn shape(&self) -> (usize, usize, usize, usize) {
        match self {
            Layout::Four(b) => (b.nodes().len(), b.leaf_count(), b.depth(), b.node_bytes()),
            Layout::Eight(b) => (b.nodes().len(), b.leaf_count(), b.depth(), b.node_bytes()),
        }
    }

    fn refit(&mut self, positions: &[Vec3]) {
        match self {
            Layout::Four(b) => b.refit(positions),
            Layout::Eight(b) => b.refit(positions),
        }
    }
}

/// BVH over one triangle mesh. `Hit::prim` is the index into the `triangles` given to `build`.
#[derive(Clone, Debug)]
pub struct MeshBvh {
    /// The tree the closest-hit queries walk (and the any-hit ones, without `any_hit`).
    layout: Layout,
    /// With spatial splits ([`BuildOptions::spatial_splits`]), the any-hit queries' tree: the
    /// same mesh without them. Spatial splits cut the big triangles (floors, walls) into
    /// pieces deep in the tree, where an object split keeps them whole in leaves near the
    /// root; an any-hit ray is stopped by whichever triangle it meets first, and finds those
    /// leaves after a few nodes. Sponza: closest hits of diffuse rays +20 %, any hits −28 %
    /// on the spatial tree (BENCHMARKS.md §13.14), so each query walks the tree that suits it.
    any_hit: Option<Layout>,
    isa: Isa,
    stats: BvhStats,
}

impl MeshBvh {
    /// Builds over `triangles` (vertex indices into `positions`). Triangles with an out-of-range
    /// index or a non-finite vertex are never hit (also after a refit that makes them valid).
    pub fn build(positions: &[Vec3], triangles: &[[u32; 3]], options: &BuildOptions) -> MeshBvh {
        let start = Instant::now();
        let object_options = BuildOptions { spatial_splits: 0.0, ..options.clone() };
        let mut bvh2 = Bvh2::build(positions, triangles, &object_options);
        let isa = Isa::detect();
        let width = match options.width {
            Width::Auto => Width::preferred(isa),
            w => w,
        };
        let n = if width == Width::Eight { 8 } else { 4 };
        // A tree of one node: its leaves as the walks' cost would choose them
        // (`wide::one_node`), where that costs less than the builder's.
        if bvh2.leaf_count() > 1 && bvh2.leaf_count() <= n {
            let fine_options = BuildOptions { max_leaf_size: 1, traversal_cost: 0.0, ..object_options.clone() };
            let fine = Bvh2::build(positions, triangles, &fine_options);
            let boxes: Vec<Bounds3> =
                (0..triangles.len()).map(|i| crate::build::triangle_box(positions, triangles, i)).collect();
            if let Some((cut, cost)) =
                one_node::best_leaves(&fine, &boxes, n, options.traversal_cost, options.intersection_cost)
                && cost < one_node::leaf_cost(&bvh2)
            {
                bvh2 = cut;
            }
        }
        let layout_of = |bvh2: &Bvh2| match width {
            Width::Eight => Layout::Eight(Bvh8::from_bvh2(bvh2, positions, triangles)),
            _ => Layout::Four(Bvh4::from_bvh2(bvh2, positions, triangles)),
        };
        // Spatial splits for a tree of more than one node (one node's leaves are chosen above).
        let spatial = options.spatial_splits > 0.0 && bvh2.leaf_count() > n;
        let (layout, any_hit) = match spatial {
            true => {
                let object = layout_of(&bvh2);
                bvh2 = Bvh2::build(positions, triangles, options);
                (layout_of(&bvh2), Some(object))
            }
            false => (layout_of(&bvh2), None),
        };
        let (nodes, leaves, depth, _) = layout.shape();
        let node_bytes = layout.shape().3 + any_hit.as_ref().map_or(0, |l| l.shape().3);
        let stats = BvhStats {
            nodes,
            leaves,
            depth,
            node_bytes,
            sah_cost: bvh2.sah_cost(),
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        MeshBvh { layout, any_hit, isa, stats }
    }

    /// The tree the any-hit queries walk.
    #[inline]
    fn any_hit_layout(&self) -> &Layout {
        self.any_hit.as_ref().unwrap_or(&self.layout)
    }

    /// Closest hit in `(tmin, tmax]`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match &self.layout {
            Layout::Four(b) => b.intersect_isa(self.isa, ray),
            Layout::Eight(b) => b.intersect_isa(self.isa, ray),
        }
    }

    /// Any hit in `(tmin, tmax]`; stops at the first.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        match self.any_hit_layout() {
            Layout::Four(b) => b.occluded_isa(self.isa, ray),
            Layout::Eight(b) => b.occluded_isa(self.isa, ray),
        }
    }

    /// Closest hits of up to 8 rays (e.g. a 4×2 pixel tile of primary rays, or shadow rays
    /// toward one light); `out[i]` is what `intersect(&rays[i])` returns, bit for bit (same t,
    /// prim, u, v). Coherent rays share the tree walk (packet traversal, 8-wide layout with
    /// AVX2); otherwise, and for a 4-wide layout, one single-ray query per ray.
    pub fn intersect8(&self, rays: &[Ray; 8], out: &mut [Option<Hit>; 8]) {
        match &self.layout {
            Layout::Four(b) => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = b.intersect_isa(self.isa, r);
                }
            }
            Layout::Eight(b) => b.intersect8_isa(self.isa, rays, out),
        }
    }

    /// Whether [`MeshBvh::intersect8`] and [`MeshBvh::occluded8`] walk any rays of one
    /// direction octant together, coherent or not (a tree of one node, 8-wide, AVX2): their
    /// leaves then test triangles against the rays in lanes when the rays also share their
    /// dominant axis (the watertight test's axis permutation), so a caller that can order its
    /// rays does best to group them by octant and dominant axis
    /// ([`crate::primitives::dominant_axis`]).
    #[must_use]
    pub fn packs_any_rays(&self) -> bool {
        match &self.layout {
            Layout::Four(_) => false,
            Layout::Eight(b) => self.isa == Isa::Avx2 && Isa::detect() == Isa::Avx2 && b.packs_any_rays(),
        }
    }

    /// Any hits of up to 8 rays: `out[i] == occluded(&rays[i])`.
    pub fn occluded8(&self, rays: &[Ray; 8], out: &mut [bool; 8]) {
        match self.any_hit_layout() {
            Layout::Four(b) => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = b.occluded_isa(self.isa, r);
                }
            }
            Layout::Eight(b) => b.occluded8_isa(self.isa, rays, out),
        }
    }

    /// Same triangles, moved vertices: recomputes boxes and leaf data without rebuilding.
    pub fn refit(&mut self, positions: &[Vec3]) {
        self.layout.refit(positions);
        if let Some(any_hit) = &mut self.any_hit {
            any_hit.refit(positions);
        }
    }

    pub fn bounds(&self) -> Bounds3 {
        match &self.layout {
            Layout::Four(b) => b.bounds(),
            Layout::Eight(b) => b.bounds(),
        }
    }

    pub fn stats(&self) -> BvhStats {
        self.stats
    }

    /// Node width of the layout in use (4 or 8).
    pub fn width(&self) -> usize {
        match &self.layout {
            Layout::Four(_) => 4,
            Layout::Eight(_) => 8,
        }
    }

    /// Node arrays and leaf data equal (the determinism test).
    #[cfg(test)]
    pub(crate) fn same_layout(&self, other: &MeshBvh) -> bool {
        self.layout == other.layout && self.any_hit == other.any_hit
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{Rng, displaced_sphere, icosphere, tessellated_cube, triangle_soup};
    use crate::test_util::{random_rays, same_hit, shoot_at_edges};
    use crate::{brute_force_intersect, brute_force_occluded};
    use proptest::prelude::*;

    fn check_against_brute_force(positions: &[Vec3], triangles: &[[u32; 3]], bvh: &MeshBvh, seed: u64) {
        let bvh2 = Bvh2::build(positions, triangles, &BuildOptions::default());
        for (i, ray) in random_rays(96, seed).iter().enumerate() {
            let want = brute_force_intersect(positions, triangles, ray);
            let got = bvh.intersect(ray);
            assert!(same_hit(got, want), "ray {i} {ray:?}: bvh {got:?} brute {want:?}");
            let got2 = bvh2.intersect(positions, triangles, ray);
            assert!(same_hit(got2, want), "ray {i} {ray:?}: bvh2 {got2:?} brute {want:?}");
            let occ = brute_force_occluded(positions, triangles, ray);
            assert_eq!(bvh.occluded(ray), occ, "ray {i} {ray:?}");
            assert_eq!(bvh2.occluded(positions, triangles, ray), occ, "ray {i} {ray:?}");
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(96))]
        #[test]
        fn random_soups_match_brute_force(n in 1usize..160, size in 0.01f32..0.8, seed in any::<u64>(), leaf in 1usize..9) {
            let m = triangle_soup(n, size, seed);
            let opts = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
            let bvh = MeshBvh::build(&m.positions, &m.triangles, &opts);
            check_against_brute_force(&m.positions, &m.triangles, &bvh, seed ^ 1);
        }

        #[test]
        fn spatial_split_trees_match_brute_force(n in 1usize..400, size in 0.01f32..0.9, seed in any::<u64>(), leaf in 1usize..9) {
            let m = triangle_soup(n, size, seed);
            let opts = BuildOptions { max_leaf_size: leaf, spatial_splits: 1.0, ..BuildOptions::default() };
            let bvh = MeshBvh::build(&m.positions, &m.triangles, &opts);
            check_against_brute_force(&m.positions, &m.triangles, &bvh, seed ^ 3);
            let mut rng = Rng::new(seed ^ 5);
            let moved: Vec<Vec3> = m.positions.iter().map(|p| *p + (rng.next_vec3() - 0.5) * 0.4).collect();
            let mut refitted = bvh.clone();
            refitted.refit(&moved);
            check_against_brute_force(&moved, &m.triangles, &refitted, seed ^ 4);
        }

        #[test]
        fn refit_matches_brute_force(n in 1usize..120, seed in any::<u64>()) {
            let m = triangle_soup(n, 0.3, seed);
            let mut bvh = MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::default());
            let mut rng = Rng::new(seed ^ 7);
            let moved: Vec<Vec3> = m.positions.iter().map(|p| *p + (rng.next_vec3() - 0.5) * 0.4).collect();
            bvh.refit(&moved);
            check_against_brute_force(&moved, &m.triangles, &bvh, seed ^ 2);
        }
    }

    #[test]
    fn empty_and_single_triangle() {
        let empty = MeshBvh::build(&[], &[], &BuildOptions::default());
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        assert!(empty.intersect(&ray).is_none());
        assert!(!empty.occluded(&ray));
        assert!(empty.bounds().is_empty());
        let p = [Vec3::new(0.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(0.0, 1.0, -1.0)];
        let one = MeshBvh::build(&p, &[[0, 1, 2]], &BuildOptions::default());
        let hit = one.intersect(&Ray::new(Vec3::new(0.2, 0.2, 0.0), -Vec3::Z)).expect("hit");
        assert_eq!((hit.prim, hit.t), (0, 1.0));
        // Invalid indices and NaN vertices are never hit and do not panic.
        let bad = MeshBvh::build(&p, &[[0, 1, 7], [0, 1, 2]], &BuildOptions::default());
        assert_eq!(bad.intersect(&Ray::new(Vec3::new(0.2, 0.2, 0.0), -Vec3::Z)).map(|h| h.prim), Some(1));
        let mut nan = p.to_vec();
        nan.push(Vec3::NAN);
        let bad = MeshBvh::build(&nan, &[[0, 1, 3], [3, 3, 3]], &BuildOptions::default());
        assert!(bad.intersect(&Ray::new(Vec3::new(0.2, 0.2, 0.0), -Vec3::Z)).is_none());
        // A NaN ray.
        assert!(one.intersect(&Ray::new(Vec3::NAN, -Vec3::Z)).is_none());
        assert!(!one.occluded(&Ray::new(Vec3::ZERO, Vec3::NAN)));
    }

    #[test]
    fn degenerate_inputs_build_and_traverse() {
        // All triangles at one point.
        let positions = vec![Vec3::ONE; 3];
        let triangles = vec![[0, 1, 2]; 5000];
        let bvh = MeshBvh::build(&positions, &triangles, &BuildOptions::default());
        assert!(bvh.intersect(&Ray::new(Vec3::ZERO, Vec3::ONE)).is_none());
        // Many coincident copies of one triangle: some copy is hit at the right distance.
        let positions = vec![Vec3::new(0.0, 0.0, -2.0), Vec3::new(1.0, 0.0, -2.0), Vec3::new(0.0, 1.0, -2.0)];
        let triangles = vec![[0, 1, 2]; 3000];
        let bvh = MeshBvh::build(&positions, &triangles, &BuildOptions::default());
        let ray = Ray::new(Vec3::new(0.25, 0.25, 0.0), -Vec3::Z);
        assert_eq!(bvh.intersect(&ray).map(|h| h.t), Some(2.0));
        assert!(bvh.occluded(&ray));
        assert!(bvh.stats().depth < 40);
    }

    #[test]
    fn closed_meshes_are_watertight() {
        let ico = icosphere(5);
        let cube = tessellated_cube(24);
        for m in [&ico, &cube] {
            let bvh = MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::default());
            shoot_at_edges(m, 600_000, 11, |r| (bvh.intersect(r).is_some(), bvh.occluded(r)));
        }
    }

    #[test]
    fn closed_meshes_are_watertight_with_spatial_splits() {
        // Rays aimed at edges and vertices, where a triangle's cut parts meet their planes.
        let options = BuildOptions { spatial_splits: 1.0, ..BuildOptions::default() };
        // Three spheres stretched 30 times along x, y and z, crossing at the centre (one mesh,
        // each part closed): long thin triangles whose boxes overlap, as in an atrium.
        let mut cross = crate::procedural::Mesh::default();
        for axis in 0..3 {
            let part = icosphere(3);
            let base = cross.positions.len() as u32;
            cross.positions.extend(part.positions.iter().map(|&p| {
                let mut q = p;
                q[axis] *= 30.0;
                q
            }));
            cross.triangles.extend(part.triangles.iter().map(|t| t.map(|v| v + base)));
        }
        let bvh = MeshBvh::build(&cross.positions, &cross.triangles, &options);
        let split = Bvh2::build(&cross.positions, &cross.triangles, &options);
        assert!(split.prim_indices().len() > cross.triangles.len(), "no spatial split");
        shoot_at_edges(&cross, 300_000, 12, |r| (bvh.intersect(r).is_some(), bvh.occluded(r)));
    }

    #[test]
    fn spatial_splits_keep_a_tree_without_them_for_any_hits() {
        let m = triangle_soup(3000, 0.5, 8);
        let bvh = MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::spatial());
        let plain = MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::default());
        assert!(bvh.any_hit.as_ref().is_some_and(|l| *l == plain.layout));
        assert!(bvh.layout != plain.layout);
        assert!(bvh.stats().node_bytes > plain.stats().node_bytes);
        // A tree of one node has no spatial splits and no second tree.
        let small = triangle_soup(6, 0.5, 8);
        assert!(MeshBvh::build(&small.positions, &small.triangles, &BuildOptions::spatial()).any_hit.is_none());
    }

    #[test]
    fn eight_ray_queries_equal_single_rays_for_every_width() {
        let m = displaced_sphere(20_000);
        for width in [Width::Auto, Width::Four, Width::Eight] {
            let bvh = MeshBvh::build(&m.positions, &m.triangles, &BuildOptions { width, ..BuildOptions::default() });
            let mut rng = Rng::new(3);
            for k in 0..200 {
                let origin = rng.next_dir() * 3.0;
                let aim = (rng.next_vec3() - 0.5) * 2.0 - origin;
                let rays: [Ray; 8] = std::array::from_fn(|i| {
                    let d = aim + Vec3::new((i % 4) as f32, (i / 4) as f32, 0.0) * 0.01;
                    if k % 3 == 0 { Ray::segment(origin, d, 0.0, 0.9) } else { Ray::new(origin, d) }
                });
                let mut hits = [None; 8];
                let mut occ = [false; 8];
                bvh.intersect8(&rays, &mut hits);
                bvh.occluded8(&rays, &mut occ);
                for i in 0..8 {
                    let want = bvh.intersect(&rays[i]);
                    let bits = |h: Option<Hit>| h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()));
                    assert_eq!(bits(hits[i]), bits(want), "{width:?} packet {k} lane {i}");
                    assert_eq!(occ[i], bvh.occluded(&rays[i]), "{width:?} packet {k} lane {i}");
                }
            }
        }
    }

    #[test]
    fn coincident_triangles_resolve_to_the_lowest_index_in_every_path() {
        // Equal distances are resolved by the lowest primitive index, whatever order the
        // traversal visits the copies in: single rays and packets agree with brute force.
        let positions = vec![Vec3::new(0.0, 0.0, -2.0), Vec3::new(1.0, 0.0, -2.0), Vec3::new(0.0, 1.0, -2.0)];
        let triangles = vec![[0, 1, 2]; 500];
        let bvh = MeshBvh::build(&positions, &triangles, &BuildOptions::default());
        let rays: [Ray; 8] = std::array::from_fn(|i| {
            Ray::new(Vec3::new(0.1 + 0.05 * (i % 4) as f32, 0.1 + 0.1 * (i / 4) as f32, 0.0), -Vec3::Z)
        });
        let mut hits = [None; 8];
        bvh.intersect8(&rays, &mut hits);
        for (r, h) in rays.iter().zip(hits) {
            assert_eq!(brute_force_intersect(&positions, &triangles, r).map(|h| h.prim), Some(0));
            assert_eq!(bvh.intersect(r).map(|h| h.prim), Some(0));
            assert_eq!(h.map(|h| h.prim), Some(0));
        }
    }

    #[test]
    fn bvh2_is_watertight() {
        let ico = icosphere(4);
        let b = Bvh2::build(&ico.positions, &ico.triangles, &BuildOptions::default());
        shoot_at_edges(&ico, 100_000, 5, |r| {
            (b.intersect(&ico.positions, &ico.triangles, r).is_some(), b.occluded(&ico.positions, &ico.triangles, r))
        });
    }

    #[test]
    fn build_is_deterministic_across_thread_counts() {
        let m = displaced_sphere(150_000);
        let opts = BuildOptions { parallel_threshold: 256, ..BuildOptions::spatial() };
        let build = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
            pool.install(|| {
                (Bvh2::build(&m.positions, &m.triangles, &opts), MeshBvh::build(&m.positions, &m.triangles, &opts))
            })
        };
        let (a2, am) = build(1);
        let (b2, bm) = build(2);
        assert!(a2 == b2, "binary trees differ");
        assert!(am.same_layout(&bm), "mesh BVH layouts differ");
    }
}
