//! The guided image filter (He, Sun, Tang 2010, eqs. 5–8; with a multi-channel guide as in
//! their §3.5 and Bauszat et al. 2011 §3.3), streamed over row strips in O(1) per pixel.
//!
//! Per strip, two sliding windows move down the rows together:
//!
//! 1. **Coefficients.** For each row of window centres k, column sums of the 29 (4-D guide)
//!    quantities I, N, I·Iᵀ (upper triangle) and I·N are updated by adding the row entering the
//!    window and subtracting the row leaving it. Then, 128 columns at a time (so that the
//!    block's data stays in L1): horizontal running sums ([`crate::boxsum`]) turn them into
//!    window sums, and per pixel come the means, `Σ_k + E` and `cov_k(I, N)`, an LDLᵀ solve
//!    for `a_k` (three right-hand sides) and `b_k = mean(N) − a_k·mean(I)`.
//! 2. **Output.** The coefficients are box-summed horizontally as soon as the blocks their
//!    windows reach are done, and kept in a ring of 2r + 2 rows; a second vertical running sum
//!    over the ring gives, for output row i, `Σ a_k` and `Σ b_k` over the windows containing
//!    i, and `F_i = (Σa·I_i + Σb) / n_i`.
//!
//! Everything is f32: the guide is centred (I − 1/2, so |I| ≤ 1/2 and products stay small),
//! horizontal sums are re-based every 128 columns and vertical ones at each strip start, so
//! rounding drift never spans more than a strip. Against the direct f64 definition the error
//! is below 1e-6 of the input's range for inputs in [0, 1] (160×96, r = 28) and below 3e-5
//! relative for light spanning five decades (`precision_report` prints it).
//!
//! Strips depend only on the image height and the radius (never on the thread count): each
//! recomputes the r coefficient rows beyond each of its ends, so strips are few and tall.
//! Inputs are checked for NaN/inf while rows are loaded (every row enters some strip's window),
//! which saves a separate pass over the seven planes; the first bad pixel is searched only
//! when one was seen.
//!
//! Layout: row buffers are whole vectors (`[f32; 8]`) so the compiler can drop bounds checks;
//! per-pixel quantities that are read together (the 29 window sums of a vector, the 15 box
//! sums of a ring row) are interleaved, and planes that are not are spaced an odd number of
//! vectors apart — 29 planes exactly 4 KiB apart (1024 wide) thrash one L1 set and make loads
//! wait on unrelated stores. A strip's buffers (≈ 3.6 MB at 1024 wide, r = 28, mostly the
//! ring) are kept in a small pool between calls: fresh pages cost more than the arithmetic.

use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};

use rayon::prelude::*;

use crate::boxsum::{BLOCK, pad, tail_pad};
use crate::check::{self, Names};
use crate::lanes::{Chunk, F8, LANES, NanIfNotFinite, Wide, array};
use crate::simd::{self, BoxSum};
use crate::{FilterError, Guide, GuideChannels, GuidedParams, Isa};

/// Rec. 709 luma weights (the 1-D guide is the luma of (n + 1)/2).
const LUMA: [f32; 3] = [0.2126, 0.7152, 0.0722];
const MAX_D: usize = 4;
const MAX_Q: usize = quantities(MAX_D);
const MAX_AB: usize = 3 * MAX_D + 3;
const ZERO: Chunk = [0.0; LANES];

/// Number of box-summed quantities for a D-channel guide and three input planes:
/// I (D), N (3), I·Iᵀ (D(D+1)/2), I·N (3D).
const fn quantities(d: usize) -> usize {
    d + 3 + d * (d + 1) / 2 + 3 * d
}

