//! Value types of the TOML scene format that check themselves while they are read.
//!
//! TOML allows `nan` and `inf`; a scene never does. Every number in a scene file goes through
//! [`Num`], so a non-finite value is rejected by the deserializer itself, and the toml crate
//! attaches the span of the offending value to the error (line and column for free).

use glint_core::{Vec2, Vec3};
use serde::de::{self, Deserialize, Deserializer, SeqAccess, Visitor};
use std::fmt;

/// A finite number that fits an `f32`. Integers are accepted (`radius = 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Num(pub f32);

fn finite_f32<E: de::Error>(v: f64) -> Result<f32, E> {
    if !v.is_finite() {
        return Err(E::custom(format!("{v} is not allowed here: expected a finite number")));
    }
    if v.abs() > f32::MAX as f64 {
        return Err(E::custom(format!("{v} is too large for a 32-bit float")));
    }
    Ok(v as f32)
}

struct NumVisitor;

impl Visitor<'_> for NumVisitor {
    type Value = Num;

    fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
        f.write_str("a finite number")
    }

    fn visit_f64<E: de::Error>(self, v: f64) -> Result<Num, E> {
        finite_f32(v).map(Num)
    }

    fn visit_i64<E: de::Error>(self, v: i64) -> Result<Num, E> {
        Ok(Num(v as f32))
    }

    fn visit_u64<E: de::Error>(self, v: u64) -> Result<Num, E> {
        Ok(Num(v as f32))
    }
}

impl<'de> Deserialize<'de> for Num {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(NumVisitor)
    }
}

/// Reads an array of exactly `N` finite numbers.
fn read_array<'de, A: SeqAccess<'de>, const N: usize>(mut seq: A, what: &str) -> Result<[f32; N], A::Error> {
    let mut out = [0.0; N];
    for (i, slot) in out.iter_mut().enumerate() {
        match seq.next_element::<Num>()? {
            Some(Num(v)) => *slot = v,
            None => {
                return Err(de::Error::custom(format!("expected {what} ({N} numbers), found only {i}")));
            }
        }
    }
    if seq.next_element::<de::IgnoredAny>()?.is_some() {
        return Err(de::Error::custom(format!("expected {what} ({N} numbers), found more")));
    }
    Ok(out)
}

/// `[x, y, z]`: a point, a direction or a linear RGB colour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct V3(pub Vec3);

impl<'de> Deserialize<'de> for V3 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = V3;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 3 finite numbers [x, y, z]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<V3, A::Error> {
                read_array::<A, 3>(seq, "[x, y, z]").map(|a| V3(Vec3::from_array(a)))
            }
        }
        d.deserialize_seq(V)
    }
}

/// `[u, v]`: a texture coordinate or a 2-D scale.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct V2(pub Vec2);

impl<'de> Deserialize<'de> for V2 {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = V2;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("an array of 2 finite numbers [u, v]")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<V2, A::Error> {
                read_array::<A, 2>(seq, "[u, v]").map(|a| V2(Vec2::from_array(a)))
            }
        }
        d.deserialize_seq(V)
    }
}

/// `scale = s` (uniform) or `scale = [sx, sy, sz]`; also a grey or RGB value (`f0`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Scale(pub Vec3);

impl<'de> Deserialize<'de> for Scale {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = Scale;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number or an array of 3 numbers")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<Scale, E> {
                finite_f32(v).map(|s| Scale(Vec3::splat(s)))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<Scale, E> {
                Ok(Scale(Vec3::splat(v as f32)))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<Scale, E> {
                Ok(Scale(Vec3::splat(v as f32)))
            }
            fn visit_seq<A: SeqAccess<'de>>(self, seq: A) -> Result<Scale, A::Error> {
                read_array::<A, 3>(seq, "an array").map(|a| Scale(Vec3::from_array(a)))
            }
        }
        d.deserialize_any(V)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Deserialize;

    #[derive(Debug, Deserialize)]
    struct T {
        v: V3,
        s: Scale,
    }

    #[test]
    fn integers_and_floats_are_numbers() {
        let t: T = toml::from_str("v = [1, 2.5, -3]\ns = 2").expect("valid");
        assert_eq!(t.v.0, Vec3::new(1.0, 2.5, -3.0));
        assert_eq!(t.s.0, Vec3::splat(2.0));
    }

    #[test]
    fn nan_and_wrong_lengths_are_rejected_at_their_place() {
        let e = toml::from_str::<T>("v = [1, nan, 3]\ns = 1").expect_err("nan rejected");
        assert!(e.message().contains("finite"), "{e}");
        assert_eq!(e.span(), Some(8..11));
        assert!(toml::from_str::<T>("v = [1, 2]\ns = 1").is_err());
        assert!(toml::from_str::<T>("v = [1, 2, 3, 4]\ns = 1").is_err());
        assert!(toml::from_str::<T>("v = [1, 2, 3]\ns = inf").is_err());
    }
}
