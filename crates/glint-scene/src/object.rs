//! Objects: a shape, a material and a placement (an instance, in BVH terms).

use glint_core::{Affine3A, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// Sphere in object space.
    Sphere { centre: Vec3, radius: f32 },
    /// The plane `p · normal + offset = 0` (normal unit length). Infinite: kept outside the BVH.
    Plane { normal: Vec3, offset: f32 },
    /// Index into `Scene::meshes`.
    Mesh(usize),
}

#[derive(Clone, Debug, PartialEq)]
pub struct Object {
    pub name: String,
    pub shape: Shape,
    /// Index into `Scene::materials`.
    pub material: usize,
    /// Placement of the shape in the world. Planes ignore it (their equation is in world space).
    pub world_from_object: Affine3A,
}
