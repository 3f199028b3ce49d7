//! The gather (points pipeline: projection → **gather** → pull-push → shading): for every pixel
//! a point won, what the pyramid needs of that point — its level-0 texel but for the depth,
//! which the depth word holds (Marroquim et al. 2007, §3.1: a texel is the projected point's
//! depth interval, normal, radius and colour).
//!
//! Made once per frame, so the pull into level 1 and the final push, which both read it,
//! decode each winner's normal once. Two steps per run of pixels: first only the random reads
//! of the winners' records (a tight loop keeps many cache misses in flight), then the
//! arithmetic on what they brought, eight pixels at a time in `glint_accel::lanes` with the
//! scalar [`Winner::new`]'s operations in its order (the same bits; tested).

use super::prepared::{self, PointAttributes, PreparedPoints};
use super::project::EMPTY;
use super::pyramid::Span;
use super::view::{CloudView, View, cloud_for};
use glint_accel::lanes::{F8, Isa, LANES, LaneKernel, M8, U8x, dispatch};
use glint_core::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// What the pyramid reads of the point that won a pixel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Winner {
    /// Camera-space unit normal, facing the camera.
    pub normal: [f32; 3],
    /// World radius (the cloud's scale applied).
    pub radius: f32,
    /// Packed 8-bit sRGB, as the point stores it.
    pub colour: u32,
    pub material: u32,
}

impl Winner {
    pub const NONE: Winner = Winner { normal: [0.0; 3], radius: 0.0, colour: 0, material: u32::MAX };

    /// The winner at pixel (x, y) of the point with normal `code` and `attributes`, from cloud
    /// `cv` (the oracle the lanes are held to).
    #[inline]
    pub fn new(view: &View, cv: &CloudView, x: usize, y: usize, code: u32, attributes: PointAttributes) -> Winner {
        let ray = view.camera_ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
        let mut normal = if cv.has_normals {
            (cv.camera_normal_from_object * prepared::decode_octahedral_direction(code)).normalize_or(Vec3::NEG_Z)
        } else {
            -ray.normalize()
        };
        // Face the camera: unoriented normals have no reliable sign, and a two-sided cloud
        // shows its back faces lit like its front.
        if normal.dot(ray) > 0.0 {
            normal = -normal;
        }
        Winner {
            normal: normal.to_array(),
            radius: attributes.radius * cv.radius_scale,
            colour: attributes.colour,
            material: cv.material,
        }
    }
}

/// Pixels whose records are read before any is computed with.
const RUN: usize = 64;

/// Fill `out[i]` for every pixel i whose depth word names a point (other pixels keep what they
/// hold), and `spans[y]` with where row y's covered pixels lie, row-parallel; `baseline` forces
/// the SSE lanes (the test that both builds agree).
pub(super) fn gather(
    points: &PreparedPoints,
    clouds: &[CloudView],
    view: &View,
    depth: &[AtomicU64],
    out: &mut [Winner],
    spans: &mut [Span],
    baseline: bool,
) {
    let width = view.width as usize;
    let rows = out.par_chunks_mut(width).zip(depth.par_chunks(width)).zip(spans.par_iter_mut());
    rows.enumerate().with_min_len(8).for_each(|(y, ((out, words), span))| {
        *span = dispatch(Row { points, clouds, view, y, words, out }, baseline);
    });
}

/// One row's gather.
struct Row<'a> {
    points: &'a PreparedPoints,
    clouds: &'a [CloudView],
    view: &'a View,
    y: usize,
    words: &'a [AtomicU64],
    out: &'a mut [Winner],
}

impl LaneKernel for Row<'_> {
    type Output = Span;

    #[inline(always)]
    fn run<I: Isa>(self) -> Span {
        gather_row::<I>(self)
    }
}

