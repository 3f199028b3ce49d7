//! Pixel reconstruction filters: sample positions drawn from them, or samples splatted through
//! them.
//!
//! A film with a filter f computes at each pixel centre p the weighted average
//! ∫ f(x − p) L(x) dx / ∫ f. Two estimators of it ([`Reconstruction`]):
//! - **Splatting** (Mitsuba's film): sample positions are uniform in their pixel, and every
//!   sample adds `f(centre − x) · L` and `f(centre − x)` to each pixel whose centre its filter
//!   reaches; a pixel is the ratio of the two sums. A pixel averages the samples of about
//!   `(∫ f)² / ∫ f²` pixels (3.1 for Mitsuba's default Gaussian, σ = ½), so its error at the
//!   same samples per pixel is that many times lower, at the price of correlated neighbours.
//! - **Sampling** (pbrt-v4, "Filter Sampling"): each sample's offset is drawn from the filter
//!   itself, so every sample has the same weight and stays in its own pixel: pixels are
//!   independent and a pixel's variance is one sample's over the sample count.
//!
//! For the non-negative filters here both converge to the same image. Filters are separable:
//! the 2-D offset is two independent 1-D offsets, a 2-D weight the product of two 1-D ones.

use glam::Vec2;

/// A separable pixel filter (1-D profile per axis, in pixels).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum PixelFilter {
    /// The pixel's own square (radius ½): glint's default.
    #[default]
    Box,
    /// 1 − |x| / r on |x| < r (Mitsuba's `tent`, r = 1 by default).
    Tent { radius: f32 },
    /// exp(−x² / 2σ²) − exp(−r² / 2σ²) on |x| < r = 4σ (Mitsuba's `gaussian`, σ = 0.5 by
    /// default: the film filter Mitsuba uses unless a scene names another).
    Gaussian { stddev: f32 },
}

/// How a film wider than a pixel turns samples into pixels (see the module comment). A box
/// filter (radius ½) reaches no other pixel: both are the same estimator there.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reconstruction {
    /// Positions uniform in the pixel, each sample weighted into every pixel the filter
    /// reaches (Mitsuba's film): lower error per sample.
    #[default]
    Splat,
    /// Positions drawn from the filter, each sample in its own pixel (pbrt-v4's).
    Sample,
}

/// The most pixels a splat reaches on either side of its own along one axis
/// ([`PixelFilter::reach`] of the widest filter accepted).
pub const MAX_REACH: usize = 16;

/// The widest filter accepted, in pixels (a wider one blurs more than any film filter should).
pub const MAX_FILTER_RADIUS: f32 = 16.0;

impl PixelFilter {
    /// Half the width of the filter's support, in pixels.
    pub fn radius(&self) -> f32 {
        match *self {
            PixelFilter::Box => 0.5,
            PixelFilter::Tent { radius } => radius,
            PixelFilter::Gaussian { stddev } => 4.0 * stddev,
        }
    }

    /// How many pixels on either side of its own a sample in a pixel can reach along one
    /// axis: the pixels `i` whose centre `i + ½` lies within the radius of some position
    /// `x + o`, `o ∈ [0, 1)`, that is `|i − x| ≤ ⌈r + ½⌉ − 1` (0 for the box, 2 for Mitsuba's
    /// Gaussian). At most [`MAX_REACH`] for a valid filter.
    pub fn reach(&self) -> usize {
        ((self.radius() + 0.5).ceil() as usize).saturating_sub(1).min(MAX_REACH)
    }

    /// The unnormalised 1-D profile at offset `x` from the pixel centre.
    pub fn eval(&self, x: f32) -> f32 {
        let r = self.radius();
        if x.abs() >= r {
            return 0.0;
        }
        match *self {
            PixelFilter::Box => 1.0,
            PixelFilter::Tent { radius } => 1.0 - x.abs() / radius,
            PixelFilter::Gaussian { stddev } => {
                let alpha = -1.0 / (2.0 * stddev * stddev);
                ((alpha * x * x).exp() - (alpha * r * r).exp()).max(0.0)
            }
        }
    }

    /// # Errors
    /// A message when the filter's size is not a finite number in (0, 16] pixels.
    pub fn validate(&self) -> Result<(), String> {
        let r = self.radius();
        if r.is_finite() && r > 0.0 && r <= MAX_FILTER_RADIUS {
            Ok(())
        } else {
            Err(format!("pixel filter {self:?}: its radius {r} must be in (0, {MAX_FILTER_RADIUS}] pixels"))
        }
    }
}

/// Entries of the Gaussian's tabulated inverse distribution (its quantiles at i / N).
const QUANTILES: usize = 512;

/// Draws sample positions within a pixel from a [`PixelFilter`].
#[derive(Clone, Debug)]
pub struct PixelSampler {
    filter: PixelFilter,
    /// The Gaussian's inverse cumulative distribution at u = i / QUANTILES (empty otherwise).
    quantiles: Vec<f32>,
}