pub(crate) fn guided_into_named(
    isa: Isa,
    input: [&[f32]; 3],
    guide: &Guide,
    p: &GuidedParams,
    names: &Names,
    out: [&mut [f32]; 3],
) -> Result<(), FilterError> {
    let (width, height) = check::sizes(input, guide, names)?;
    check::outputs(&out, width, height)?;
    if p.radius == 0 {
        return Err(FilterError::parameter("guided", "radius must be at least 1 (radius 0 returns the input)"));
    }
    check::positive("guided", "eps_normal", p.eps_normal)?;
    if p.channels == GuideChannels::NormalDepth {
        check::positive("guided", "eps_depth", p.eps_depth)?;
    }
    // A window wider than the image covers it whole whatever r is; cap r so buffers stay small.
    let radius = p.radius.min(width.max(height));
    let eps = [p.eps_normal, p.eps_normal, p.eps_normal, p.eps_depth];
    let src = Source { input, guide: *guide };
    let finite = match p.channels {
        GuideChannels::Grey => run::<1>(isa, src, radius, eps, out),
        GuideChannels::Normal => run::<3>(isa, src, radius, eps, out),
        GuideChannels::NormalDepth => run::<4>(isa, src, radius, eps, out),
    };
    if finite { Ok(()) } else { check::finite(input, guide, names) }
}

/// The unvalidated planes a strip reads.
#[derive(Clone, Copy)]
pub(crate) struct Source<'a> {
    input: [&'a [f32]; 3],
    guide: Guide<'a>,
}

/// Sizes of the strip buffers, in vectors of 8 unless named otherwise.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Layout {
    /// Image width and height in pixels.
    w: usize,
    h: usize,
    r: usize,
    /// Vectors per row.
    n8: usize,
    /// Vectors before column 0 in a padded row (see [`crate::boxsum::pad`]).
    p8: usize,
    /// Vectors per padded row (odd, see `ps`).
    s8: usize,
    /// Vectors between the planes of a row buffer: n8 rounded up to odd. Plane strides that
    /// are multiples of 4 KiB (n8 = 128 at 1024 wide) would put every plane's vector i in the
    /// same L1 set, and 29 planes thrash its 8 ways.
    ps: usize,
}

impl Layout {
    fn new(w: usize, h: usize, r: usize) -> Self {
        let n8 = w.div_ceil(LANES);
        let p8 = pad(r) / LANES;
        Layout { w, h, r, n8, p8, s8: (p8 + n8 + tail_pad(r) / LANES) | 1, ps: n8 | 1 }
    }

    /// 1 / (rows of the clipped window around row y).
    #[inline(always)]
    fn inv_wy(&self, y: usize) -> f32 {
        1.0 / ((y + self.r).min(self.h - 1) - y.saturating_sub(self.r) + 1) as f32
    }
}

/// Rows per strip: the fewest strips (a power of two, for an even split over 2^k threads) such
/// that the recomputed coefficient rows (2r per inner strip boundary) stay under 1/8 of the
/// image, and no strip is shorter than 16 rows; but at least two whenever each half (h/2 rows
/// and the r beyond its inner end) is less work than the whole, so that a large radius still
/// runs on two threads (r = 64 on 768 rows ran as one strip, on one thread).
fn strip_bounds(h: usize, r: usize) -> Vec<(usize, usize)> {
    let mut n = 1;
    while n < 64 && h / (2 * n) >= 16 && ((2 * n - 1) * 2 * r * 8 <= h || (n == 1 && 2 * r < h)) {
        n *= 2;
    }
    (0..n).map(|i| (i * h / n, (i + 1) * h / n)).collect()
}

/// Filters into `out`; false if some input value was not finite (`out` is then garbage).
fn run<const D: usize>(isa: Isa, src: Source, r: usize, eps: [f32; 4], out: [&mut [f32]; 3]) -> bool {
    let (w, h) = (src.guide.width, src.guide.height);
    let lay = Layout::new(w, h, r);
    let inv_wx: Vec<Chunk> = (0..lay.n8)
        .map(|i| {
            array(|l| {
                let x = i * LANES + l;
                if x < w { 1.0 / ((x + r).min(w - 1) - x.saturating_sub(r) + 1) as f32 } else { 0.0 }
            })
        })
        .collect();
    let bad = AtomicBool::new(false);
    let mut rest = out;
    let mut jobs = Vec::new();
    for (y0, y1) in strip_bounds(h, r) {
        let strip: [&mut [f32]; 3] = std::array::from_fn(|i| {
            let (head, tail) = std::mem::take(&mut rest[i]).split_at_mut((y1 - y0) * w);
            rest[i] = tail;
            head
        });
        jobs.push(StripJob { src, lay, eps, inv_wx: &inv_wx, y0, y1, out: strip, bad: &bad });
    }
    jobs.into_par_iter().for_each(|job| simd::guided_strip::<D>(isa, job));
    !bad.load(Ordering::Relaxed)
}

