//! Projection of points to single pixels (Marroquim et al. 2007, §3.1; DESIGN.md §3): transform,
//! clip, cull back faces where normals are oriented, and keep the nearest point per pixel.
//!
//! The depth test is one atomic minimum per point on a 64-bit word holding the depth's bits
//! (positive floats order like their bit patterns) above the point's index, so the winner is
//! the nearest point, ties going to the lowest index: the result does not depend on the order
//! threads visit points in, and equals the serial projection bit for bit.

use super::prepared::{PreparedPoints, StreamPoint, decode_octahedral_direction};
use super::view::{CloudView, View};
use glint_accel::lanes::{F8, Isa, LANES, LaneKernel, U8x, dispatch};
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
    project_with(points, clouds, view, depth, side, false);
}

/// [`project`], with the SSE build of the one-pixel kernel forced when `baseline` (the test
/// that both builds give the serial reference's bits).
pub(super) fn project_with(
    points: &PreparedPoints,
    clouds: &[CloudView],
    view: &View,
    depth: &[AtomicU64],
    side: u32,
    baseline: bool,
) {
    for cv in clouds {
        let range = &points.stream[cv.start as usize..cv.end as usize];
        range.par_chunks(CHUNK).enumerate().for_each(|(chunk, pts)| {
            let base = cv.start + (chunk * CHUNK) as u32;
            if side == 1 {
                dispatch(Chunk { pts, base, cv, view, depth }, baseline);
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

/// One rayon task's points, projected one pixel each.
struct Chunk<'a> {
    pts: &'a [StreamPoint],
    base: u32,
    cv: &'a CloudView,
    view: &'a View,
    depth: &'a [AtomicU64],
}

impl LaneKernel for Chunk<'_> {
    type Output = ();

    #[inline(always)]
    fn run<I: Isa>(self) {
        project_chunk::<I>(self);
    }
}

/// The one-pixel projection of a chunk, eight points at a time in `glint_accel::lanes` (one
/// AVX2 register, or two SSE ones where the CPU has no AVX2: `dispatch` chooses at run time),
/// with exactly [`pixel_of`]'s operations in its order (no fused multiply-add), so every
/// lane's pixel and depth equal the scalar test's bit for bit in either build.
#[inline(always)]
fn project_chunk<I: Isa>(Chunk { pts, base, cv, view, depth }: Chunk<'_>) {
    let m = cv.camera_from_object;
    let rows = [m.matrix3.row(0), m.matrix3.row(1), m.matrix3.row(2)];
    let r = rows.map(|r| [F8::<I>::splat(r.x), F8::splat(r.y), F8::splat(r.z)]);
    let t = [F8::<I>::splat(m.translation.x), F8::splat(m.translation.y), F8::splat(m.translation.z)];
    let eye = [F8::<I>::splat(cv.eye_object.x), F8::splat(cv.eye_object.y), F8::splat(cv.eye_object.z)];
    let cull = F8::<I>::splat(if cv.cull { 1.0 } else { 0.0 });
    let (focal, near) = (F8::<I>::splat(view.focal), F8::<I>::splat(view.near));
    let centre = [F8::<I>::splat(view.centre.x), F8::splat(view.centre.y)];
    let size = [F8::<I>::splat(view.width_f), F8::splat(view.height_f)];
    let zero = F8::<I>::zero();
    const SCALE: f32 = 2.0 / 65534.0;
    let (scale, offset) = (F8::<I>::splat(SCALE), F8::<I>::splat(1.0 + SCALE));
    let width = view.width as usize;
    // Lanes past the end of a block hold NaN positions, which no clip test passes.
    let (mut px, mut py, mut pz, mut pn) = ([f32::NAN; BLOCK], [f32::NAN; BLOCK], [f32::NAN; BLOCK], [0u32; BLOCK]);
    let (mut sx_out, mut sy_out, mut depth_bits) = ([u32::MAX; BLOCK], [0u32; BLOCK], [0u32; BLOCK]);
    for (b, block) in pts.chunks(BLOCK).enumerate() {
        let first = base + (b * BLOCK) as u32;
        let n = block.len();
        for (k, p) in block.iter().enumerate() {
            (px[k], py[k], pz[k], pn[k]) = (p.position.x, p.position.y, p.position.z, p.normal);
        }
        for k in n..n.next_multiple_of(LANES) {
            (px[k], py[k], pz[k]) = (f32::NAN, f32::NAN, f32::NAN);
        }
        for g in (0..n).step_by(LANES) {
            let lane = |a: &[f32; BLOCK]| F8::<I>::from_array(a[g..g + LANES].try_into().unwrap_or([f32::NAN; LANES]));
            let (x, y, z) = (lane(&px), lane(&py), lane(&pz));
            let row = |r: &[F8<I>; 3], t: F8<I>| r[0] * x + r[1] * y + r[2] * z + t;
            let (cx, cy, cz) = (row(&r[0], t[0]), row(&r[1], t[1]), row(&r[2], t[2]));
            let inv = focal / cz;
            let sx = cx * inv + centre[0];
            let sy = cy * inv + centre[1];
            let inside = cz.gt(near) & sx.ge(zero) & sy.ge(zero) & sx.lt(size[0]) & sy.lt(size[1]);
            // The octahedral normal, decoded as `decode_octahedral_unchecked` does.
            let code = U8x::<I>::from_array(pn[g..g + LANES].try_into().unwrap_or([0; LANES]));
            let nx = code.and(0xffff).to_f32() * scale - offset;
            let ny = code.shift_right(16).to_f32() * scale - offset;
            let nz = F8::one() - nx.abs() - ny.abs();
            let fold = (-nz).max(zero);
            let (nx, ny) = (nx - fold.copysign(nx), ny - fold.copysign(ny));
            let facing = nx * (x - eye[0]) + ny * (y - eye[1]) + nz * (z - eye[2]);
            let back = (facing * cull).gt(zero);
            let keep = inside.and_not(back);
            let sx = U8x::select(keep, sx.trunc_to_u32(), U8x::splat(u32::MAX));
            sx_out[g..g + LANES].copy_from_slice(&sx.to_array());
            sy_out[g..g + LANES].copy_from_slice(&sy.trunc_to_u32().to_array());
            depth_bits[g..g + LANES].copy_from_slice(&cz.to_bits().to_array());
        }
        for k in 0..n {
            if sx_out[k] != u32::MAX {
                let pixel = sy_out[k] as usize * width + sx_out[k] as usize;
                depth_min(&depth[pixel], (u64::from(depth_bits[k]) << 32) | u64::from(first + k as u32));
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
