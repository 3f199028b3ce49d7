//! Which instruction set a band is traced with: the batched tracer is one generic kernel
//! (`batch.rs` over `glint_accel::lanes`), which `glint_accel::lanes::dispatch` instantiates
//! with AVX2 where the CPU has it (inside a `#[target_feature]` entry, after runtime detection)
//! and with the SSE baseline otherwise. Both give the same bits (no fused multiply-add
//! anywhere); the baseline can be forced for measurements and for the test that checks that.

use super::batch::{Frame, Scratch, render_band};
use crate::film::FilmRows;
use crate::stats::BandStats;
use glint_accel::lanes::{Isa, LaneKernel, dispatch};

thread_local! {
    /// Each worker thread's streams and sample sums, reused by every band it traces.
    static SCRATCH: std::cell::RefCell<Scratch> = std::cell::RefCell::new(Scratch::default());
}

/// One band of the batched tracer.
struct Band<'a, 'f> {
    frame: &'a Frame<'f>,
    index: usize,
    rows: usize,
    pixels: FilmRows<'a>,
}

impl LaneKernel for Band<'_, '_> {
    type Output = BandStats;

    #[inline(always)]
    fn run<I: Isa>(self) -> BandStats {
        // Taken out and put back (no closure: a closure would be compiled without the
        // kernel's target features).
        let mut scratch = SCRATCH.take();
        let stats = render_band::<I>(self.frame, &mut scratch, self.index, self.rows, self.pixels);
        SCRATCH.set(scratch);
        stats
    }
}

/// One band with the fastest build this machine runs (`baseline` forces SSE).
pub(super) fn band(frame: &Frame, index: usize, rows: usize, pixels: FilmRows, baseline: bool) -> BandStats {
    dispatch(Band { frame, index, rows, pixels }, baseline)
}
