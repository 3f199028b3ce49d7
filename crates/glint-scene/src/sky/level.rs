//! One mip level of an environment map: a grid of linear RGB texels with a one-texel border
//! around it, so that every bilinear footprint reads four stored texels without a branch. What
//! the border holds (the neighbouring cube face, the opposite longitude, a clamped row) is
//! decided by the map that owns the level; this module only stores, filters and downsamples.

use glint_core::{Rgb, Vec3A};

/// Largest value a texel holds (RGB9E5's: 511/512 · 2^16); brighter values are clamped.
pub const MAX_TEXEL: f32 = 65408.0;

/// Packs linear RGB into RGB9E5, the shared-exponent format GPUs use for HDR textures: three
/// 9-bit mantissas and a 5-bit exponent in 4 bytes (relative precision 2^-9 of the brightest
/// channel, range up to [`MAX_TEXEL`]). A cube map of 1024² faces is 25 MB instead of 100 MB
/// of f32x4, which is what decides the speed of a sky lookup: its time goes into cache misses.
#[inline]
pub(crate) fn encode_rgb9e5(c: Rgb) -> u32 {
    let c = c.max(Rgb::ZERO).min(Rgb::splat(MAX_TEXEL)); // NaN → 0
    let max = c.max_element();
    if max < 1.0e-20 {
        return 0;
    }
    // Shared exponent e = ⌊log2 max⌋ + 16 (at least 0), read from the float's exponent bits;
    // mantissas are x / 2^(e − 24) rounded, and if the largest rounds up to 512 the exponent
    // steps up once. Powers of two are built from bits too: no libm call.
    let floor_log2 = ((max.to_bits() >> 23) & 0xff) as i32 - 127;
    let mut e = floor_log2.max(-16) + 16;
    let pow2 = |k: i32| f32::from_bits(((k + 127) as u32) << 23);
    let mut inv_scale = pow2(24 - e);
    if (max * inv_scale + 0.5) as u32 >= 512 {
        e += 1;
        inv_scale *= 0.5;
    }
    let m = |x: f32| ((x * inv_scale + 0.5) as u32).min(511);
    m(c.x) | (m(c.y) << 9) | (m(c.z) << 18) | ((e.clamp(0, 31) as u32) << 27)
}

#[inline(always)]
pub(crate) fn decode_rgb9e5(v: u32) -> Vec3A {
    // 2^(e − 15 − 9) built from its bits: e + 103 is always a normal exponent.
    let scale = f32::from_bits(((v >> 27) + 103) << 23);
    Vec3A::new((v & 511) as f32, ((v >> 9) & 511) as f32, ((v >> 18) & 511) as f32) * scale
}

/// `x` clamped to [lo, hi], NaN to `lo`: written as comparisons that are false for NaN, so
/// that it compiles to one `maxss` and one `minss` (`f32::max`/`min` add NaN fix-ups).
#[inline(always)]
fn clamp_nan_low(x: f32, lo: f32, hi: f32) -> f32 {
    let x = if x > lo { x } else { lo };
    if x < hi { x } else { hi }
}

/// Bilinear weighting of four RGB9E5 taps (top left, top right, bottom left, bottom right) at
/// fractions (`fx`, `fy`). On x86-64 the four taps are decoded and weighted in SSE2 lanes, one
/// channel per register, then summed across lanes: a third of the instructions of decoding
/// them one by one.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
#[allow(unsafe_code)]
fn filter_taps(taps: [u32; 4], fx: f32, fy: f32) -> Rgb {
    use std::arch::x86_64::*;
    // SAFETY: every intrinsic below is SSE2, which every x86-64 CPU has (it is part of the
    // x86_64 target's baseline), and none takes a pointer: they only compute on registers.
    // Tested against the scalar decode in `filtering_the_taps_equals_decoding_then_lerping`.
    unsafe {
        let v = _mm_set_epi32(taps[3] as i32, taps[2] as i32, taps[1] as i32, taps[0] as i32);
        let mask = _mm_set1_epi32(511);
        // 2^(e − 24) per tap, from its exponent bits (see decode_rgb9e5).
        let scale = _mm_castsi128_ps(_mm_slli_epi32::<23>(_mm_add_epi32(_mm_srli_epi32::<27>(v), _mm_set1_epi32(103))));
        let (gx, gy) = (1.0 - fx, 1.0 - fy);
        let w = _mm_mul_ps(_mm_set_ps(fx * fy, gx * fy, fx * gy, gx * gy), scale);
        let r = _mm_mul_ps(_mm_cvtepi32_ps(_mm_and_si128(v, mask)), w);
        let g = _mm_mul_ps(_mm_cvtepi32_ps(_mm_and_si128(_mm_srli_epi32::<9>(v), mask)), w);
        let b = _mm_mul_ps(_mm_cvtepi32_ps(_mm_and_si128(_mm_srli_epi32::<18>(v), mask)), w);
        // Lane sums: (r0+r2, g0+g2, r1+r3, g1+g3) then fold the halves; b folded the same way.
        let rg = _mm_add_ps(_mm_unpacklo_ps(r, g), _mm_unpackhi_ps(r, g));
        let rg = _mm_add_ps(rg, _mm_movehl_ps(rg, rg));
        let b = _mm_add_ps(b, _mm_movehl_ps(b, b));
        let b = _mm_add_ss(b, _mm_shuffle_ps::<0b01>(b, b));
        Rgb::new(_mm_cvtss_f32(rg), _mm_cvtss_f32(_mm_shuffle_ps::<0b01>(rg, rg)), _mm_cvtss_f32(b))
    }
}