/// One strip: output rows `y0..y1`, written to `out` (rows of width `w`).
pub(crate) struct StripJob<'a> {
    src: Source<'a>,
    lay: Layout,
    eps: [f32; 4],
    inv_wx: &'a [Chunk],
    y0: usize,
    y1: usize,
    out: [&'a mut [f32]; 3],
    /// Set when a loaded value was not finite.
    bad: &'a AtomicBool,
}

/// A strip's buffers, reused between calls through [`POOL`].
#[derive(Default)]
struct Scratch {
    enter: Vec<Chunk>,
    leave: Vec<Chunk>,
    zeros: Vec<Chunk>,
    colsum: Vec<Chunk>,
    rowsum: Vec<Chunk>,
    ab: Vec<Chunk>,
    ring: Vec<Chunk>,
    colsum2: Vec<Chunk>,
    guide_row: Vec<Chunk>,
}

/// At most this many strips' buffers are kept between calls.
const POOL_SIZE: usize = 8;
static POOL: Mutex<Vec<Scratch>> = Mutex::new(Vec::new());

impl Scratch {
    fn take() -> Scratch {
        POOL.lock().ok().and_then(|mut pool| pool.pop()).unwrap_or_default()
    }

    fn give_back(self) {
        if let Ok(mut pool) = POOL.lock()
            && pool.len() < POOL_SIZE
        {
            pool.push(self);
        }
    }
}

impl Scratch {
    /// Every buffer at its size for a strip of `slots` coefficient rows (zeros but the ring,
    /// whose slots are each written before they are read).
    fn size<const D: usize>(&mut self, lay: &Layout, slots: usize) {
        let Layout { n8, s8, ps, .. } = *lay;
        let (nq, nab, ng) = (quantities(D), 3 * D + 3, D + 3);
        zeroed(&mut self.enter, ng * ps);
        zeroed(&mut self.leave, ng * ps);
        zeroed(&mut self.zeros, (nab * n8).max(ng * ps));
        zeroed(&mut self.colsum, nq * s8);
        zeroed(&mut self.rowsum, nq * BLOCK);
        zeroed(&mut self.ab, nab * s8);
        self.ring.resize(slots * nab * n8, ZERO);
        zeroed(&mut self.colsum2, nab * n8);
        zeroed(&mut self.guide_row, ng * ps);
    }
}

/// The strips' buffers of a `w`×`h` filter with these parameters, made (their pages written,
/// each strip's on the thread that takes it) and kept for the next call: see [`crate::reserve`].
pub(crate) fn reserve(w: usize, h: usize, p: &GuidedParams) {
    if w == 0 || h == 0 || p.radius == 0 {
        return;
    }
    let r = p.radius.min(w.max(h));
    let lay = Layout::new(w, h, r);
    let size = |(y0, y1): (usize, usize)| {
        let slots = (2 * r + 2).min((y1 + r).min(h) - y0.saturating_sub(r));
        let mut sc = Scratch::take();
        match p.channels {
            GuideChannels::Grey => sc.size::<1>(&lay, slots),
            GuideChannels::Normal => sc.size::<3>(&lay, slots),
            GuideChannels::NormalDepth => sc.size::<4>(&lay, slots),
        }
        // The ring's new pages too (`size` keeps its contents).
        sc.ring.fill(ZERO);
        sc
    };
    let kept: Vec<Scratch> = strip_bounds(h, r).into_par_iter().map(size).collect();
    kept.into_iter().for_each(Scratch::give_back);
}

/// `v` := `n` zero vectors.
fn zeroed(v: &mut Vec<Chunk>, n: usize) {
    v.clear();
    v.resize(n, ZERO);
}

/// The sliding window of rows `lo..hi` a running sum currently holds.
#[derive(Clone, Copy)]
struct Window {
    lo: usize,
    hi: usize,
}

