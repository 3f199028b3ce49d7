//! The top level of a two-level BVH (Wald, Benthin, Slusallek, "Distributed Interactive Ray
//! Tracing of Dynamic Scenes", 2003): a BVH over the world-space boxes of object instances, cheap
//! enough to rebuild every frame, whose leaves call back into the caller. The caller transforms
//! the ray into the instance's object space and traces that object's own [`crate::MeshBvh`] (or
//! analytic shape); this crate never sees transforms or materials.

use crate::build::BuildOptions;
use crate::bvh2::Bvh2;
use glint_core::{Bounds3, Ray};

/// Top-level BVH over instance boxes (index = instance id).
#[derive(Clone, Debug)]
pub struct Tlas {
    bvh: Bvh2,
}

impl Tlas {
    /// Builds over world-space instance boxes; empty or non-finite boxes are never visited.
    pub fn build(instance_bounds: &[Bounds3]) -> Tlas {
        let options = BuildOptions { max_leaf_size: 1, bins: 16, ..BuildOptions::default() };
        Tlas { bvh: Bvh2::build_from_boxes(instance_bounds, &options) }
    }

    /// Visits instances whose box the ray meets, nearest box first. `leaf(instance, tmax_so_far)`
    /// returns `Some(t)` when it found a hit closer than `tmax_so_far`; that shrinks the ray.
    pub fn intersect(&self, ray: &Ray, leaf: impl FnMut(u32, f32) -> Option<f32>) {
        self.bvh.traverse_closest(ray, leaf);
    }

    /// Any-hit: true as soon as `leaf(instance)` returns true.
    pub fn occluded(&self, ray: &Ray, leaf: impl FnMut(u32) -> bool) -> bool {
        self.bvh.traverse_any(ray, leaf)
    }

    pub fn bounds(&self) -> Bounds3 {
        self.bvh.bounds()
    }

    /// The binary tree underneath (for statistics and tests).
    pub fn bvh(&self) -> &Bvh2 {
        &self.bvh
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
        let meshes = [triangle_soup(60, 0.3, 1), triangle_soup(200, 0.1, 2), triangle_soup(1, 0.8, 3)];
        let blases: Vec<MeshBvh> =
            meshes.iter().map(|m| MeshBvh::build(&m.positions, &m.triangles, &BuildOptions::default())).collect();
        let mut rng = Rng::new(9);
        let instances: Vec<(usize, Affine3A)> = (0..40)
            .map(|i| {
                let rot = Quat::from_axis_angle(rng.next_dir(), rng.next_f32() * 6.0);
                let scale = Vec3::splat(0.5 + rng.next_f32());
                let tr = (rng.next_vec3() - 0.5) * 6.0;
                (i % meshes.len(), Affine3A::from_scale_rotation_translation(scale, rot, tr))
            })
            .collect();
        let boxes: Vec<Bounds3> = instances.iter().map(|(m, xf)| blases[*m].bounds().transformed(xf)).collect();
        let tlas = Tlas::build(&boxes);
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
