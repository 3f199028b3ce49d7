//! Sensors (perspective, thinlens, orthographic), films, reconstruction filters, samplers and
//! integrators → the camera and [`MitsubaSettings`] (src/sensors/perspective.cpp, thinlens.cpp,
//! orthographic.cpp, include/mitsuba/render/sensor.h `parse_fov`, src/films, src/rfilters,
//! src/samplers, src/integrators).
//!
//! An orthographic sensor sees camera-space x ∈ [−1, 1] and y ∈ [−1/aspect, 1/aspect] before
//! `to_world`, so its view is as wide as twice the length `to_world` gives the x axis.
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
use glint_core::random::Sampler;
use glint_scene::{Camera, Fov, Lens, ViewSize, limits::image_size_ok};

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
        if !["perspective", "thinlens", "orthographic"].contains(&p.plugin) {
            return self.unsupported(&el.loc, format!("sensor '{}' is not supported", p.plugin));
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
            self.settings.sampler = match s.plugin {
                "independent" => Sampler::Independent,
                _ => Sampler::Sobol,
            };
            s.ignore(&["seed", "jitter", "strength", "scramble", "dimension"]);
            self.finish(&s)?;
        }
        let to_world = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let (fov, lens) = match p.plugin {
            "orthographic" => (Fov::Vertical(45.0), self.orthographic(el, &to_world)?),
            "thinlens" => (self.fov(&p)?, thin_lens(&p)?),
            _ => (self.fov(&p)?, Lens::Pinhole),
        };
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
        self.scene.camera =
            Camera { position: position.as_vec3(), forward: forward.as_vec3(), up: up.as_vec3(), fov, lens };
        if Vec3::cross(self.scene.camera.forward, self.scene.camera.up).length_squared() < 1e-12 {
            return Err(el.loc.error("sensor to_world: up is parallel to the view direction"));
        }
        self.finish(&p)
    }

    /// An orthographic sensor's view: half as wide as `to_world` makes camera-space x long;
    /// its height follows the image's aspect, as Mitsuba's does when `to_world` scales x and y
    /// alike (a warning when it does not: glint's pixels stay square).
    fn orthographic(&mut self, el: &Element, to_world: &DMat4) -> Result<Lens, FormatError> {
        let sx = to_world.transform_vector3(DVec3::X).length();
        let sy = to_world.transform_vector3(DVec3::Y).length();
        if !(sx.is_finite() && sx > 0.0 && sy.is_finite() && sy > 0.0) {
            return Err(el.loc.error("orthographic sensor: to_world collapses the view (a zero or non-finite scale)"));
        }
        if (sx - sy).abs() > 1e-4 * sx {
            self.warnings.push(format!(
                "{}: the orthographic sensor's to_world scales x by {sx} and y by {sy}: glint keeps square pixels \
                 (the view's width from x, its height from the image's aspect)",
                el.loc.describe()
            ));
        }
        Ok(Lens::Orthographic(ViewSize::HalfWidth(sx as f32)))
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

/// A thinlens sensor's lens: `aperture_radius` (required, as in Mitsuba) and `focus_distance`
/// (Mitsuba's default is its far clip, 10⁴).
fn thin_lens(p: &Props<'_>) -> Result<Lens, FormatError> {
    let Some(aperture_radius) = p.float_opt("aperture_radius")? else {
        return Err(p.loc().error("thinlens sensor needs aperture_radius (Mitsuba requires it too)"));
    };
    let far = p.float_opt("far_clip")?.unwrap_or(1e4);
    let focus_distance = p.float_opt("focus_distance")?.unwrap_or(far);
    if !(aperture_radius.is_finite() && aperture_radius >= 0.0) {
        return Err(p.loc().error(format!("aperture_radius = {aperture_radius} must be finite and >= 0")));
    }
    if !(focus_distance.is_finite() && focus_distance > 0.0) {
        return Err(p.loc().error(format!("focus_distance = {focus_distance} must be finite and > 0")));
    }
    Ok(Lens::ThinLens { aperture_radius: aperture_radius as f32, focus_distance: focus_distance as f32 })
}
