//! The brute-force cross-bilateral filter (Petschnigg et al. 2004, Eisemann and Durand 2004),
//! the quality reference of Bauszat et al.'s comparison: O(r²) per pixel by design.
//!
//! Each weight is one `exp2`: the guide is stored pre-scaled (n·√(log₂e/2σn²), z·√(log₂e/2σz²))
//! so that `exp(−d²/2σs² − |Δn|²/2σn² − Δz²/2σz²) = 2^−(d²·s + |Δg|²)`. Pixels are processed
//! eight at a time with their sums in registers, every tap of the window in turn; taps outside
//! the image get weight zero through a lane mask (only in vectors near the border). Rows are
//! independent, so any split over threads gives the same bits.

use rayon::prelude::*;

use crate::check::{self, Names};
use crate::lanes::{F8, LANES, array};
use crate::padded::Padded;
use crate::simd::{self, Kernels};
use crate::{BilateralParams, FilterError, Guide, Isa};

/// Rows per parallel work item.
const BAND: usize = 4;

pub(crate) fn cross_bilateral_into_named(
    isa: Isa,
    input: [&[f32]; 3],
    guide: &Guide,
    p: &BilateralParams,
    names: &Names,
    out: [&mut [f32]; 3],
) -> Result<(), FilterError> {
    let (w, h) = check::sizes(input, guide, names)?;
    check::outputs(&out, w, h)?;
    if p.radius == 0 {
        return Err(FilterError::parameter("bilateral", "radius must be at least 1 (radius 0 returns the input)"));
    }
    check::positive("bilateral", "sigma_spatial", p.sigma_spatial)?;
    check::positive("bilateral", "sigma_normal", p.sigma_normal)?;
    check::positive("bilateral", "sigma_depth", p.sigma_depth)?;
    check::finite(input, guide, names)?;
    let r = p.radius.min(w.max(h));
    let log2e = std::f32::consts::LOG2_E;
    let scale = |sigma: f32| (log2e / (2.0 * sigma * sigma)).sqrt();
    let (kn, kz) = (scale(p.sigma_normal), scale(p.sigma_depth));
    let mut planes = Padded::zeros(w, h, r, 7);
    for (k, (n, i)) in guide.normal.iter().zip(input).enumerate() {
        planes.fill(k, n, |v| v * kn);
        planes.fill(4 + k, i, |v| v);
    }
    planes.fill(3, guide.depth, |z| z.min(1.0) * kz);
    let spatial = log2e / (2.0 * p.sigma_spatial * p.sigma_spatial);

    let [o0, o1, o2] = out;
    let bands = o0.par_chunks_mut(BAND * w).zip(o1.par_chunks_mut(BAND * w)).zip(o2.par_chunks_mut(BAND * w));
    bands.enumerate().for_each(|(i, ((a, b), c))| {
        let job = BandJob { planes: &planes, r, spatial, y0: i * BAND, out: [a, b, c] };
        simd::bilateral_band(isa, job);
    });
    Ok(())
}

/// Output rows `y0..` (as many as `out` holds).
pub(crate) struct BandJob<'a> {
    /// Scaled normal x, y, z, scaled depth, colour R, G, B.
    planes: &'a Padded,
    r: usize,
    /// log₂e / 2σs².
    spatial: f32,
    y0: usize,
    out: [&'a mut [f32]; 3],
}

