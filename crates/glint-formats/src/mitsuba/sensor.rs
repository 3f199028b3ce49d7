//! Sensors (perspective; thinlens and orthographic approximated), films, reconstruction
//! filters, samplers and integrators → the camera and [`MitsubaSettings`]
//! (src/sensors/perspective.cpp, include/mitsuba/render/sensor.h `parse_fov`, src/films,
//! src/rfilters, src/samplers, src/integrators).
//!
//! Mitsuba's camera looks along its local +z with +y up, and its image x runs along local −x
//! (`perspective_projection` scales by −½): for a proper rotation that is forward × up, glint's
//! right. A mirroring `to_world` flips Mitsuba's image, which [`MitsubaSettings::camera_flip_x`]
//! reports.

use super::props::Props;
use super::xml::Element;
use super::{Builder, MitsubaIntegrator, PixelFilter};
use crate::error::FormatError;
use glint_core::Vec3;
use glint_core::glam::{DMat4, DVec3};
use glint_scene::{Camera, Fov, limits::image_size_ok};

const SAMPLERS: [&str; 5] = ["independent", "stratified", "multijitter", "ldsampler", "orthogonal"];

impl<'a> Builder<'a> {
    pub(super) fn integrator(&mut self, el: &'a Element) -> Result<(), FormatError> {
        let p = self.props(el)?;
        let hide = p.boolean("hide_emitters", false)?;
        match p.plugin {
            "path" | "ptracer" | "volpath" | "volpathmis" => {
                if p.plugin != "path" {
                    self.unsupported(&el.loc, format!("{}: rendered as a unidirectional path tracer", el.describe()))?;
                }
                let max_depth = p.int("max_depth", -1)?;
                let max_depth = match max_depth {
                    -1 => None,
                    d => Some(
                        u32::try_from(d).map_err(|_| el.loc.error(format!("max_depth = {d} must be -1 or >= 0")))?,
                    ),
                };
                let rr_depth = p.count("rr_depth", 5)?;
                p.ignore(&["samples_per_pass", "timeout"]);
                self.settings.integrator = MitsubaIntegrator::Path { max_depth, rr_depth, hide_emitters: hide };
            }
            "direct" => {
                let shading = p.count("shading_samples", 1)?;
                let emitter_samples = p.count("emitter_samples", shading)?;
                let bsdf_samples = p.count("bsdf_samples", shading)?;
                self.settings.integrator =
                    MitsubaIntegrator::Direct { emitter_samples, bsdf_samples, hide_emitters: hide };
            }
            "moment" | "aov" => {
                p.ignore(&["aovs"]);
                let inner = p.unnamed("integrator");
                if p.plugin == "aov" && inner.is_empty() {
                    self.unsupported(
                        &el.loc,
                        "<integrator type=\"aov\"> without an inner integrator: glint renders its path mode",
                    )?;
                }
                for i in inner {
                    self.integrator(i)?;
                }
            }
            other => {
                self.unsupported(&el.loc, format!("integrator '{other}' is not supported: glint uses a path tracer"))?;
                p.ignore(&["max_depth", "rr_depth"]);
            }
        }
        self.finish(&p)
    }

    pub(super) fn sensor(&mut self, el: &'a Element) -> Result<(), FormatError> {
        if self.has_sensor {
            return self.unsupported(&el.loc, "a second <sensor>: glint renders the first");
        }
        self.has_sensor = true;
        let p = self.props(el)?;
        match p.plugin {
            "perspective" => {}
            "thinlens" => {
                self.unsupported(&el.loc, "thinlens sensor: rendered as a pinhole (aperture_radius ignored)")?;
                p.ignore(&["aperture_radius"]);
            }
            "orthographic" => {
                self.unsupported(
                    &el.loc,
                    "orthographic sensor: glint has no orthographic camera; a perspective one is used",
                )?;
            }
            other => return self.unsupported(&el.loc, format!("sensor '{other}' is not supported")),
        }
        // Film first: the field of view depends on its aspect.
        for film in p.unnamed("film") {
            self.film(film)?;
        }
        for sampler in p.unnamed("sampler") {
            let s = self.props(sampler)?;
            if !SAMPLERS.contains(&s.plugin) {
                self.unsupported(
                    &sampler.loc,
                    format!("sampler '{}' is not supported: its sample_count is used", s.plugin),
                )?;
            }
            self.settings.spp = Some(s.count("sample_count", 4)?);
            s.ignore(&["seed", "jitter", "strength", "scramble", "dimension"]);
            self.finish(&s)?;
        }
        let to_world = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let fov = self.fov(&p)?;
        p.ignore(&[
            "near_clip",
            "far_clip",
            "focus_distance",
            "shutter_open",
            "shutter_close",
            "srf",
            "principal_point_offset_x",
            "principal_point_offset_y",
        ]);
        let position = to_world.transform_point3(DVec3::ZERO);
        let forward = to_world.transform_vector3(DVec3::Z);
        let up = to_world.transform_vector3(DVec3::Y);
        let m3 = glint_core::glam::DMat3::from_mat4(to_world);
        self.settings.camera_flip_x = m3.determinant() < 0.0;
        if self.settings.camera_flip_x {
            self.warnings.push(format!(
                "{}: the sensor's to_world mirrors: glint's image is Mitsuba's flipped left to right (settings.camera_flip_x)",
                el.loc.describe()
            ));
        }
        let forward = forward.try_normalize().ok_or_else(|| el.loc.error("sensor to_world maps +z to zero"))?;
        self.scene.camera = Camera { position: position.as_vec3(), forward: forward.as_vec3(), up: up.as_vec3(), fov };
        if Vec3::cross(self.scene.camera.forward, self.scene.camera.up).length_squared() < 1e-12 {
            return Err(el.loc.error("sensor to_world: up is parallel to the view direction"));
        }
        self.finish(&p)
    }

