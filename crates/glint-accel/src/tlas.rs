//! The top level of a two-level BVH (Wald, Benthin, Slusallek, "Distributed Interactive Ray
//! Tracing of Dynamic Scenes", 2003): a BVH over the world-space boxes of object instances, cheap
//! enough to rebuild every frame, whose leaves call back into the caller. The caller transforms
//! the ray into the instance's object space and traces that object's own [`crate::MeshBvh`] (or
//! analytic shape); this crate never sees transforms or materials.

use crate::build::BuildOptions;
use crate::bvh2::{Bvh2, FAR_SCALE, ray_is_traceable};
use glint_core::{Bounds3, Ray, Vec4};

/// Up to this many instances (two SSE vectors per coordinate) the boxes are tested all at once (a flat, vectorisable pass over
/// SoA arrays) instead of walking a tree: for the handful of objects of a classic Whitted scene
/// that is several times cheaper than a traversal with its stack.
const FLAT_LIMIT: usize = 8;

/// Top-level BVH over instance boxes (index = instance id).
#[derive(Clone, Debug)]
pub struct Tlas {
    kind: Kind,
    bounds: Bounds3,
}

// The flat variant is stored inline on purpose: no pointer to chase per ray.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug)]
enum Kind {
    Flat(FlatBoxes),
    Tree(Bvh2),
}

/// Instance boxes as structure-of-arrays in 4-lane vectors (SSE2 is baseline on x86-64: no
/// run-time detection needed); empty and non-finite boxes are dropped at build time.
#[derive(Clone, Debug)]
struct FlatBoxes {
    min: [[Vec4; GROUPS]; 3],
    max: [[Vec4; GROUPS]; 3],
    id: [u32; FLAT_LIMIT],
    len: usize,
}

const GROUPS: usize = FLAT_LIMIT / 4;

impl FlatBoxes {
    fn new(boxes: &[Bounds3]) -> Self {
        // Padding lanes hold an inverted box (min +inf, max -inf) that no ray can enter.
        let mut min = [[f32::INFINITY; FLAT_LIMIT]; 3];
        let mut max = [[f32::NEG_INFINITY; FLAT_LIMIT]; 3];
        let mut id = [0u32; FLAT_LIMIT];
        let mut len = 0;
        for (i, b) in boxes.iter().enumerate() {
            if b.is_empty() || !b.min.is_finite() || !b.max.is_finite() {
                continue;
            }
            for a in 0..3 {
                min[a][len] = b.min[a];
                max[a][len] = b.max[a];
            }
            id[len] = i as u32;
            len += 1;
        }
        let pack = |v: &[f32; FLAT_LIMIT]| std::array::from_fn(|g| Vec4::from_slice(&v[g * 4..g * 4 + 4]));
        FlatBoxes { min: min.each_ref().map(pack), max: max.each_ref().map(pack), id, len }
    }

    /// Entry distances of every box the ray meets within `[tmin, tmax]` (nearest first when
    /// `sorted`). The same conservative slab test as the tree (`bvh2::BoxRay::hit`: exact
    /// reciprocal, the far planes' scaled by `FAR_SCALE`; Ize 2013). `_mm_max_ps(n, t)` /
    /// `_mm_min_ps(f, t)` return their second operand when the first is NaN (a ray parallel to
    /// a slab and lying on it): the slab stays open.
    #[inline]
    fn hits(&self, ray: &Ray, tmax: f32, sorted: bool, out: &mut [(f32, u32); FLAT_LIMIT]) -> usize {
        let inv = [1.0 / ray.dir.x, 1.0 / ray.dir.y, 1.0 / ray.dir.z];
        let inv_far = inv.map(|i| i * FAR_SCALE);
        let org = [ray.origin.x, ray.origin.y, ray.origin.z];
        let mut count = 0;
        for g in 0..GROUPS {
            if g * 4 >= self.len {
                break;
            }
            let mut tn = Vec4::splat(ray.tmin);
            let mut tf = Vec4::splat(tmax);
            for a in 0..3 {
                let (lo, hi) =
                    if inv[a] < 0.0 { (self.max[a][g], self.min[a][g]) } else { (self.min[a][g], self.max[a][g]) };
                let o = Vec4::splat(org[a]);
                tn = ((lo - o) * Vec4::splat(inv[a])).max(tn);
                tf = ((hi - o) * Vec4::splat(inv_far[a])).min(tf);
            }
            let mut mask = tn.cmple(tf).bitmask();
            let tn = tn.to_array();
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                let (t, id) = (tn[lane], self.id[g * 4 + lane]);
                // Insertion by entry distance (ties keep instance order: deterministic).
                let mut j = count;
                while sorted && j > 0 && out[j - 1].0 > t {
                    out[j] = out[j - 1];
                    j -= 1;
                }
                out[j] = (t, id);
                count += 1;
            }
        }
        count
    }
}

