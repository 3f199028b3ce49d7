//! Edge-avoiding À-Trous wavelet filtering (Dammertz, Sewtz, Hanika, Lensch, HPG 2010): the
//! 5×5 B3-spline kernel h·hᵀ, h = [1, 4, 6, 4, 1]/16, applied with holes 2^i pixels apart at
//! iteration i, each tap weighted by edge-stopping functions of colour, normal and depth.
//!
//! One `exp2` per pair of pixels: normals, depth and colour are stored pre-scaled by √(log₂e)/σ,
//! and the kernel weight enters as an offset, so `h_ab · e^(−|Δc|²/σc²) · e^(−|Δn|²/σn²) ·
//! e^(−Δz²/σz²) = 2^−(|Δg|² − log₂ h_ab)`. That weight is symmetric (h is, and so is |Δg|²),
//! so each row first computes the 12 "forward" taps (below, or right on the same row) of its
//! pixels, uses them for its own sums and keeps them in a ring of rows; each pixel then adds its
//! 12 "backward" taps by reading the weight its neighbour computed. Half the exponentials, and
//! the same bits as computing both (the weight of a pair is one value either way). A row's
//! forward pass keeps a vector's centre features and its four sums in registers across the 12
//! taps (the taps' weights are independent, so the long chain of each, distance then `exp2`,
//! overlaps the next tap's); its backward pass adds the stored weights and writes the output.
//!
//! The colour sigma halves each iteration, which in scaled units is a factor 2 on the colour
//! written for the next one (exact in binary floating point). Taps outside the image count
//! for nothing: rows outside are skipped; columns outside hold depth +inf, so a pair with one
//! end there gets weight zero, with no mask in the loop (the exponential is 0 from 2^−40
//! down: see [`Wide::exp2_neg_or_zero`]). Rows are split into bands
//! for the threads; a band recomputes the forward taps of the 2·2^i rows above it, and since
//! every pixel adds its contributions in an order that does not depend on the band, any split
//! gives the same bits.

use std::sync::Mutex;

use rayon::prelude::*;

use crate::check::{self, Names};
use crate::lanes::{LANES, Wide, array};
use crate::padded::{Padded, view};
use crate::simd::{self, Kernels};
use crate::{AtrousParams, FilterError, Guide, Isa};

/// More iterations than this would space taps 2^16 px apart: beyond any image.
const MAX_ITERATIONS: u32 = 16;

/// The 12 forward taps (column, row) in units of the step: the rest of the row to the right,
/// and the two rows below. Their mirror images are the backward taps.
const FORWARD: [(isize, usize); 12] =
    [(1, 0), (2, 0), (-2, 1), (-1, 1), (0, 1), (1, 1), (2, 1), (-2, 2), (-1, 2), (0, 2), (1, 2), (2, 2)];

/// The unit of σc: the standard deviation of the input's finite values over all three planes
/// (1 when there are none or they are all equal), summed in f64: per block of
/// [`SCALE_BLOCK`] values in parallel, the blocks' sums then added in order, so the result does
/// not depend on the thread count. So the filter commutes with `s·N + t` (s > 0) and one σc
/// suits any exposure.
pub fn colour_scale(input: [&[f32]; 3]) -> f32 {
    let block = |values: &[f32]| {
        let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0u64);
        for &v in values {
            if v.is_finite() {
                let v = f64::from(v);
                sum += v;
                sum2 += v * v;
                n += 1;
            }
        }
        (sum, sum2, n)
    };
    let blocks: Vec<(f64, f64, u64)> =
        input.par_iter().flat_map(|plane| plane.par_chunks(SCALE_BLOCK).map(block)).collect();
    let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0u64);
    for (s, s2, k) in blocks {
        sum += s;
        sum2 += s2;
        n += k;
    }
    if n == 0 {
        return 1.0;
    }
    let mean = sum / n as f64;
    let sd = ((sum2 / n as f64 - mean * mean).max(0.0)).sqrt() as f32;
    if sd > 0.0 && sd.is_finite() { sd } else { 1.0 }
}

