//! Closest-hit queries (pipeline: integrators ask **World** what a ray hits): the sphere set,
//! the top-level BVH with its instances' BVHs, and the planes, nearest wins. Equal distances
//! resolve the same way in every kernel, so 8-ray queries equal single rays bit for bit.

use super::World;
use super::hit::SurfaceHit;
use super::instances::{Found, InstanceShape, transform_ray};
use super::merged::Merged;
use glint_accel::{MeshBvh, primitives};
use glint_core::Ray;

impl World {
    /// Closest hit along `ray` within `[ray.tmin, ray.tmax]`.
    #[must_use]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let (found, t) = self.closest(ray, false);
        self.surface_hit(ray, found, t)
    }

    /// [`World::intersect`] of 8 rays: one packet query where [`World::traces_packets`] (the
    /// same hits bit for bit; coherent rays, e.g. neighbouring pixels, gain), else ray by ray.
    pub fn intersect8(&self, rays: &[Ray; 8], out: &mut [Option<SurfaceHit>; 8]) {
        match self.lone_mesh() {
            Some(lone) => {
                let mut hits = [None; 8];
                lone.bvh.intersect8(rays, &mut hits);
                // Their surface data in lanes.
                let found = hits.map(|h| {
                    h.map(|hit| {
                        let (inst, prim) = lone.owner(hit.prim);
                        super::hits8::Found { inst, prim, hit }
                    })
                });
                self.mesh_hits8(rays, &found, out);
            }
            None => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.intersect(r);
                }
            }
        }
    }

    /// Distance to the closest hit, without computing shading data (traversal only: what the
    /// ray benchmarks time).
    #[must_use]
    pub fn hit_distance(&self, ray: &Ray) -> Option<f32> {
        match self.closest(ray, false) {
            (Found::None, _) => None,
            (_, t) => Some(t),
        }
    }

    /// The one mesh tree of a scene whose every surface is in it (no planes, no spheres): one
    /// untransformed mesh instance, or every instance merged ([`super::merged`]). There the
    /// 8-ray queries take the packet path of [`MeshBvh::intersect8`].
    pub(super) fn lone_mesh(&self) -> Option<LoneMesh<'_>> {
        if !self.planes.is_empty() {
            return None;
        }
        match (&self.merged, self.instances.as_slice()) {
            (Some(merged), _) if !self.tlas_used && self.sphere_instances.is_empty() => {
                Some(LoneMesh { bvh: &merged.bvh, merged: Some(merged) })
            }
            (None, [inst]) if inst.identity => match inst.shape {
                InstanceShape::Mesh(m) => self.blas.get(m).map(|bvh| LoneMesh { bvh, merged: None }),
                InstanceShape::Sphere { .. } => None,
            },
            _ => None,
        }
    }

    /// Whether [`World::hit_distance8`] and [`World::occluded8`] trace packets (true) or loop
    /// over single rays.
    #[must_use]
    pub fn traces_packets(&self) -> bool {
        self.lone_mesh().is_some()
    }

    /// Whether the 8-ray queries walk incoherent rays of one octant together too (one small
    /// tree: [`glint_accel::MeshBvh::packs_any_rays`]), so that callers who order their rays
    /// group them by octant and dominant axis.
    #[must_use]
    pub fn packs_any_rays(&self) -> bool {
        self.lone_mesh().is_some_and(|lone| lone.bvh.packs_any_rays())
    }

    /// [`World::hit_distance`] of up to 8 rays (coherent ones, e.g. a 4×2 pixel tile, gain):
    /// `out[i] == hit_distance(&rays[i])` bit for bit.
    pub fn hit_distance8(&self, rays: &[Ray; 8], out: &mut [Option<f32>; 8]) {
        match self.lone_mesh() {
            Some(lone) => {
                let mut hits = [None; 8];
                lone.bvh.intersect8(rays, &mut hits);
                for (o, h) in out.iter_mut().zip(hits) {
                    *o = h.map(|h| h.t);
                }
            }
            None => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.hit_distance(r);
                }
            }
        }
    }

    /// Closest hit; with `transparent_only`, instances and planes that are wholly opaque are
    /// skipped (used after an any-hit query has ruled them out).
    pub(super) fn closest(&self, ray: &Ray, transparent_only: bool) -> (Found, f32) {
        let mut found = Found::None;
        let mut tmax = ray.tmax;
        if transparent_only {
            // The rare path (transparent meshes in the scene): one sphere at a time.
            for &i in &self.sphere_instances {
                let inst = &self.instances[i as usize];
                if let (false, InstanceShape::Sphere { centre, radius }) = (inst.opaque, inst.shape)
                    && let Some(t) = primitives::intersect_sphere(&Ray { tmax, ..*ray }, centre, radius)
                {
                    found = Found::Instance { inst: i, prim: 0, u: 0.0, v: 0.0 };
                    tmax = t;
                }
            }
        } else if let Some((t, k)) = self.spheres.closest(ray) {
            found = Found::Instance { inst: self.sphere_instances[k as usize], prim: 0, u: 0.0, v: 0.0 };
            tmax = t;
        }
        if !transparent_only
            && let Some(merged) = &self.merged
            && let Some(h) = merged.bvh.intersect(&Ray { tmax, ..*ray })
        {
            let (inst, prim) = merged.owner(h.prim);
            found = Found::Instance { inst, prim, u: h.u, v: h.v };
            tmax = h.t;
        }
        let ray = &Ray { tmax, ..*ray };
        let leaf = |i: u32, t_limit: f32| {
            let inst = &self.instances[i as usize];
            if transparent_only && inst.opaque {
                return None;
            }
            let mut r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
            r.tmax = t_limit;
            match inst.shape {
                InstanceShape::Sphere { centre, radius } => {
                    let t = primitives::intersect_sphere(&r, centre, radius)?;
                    found = Found::Instance { inst: i, prim: 0, u: 0.0, v: 0.0 };
                    tmax = t;
                    Some(t)
                }
                InstanceShape::Mesh(m) => {
                    let h = self.blas[m].intersect(&r)?;
                    found = Found::Instance { inst: i, prim: h.prim, u: h.u, v: h.v };
                    tmax = h.t;
                    Some(h.t)
                }
            }
        };
        if self.tlas_used {
            self.tlas.intersect(ray, leaf);
        }
        for (pi, p) in self.planes.iter().enumerate() {
            if transparent_only && p.opaque {
                continue;
            }
            let r = Ray { tmax, ..*ray };
            if let Some(t) = primitives::intersect_plane(&r, p.normal, p.offset) {
                tmax = t;
                found = Found::Plane(pi);
            }
        }
        (found, tmax)
    }
}

/// The tree of a scene that is one mesh (see [`World::lone_mesh`]) and the way back to its
/// instances.
pub(super) struct LoneMesh<'a> {
    pub(super) bvh: &'a MeshBvh,
    merged: Option<&'a Merged>,
}

impl LoneMesh<'_> {
    /// Instance and mesh triangle of the tree's triangle `prim`.
    #[inline]
    fn owner(&self, prim: u32) -> (u32, u32) {
        self.merged.map_or((0, prim), |m| m.owner(prim))
    }
}
