//! One mip level of an environment map: a grid of linear RGB texels with a one-texel border
//! around it, so that every bilinear footprint reads four stored texels without a branch. What
//! the border holds (the neighbouring cube face, the opposite longitude, a clamped row) is
//! decided by the map that owns the level; this module only stores, filters and downsamples.

use glint_core::{Rgb, Vec3A};

/// `width × height` texels inside a border of one texel on each side. Row 0 is the top row.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Level {
    pub width: usize,
    pub height: usize,
    /// `width + 2`.
    pub stride: usize,
    /// `(width + 2) × (height + 2)` texels, border included; 16-byte SIMD lanes (the fourth
    /// unused), so that a bilinear lerp is three vector operations.
    pub texels: Vec<Vec3A>,
}

impl Level {
    /// A level holding `texels` (`width × height`, row-major, no border); the border is zero
    /// until the owner fills it.
    pub fn from_interior(width: usize, height: usize, texels: &[Rgb]) -> Level {
        debug_assert_eq!(texels.len(), width * height);
        let stride = width + 2;
        let mut out = vec![Vec3A::ZERO; stride * (height + 2)];
        for y in 0..height {
            let row = &mut out[(y + 1) * stride + 1..(y + 1) * stride + 1 + width];
            for (o, t) in row.iter_mut().zip(&texels[y * width..(y + 1) * width]) {
                *o = Vec3A::from(*t);
            }
        }
        Level { width, height, stride, texels: out }
    }

    /// Index of texel (x, y), where x ∈ -1..=width and y ∈ -1..=height (the border included).
    #[inline(always)]
    pub fn index(&self, x: isize, y: isize) -> usize {
        ((y + 1) as usize) * self.stride + (x + 1) as usize
    }

    #[inline(always)]
    pub fn get(&self, x: isize, y: isize) -> Rgb {
        self.texels[self.index(x, y)].into()
    }

    #[inline(always)]
    pub fn set(&mut self, x: isize, y: isize, c: Rgb) {
        let i = self.index(x, y);
        self.texels[i] = c.into();
    }

    /// The texels inside the border, row-major.
    pub fn interior(&self) -> Vec<Rgb> {
        let mut out = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            let row = (y + 1) * self.stride + 1;
            out.extend(self.texels[row..row + self.width].iter().map(|&t| Rgb::from(t)));
        }
        out
    }

    /// Bilinear filter at continuous texel coordinates (`u`, `v`) ∈ [0, width] × [0, height]
    /// (texel centres at half integers). Coordinates outside are clamped, NaN reads texel 0, so
    /// the read never leaves the bordered grid.
    #[inline(always)]
    pub fn bilinear(&self, u: f32, v: f32) -> Rgb {
        // Shifted by one texel into the bordered grid: x = u − ½ + 1 ∈ [½, width + ½], so the
        // left tap is ⌊x⌋ ∈ [0, width] and the right one ≤ width + 1 < stride. Being positive,
        // ⌊x⌋ is a truncating cast (no libm floor call); max/min map NaN to the edge.
        let x = (u + 0.5).max(0.5).min(self.width as f32 + 0.5);
        let y = (v + 0.5).max(0.5).min(self.height as f32 + 0.5);
        let (xi, yi) = (x as usize, y as usize);
        let (fx, fy) = (x - xi as f32, y - yi as f32);
        let i = yi * self.stride + xi;
        let t = &self.texels[i..i + 2];
        let b = &self.texels[i + self.stride..i + self.stride + 2];
        let top = t[0] + (t[1] - t[0]) * fx;
        let bottom = b[0] + (b[1] - b[0]) * fx;
        (top + (bottom - top) * fy).into()
    }

    /// The next coarser level's interior: each side halved (at least 1), every new texel the
    /// area-weighted mean of the texels it covers (an exact 2×2 box for even sides, a
    /// fractional box for odd ones, so no row or column is dropped).
    pub fn downsampled_interior(&self) -> (usize, usize, Vec<Rgb>) {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        let src = self.interior();
        // Rows first, then columns: separable box weights.
        let wx = box_weights(self.width, w);
        let wy = box_weights(self.height, h);
        let mut rows = vec![Rgb::ZERO; w * self.height];
        for y in 0..self.height {
            for (x, taps) in wx.iter().enumerate() {
                rows[y * w + x] = taps.iter().map(|&(i, k)| src[y * self.width + i] * k).sum();
            }
        }
        let mut out = vec![Rgb::ZERO; w * h];
        for (y, taps) in wy.iter().enumerate() {
            for x in 0..w {
                out[y * w + x] = taps.iter().map(|&(i, k)| rows[i * w + x] * k).sum();
            }
        }
        (w, h, out)
    }
}

