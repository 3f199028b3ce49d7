//! `[camera]` → [`Camera`]: a position, a view direction (`look_at` or `forward`), `up` and a
//! field of view (`fov` vertical or `hfov`), in degrees; a thin lens (`aperture_radius`,
//! `focus_distance`, which defaults to the distance to `look_at`) or an orthographic view
//! (`view_height`, in scene units) instead of the pinhole.
//!
//! Read right after the render settings. A view direction that vanishes or runs along `up`
//! is an error at its line here, so the scene's camera frame always exists.

use super::Builder;
use super::defs::CameraDef;
use super::values::Num;
use crate::error::FormatError;
use glint_core::Vec3;
use glint_scene::{Camera, Fov, Lens, ViewSize};
use toml::Spanned;

impl Builder<'_> {
    pub(super) fn camera(&self, c: &Spanned<CameraDef>) -> Result<Camera, FormatError> {
        let def = c.get_ref();
        let position = match &def.position {
            Some(p) => p.get_ref().0,
            None => return Err(self.missing(&c.span(), "[camera] needs `position`")),
        };
        let mut to_target = None;
        let forward = match (&def.look_at, &def.forward) {
            (Some(_), Some(f)) => return Err(self.err(&f.span(), "give either `look_at` or `forward`, not both")),
            (Some(t), None) => {
                let d = t.get_ref().0 - position;
                if d.length_squared() == 0.0 {
                    return Err(self.err(&t.span(), "`look_at` equals the camera position"));
                }
                to_target = Some(d.length());
                d
            }
            (None, Some(f)) => self.direction(f, "forward")?,
            (None, None) => return Err(self.missing(&c.span(), "[camera] needs `look_at` or `forward`")),
        };
        let up = match &def.up {
            Some(u) => self.direction(u, "up")?,
            None => Vec3::Y,
        };
        if forward.normalize().cross(up).length_squared() < 1e-12 {
            let span = def.up.as_ref().map_or(c.span(), Spanned::span);
            return Err(self.err(&span, "`up` is parallel to the view direction"));
        }
        let fov = match (&def.fov, &def.hfov) {
            (Some(_), Some(h)) => return Err(self.err(&h.span(), "give either `fov` (vertical) or `hfov`, not both")),
            (Some(v), None) => Fov::Vertical(self.angle(v, "fov")?),
            (None, Some(h)) => Fov::Horizontal(self.angle(h, "hfov")?),
            (None, None) => Fov::Vertical(45.0),
        };
        let lens = self.lens(c, to_target)?;
        Ok(Camera { position, forward: forward.normalize(), up: up.normalize(), fov, lens })
    }

    /// The pinhole, unless the table asks for a thin lens or an orthographic view.
    fn lens(&self, c: &Spanned<CameraDef>, to_target: Option<f32>) -> Result<Lens, FormatError> {
        let def = c.get_ref();
        let positive = |v: &Spanned<Num>, key: &str| {
            let x = v.get_ref().0;
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(self.err(&v.span(), format!("`{key}` = {x} must be > 0")))
            }
        };
        match (&def.aperture_radius, &def.view_height) {
            (Some(_), Some(h)) => Err(self
                .err(&h.span(), "`view_height` (orthographic) and `aperture_radius` (thin lens) exclude each other")),
            (None, Some(h)) => {
                if let Some(f) = def.fov.as_ref().or(def.hfov.as_ref()) {
                    return Err(self.err(&f.span(), "an orthographic camera (`view_height`) has no field of view"));
                }
                if let Some(f) = &def.focus_distance {
                    return Err(self.err(&f.span(), "`focus_distance` needs `aperture_radius`"));
                }
                Ok(Lens::Orthographic(ViewSize::HalfHeight(0.5 * positive(h, "view_height")?)))
            }
            (Some(r), None) => {
                let aperture_radius = positive(r, "aperture_radius")?;
                let focus_distance = match (&def.focus_distance, to_target) {
                    (Some(f), _) => positive(f, "focus_distance")?,
                    (None, Some(d)) => d,
                    (None, None) => {
                        return Err(
                            self.err(&r.span(), "a thin lens needs `focus_distance` (or `look_at` to focus on)")
                        );
                    }
                };
                Ok(Lens::ThinLens { aperture_radius, focus_distance })
            }
            (None, None) => match &def.focus_distance {
                Some(f) => Err(self.err(&f.span(), "`focus_distance` needs `aperture_radius`")),
                None => Ok(Lens::Pinhole),
            },
        }
    }

    fn angle(&self, v: &Spanned<Num>, key: &str) -> Result<f32, FormatError> {
        let a = v.get_ref().0;
        if !(a > 0.0 && a < 180.0) {
            return Err(self.err(&v.span(), format!("`{key}` = {a} must be in (0, 180) degrees")));
        }
        Ok(a)
    }
}