impl Window {
    /// The next (entering, leaving) rows on the way to `lo..hi`; `None` when already there.
    #[inline(always)]
    fn step(&mut self, lo: usize, hi: usize) -> Option<(Option<usize>, Option<usize>)> {
        let enter = (self.hi < hi).then(|| {
            self.hi += 1;
            self.hi - 1
        });
        let leave = (self.lo < lo).then(|| {
            self.lo += 1;
            self.lo - 1
        });
        (enter.is_some() || leave.is_some()).then_some((enter, leave))
    }
}

/// Runs one strip. See the module documentation.
#[inline(always)]
pub(crate) fn strip<const D: usize, K: BoxSum>(k: K, job: StripJob<'_>) {
    let StripJob { src, lay, eps, inv_wx, y0, y1, mut out, bad } = job;
    let Layout { w, h, r, n8, s8, ps, .. } = lay;
    let nq = quantities(D);
    let nab = 3 * D + 3;
    let ng = D + 3;
    // Coefficient rows this strip needs: those of every window containing one of its rows.
    let (c0, c1) = (y0.saturating_sub(r), (y1 + r).min(h));
    let slots = (2 * r + 2).min(c1 - c0);

    let mut sc = Scratch::take();
    sc.size::<D>(&lay, slots);

    let mut finite = true;
    let mut win1 = Window { lo: c0.saturating_sub(r), hi: c0.saturating_sub(r) };
    let mut win2 = Window { lo: c0, hi: c0 };
    let mut y = y0;
    let slot = |c: usize| (c - c0) % slots * nab * n8;
    for c in c0..c1 {
        // Stage 1: window sums around row c, then a_k, b_k for the row.
        while let Some((e, l)) = win1.step(c.saturating_sub(r), (c + r + 1).min(h)) {
            let e_row: &[Chunk] = match e {
                Some(row) => {
                    // Every row enters some strip's window once: check it here.
                    finite &= load_row::<D, true>(&src, &lay, row, &mut sc.enter);
                    &sc.enter
                }
                None => &sc.zeros[..ng * ps],
            };
            let l_row: &[Chunk] = match l {
                Some(row) => {
                    load_row::<D, true>(&src, &lay, row, &mut sc.leave);
                    &sc.leave
                }
                None => &sc.zeros[..ng * ps],
            };
            vertical1::<D>(&lay, &mut sc.colsum, e_row, l_row);
        }
        // Then block by block (128 columns, L1-sized): window sums, coefficients, and the
        // horizontal sums of the coefficients `lag` blocks behind (their window must be done).
        let s = slot(c);
        let blocks = n8.div_ceil(BLOCK);
        let lag = r.div_ceil(LANES).div_ceil(BLOCK);
        let range = |b: usize| (b * BLOCK, ((b + 1) * BLOCK).min(n8));
        for b in 0..blocks + lag {
            if b < blocks {
                k.hbox(&sc.colsum, s8, nq, &mut sc.rowsum, nq, range(b), r);
                coefficients::<D>(&lay, &sc.rowsum, range(b), inv_wx, lay.inv_wy(c), eps, &mut sc.ab);
            }
            if b >= lag {
                let (i0, i1) = range(b - lag);
                k.hbox(&sc.ab, s8, nab, &mut sc.ring[s + i0 * nab..s + i1 * nab], nab, (i0, i1), r);
            }
        }

        // Stage 2: every output row whose window of coefficient rows is now complete.
        while y < y1 && (y + r).min(h - 1) <= c {
            while let Some((e, l)) = win2.step(y.saturating_sub(r), (y + r + 1).min(h)) {
                let e_row = match e {
                    Some(row) => &sc.ring[slot(row)..slot(row) + nab * n8],
                    None => &sc.zeros[..nab * n8],
                };
                let l_row = match l {
                    Some(row) => &sc.ring[slot(row)..slot(row) + nab * n8],
                    None => &sc.zeros[..nab * n8],
                };
                vertical2(&mut sc.colsum2, e_row, l_row);
            }
            load_row::<D, false>(&src, &lay, y, &mut sc.guide_row);
            let o = (y - y0) * w;
            let [r0, r1, r2] = &mut out;
            let rows = [&mut r0[o..o + w], &mut r1[o..o + w], &mut r2[o..o + w]];
            output_row::<D>(&lay, &sc.colsum2, &sc.guide_row, inv_wx, lay.inv_wy(y), rows);
            y += 1;
        }
    }
    debug_assert_eq!(y, y1);
    if !finite {
        bad.store(true, Ordering::Relaxed);
    }
    sc.give_back();
}