impl PixelSampler {
    pub fn new(filter: PixelFilter) -> PixelSampler {
        let quantiles = match filter {
            PixelFilter::Gaussian { .. } => tabulate_quantiles(&filter),
            _ => Vec::new(),
        };
        PixelSampler { filter, quantiles }
    }

    pub fn filter(&self) -> PixelFilter {
        self.filter
    }

    /// The offset from the pixel centre along one axis for u uniform in [0, 1), distributed as
    /// the filter's profile.
    pub fn offset(&self, u: f32) -> f32 {
        match self.filter {
            PixelFilter::Box => u - 0.5,
            PixelFilter::Tent { radius } => {
                // Inverse of the tent's cumulative distribution, one half at a time.
                if u < 0.5 {
                    radius * ((2.0 * u).sqrt() - 1.0)
                } else {
                    radius * (1.0 - (2.0 - 2.0 * u).max(0.0).sqrt())
                }
            }
            PixelFilter::Gaussian { .. } => {
                let t = u.clamp(0.0, 1.0) * QUANTILES as f32;
                let i = (t as usize).min(QUANTILES - 1);
                let f = t - i as f32;
                self.quantiles[i] + (self.quantiles[i + 1] - self.quantiles[i]) * f
            }
        }
    }

    /// A sample position within the pixel's frame (the pixel is [0, 1)², its centre ½) for u
    /// uniform in [0, 1)²; the box filter returns u itself.
    #[inline]
    pub fn position(&self, u: Vec2) -> Vec2 {
        match self.filter {
            PixelFilter::Box => u,
            _ => Vec2::new(0.5 + self.offset(u.x), 0.5 + self.offset(u.y)),
        }
    }
}

/// The profile's quantiles at u = i / QUANTILES, i = 0..=QUANTILES, from its cumulative
/// integral on a fine grid (trapezoids), inverted by linear interpolation.
fn tabulate_quantiles(filter: &PixelFilter) -> Vec<f32> {
    const STEPS: usize = 8192;
    let r = f64::from(filter.radius());
    let x_at = |k: usize| -r + 2.0 * r * k as f64 / STEPS as f64;
    let mut cdf = Vec::with_capacity(STEPS + 1);
    let mut sum = 0.0f64;
    cdf.push(0.0);
    for k in 0..STEPS {
        let (a, b) = (f64::from(filter.eval(x_at(k) as f32)), f64::from(filter.eval(x_at(k + 1) as f32)));
        sum += 0.5 * (a + b);
        cdf.push(sum);
    }
    let mut quantiles = Vec::with_capacity(QUANTILES + 1);
    let mut k = 0;
    for i in 0..=QUANTILES {
        let target = sum * i as f64 / QUANTILES as f64;
        while k + 1 < STEPS && cdf[k + 1] < target {
            k += 1;
        }
        let (c0, c1) = (cdf[k], cdf[k + 1]);
        let f = if c1 > c0 { ((target - c0) / (c1 - c0)).clamp(0.0, 1.0) } else { 0.0 };
        quantiles.push((x_at(k) + f * (x_at(k + 1) - x_at(k))) as f32);
    }
    quantiles
}

/// A filter's 1-D splat weights: for a sample at offset `o ∈ [0, 1)` in its pixel, weight `j`
/// is the profile at the centre of the pixel `j − reach` away, `eval(j − reach + ½ − o)`, for
/// `j` in `0..=2·reach`. The constants of the profile are formed once (per band of a frame),
/// so that a sample's weights cost two exponentials per axis, not one per pixel reached
/// (libm's `expf` was 2.5–3 % of a Mitsuba Cornell box frame).
///
/// The Gaussian's `e(x) = exp(α x²)` at the pixel centres `x = d + m` (`d = ½ − o`, `m` an
/// integer) is carried outward from the sample's own pixel by the ratio of neighbours,
/// `e(d + m ± 1) = e(d + m) · exp(±2αd) · exp(α(2|m| + 1))`, the last factor a constant.
/// The weights then differ from [`PixelFilter::eval`] by rounding (a few ulps per pixel
/// stepped, within 1e-5 relative), and they are still formed from the offset and small
/// integers alone: a pixel's weights do not depend on where it is in the image (a tile's
/// splats are the whole frame's bit for bit). Box and tent weights are `eval`'s.
#[derive(Clone, Copy, Debug)]
pub struct SplatWeights {
    filter: PixelFilter,
    reach: usize,
    /// The Gaussian's −1 / 2σ², its value at the radius, and `exp(α(2k + 1))`.
    alpha: f32,
    floor: f32,
    steps: [f32; MAX_REACH],
}

