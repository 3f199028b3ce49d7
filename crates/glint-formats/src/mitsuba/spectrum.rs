//! Spectra → linear sRGB as Mitsuba 3's RGB variants see them (src/core/properties.cpp,
//! `spectrum_list_to_srgb` in src/core/spectrum.cpp): a `wavelength:value` list is integrated,
//! piecewise linear, against the CIE 1931 curves at 1000 fixed steps over 360–830 nm — for
//! reflectances weighted by the D65 illuminant and clamped to [0, 1], for emitters neither
//! (only negative values clamped). A uniform spectrum is its value for reflectances, and
//! `value · xyz_to_srgb(1, 1, 1)` for emitters (so RGB renders match spectral ones).

use super::cie_tables::{CIE_XYZ, D65};
use super::props::{Spectrum, Value};

const CIE_MIN: f64 = 360.0;
const CIE_MAX: f64 = 830.0;
const CIE_SAMPLES: usize = 95;
const CIE_Y_NORMALIZATION: f64 = 1.0 / 106.750_259_399_414_06;
const D65_NORMALIZATION: f64 = 1.0 / 98.997_417_518_762_55;

/// What a colour is for: Mitsuba converts spectra differently for each.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Use {
    /// Reflectances and other factors in [0, 1].
    Bounded,
    /// Unbounded non-emitter values (a conductor's eta and k).
    Unbounded,
    /// Radiance, intensity, irradiance.
    Emitter,
}

/// Mitsuba's table lookup: linear between the 5 nm samples.
fn table(values: &[f32], w: f64) -> f64 {
    if !(CIE_MIN..=CIE_MAX).contains(&w) {
        return 0.0;
    }
    let t = (w - CIE_MIN) * ((CIE_SAMPLES - 1) as f64 / (CIE_MAX - CIE_MIN));
    let i0 = (t as usize).min(CIE_SAMPLES - 2);
    let w1 = t - i0 as f64;
    (1.0 - w1) * f64::from(values[i0]) + w1 * f64::from(values[i0 + 1])
}

fn cie_xyz(w: f64) -> [f64; 3] {
    let n = CIE_SAMPLES;
    [table(&CIE_XYZ[..n], w), table(&CIE_XYZ[n..2 * n], w), table(&CIE_XYZ[2 * n..], w)]
}

pub(super) fn xyz_to_srgb(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    // Mitsuba's matrix, as f32 constants.
    let m = |a: f32, b: f32, c: f32| f64::from(a) * x + f64::from(b) * y + f64::from(c) * z;
    [m(3.240_479, -1.537_15, -0.498_535), m(-0.969_256, 1.875_991, 0.041_556), m(0.055_648, -0.204_043, 1.057_311)]
}

/// Mitsuba's `spectrum_list_to_srgb(wavelengths, values, bounded, d65)`. `wavelengths`
/// increase (checked by the parser) and are as many as `values`.
pub(super) fn list_to_srgb(wavelengths: &[f64], values: &[f64], bounded: bool, d65: bool) -> [f64; 3] {
    let mut xyz = [0.0f64; 3];
    let steps = 1000;
    let (Some(&first), Some(&last)) = (wavelengths.first(), wavelengths.last()) else { return [0.0; 3] };
    for i in 0..steps {
        let w = CIE_MIN + (i as f64 / (steps - 1) as f64) * (CIE_MAX - CIE_MIN);
        if w < first || w > last {
            continue;
        }
        // The last index whose wavelength is <= w, at most len − 2 (Mitsuba's find_interval).
        let idx = wavelengths.partition_point(|&x| x <= w).saturating_sub(1).min(wavelengths.len().saturating_sub(2));
        let v = if wavelengths.len() == 1 {
            values[0]
        } else {
            let (w0, w1, v0, v1) = (wavelengths[idx], wavelengths[idx + 1], values[idx], values[idx + 1]);
            ((w - w1) * v0 + (w0 - w) * v1) / (w0 - w1)
        };
        let weight = v * if d65 { table(&D65, w) * D65_NORMALIZATION } else { 1.0 };
        let c = cie_xyz(w);
        for k in 0..3 {
            xyz[k] += c[k] * weight;
        }
    }
    let scale = (CIE_MAX - CIE_MIN) * CIE_Y_NORMALIZATION / f64::from(steps);
    let rgb = xyz_to_srgb(xyz.map(|v| v * scale));
    if bounded { rgb.map(|v| v.clamp(0.0, 1.0)) } else { rgb.map(|v| v.max(0.0)) }
}

/// The linear RGB Mitsuba's RGB variants make of a colour-like value, or None for values that
/// are not colours (strings, objects…).
pub(super) fn to_rgb(value: &Value, usage: Use) -> Option<[f64; 3]> {
    let emitter = usage == Use::Emitter;
    match value {
        Value::Float(v) => Some([*v; 3]),
        Value::Int(v) => Some([*v as f64; 3]),
        Value::Rgb(c) => Some(*c),
        Value::Spectrum(Spectrum::Uniform(v)) => {
            Some(if emitter { xyz_to_srgb([1.0; 3]).map(|c| c * v) } else { [*v; 3] })
        }
        Value::Spectrum(Spectrum::List { wavelengths, values }) => {
            Some(list_to_srgb(wavelengths, values, usage == Use::Bounded, !emitter))
        }
        _ => None,
    }
}
