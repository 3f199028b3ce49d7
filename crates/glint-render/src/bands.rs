//! The band driver every mode's tracing runs on (pipeline: integrators → **bands** → film):
//! the image is cut into bands of rows, the unit of parallel work, and each band is computed
//! from its pixels' own hash streams only, so neither the thread count nor the order changes a
//! bit. Two schedules, as the thesis compares them: rayon work stealing (the default) and a
//! static split (one contiguous block of bands per thread, fixed up front, as OpenMP's).
//! Progress is reported and cancellation checked per band.

use crate::RenderError;
use crate::stats::BandStats;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};

/// How image bands are handed to threads.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Schedule {
    /// rayon work stealing over bands of rows.
    #[default]
    WorkStealing,
    /// One contiguous block of bands per thread, fixed up front.
    Static,
}

/// What a frame reports to its caller while it runs, and how the caller stops it.
#[derive(Clone, Copy, Default)]
pub struct Hooks<'a> {
    /// Called with the number of rows finished, from worker threads, as bands finish (once per
    /// row of the image over a frame's first pass).
    pub progress: Option<&'a (dyn Fn(u64) + Sync)>,
    /// When set, bands not yet started are skipped and the frame returns
    /// [`RenderError::Cancelled`].
    pub cancel: Option<&'a AtomicBool>,
}

impl<'a> Hooks<'a> {
    /// Report progress to `progress`.
    #[must_use]
    pub fn with_progress(progress: &'a (dyn Fn(u64) + Sync)) -> Self {
        Self { progress: Some(progress), cancel: None }
    }

    pub(crate) fn report(&self, rows: u64) {
        if let Some(p) = self.progress {
            p(rows);
        }
    }

    /// Run `f` with hooks that report this frame's rows while each of `passes` passes
    /// reports all of them: a row of the frame per `passes` rows reported.
    pub(crate) fn over_passes<R>(&self, passes: u64, f: impl FnOnce(&Hooks) -> R) -> R {
        self.scaled(1, passes, f)
    }

    /// Run `f` with hooks that report `shown` rows of this frame for every `traced` rows `f`
    /// reports (whole rows, as they complete).
    pub(crate) fn scaled<R>(&self, shown: u64, traced: u64, f: impl FnOnce(&Hooks) -> R) -> R {
        let rows = std::sync::atomic::AtomicU64::new(0);
        let traced = traced.max(1);
        let report = |r: u64| {
            let before = rows.fetch_add(r, Ordering::Relaxed);
            let whole = (before + r) * shown / traced - before * shown / traced;
            if whole > 0 {
                self.report(whole);
            }
        };
        f(&Hooks { progress: Some(&report), ..*self })
    }

    pub(crate) fn cancelled(&self) -> bool {
        self.cancel.is_some_and(|c| c.load(Ordering::Relaxed))
    }

    /// `Err(Cancelled)` once cancellation was asked for.
    pub(crate) fn check(&self) -> Result<(), RenderError> {
        if self.cancelled() { Err(RenderError::Cancelled) } else { Ok(()) }
    }
}

/// Run `render_band(band_index, part)` over every band's `part` (the band's slices of the
/// frame's buffers, split by the caller: band i holds rows i·rows_per_band onwards) under
/// `schedule`, and sum what the bands counted. A cancelled frame skips the bands not started.
pub(crate) fn run<P: Send>(
    parts: Vec<P>,
    schedule: Schedule,
    hooks: &Hooks,
    render_band: impl Fn(usize, P) -> BandStats + Sync,
) -> Result<BandStats, RenderError> {
    let band = |i: usize, part: P| if hooks.cancelled() { BandStats::default() } else { render_band(i, part) };
    let totals = match schedule {
        Schedule::WorkStealing => {
            parts.into_par_iter().enumerate().map(|(i, p)| band(i, p)).reduce(BandStats::default, BandStats::merge)
        }
        Schedule::Static => {
            let threads = rayon::current_num_threads().max(1);
            let per_thread = parts.len().div_ceil(threads).max(1);
            let mut blocks: Vec<Vec<(usize, P)>> = Vec::with_capacity(threads);
            let mut parts = parts.into_iter().enumerate().peekable();
            while parts.peek().is_some() {
                blocks.push(parts.by_ref().take(per_thread).collect());
            }
            let mut results = vec![BandStats::default(); blocks.len()];
            rayon::scope(|scope| {
                for (block, result) in blocks.into_iter().zip(results.iter_mut()) {
                    let band = &band;
                    scope.spawn(move |_| {
                        for (i, p) in block {
                            *result = result.merge(band(i, p));
                        }
                    });
                }
            });
            results.into_iter().fold(BandStats::default(), BandStats::merge)
        }
    };
    hooks.check()?;
    Ok(totals)
}