    /// Mitsuba's `parse_fov`: the field of view along its axis (resolved against the image's
    /// aspect when rays are made, so `--width`/`--height` keep Mitsuba's framing).
    fn fov(&mut self, p: &Props<'a>) -> Result<Fov, FormatError> {
        let (fov, axis) = match (p.float_opt("fov")?, p.string("focal_length")?) {
            (Some(_), Some(_)) => return Err(p.loc().error("give either fov or focal_length, not both")),
            (Some(f), None) => (f, p.string("fov_axis")?.unwrap_or("x")),
            (None, focal) => {
                let text = focal.unwrap_or("50mm");
                let mm = text.trim().trim_end_matches("mm").trim();
                let f = mm
                    .parse::<f64>()
                    .ok()
                    .filter(|f| f.is_finite() && *f > 0.0)
                    .ok_or_else(|| p.loc().error(format!("focal_length '{text}' is not a length like 50mm")))?;
                let _ = p.string("fov_axis")?;
                // A 36 × 24 mm film's diagonal.
                let diagonal = (36.0f64 * 36.0 + 24.0 * 24.0).sqrt();
                (2.0 * (diagonal / (2.0 * f)).atan().to_degrees(), "diagonal")
            }
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(p.loc().error(format!("fov = {fov}° must be in (0, 180)")));
        }
        let fov = fov as f32;
        Ok(match axis.to_ascii_lowercase().as_str() {
            "x" => Fov::Horizontal(fov),
            "y" => Fov::Vertical(fov),
            "smaller" => Fov::Smaller(fov),
            "larger" => Fov::Larger(fov),
            "diagonal" => Fov::Diagonal(fov),
            other => {
                return Err(p.loc().error(format!("fov_axis '{other}' is none of x, y, smaller, larger, diagonal")));
            }
        })
    }

    fn film(&mut self, el: &'a Element) -> Result<(), FormatError> {
        let p = self.props(el)?;
        if p.plugin != "hdrfilm" && p.plugin != "specfilm" {
            self.unsupported(&el.loc, format!("film '{}': read as hdrfilm", p.plugin))?;
        }
        let (w, h) = (p.count("width", 768)?, p.count("height", 576)?);
        if !image_size_ok(w, h) {
            return Err(el.loc.error(format!("film size {w}x{h} is not a size glint renders")));
        }
        let (ox, oy) = (p.count("crop_offset_x", 0)?, p.count("crop_offset_y", 0)?);
        let (cw, ch) = (p.count("crop_width", w.saturating_sub(ox))?, p.count("crop_height", h.saturating_sub(oy))?);
        if cw == 0
            || ch == 0
            || u64::from(ox) + u64::from(cw) > u64::from(w)
            || u64::from(oy) + u64::from(ch) > u64::from(h)
        {
            return Err(el.loc.error(format!("crop window {cw}x{ch} at ({ox}, {oy}) is not inside the {w}x{h} film")));
        }
        self.settings.width = w;
        self.settings.height = h;
        self.settings.crop = ((ox, oy, cw, ch) != (0, 0, w, h)).then_some([ox, oy, cw, ch]);
        p.ignore(&[
            "pixel_format",
            "component_format",
            "file_format",
            "banner",
            "high_quality_edges",
            "sample_border",
            "compensate",
            "rfilter",
        ]);
        for f in p.unnamed("rfilter") {
            let fp = self.props(f)?;
            self.settings.filter = match fp.plugin {
                "box" => PixelFilter::Box,
                "tent" => PixelFilter::Tent { radius: positive(&fp, "radius", 1.0)? },
                "gaussian" => PixelFilter::Gaussian { stddev: positive(&fp, "stddev", 0.5)? },
                other => {
                    self.unsupported(
                        &f.loc,
                        format!("reconstruction filter '{other}': a gaussian (stddev 0.5) is used"),
                    )?;
                    fp.ignore(&["radius", "B", "C", "lobes"]);
                    PixelFilter::Gaussian { stddev: 0.5 }
                }
            };
            self.settings.filter.validate().map_err(|m| f.loc.error(m))?;
            self.finish(&fp)?;
        }
        self.finish(&p)
    }
}

fn positive(p: &Props, name: &str, default: f64) -> Result<f32, FormatError> {
    let v = p.float(name, default)?;
    if v > 0.0 { Ok(v as f32) } else { Err(p.loc().error(format!("{name} = {v} must be > 0"))) }
}
