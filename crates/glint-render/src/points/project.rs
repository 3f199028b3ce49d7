//! Projection of points to single pixels (Marroquim et al. 2007, §3.1; DESIGN.md §3): transform,
//! clip, cull back faces where normals are oriented, and keep the nearest point per pixel.
//!
//! The depth test is one atomic minimum per point on a 64-bit word holding the depth's bits
//! (positive floats order like their bit patterns) above the point's index, so the winner is
//! the nearest point, ties going to the lowest index: the result does not depend on the order
//! threads visit points in, and equals the serial projection bit for bit.

use super::prepared::{PreparedPoints, decode_octahedral_direction};
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

fn project_chunk(pts: &[super::prepared::StreamPoint], base: u32, cv: &CloudView, view: &View, depth: &[AtomicU64]) {
    let w = view.width as usize;
    for (k, p) in pts.iter().enumerate() {
        if let Some((x, y, z)) = pixel_of(p, cv, view) {
            depth_min(&depth[y as usize * w + x as usize], pack(z, base + k as u32));
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