impl Tlas {
    /// Builds over world-space instance boxes; empty or non-finite boxes are never visited.
    pub fn build(instance_bounds: &[Bounds3]) -> Tlas {
        let bounds = instance_bounds
            .iter()
            .filter(|b| !b.is_empty() && b.min.is_finite() && b.max.is_finite())
            .fold(Bounds3::EMPTY, |a, b| a.union(*b));
        let kind = if instance_bounds.len() <= FLAT_LIMIT {
            Kind::Flat(FlatBoxes::new(instance_bounds))
        } else {
            let options = BuildOptions { max_leaf_size: 1, bins: 16, ..BuildOptions::default() };
            Kind::Tree(Bvh2::build_from_boxes(instance_bounds, &options))
        };
        Tlas { kind, bounds }
    }

    /// Visits instances whose box the ray meets, nearest box first (a lone instance is visited
    /// without the box test: its own BVH tests its root). `leaf(instance, tmax_so_far)`
    /// returns `Some(t)` when it found a hit closer than `tmax_so_far`; that shrinks the ray.
    #[inline]
    pub fn intersect(&self, ray: &Ray, mut leaf: impl FnMut(u32, f32) -> Option<f32>) {
        match &self.kind {
            Kind::Tree(bvh) => bvh.traverse_closest(ray, leaf),
            Kind::Flat(flat) => {
                if !ray_is_traceable(ray) {
                    return;
                }
                if flat.len == 1 {
                    // One instance: its own BVH tests its root box; a second test here is waste.
                    leaf(flat.id[0], ray.tmax);
                    return;
                }
                let mut order = [(0.0f32, 0u32); FLAT_LIMIT];
                let n = flat.hits(ray, ray.tmax, true, &mut order);
                let mut tmax = ray.tmax;
                for &(entry, id) in &order[..n] {
                    if entry > tmax {
                        break;
                    }
                    if let Some(t) = leaf(id, tmax) {
                        tmax = tmax.min(t);
                    }
                }
            }
        }
    }

