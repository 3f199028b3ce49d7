//! glint-filter: image-space filters that remove Monte Carlo noise from the indirect light,
//! guided by noise-free geometry (normals and depth) — DESIGN.md §2, after Bauszat, Eisemann and
//! Magnor, "Guided Image Filtering for Interactive High-quality Global Illumination" (EGSR 2011).
//!
//! Pipeline position: after the film. Input is three planar colour planes (typically the
//! demodulated indirect light R, G, B) and a [`Guide`] (unit normals, depth scaled to about
//! [0, 1]); output is three new planes ([`apply`]) or the caller's planes ([`apply_into`], for
//! a viewer that filters every frame without allocating). [`aov::filter_image`] does the whole
//! job on a stored AOV [`glint_image::Image`]. Depends on glint-image only (never on
//! glint-render).
//!
//! The filters:
//! - [`guided`]: the guided image filter of He, Sun and Tang (2010) with a 1-, 3- or 4-channel
//!   guide; every box mean is a running sum, so the work does not grow with the radius.
//! - [`cross_bilateral`]: brute-force Gaussian weights on distance, normal and depth — the
//!   quality reference, O(r²) per pixel.
//! - [`atrous`]: edge-avoiding À-Trous wavelets (Dammertz et al. 2010), 5×5 taps with holes;
//!   each symmetric pair of taps shares one weight.
//!
//! Errors ([`FilterError`]) are returned, never panicked: zero sizes, planes of the wrong
//! length, NaN/inf (naming the plane and its first bad pixel), parameters out of domain.
//!
//! All three are deterministic: rows are split into strips or bands that depend only on the
//! image size and the parameters (or do not matter), never on the thread count, so 1 or N
//! threads give the same bits. Each kernel is written once in portable code and compiled for
//! the baseline and, chosen at run time, for AVX2 + FMA ([`Isa`]; À-Trous also in 16 lanes
//! for AVX-512, with the AVX2 build's bits); `unsafe` is confined to `simd.rs` (the AVX2 and
//! AVX-512 entry points and the guided filter's box-sum intrinsics), each block with a
//! `// SAFETY:` note. The guided filter's two builds agree bit for bit; the weighted filters'
//! differ only by fused multiply-add rounding (both tested against the f64 definitions in
//! [`oracle`]). The guided and À-Trous filters keep their row buffers in a small pool between
//! calls (a few MB), and À-Trous its padded planes too (images up to 4 Mpixels), since fresh
//! pages cost more than the arithmetic.
#![deny(unsafe_code)]
// Index loops over lanes, colours and small matrices read like the equations they implement.
#![allow(clippy::needless_range_loop)]

pub mod aov;
mod atrous;
mod bilateral;
mod boxsum;
mod check;
pub mod error;
mod guided;
mod lanes;
#[doc(hidden)]
pub mod oracle;
mod padded;
mod simd;
#[cfg(test)]
mod test_util;
#[cfg(test)]
mod tests;

pub use error::FilterError;
pub use lanes::Isa;

/// The geometry that steers the filters: planar single-channel f32 buffers of `width * height`
/// values, row-major, top row first.
#[derive(Clone, Copy, Debug)]
pub struct Guide<'a> {
    pub width: usize,
    pub height: usize,
    /// Unit normals, components in [−1, 1] (the zero vector where nothing was hit).
    pub normal: [&'a [f32]; 3],
    /// Depth already scaled to about [0, 1] by the caller; 1.0 or more means background/far
    /// (values above 1 are treated as 1).
    pub depth: &'a [f32],
}

/// Which guide the guided filter fits the input to (Bauszat et al. fig. 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GuideChannels {
    /// 1-D: the Rec. 709 luma of (n + 1)/2, a grey version of the normal map.
    Grey,
    /// 3-D: (n + 1)/2.
    Normal,
    /// 4-D: (n + 1)/2 and the depth.
    NormalDepth,
}

