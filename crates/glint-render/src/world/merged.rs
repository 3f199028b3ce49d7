//! Static geometry in one BVH (pipeline: Scene → **World**): the opaque, unanimated meshes that
//! are not instanced are baked into world space and built into a single mesh BVH, as Embree
//! and Mitsuba keep a scene's plain geometry in one tree.
//!
//! A two-level BVH pays at every ray for its top level: a walk of the instance boxes, a ray
//! transform per instance reached, and a separate descent into each instance whose box the
//! ray crosses — and the boxes of a room's walls, floor and furniture overlap wherever the
//! ray goes. On Mitsuba's Cornell box (8 meshes, 36 triangles) the top level and the instance
//! bookkeeping were a quarter of a path-traced frame (BENCHMARKS.md §6). One tree over the
//! world-space triangles has none of that and a better SAH split (it may cut between objects).
//!
//! What is merged: mesh instances that are opaque (shadow rays may stop at their first hit),
//! whose object is no animation's target, and whose mesh no other object uses (true
//! instancing stays instanced: baking copies of a mesh would multiply its memory). At least
//! two must qualify, else merging only copies a tree. Hits in the merged tree are mapped back
//! to (instance, triangle) so shading reads the original mesh exactly as before; the
//! barycentrics are those of the world-space triangle, the same point up to rounding. An
//! object moved later ([`World::set_transform`]) or a mesh deformed
//! ([`World::update_mesh_positions`]) leaves the merged tree, which is rebuilt without it.
//!
//! [`World::set_transform`]: super::World::set_transform
//! [`World::update_mesh_positions`]: super::World::update_mesh_positions

use super::instances::{Instance, InstanceShape};
use glint_accel::{BuildOptions, MeshBvh};
use glint_core::Vec3;
use glint_scene::Mesh;
use std::sync::Arc;

/// The merged tree and the way back from its triangles to the instances'.
pub(super) struct Merged {
    pub(super) bvh: MeshBvh,
    /// Instance and triangle (within the instance's mesh) of each merged triangle.
    pub(super) owner: Vec<(u32, u32)>,
}

impl Merged {
    /// Instance and mesh triangle of merged triangle `prim`.
    #[inline(always)]
    pub(super) fn owner(&self, prim: u32) -> (u32, u32) {
        self.owner[prim as usize]
    }
}

/// Which instances may join the merged tree: `pinned[object]` marks objects that must stay
/// instances (animated, or moved or deformed since the world was built).
pub(super) fn mergeable(instances: &[Instance], meshes: &[Arc<Mesh>], pinned: &[bool]) -> Vec<bool> {
    let mut users = vec![0u32; meshes.len()];
    for inst in instances {
        if let InstanceShape::Mesh(m) = inst.shape {
            users[m] += 1;
        }
    }
    let ok: Vec<bool> = instances
        .iter()
        .map(|inst| match inst.shape {
            InstanceShape::Mesh(m) => {
                inst.opaque && users[m] == 1 && !pinned.get(inst.object as usize).copied().unwrap_or(true)
            }
            InstanceShape::Sphere { .. } => false,
        })
        .collect();
    if ok.iter().filter(|&&b| b).count() >= 2 { ok } else { vec![false; instances.len()] }
}

/// Bake the instances marked in `merge` into world space and build one BVH over them; None
/// when none is marked.
pub(super) fn build(
    instances: &[Instance],
    meshes: &[Arc<Mesh>],
    merge: &[bool],
    options: &BuildOptions,
) -> Option<Merged> {
    let mut positions: Vec<Vec3> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    let mut owner = Vec::new();
    for (i, inst) in instances.iter().enumerate() {
        let (true, InstanceShape::Mesh(m)) = (merge[i], inst.shape) else { continue };
        let mesh = &meshes[m];
        let base = positions.len() as u32;
        if inst.identity {
            positions.extend_from_slice(&mesh.positions);
        } else {
            positions.extend(mesh.positions.iter().map(|&p| inst.world_from_object.transform_point3(p)));
        }
        // Out-of-range indices stay out of range (never hit), as in the mesh's own tree.
        triangles.extend(
            mesh.triangles
                .iter()
                .map(|t| t.map(|v| if (v as usize) < mesh.positions.len() { base + v } else { u32::MAX })),
        );
        owner.extend((0..mesh.triangles.len() as u32).map(|p| (i as u32, p)));
    }
    if owner.is_empty() {
        return None;
    }
    Some(Merged { bvh: MeshBvh::build(&positions, &triangles, options), owner })
}