#[inline(always)]
fn gather_row<I: Isa>(Row { points, clouds, view, y, words, out }: Row<'_>) -> Span {
    let mut span = Span::EMPTY;
    let mut word = [EMPTY; RUN];
    let mut code = [0u32; RUN];
    let mut attributes = [PointAttributes { radius: 0.0, colour: 0 }; RUN];
    for (run, (out, words)) in out.chunks_mut(RUN).zip(words.chunks(RUN)).enumerate() {
        let x0 = run * RUN;
        for (k, w) in words.iter().enumerate() {
            word[k] = w.load(Ordering::Relaxed);
            if word[k] != EMPTY {
                let i = word[k] as u32 as usize;
                (code[k], attributes[k]) = (points.stream[i].normal, points.attributes[i]);
            }
        }
        for (g, out) in out.chunks_mut(LANES).enumerate() {
            let k0 = g * LANES;
            let covered = (0..out.len()).filter(|&k| word[k0 + k] != EMPTY).fold(0u32, |m, k| m | 1 << k);
            if covered == 0 {
                continue;
            }
            let x = (x0 + k0) as u32;
            span = span.union(Span { lo: x + covered.trailing_zeros(), hi: x + 32 - covered.leading_zeros() });
            let cv = cloud_for(clouds, word[k0 + covered.trailing_zeros() as usize] as u32);
            let one_cloud = clouds.len() == 1
                || (0..out.len())
                    .all(|k| covered >> k & 1 == 0 || std::ptr::eq(cloud_for(clouds, word[k0 + k] as u32), cv));
            if !one_cloud {
                for (k, o) in out.iter_mut().enumerate().filter(|&(k, _)| covered >> k & 1 == 1) {
                    let cv = cloud_for(clouds, word[k0 + k] as u32);
                    *o = Winner::new(view, cv, x0 + k0 + k, y, code[k0 + k], attributes[k0 + k]);
                }
                continue;
            }
            let lanes: [usize; LANES] = std::array::from_fn(|k| k0 + k.min(out.len() - 1));
            let (normal, radius) =
                winners8::<I>(view, cv, x0 + k0, y, lanes.map(|k| code[k]), lanes.map(|k| attributes[k].radius));
            for (k, o) in out.iter_mut().enumerate().filter(|&(k, _)| covered >> k & 1 == 1) {
                *o = Winner {
                    normal: [normal[0][k], normal[1][k], normal[2][k]],
                    radius: radius[k],
                    colour: attributes[k0 + k].colour,
                    material: cv.material,
                };
            }
        }
    }
    span
}

/// [`Winner::new`]'s normal and radius for pixels x0..x0 + 8 of row y, all from cloud `cv`.
#[inline(always)]
fn winners8<I: Isa>(
    view: &View,
    cv: &CloudView,
    x0: usize,
    y: usize,
    code: [u32; LANES],
    radius: [f32; LANES],
) -> ([[f32; LANES]; 3], [f32; LANES]) {
    // View::camera_ray: ((p − centre) / focal, 1).
    let focal = F8::<I>::splat(view.focal);
    let rx = (F8::<I>::from_fn(|k| (x0 + k) as f32 + 0.5) - F8::splat(view.centre.x)) / focal;
    let ry = F8::<I>::splat(((y as f32 + 0.5) - view.centre.y) / view.focal);
    let rz = F8::<I>::one();
    let (mut nx, mut ny, mut nz);
    if cv.has_normals {
        // decode_octahedral_direction (code 0 decodes to zero, which normalises to −z).
        const SCALE: f32 = 2.0 / 65534.0;
        let (scale, offset) = (F8::<I>::splat(SCALE), F8::<I>::splat(1.0 + SCALE));
        let code = U8x::<I>::from_array(code);
        let zero_code = code.eq(U8x::splat(0));
        let ox = code.and(0xffff).to_f32() * scale - offset;
        let oy = code.shift_right(16).to_f32() * scale - offset;
        let oz = F8::one() - ox.abs() - oy.abs();
        let fold = (-oz).max(F8::zero());
        let (ox, oy) = (ox - fold.copysign(ox), oy - fold.copysign(oy));
        let z0 = F8::zero();
        let (ox, oy, oz) =
            (F8::select(zero_code, z0, ox), F8::select(zero_code, z0, oy), F8::select(zero_code, z0, oz));
        // Mat3 × Vec3 as glam computes it: x_axis·x + y_axis·y + z_axis·z.
        let m = cv.camera_normal_from_object;
        let row = |i: usize| F8::splat(m.x_axis[i]) * ox + F8::splat(m.y_axis[i]) * oy + F8::splat(m.z_axis[i]) * oz;
        let (tx, ty, tz) = (row(0), row(1), row(2));
        // normalize_or(−z): 1 / length when that is finite and positive.
        let rcp = F8::one() / (tx * tx + ty * ty + tz * tz).sqrt();
        let ok = rcp.gt(F8::zero()) & rcp.lt(F8::splat(f32::INFINITY));
        nx = F8::select(ok, tx * rcp, F8::zero());
        ny = F8::select(ok, ty * rcp, F8::zero());
        nz = F8::select(ok, tz * rcp, F8::splat(-1.0));
    } else {
        let rcp = F8::one() / (rx * rx + ry * ry + rz * rz).sqrt();
        (nx, ny, nz) = (-(rx * rcp), -(ry * rcp), -(rz * rcp));
    }
    let away: M8<I> = (nx * rx + ny * ry + nz * rz).gt(F8::zero());
    (nx, ny, nz) = (F8::select(away, -nx, nx), F8::select(away, -ny, ny), F8::select(away, -nz, nz));
    let radius = F8::<I>::from_array(radius) * F8::splat(cv.radius_scale);
    ([nx.to_array(), ny.to_array(), nz.to_array()], radius.to_array())
}
