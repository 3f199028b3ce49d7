//! `[[light]]` → [`Light`]: point, directional and spot lights, each type with its own keys.
//!
//! Read after the materials; a light's `[light.animation]` is read by the builder right after
//! the light (see [`super::animation`]). A key that does not apply to the light's type is an
//! error at its line, not a silent default.

use super::Builder;
use super::defs::{Falloff, LightDef, LightKind};
use crate::error::FormatError;
use glint_core::Rgb;
use glint_scene::{Attenuation, Light, SpotFalloff};
use toml::Spanned;

impl Builder<'_> {
    pub(super) fn light(&self, l: &Spanned<LightDef>) -> Result<Light, FormatError> {
        let def = l.get_ref();
        let keys = def.keys();
        let colour = match &def.colour {
            Some(c) => self.colour(c, "colour")?,
            None => Rgb::ONE,
        };
        let intensity = match &def.intensity {
            Some(i) => self.non_negative(i, "intensity")?,
            None => 1.0,
        };
        let attenuation = match def.falloff.as_ref().map(|f| *f.get_ref()) {
            Some(Falloff::InverseSquare) => Attenuation::InverseSquare,
            Some(Falloff::None) | None => Attenuation::None,
        };
        let position = |what: &str| match &def.position {
            Some(p) => Ok(p.get_ref().0),
            None => Err(self.missing(&l.span(), format!("a {what} light needs `position`"))),
        };
        match def.kind.get_ref() {
            LightKind::Point => {
                self.disallow(&keys, &["position", "falloff"], "a point light")?;
                Ok(Light::Point { position: position("point")?, colour, intensity, attenuation })
            }
            LightKind::Directional => {
                self.disallow(&keys, &["direction"], "a directional light (it has no position)")?;
                let Some(d) = &def.direction else {
                    return Err(self.missing(&l.span(), "a directional light needs `direction`"));
                };
                Ok(Light::Directional { direction: self.direction(d, "direction")?, colour, intensity })
            }
            LightKind::Spot => {
                self.disallow(
                    &keys,
                    &["position", "direction", "look_at", "inner_angle", "outer_angle", "falloff"],
                    "a spot light",
                )?;
                let position = position("spot")?;
                let direction = match (&def.direction, &def.look_at) {
                    (Some(_), Some(t)) => {
                        return Err(self.err(&t.span(), "give either `direction` or `look_at`, not both"));
                    }
                    (Some(d), None) => self.direction(d, "direction")?,
                    (None, Some(t)) => (t.get_ref().0 - position)
                        .try_normalize()
                        .ok_or_else(|| self.err(&t.span(), "`look_at` equals the light position"))?,
                    (None, None) => return Err(self.missing(&l.span(), "a spot light needs `direction` or `look_at`")),
                };
                let outer_deg = match &def.outer_angle {
                    Some(a) => a.get_ref().0,
                    None => 30.0,
                };
                let inner_deg = match &def.inner_angle {
                    Some(a) => a.get_ref().0,
                    None => (outer_deg * 0.75).min(20.0),
                };
                if !(inner_deg >= 0.0 && inner_deg <= outer_deg && outer_deg > 0.0 && outer_deg <= 180.0) {
                    let span = def.inner_angle.as_ref().or(def.outer_angle.as_ref()).map_or(l.span(), Spanned::span);
                    return Err(self.err(
                        &span,
                        format!("cone angles need 0 <= inner_angle ({inner_deg}) <= outer_angle ({outer_deg}) <= 180"),
                    ));
                }
                Ok(Light::Spot {
                    position,
                    direction,
                    inner_deg,
                    outer_deg,
                    colour,
                    intensity,
                    attenuation,
                    falloff: SpotFalloff::Smoothstep,
                    projection: None,
                })
            }
        }
    }
}
