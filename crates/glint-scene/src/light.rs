//! Lights of the Phong model: point, directional and spot (cone with smooth falloff).

use glint_core::{Rgb, Vec3};

/// How a spot light's intensity falls off between its inner and outer cones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SpotFalloff {
    /// Smoothstep on the cosine of the angle from the axis (glint's own spots).
    #[default]
    Smoothstep,
    /// Linear in the angle itself, `(outer − θ) / (outer − inner)`: Mitsuba 3's `spot`
    /// (`beam_width` is the inner cone, `cutoff_angle` the outer one).
    LinearAngle,
    /// The square of a linear ramp in the cosine, from the outer cone (0) to the inner one (1):
    /// glTF's KHR_lights_punctual recommended falloff ([`spot_falloff_gltf`]).
    SquaredCosine,
}

/// How a positional light's intensity falls off with distance.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Attenuation {
    /// The classic Whitted/Phong light: no falloff (the thesis's model).
    #[default]
    None,
    /// Physical 1/d² falloff.
    InverseSquare,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    Point {
        position: Vec3,
        colour: Rgb,
        intensity: f32,
        attenuation: Attenuation,
    },
    /// `direction` is the way the light travels (from the light toward the scene), unit length.
    Directional {
        direction: Vec3,
        colour: Rgb,
        intensity: f32,
    },
    /// Full intensity inside `inner_deg` of the axis, falling to zero at `outer_deg` as
    /// `falloff` says (smoothstep unless the scene came from Mitsuba).
    Spot {
        position: Vec3,
        direction: Vec3,
        inner_deg: f32,
        outer_deg: f32,
        colour: Rgb,
        intensity: f32,
        attenuation: Attenuation,
        falloff: SpotFalloff,
        /// A texture projected along the cone (Mitsuba's spot `texture`), or none.
        projection: Option<SpotProjection>,
    },
}

/// A texture a spot light projects: the direction `d` leaving the light (in the light's frame
/// `right`, `up`, `direction`, with `d·direction` = z) reads the texture at Mitsuba's
/// `(½ + ½ x/(z·tan c), ½ + ½ y/(z·tan c))` for the cutoff angle c, v flipped to glint's
/// convention (src/emitters/spot.cpp `direction_to_uv`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpotProjection {
    /// Index into [`crate::Scene::textures`] (read by uv).
    pub texture: usize,
    /// The light frame's unit x and y axes (Mitsuba's `to_world` applied to them).
    pub right: Vec3,
    pub up: Vec3,
    /// tan of the cutoff (outer) angle: the texture's edge.
    pub tan_cutoff: f32,
}

impl SpotProjection {
    /// The texture coordinates (glint's) of the direction `d` leaving the light along its
    /// axis `direction`.
    #[must_use]
    pub fn uv(&self, d: Vec3, direction: Vec3) -> glint_core::Vec2 {
        let z = d.dot(direction) * self.tan_cutoff;
        let (x, y) = (d.dot(self.right) / z, d.dot(self.up) / z);
        glint_core::Vec2::new(0.5 + 0.5 * x, 1.0 - (0.5 + 0.5 * y))
    }
}

/// What a shading point receives from one light, before visibility.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    /// Unit direction from the shading point toward the light.
    pub wi: Vec3,
    /// Distance to the light (infinite for directional lights).
    pub distance: f32,
    /// Incident intensity (colour × intensity × falloff).
    pub radiance: Rgb,
}

impl Light {
    /// [`Light::sample_at`] with a spot light's projected texture applied (`textures`: the
    /// scene's).
    #[must_use]
    pub fn sample_in(&self, p: Vec3, textures: &[crate::Texture]) -> Option<LightSample> {
        let mut s = self.sample_at(p)?;
        if let Light::Spot { direction, projection: Some(proj), .. } = *self {
            let texel = textures.get(proj.texture).map_or(Rgb::ONE, |t| t.evaluate(proj.uv(-s.wi, direction)));
            s.radiance *= texel;
        }
        Some(s)
    }

    /// Does this light project a texture (then only [`Light::sample_in`] gives its light)?
    #[must_use]
    pub fn is_textured(&self) -> bool {
        matches!(self, Light::Spot { projection: Some(_), .. })
    }