#[cfg(not(target_arch = "x86_64"))]
#[inline(always)]
fn filter_taps(taps: [u32; 4], fx: f32, fy: f32) -> Rgb {
    let [t0, t1, b0, b1] = taps.map(decode_rgb9e5);
    let top = t0 + (t1 - t0) * fx;
    let bottom = b0 + (b1 - b0) * fx;
    (top + (bottom - top) * fy).into()
}

/// `width × height` texels inside a border of one texel on each side. Row 0 is the top row.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Level {
    pub width: usize,
    pub height: usize,
    /// `width + 2`.
    pub stride: usize,
    /// `(width + 2) × (height + 2)` texels in RGB9E5, border included.
    pub texels: Vec<u32>,
    /// (width, height) as floats, for lookups.
    pub size: glint_core::Vec2,
}

impl Level {
    /// A level holding `texels` (`width × height`, row-major, no border); the border is zero
    /// until the owner fills it.
    pub fn from_interior(width: usize, height: usize, texels: &[Rgb]) -> Level {
        debug_assert_eq!(texels.len(), width * height);
        let stride = width + 2;
        let mut out = vec![0u32; stride * (height + 2)];
        for y in 0..height {
            let row = &mut out[(y + 1) * stride + 1..(y + 1) * stride + 1 + width];
            for (o, t) in row.iter_mut().zip(&texels[y * width..(y + 1) * width]) {
                *o = encode_rgb9e5(*t);
            }
        }
        Level { width, height, stride, texels: out, size: glint_core::Vec2::new(width as f32, height as f32) }
    }

    /// Index of texel (x, y), where x ∈ -1..=width and y ∈ -1..=height (the border included).
    #[inline(always)]
    pub fn index(&self, x: isize, y: isize) -> usize {
        ((y + 1) as usize) * self.stride + (x + 1) as usize
    }

    #[inline(always)]
    pub fn get(&self, x: isize, y: isize) -> Rgb {
        decode_rgb9e5(self.texels[self.index(x, y)]).into()
    }

    #[inline(always)]
    pub fn set(&mut self, x: isize, y: isize, c: Rgb) {
        let i = self.index(x, y);
        self.texels[i] = encode_rgb9e5(c);
    }

    /// The texels inside the border, row-major.
    pub fn interior(&self) -> Vec<Rgb> {
        let mut out = Vec::with_capacity(self.width * self.height);
        for y in 0..self.height {
            let row = (y + 1) * self.stride + 1;
            out.extend(self.texels[row..row + self.width].iter().map(|&t| Rgb::from(decode_rgb9e5(t))));
        }
        out
    }

