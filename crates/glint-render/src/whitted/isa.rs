//! The crate's only `unsafe`: the batched Whitted tracer compiled a second time for AVX2.
//!
//! `batch.rs` and everything it calls on a hot path (`shade8.rs`, the world's batch queries,
//! glint-core's lanes, glint-accel's batch tests) are `#[inline(always)]` and ISA-neutral, so
//! inlined into the `#[target_feature(enable = "avx2,fma")]` function below they become
//! 256-bit code, and inlined into the plain call they become SSE2 code (the x86-64 baseline).
//! No fused multiply-add is written anywhere in them, so both give the same bits. Measured in
//! BENCHMARKS.md §3 (the AVX2 build against the baseline build on the benchmark scene).

#![allow(unsafe_code)]

use super::batch::{Frame, Scratch, render_band};
use crate::film::FilmPixel;
use crate::stats::BandStats;

/// Whether this machine runs the AVX2 build (AVX2 and FMA, detected once by std).
#[must_use]
pub(crate) fn avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// One band with the fastest build this machine runs (`baseline` forces the plain one, for
/// the measurement and the test that both agree).
pub(super) fn band(
    frame: &Frame,
    band_index: usize,
    rows: usize,
    pixels: &mut [FilmPixel],
    baseline: bool,
) -> BandStats {
    let mut scratch = Scratch::default();
    #[cfg(target_arch = "x86_64")]
    if !baseline && avx2() {
        // SAFETY: `band_avx2` only needs AVX2 and FMA, which `avx2()` has just detected on this
        // CPU.
        return unsafe { band_avx2(frame, &mut scratch, band_index, rows, pixels) };
    }
    render_band(frame, &mut scratch, band_index, rows, pixels)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn band_avx2(
    frame: &Frame,
    scratch: &mut Scratch,
    band_index: usize,
    rows: usize,
    pixels: &mut [FilmPixel],
) -> BandStats {
    render_band(frame, scratch, band_index, rows, pixels)
}
