//! Projection of points to single pixels (Marroquim et al. 2007, §3.1; DESIGN.md §3): transform,
//! clip, cull back faces where normals are oriented, and keep the nearest point per pixel.
//!
//! The depth test is one atomic minimum per point on a 64-bit word holding the depth's bits
//! (positive floats order like their bit patterns) above the point's index, so the winner is
//! the nearest point, ties going to the lowest index: the result does not depend on the order
//! threads visit points in, and equals the serial projection bit for bit.

use super::prepared::{PreparedPoints, decode_octahedral_direction, decode_octahedral_unchecked};
use super::view::{CloudView, View};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// An empty pixel.
pub const EMPTY: u64 = u64::MAX;

/// Points handed to a rayon task at once.
const CHUNK: usize = 1 << 14;

#[inline]
pub fn pack(z: f32, index: u32) -> u64 {
    (u64::from(z.to_bits()) << 32) | u64::from(index)
}

#[inline]
pub fn unpack(word: u64) -> (f32, u32) {
    (f32::from_bits((word >> 32) as u32), word as u32)
}

/// Write every visible point into `depth` (`view.width × view.height` words, cleared to
/// [`EMPTY`]) as `side × side` pixels centred on its own (`side` = 1: the paper's one pixel per
/// point; larger: the fixed-size square splats of common point viewers).
pub fn project(points: &PreparedPoints, clouds: &[CloudView], view: &View, depth: &[AtomicU64], side: u32) {
    for cv in clouds {
        let range = &points.stream[cv.start as usize..cv.end as usize];
        range.par_chunks(CHUNK).enumerate().for_each(|(chunk, pts)| {
            let base = cv.start + (chunk * CHUNK) as u32;
            if side == 1 {
                project_chunk(pts, base, cv, view, depth);
            } else {
                project_chunk_squares(pts, base, cv, view, depth, side);
            }
        });
    }
}

/// The pixel a point lands on and its eye depth, or `None` when clipped or culled.
#[inline(always)]
pub(super) fn pixel_of(p: &super::prepared::StreamPoint, cv: &CloudView, view: &View) -> Option<(u32, u32, f32)> {
    let c = cv.camera_from_object.transform_point3(p.position);
    if c.z.is_nan() || c.z <= view.near {
        return None;
    }
    let inv = view.focal / c.z;
    let sx = c.x * inv + view.centre.x;
    let sy = c.y * inv + view.centre.y;
    if !(sx >= 0.0 && sy >= 0.0 && sx < view.width_f && sy < view.height_f) {
        return None;
    }
    if cv.cull {
        // Back-facing: the normal points away from the eye. Tested in object space, where the
        // code's direction need not be normalised for its sign.
        let n = decode_octahedral_direction(p.normal);
        if n.dot(p.position - cv.eye_object) > 0.0 {
            return None;
        }
    }
    Some((sx as u32, sy as u32, c.z))
}

#[inline(always)]
fn depth_min(slot: &AtomicU64, word: u64) {
    // A plain load first: most losing points never need the read-modify-write.
    if word < slot.load(Ordering::Relaxed) {
        slot.fetch_min(word, Ordering::Relaxed);
    }
}

/// Points per block of the one-pixel projection: first the block's pixels and words are
/// computed without branches (clip and cull become a sentinel pixel), then scattered.
const BLOCK: usize = 128;

fn project_chunk(pts: &[super::prepared::StreamPoint], base: u32, cv: &CloudView, view: &View, depth: &[AtomicU64]) {
    let width = view.width;
    let m = cv.camera_from_object;
    let (r0, r1, r2) = (m.matrix3.row(0), m.matrix3.row(1), m.matrix3.row(2));
    let t = m.translation;
    let cull = if cv.cull { 1.0f32 } else { 0.0 };
    let eye = cv.eye_object;
    let (mut px, mut py, mut pz, mut pn) = ([0f32; BLOCK], [0f32; BLOCK], [0f32; BLOCK], [0u32; BLOCK]);
    let mut pixel = [0u32; BLOCK];
    let mut depth_bits = [0u32; BLOCK];
    for (b, block) in pts.chunks(BLOCK).enumerate() {
        let first = base + (b * BLOCK) as u32;
        let n = block.len();
        for (k, p) in block.iter().enumerate() {
            (px[k], py[k], pz[k], pn[k]) = (p.position.x, p.position.y, p.position.z, p.normal);
        }
        // Straight-line arithmetic over the block's arrays, so that the compiler can use SIMD
        // lanes; clipping and culling select a sentinel pixel instead of branching.
        for k in 0..n {
            let (x, y, z) = (px[k], py[k], pz[k]);
            let cx = r0.x * x + r0.y * y + r0.z * z + t.x;
            let cy = r1.x * x + r1.y * y + r1.z * z + t.y;
            let cz = r2.x * x + r2.y * y + r2.z * z + t.z;
            let inv = view.focal / cz;
            let sx = cx * inv + view.centre.x;
            let sy = cy * inv + view.centre.y;
            let inside = (cz > view.near) & (sx >= 0.0) & (sy >= 0.0) & (sx < view.width_f) & (sy < view.height_f);
            // Back-facing: the normal points away from the eye (object space; the code's
            // direction need not be normalised for its sign).
            let nrm = decode_octahedral_unchecked(pn[k]);
            let facing = nrm.x * (x - eye.x) + nrm.y * (y - eye.y) + nrm.z * (z - eye.z);
            let back = facing * cull > 0.0;
            let p = (sy as i32 as u32).wrapping_mul(width).wrapping_add(sx as i32 as u32);
            pixel[k] = if inside & !back { p } else { u32::MAX };
            depth_bits[k] = cz.to_bits();
        }
        for k in 0..n {
            if pixel[k] != u32::MAX {
                depth_min(&depth[pixel[k] as usize], (u64::from(depth_bits[k]) << 32) | u64::from(first + k as u32));
            }
        }
    }
}

fn project_chunk_squares(
    pts: &[super::prepared::StreamPoint],
    base: u32,
    cv: &CloudView,
    view: &View,
    depth: &[AtomicU64],
    side: u32,
) {
    let w = view.width as i64;
    let h = view.height as i64;
    let lo = -((side as i64 - 1) / 2);
    let hi = lo + side as i64;
    for (k, p) in pts.iter().enumerate() {
        if let Some((x, y, z)) = pixel_of(p, cv, view) {
            let word = pack(z, base + k as u32);
            for yy in (y as i64 + lo).max(0)..(y as i64 + hi).min(h) {
                for xx in (x as i64 + lo).max(0)..(x as i64 + hi).min(w) {
                    depth_min(&depth[(yy * w + xx) as usize], word);
                }
            }
        }
    }
}