    /// Direction, distance and intensity of this light as seen from `p`. `None` when the
    /// light cannot reach `p` (outside a spot cone, or at the light's position). A spot's
    /// projected texture is not applied here (see [`Light::sample_in`]).
    pub fn sample_at(&self, p: Vec3) -> Option<LightSample> {
        match *self {
            Light::Point { position, colour, intensity, attenuation } => {
                let d = position - p;
                let dist = d.length();
                if dist <= 0.0 {
                    return None;
                }
                let fall = falloff(attenuation, dist);
                Some(LightSample { wi: d / dist, distance: dist, radiance: colour * (intensity * fall) })
            }
            Light::Directional { direction, colour, intensity } => {
                Some(LightSample { wi: -direction, distance: f32::INFINITY, radiance: colour * intensity })
            }
            Light::Spot {
                position,
                direction,
                inner_deg,
                outer_deg,
                colour,
                intensity,
                attenuation,
                falloff: curve,
                ..
            } => {
                let d = position - p;
                let dist = d.length();
                if dist <= 0.0 {
                    return None;
                }
                let wi = d / dist;
                let cos = (-wi).dot(direction);
                let cone = match curve {
                    SpotFalloff::Smoothstep => spot_falloff(cos, inner_deg, outer_deg),
                    SpotFalloff::LinearAngle => spot_falloff_linear(cos, inner_deg, outer_deg),
                    SpotFalloff::SquaredCosine => spot_falloff_gltf(cos, inner_deg, outer_deg),
                };
                if cone <= 0.0 {
                    return None;
                }
                let fall = falloff(attenuation, dist) * cone;
                Some(LightSample { wi, distance: dist, radiance: colour * (intensity * fall) })
            }
        }
    }

    /// The position of a positional light.
    pub fn position(&self) -> Option<Vec3> {
        match *self {
            Light::Point { position, .. } | Light::Spot { position, .. } => Some(position),
            Light::Directional { .. } => None,
        }
    }
}

fn falloff(a: Attenuation, dist: f32) -> f32 {
    match a {
        Attenuation::None => 1.0,
        Attenuation::InverseSquare => 1.0 / (dist * dist),
    }
}

/// Smoothstep from the outer cone (0) to the inner cone (1), on the cosine of the angle.
pub fn spot_falloff(cos_angle: f32, inner_deg: f32, outer_deg: f32) -> f32 {
    let cos_inner = inner_deg.to_radians().cos();
    let cos_outer = outer_deg.to_radians().cos();
    if cos_angle >= cos_inner {
        return 1.0;
    }
    if cos_angle <= cos_outer || cos_inner <= cos_outer {
        return 0.0;
    }
    let x = (cos_angle - cos_outer) / (cos_inner - cos_outer);
    x * x * (3.0 - 2.0 * x)
}

/// KHR_lights_punctual's recommended spot falloff:
/// `saturate((cos − cos_outer) / max(0.001, cos_inner − cos_outer))²`.
pub fn spot_falloff_gltf(cos_angle: f32, inner_deg: f32, outer_deg: f32) -> f32 {
    let (cos_inner, cos_outer) = (inner_deg.to_radians().cos(), outer_deg.to_radians().cos());
    let x = ((cos_angle - cos_outer) / (cos_inner - cos_outer).max(1e-3)).clamp(0.0, 1.0);
    x * x
}

