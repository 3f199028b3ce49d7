//! The traceable world (pipeline: Scene → **World** → integrators): a scene's geometry in a
//! two-level BVH, and every question an integrator asks of it.
//!
//! Every bounded object is an *instance*: a shape in object space (a sphere, or a mesh with its
//! own BVH) and an affine placement. A top-level BVH over the instances' world boxes is rebuilt
//! when an object moves (cheap: one box per object); a mesh whose vertices move is refitted.
//! Nothing else is rebuilt (the two-level scheme of Wald et al. 2003 that the path-tracing paper
//! uses). Infinite planes cannot live in a BVH and are tested beside it.
//!
//! Hit points carry a conservative bound on their floating-point error (pbrt §3.9) so that
//! spawned rays start just outside it: no fixed epsilon, correct at every scale.
//!
//! The files: `instances` (shapes, placements, the top level), `intersect` (closest hits),
//! `hit` (surface data and material queries at a hit), `shadows` (any hit, transmittance),
//! `emitters` (emissive triangles), `animation` (re-placing what moves). The scene inside is
//! validated before and read-only after; only [`World::set_time`] moves its animated parts.

mod animation;
mod batch;
mod emitters;
mod hit;
mod hits8;
mod instances;
mod intersect;
mod merged;
mod shadows;
#[cfg(test)]
mod tests;

pub use batch::{PointCones, Surfaces8};
pub use emitters::EmissiveTriangle;
pub use hit::{NO_PRIM, SurfaceHit};

use glint_accel::{BuildOptions, MeshBvh, SphereSet, Tlas};
use glint_core::Bounds3;
use glint_scene::{IrradianceSh, Material, Mesh, Scene, Shape, Sky};
use instances::{Instance, InstanceShape, Plane, object_curvature, top_level};
use rayon::prelude::*;
use std::sync::Arc;

/// Statistics of the acceleration structures (reported by the CLI and benchmarks).
#[derive(Clone, Copy, Debug, Default)]
pub struct WorldStats {
    pub triangles: usize,
    pub instances: usize,
    pub spheres: usize,
    pub planes: usize,
    pub node_bytes: usize,
    pub build_ms: f64,
}

/// A scene made traceable.
pub struct World {
    scene: Scene,
    /// `scene.bounds()`, updated with the top level.
    bounds: Bounds3,
    meshes: Vec<Arc<Mesh>>,
    blas: Vec<MeshBvh>,
    /// How the meshes' trees are built.
    build: BuildOptions,
    instances: Vec<Instance>,
    tlas: Tlas,
    /// Whether the TLAS holds any instance (not when every instance is in the sphere set):
    /// an empty one is not visited at all.
    tlas_used: bool,
    /// Untransformed spheres, tested four at a time beside the TLAS (which then skips them).
    spheres: SphereSet,
    /// Instance index of each member of `spheres`.
    sphere_instances: Vec<u32>,
    /// The TLAS's members and their world boxes (see [`instances::TopLevel::members`]).
    top_members: Vec<(u32, Bounds3)>,
    /// Static meshes in one world-space tree, tested beside the top level ([`merged`]).
    merged: Option<merged::Merged>,
    /// Objects that must stay instances (animated, moved or deformed), by object index.
    pinned: Vec<bool>,
    planes: Vec<Plane>,
    /// Instance index of each object (None for planes).
    instance_of_object: Vec<Option<usize>>,
    any_transparent: bool,
    /// The sky's irradiance, when the scene takes its ambient light from the sky.
    sky_irradiance: Option<IrradianceSh>,
    /// Curvature (1 / radius in world units) of each object, for ray cones: spheres by their
    /// smallest scaled radius, planes 0, meshes 0 (treated as locally flat).
    curvature: Vec<f32>,
    pub stats: WorldStats,
}

impl World {
    /// Build the acceleration structures of a validated scene (meshes in parallel), with
    /// spatial splits ([`BuildOptions::spatial`]): a scene is built once and traced many times.
    #[must_use]
    pub fn new(scene: Scene) -> Self {
        Self::with_build(scene, BuildOptions::spatial())
    }