/// Runs a band of rows: eight pixels at a time with their sums in registers, every tap of the
/// window in turn.
#[inline(always)]
pub(crate) fn band<K: Kernels>(k: K, job: BandJob<'_>) {
    let BandJob { planes, r, spatial, y0, mut out } = job;
    let (w, h, wp, m, stride) = (planes.w, planes.h, planes.wp, planes.margin, planes.stride);
    let rows = out[0].len() / w;
    let w_f = w as f32;
    let mut row_out = vec![[0.0f32; LANES]; 3 * (wp / LANES)];
    for y in y0..y0 + rows {
        let (ya, yb) = (y.saturating_sub(r), (y + r).min(h - 1));
        let centre_block = planes.block(y);
        for (i, x) in (0..wp).step_by(LANES).enumerate() {
            let c = &centre_block[m + x..m + x + 3 * stride + LANES];
            let centre: [F8; 4] = array(|p| F8::load(c, p * stride));
            let interior = x >= r && x + LANES + r <= w;
            let mut wsum = F8::ZERO;
            let mut acc = [F8::ZERO; 3];
            for yy in ya..=yb {
                let dy2 = (yy.abs_diff(y) * yy.abs_diff(y)) as f32 * spatial;
                let block = planes.block(yy);
                for j in (m + x - r)..=(m + x + r) {
                    let dx = j.abs_diff(m + x);
                    // One bounds check for all seven planes of the tap.
                    let t = &block[j..j + 6 * stride + LANES];
                    let d: [F8; 4] = array(|p| F8::load(t, p * stride) - centre[p]);
                    // Two short chains rather than one of four multiply-adds.
                    let s = k.mul_add(d[1], d[1], k.mul_add(d[0], d[0], F8::splat((dx * dx) as f32 * spatial + dy2)));
                    let mut wt = k.exp2_neg(s + k.mul_add(d[3], d[3], d[2] * d[2]));
                    if !interior {
                        // Lane l reads image column j − m + l.
                        wt = wt * F8::window_mask(j as f32 - m as f32, 0.0, w_f);
                    }
                    wsum += wt;
                    for (c, a) in acc.iter_mut().enumerate() {
                        *a = k.mul_add(wt, F8::load(t, (4 + c) * stride), *a);
                    }
                }
            }
            let inv = F8::splat(1.0) / wsum;
            for (c, a) in acc.iter().enumerate() {
                row_out[c * (wp / LANES) + i] = (*a * inv).0;
            }
        }
        let o = (y - y0) * w;
        for (c, plane) in out.iter_mut().enumerate() {
            let row = row_out[c * (wp / LANES)..(c + 1) * (wp / LANES)].as_flattened();
            plane[o..o + w].copy_from_slice(&row[..w]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::oracle;
    use crate::test_util::{PLUS_Z, random_scene, two_halves};

    #[test]
    fn equals_the_direct_definition() {
        let scene = random_scene(21, 13, 4);
        for radius in [1, 3, 6] {
            let p = BilateralParams { radius, sigma_spatial: 2.0, sigma_normal: 0.5, sigma_depth: 0.3 };
            let want = oracle::bilateral_direct(scene.input(), &scene.guide(), &p);
            for isa in [Isa::Portable, Isa::Avx2] {
                let got =
                    crate::apply_with(isa, &crate::Filter::Bilateral(p), scene.input(), &scene.guide()).expect("valid");
                for c in 0..3 {
                    let d = got[c].iter().zip(&want[c]).fold(0.0f32, |m, (a, b)| m.max((a - b).abs()));
                    // exp2 is good to 4e-6 relative; the input spans [0, 1].
                    assert!(d < 2e-5, "r {radius} plane {c}: {d}");
                }
            }
        }
    }

    #[test]
    fn keeps_a_depth_edge() {
        // Same normals on both sides, only depth differs: the depth term alone must stop bleeding.
        let scene = two_halves(40, 12, 20, [0.2, 0.8], [0.3, 0.6], [PLUS_Z, PLUS_Z]);
        let p = BilateralParams { radius: 6, sigma_spatial: 4.0, sigma_normal: 0.2, sigma_depth: 0.05 };
        let out = crate::cross_bilateral(scene.input(), &scene.guide(), &p).expect("valid");
        // Across Δz = 0.3 = 6σ the weight is e^−18 ≈ 1.5e-8 per tap: no visible bleed.
        for (i, v) in out[0].iter().enumerate() {
            let want = if i % 40 < 20 { 0.2 } else { 0.8 };
            assert!((v - want).abs() < 1e-5, "pixel {i}: {v}");
        }
    }
}