/// Values per block of [`colour_scale`]'s sums.
const SCALE_BLOCK: usize = 1 << 15;

/// The filter's planes (scaled guide, colour, next colour), kept between calls when the next
/// call has the same layout: a 1024 × 768 frame's are 31 MB, whose fresh pages cost more than
/// an iteration. Outside the image they keep what they held (zeros; the guide's depth +inf,
/// set again every call): the bands and [`Padded::fill`] write only image pixels, so a kept
/// plane set is as good as a new one once filled.
static PLANES: Mutex<Vec<Padded>> = Mutex::new(Vec::new());

/// `count` planes for this layout: kept ones if the pool has them, else new zeros.
fn take_planes(lanes: usize, w: usize, h: usize, reach: usize, count: usize) -> Padded {
    let (wp, margin, stride) = Padded::layout(lanes, w, reach);
    let fits = |p: &Padded| (p.w, p.h, p.wp, p.margin, p.stride, p.count) == (w, h, wp, margin, stride, count);
    if let Ok(mut pool) = PLANES.lock()
        && let Some(i) = pool.iter().position(fits)
    {
        return pool.swap_remove(i);
    }
    Padded::zeros_for(lanes, w, h, reach, count)
}

/// Keep `planes` for the next call, dropping any kept for another layout: images up to
/// [`KEPT_PIXELS`] (interactive sizes; a larger frame's planes are freed), and at most three
/// calls' worth (filters running side by side).
fn keep_planes<const K: usize>(planes: [Padded; K]) {
    let Some(first) = planes.first() else { return };
    if first.w * first.h > KEPT_PIXELS {
        return;
    }
    if let Ok(mut pool) = PLANES.lock() {
        let layout = |p: &Padded| (p.w, p.h, p.wp, p.margin, p.stride);
        let want = layout(first);
        pool.retain(|p| layout(p) == want);
        pool.extend(planes);
        pool.truncate(9);
    }
}

/// The largest image whose planes [`keep_planes`] keeps: 2048 × 2048 (168 MB of planes).
const KEPT_PIXELS: usize = 1 << 22;

/// The planes of a `w`×`h` filter with `p`'s iterations, made (their pages written on every
/// thread) and kept for the next call: see [`crate::reserve`].
pub(crate) fn reserve(isa: Isa, w: usize, h: usize, p: &AtrousParams) {
    // Planes of a larger image are not kept ([`keep_planes`]): nothing to make ahead.
    if w == 0 || h == 0 || w * h > KEPT_PIXELS || p.iterations == 0 || p.iterations > MAX_ITERATIONS {
        return;
    }
    let reach = (2usize << (p.iterations - 1)).min(w + LANES);
    let lanes = simd::atrous_lanes(isa);
    // The guide's four planes, the colour's three and the next colour's three.
    let mut planes = [4, 3, 3].map(|count| take_planes(lanes, w, h, reach, count));
    for p in &mut planes {
        p.planes_mut().par_chunks_mut(1 << 14).for_each(|c| c.fill(0.0));
    }
    keep_planes(planes);
}