/// For each of `to` output cells, the input cells of `from` it covers and their weights (sum 1).
fn box_weights(from: usize, to: usize) -> Vec<Vec<(usize, f32)>> {
    let scale = from as f64 / to as f64;
    (0..to)
        .map(|o| {
            let (lo, hi) = (o as f64 * scale, (o + 1) as f64 * scale);
            let mut taps = Vec::new();
            let mut i = lo.floor() as usize;
            while (i as f64) < hi && i < from {
                let cover = (hi.min(i as f64 + 1.0) - lo.max(i as f64)) / scale;
                if cover > 1e-9 {
                    taps.push((i, cover as f32));
                }
                i += 1;
            }
            taps
        })
        .collect()
}

/// Number of levels of a pyramid whose finest level is `size` texels on its longer side.
pub(crate) fn level_count(size: usize) -> usize {
    (usize::BITS - size.max(1).leading_zeros()) as usize
}

/// log2 of a positive number, to within 0.01, from its bits: enough to pick a mip level, and
/// exact at powers of two (so a footprint of exactly one texel reads one level only).
#[inline(always)]
pub(crate) fn fast_log2(x: f32) -> f32 {
    let bits = x.to_bits();
    let exponent = ((bits >> 23) & 0xff) as f32 - 127.0;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000); // mantissa in [1, 2)
    // The quadratic −m²/3 + 2m − 5/3 through (1, 0) and (2, 1), written in t = m − 1 so that
    // t = 0 gives exactly 0.
    let t = m - 1.0;
    exponent + t * (4.0 / 3.0 - t * (1.0 / 3.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ramp(w: usize, h: usize) -> Vec<Rgb> {
        (0..w * h).map(|i| Rgb::new((i % w) as f32, (i / w) as f32, 1.0)).collect()
    }

    #[test]
    fn interior_round_trips() {
        let t = ramp(5, 3);
        let l = Level::from_interior(5, 3, &t);
        assert_eq!(l.interior(), t);
        assert_eq!(l.get(4, 2), Rgb::new(4.0, 2.0, 1.0));
    }

    #[test]
    fn bilinear_is_exact_at_centres_and_linear_between() {
        let l = Level::from_interior(4, 4, &ramp(4, 4));
        assert_eq!(l.bilinear(1.5, 2.5), Rgb::new(1.0, 2.0, 1.0));
        let c = l.bilinear(2.0, 1.75);
        assert!((c.x - 1.5).abs() < 1e-6 && (c.y - 1.25).abs() < 1e-6);
        // Far outside or NaN: clamped, no panic.
        let _ = l.bilinear(f32::NAN, -1e30);
        let _ = l.bilinear(1e30, f32::INFINITY);
    }

    #[test]
    fn downsampling_keeps_the_mean_for_even_and_odd_sides() {
        for (w, h) in [(8, 4), (7, 5), (3, 1), (1, 1)] {
            let t = ramp(w, h);
            let l = Level::from_interior(w, h, &t);
            let (dw, dh, d) = l.downsampled_interior();
            assert_eq!((dw, dh), ((w / 2).max(1), (h / 2).max(1)));
            let mean = |v: &[Rgb]| v.iter().copied().sum::<Rgb>() / v.len() as f32;
            let (a, b) = (mean(&t), mean(&d));
            assert!((a - b).abs().max_element() < 1e-4, "{w}x{h}: {a} vs {b}");
        }
        // Even sides: an exact 2×2 box.
        let l = Level::from_interior(2, 2, &[Rgb::ZERO, Rgb::ONE, Rgb::ONE, Rgb::splat(2.0)]);
        assert_eq!(l.downsampled_interior().2, vec![Rgb::ONE]);
    }

    #[test]
    fn level_counts() {
        assert_eq!(level_count(1), 1);
        assert_eq!(level_count(2), 2);
        assert_eq!(level_count(512), 10);
        assert_eq!(level_count(600), 10);
    }

    #[test]
    fn fast_log2_is_close() {
        for x in [1e-6f32, 0.3, 1.0, 1.5, 2.0, 3.7, 1024.0, 5e7] {
            assert!((fast_log2(x) - x.log2()).abs() < 0.01, "{x}");
        }
        for k in -20..20 {
            let x = 2f32.powi(k);
            assert_eq!(fast_log2(x), k as f32);
        }
    }
}