/// `dst[..] = f(src[..])` by vectors, lanes past the row's end set to zero; `check`
/// accumulates `v − v` (0, or NaN for a non-finite v).
#[inline(always)]
fn convert(src: &[f32], dst: &mut [Chunk], check: &mut F8, f: impl Fn(F8) -> F8) {
    let (full, tail) = src.as_chunks::<LANES>();
    for (d, s) in dst.iter_mut().zip(full) {
        let v = Wide(*s);
        *check += v.nan_if_not_finite();
        *d = f(v).0;
    }
    if !tail.is_empty() {
        let mut t = ZERO;
        t[..tail.len()].copy_from_slice(tail);
        let v = Wide(t);
        *check += v.nan_if_not_finite();
        let mut o = f(v).0;
        o[tail.len()..].fill(0.0);
        dst[full.len()] = o;
    }
}

/// Accumulates `v − v` over `src` into `check` (see [`convert`]).
#[inline(always)]
fn check_plane(src: &[f32], check: &mut F8) {
    let (full, tail) = src.as_chunks::<LANES>();
    for s in full {
        *check += Wide(*s).nan_if_not_finite();
    }
    for &v in tail {
        check.0[0] += v.nan_if_not_finite();
    }
}

/// Row `y` of the centred guide I − 1/2 (D planes) and, with `INPUT`, the input (3 planes),
/// planes `ps` vectors apart, zero past the image. Returns whether every value read was finite (with
/// `INPUT` all seven planes are read, including any the guide does not use).
#[inline(always)]
fn load_row<const D: usize, const INPUT: bool>(src: &Source, lay: &Layout, y: usize, dst: &mut [Chunk]) -> bool {
    let (w, n8, ps) = (lay.w, lay.n8, lay.ps);
    let row = y * w..(y + 1) * w;
    let mut check = F8::ZERO;
    let [nx, ny, nz] = [0, 1, 2].map(|k| &src.guide.normal[k][row.clone()]);
    let depth = &src.guide.depth[row.clone()];
    if D == 1 {
        // 0.5 · luma(n) = luma((n + 1)/2) − 1/2 (the weights sum to 1).
        let (full, tail) = (w / LANES, w % LANES);
        for (i, d) in dst[..n8].iter_mut().enumerate() {
            let load = |p: &[f32]| {
                let mut c = ZERO;
                let n = if i < full { LANES } else { tail };
                c[..n].copy_from_slice(&p[i * LANES..i * LANES + n]);
                Wide(c)
            };
            let (x, y, z) = (load(nx), load(ny), load(nz));
            if INPUT {
                check += x.nan_if_not_finite() + y.nan_if_not_finite() + z.nan_if_not_finite();
            }
            *d = ((x * F8::splat(0.5 * LUMA[0]) + y * F8::splat(0.5 * LUMA[1])) + z * F8::splat(0.5 * LUMA[2])).0;
        }
        if INPUT {
            check_plane(depth, &mut check);
        }
    } else {
        for (k, n) in [nx, ny, nz].into_iter().enumerate() {
            convert(n, &mut dst[k * ps..k * ps + n8], &mut check, |v| v * F8::splat(0.5));
        }
        if D == 4 {
            convert(depth, &mut dst[3 * ps..3 * ps + n8], &mut check, |v| v.min(F8::splat(1.0)) - F8::splat(0.5));
        } else if INPUT {
            check_plane(depth, &mut check);
        }
    }
    if INPUT {
        for (c, plane) in src.input.iter().enumerate() {
            convert(&plane[row.clone()], &mut dst[(D + c) * ps..(D + c) * ps + n8], &mut check, |v| v);
        }
    }
    check.0 == ZERO
}

