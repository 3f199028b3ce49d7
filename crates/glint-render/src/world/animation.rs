//! Animation (pipeline: Scene at time t → **World**): objects and lights re-placed from their
//! rest state, only the top level rebuilt; a deforming mesh's BVH refitted.

use super::World;
use super::instances::{Instance, InstanceShape, Plane, object_curvature, top_level};
use super::merged;
use glint_accel::MeshBvh;
use glint_core::{Affine3A, Vec3};
use glint_scene::{AnimationTarget, Light, Shape};
use std::sync::Arc;

/// An animated object's placement or light, before [`World::set_time`] moves it.
enum Placement {
    Object(usize, Affine3A, Shape),
    Light(usize, Light),
}

impl World {
    /// Move object `object` (not a plane): only the top level is rebuilt.
    pub fn set_transform(&mut self, object: usize, world_from_object: Affine3A) -> bool {
        if !matches!(self.instance_of_object.get(object), Some(Some(_))) {
            return false;
        }
        self.pin(&[object]);
        self.scene.objects[object].world_from_object = world_from_object;
        self.place_object(object);
        self.rebuild_top_level();
        true
    }

    /// Put the scene's animated objects and lights where they are at time `t` (seconds; see
    /// [`glint_scene::Scene::set_time`]): the moved instances get their new transforms, moved planes their
    /// new equations, and the top level is rebuilt once; no mesh BVH is touched. Lights are
    /// read from the scene by every render, so a moved light needs nothing more. Returns whether
    /// anything moved. The result is the world [`World::new`] builds from the scene at `t`.
    pub fn set_time(&mut self, t: f32) -> bool {
        if !self.scene.is_animated() {
            return false;
        }
        // The animated targets as they are now, to tell what moved.
        let before: Vec<Placement> = self
            .scene
            .animations
            .iter()
            .filter_map(|a| match a.target {
                AnimationTarget::Object(i) => {
                    self.scene.objects.get(i).map(|o| Placement::Object(i, o.world_from_object, o.shape))
                }
                AnimationTarget::Light(i) => self.scene.lights.get(i).map(|l| Placement::Light(i, *l)),
            })
            .collect();
        self.scene.set_time(t);
        let mut changed = false;
        let mut moved_instance = false;
        for was in before {
            match was {
                Placement::Object(i, w, shape) => {
                    let o = &self.scene.objects[i];
                    if o.world_from_object != w || o.shape != shape {
                        changed = true;
                        moved_instance |= self.place_object(i);
                    }
                }
                Placement::Light(i, l) => changed |= self.scene.lights[i] != l,
            }
        }
        if moved_instance {
            self.rebuild_top_level();
        }
        changed
    }

    /// Bring the instance (or plane) of object `object` in line with its placement in the
    /// scene, without rebuilding the top level. Returns whether an instance (a TLAS member)
    /// changed.
    fn place_object(&mut self, object: usize) -> bool {
        let o = &self.scene.objects[object];
        self.curvature[object] = object_curvature(o);
        match (o.shape, self.instance_of_object.get(object).copied().flatten()) {
            (Shape::Plane { normal, offset }, _) => {
                if let Some(p) = self.planes.iter_mut().find(|p| p.object as usize == object) {
                    *p = Plane::new(normal, offset, p.object, p.material, p.opaque);
                }
                false
            }
            (_, Some(i)) => {
                let inst = &self.instances[i];
                debug_assert!(!inst.merged, "a moving object is pinned out of the merged tree first");
                self.instances[i] =
                    Instance::new(inst.shape, inst.object, inst.material, o.world_from_object, inst.opaque);
                true
            }
            (_, None) => false,
        }
    }

    /// New vertex positions for mesh `mesh` (same triangles): its BVH is refitted, not rebuilt.
    pub fn update_mesh_positions(&mut self, mesh: usize, positions: Vec<Vec3>) -> bool {
        let Some(m) = self.meshes.get(mesh) else { return false };
        if positions.len() != m.positions.len() || positions.iter().any(|p| !p.is_finite()) {
            return false;
        }
        let mut new_mesh = (**m).clone();
        new_mesh.positions = positions;
        let users: Vec<usize> = self
            .instances
            .iter()
            .filter(|i| matches!(i.shape, InstanceShape::Mesh(k) if k == mesh))
            .map(|i| i.object as usize)
            .collect();
        self.pin(&users);
        self.blas[mesh].refit(&new_mesh.positions);
        let new_mesh = Arc::new(new_mesh);
        self.meshes[mesh] = new_mesh.clone();
        self.scene.meshes[mesh] = new_mesh;
        self.rebuild_top_level();
        true
    }

    /// Keep `objects` out of the merged static tree from now on (they move or deform): the
    /// tree is rebuilt without them, their meshes get trees of their own, the top level takes
    /// them in.
    pub(super) fn pin(&mut self, objects: &[usize]) {
        let mut changed = false;
        for &o in objects {
            if let Some(p) = self.pinned.get_mut(o) {
                changed |= !*p;
                *p = true;
            }
        }
        let merge = merged::mergeable(&self.instances, &self.meshes, &self.pinned);
        if !changed || self.instances.iter().zip(&merge).all(|(i, &m)| i.merged == m) {
            return;
        }
        for (inst, &m) in self.instances.iter_mut().zip(&merge) {
            if let (true, false, InstanceShape::Mesh(k)) = (inst.merged, m, inst.shape) {
                let mesh = &self.meshes[k];
                self.blas[k] = MeshBvh::build(&mesh.positions, &mesh.triangles, &self.build);
            }
            inst.merged = m;
        }
        self.merged = merged::build(&self.instances, &self.meshes, &merge, &self.build);
        self.rebuild_top_level();
    }

    fn rebuild_top_level(&mut self) {
        let top = top_level(&self.instances, &self.blas);
        (self.tlas, self.tlas_used, self.spheres) = (top.tlas, top.used, top.spheres);
        (self.sphere_instances, self.top_members) = (top.sphere_instances, top.members);
        self.bounds = self.scene.bounds();
    }
}