/// Mitsuba 3's spot profile: 1 inside `inner_deg`, `(outer − θ)/(outer − inner)` (θ the angle
/// from the axis, radians) up to `outer_deg`, 0 at and beyond it.
pub fn spot_falloff_linear(cos_angle: f32, inner_deg: f32, outer_deg: f32) -> f32 {
    let (inner, outer) = (inner_deg.to_radians(), outer_deg.to_radians());
    if cos_angle <= outer.cos() {
        return 0.0;
    }
    if cos_angle >= inner.cos() || outer <= inner {
        return 1.0;
    }
    ((outer - cos_angle.clamp(-1.0, 1.0).acos()) / (outer - inner)).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_is_full_inside_zero_outside_and_smooth_between() {
        assert_eq!(spot_falloff(1.0, 20.0, 30.0), 1.0);
        assert_eq!(spot_falloff(35f32.to_radians().cos(), 20.0, 30.0), 0.0);
        let mid = spot_falloff(25f32.to_radians().cos(), 20.0, 30.0);
        assert!(mid > 0.3 && mid < 0.7, "{mid}");
    }

    #[test]
    fn linear_spot_falls_linearly_in_angle() {
        assert_eq!(spot_falloff_linear(1.0, 15.0, 20.0), 1.0);
        assert_eq!(spot_falloff_linear(20.5f32.to_radians().cos(), 15.0, 20.0), 0.0);
        let at = |deg: f32| spot_falloff_linear(deg.to_radians().cos(), 15.0, 20.0);
        assert!((at(17.5) - 0.5).abs() < 1e-3, "{}", at(17.5));
        assert!((at(19.0) - 0.2).abs() < 1e-3, "{}", at(19.0));
        let spot = Light::Spot {
            position: Vec3::Y,
            direction: -Vec3::Y,
            inner_deg: 15.0,
            outer_deg: 20.0,
            colour: Rgb::ONE,
            intensity: 1.0,
            attenuation: Attenuation::None,
            falloff: SpotFalloff::LinearAngle,
            projection: None,
        };
        let p = Vec3::new(17.5f32.to_radians().tan(), 0.0, 0.0);
        let s = spot.sample_at(p).expect("inside the cone");
        assert!((s.radiance.x - 0.5).abs() < 1e-3, "{}", s.radiance);
    }

    #[test]
    fn point_light_points_at_the_light() {
        let l = Light::Point {
            position: Vec3::new(0.0, 2.0, 0.0),
            colour: Rgb::ONE,
            intensity: 2.0,
            attenuation: Attenuation::InverseSquare,
        };
        let s = l.sample_at(Vec3::ZERO).expect("reachable");
        assert_eq!(s.wi, Vec3::Y);
        assert_eq!(s.distance, 2.0);
        assert!((s.radiance.x - 0.5).abs() < 1e-6);
    }

    #[test]
    fn a_projected_texture_spans_the_cutoff_cone() {
        let proj = SpotProjection { texture: 0, right: Vec3::X, up: Vec3::Y, tan_cutoff: 20f32.to_radians().tan() };
        let axis = Vec3::Z;
        let uv = |deg_x: f32, deg_y: f32| {
            let d = Vec3::new(deg_x.to_radians().tan(), deg_y.to_radians().tan(), 1.0).normalize();
            proj.uv(d, axis)
        };
        assert!((uv(0.0, 0.0) - glint_core::Vec2::splat(0.5)).length() < 1e-6);
        // The cutoff along +x is the texture's right edge; along +y (up) its top row (v = 0).
        assert!((uv(20.0, 0.0) - glint_core::Vec2::new(1.0, 0.5)).length() < 1e-5, "{}", uv(20.0, 0.0));
        assert!((uv(0.0, 20.0) - glint_core::Vec2::new(0.5, 0.0)).length() < 1e-5, "{}", uv(0.0, 20.0));
        // sample_in multiplies the spot's light by the texel there.
        let texture = crate::Texture::Checker { size: 0.5, even: Rgb::splat(0.25), odd: Rgb::ONE };
        let spot = Light::Spot {
            position: Vec3::ZERO,
            direction: axis,
            inner_deg: 20.0,
            outer_deg: 20.0,
            colour: Rgb::ONE,
            intensity: 1.0,
            attenuation: Attenuation::None,
            falloff: SpotFalloff::LinearAngle,
            projection: Some(proj),
        };
        let p = Vec3::new(-0.1, -0.1, 1.0);
        let plain = spot.sample_at(p).expect("in the cone").radiance;
        let lit = spot.sample_in(p, std::slice::from_ref(&texture)).expect("in the cone").radiance;
        let want = texture.evaluate(proj.uv(p.normalize(), axis));
        assert!(spot.is_textured() && (lit - plain * want).abs().max_element() < 1e-6, "{lit} vs {plain} × {want}");
    }
}
