//! Emitters and exports (pipeline: **World** → the path tracer's light set, the ray
//! benchmarks' dumps): triangles in world space.

use super::World;
use super::instances::InstanceShape;
use glint_core::{Rgb, Vec3};

/// A light-emitting triangle in world space.
#[derive(Clone, Copy, Debug)]
pub struct EmissiveTriangle {
    pub object: u32,
    pub prim: u32,
    pub vertices: [Vec3; 3],
    pub emission: Rgb,
}

impl World {
    /// Every triangle whose material emits light, in world space, with its object and
    /// triangle index (the path tracer's area lights).
    #[must_use]
    pub fn emissive_triangles(&self) -> Vec<EmissiveTriangle> {
        let mut out = Vec::new();
        for inst in &self.instances {
            let InstanceShape::Mesh(m) = inst.shape else { continue };
            let mesh = &self.meshes[m];
            for (prim, t) in mesh.triangles.iter().enumerate() {
                let material = match &mesh.triangle_materials {
                    Some(ms) => ms[prim],
                    None => inst.material,
                };
                let emission = self.scene.materials[material as usize].emission;
                if emission.max_element() <= 0.0 {
                    continue;
                }
                let vertices = t.map(|i| inst.world_from_object.transform_point3(mesh.positions[i as usize]));
                out.push(EmissiveTriangle { object: inst.object, prim: prim as u32, vertices, emission });
            }
        }
        out
    }

    /// Every triangle of the world in world space (for the Embree comparison dumps).
    #[must_use]
    pub fn world_triangles(&self) -> Vec<[Vec3; 3]> {
        let mut out = Vec::new();
        for inst in &self.instances {
            if let InstanceShape::Mesh(m) = inst.shape {
                let mesh = &self.meshes[m];
                for t in &mesh.triangles {
                    out.push(t.map(|i| inst.world_from_object.transform_point3(mesh.positions[i as usize])));
                }
            }
        }
        out
    }
}