pub(crate) fn atrous_into_named(
    isa: Isa,
    input: [&[f32]; 3],
    guide: &Guide,
    p: &AtrousParams,
    names: &Names,
    out: [&mut [f32]; 3],
) -> Result<(), FilterError> {
    let (w, h) = check::sizes(input, guide, names)?;
    check::outputs(&out, w, h)?;
    if p.iterations == 0 || p.iterations > MAX_ITERATIONS {
        return Err(FilterError::parameter(
            "A-Trous",
            format!("iterations must be in 1..={MAX_ITERATIONS}, got {}", p.iterations),
        ));
    }
    check::positive("A-Trous", "sigma_colour", p.sigma_colour)?;
    check::positive("A-Trous", "sigma_normal", p.sigma_normal)?;
    check::positive("A-Trous", "sigma_depth", p.sigma_depth)?;
    let root = std::f32::consts::LOG2_E.sqrt();
    // Taps at |dx| >= w can never land inside the image and are skipped, so the margin never
    // needs to exceed the width.
    let reach = (2usize << (p.iterations - 1)).min(w + LANES);
    // Rows in whole vectors of the width the kernel runs (16 lanes with AVX-512).
    let lanes = simd::atrous_lanes(isa);
    let mut geo = take_planes(lanes, w, h, reach, 4);
    let kn = root / p.sigma_normal;
    let mut finite = true;
    for (k, plane) in guide.normal.iter().enumerate() {
        finite &= geo.fill(k, plane, |v| v * kn);
    }
    let kz = root / p.sigma_depth;
    finite &= geo.fill(3, guide.depth, |z| z.min(1.0) * kz);
    // Outside the image depth is +inf, so no weight pairs a pixel with one there.
    geo.set_outside(3, f32::INFINITY);
    let mut cur = take_planes(lanes, w, h, reach, 3);
    let mut kc = root / (p.sigma_colour * colour_scale(input));
    for (k, plane) in input.iter().enumerate() {
        finite &= cur.fill(k, plane, |v| v * kc);
    }
    if !finite {
        keep_planes([geo, cur]);
        return check::finite(input, guide, names);
    }
    let mut next = take_planes(lanes, w, h, reach, 3);
    // −log₂ h_ab: the exponent offset of each forward tap, and of the centre.
    let hk = [1.0f32, 4.0, 6.0, 4.0, 1.0].map(|v| v / 16.0);
    let offset = FORWARD.map(|(tx, ty)| -(hk[(tx + 2) as usize] * hk[ty + 2]).log2());
    let centre = -(hk[2] * hk[2]).log2();

    let mut image = Some(out);
    for it in 0..p.iterations {
        let last = it + 1 == p.iterations;
        // Colour out, in the next iteration's units (σc halves: ×2), or plain after the last.
        let factor = if last { 1.0 / kc } else { 2.0 };
        let step = 1usize << it;
        // Bands tall enough that the 2·step rows recomputed above each cost at most ~1/4.
        let band = (32 * step).clamp(64, h.div_ceil(4).max(64));
        let run = |i: usize, out: BandOut<'_>| {
            let job = BandJob { geo: &geo, cur: &cur, step, factor, offset, centre, y0: i * band, out };
            simd::atrous_band(isa, job);
        };
        // The last iteration writes the caller's planes: no copy out of the padded ones.
        if let Some([a, b, c]) = image.take_if(|_| last) {
            let rows = band * w;
            let planes = a.par_chunks_mut(rows).zip(b.par_chunks_mut(rows)).zip(c.par_chunks_mut(rows));
            planes.enumerate().for_each(|(i, ((a, b), c))| run(i, BandOut::Image([a, b, c])));
        } else {
            let rows = band * 3 * cur.stride;
            next.planes_mut().par_chunks_mut(rows).enumerate().for_each(|(i, out)| run(i, BandOut::Padded(out)));
            std::mem::swap(&mut cur, &mut next);
            kc *= 2.0;
        }
    }
    keep_planes([geo, cur, next]);
    Ok(())
}

