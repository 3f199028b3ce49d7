//! glint-accel: ray-tracing acceleration structures.
//!
//! Pipeline position: glint-core's rays and boxes in, hits (distance, primitive, barycentrics)
//! out. Knows nothing about materials, scenes or files; depends only on glint-core and rayon.
//!
//! - [`batch`]: eight rays at once (structure of arrays, active-lane masks): spheres and
//!   planes across lanes, meshes through [`MeshBvh::intersect_batch`] / `occluded_batch`.
//! - [`primitives`]: ray/triangle (watertight, Woop et al. 2013), ray/sphere, ray/plane tests.
//! - [`build`]: the binned SAH builder producing the canonical binary [`Bvh2`].
//! - [`wide`]: the binary tree collapsed into 4- or 8-wide nodes with SoA child boxes and
//!   SoA triangle leaves, traversed by SIMD kernels per ISA (scalar kept as the oracle).
//! - [`MeshBvh`]: the production structure for one triangle mesh; [`Tlas`]: the top level over
//!   instances of a two-level scene (Wald et al. 2003).
//! - [`brute_force_intersect`]: the oracle every layout is tested against.
//!
//! `unsafe` is confined to the SIMD kernels (loads from fixed-size arrays, calls of
//! `#[target_feature]` functions after runtime detection), each block with a `// SAFETY:` note.

pub mod batch;
pub mod build;
pub mod bvh2;
pub mod lanes;
mod mesh;
pub mod primitives;
pub mod procedural;
pub mod spheres;
mod tlas;
pub mod wide;

#[cfg(test)]
mod test_util;

pub use build::{BuildOptions, Width};
pub use bvh2::{Bvh2, Bvh2Node};
pub use mesh::MeshBvh;
pub use spheres::SphereSet;
pub use tlas::Tlas;
pub use wide::{Bvh4, Bvh8, Isa, WideBvh};

use glint_core::{Ray, Vec3};
use primitives::{WoopRay, woop};

/// A closest hit: distance, the primitive's index in the caller's input, and barycentrics
/// (`point = (1 − u − v) p0 + u p1 + v p2`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}

/// What a build produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BvhStats {
    /// Nodes of the traversed layout.
    pub nodes: usize,
    pub leaves: usize,
    pub depth: usize,
    /// Bytes of node memory (leaf triangle data excluded).
    pub node_bytes: usize,
    /// SAH cost of the binary tree (relative to the root box, see [`Bvh2::sah_cost`]).
    pub sah_cost: f32,
    /// Wall time of the build, binary tree and conversion.
    pub build_ms: f64,
}

/// The three vertices of triangle `p`, or `None` if an index is out of range or a vertex is not
/// finite (such triangles are never hit by any structure in this crate).
#[inline]
pub(crate) fn fetch_triangle(positions: &[Vec3], triangles: &[[u32; 3]], p: u32) -> Option<[[f32; 3]; 3]> {
    let t = triangles.get(p as usize)?;
    let a = *positions.get(t[0] as usize)?;
    let b = *positions.get(t[1] as usize)?;
    let c = *positions.get(t[2] as usize)?;
    (a.is_finite() && b.is_finite() && c.is_finite()).then_some([a.to_array(), b.to_array(), c.to_array()])
}

/// Closest hit by testing every triangle: the oracle. Ties keep the lowest index.
pub fn brute_force_intersect(positions: &[Vec3], triangles: &[[u32; 3]], ray: &Ray) -> Option<Hit> {
    if !bvh2::ray_is_traceable(ray) {
        return None;
    }
    let wr = WoopRay::new(ray);
    let mut best: Option<Hit> = None;
    for p in 0..triangles.len() as u32 {
        let Some([a, b, c]) = fetch_triangle(positions, triangles, p) else { continue };
        let tmax = best.map_or(ray.tmax, |h| h.t);
        if let Some(h) = woop(&wr, a, b, c, ray.tmin, tmax)
            && best.is_none_or(|b| h.t < b.t)
        {
            best = Some(Hit { t: h.t, prim: p, u: h.u, v: h.v });
        }
    }
    best
}

/// Any hit in `(tmin, tmax]` by testing every triangle: the any-hit oracle.
pub fn brute_force_occluded(positions: &[Vec3], triangles: &[[u32; 3]], ray: &Ray) -> bool {
    if !bvh2::ray_is_traceable(ray) {
        return false;
    }
    let wr = WoopRay::new(ray);
    (0..triangles.len() as u32).any(|p| {
        fetch_triangle(positions, triangles, p)
            .is_some_and(|[a, b, c]| woop(&wr, a, b, c, ray.tmin, ray.tmax).is_some())
    })
}