    /// Any-hit: true as soon as `leaf(instance)` returns true.
    #[inline]
    pub fn occluded(&self, ray: &Ray, mut leaf: impl FnMut(u32) -> bool) -> bool {
        match &self.kind {
            Kind::Tree(bvh) => bvh.traverse_any(ray, leaf),
            Kind::Flat(flat) => {
                if !ray_is_traceable(ray) {
                    return false;
                }
                if flat.len == 1 {
                    return leaf(flat.id[0]);
                }
                let mut order = [(0.0f32, 0u32); FLAT_LIMIT];
                let n = flat.hits(ray, ray.tmax, false, &mut order);
                order[..n].iter().any(|&(_, id)| leaf(id))
            }
        }
    }

    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }

    /// The binary tree underneath, when the instances are too many for the flat test.
    pub fn bvh(&self) -> Option<&Bvh2> {
        match &self.kind {
            Kind::Tree(b) => Some(b),
            Kind::Flat(_) => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{Rng, triangle_soup};
    use crate::{BuildOptions, MeshBvh, brute_force_intersect, brute_force_occluded};
    use glint_core::{Affine3A, Quat, Vec3};

    #[test]
    fn instances_match_brute_force_over_all_instances() {
        // 40 and 12 instances walk the tree; 8 and 1 take the flat path.
        for count in [40, 12, 8, 1] {
            instances_match_brute_force(count);
        }
    }

    fn instances_match_brute_force(count: usize) {
        let meshes = [triangle_soup(60, 0.3, 1), triangle_soup(200, 0.1, 2), triangle_soup(1, 0.8, 3)];
        let blases: Vec<MeshBvh> =
            meshes.iter().map(|m| MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::default())).collect();
        let mut rng = Rng::new(9);
        let instances: Vec<(usize, Affine3A)> = (0..count)
            .map(|i| {
                let rot = Quat::from_axis_angle(rng.next_dir(), rng.next_f32() * 6.0);
                let scale = Vec3::splat(0.5 + rng.next_f32());
                let tr = (rng.next_vec3() - 0.5) * 6.0;
                (i % meshes.len(), Affine3A::from_scale_rotation_translation(scale, rot, tr))
            })
            .collect();
        let boxes: Vec<Bounds3> = instances.iter().map(|(m, xf)| blases[*m].bounds().transformed(xf)).collect();
        let tlas = Tlas::build(&boxes);
        assert_eq!(tlas.bvh().is_some(), count > FLAT_LIMIT);
        let local = |inst: usize, ray: &Ray, tmax: f32| {
            let inv = instances[inst].1.inverse();
            Ray::segment(inv.transform_point3(ray.origin), inv.transform_vector3(ray.dir), ray.tmin, tmax)
        };
        for i in 0..3000 {
            let origin = (rng.next_vec3() - 0.5) * 10.0;
            let ray = Ray::segment(origin, rng.next_dir(), 0.0, if i % 4 == 0 { 3.0 } else { f32::INFINITY });
            // Oracle: brute force over every instance in object space.
            let mut want: Option<(f32, usize, u32)> = None;
            for (k, (m, _)) in instances.iter().enumerate() {
                let r = local(k, &ray, ray.tmax);
                if let Some(h) = brute_force_intersect(&meshes[*m].positions, &meshes[*m].triangles, &r)
                    && want.is_none_or(|w| h.t < w.0)
                {
                    want = Some((h.t, k, h.prim));
                }
            }
            let mut got: Option<(f32, usize, u32)> = None;
            tlas.intersect(&ray, |inst, tmax| {
                let k = inst as usize;
                let h = blases[instances[k].0].intersect(&local(k, &ray, tmax))?;
                got = Some((h.t, k, h.prim));
                Some(h.t)
            });
            match (got, want) {
                (None, None) => {}
                (Some(g), Some(w)) => assert_eq!(g.0, w.0, "ray {i}: {g:?} vs {w:?}"),
                _ => panic!("ray {i}: tlas {got:?} brute {want:?}"),
            }
            let occ_want = instances.iter().enumerate().any(|(k, (m, _))| {
                brute_force_occluded(&meshes[*m].positions, &meshes[*m].triangles, &local(k, &ray, ray.tmax))
            });
            let occ = tlas.occluded(&ray, |inst| {
                let k = inst as usize;
                blases[instances[k].0].occluded(&local(k, &ray, ray.tmax))
            });
            assert_eq!(occ, occ_want, "ray {i}");
        }
    }

    #[test]
    fn empty_tlas() {
        let tlas = Tlas::build(&[]);
        let ray = Ray::new(Vec3::ZERO, Vec3::X);
        let mut called = false;
        tlas.intersect(&ray, |_, _| {
            called = true;
            None
        });
        assert!(!called);
        assert!(!tlas.occluded(&ray, |_| true));
    }
}
