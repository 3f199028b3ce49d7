//! `[object.animation]` and `[light.animation]` → [`Motion`]: a rotation about an axis, keyframed
//! translation, or both.
//!
//! Read right after the light or object it moves; the builder then hands the motion to
//! [`glint_scene::Scene::animate`], and the loaded scene is the one at t = 0.

use super::Builder;
use super::defs::{AnimationDef, KeyframeDef, RepeatDef, RotateDef};
use crate::error::FormatError;
use glint_core::Vec3;
use glint_scene::{Keyframes, Motion, Repeat, Rotation};
use toml::Spanned;

impl Builder<'_> {
    /// `[object.animation]` or `[light.animation]`. A directional light has no position: it
    /// can only turn, about no particular point.
    pub(super) fn animation(&self, a: &Spanned<AnimationDef>, directional: bool) -> Result<Motion, FormatError> {
        let def = a.get_ref();
        if def.rotate.is_none() && def.keyframes.is_none() {
            return Err(self.missing(&a.span(), "an animation needs `rotate`, `keyframes` or both"));
        }
        let rotation = match &def.rotate {
            Some(r) => Some(self.rotation(r, directional)?),
            None => None,
        };
        let translation = match &def.keyframes {
            Some(ks) => Some(self.keyframes(ks, def.repeat.as_ref(), directional)?),
            None => {
                if let Some(r) = &def.repeat {
                    return Err(self.err(&r.span(), "`repeat` applies to `keyframes`, and there are none"));
                }
                None
            }
        };
        Ok(Motion { rotation, translation })
    }

    /// `rotate = { axis, degrees_per_second, pivot, phase_deg }`.
    fn rotation(&self, r: &Spanned<RotateDef>, directional: bool) -> Result<Rotation, FormatError> {
        let rd = r.get_ref();
        let Some(axis) = &rd.axis else {
            return Err(self.missing(&r.span(), "`rotate` needs `axis` (a direction)"));
        };
        let Some(speed) = &rd.degrees_per_second else {
            return Err(self.missing(&r.span(), "`rotate` needs `degrees_per_second`"));
        };
        if directional && let Some(p) = &rd.pivot {
            return Err(self.err(&p.span(), "`pivot` does not apply to a directional light (it has no position)"));
        }
        Ok(Rotation {
            axis: self.direction(axis, "axis")?,
            pivot: rd.pivot.as_ref().map(|p| p.get_ref().0),
            degrees_per_second: speed.get_ref().0,
            phase_deg: rd.phase_deg.as_ref().map_or(0.0, |p| p.get_ref().0),
        })
    }

    /// `keyframes = [{ time, offset }, …]` with strictly increasing times, and `repeat`.
    fn keyframes(
        &self,
        ks: &Spanned<Vec<Spanned<KeyframeDef>>>,
        repeat: Option<&Spanned<RepeatDef>>,
        directional: bool,
    ) -> Result<Keyframes, FormatError> {
        if directional {
            return Err(self.err(
                &ks.span(),
                "a directional light has no position to move: `keyframes` do not apply (use `rotate`)",
            ));
        }
        if ks.get_ref().is_empty() {
            return Err(self.err(&ks.span(), "`keyframes` needs at least one key"));
        }
        let mut keys: Vec<(f32, Vec3)> = Vec::with_capacity(ks.get_ref().len());
        for k in ks.get_ref() {
            let (Some(time), Some(offset)) = (&k.get_ref().time, &k.get_ref().offset) else {
                return Err(self.missing(&k.span(), "a key needs `time` (seconds) and `offset` ([x, y, z])"));
            };
            let t = time.get_ref().0;
            if let Some(&(previous, _)) = keys.last()
                && t <= previous
            {
                return Err(self.err(
                    &time.span(),
                    format!("key time {t} must be after the previous key's ({previous}): times increase strictly"),
                ));
            }
            keys.push((t, offset.get_ref().0));
        }
        let repeat = match repeat.map(|r| *r.get_ref()) {
            Some(RepeatDef::Hold) => Repeat::Hold,
            Some(RepeatDef::Loop) | None => Repeat::Loop,
            Some(RepeatDef::PingPong) => Repeat::PingPong,
        };
        Ok(Keyframes { keys, repeat })
    }
}