/// Adds the quantities of row `e` to the column sums and subtracts those of row `l` (each D + 3
/// planes as [`load_row`] makes them).
#[inline(always)]
fn vertical1<const D: usize>(lay: &Layout, colsum: &mut [Chunk], e: &[Chunk], l: &[Chunk]) {
    let Layout { n8, p8, s8, ps, .. } = *lay;
    let mut cs: [&mut [Chunk]; MAX_Q] = Default::default();
    for (q, plane) in colsum.chunks_exact_mut(s8).take(quantities(D)).enumerate() {
        cs[q] = &mut plane[p8..p8 + n8];
    }
    let ep: [&[Chunk]; MAX_D + 3] = array(|k| if k < D + 3 { &e[k * ps..k * ps + n8] } else { &[] });
    let lp: [&[Chunk]; MAX_D + 3] = array(|k| if k < D + 3 { &l[k * ps..k * ps + n8] } else { &[] });
    for i in 0..n8 {
        let (mut ie, mut il) = ([F8::ZERO; D], [F8::ZERO; D]);
        for d in 0..D {
            ie[d] = Wide(ep[d][i]);
            il[d] = Wide(lp[d][i]);
        }
        let (mut ne, mut nl) = ([F8::ZERO; 3], [F8::ZERO; 3]);
        for c in 0..3 {
            ne[c] = Wide(ep[D + c][i]);
            nl[c] = Wide(lp[D + c][i]);
        }
        let mut q = 0;
        macro_rules! add {
            ($v:expr) => {{
                let s = &mut cs[q][i];
                *s = (Wide(*s) + $v).0;
                q += 1;
            }};
        }
        for d in 0..D {
            add!(ie[d] - il[d]);
        }
        for c in 0..3 {
            add!(ne[c] - nl[c]);
        }
        for j in 0..D {
            for m in j..D {
                add!(ie[j] * ie[m] - il[j] * il[m]);
            }
        }
        for c in 0..3 {
            for d in 0..D {
                add!(ie[d] * ne[c] - il[d] * nl[c]);
            }
        }
    }
}