impl GuideChannels {
    /// Number of guide channels (1, 3 or 4).
    pub fn dimension(self) -> usize {
        match self {
            GuideChannels::Grey => 1,
            GuideChannels::Normal => 3,
            GuideChannels::NormalDepth => 4,
        }
    }
}

/// Parameters of the guided filter (He, Sun, Tang 2010; Bauszat et al. 2011 §3.3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuidedParams {
    /// Window radius r: windows are (2r + 1)² pixels, clipped at the border.
    pub radius: usize,
    /// Regulariser ε of the normal channels (and of the grey guide), in (n + 1)/2 units².
    pub eps_normal: f32,
    /// Regulariser ε of the depth channel, in depth units².
    pub eps_depth: f32,
    pub channels: GuideChannels,
}

impl GuidedParams {
    /// The paper's settings scaled to `width`: radius 28 px at 1024 wide (its range is 24–32),
    /// at least 2; ε 0.01 for normals and 0.02 for depth (its range 0.01–0.03); 4-D guide.
    pub fn for_width(width: usize) -> Self {
        Self {
            radius: scaled_radius(28, width),
            eps_normal: 0.01,
            eps_depth: 0.02,
            channels: GuideChannels::NormalDepth,
        }
    }
}

/// Parameters of the brute-force cross-bilateral filter. The weight of pixel j for pixel i is
/// `exp(−d²/2σs²) · exp(−|n_i − n_j|²/2σn²) · exp(−(z_i − z_j)²/2σz²)` (d in pixels, n the
/// unit normals, z the guide depth clamped to 1), over a (2r + 1)² window clipped at the border.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilateralParams {
    pub radius: usize,
    pub sigma_spatial: f32,
    pub sigma_normal: f32,
    pub sigma_depth: f32,
}

impl BilateralParams {
    /// Radius 16 px at 1024 wide (the paper's smallest setting; 24 and 32 are its others), at
    /// least 2; σs = radius/2; σn = 0.2 (about 11° between normals gives weight 1/e^½);
    /// σz = 0.05.
    pub fn for_width(width: usize) -> Self {
        let radius = scaled_radius(16, width);
        Self { radius, sigma_spatial: radius as f32 * 0.5, sigma_normal: 0.2, sigma_depth: 0.05 }
    }
}

/// Parameters of the edge-avoiding À-Trous filter (Dammertz et al. 2010). Iteration i (from 0)
/// applies the 5×5 kernel h·hᵀ, h = [1, 4, 6, 4, 1]/16, with taps 2^i pixels apart, weighted by
/// `exp(−|Δc|²/σc_i²) · exp(−|Δn|²/σn²) · exp(−Δz²/σz²)` with σc_i = σc/2^i (c the current
/// colour, n the unit normal, z the guide depth clamped to 1), normalised; taps outside the
/// image are skipped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtrousParams {
    pub iterations: u32,
    /// σc of the first iteration, relative to the standard deviation of the input (so one
    /// setting suits any exposure and noise level; Dammertz et al. tuned it per scene), halved
    /// at each iteration.
    pub sigma_colour: f32,
    pub sigma_normal: f32,
    pub sigma_depth: f32,
}

impl Default for AtrousParams {
    /// 5 iterations (taps up to 32 px apart, a 125 px wide support); σc = 1 (a colour step of
    /// one standard deviation of the input weighs 1/e in the first pass: the first passes smooth
    /// noise, the last ones keep edges); σn = 0.3; σz = 0.1.
    fn default() -> Self {
        Self { iterations: 5, sigma_colour: 1.0, sigma_normal: 0.3, sigma_depth: 0.1 }
    }
}

/// A filter and its parameters: the closed set the CLI and viewer switch between.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Filter {
    /// Returns the input unchanged (still validated).
    None,
    Guided(GuidedParams),
    Bilateral(BilateralParams),
    Atrous(AtrousParams),
}