    /// Bilinear filter at continuous texel coordinates (`u`, `v`) ∈ [0, width] × [0, height]
    /// (texel centres at half integers). Coordinates outside are clamped, NaN reads texel 0, so
    /// the read never leaves the bordered grid.
    #[inline(always)]
    #[allow(unsafe_code)]
    pub fn bilinear(&self, u: f32, v: f32) -> Rgb {
        // Shifted by one texel into the bordered grid: x = u − ½ + 1 ∈ [½, width + ½], so the
        // left tap is ⌊x⌋ ∈ [0, width] and the right one ≤ width + 1 < stride; ⌊x⌋ of a
        // positive number is a truncation. NaN becomes ½ (a NaN direction reads texel 0).
        let (x, y) = Level::bilinear_coordinates(u, v, self.size.x, self.size.y);
        // SAFETY: x and y are finite and in [½, size + ½] (`clamp_nan_low` returns a bound for
        // NaN or out-of-range input), so the truncations fit a u32 and give xi ≤ width, yi ≤ height;
        // the taps at columns xi, xi + 1 ≤ width + 1 of rows yi, yi + 1 ≤ height + 1 lie inside
        // the (width + 2) × (height + 2) grid. Tested by `bilinear_is_exact_at_centres_and_linear_between`
        // (out-of-range and NaN coordinates) and every lookup test of the cube and lat-long maps.
        unsafe {
            let (xi, yi) = (x.to_int_unchecked::<u32>() as usize, y.to_int_unchecked::<u32>() as usize);
            let (fx, fy) = (x - xi as f32, y - yi as f32);
            let i = yi * self.stride + xi;
            debug_assert!(i + self.stride + 1 < self.texels.len());
            let t = self.texels.get_unchecked(i..i + 2);
            let b = self.texels.get_unchecked(i + self.stride..i + self.stride + 2);
            filter_taps([t[0], t[1], b[0], b[1]], fx, fy)
        }
    }

    /// Where [`Level::bilinear`] reads (`u`, `v`) in a level of `width × height` texels: the
    /// coordinates shifted by one texel into the bordered grid and clamped to
    /// [½, size + ½], NaN to ½ (so the left tap ⌊x⌋ ∈ [0, width], the right one ≤ width + 1).
    #[inline(always)]
    pub(crate) fn bilinear_coordinates(u: f32, v: f32, width: f32, height: f32) -> (f32, f32) {
        (clamp_nan_low(u + 0.5, 0.5, width + 0.5), clamp_nan_low(v + 0.5, 0.5, height + 0.5))
    }

    /// The four taps (top left, top right, bottom left, bottom right) whose top left is texel
    /// `index` of the bordered grid, read without bounds checks.
    ///
    /// # Safety
    /// `index + stride + 1` must be below `texels.len()`: true for `⌊y⌋ · stride + ⌊x⌋` of
    /// coordinates from [`Level::bilinear_coordinates`] (⌊x⌋ ≤ width, ⌊y⌋ ≤ height).
    #[inline(always)]
    #[allow(unsafe_code)]
    pub(crate) unsafe fn taps_unchecked(&self, index: usize) -> [u32; 4] {
        debug_assert!(index + self.stride + 1 < self.texels.len());
        // SAFETY: the caller keeps index + stride + 1 inside the texels (see above).
        unsafe {
            let t = self.texels.get_unchecked(index..index + 2);
            let b = self.texels.get_unchecked(index + self.stride..index + self.stride + 2);
            [t[0], t[1], b[0], b[1]]
        }
    }

