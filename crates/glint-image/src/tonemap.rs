//! Tone maps: scene-referred linear values (after exposure) to display values in `[0, 1]`.
//!
//! Applied per channel, after exposure scaling and before the sRGB OETF (see the crate docs
//! for the whole chain). The formulas, for `x ≥ 0` after sanitising:
//!
//! - [`ToneMap::Clamp`] (`clamp`): `x ↦ min(x, 1)`.
//! - [`ToneMap::Reinhard`] (`reinhard`): `x ↦ x / (1 + x)` (Reinhard et al. 2002, eq. 3).
//! - [`ToneMap::Aces`] (`aces`): `x ↦ clamp(x·(2.51x + 0.03) / (x·(2.43x + 0.59) + 0.14), 0, 1)`
//!   (Narkowicz 2015, "ACES Filmic Tone Mapping Curve", applied without his 0.6 pre-scale).
//!
//! NaN and non-positive inputs map to 0; inputs above `10⁹` (including `+∞`) are treated as
//! `10⁹`, so every output is finite and in `[0, 1]`.

use std::fmt;
use std::str::FromStr;

use crate::error::UnknownToneMap;

/// Largest input a tone map sees; larger values (and `+∞`) are clamped to it first.
pub const MAX_INPUT: f32 = 1.0e9;

/// How linear values above 1 are brought into the displayable range.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ToneMap {
    /// `min(x, 1)`: exact below 1, hard clip above.
    #[default]
    Clamp,
    /// `x / (1 + x)`: never clips, compresses highlights strongly.
    Reinhard,
    /// Narkowicz's fit of the ACES filmic curve: a toe, a shoulder, saturates a little above 10.
    Aces,
}

impl ToneMap {
    /// All tone maps, in CLI order.
    pub const ALL: [ToneMap; 3] = [ToneMap::Clamp, ToneMap::Reinhard, ToneMap::Aces];

    /// The CLI name: `clamp`, `reinhard` or `aces`.
    pub fn as_str(self) -> &'static str {
        match self {
            ToneMap::Clamp => "clamp",
            ToneMap::Reinhard => "reinhard",
            ToneMap::Aces => "aces",
        }
    }

    /// Maps one linear value (already exposed) to `[0, 1]`; formulas in the module docs.
    #[inline]
    pub fn apply(self, x: f32) -> f32 {
        match self {
            ToneMap::Clamp => clamp(x),
            ToneMap::Reinhard => reinhard(x),
            ToneMap::Aces => aces(x),
        }
    }
}

/// NaN and `x ≤ 0` → 0, `x > MAX_INPUT` → `MAX_INPUT`; a select, not a branch, so loops over
/// values vectorise.
#[inline(always)]
fn sanitise(x: f32) -> f32 {
    if x > 0.0 { x.min(MAX_INPUT) } else { 0.0 }
}

#[inline(always)]
pub(crate) fn clamp(x: f32) -> f32 {
    sanitise(x).min(1.0)
}

/// Reinhard et al. 2002, eq. 3 (the global operator without white point).
#[inline(always)]
pub(crate) fn reinhard(x: f32) -> f32 {
    let x = sanitise(x);
    x / (1.0 + x)
}

/// Narkowicz 2015, "ACES Filmic Tone Mapping Curve".
#[inline(always)]
pub(crate) fn aces(x: f32) -> f32 {
    let x = sanitise(x);
    ((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14)).clamp(0.0, 1.0)
}

impl FromStr for ToneMap {
    type Err = UnknownToneMap;

    /// Parses `clamp`, `reinhard` or `aces` (ASCII case-insensitive).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        ToneMap::ALL
            .into_iter()
            .find(|t| t.as_str().eq_ignore_ascii_case(s))
            .ok_or_else(|| UnknownToneMap(s.to_string()))
    }
}

impl fmt::Display for ToneMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() <= 1e-6 * b.abs().max(1.0)
    }

    #[test]
    fn clamp_formula() {
        for (x, y) in [(0.0, 0.0), (0.25, 0.25), (1.0, 1.0), (7.0, 1.0), (-3.0, 0.0)] {
            assert_eq!(ToneMap::Clamp.apply(x), y, "clamp({x})");
        }
    }

    #[test]
    fn reinhard_formula() {
        for (x, y) in [(0.0, 0.0), (1.0, 0.5), (3.0, 0.75), (0.25, 0.2), (9.0, 0.9)] {
            assert!(close(ToneMap::Reinhard.apply(x), y), "reinhard({x}) = {}", ToneMap::Reinhard.apply(x));
        }
    }

    #[test]
    fn aces_formula() {
        let f = |x: f64| (x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14);
        for x in [0.01, 0.18, 0.5, 1.0, 2.0] {
            let expected = f(x).min(1.0) as f32;
            assert!(close(ToneMap::Aces.apply(x as f32), expected), "aces({x})");
        }
        // Known points of the curve: 1 ↦ 2.54/3.16, and it saturates above ~10.
        assert!(close(ToneMap::Aces.apply(1.0), 2.54 / 3.16));
        assert_eq!(ToneMap::Aces.apply(100.0), 1.0);
        assert_eq!(ToneMap::Aces.apply(0.0), 0.0);
    }

    #[test]
    fn bad_values_stay_in_range() {
        for t in ToneMap::ALL {
            assert_eq!(t.apply(f32::NAN), 0.0);
            assert_eq!(t.apply(f32::NEG_INFINITY), 0.0);
            let top = t.apply(f32::INFINITY);
            assert!(top.is_finite() && (0.999..=1.0).contains(&top), "{t}: {top}");
            assert_eq!(t.apply(f32::MAX), top);
        }
    }

    #[test]
    fn names_round_trip() {
        for t in ToneMap::ALL {
            assert_eq!(t.as_str().parse::<ToneMap>(), Ok(t));
            assert_eq!(t.to_string(), t.as_str());
        }
        assert_eq!("ACES".parse::<ToneMap>(), Ok(ToneMap::Aces));
        let err = "filmic".parse::<ToneMap>().expect_err("unknown");
        assert!(err.to_string().contains("'filmic'"), "{err}");
        assert_eq!(ToneMap::default(), ToneMap::Clamp);
    }
}
