//! The scene's lights seen from eight shading points at once: what [`Light::sample_at`]
//! computes, lane by lane and in its order, for the batched Whitted shader (`whitted/shade8.rs`)
//! and the points mode's deferred shading (`points/shade.rs`). Projected textures are not
//! applied here: a scene with a textured spot is shaded by the scalar code.

use glint_accel::lanes::{F8, Isa, M8, V8};
use glint_core::Vec3;
use glint_scene::light::{spot_falloff_gltf, spot_falloff_linear};
use glint_scene::{Attenuation, Light, SpotFalloff};

/// A light as the lanes read it, with the spot cone's cosines worked out once.
pub(crate) struct LightLanes {
    kind: LightKind,
    position: Vec3,
    /// Spot axis (unit), or a directional light's travel direction.
    direction: Vec3,
    colour: Vec3,
    intensity: f32,
    inverse_square: bool,
    cos_inner: f32,
    cos_outer: f32,
    /// A spot's curve between its cones, and the cones in degrees (for the curves other than
    /// smoothstep, worked out lane by lane by the scalar functions).
    falloff: SpotFalloff,
    inner_deg: f32,
    outer_deg: f32,
}

#[derive(Clone, Copy, PartialEq, Eq)]
enum LightKind {
    Point,
    Directional,
    Spot,
}

impl LightLanes {
    pub(crate) fn new(light: &Light) -> Self {
        let base = LightLanes {
            kind: LightKind::Point,
            position: Vec3::ZERO,
            direction: Vec3::ZERO,
            colour: Vec3::ZERO,
            intensity: 0.0,
            inverse_square: false,
            cos_inner: 1.0,
            cos_outer: 1.0,
            falloff: SpotFalloff::Smoothstep,
            inner_deg: 0.0,
            outer_deg: 0.0,
        };
        match *light {
            Light::Point { position, colour, intensity, attenuation } => LightLanes {
                position,
                colour,
                intensity,
                inverse_square: attenuation == Attenuation::InverseSquare,
                ..base
            },
            Light::Directional { direction, colour, intensity } => {
                LightLanes { kind: LightKind::Directional, direction, colour, intensity, ..base }
            }
            Light::Spot {
                position, direction, inner_deg, outer_deg, colour, intensity, attenuation, falloff, ..
            } => LightLanes {
                kind: LightKind::Spot,
                position,
                direction,
                colour,
                intensity,
                inverse_square: attenuation == Attenuation::InverseSquare,
                cos_inner: inner_deg.to_radians().cos(),
                cos_outer: outer_deg.to_radians().cos(),
                falloff,
                inner_deg,
                outer_deg,
            },
        }
    }

    /// `Light::sample_at` of eight points: the unit direction toward the light, the distance
    /// (∞ for a directional light), the radiance, and the lanes the light reaches.
    #[inline(always)]
    pub(crate) fn sample<I: Isa>(&self, p: V8<I>) -> (V8<I>, F8<I>, V8<I>, M8<I>) {
        if self.kind == LightKind::Directional {
            let radiance = V8::splat(self.colour * self.intensity);
            return (V8::splat(-self.direction), F8::splat(f32::INFINITY), radiance, M8::all());
        }
        let d = V8::splat(self.position) - p;
        let dist = d.dot(d).sqrt();
        let reaches = dist.gt(F8::zero());
        let wi = V8::new(d.x / dist, d.y / dist, d.z / dist);
        let mut fall = if self.inverse_square { F8::one() / (dist * dist) } else { F8::one() };
        let mut lit = reaches;
        if self.kind == LightKind::Spot {
            let cos = (-wi).dot(V8::splat(self.direction));
            let cone = match self.falloff {
                SpotFalloff::Smoothstep => {
                    let (ci, co) = (self.cos_inner, self.cos_outer);
                    let x = (cos - F8::splat(co)) / F8::splat(ci - co);
                    let smooth = x * x * (F8::splat(3.0) - F8::splat(2.0) * x);
                    if ci <= co {
                        F8::select(cos.ge(F8::splat(ci)), F8::one(), F8::zero())
                    } else {
                        let outside = F8::select(cos.le(F8::splat(co)), F8::zero(), smooth);
                        F8::select(cos.ge(F8::splat(ci)), F8::one(), outside)
                    }
                }
                // The imported scenes' curves (an arccosine, a clamp): rare, and exact lane by lane.
                SpotFalloff::LinearAngle => {
                    F8::from_fn(|i| spot_falloff_linear(cos[i], self.inner_deg, self.outer_deg))
                }
                SpotFalloff::SquaredCosine => {
                    F8::from_fn(|i| spot_falloff_gltf(cos[i], self.inner_deg, self.outer_deg))
                }
            };
            lit = lit & cone.gt(F8::zero());
            fall *= cone;
        }
        let scale = F8::splat(self.intensity) * fall;
        (wi, dist, V8::splat(self.colour).scale(scale), lit)
    }
}