/// Where a band's output rows go.
pub(crate) enum BandOut<'a> {
    /// The next iteration's padded planes: rows `y0..` of the three, row-interleaved.
    Padded(&'a mut [f32]),
    /// The caller's three planes, rows `y0..` (`w` floats each, no margins): the last
    /// iteration's.
    Image([&'a mut [f32]; 3]),
}

/// Output rows `y0..` of one iteration (as many as `out` holds).
pub(crate) struct BandJob<'a> {
    /// Scaled normal x, y, z and depth.
    geo: &'a Padded,
    /// Scaled colour of this iteration.
    cur: &'a Padded,
    step: usize,
    /// Multiplies the filtered colour on output.
    factor: f32,
    /// −log₂ h of each forward tap.
    offset: [f32; 12],
    /// −log₂ h of the centre tap.
    centre: f32,
    y0: usize,
    out: BandOut<'a>,
}

/// A band's weight ring, reused between calls (fresh pages cost more than the arithmetic).
static RINGS: Mutex<Vec<Vec<f32>>> = Mutex::new(Vec::new());

/// One forward tap of a row: where its features are, where its weights go and its kernel
/// weight's exponent offset.
#[derive(Clone, Copy, Default)]
struct Tap<'a, const N: usize> {
    /// The tap row's normal x, y, z and depth from the tap's column on, plane p at vector
    /// `p·s8` (one slice: reading plane 3 first bounds the other three).
    geo: &'a [[f32; N]],
    /// Its colour, likewise.
    colour: &'a [[f32; N]],
    /// Where the tap's weights go in the ring slot of the row.
    weights: usize,
    /// −log₂ h of the tap, the start of its exponent.
    offset: f32,
}

/// One backward tap of a row: the weights its partner row stored and that row's colour, both
/// seen from this row's pixels.
#[derive(Clone, Copy, Default)]
struct Back<'a, const N: usize> {
    weights: &'a [[f32; N]],
    colour: &'a [[f32; N]],
}

/// How many vectors ahead [`band`] prefetches the row two steps down: 8 (2 KB a plane with
/// 16 lanes) measured best, 4 as good within noise, 16 slower (BENCHMARKS.md §13.5).
const AHEAD: usize = 8;

