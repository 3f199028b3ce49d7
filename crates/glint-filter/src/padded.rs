//! Planes with zero margins left and right, so that the weighted filters load eight
//! neighbours at any tap offset without a bounds branch per lane (taps that fall outside the
//! image are then given weight zero by a mask, never read from another row).
//!
//! The planes of one row are stored side by side (row-interleaved): a kernel reading all of a
//! pixel's features takes one slice per row and lets the compiler check its bounds once.

use rayon::prelude::*;

use crate::lanes::{F8, LANES, NanIfNotFinite, Wide};

/// `count` planes of `h` rows, row-interleaved: plane k of row y starts at
/// `(y·count + k)·stride`, with image column x at `margin + x`. Columns outside `0..w` hold
/// zeros (or what [`Padded::set_outside`] put there). The planes start on a 64-byte line, so
/// with margins and strides in whole vectors every vector at a pixel offset that is a multiple
/// of the width loads from one cache line.
#[derive(Debug)]
pub(crate) struct Padded {
    pub w: usize,
    pub h: usize,
    /// `w` rounded up to whole vectors.
    pub wp: usize,
    pub margin: usize,
    pub stride: usize,
    pub count: usize,
    /// The planes, from `start` on (the allocation's first 64-byte line boundary).
    data: Vec<f32>,
    start: usize,
}

/// Floats per cache line.
const LINE: usize = 16;

impl Padded {
    /// `count` zero planes for a `w`×`h` image whose kernels reach `reach` columns sideways.
    pub(crate) fn zeros(w: usize, h: usize, reach: usize, count: usize) -> Self {
        Self::zeros_for(LANES, w, h, reach, count)
    }

    /// [`Padded::zeros`] for kernels of `lanes` lanes: rows, margins and strides in whole
    /// vectors of that width.
    pub(crate) fn zeros_for(lanes: usize, w: usize, h: usize, reach: usize, count: usize) -> Self {
        let (wp, margin, stride) = Self::layout(lanes, w, reach);
        let data = vec![0.0; h * count * stride + LINE];
        let start = (LINE - (data.as_ptr() as usize / size_of::<f32>()) % LINE) % LINE;
        Self { w, h, wp, margin, stride, count, data, start }
    }

    /// The padded width, margin and stride of [`Padded::zeros_for`]'s rows.
    pub(crate) fn layout(lanes: usize, w: usize, reach: usize) -> (usize, usize, usize) {
        let wp = w.div_ceil(lanes) * lanes;
        let margin = reach.div_ceil(lanes) * lanes;
        // An odd number of vectors per plane row keeps the planes of a row out of one L1 set.
        let stride = (((margin + wp + margin) / lanes) | 1) * lanes;
        (wp, margin, stride)
    }

    /// All planes, row after row.
    pub(crate) fn planes_mut(&mut self) -> &mut [f32] {
        let len = self.h * self.count * self.stride;
        &mut self.data[self.start..self.start + len]
    }

    /// Plane `k` := `f(src)` inside the image, rows in parallel. Returns whether every value of
    /// `src` was finite (checked on the way: `v − v` is 0 exactly when v is finite).
    pub(crate) fn fill(&mut self, k: usize, src: &[f32], f: impl Fn(f32) -> f32 + Sync) -> bool {
        let (w, m, stride) = (self.w, self.margin, self.stride);
        let row_finite = |(block, s): (&mut [f32], &[f32])| {
            let mut check = F8::ZERO;
            let row = &mut block[k * stride + m..k * stride + m + w];
            let (full, tail) = s.as_chunks::<LANES>();
            for (d, c) in row.chunks_mut(LANES).zip(full) {
                let v = Wide(*c);
                check += v.nan_if_not_finite();
                for (d, &v) in d.iter_mut().zip(c) {
                    *d = f(v);
                }
            }
            for (d, &v) in row[full.len() * LANES..].iter_mut().zip(tail) {
                check.0[0] += v.nan_if_not_finite();
                *d = f(v);
            }
            check == F8::ZERO
        };
        let count = self.count;
        let rows = self.planes_mut().par_chunks_exact_mut(count * stride).zip(src.par_chunks_exact(w));
        rows.with_min_len(16).map(row_finite).reduce(|| true, |a, b| a && b)
    }

    /// Plane `k` := `v` outside the image: its margins and the columns from `w` to the next
    /// whole vector, on every row.
    pub(crate) fn set_outside(&mut self, k: usize, v: f32) {
        let (w, m, stride, count) = (self.w, self.margin, self.stride, self.count);
        self.planes_mut().par_chunks_exact_mut(count * stride).with_min_len(16).for_each(|block| {
            let row = &mut block[k * stride..(k + 1) * stride];
            row[..m].fill(v);
            row[m + w..].fill(v);
        });
    }

    /// All planes of row `y`, side by side.
    #[inline(always)]
    pub(crate) fn block(&self, y: usize) -> &[f32] {
        let n = self.count * self.stride;
        &self.data[self.start + y * n..self.start + (y + 1) * n]
    }

    /// The padded row `y` of plane `k`.
    #[inline(always)]
    #[cfg(test)]
    pub(crate) fn row(&self, k: usize, y: usize) -> &[f32] {
        let start = self.start + (y * self.count + k) * self.stride;
        &self.data[start..start + self.stride]
    }
}

/// The `wp` floats of `block` from `start` on, as vectors of `N` lanes: views of one row
/// that are all `wp / N` long, so that indexing them by a vector index needs no further
/// bounds check.
#[inline(always)]
pub(crate) fn view<const N: usize>(block: &[f32], start: usize, wp: usize) -> &[[f32; N]] {
    block[start..start + wp].as_chunks::<N>().0
}

#[cfg(test)]
mod tests {
    use super::Padded;

    #[test]
    fn planes_start_on_a_line_and_outside_values_stay_outside() {
        for (lanes, w, reach) in [(8, 13, 5), (16, 37, 33), (16, 64, 16)] {
            let mut p = Padded::zeros_for(lanes, w, 3, reach, 2);
            assert_eq!(p.block(0).as_ptr() as usize % 64, 0, "{lanes} lanes, w {w}");
            assert_eq!((p.wp % lanes, p.margin % lanes, p.stride % lanes), (0, 0, 0));
            let src: Vec<f32> = (0..w * 3).map(|i| i as f32).collect();
            assert!(p.fill(1, &src, |v| v + 0.5));
            p.set_outside(1, f32::INFINITY);
            for y in 0..3 {
                let row = p.row(1, y);
                for (x, &v) in row.iter().enumerate() {
                    let inside = x >= p.margin && x < p.margin + w;
                    let want = if inside { (y * w + x - p.margin) as f32 + 0.5 } else { f32::INFINITY };
                    assert_eq!(v, want, "row {y}, column {x}");
                }
                // The other plane keeps its zeros.
                assert!(p.row(0, y).iter().all(|&v| v == 0.0));
            }
            // A non-finite value is reported.
            let mut bad = src.clone();
            bad[4] = f32::NAN;
            assert!(!p.fill(0, &bad, |v| v));
        }
    }
}
