//! Emitters and exports (pipeline: **World** → the path tracer's light set, the ray
//! benchmarks' dumps): triangles in world space.

use super::World;
use super::instances::InstanceShape;
use glint_core::{Rgb, Vec2, Vec3};

/// A light-emitting triangle in world space.
#[derive(Clone, Copy, Debug)]
pub struct EmissiveTriangle {
    pub object: u32,
    pub prim: u32,
    /// Wound so that `(v1 − v0) × (v2 − v0)` is the front face's normal (the hit's geometric
    /// normal), also under mirroring transforms.
    pub vertices: [Vec3; 3],
    pub emission: Rgb,
    /// Emits from both faces (else from the front only).
    pub two_sided: bool,
    /// The emission texture (an index into `Scene::textures`) and the vertices' uvs, in the
    /// order of `vertices`: the emitted radiance is `emission` times the texture there.
    pub texture: Option<(usize, [Vec2; 3])>,
}

impl EmissiveTriangle {
    /// The radiance emitted at barycentric coordinates (b0, b1) of `vertices` (toward a
    /// direction it emits to).
    #[inline]
    #[must_use]
    pub fn emission_at(&self, world: &World, b0: f32, b1: f32) -> Rgb {
        match &self.texture {
            None => self.emission,
            Some((t, [u0, u1, u2])) => {
                let uv = *u0 * b0 + *u1 * b1 + *u2 * (1.0 - b0 - b1);
                self.emission * world.scene.textures[*t].evaluate(uv)
            }
        }
    }
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
                let m = &self.scene.materials[material as usize];
                if m.emission.max_element() <= 0.0 {
                    continue;
                }
                let [a, b, c] = t.map(|i| inst.world_from_object.transform_point3(mesh.positions[i as usize]));
                // A mirroring transform turns the winding around; the hit's normal does not turn.
                let mirrored = inst.world_from_object.matrix3.determinant() < 0.0;
                let vertices = if mirrored { [a, c, b] } else { [a, b, c] };
                let texture = m.emission_texture.map(|tex| {
                    let [ua, ub, uc] = match &mesh.uvs {
                        Some(uvs) => t.map(|i| uvs[i as usize]),
                        None => [Vec2::ZERO; 3],
                    };
                    (tex, if mirrored { [ua, uc, ub] } else { [ua, ub, uc] })
                });
                out.push(EmissiveTriangle {
                    object: inst.object,
                    prim: prim as u32,
                    vertices,
                    emission: m.emission,
                    two_sided: m.two_sided,
                    texture,
                });
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