/// Runs one band of one iteration (see the module documentation). Each row takes two passes
/// over its vectors: the forward pass keeps a vector's centre features and four sums in
/// registers while it runs through the 12 forward taps (storing each weight in the ring), the
/// backward pass adds the 12 weights the rows above stored and writes the output. Both run
/// the taps in the same order as ever (centre, forward, backward), so the bits do not depend
/// on the band.
#[inline(always)]
pub(crate) fn band<K: Kernels, const N: usize>(k: K, job: BandJob<'_>) {
    let BandJob { geo, cur, step, factor, offset, centre, y0, mut out } = job;
    let (w, h, wp, m, stride) = (geo.w, geo.h, geo.wp, geo.margin, geo.stride);
    let y1 = y0
        + match &out {
            BandOut::Padded(o) => o.len() / (3 * stride),
            BandOut::Image(o) => o[0].len() / w,
        };
    assert!(wp % N == 0 && m % N == 0 && stride % N == 0, "planes laid out for {N} lanes");
    let (n8, s8, m8) = (wp / N, stride / N, m / N);
    // Forward weights of rows y − 2·step ..= y: slot per row, 12 padded rows per slot.
    let first = y0.saturating_sub(2 * step);
    let slots = (2 * step + 1).min(y1 - first);
    let mut store = RINGS.lock().ok().and_then(|mut r| r.pop()).unwrap_or_default();
    // Each weight row is written inside the image before it is read; its margins (read by
    // the border vectors' backward taps) must be zero, which is all a reused ring needs.
    // From the first 64-byte line on (the weights then store whole lines).
    store.resize(slots * 12 * stride + 16, 0.0);
    let line = (16 - (store.as_ptr() as usize / size_of::<f32>()) % 16) % 16;
    let ring = store[line..line + slots * 12 * stride].as_chunks_mut::<N>().0;
    for row in ring.chunks_exact_mut(s8) {
        row[..m8].fill([0.0; N]);
        row[m8 + n8..].fill([0.0; N]);
    }
    // Per row and vector: Σw·c (3) and Σw, side by side, between the two passes.
    let mut sums = vec![[[0.0f32; N]; 4]; n8];
    let wc = k.exp2_neg_or_zero(Wide::<N>::splat(centre));
    let at = |p: usize, dx: isize| (p * stride + m).wrapping_add_signed(dx);
    for y in first..y1 {
        let slot = (y - first) % slots * 12 * s8;
        let (centre_geo, centre_colour) = (geo.block(y), cur.block(y));
        // Plane p of a block's view at vector p·s8 (plane 3 read first bounds the others).
        let span = |count: usize| (count - 1) * stride + wp;
        let (cg, cc) = (view(centre_geo, at(0, 0), span(4)), view(centre_colour, at(0, 0), span(3)));
        let mut live = [false; 12];
        let taps: [Tap<'_, N>; 12] = array(|o| {
            let (tx, ty) = FORWARD[o];
            let dx = tx * step as isize;
            let yy = y + ty * step;
            if yy >= h || dx.unsigned_abs() >= w {
                return Tap::default();
            }
            live[o] = true;
            Tap {
                geo: view(geo.block(yy), at(0, dx), span(4)),
                colour: view(cur.block(yy), at(0, dx), span(3)),
                weights: o * s8 + m8,
                offset: offset[o],
            }
        });
        let weights = &mut ring[slot..slot + 12 * s8];
        for (o, &live) in live.iter().enumerate() {
            if !live {
                weights[o * s8..(o + 1) * s8].fill([0.0; N]);
            }
        }
        // The row two steps down is the one whose lines this row reads first (the rows
        // above read it later, as their nearer tap row and as the centre). The hardware's
        // stride prefetcher does not follow it: the same load instructions walk all 12 taps'
        // rows in turn. So its seven planes are fetched ahead, [`AHEAD`] vectors on.
        let ahead = if live[9] { Some(taps[9]) } else { None };
        for i in 0..n8 {
            if let Some(t) = ahead {
                for p in 0..4 {
                    k.prefetch(t.geo.as_ptr().wrapping_add(p * s8 + i + AHEAD));
                }
                for p in 0..3 {
                    k.prefetch(t.colour.as_ptr().wrapping_add(p * s8 + i + AHEAD));
                }
            }
            let c3 = Wide(cg[3 * s8 + i]);
            let c6 = Wide(cc[2 * s8 + i]);
            let c = [Wide(cg[i]), Wide(cg[s8 + i]), Wide(cg[2 * s8 + i]), c3, Wide(cc[i]), Wide(cc[s8 + i]), c6];
            let mut s = [wc * c[4], wc * c[5], wc * c[6], wc];
            for (t, &live) in taps.iter().zip(&live) {
                if !live {
                    continue;
                }
                let (g3, t2) = (Wide(t.geo[3 * s8 + i]), Wide(t.colour[2 * s8 + i]));
                let tap = [Wide(t.colour[i]), Wide(t.colour[s8 + i]), t2];
                let d = [
                    Wide(t.geo[i]) - c[0],
                    Wide(t.geo[s8 + i]) - c[1],
                    Wide(t.geo[2 * s8 + i]) - c[2],
                    g3 - c[3],
                    tap[0] - c[4],
                    tap[1] - c[5],
                    tap[2] - c[6],
                ];
                // Four short chains instead of one of seven multiply-adds.
                let s01 = k.mul_add(d[1], d[1], k.mul_add(d[0], d[0], Wide::splat(t.offset)));
                let s23 = k.mul_add(d[3], d[3], d[2] * d[2]);
                let s45 = k.mul_add(d[5], d[5], d[4] * d[4]);
                // A partner outside the image has depth +inf: s is +inf or NaN, and 2^−s is 0
                // (see `exp2_neg_or_zero`).
                let wt = k.exp2_neg_or_zero((s01 + s23) + (s45 + d[6] * d[6]));
                weights[t.weights + i] = wt.0;
                for c in 0..3 {
                    s[c] = k.mul_add(wt, tap[c], s[c]);
                }
                s[3] += wt;
            }
            sums[i] = s.map(|v| v.0);
        }
        if y < y0 {
            continue;
        }
        // Backward taps: the weight the neighbour q − o stored, times that neighbour's colour.
        // Outside the image the stored weights are zero (margins, dead rows, taps outside).
        let mut live = [false; 12];
        let back: [Back<'_, N>; 12] = array(|o| {
            let (tx, ty) = FORWARD[o];
            let dx = tx * step as isize;
            let Some(py) = y.checked_sub(ty * step) else { return Back::default() };
            if dx.unsigned_abs() >= w {
                return Back::default();
            }
            live[o] = true;
            let start = ((py - first) % slots * 12 * s8 + o * s8) * N + m;
            Back {
                weights: view(ring.as_flattened(), start.wrapping_add_signed(-dx), wp),
                colour: view(cur.block(py), at(0, -dx), span(3)),
            }
        });
        // The row's three planes, and the column of pixel 0 in them.
        let (mut row, x0): ([&mut [f32]; 3], usize) = match &mut out {
            BandOut::Padded(o) => {
                let (a, rest) = o[(y - y0) * 3 * stride..(y - y0 + 1) * 3 * stride].split_at_mut(stride);
                let (b, c) = rest.split_at_mut(stride);
                ([a, b, c], m)
            }
            BandOut::Image(o) => (o.each_mut().map(|p| &mut p[(y - y0) * w..(y - y0 + 1) * w]), 0),
        };
        for (i, sum) in sums.iter().enumerate() {
            let mut s = sum.map(Wide);
            for (b, &live) in back.iter().zip(&live) {
                if !live {
                    continue;
                }
                let wt = Wide(b.weights[i]);
                let c2 = Wide(b.colour[2 * s8 + i]);
                let col = [Wide(b.colour[i]), Wide(b.colour[s8 + i]), c2];
                for c in 0..3 {
                    s[c] = k.mul_add(wt, col[c], s[c]);
                }
                s[3] += wt;
            }
            // The centre tap always counts (weight ≈ 0.14), so Σw > 0 for image pixels.
            let scale = Wide::splat(factor) / s[3];
            for (c, dst) in row.iter_mut().enumerate() {
                let v = (s[c] * scale).0;
                let x = x0 + i * N;
                let n = w - i * N;
                if n >= N {
                    // A whole vector: one store, not a copy of variable length.
                    dst[x..x + N].copy_from_slice(&v);
                } else {
                    dst[x..x + n].copy_from_slice(&v[..n]);
                }
            }
        }
    }
    if let Ok(mut rings) = RINGS.lock()
        && rings.len() < 8
    {
        rings.push(store);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle;
    use crate::test_util::{PLUS_Z, random_scene, two_halves};

    #[test]
    fn equals_the_direct_definition() {
        let scene = random_scene(37, 19, 5);
        for iterations in [1, 3, 5] {
            let p = AtrousParams { iterations, sigma_colour: 0.8, sigma_normal: 0.6, sigma_depth: 0.4 };
            let want = oracle::atrous_direct(scene.input(), &scene.guide(), &p);
            for isa in [Isa::Portable, Isa::Avx2, Isa::Avx512] {
                let got =
                    crate::apply_with(isa, &crate::Filter::Atrous(p), scene.input(), &scene.guide()).expect("valid");
                for c in 0..3 {
                    let d = got[c].iter().zip(&want[c]).fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
                    assert!(d < 2e-5, "{iterations} iterations, plane {c}: {d}");
                }
            }
        }
    }

    #[test]
    fn the_16_lane_build_gives_the_8_lane_bits() {
        // Same operations lane for lane, on planes laid out for 16 lanes: the same bits, at
        // widths that end inside a 16-lane vector, inside an 8-lane one, and on a whole one.
        for (w, h) in [(37, 19), (45, 11), (64, 9), (5, 7)] {
            let scene = random_scene(w, h, 9);
            for iterations in [1, 2, 5] {
                let p = AtrousParams { iterations, sigma_colour: 0.8, sigma_normal: 0.6, sigma_depth: 0.4 };
                let filter = crate::Filter::Atrous(p);
                let a = crate::apply_with(Isa::Avx2, &filter, scene.input(), &scene.guide()).expect("valid");
                let b = crate::apply_with(Isa::Avx512, &filter, scene.input(), &scene.guide()).expect("valid");
                let bits = |p: &Vec<f32>| p.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
                for c in 0..3 {
                    assert_eq!(bits(&a[c]), bits(&b[c]), "{w}x{h}, {iterations} iterations, plane {c}");
                }
            }
        }
    }

    #[test]
    fn kept_planes_carry_nothing_from_one_call_to_the_next() {
        // The same layout three times (and a failed call between), then the first image again:
        // its bits must not depend on what the pooled planes held before.
        let p = AtrousParams { iterations: 4, sigma_colour: 0.8, sigma_normal: 0.6, sigma_depth: 0.4 };
        let filter = crate::Filter::Atrous(p);
        let a = random_scene(53, 21, 3);
        let mut b = random_scene(53, 21, 4);
        let first = crate::apply(&filter, a.input(), &a.guide()).expect("valid");
        let other = crate::apply(&filter, b.input(), &b.guide()).expect("valid");
        b.depth[17] = f32::NAN;
        assert!(crate::apply(&filter, b.input(), &b.guide()).is_err());
        // A smaller image in between drops the kept planes and keeps its own.
        let c = random_scene(9, 5, 5);
        crate::apply(&filter, c.input(), &c.guide()).expect("valid");
        let again = crate::apply(&filter, a.input(), &a.guide()).expect("valid");
        let bits = |p: &Vec<f32>| p.iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for c in 0..3 {
            assert_eq!(bits(&first[c]), bits(&again[c]), "plane {c}");
            assert_ne!(bits(&first[c]), bits(&other[c]), "plane {c}: two images, one result");
        }
    }

    #[test]
    fn a_black_region_stays_black_not_nearly() {
        // Black beside a bright stripe 8 pixels wide on one surface: the colour's standard
        // deviation is 0.28, so the colour term cuts the weights across the edge to about
        // 2^−60 in the first iteration. Weights that small must be zero, not carried in:
        // black pixels at 1e-17, then (squared, weighted again) far smaller, make later
        // iterations' products underflow, which costs a microcode assist each.
        let scene = two_halves(96, 8, 88, [0.0, 1.0], [0.5, 0.5], [PLUS_Z, PLUS_Z]);
        for isa in [Isa::Portable, Isa::Avx2, Isa::Avx512] {
            let filter = crate::Filter::Atrous(AtrousParams::default());
            let out = crate::apply_with(isa, &filter, scene.input(), &scene.guide()).expect("valid");
            for (i, &v) in out[0].iter().enumerate() {
                assert!(v == 0.0 || v.abs() > 1e-15, "{isa:?}, pixel {i}: {v:e}");
            }
        }
    }

    #[test]
    fn keeps_a_depth_edge() {
        let scene = two_halves(64, 16, 32, [0.2, 0.8], [0.3, 0.6], [PLUS_Z, PLUS_Z]);
        let out = crate::atrous(scene.input(), &scene.guide(), &AtrousParams::default()).expect("valid");
        // Across Δz = 0.3 = 3σz the weight is e^−9 ≈ 1.2e-4 times the kernel weight, and the colour
        // term (Δc = 0.6) cuts it further: bleed stays below 1e-3 of the 0.6 step.
        for (i, v) in out[0].iter().enumerate() {
            let want = if i % 64 < 32 { 0.2 } else { 0.8 };
            assert!((v - want).abs() < 6e-4, "pixel {i}: {v}");
        }
    }
}