/// The kinds of [`Filter`], without parameters: what a user chooses (`--filter`, the viewer's
/// F key); [`Filter::for_width`] gives each its default parameters for an image size.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum FilterKind {
    /// The guided image filter on normal and depth (the paper's method).
    #[default]
    Guided,
    /// The brute-force cross-bilateral filter (the quality reference, slow).
    Bilateral,
    /// Edge-avoiding À-Trous wavelets.
    Atrous,
    /// No filter.
    None,
}

impl Filter {
    /// The filter of `kind` with its default parameters for an image `width` pixels wide.
    #[must_use]
    pub fn for_width(kind: FilterKind, width: usize) -> Filter {
        match kind {
            FilterKind::Guided => Filter::Guided(GuidedParams::for_width(width)),
            FilterKind::Bilateral => Filter::Bilateral(BilateralParams::for_width(width)),
            FilterKind::Atrous => Filter::Atrous(AtrousParams::default()),
            FilterKind::None => Filter::None,
        }
    }

    #[must_use]
    pub fn kind(&self) -> FilterKind {
        match self {
            Filter::None => FilterKind::None,
            Filter::Guided(_) => FilterKind::Guided,
            Filter::Bilateral(_) => FilterKind::Bilateral,
            Filter::Atrous(_) => FilterKind::Atrous,
        }
    }
}

/// The filter and its main parameter, as render summaries print it ("guided 4-D r=28").
impl std::fmt::Display for Filter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Filter::None => write!(f, "none"),
            Filter::Guided(p) => {
                let dims = match p.channels {
                    GuideChannels::Grey => "1-D",
                    GuideChannels::Normal => "3-D",
                    GuideChannels::NormalDepth => "4-D",
                };
                write!(f, "guided {dims} r={}", p.radius)
            }
            Filter::Bilateral(p) => write!(f, "bilateral r={}", p.radius),
            Filter::Atrous(p) => write!(f, "A-Trous {} iterations", p.iterations),
        }
    }
}

/// Planes with `width * height` values each, the form every filter returns.
pub type Planes = [Vec<f32>; 3];

/// Filters the three colour planes `input` (e.g. the demodulated indirect light R, G, B)
/// guided by `guide`, returning new planes. Fails (never panics) on zero sizes, planes of the
/// wrong length, NaN/inf in any plane (naming the plane and its first bad pixel) and
/// parameters outside their domain.
pub fn apply(filter: &Filter, input: [&[f32]; 3], guide: &Guide) -> Result<Planes, FilterError> {
    apply_with(Isa::detect(), filter, input, guide)
}

/// [`apply`] writing into the caller's planes (`width * height` each), so that a caller
/// filtering every frame allocates nothing. On error `out` is unspecified.
pub fn apply_into(filter: &Filter, input: [&[f32]; 3], guide: &Guide, out: [&mut [f32]; 3]) -> Result<(), FilterError> {
    apply_into_with(Isa::detect(), filter, input, guide, out)
}

/// [`apply`] with an explicit instruction set (falls back to [`Isa::Portable`] when the CPU
/// lacks the one asked for): for benchmarks and tests that compare the two builds.
pub fn apply_with(isa: Isa, filter: &Filter, input: [&[f32]; 3], guide: &Guide) -> Result<Planes, FilterError> {
    apply_named(isa, filter, input, guide, &check::Names::DEFAULT)
}

/// [`apply_into`] with an explicit instruction set.
pub fn apply_into_with(
    isa: Isa,
    filter: &Filter,
    input: [&[f32]; 3],
    guide: &Guide,
    out: [&mut [f32]; 3],
) -> Result<(), FilterError> {
    apply_into_named(isa, filter, input, guide, &check::Names::DEFAULT, out)
}

/// [`apply_with`], errors naming the planes as `names` says.
pub(crate) fn apply_named(
    isa: Isa,
    filter: &Filter,
    input: [&[f32]; 3],
    guide: &Guide,
    names: &check::Names,
) -> Result<Planes, FilterError> {
    let (w, h) = check::sizes(input, guide, names)?;
    let mut out: Planes = std::array::from_fn(|_| vec![0.0; w * h]);
    let [a, b, c] = &mut out;
    apply_into_named(isa, filter, input, guide, names, [a, b, c])?;
    Ok(out)
}

