//! Point colours from whatever a file carries: its RGB, its intensity, its classification, or
//! its height, chosen by [`ColourBy`].
//!
//! The readers (PLY, LAS/LAZ, XYZ text) only gather the raw attributes into [`ColourSources`];
//! the choice, the normalisation and the palettes live here once, so every format colours the
//! same way. Everything is computed in sRGB-encoded [0, 1] and stored linear, as
//! [`PointCloud::colours`](glint_scene::PointCloud) wants.

use crate::FormatError;
use glint_core::colour::srgb_to_linear;
use glint_core::{Rgb, Vec3};
use std::path::Path;

/// Which attribute of a point-cloud file becomes the points' colour.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColourBy {
    /// RGB when the file has it (and not all zero), else intensity (likewise), else elevation
    /// for LAS/LAZ (airborne scans read best by height) and no colour for PLY and text files.
    #[default]
    Auto,
    /// The file's RGB; an error when it has none.
    Rgb,
    /// Grey from the intensity, normalised by a robust maximum (the 99th percentile).
    Intensity,
    /// The ASPRS standard classes (ground brown, vegetation greens, buildings orange, ...).
    Classification,
    /// A viridis-like ramp over the height (glint's up axis, +Y).
    Elevation,
}

impl ColourBy {
    /// The names of the scene format's `colour_by` and the command line's `--colour-by`.
    pub const NAMES: [(&'static str, ColourBy); 5] = [
        ("auto", ColourBy::Auto),
        ("rgb", ColourBy::Rgb),
        ("intensity", ColourBy::Intensity),
        ("classification", ColourBy::Classification),
        ("elevation", ColourBy::Elevation),
    ];

    pub fn from_name(name: &str) -> Option<ColourBy> {
        Self::NAMES.iter().find(|(n, _)| *n == name).map(|&(_, c)| c)
    }
}

/// How to read a point-cloud file.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct PointReadOptions {
    pub colour_by: ColourBy,
}

/// The colour-bearing attributes a reader found, one value per point.
#[derive(Clone, Debug, Default)]
pub(crate) struct ColourSources {
    /// sRGB-encoded colours, each component in [0, 1].
    pub rgb: Option<Vec<Rgb>>,
    pub intensity: Option<Vec<f32>>,
    pub classification: Option<Vec<u8>>,
    /// [`ColourBy::Auto`] falls back to elevation (LAS) rather than to no colour.
    pub auto_elevation: bool,
}

/// The linear colours `by` asks for, or `None` (Auto on a file without colour). `place` names
/// where a missing attribute would have been ("header", "line 1") in the error.
pub(crate) fn colours(
    path: &Path,
    place: &str,
    by: ColourBy,
    sources: ColourSources,
    positions: &[Vec3],
) -> Result<Option<Vec<Rgb>>, FormatError> {
    let missing = |what: &str| {
        FormatError::malformed(path, place, format!("cannot colour by {what}: the file has no {what} values"))
    };
    let srgb = match by {
        ColourBy::Auto => {
            if let Some(rgb) = sources.rgb.filter(|c| c.iter().any(|&v| v != Vec3::ZERO)) {
                rgb
            } else if let Some(i) = sources.intensity.filter(|i| i.iter().any(|&v| v != 0.0)) {
                intensity_grey(&i)
            } else if sources.auto_elevation {
                elevation(positions)
            } else {
                return Ok(None);
            }
        }
        ColourBy::Rgb => sources.rgb.ok_or_else(|| missing("RGB colour"))?,
        ColourBy::Intensity => intensity_grey(&sources.intensity.ok_or_else(|| missing("intensity"))?),
        ColourBy::Classification => {
            sources.classification.ok_or_else(|| missing("classification"))?.iter().map(|&c| class_colour(c)).collect()
        }
        ColourBy::Elevation => elevation(positions),
    };
    Ok(Some(srgb.into_iter().map(to_linear).collect()))
}

fn to_linear(c: Rgb) -> Rgb {
    let c = c.clamp(Vec3::ZERO, Vec3::ONE);
    Rgb::new(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z))
}

/// Grey levels from `(i - low) / (p99 - low)`, where `low` is 0 (or the minimum if negative,
/// as in Leica PTS files) and `p99` the 99th percentile, so a few specular returns do not turn
/// the rest of the scan black. Falls back to the maximum when the percentile equals `low`.
fn intensity_grey(values: &[f32]) -> Vec<Rgb> {
    let finite: Vec<f32> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return vec![Rgb::ZERO; values.len()];
    }
    let low = finite.iter().copied().fold(0.0f32, f32::min);
    let max = finite.iter().copied().fold(f32::MIN, f32::max);
    let mut sorted = finite;
    let k = ((sorted.len() - 1) as f64 * 0.99).round() as usize;
    let (_, &mut p99, _) = sorted.select_nth_unstable_by(k, f32::total_cmp);
    let high = if p99 > low { p99 } else { max };
    let scale = if high > low { 1.0 / (high - low) } else { 0.0 };
    values.iter().map(|&v| Rgb::splat(((v - low) * scale).clamp(0.0, 1.0))).collect()
}