    /// [`World::new`] with the meshes' trees built with `options` (also those built later,
    /// when an object starts to move). A mesh whose vertices are moved later is refitted,
    /// whatever it was built with.
    #[must_use]
    pub fn with_build(scene: Scene, options: BuildOptions) -> Self {
        let start = std::time::Instant::now();
        let meshes = scene.meshes.clone();
        let transparent = |m: usize| scene.materials[m].is_transparent();
        let mesh_opaque = |mesh: usize, object_material: usize| match &meshes[mesh].triangle_materials {
            Some(ms) => ms.iter().all(|&m| !transparent(m as usize)),
            None => !transparent(object_material),
        };
        let mut instances = Vec::new();
        let mut planes = Vec::new();
        let mut instance_of_object = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            let (object, material) = (i as u32, o.material as u32);
            match o.shape {
                Shape::Plane { normal, offset } => {
                    planes.push(Plane::new(normal, offset, object, material, !transparent(o.material)));
                    instance_of_object.push(None);
                }
                Shape::Sphere { centre, radius } => {
                    instance_of_object.push(Some(instances.len()));
                    instances.push(Instance::new(
                        InstanceShape::Sphere { centre, radius },
                        object,
                        material,
                        o.world_from_object,
                        !transparent(o.material),
                    ));
                }
                Shape::Mesh(m) => {
                    instance_of_object.push(Some(instances.len()));
                    let opaque = mesh_opaque(m, o.material);
                    instances.push(Instance::new(
                        InstanceShape::Mesh(m),
                        object,
                        material,
                        o.world_from_object,
                        opaque,
                    ));
                }
            }
        }
        // Animated objects stay instances; the other static meshes go into one tree.
        let mut pinned = vec![false; scene.objects.len()];
        for a in &scene.animations {
            if let glint_scene::AnimationTarget::Object(i) = a.target
                && let Some(p) = pinned.get_mut(i)
            {
                *p = true;
            }
        }
        let merge = merged::mergeable(&instances, &meshes, &pinned);
        let mut in_merged = vec![false; meshes.len()];
        for (inst, &m) in instances.iter_mut().zip(&merge) {
            inst.merged = m;
            if let (true, InstanceShape::Mesh(k)) = (m, inst.shape) {
                in_merged[k] = true;
            }
        }
        // A merged mesh needs no tree of its own (one is built if it ever leaves).
        let (blas, merged): (Vec<MeshBvh>, _) = rayon::join(
            || {
                meshes
                    .par_iter()
                    .zip(&in_merged)
                    .map(|(m, &skip)| {
                        if skip {
                            MeshBvh::build(&[], &[], &options)
                        } else {
                            MeshBvh::build(&m.positions, &m.triangles, &options)
                        }
                    })
                    .collect()
            },
            || merged::build(&instances, &meshes, &merge, &options),
        );
        let top = top_level(&instances, &blas);
        let any_transparent = scene.materials.iter().any(Material::is_transparent);
        let sky_irradiance = scene.sky_ambient.then(|| scene.sky.irradiance_sh());
        let curvature = scene.objects.iter().map(object_curvature).collect();
        let stats = WorldStats {
            triangles: meshes.iter().map(|m| m.triangles.len()).sum(),
            instances: instances.len(),
            spheres: instances.iter().filter(|i| matches!(i.shape, InstanceShape::Sphere { .. })).count(),
            planes: planes.len(),
            node_bytes: blas.iter().chain(merged.as_ref().map(|m| &m.bvh)).map(|b| b.stats().node_bytes).sum(),
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        Self {
            bounds: scene.bounds(),
            scene,
            meshes,
            blas,
            instances,
            tlas: top.tlas,
            tlas_used: top.used,
            spheres: top.spheres,
            sphere_instances: top.sphere_instances,
            top_members: top.members,
            merged,
            pinned,
            build: options,
            planes,
            instance_of_object,
            any_transparent,
            sky_irradiance,
            curvature,
            stats,
        }
    }

    /// `scene.bounds()` as of the last change through this world's methods, kept so that a
    /// frame does not walk every mesh vertex (the path mode reads it per frame).
    #[must_use]
    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }

    /// The scene this world was built from (at the time of the last [`World::set_time`]).
    #[must_use]
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    #[must_use]
    pub fn sky(&self) -> &Sky {
        &self.scene.sky
    }

    /// Curvature of object `object` (see the field); 0 for unknown objects.
    #[inline]
    #[must_use]
    pub fn curvature(&self, object: u32) -> f32 {
        self.curvature.get(object as usize).copied().unwrap_or(0.0)
    }

    #[must_use]
    pub fn material(&self, index: u32) -> &Material {
        &self.scene.materials[index as usize]
    }
}