/// [`apply_into_with`], errors naming the planes as `names` says.
pub(crate) fn apply_into_named(
    isa: Isa,
    filter: &Filter,
    input: [&[f32]; 3],
    guide: &Guide,
    names: &check::Names,
    out: [&mut [f32]; 3],
) -> Result<(), FilterError> {
    match filter {
        Filter::None => {
            let (w, h) = check::sizes(input, guide, names)?;
            check::outputs(&out, w, h)?;
            check::finite(input, guide, names)?;
            for (o, i) in out.into_iter().zip(input) {
                o.copy_from_slice(i);
            }
            Ok(())
        }
        Filter::Guided(p) => guided::guided_into_named(isa, input, guide, p, names, out),
        Filter::Bilateral(p) => bilateral::cross_bilateral_into_named(isa, input, guide, p, names, out),
        Filter::Atrous(p) => atrous::atrous_into_named(isa, input, guide, p, names, out),
    }
}

/// Make and keep the working memory `filter` needs for a `width`×`height` image, so that the
/// next call of that size does not pay for fresh pages (a one-frame render: `glint render`
/// sizes its buffers before its clock starts, so its filter time is a later frame's). Nothing
/// to do for the filters without kept buffers, or for sizes and parameters the call would refuse.
pub fn reserve(filter: &Filter, width: usize, height: usize) {
    match filter {
        Filter::Guided(p) => guided::reserve(width, height, p),
        Filter::Atrous(p) => atrous::reserve(Isa::detect(), width, height, p),
        Filter::None | Filter::Bilateral(_) => {}
    }
}

/// The guided image filter (He, Sun, Tang 2010) with a multi-channel guide I built from
/// `guide` as `p.channels` says. For every window w_k of radius r:
/// `a_k = (Σ_k + E)⁻¹ cov_k(I, N)`, `b_k = mean_k(N) − a_k·mean_k(I)`, E = diag(ε_n, …, ε_z);
/// output `F_i = mean(a)_i · I_i + mean(b)_i` over the windows containing i. Windows are
/// clipped at the border and means divide by the pixels inside. O(1) per pixel in r.
pub fn guided(input: [&[f32]; 3], guide: &Guide, p: &GuidedParams) -> Result<Planes, FilterError> {
    apply(&Filter::Guided(*p), input, guide)
}

/// The brute-force cross-bilateral filter (see [`BilateralParams`]), O(r²) per pixel.
pub fn cross_bilateral(input: [&[f32]; 3], guide: &Guide, p: &BilateralParams) -> Result<Planes, FilterError> {
    apply(&Filter::Bilateral(*p), input, guide)
}

/// Edge-avoiding À-Trous wavelet filtering (see [`AtrousParams`]).
pub fn atrous(input: [&[f32]; 3], guide: &Guide, p: &AtrousParams) -> Result<Planes, FilterError> {
    apply(&Filter::Atrous(*p), input, guide)
}

/// `base` pixels at 1024 wide, scaled linearly with `width`, rounded, at least 2.
fn scaled_radius(base: usize, width: usize) -> usize {
    ((base * width + 512) / 1024).max(2)
}

#[cfg(test)]
mod defaults {
    use super::*;

    #[test]
    fn defaults_scale_with_width() {
        assert_eq!(GuidedParams::for_width(1024).radius, 28);
        assert_eq!(GuidedParams::for_width(512).radius, 14);
        assert_eq!(GuidedParams::for_width(10).radius, 2);
        assert_eq!(GuidedParams::for_width(1024).channels, GuideChannels::NormalDepth);
        let b = BilateralParams::for_width(2048);
        assert_eq!(b.radius, 32);
        assert_eq!(b.sigma_spatial, 16.0);
        assert_eq!(AtrousParams::default().iterations, 5);
    }
}
