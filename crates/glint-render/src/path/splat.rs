//! Samples splatted through the film's pixel filter (pipeline: camera samples → **splats** →
//! sums → film), as Mitsuba's film does: each sample, its position uniform in its pixel, adds
//! its colour, direct and indirect light weighted by the filter to every pixel whose centre
//! the filter reaches, and that weight to the pixel's weight sum; the film divides the two
//! (`glint_core::pixel_filter`, [`super::PathSums::splat`]).
//!
//! Bands of rows are traced in parallel and each owns its rows' sums, so a band's splats that
//! fall on rows above or below it go to the band's own halo, added into the frame's sums after
//! every band is done ([`add_halos`]). The sums are fixed point (`crate::fixed`): the order in
//! which splats land does not change a bit, and each splat's weight is formed from the
//! sample's offset in its pixel and small integers only ([`SplatWeights`]), so
//! neither thread count, band size nor a tile's place in the frame changes a pixel.

use super::integrator::CameraSample;
use super::sums::{PixelSums, SplatTerms};
use glint_core::pixel_filter::{MAX_REACH, SplatWeights};
use glint_core::{PixelFilter, Vec2};

/// Rows per band when samples are splatted: at least four times the filter's reach, so a
/// band's halo (reach rows above and below) stays a fraction of its rows.
pub(super) fn band_rows(reach: usize, rows: usize) -> usize {
    rows.max(4 * reach).max(16)
}

/// One band's splats: its own rows' sums, and a halo for the rows the filter reaches beyond
/// them.
pub(super) struct BandSplats<'a> {
    weights: SplatWeights,
    reach: usize,
    width: usize,
    height: usize,
    /// The band's first row in the image, and its rows.
    y0: usize,
    rows: usize,
    own: &'a mut [PixelSums],
    /// `reach` rows above the band, then `reach` rows below it, `width` pixels each.
    halo: Vec<PixelSums>,
}

/// A band's halo once its samples are done: what [`add_halos`] adds into the frame's sums.
pub(super) struct Halo {
    y0: usize,
    rows: usize,
    sums: Vec<PixelSums>,
}

impl<'a> BandSplats<'a> {
    /// The splats of the band whose rows start at image row `y0` and whose sums are `own`
    /// (whole rows of a `width × height` image), through `filter`.
    pub(super) fn new(filter: PixelFilter, width: usize, height: usize, y0: usize, own: &'a mut [PixelSums]) -> Self {
        let reach = filter.reach();
        let rows = own.len() / width.max(1);
        // A halo of the last pass's, cleared (a fresh one is a fresh mapping: page faults).
        let mut halo = SPARE.lock().ok().and_then(|mut spare| spare.pop()).unwrap_or_default();
        halo.clear();
        halo.resize(2 * reach * width, PixelSums::default());
        Self { weights: SplatWeights::new(filter), reach, width, height, y0, rows, own, halo }
    }

    /// The band's own sums of pixel `k` (row-major in the band).
    pub(super) fn own(&mut self, k: usize) -> &mut PixelSums {
        &mut self.own[k]
    }

    /// Splat a sample of pixel `k` of the band at `offset` in the pixel ([0, 1)²): its
    /// colour (and when `aovs` its direct and indirect light) into every pixel of the image
    /// whose centre the filter reaches, weighted; the pixel's own counts.
    pub(super) fn add(&mut self, k: usize, offset: Vec2, cs: &CameraSample, aovs: bool) {
        let (x, y) = (k % self.width, self.y0 + k / self.width);
        let terms = SplatTerms::new(cs.rest + cs.albedo * cs.indirect, cs.direct, cs.indirect, aovs);
        let (mut wx, mut wy) = ([0.0f32; 2 * MAX_REACH + 1], [0.0f32; 2 * MAX_REACH + 1]);
        self.weights.fill(offset.x, &mut wx);
        self.weights.fill(offset.y, &mut wy);
        let r = self.reach;
        // The columns the splat covers inside the image, and their weights.
        let (first, last) = (x.saturating_sub(r), (x + r).min(self.width - 1));
        let wx = &wx[first + r - x..=last + r - x];
        for (j, &w_row) in wy[..=2 * r].iter().enumerate() {
            let Some(ty) = (y + j).checked_sub(r).filter(|&ty| ty < self.height) else { continue };
            if w_row == 0.0 {
                continue;
            }
            let row = if ty < self.y0 {
                &mut self.halo[(ty + r - self.y0) * self.width..][..self.width]
            } else if ty < self.y0 + self.rows {
                &mut self.own[(ty - self.y0) * self.width..][..self.width]
            } else {
                &mut self.halo[(r + ty - self.y0 - self.rows) * self.width..][..self.width]
            };
            for (p, &w_col) in row[first..=last].iter_mut().zip(wx) {
                let w = w_col * w_row;
                if w > 0.0 {
                    p.add_splat(w, &terms);
                }
            }
        }
        let own = &mut self.own[k];
        own.covered += cs.covered as u32;
        own.samples += 1;
    }

    /// The band's halo, for [`add_halos`].
    pub(super) fn into_halo(self) -> Halo {
        Halo { y0: self.y0, rows: self.rows, sums: self.halo }
    }
}

/// Halos kept for the next pass's bands (a pass holds one per band until its end; at most
/// [`SPARE_MAX`] are kept).
static SPARE: std::sync::Mutex<Vec<Vec<PixelSums>>> = std::sync::Mutex::new(Vec::new());
const SPARE_MAX: usize = 64;

/// Add the bands' halos into the frame's sums `acc` (rows of `width`; rows outside the image
/// hold nothing and are skipped), and keep their memory for the next pass's bands.
pub(super) fn add_halos(acc: &mut [PixelSums], width: usize, reach: usize, halos: Vec<Halo>) {
    let height = acc.len() / width.max(1);
    for h in &halos {
        let above = (0..reach).map(|r| (h.y0 + r).checked_sub(reach));
        let below = (0..reach).map(|r| Some(h.y0 + h.rows + r));
        for (row, y) in h.sums.chunks_exact(width).zip(above.chain(below)) {
            let Some(y) = y.filter(|&y| y < height) else { continue };
            for (a, s) in acc[y * width..][..width].iter_mut().zip(row) {
                a.add(s);
            }
        }
    }
    if let Ok(mut spare) = SPARE.lock() {
        let room = SPARE_MAX.saturating_sub(spare.len());
        spare.extend(halos.into_iter().take(room).map(|h| h.sums));
    }
}