impl SplatWeights {
    #[must_use]
    pub fn new(filter: PixelFilter) -> Self {
        let reach = filter.reach();
        let mut steps = [0.0f32; MAX_REACH];
        let (mut alpha, mut floor) = (0.0, 0.0);
        if let PixelFilter::Gaussian { stddev } = filter {
            let r = filter.radius();
            alpha = -1.0 / (2.0 * stddev * stddev);
            floor = (alpha * r * r).exp();
            for (k, c) in steps.iter_mut().enumerate() {
                *c = (alpha * (2 * k + 1) as f32).exp();
            }
        }
        Self { filter, reach, alpha, floor, steps }
    }

    /// How many pixels the weights reach on either side ([`PixelFilter::reach`]).
    #[must_use]
    pub fn reach(&self) -> usize {
        self.reach
    }

    /// The weights of a sample at offset `o ∈ [0, 1)` in its pixel into `out[0..=2·reach]`
    /// (entries beyond are left alone).
    #[inline]
    pub fn fill(&self, o: f32, out: &mut [f32; 2 * MAX_REACH + 1]) {
        let reach = self.reach;
        let d = 0.5 - o;
        let at = |j: usize| (j as f32 - reach as f32) + d;
        let PixelFilter::Gaussian { .. } = self.filter else {
            for (j, w) in out.iter_mut().enumerate().take(2 * reach + 1) {
                *w = self.filter.eval(at(j));
            }
            return;
        };
        let r = self.filter.radius();
        let weight = |x: f32, e: f32| if x.abs() >= r { 0.0 } else { (e - self.floor).max(0.0) };
        let centre = (self.alpha * d * d).exp();
        out[reach] = weight(d, centre);
        let up = (2.0 * self.alpha * d).exp();
        let down = 1.0 / up;
        let (mut above, mut below) = (centre, centre);
        for (k, &c) in self.steps.iter().enumerate().take(reach) {
            above *= up * c;
            below *= down * c;
            out[reach + k + 1] = weight(at(reach + k + 1), above);
            out[reach - k - 1] = weight(at(reach - k - 1), below);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The sampled offsets follow the profile: a histogram of stratified samples against the
    /// profile's integral over each bin (χ²-style, but deterministic: quantiles are exact
    /// up to the table's interpolation).
    fn check_distribution(filter: PixelFilter) {
        let s = PixelSampler::new(filter);
        let r = filter.radius();
        const BINS: usize = 32;
        const N: usize = 200_000;
        let mut hist = [0usize; BINS];
        for i in 0..N {
            let x = s.offset((i as f32 + 0.5) / N as f32);
            assert!(x.abs() <= r * 1.0001, "{filter:?}: offset {x} outside the support");
            hist[(((x + r) / (2.0 * r) * BINS as f32) as usize).min(BINS - 1)] += 1;
        }
        // The profile's mass per bin by a fine midpoint sum.
        let mass: Vec<f64> = (0..BINS)
            .map(|b| {
                (0..200)
                    .map(|k| {
                        let x = -r + 2.0 * r * (b as f32 + (k as f32 + 0.5) / 200.0) / BINS as f32;
                        f64::from(filter.eval(x))
                    })
                    .sum()
            })
            .collect();
        let total: f64 = mass.iter().sum();
        for (b, (&h, &m)) in hist.iter().zip(&mass).enumerate() {
            let (got, want) = (h as f64 / N as f64, m / total);
            assert!((got - want).abs() < 2e-3, "{filter:?}: bin {b}: {got} vs {want}");
        }
    }

    #[test]
    fn offsets_follow_each_profile() {
        check_distribution(PixelFilter::Box);
        check_distribution(PixelFilter::Tent { radius: 1.0 });
        check_distribution(PixelFilter::Tent { radius: 2.5 });
        check_distribution(PixelFilter::Gaussian { stddev: 0.5 });
        check_distribution(PixelFilter::Gaussian { stddev: 1.3 });
    }

    #[test]
    fn offsets_are_symmetric_and_monotonic() {
        for f in [PixelFilter::Tent { radius: 1.0 }, PixelFilter::Gaussian { stddev: 0.5 }] {
            let s = PixelSampler::new(f);
            let mut last = f32::NEG_INFINITY;
            for i in 0..=1000 {
                let u = i as f32 / 1000.0;
                let x = s.offset(u);
                assert!(x >= last, "{f:?}: not monotonic at {u}");
                assert!((x + s.offset(1.0 - u)).abs() < 2e-3, "{f:?}: not symmetric at {u}");
                last = x;
            }
            assert!(s.offset(0.5).abs() < 1e-3);
        }
    }

    /// Splat weights: the box keeps a sample in its pixel; every filter's reach holds each
    /// pixel it can weight (a position just inside either edge of the pixel reaches the outer
    /// ones), and no pixel beyond it; the weights are the profile at the centres.
    #[test]
    fn splat_weights_reach_exactly_the_pixels_the_filter_covers() {
        let mut w = [f32::NAN; 2 * MAX_REACH + 1];
        SplatWeights::new(PixelFilter::Box).fill(0.3, &mut w);
        assert_eq!((PixelFilter::Box.reach(), w[0]), (0, 1.0));
        let filters = [
            (PixelFilter::Tent { radius: 1.0 }, 1),
            (PixelFilter::Tent { radius: 2.5 }, 2),
            (PixelFilter::Gaussian { stddev: 0.5 }, 2),
            (PixelFilter::Gaussian { stddev: 1.3 }, 5),
            (PixelFilter::Gaussian { stddev: 4.0 }, MAX_REACH),
        ];
        for (f, reach) in filters {
            assert_eq!(f.reach(), reach, "{f:?}");
            let r = f.radius();
            for o in [0.0, 1e-4, 0.25, 0.5, 0.75, 0.9999] {
                let mut w = [f32::NAN; 2 * MAX_REACH + 1];
                SplatWeights::new(f).fill(o, &mut w);
                for (j, &wj) in w.iter().enumerate().take(2 * reach + 1) {
                    let d = j as f32 - reach as f32 + 0.5 - o;
                    match f {
                        PixelFilter::Gaussian { .. } => {
                            let (got, want) = (f64::from(wj), f64::from(f.eval(d)));
                            // Relative to the peak: near the radius the weight is a small
                            // difference of two exponentials.
                            assert!(
                                (got - want).abs() <= 1e-5 * f64::from(f.eval(0.0)),
                                "{f:?} o {o} j {j}: {got} vs {want}"
                            );
                            assert!(d.abs() < r || got == 0.0, "{f:?} o {o} j {j}: {got} beyond the radius");
                        }
                        _ => assert_eq!(wj, f.eval(d), "{f:?} o {o} j {j}"),
                    }
                }
                assert!(w[2 * reach + 1..].iter().all(|v| v.is_nan()), "{f:?}: wrote beyond its reach");
                // Beyond the reach, no position in the pixel has weight.
                let beyond = reach as f32 + 1.0;
                assert_eq!(f.eval(beyond + 0.5 - o), 0.0, "{f:?} o {o}");
                assert_eq!(f.eval(-beyond + 0.5 - o), 0.0, "{f:?} o {o}");
            }
            // The outermost pixels are reached from one edge or the other.
            let edge = |o: f32| f.eval(reach as f32 + 0.5 - o);
            assert!(edge(0.9999) > 0.0 || r <= reach as f32 - 0.5, "{f:?}: reach {reach} is too wide");
        }
    }

    /// The Gaussian's weights carried from pixel to pixel stay within 1e-5 of the peak of the
    /// profile evaluated at each centre, over the whole pixel and every accepted width.
    #[test]
    fn carried_gaussian_weights_are_the_profile() {
        for stddev in [0.05, 0.3, 0.5, 1.3, 2.2, 4.0] {
            let f = PixelFilter::Gaussian { stddev };
            let weights = SplatWeights::new(f);
            let (reach, r, peak) = (f.reach(), f.radius(), f64::from(f.eval(0.0)));
            for i in 0..2000 {
                let o = i as f32 / 2000.0;
                let mut w = [f32::NAN; 2 * MAX_REACH + 1];
                weights.fill(o, &mut w);
                for (j, &wj) in w.iter().enumerate().take(2 * reach + 1) {
                    let d = j as f32 - reach as f32 + 0.5 - o;
                    let want = f64::from(f.eval(d));
                    assert!((f64::from(wj) - want).abs() <= 1e-5 * peak, "σ {stddev} o {o} j {j}: {wj} vs {want}");
                    assert!(wj >= 0.0 && (d.abs() < r || wj == 0.0), "σ {stddev} o {o} j {j}: {wj}");
                }
            }
        }
    }

    #[test]
    fn the_box_keeps_the_uniform_position_exactly() {
        let s = PixelSampler::new(PixelFilter::Box);
        let u = Vec2::new(0.123_456_7, 0.987_654_3);
        assert_eq!(s.position(u), u);
    }

    #[test]
    fn sizes_outside_the_range_are_refused() {
        assert!(PixelFilter::Gaussian { stddev: 0.5 }.validate().is_ok());
        assert!(PixelFilter::Tent { radius: 0.0 }.validate().is_err());
        assert!(PixelFilter::Tent { radius: f32::NAN }.validate().is_err());
        assert!(PixelFilter::Gaussian { stddev: 100.0 }.validate().is_err());
        assert!(PixelFilter::Tent { radius: MAX_FILTER_RADIUS }.validate().is_ok());
        assert_eq!(PixelFilter::Tent { radius: MAX_FILTER_RADIUS }.reach(), MAX_REACH);
    }
}