/// `a_k` (3 × D planes, colour-major) and `b_k` (3 planes) of the vectors `range` of one row
/// from their window sums (interleaved from `range.0` on, see [`crate::boxsum::hbox_portable`]), written into
/// the padded planes of `ab`.
#[inline(always)]
fn coefficients<const D: usize>(
    lay: &Layout,
    rowsum: &[Chunk],
    (i0, i1): (usize, usize),
    inv_wx: &[Chunk],
    inv_wy: f32,
    eps: [f32; 4],
    ab: &mut [Chunk],
) {
    let Layout { n8, p8, s8, .. } = *lay;
    let nii = D * (D + 1) / 2;
    let nq = quantities(D);
    let rowsum = &rowsum[..(i1 - i0) * nq];
    let mut out: [&mut [Chunk]; MAX_AB] = Default::default();
    for (q, plane) in ab.chunks_exact_mut(s8).take(3 * D + 3).enumerate() {
        out[q] = &mut plane[p8..p8 + n8];
    }
    let inv_wx = &inv_wx[..n8];
    // The pivots of Σ + E are at least min ε in exact arithmetic; flooring them at half that
    // only matters when rounding makes Σ slightly indefinite, and keeps every output finite.
    let floor = F8::splat(0.5 * eps[..D].iter().fold(f32::INFINITY, |m, &e| m.min(e)));
    for i in i0..i1 {
        let inv_n = Wide(inv_wx[i]) * F8::splat(inv_wy);
        let sums = &rowsum[(i - i0) * nq..(i - i0 + 1) * nq];
        let mut mean = [F8::ZERO; MAX_Q];
        for q in 0..nq {
            mean[q] = Wide(sums[q]) * inv_n;
        }
        let mut mi = [F8::ZERO; D];
        mi.copy_from_slice(&mean[..D]);
        let mut mn = [F8::ZERO; 3];
        mn.copy_from_slice(&mean[D..D + 3]);
        // Σ + E, lower triangle (s[m][j], j <= m).
        let mut s = [[F8::ZERO; D]; D];
        let mut q = D + 3;
        for j in 0..D {
            for m in j..D {
                s[m][j] = mean[q] - mi[j] * mi[m];
                q += 1;
            }
            s[j][j] += F8::splat(eps[j]);
        }
        // LDLᵀ: unit lower l, pivots d (and their reciprocals).
        let mut l = [[F8::ZERO; D]; D];
        let mut d = [F8::ZERO; D];
        let mut inv_d = [F8::ZERO; D];
        // Every loop below runs D times, its bounds tested inside (`m < j`, ...): trip counts
        // that are constants let LLVM unroll the whole solve into straight-line code in
        // registers. With triangular bounds (`0..j`) it kept the loops, indexing the arrays on
        // the stack, and the chain of pivots (a division each) left the core waiting; the
        // operations and their order are the same.
        for j in 0..D {
            let mut dj = s[j][j];
            for m in 0..D {
                if m < j {
                    dj = dj - l[j][m] * l[j][m] * d[m];
                }
            }
            d[j] = dj.max(floor);
            inv_d[j] = F8::splat(1.0) / d[j];
            for m in 0..D {
                if m > j {
                    let mut v = s[m][j];
                    for t in 0..D {
                        if t < j {
                            v = v - l[m][t] * l[j][t] * d[t];
                        }
                    }
                    l[m][j] = v * inv_d[j];
                }
            }
        }
        for c in 0..3 {
            // cov(I, N_c), then forward, diagonal and backward substitution.
            let mut a = [F8::ZERO; D];
            for m in 0..D {
                a[m] = mean[D + 3 + nii + c * D + m] - mi[m] * mn[c];
            }
            for m in 0..D {
                for t in 0..D {
                    if t < m {
                        a[m] = a[m] - l[m][t] * a[t];
                    }
                }
            }
            for m in 0..D {
                a[m] = a[m] * inv_d[m];
            }
            for k in 0..D {
                let m = D - 1 - k;
                for t in 0..D {
                    if t > m {
                        a[m] = a[m] - l[t][m] * a[t];
                    }
                }
            }
            let mut b = mn[c];
            for m in 0..D {
                b = b - a[m] * mi[m];
                out[c * D + m][i] = a[m].0;
            }
            out[3 * D + c][i] = b.0;
        }
    }
}

/// `colsum2 += e − l`, element-wise.
#[inline(always)]
fn vertical2(colsum2: &mut [Chunk], e: &[Chunk], l: &[Chunk]) {
    for ((s, e), l) in colsum2.iter_mut().zip(e).zip(l) {
        *s = (Wide(*s) + (Wide(*e) - Wide(*l))).0;
    }
}

/// `F = (Σa · I + Σb) / n` for one output row (`colsum2` interleaved), into `out` (3 rows of
/// `w` pixels).
#[inline(always)]
fn output_row<const D: usize>(
    lay: &Layout,
    colsum2: &[Chunk],
    guide_row: &[Chunk],
    inv_wx: &[Chunk],
    inv_wy: f32,
    out: [&mut [f32]; 3],
) {
    let (n8, ps) = (lay.n8, lay.ps);
    let cs = &colsum2[..n8 * (3 * D + 3)];
    let g: [&[Chunk]; MAX_D] = array(|d| if d < D { &guide_row[d * ps..d * ps + n8] } else { &[] });
    let inv_wx = &inv_wx[..n8];
    for (c, row) in out.into_iter().enumerate() {
        let (full, tail) = row.as_chunks_mut::<LANES>();
        for (i, o) in full.iter_mut().enumerate() {
            *o = output_value::<D>(cs, &g, inv_wx, inv_wy, i, c).0;
        }
        if !tail.is_empty() {
            let n = tail.len();
            tail.copy_from_slice(&output_value::<D>(cs, &g, inv_wx, inv_wy, full.len(), c).0[..n]);
        }
    }
}

