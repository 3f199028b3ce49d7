//! `[image]` and `[render]` → [`RenderDefaults`]: the image size, samples and integrator
//! settings a scene file suggests (the command line overrides them later, in glint-render).
//!
//! The first tables the builder reads. Every count is checked against
//! [`glint_scene::limits`], the ranges the render settings, the command line and the viewer
//! check too, so a scene this file accepts is never refused further down the pipeline.

use super::Builder;
use super::defs::SceneDef;
use crate::error::FormatError;
use glint_core::random::Sampler;
use glint_scene::limits::{self, MAX_IMAGE_SIDE};
use glint_scene::{RenderDefaults, RenderMode};
use std::ops::RangeInclusive;
use toml::Spanned;

impl Builder<'_> {
    pub(super) fn render_defaults(&self, def: &SceneDef) -> Result<RenderDefaults, FormatError> {
        let mut r = RenderDefaults::default();
        if let Some(image) = &def.image {
            for (value, slot, key) in [(&image.width, &mut r.width, "width"), (&image.height, &mut r.height, "height")]
            {
                if let Some(v) = value {
                    *slot = self.within(v, &format!("image {key}"), &(1..=MAX_IMAGE_SIDE), "")?;
                }
            }
            if let Some(s) = &image.samples {
                r.samples_per_side =
                    self.within(s, "samples", &limits::SAMPLES_PER_SIDE, " (N gives N×N per pixel)")?;
            }
        }
        if let Some(render) = &def.render {
            if let Some(d) = &render.max_depth {
                r.max_depth = self.within(d, "max_depth", &limits::MAX_DEPTH, "")?;
            }
            if let Some(c) = &render.min_contribution {
                r.min_contribution = self.non_negative(c, "min_contribution")?;
            }
            if let Some(m) = &render.mode {
                r.mode = match m.get_ref().as_str() {
                    "whitted" => RenderMode::Whitted,
                    "path" => RenderMode::Path,
                    "points" => RenderMode::Points,
                    other => {
                        return Err(
                            self.err(&m.span(), format!("mode {other:?}: use \"whitted\", \"path\" or \"points\""))
                        );
                    }
                };
            }
            if let Some(b) = &render.max_bounces {
                r.max_bounces = self.within(b, "max_bounces", &limits::MAX_BOUNCES, "")?;
            }
            if let Some(s) = &render.sampler {
                r.sampler = match s.get_ref().as_str() {
                    "sobol" => Sampler::Sobol,
                    "independent" => Sampler::Independent,
                    other => {
                        return Err(self.err(&s.span(), format!("sampler {other:?}: use \"sobol\" or \"independent\"")));
                    }
                };
            }
        }
        Ok(r)
    }

    /// The value of `v` if [`limits::check`] accepts it, else its message (with `note` added)
    /// at the value's line.
    fn within(
        &self,
        v: &Spanned<u32>,
        what: &str,
        range: &RangeInclusive<u32>,
        note: &str,
    ) -> Result<u32, FormatError> {
        let n = *v.get_ref();
        limits::check(what, n, range).map_err(|message| self.err(&v.span(), message + note))?;
        Ok(n)
    }
}
