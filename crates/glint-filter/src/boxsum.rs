//! Horizontal box sums of one row in O(1) per pixel, the half of the guided filter's box means
//! that does not vectorise by itself (the vertical half is an element-wise running sum).
//!
//! A row `S` is stored with at least `r + 1` zeros before `S[0]` and `r` after its end (rounded
//! up to whole vectors), so that clipping at the border is the same as summing zeros. The
//! window sum `H[x] = Σ S[x−r..=x+r]` then obeys `H[x] = H[x−1] + (S[x+r] − S[x−r−1])`. The
//! differences are scanned four at a time (a log-step prefix sum: shift by one lane and add,
//! by two and add), then the running carry is added; the carry is re-based from a fresh window
//! sum every [`REBASE`] columns, so rounding drift never spans more than that.
//!
//! Two rows are processed together, one in each 128-bit half of an AVX register, so the AVX2
//! kernel (`simd.rs`) needs only in-lane shuffles (cross-lane ones cost 3–4× more on Zen) and
//! its carry chain is one addition per four columns of two rows. The portable code below
//! performs exactly the same additions in the same order, so both give the same bits.

use crate::lanes::{Chunk, F8, LANES, Wide};

/// Columns between fresh window sums.
pub(crate) const REBASE: usize = 128;

/// `Σ s` in a fixed order: eight lane sums over whole vectors, the tail, then the lanes.
#[inline(always)]
pub(crate) fn window_sum(s: &[f32]) -> f32 {
    let (whole, tail) = s.as_chunks::<LANES>();
    let mut acc = F8::ZERO;
    for c in whole {
        acc += Wide(*c);
    }
    let mut t = 0.0;
    for v in tail {
        t += v;
    }
    let a = acc.0;
    (((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))) + t
}

/// The inclusive prefix sum of four lanes as the AVX2 kernel computes it: shift by one lane
/// and add, then by two and add.
#[inline(always)]
pub(crate) fn scan4(d: [f32; 4]) -> [f32; 4] {
    let s = [d[0] + 0.0, d[1] + d[0], d[2] + d[1], d[3] + d[2]];
    [s[0] + 0.0, s[1] + 0.0, s[2] + s[0], s[3] + s[1]]
}

/// Where a padded row keeps its data: `pad(r)` zeros (at least r + 1, a whole number of
/// vectors) before S[0], and [`tail_pad`] after the row.
#[inline(always)]
pub(crate) const fn pad(r: usize) -> usize {
    (r + 1).div_ceil(LANES) * LANES
}

/// Zeros after the data of a padded row (at least r, a whole number of vectors).
#[inline(always)]
pub(crate) const fn tail_pad(r: usize) -> usize {
    r.div_ceil(LANES) * LANES
}

/// Vectors per re-based block.
pub(crate) const BLOCK: usize = REBASE / LANES;

/// Horizontal box sums of `n` padded rows over the vectors `i0..i1` (i0 a multiple of
/// [`BLOCK`]): for row q (the `s8` vectors at `src[q·s8..]`, holding S_q[j] at float
/// `pad(r) + j` and zeros outside S_q), `H[x] = Σ_{j=x−r}^{x+r} S_q[j]` for x from 8·i0 to
/// 8·i1 − 1, written interleaved: vector i of row q to `dst[(i − i0)·stride + q]`. Rows are
/// processed in pairs (an odd last row with itself), one per 128-bit half in the AVX2 kernel.
#[inline(always)]
pub(crate) fn hbox_portable(
    src: &[Chunk],
    s8: usize,
    n: usize,
    dst: &mut [Chunk],
    stride: usize,
    (i0, i1): (usize, usize),
    r: usize,
) {
    let (lo, hi) = (pad(r) - r - 1, pad(r) + r);
    check_hbox(src.len(), s8, n, dst.len(), stride, (i0, i1), r);
    for q in (0..n).step_by(2) {
        let pair = [q, (q + 1).min(n - 1)];
        let rows = pair.map(|q| src[q * s8..(q + 1) * s8].as_flattened());
        for start in (i0..i1).step_by(BLOCK) {
            let mut carry = rows.map(|row| window_sum(&row[lo + start * LANES..hi + start * LANES]));
            for i in start..i1.min(start + BLOCK) {
                for half in 0..2 {
                    let x = i * LANES + half * 4;
                    for k in 0..2 {
                        let d: [f32; 4] = std::array::from_fn(|l| rows[k][hi + x + l] - rows[k][lo + x + l]);
                        let s = scan4(d);
                        let out = &mut dst[(i - i0) * stride + pair[k]][half * 4..half * 4 + 4];
                        for l in 0..4 {
                            out[l] = s[l] + carry[k];
                        }
                        carry[k] += s[3];
                    }
                }
            }
        }
    }
}

/// The bounds [`hbox_portable`] and its AVX2 twin rely on.
#[inline(always)]
pub(crate) fn check_hbox(
    src_len: usize,
    s8: usize,
    n: usize,
    dst_len: usize,
    stride: usize,
    (i0, i1): (usize, usize),
    r: usize,
) {
    let ok = n > 0
        && i0 < i1
        && i0 % BLOCK == 0
        && n <= stride
        && (i1 - i0) * stride <= dst_len
        && n * s8 <= src_len
        && s8 * LANES >= pad(r) + r + i1 * LANES;
    assert!(ok, "hbox: bad block or buffers too short");
}

#[cfg(test)]
mod tests {
    use super::*;

    fn padded(s: &[f32], r: usize, width: usize) -> Vec<Chunk> {
        let mut v = vec![0.0; pad(r)];
        v.extend_from_slice(s);
        v.resize(pad(r) + width + tail_pad(r), 0.0);
        v.as_chunks::<LANES>().0.to_vec()
    }

    #[test]
    fn box_sums_equal_direct_sums() {
        let s: Vec<f32> = (0..300).map(|i| ((i * 37 % 101) as f32) * 0.25 - 3.0).collect();
        for r in [1, 2, 5, 40, 200, 400] {
            let width = 304;
            let src = padded(&s, r, width);
            let mut dst = vec![[0.0; LANES]; width / LANES];
            hbox_portable(&src, src.len(), 1, &mut dst, 1, (0, width / LANES), r);
            let dst = dst.as_flattened();
            for x in 0..s.len() {
                let lo = x.saturating_sub(r);
                let hi = (x + r).min(s.len() - 1);
                let want: f64 = s[lo..=hi].iter().map(|&v| v as f64).sum();
                assert!((dst[x] as f64 - want).abs() < 1e-3, "r {r} x {x}: {} vs {want}", dst[x]);
            }
        }
    }

    #[test]
    fn scan_is_a_prefix_sum() {
        assert_eq!(scan4([1.0, 2.0, 3.0, 4.0]), [1.0, 3.0, 6.0, 10.0]);
    }
}
