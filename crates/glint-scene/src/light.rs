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
    },
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
    /// Direction, distance and intensity of this light as seen from `p`. `None` when the
    /// light cannot reach `p` (outside a spot cone, or at the light's position).
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
}
