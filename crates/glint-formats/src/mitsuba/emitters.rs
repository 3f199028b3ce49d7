//! Emitters (src/emitters/*.cpp) → emissive materials, lights and the sky.
//!
//! Units: Mitsuba's point and spot `intensity` I (W/sr) gives an irradiance I/d²; glint's
//! path mode gives a light of `colour · intensity` the irradiance π · colour · intensity ·
//! falloff (crates/glint-render/src/path/lights.rs), so colour = I/π with inverse-square
//! falloff. A directional `irradiance` E likewise becomes colour E/π. Area `radiance` and
//! `constant`/`envmap` radiance are radiances in both.
//!
//! `envmap`: Mitsuba maps a local direction v to uv = (atan2(v.x, −v.z)/2π, acos(v.y)/π),
//! glint's lat-long map to (½ + atan2(x, −z)/2π, acos(y)/π) — the same but turned 180° about
//! +y. So glint's map direction is R_y(180°) · to_world⁻¹ · d. Texel columns agree (centres at
//! (i + ½)/W in both); Mitsuba places row j at v = j/(H − 1), glint at (j + ½)/H, so rows can
//! differ by up to half a texel (the only approximation).

use super::Builder;
use super::props::Props;
use super::spectrum::Use;
use super::xml::Element;
use crate::error::FormatError;
use glint_core::glam::{DMat3, DMat4, DVec3};
use glint_core::{Mat3, Rgb};
use glint_scene::{Attenuation, LatLongMap, Light, Sky, SkyTransform, SpotFalloff, SpotProjection, Tex};
use std::f32::consts::PI;
use std::sync::Arc;

/// glint's lat-long map rotation for a Mitsuba envmap's `to_world` (None: not a rotation).
pub(super) fn envmap_map_from_world(to_world: &DMat4) -> Option<Mat3> {
    let m = DMat3::from_mat4(*to_world);
    if m.determinant().abs() < 1e-12 || !m.is_finite() {
        return None;
    }
    let inv = m.inverse();
    let turn = DMat3::from_diagonal(DVec3::new(-1.0, 1.0, -1.0));
    let r = turn * inv;
    // Re-orthonormalise (files round their matrices to a few digits).
    let z = r.z_axis.try_normalize()?;
    let x = r.y_axis.cross(z).try_normalize()?;
    let y = z.cross(x);
    let ortho = DMat3::from_cols(x, y, z);
    ((ortho - r).to_cols_array().iter().all(|e| e.abs() < 1e-3)).then(|| ortho.as_mat3())
}

impl<'a> Builder<'a> {
    /// A colour the emitter gives (textures are not supported: lenient mode uses white).
    fn emitted(&mut self, p: &Props<'a>, name: &str) -> Result<Rgb, FormatError> {
        match self.rgb_tex(p, name, 1.0, Use::Emitter)? {
            Tex::Value(c) => Ok(c),
            Tex::Texture(_) => {
                self.unsupported(p.loc(), format!("a textured '{name}' is not supported by glint: white is used"))?;
                Ok(Rgb::ONE)
            }
        }
    }

    /// An `area` emitter on a shape: its radiance, a colour or a texture over the shape's uvs.
    pub(super) fn area_emitter(&mut self, el: &'a Element) -> Result<Tex<Rgb>, FormatError> {
        let p = self.props(el)?;
        if p.plugin != "area" {
            return Err(el.loc.error(format!("a shape's emitter must be 'area', not '{}'", p.plugin)));
        }
        let mut radiance = self.rgb_tex(&p, "radiance", 1.0, Use::Emitter)?;
        if let Tex::Texture(t) = radiance
            && self.scene.textures[t].reads_mesh()
        {
            // Light sampling picks points by uv, not by the mesh's attributes.
            self.unsupported(&el.loc, "an area emitter's radiance from a mesh_attribute: a constant 1 is used")?;
            radiance = Tex::Value(Rgb::ONE);
        }
        self.finish(&p)?;
        Ok(radiance)
    }