/// `(Σa · I + Σb) / n` of colour `c` at vector `i`.
#[inline(always)]
fn output_value<const D: usize>(
    cs: &[Chunk],
    g: &[&[Chunk]; MAX_D],
    inv_wx: &[Chunk],
    inv_wy: f32,
    i: usize,
    c: usize,
) -> F8 {
    let nab = 3 * D + 3;
    let sums = &cs[i * nab..(i + 1) * nab];
    let inv_n = Wide(inv_wx[i]) * F8::splat(inv_wy);
    let mut v = Wide(sums[3 * D + c]);
    for d in 0..D {
        v += Wide(sums[c * D + d]) * Wide(g[d][i]);
    }
    v * inv_n
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle;
    use crate::test_util::random_scene;

    fn max_diff(a: &[f32], b: &[f32]) -> f32 {
        a.iter().zip(b).fold(0.0f32, |m, (x, y)| m.max((x - y).abs()))
    }

    #[test]
    fn equals_the_direct_definition() {
        for channels in [GuideChannels::Grey, GuideChannels::Normal, GuideChannels::NormalDepth] {
            for (w, h, seed) in [(23, 17, 1), (9, 30, 2), (40, 8, 3)] {
                let scene = random_scene(w, h, seed);
                for radius in 1..=5 {
                    let p = GuidedParams { radius, eps_normal: 0.01, eps_depth: 0.02, channels };
                    let want = oracle::guided_direct(scene.input(), &scene.guide(), &p);
                    for isa in [Isa::Portable, Isa::Avx2] {
                        let got = crate::apply_with(isa, &crate::Filter::Guided(p), scene.input(), &scene.guide())
                            .expect("valid");
                        for c in 0..3 {
                            let d = max_diff(&got[c], &want[c]);
                            // The input spans [0, 1]: the bound is relative to its range.
                            assert!(d <= 1e-5, "{channels:?} {w}x{h} r {radius} plane {c}: {d}");
                        }
                    }
                }
            }
        }
    }

    /// Prints the worst error against the f64 definition on larger, high-dynamic-range inputs
    /// (`cargo test --release -p glint-filter -- --ignored --nocapture precision`).
    #[test]
    #[ignore]
    fn precision_report() {
        for (w, h, r, hdr) in [(160, 96, 28, false), (160, 96, 28, true), (256, 64, 60, true)] {
            let mut scene = random_scene(w, h, 11);
            if hdr {
                // Light spanning five decades, with a bright block.
                for (i, v) in scene.input[0].iter_mut().enumerate() {
                    let (x, y) = (i % w, i / w);
                    *v = 10f32.powf(*v * 5.0 - 3.0) * if (40..80).contains(&x) && y < 40 { 100.0 } else { 1.0 };
                }
            }
            let p = GuidedParams { radius: r, eps_normal: 0.01, eps_depth: 0.02, channels: GuideChannels::NormalDepth };
            let want = oracle::guided_direct(scene.input(), &scene.guide(), &p);
            let got = crate::guided(scene.input(), &scene.guide(), &p).expect("valid");
            let range = scene.input[0].iter().fold(0.0f32, |m, &v| m.max(v))
                - scene.input[0].iter().fold(f32::MAX, |m, &v| m.min(v));
            let abs = max_diff(&got[0], &want[0]);
            let rel = got[0].iter().zip(&want[0]).fold(0.0f32, |m, (a, b)| m.max((a - b).abs() / b.abs().max(1e-3)));
            println!(
                "{w}x{h} r {r} hdr {hdr}: max |Δ| = {abs:.3e} = {:.3e} of the range, max relative {rel:.3e}",
                abs / range
            );
        }
    }

    #[test]
    fn strips_never_depend_on_threads() {
        assert_eq!(strip_bounds(768, 28), vec![(0, 384), (384, 768)]);
        assert_eq!(strip_bounds(768, 8).len(), 4);
        assert_eq!(strip_bounds(10, 1), vec![(0, 10)]);
        // A large radius still splits in two while half plus its margin is less than the whole.
        assert_eq!(strip_bounds(768, 64), vec![(0, 384), (384, 768)]);
        assert_eq!(strip_bounds(768, 383), vec![(0, 384), (384, 768)]);
        assert_eq!(strip_bounds(768, 384), vec![(0, 768)]);
    }
}
