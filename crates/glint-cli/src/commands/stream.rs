//! The machine's memory bandwidth, measured in the same run as the passes it is compared with:
//! STREAM's copy (`a = b`) and triad (`a = b + s·c`) kernels (McCalpin 1995) on f32 arrays far
//! larger than the last-level cache, split across the pool's threads the way the image passes
//! split rows (each thread first touches, and then streams, its own contiguous part).
//!
//! Bytes are counted as STREAM counts them: 8 per element for copy (one read, one write), 12 for
//! triad. Plain stores also read each destination line before writing it (write-allocate), so
//! the traffic the memory system carries is 1.5× (copy) and 1.33× (triad) the figure; image
//! passes pay the same, so the two compare like with like.

use anyhow::{Result, anyhow};
use rayon::prelude::*;
use std::time::Instant;

/// Elements per array: 2^25 f32 = 128 MiB, four times a 32 MiB L3.
const ELEMENTS: usize = 1 << 25;
/// Elements per parallel piece (4 MiB of each array).
const PIECE: usize = 1 << 20;

/// Median bandwidths of one measurement, GB/s (10^9 bytes per second).
#[derive(Clone, Copy, Debug)]
pub struct Bandwidth {
    pub copy_gbs: f64,
    pub triad_gbs: f64,
    pub threads: usize,
}

impl Bandwidth {
    /// One line for a benchmark's header.
    pub fn line(&self) -> String {
        format!(
            "memory (STREAM-like, {} MiB f32 arrays, {} threads, median of {REPS}): copy {:.1} GB/s, triad {:.1} GB/s",
            (ELEMENTS * 4) >> 20,
            self.threads,
            self.copy_gbs,
            self.triad_gbs
        )
    }
}

const REPS: usize = 7;

/// Copy and triad on the current rayon pool.
///
/// # Errors
/// When the three arrays (384 MiB) cannot be allocated.
pub fn measure() -> Result<Bandwidth> {
    let alloc = |fill: f32| -> Result<Vec<f32>> {
        let mut v: Vec<f32> = Vec::new();
        v.try_reserve_exact(ELEMENTS)
            .map_err(|e| anyhow!("the bandwidth measurement's {} MiB arrays: {e}", (ELEMENTS * 4) >> 20))?;
        v.resize(ELEMENTS, 0.0);
        // The first touch (the zeroing above may be lazy pages) on the threads that stream it.
        v.par_chunks_mut(PIECE).for_each(|c| c.fill(fill));
        Ok(v)
    };
    let (mut a, b, c) = (alloc(0.0)?, alloc(1.0)?, alloc(2.0)?);
    let time = |f: &mut dyn FnMut()| {
        let t = Instant::now();
        f();
        t.elapsed().as_secs_f64()
    };
    let (mut copy, mut triad) = (Vec::with_capacity(REPS), Vec::with_capacity(REPS));
    for _ in 0..REPS {
        copy.push(time(&mut || {
            a.par_chunks_mut(PIECE).zip(b.par_chunks(PIECE)).for_each(|(a, b)| a.copy_from_slice(b));
        }));
        triad.push(time(&mut || {
            a.par_chunks_mut(PIECE).zip(b.par_chunks(PIECE)).zip(c.par_chunks(PIECE)).for_each(|((a, b), c)| {
                for ((a, b), c) in a.iter_mut().zip(b).zip(c) {
                    *a = b + 3.0 * c;
                }
            });
        }));
    }
    std::hint::black_box(&a);
    let gbs = |bytes_per_element: usize, times: &mut [f64]| {
        (ELEMENTS * bytes_per_element) as f64 / super::bench::median(times) * 1e-9
    };
    Ok(Bandwidth { copy_gbs: gbs(8, &mut copy), triad_gbs: gbs(12, &mut triad), threads: rayon::current_num_threads() })
}

/// GB/s of `bytes` moved in `ms` milliseconds.
pub fn gbs(bytes: f64, ms: f64) -> f64 {
    if ms > 0.0 { bytes / (ms * 1e-3) * 1e-9 } else { 0.0 }
}
