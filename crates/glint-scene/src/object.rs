//! Objects: a shape, a material and a placement (an instance, in BVH terms).

use crate::PointCloud;
use glint_core::{Affine3A, Vec3};
use std::sync::Arc;

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

/// A point cloud placed in the scene: drawn by the points mode (DESIGN.md §3); the ray-tracing
/// modes do not see it.
#[derive(Clone, Debug, PartialEq)]
pub struct CloudObject {
    pub name: String,
    pub cloud: Arc<PointCloud>,
    /// Index into `Scene::materials`: Phong parameters, and the colour of points without one.
    pub material: usize,
    pub world_from_object: Affine3A,
}