/// The ASPRS standard point classes (LAS 1.4 R15, table 17) as sRGB colours; classes without a
/// conventional colour get a stable hashed one.
pub(crate) fn class_colour(class: u8) -> Rgb {
    let rgb = |r: u8, g: u8, b: u8| Rgb::new(r as f32, g as f32, b as f32) / 255.0;
    match class {
        0 | 1 => rgb(160, 160, 160),  // never classified, unclassified
        2 => rgb(150, 100, 50),       // ground
        3 => rgb(160, 220, 100),      // low vegetation
        4 => rgb(80, 180, 60),        // medium vegetation
        5 => rgb(20, 110, 30),        // high vegetation
        6 => rgb(230, 90, 40),        // building
        7 | 18 => rgb(255, 0, 255),   // low / high noise
        9 => rgb(40, 100, 230),       // water
        10 => rgb(110, 80, 70),       // rail
        11 => rgb(70, 70, 75),        // road surface
        13..=16 => rgb(240, 220, 40), // wires and towers
        17 => rgb(200, 170, 120),     // bridge deck
        _ => {
            // A small integer hash (lowbias32), so neighbouring classes differ.
            let mut h = class as u32 ^ 0x9e37_79b9;
            h ^= h >> 16;
            h = h.wrapping_mul(0x7feb_352d);
            h ^= h >> 15;
            h = h.wrapping_mul(0x846c_a68b);
            h ^= h >> 16;
            rgb((h & 0xff) as u8, (h >> 8 & 0xff) as u8, (h >> 16 & 0xff) as u8) * 0.7 + Rgb::splat(0.2)
        }
    }
}

/// Viridis (van der Walt & Smith, matplotlib 2015) at five stops, sRGB: perceptually uniform
/// and readable by colour-blind viewers.
const RAMP: [[f32; 3]; 5] =
    [[0.267, 0.005, 0.329], [0.229, 0.322, 0.546], [0.128, 0.567, 0.551], [0.369, 0.789, 0.383], [0.993, 0.906, 0.144]];

/// The ramp at `t` in [0, 1], linear between stops (in sRGB).
pub(crate) fn ramp(t: f32) -> Rgb {
    let x = t.clamp(0.0, 1.0) * (RAMP.len() - 1) as f32;
    let i = (x as usize).min(RAMP.len() - 2);
    let f = x - i as f32;
    Rgb::from(RAMP[i]).lerp(Rgb::from(RAMP[i + 1]), f)
}

/// Heights (+Y) mapped from their min..max onto [`ramp`].
fn elevation(positions: &[Vec3]) -> Vec<Rgb> {
    let (lo, hi) = positions.iter().fold((f32::MAX, f32::MIN), |(lo, hi), p| (lo.min(p.y), hi.max(p.y)));
    let scale = if hi > lo { 1.0 / (hi - lo) } else { 0.0 };
    positions.iter().map(|p| ramp((p.y - lo) * scale)).collect()
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

    fn run(by: ColourBy, sources: ColourSources, positions: &[Vec3]) -> Result<Option<Vec<Rgb>>, FormatError> {
        colours(Path::new("c.las"), "header", by, sources, positions)
    }

    #[test]
    fn auto_prefers_rgb_then_intensity_then_elevation_or_nothing() {
        let p = [Vec3::ZERO, Vec3::Y];
        let zero_rgb = Some(vec![Rgb::ZERO; 2]);
        let s = ColourSources { rgb: zero_rgb.clone(), intensity: Some(vec![0.0, 10.0]), ..Default::default() };
        let c = run(ColourBy::Auto, s, &p).unwrap().unwrap();
        assert_eq!(c[0], Rgb::ZERO);
        assert!((c[1] - Rgb::ONE).abs().max_element() < 1e-6);
        let s = ColourSources { rgb: zero_rgb.clone(), ..Default::default() };
        assert!(run(ColourBy::Auto, s, &p).unwrap().is_none());
        let s = ColourSources { rgb: zero_rgb, auto_elevation: true, ..Default::default() };
        let c = run(ColourBy::Auto, s, &p).unwrap().unwrap();
        assert_eq!(c[0], to_linear(ramp(0.0)));
        assert_eq!(c[1], to_linear(ramp(1.0)));
        let s = ColourSources { rgb: Some(vec![Rgb::splat(0.5), Rgb::X]), ..Default::default() };
        let c = run(ColourBy::Auto, s, &p).unwrap().unwrap();
        assert!((c[0].x - srgb_to_linear(0.5)).abs() < 1e-6 && c[1] == Rgb::X);
    }

    #[test]
    fn missing_attributes_are_errors_naming_the_file() {
        for (by, what) in
            [(ColourBy::Rgb, "RGB"), (ColourBy::Intensity, "intensity"), (ColourBy::Classification, "classification")]
        {
            let e = run(by, ColourSources::default(), &[Vec3::ZERO]).unwrap_err().to_string();
            assert!(e.starts_with("c.las: header: cannot colour by") && e.contains(what), "{e}");
        }
        assert!(run(ColourBy::Elevation, ColourSources::default(), &[Vec3::ZERO]).unwrap().is_some());
    }

    #[test]
    fn intensity_is_robust_to_outliers() {
        let mut values: Vec<f32> = (0..1000).map(|i| (i % 100) as f32).collect();
        values[7] = 60000.0;
        let g = intensity_grey(&values);
        assert!(g[99].x > 0.99, "{}", g[99].x);
        assert!((g[50].x - 50.0 / 99.0).abs() < 0.01);
        assert_eq!(g[7], Rgb::ONE);
        assert!(intensity_grey(&[0.0, 0.0]).iter().all(|&c| c == Rgb::ZERO));
    }

    #[test]
    fn palettes_are_in_range_and_distinct() {
        for c in 0..=255u8 {
            let k = class_colour(c);
            assert!(k.min_element() >= 0.0 && k.max_element() <= 1.0, "{c}: {k}");
        }
        assert_ne!(class_colour(2), class_colour(5));
        assert_ne!(class_colour(40), class_colour(41));
        assert!(class_colour(9).z > class_colour(9).x, "water is blue");
        for i in 0..=10 {
            let a = ramp(i as f32 / 10.0);
            assert!(a.min_element() >= 0.0 && a.max_element() <= 1.0);
        }
        assert!(ramp(1.0).x > ramp(0.0).x && ramp(0.5).y > ramp(0.0).y);
    }
}
