//! Instances and the top level (pipeline: Scene → **World** → integrators).
//!
//! Every bounded object is an *instance*: a shape in object space (a sphere, or a mesh with its
//! own BVH) and an affine placement. Up to [`SPHERE_SET_LIMIT`] untransformed spheres are tested
//! four at a time as a set; every other instance sits in a top-level BVH over world boxes,
//! rebuilt when an object moves (cheap: one box per object). Infinite planes cannot live in a
//! BVH and are kept beside it. Knows nothing of shading.

use glint_accel::{MeshBvh, SphereSet, Tlas};
use glint_core::{Affine3A, Bounds3, Mat3, Ray, Vec3};
use glint_scene::{Object, Shape};

#[derive(Clone, Copy, Debug)]
pub(super) enum InstanceShape {
    Sphere { centre: Vec3, radius: f32 },
    Mesh(usize),
}

#[derive(Clone, Debug)]
pub(super) struct Instance {
    pub(super) shape: InstanceShape,
    pub(super) object: u32,
    pub(super) material: u32,
    pub(super) world_from_object: Affine3A,
    pub(super) object_from_world: Affine3A,
    /// Inverse transpose of the linear part, for normals.
    pub(super) normal_from_object: Mat3,
    pub(super) identity: bool,
    /// Every surface of this instance is opaque (shadow rays may stop at its first hit).
    pub(super) opaque: bool,
    /// Its triangles are in the merged static tree ([`super::merged`]), not in the top level.
    pub(super) merged: bool,
}

impl Instance {
    pub(super) fn new(
        shape: InstanceShape,
        object: u32,
        material: u32,
        world_from_object: Affine3A,
        opaque: bool,
    ) -> Self {
        let identity = world_from_object == Affine3A::IDENTITY;
        Self {
            shape,
            object,
            material,
            opaque,
            world_from_object,
            object_from_world: world_from_object.inverse(),
            normal_from_object: Mat3::from(world_from_object.matrix3).inverse().transpose(),
            identity,
            merged: false,
        }
    }
}

#[derive(Clone, Copy, Debug)]
pub(super) struct Plane {
    pub(super) normal: Vec3,
    pub(super) offset: f32,
    /// `Frame::from_z(normal)`'s tangents (the uv axes), kept so no hit recomputes them.
    pub(super) u_axis: Vec3,
    pub(super) v_axis: Vec3,
    pub(super) object: u32,
    pub(super) material: u32,
    pub(super) opaque: bool,
}

impl Plane {
    pub(super) fn new(normal: Vec3, offset: f32, object: u32, material: u32, opaque: bool) -> Self {
        let frame = glint_core::Frame::from_z(normal);
        Self { normal, offset, u_axis: frame.x, v_axis: frame.y, object, material, opaque }
    }
}

#[derive(Clone, Copy)]
pub(super) enum Found {
    None,
    Instance { inst: u32, prim: u32, u: f32, v: f32 },
    Plane(usize),
}

/// Up to this many untransformed spheres are tested as a vector set; more go into the TLAS.
pub(super) const SPHERE_SET_LIMIT: usize = 16;

/// 1 / radius for spheres (their smallest scaled radius), 0 for planes and meshes.
pub(super) fn object_curvature(o: &Object) -> f32 {
    match o.shape {
        Shape::Sphere { radius, .. } => {
            let m = o.world_from_object.matrix3;
            let scale = m.x_axis.length().min(m.y_axis.length()).min(m.z_axis.length());
            1.0 / (radius * scale).max(f32::MIN_POSITIVE)
        }
        Shape::Plane { .. } | Shape::Mesh(_) => 0.0,
    }
}

/// The top level: the sphere set and the BVH over every other instance not merged.
pub(super) struct TopLevel {
    pub tlas: Tlas,
    /// Whether the TLAS holds any instance (not when every instance is in the sphere set):
    /// an empty one is not visited at all.
    pub used: bool,
    pub spheres: SphereSet,
    /// Instance index of each member of `spheres`.
    pub sphere_instances: Vec<u32>,
    /// The TLAS's members with their world boxes, in instance order (the batch queries test
    /// them flat).
    pub members: Vec<(u32, Bounds3)>,
}

/// Split the instances between the sphere set and the top-level BVH.
pub(super) fn top_level(instances: &[Instance], blas: &[MeshBvh]) -> TopLevel {
    let in_set = |inst: &Instance| inst.identity && matches!(inst.shape, InstanceShape::Sphere { .. });
    let count = instances.iter().filter(|i| in_set(i)).count();
    let use_set = count <= SPHERE_SET_LIMIT;
    let mut spheres = Vec::new();
    let mut ids = Vec::new();
    let boxes: Vec<Bounds3> = instances
        .iter()
        .enumerate()
        .map(|(i, inst)| match inst.shape {
            InstanceShape::Sphere { centre, radius } if use_set && in_set(inst) => {
                spheres.push((centre, radius));
                ids.push(i as u32);
                Bounds3::EMPTY // never visited by the TLAS
            }
            _ if inst.merged => Bounds3::EMPTY, // in the merged tree
            _ => instance_bounds(inst, blas),
        })
        .collect();
    let members: Vec<(u32, Bounds3)> =
        boxes.iter().enumerate().filter(|(_, b)| !b.is_empty()).map(|(i, b)| (i as u32, *b)).collect();
    TopLevel {
        tlas: Tlas::build(&boxes),
        used: !members.is_empty(),
        spheres: SphereSet::new(&spheres),
        sphere_instances: ids,
        members,
    }
}

fn instance_bounds(inst: &Instance, blas: &[MeshBvh]) -> Bounds3 {
    let local = match inst.shape {
        InstanceShape::Sphere { centre, radius } => {
            Bounds3::new(centre - Vec3::splat(radius), centre + Vec3::splat(radius))
        }
        InstanceShape::Mesh(m) => blas[m].bounds(),
    };
    if inst.identity { local } else { local.transformed(&inst.world_from_object) }
}

/// The ray in object space. The direction is not renormalised, so `t` is the same in both spaces.
#[inline]
pub(super) fn transform_ray(object_from_world: &Affine3A, ray: &Ray) -> Ray {
    Ray {
        origin: object_from_world.transform_point3(ray.origin),
        dir: object_from_world.transform_vector3(ray.dir),
        tmin: ray.tmin,
        tmax: ray.tmax,
    }
}
