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
use wide::{f32x4, i32x4, u32x4};

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
    let m = cv.camera_from_object;
    let (r0, r1, r2, t) = (m.matrix3.row(0), m.matrix3.row(1), m.matrix3.row(2), m.translation);
    let lanes = Lanes {
        r: [r0, r1, r2].map(|r| [f32x4::splat(r.x), f32x4::splat(r.y), f32x4::splat(r.z)]),
        t: [f32x4::splat(t.x), f32x4::splat(t.y), f32x4::splat(t.z)],
        eye: [f32x4::splat(cv.eye_object.x), f32x4::splat(cv.eye_object.y), f32x4::splat(cv.eye_object.z)],
        cull: f32x4::splat(if cv.cull { 1.0 } else { 0.0 }),
        focal: f32x4::splat(view.focal),
        centre: [f32x4::splat(view.centre.x), f32x4::splat(view.centre.y)],
        size: [f32x4::splat(view.width_f), f32x4::splat(view.height_f)],
        near: f32x4::splat(view.near),
        width: i32x4::splat(view.width as i32),
    };
    // Lanes past the end of a block hold NaN positions, which no clip test passes.
    let (mut px, mut py, mut pz, mut pn) = ([f32::NAN; BLOCK], [f32::NAN; BLOCK], [f32::NAN; BLOCK], [0u32; BLOCK]);
    let mut pixel = [0u32; BLOCK];
    let mut depth_bits = [0u32; BLOCK];
    for (b, block) in pts.chunks(BLOCK).enumerate() {
        let first = base + (b * BLOCK) as u32;
        let n = block.len();
        for (k, p) in block.iter().enumerate() {
            (px[k], py[k], pz[k], pn[k]) = (p.position.x, p.position.y, p.position.z, p.normal);
        }
        for k in n..n.next_multiple_of(4) {
            (px[k], py[k], pz[k]) = (f32::NAN, f32::NAN, f32::NAN);
        }
        for g in (0..n).step_by(4) {
            let lane = |a: &[f32; BLOCK]| f32x4::new([a[g], a[g + 1], a[g + 2], a[g + 3]]);
            let code = u32x4::new([pn[g], pn[g + 1], pn[g + 2], pn[g + 3]]);
            let (p, d) = lanes.project([lane(&px), lane(&py), lane(&pz)], code);
            pixel[g..g + 4].copy_from_slice(&p);
            depth_bits[g..g + 4].copy_from_slice(&d);
        }
        for k in 0..n {
            if pixel[k] != u32::MAX {
                depth_min(&depth[pixel[k] as usize], (u64::from(depth_bits[k]) << 32) | u64::from(first + k as u32));
            }
        }
    }
}

/// One cloud's view in SIMD lanes: four points projected at once (SSE2, part of every x86-64),
/// with exactly the scalar code's operations in the same order, so every lane's pixel and depth
/// equal [`pixel_of`]'s bit for bit.
struct Lanes {
    /// Rows of the camera-from-object rotation, each coefficient splatted.
    r: [[f32x4; 3]; 3],
    t: [f32x4; 3],
    eye: [f32x4; 3],
    cull: f32x4,
    focal: f32x4,
    centre: [f32x4; 2],
    size: [f32x4; 2],
    near: f32x4,
    width: i32x4,
}

impl Lanes {
    /// Pixel index (`u32::MAX` when clipped or culled) and depth bits of four points.
    #[inline(always)]
    fn project(&self, [x, y, z]: [f32x4; 3], code: u32x4) -> ([u32; 4], [u32; 4]) {
        let row = |r: &[f32x4; 3], t: f32x4| r[0] * x + r[1] * y + r[2] * z + t;
        let (cx, cy, cz) = (row(&self.r[0], self.t[0]), row(&self.r[1], self.t[1]), row(&self.r[2], self.t[2]));
        let inv = self.focal / cz;
        let sx = cx * inv + self.centre[0];
        let sy = cy * inv + self.centre[1];
        let zero = f32x4::ZERO;
        let inside = cz.simd_gt(self.near)
            & sx.simd_ge(zero)
            & sy.simd_ge(zero)
            & sx.simd_lt(self.size[0])
            & sy.simd_lt(self.size[1]);
        // The octahedral normal, decoded as `decode_octahedral_unchecked` does.
        const SCALE: f32 = 2.0 / 65534.0;
        let unpack = |v: u32x4| f32x4::from_i32x4(i32x4::from(v.to_array().map(|c| c as i32)));
        let nx = unpack(code & u32x4::splat(0xffff)) * f32x4::splat(SCALE) - f32x4::splat(1.0 + SCALE);
        let ny = unpack(code >> 16) * f32x4::splat(SCALE) - f32x4::splat(1.0 + SCALE);
        let nz = f32x4::ONE - nx.abs() - ny.abs();
        let fold = (-nz).max(zero);
        let (nx, ny) = (nx - fold.copysign(nx), ny - fold.copysign(ny));
        let facing = nx * (x - self.eye[0]) + ny * (y - self.eye[1]) + nz * (z - self.eye[2]);
        let back = (facing * self.cull).simd_gt(zero);
        let keep: i32x4 = bytemuck_cast(inside & !back);
        let index = sy.fast_trunc_int() * self.width + sx.fast_trunc_int();
        let pixel = keep.select(index, i32x4::splat(-1));
        (pixel.to_array().map(|p| p as u32), cz.to_bits().to_array())
    }
}

/// A lane mask of floats as the same bits in integer lanes.
#[inline(always)]
fn bytemuck_cast(m: f32x4) -> i32x4 {
    i32x4::from(m.to_bits().to_array().map(|b| b as i32))
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
