//! Shadow rays (pipeline: integrators ask **World** how much light passes): any-hit queries
//! that stop at the first opaque surface, and transmittance through transparent occluders
//! ("reduced according to the degree of transparency", DESIGN.md §1).

use super::World;
use super::instances::{InstanceShape, transform_ray};
use glint_accel::primitives;
use glint_core::float::offset_ray_origin;
use glint_core::{Ray, Rgb};

impl World {
    /// [`World::occluded`] of up to 8 rays: `out[i] == occluded(&rays[i])`.
    pub fn occluded8(&self, rays: &[Ray; 8], out: &mut [bool; 8]) {
        match self.lone_mesh() {
            Some(lone) => lone.bvh.occluded8(rays, out),
            None => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.occluded(r);
                }
            }
        }
    }

    /// True when anything blocks `ray` within its interval (opaque or not).
    #[must_use]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_filtered(ray, false)
    }

    /// Any hit; with `opaque_only`, only surfaces that are wholly opaque count.
    fn occluded_filtered(&self, ray: &Ray, opaque_only: bool) -> bool {
        for p in &self.planes {
            if (!opaque_only || p.opaque) && primitives::intersect_plane(ray, p.normal, p.offset).is_some() {
                return true;
            }
        }
        // The merged tree holds opaque meshes only.
        if let Some(merged) = &self.merged
            && merged.bvh.occluded(ray)
        {
            return true;
        }
        if self
            .spheres
            .crossings(ray, |k, _| !opaque_only || self.instances[self.sphere_instances[k as usize] as usize].opaque)
        {
            return true;
        }
        self.tlas_used
            && self.tlas.occluded(ray, |i| {
                let inst = &self.instances[i as usize];
                if opaque_only && !inst.opaque {
                    return false;
                }
                let r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
                match inst.shape {
                    InstanceShape::Sphere { centre, radius } => {
                        primitives::intersect_sphere(&r, centre, radius).is_some()
                    }
                    InstanceShape::Mesh(m) => self.blas[m].occluded(&r),
                }
            })
    }

    /// Fraction of light that passes along a shadow ray: 0 behind an opaque object, reduced by
    /// each transparent surface it crosses ("reduced according to the degree of transparency").
    #[must_use]
    pub fn transmittance(&self, ray: &Ray) -> Rgb {
        if !self.any_transparent {
            return if self.occluded(ray) { Rgb::ZERO } else { Rgb::ONE };
        }
        // One pass: an opaque hit ends it; transparent planes and spheres multiply in the
        // transmittance of every surface the segment crosses (order does not matter for a
        // product). Only a transparent mesh needs its hits in order (its triangles may carry
        // different materials): then the ordered walk below.
        let mut t = 1.0f32;
        for p in &self.planes {
            if primitives::intersect_plane(ray, p.normal, p.offset).is_some() {
                if p.opaque {
                    return Rgb::ZERO;
                }
                t *= self.material(p.material).transparency;
            }
        }
        let blocked = self.spheres.crossings(ray, |k, n| {
            let inst = &self.instances[self.sphere_instances[k as usize] as usize];
            if !inst.opaque {
                t *= self.material(inst.material).transparency.powi(n as i32);
            }
            inst.opaque
        });
        if blocked || self.merged.as_ref().is_some_and(|m| m.bvh.occluded(ray)) {
            return Rgb::ZERO;
        }
        let mut walk = false;
        let blocked = self.tlas_used
            && self.tlas.occluded(ray, |i| {
                let inst = &self.instances[i as usize];
                let r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
                match inst.shape {
                    InstanceShape::Sphere { centre, radius } => {
                        let n = primitives::sphere_crossings(&r, centre, radius);
                        if n > 0 && !inst.opaque {
                            t *= self.material(inst.material).transparency.powi(n as i32);
                        }
                        n > 0 && inst.opaque
                    }
                    InstanceShape::Mesh(m) => {
                        if inst.opaque {
                            self.blas[m].occluded(&r)
                        } else {
                            walk |= self.blas[m].occluded(&r);
                            false
                        }
                    }
                }
            });
        if blocked || t < 1e-4 {
            return Rgb::ZERO;
        }
        if !walk {
            return Rgb::splat(t);
        }
        self.transmittance_ordered(ray)
    }

    /// The general case: walk the transparent surfaces along the ray in order.
    fn transmittance_ordered(&self, ray: &Ray) -> Rgb {
        if self.occluded_filtered(ray, true) {
            return Rgb::ZERO;
        }
        let mut t = Rgb::ONE;
        let mut r = *ray;
        let end = ray.at(ray.tmax);
        for _ in 0..64 {
            let (found, th) = self.closest(&r, true);
            let Some(hit) = self.surface_hit(&r, found, th) else { return t };
            let m = self.material(hit.material);
            if !m.is_transparent() {
                return Rgb::ZERO;
            }
            t *= m.transparency;
            if t.max_element() < 1e-4 {
                return Rgb::ZERO;
            }
            let origin = offset_ray_origin(hit.position, hit.p_error, hit.geometric_normal, r.dir);
            let remaining = (end - origin).dot(r.dir);
            if remaining <= 0.0 {
                return t;
            }
            r = Ray::segment(origin, r.dir, 0.0, remaining);
        }
        t
    }
}