    pub(super) fn emitter(&mut self, el: &'a Element) -> Result<(), FormatError> {
        let p = self.props(el)?;
        p.ignore(&["id", "sampling_weight"]);
        let to_world = p.transform("to_world")?;
        let world = to_world.unwrap_or(DMat4::IDENTITY);
        match p.plugin {
            "point" => {
                let position = match p.vector("position")? {
                    Some(_) if to_world.is_some() => return Err(el.loc.error("give either position or to_world")),
                    Some(v) => v,
                    None => world.transform_point3(DVec3::ZERO),
                };
                let intensity = self.emitted(&p, "intensity")?;
                self.scene.lights.push(Light::Point {
                    position: position.as_vec3(),
                    colour: intensity / PI,
                    intensity: 1.0,
                    attenuation: Attenuation::InverseSquare,
                });
            }
            "spot" => {
                let intensity = self.emitted(&p, "intensity")?;
                let cutoff = p.float("cutoff_angle", 20.0)?;
                let beam = p.float("beam_width", cutoff * 0.75)?;
                if !(cutoff > 0.0 && cutoff <= 180.0 && beam >= 0.0) {
                    return Err(el
                        .loc
                        .error(format!("cutoff_angle {cutoff} and beam_width {beam} are not angles of a cone")));
                }
                let direction = world
                    .transform_vector3(DVec3::Z)
                    .try_normalize()
                    .ok_or_else(|| el.loc.error("to_world maps +z to zero"))?;
                let projection = match p.get("texture") {
                    None => None,
                    Some(prop) => {
                        let super::props::Value::Object(t) = prop.value else {
                            return Err(prop.at.loc.error("a spot light's texture must be a <texture>"));
                        };
                        if cutoff >= 90.0 {
                            return Err(el.loc.error(format!(
                                "a textured spot projects onto a plane ahead: cutoff_angle {cutoff} must be below 90"
                            )));
                        }
                        let axis = |v: DVec3, name: &str| {
                            world
                                .transform_vector3(v)
                                .try_normalize()
                                .map(|v| v.as_vec3())
                                .ok_or_else(|| el.loc.error(format!("to_world maps {name} to zero")))
                        };
                        Some(SpotProjection {
                            texture: self.uv_texture(t, "spot light")?,
                            right: axis(DVec3::X, "+x")?,
                            up: axis(DVec3::Y, "+y")?,
                            tan_cutoff: cutoff.to_radians().tan() as f32,
                        })
                    }
                };
                self.scene.lights.push(Light::Spot {
                    position: world.transform_point3(DVec3::ZERO).as_vec3(),
                    direction: direction.as_vec3(),
                    inner_deg: beam.min(cutoff) as f32,
                    outer_deg: cutoff as f32,
                    colour: intensity / PI,
                    intensity: 1.0,
                    attenuation: Attenuation::InverseSquare,
                    falloff: SpotFalloff::LinearAngle,
                    projection,
                });
            }
            "directional" => {
                let direction = match p.vector("direction")? {
                    Some(_) if to_world.is_some() => return Err(el.loc.error("give either direction or to_world")),
                    Some(d) => d,
                    None => world.transform_vector3(DVec3::Z),
                };
                let direction =
                    direction.try_normalize().ok_or_else(|| el.loc.error("the light's direction has zero length"))?;
                let irradiance = self.emitted(&p, "irradiance")?;
                self.scene.lights.push(Light::Directional {
                    direction: direction.as_vec3(),
                    colour: irradiance / PI,
                    intensity: 1.0,
                });
            }
            "constant" => {
                let radiance = self.emitted(&p, "radiance")?;
                self.set_sky(el, Sky::Colour(radiance))?;
            }
            "envmap" => {
                let name = p.string("filename")?.ok_or_else(|| el.loc.error("an envmap needs a filename"))?;
                let file = self.resolve(name, el)?;
                let scale = p.float("scale", 1.0)? as f32;
                p.ignore(&["mis_compensation"]);
                let image = crate::texture_file::read_texture_image(&file)?;
                // Mitsuba's rows span the poles (its envmap reads row j at v = j/(H − 1)).
                let map = LatLongMap::from_image(image)
                    .map(LatLongMap::with_rows_spanning_poles)
                    .map_err(|source| FormatError::Invalid { file: file.clone(), source })?;
                let transform = envmap_map_from_world(&world)
                    .and_then(|m| SkyTransform::from_rotation(m, scale))
                    .ok_or_else(|| el.loc.error("an envmap's to_world must be a rotation"))?;
                self.set_sky(el, Sky::LatLong { map: Arc::new(map), transform })?;
            }
            other => {
                self.unsupported(&el.loc, format!("emitter '{other}' is not supported by glint"))?;
                return Ok(());
            }
        }
        self.finish(&p)
    }

    fn set_sky(&mut self, el: &Element, sky: Sky) -> Result<(), FormatError> {
        if !matches!(self.scene.sky, Sky::Colour(c) if c == Rgb::ZERO) {
            self.unsupported(&el.loc, "a second environment emitter: glint has one sky, the last one is used")?;
        }
        self.scene.sky = sky;
        Ok(())
    }
}

/// Used by tests: glint's map direction of a world direction under an envmap `to_world`.
#[cfg(test)]
pub(super) fn map_direction(to_world: &DMat4, d: glint_core::Vec3) -> glint_core::Vec3 {
    envmap_map_from_world(to_world).map_or(glint_core::Vec3::ZERO, |m| m * d)
}