    /// The next coarser level's interior: each side halved (at least 1), every new texel the
    /// area-weighted mean of the texels it covers (an exact 2×2 box for even sides, a
    /// fractional box for odd ones, so no row or column is dropped).
    pub fn downsampled_interior(&self) -> (usize, usize, Vec<Rgb>) {
        let (w, h) = ((self.width / 2).max(1), (self.height / 2).max(1));
        if self.width.is_multiple_of(2) && self.height.is_multiple_of(2) {
            // The common case (power-of-two faces, 2:1 lat-long maps): a 2×2 box.
            let mut out = Vec::with_capacity(w * h);
            for y in 0..h {
                for x in 0..w {
                    let (sx, sy) = (2 * x as isize, 2 * y as isize);
                    let sum = self.get(sx, sy) + self.get(sx + 1, sy) + self.get(sx, sy + 1) + self.get(sx + 1, sy + 1);
                    out.push(sum * 0.25);
                }
            }
            return (w, h, out);
        }
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

/// The share of each level, at either end, read alone (see [`mip_blend`]).
const SINGLE_LEVEL_BAND: f32 = 0.15;

/// The level and blend weight for a level of detail `lambda` > 0 in a pyramid of `count`
/// levels: trilinear between ⌊λ⌋ and ⌊λ⌋ + 1, with the blend confined to the middle 70 % of each
/// level (what GPU drivers call "brilinear" filtering). Near a level only that level is read —
/// half the work for 30 % of footprints — and the weight stays continuous in λ, so no seam
/// appears where the level changes.
#[inline(always)]
pub(crate) fn mip_blend(lambda: f32, count: usize) -> (usize, f32) {
    let lambda = lambda.min((count - 1) as f32);
    let l0 = lambda as usize;
    let frac = lambda - l0 as f32;
    (l0, blend_weight(frac))
}

/// The weight of the coarser level at fraction `frac` of the way between two (see
/// [`mip_blend`]).
#[inline(always)]
pub(crate) fn blend_weight(frac: f32) -> f32 {
    ((frac - SINGLE_LEVEL_BAND) * (1.0 / (1.0 - 2.0 * SINGLE_LEVEL_BAND))).clamp(0.0, 1.0)
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
        // Far outside, infinite or NaN: clamped to the border, a finite texel value.
        for (u, v) in [(f32::NAN, -1e30), (1e30, f32::INFINITY), (f32::NEG_INFINITY, f32::NAN), (-3.0, 9.0)] {
            assert!(l.bilinear(u, v).is_finite(), "{u} {v}");
        }
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
    fn rgb9e5_keeps_nine_bits_of_the_brightest_channel() {
        for c in [
            Rgb::new(1.0, 0.5, 0.25),
            Rgb::new(0.0031, 0.2, 0.9),
            Rgb::new(6496.0, 3000.0, 1.0),
            Rgb::new(1e-6, 0.0, 2e-6),
            Rgb::splat(MAX_TEXEL),
        ] {
            let d = Rgb::from(decode_rgb9e5(encode_rgb9e5(c)));
            // 2^-9 of the brightest channel; below 2^-15 the grid is absolute, 2^-24.
            let tolerance = (c.max_element() / 512.0).max(2f32.powi(-24));
            assert!((d - c).abs().max_element() <= tolerance, "{c} → {d}");
        }
        // Exact for values on the grid; zero, NaN and negatives become 0; huge values clamp.
        assert_eq!(Rgb::from(decode_rgb9e5(encode_rgb9e5(Rgb::new(1.0, 0.5, 0.0)))), Rgb::new(1.0, 0.5, 0.0));
        assert_eq!(decode_rgb9e5(encode_rgb9e5(Rgb::new(f32::NAN, -1.0, 0.0))), Vec3A::ZERO);
        assert_eq!(Rgb::from(decode_rgb9e5(encode_rgb9e5(Rgb::splat(1e9)))), Rgb::splat(MAX_TEXEL));
    }

    #[test]
    fn filtering_the_taps_equals_decoding_then_lerping() {
        let taps = [Rgb::new(1.0, 0.5, 0.25), Rgb::new(6496.0, 3.0, 0.01), Rgb::new(0.0, 0.2, 0.9), Rgb::splat(1e-3)]
            .map(encode_rgb9e5);
        for (fx, fy) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (0.3, 0.7), (0.5, 0.5), (0.99, 0.01)] {
            let [t0, t1, b0, b1] = taps.map(decode_rgb9e5);
            let top = t0 + (t1 - t0) * fx;
            let bottom = b0 + (b1 - b0) * fx;
            let want = Rgb::from(top + (bottom - top) * fy);
            let got = filter_taps(taps, fx, fy);
            assert!(
                (got - want).abs().max_element() <= 1e-5 * want.max_element().max(1.0),
                "{fx} {fy}: {got} vs {want}"
            );
        }
    }

    #[test]
    fn mip_blend_is_continuous_and_reads_one_level_near_each() {
        assert_eq!(mip_blend(0.05, 5), (0, 0.0));
        assert_eq!(mip_blend(2.95, 5), (2, 1.0));
        assert_eq!(mip_blend(9.0, 5), (4, 0.0));
        let (l, w) = mip_blend(1.5, 5);
        assert!(l == 1 && (w - 0.5).abs() < 1e-6);
        // Continuous: the effective level l + w never jumps.
        let mut last = 0.0;
        for i in 1..400 {
            let (l, w) = mip_blend(i as f32 * 0.01, 5);
            let level = l as f32 + w;
            assert!(level >= last - 1e-6 && level - last < 0.02, "{i}: {last} → {level}");
            last = level;
        }
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
