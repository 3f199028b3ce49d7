//! KHR_lights_punctual → glint lights, placed by their nodes (lights shine along the node's
//! −Z; point and spot lights sit at its origin).
//!
//! **Units.** glTF gives point and spot lights in candela (a light of I cd gives irradiance
//! I/d²) and directional lights in lux (irradiance E). glint's lights deliver irradiance π·I
//! for intensity I (with [`Attenuation::InverseSquare`]: π·I/d²; see glint-render's
//! path/lights.rs), so glTF's I becomes I/π and E becomes E/π, colour as given. `range` is
//! ignored (glint's lights have no cut-off; a warning says so): the spec allows a renderer to
//! use the physical 1/d² falloff throughout.
//!
//! **Spot cones.** glTF's recommended falloff is the square of a linear ramp in the cosine,
//! from the outer cone (0) to the inner (1) ([`gltf_spot_falloff`]); glint's
//! [`Light::Spot`] is a smoothstep on the cosine. glint-render matches `Light::Spot`'s fields
//! one by one, so a falloff field cannot be added to glint-scene without editing the renderer:
//! the loader instead picks the smoothstep cone closest to glTF's curve ([`smoothstep_cone`]:
//! within 0.07 of the peak when the inner cone is close to the outer, growing to 0.15 as the
//! inner angle goes to 0, glTF's default, where the smoothstep cannot start early enough).

use crate::error::FormatError;
use crate::model::file_name;
use glint_core::{Mat4, Rgb, Vec3};
use glint_scene::light::spot_falloff;
use glint_scene::{Attenuation, Light};
use std::f32::consts::PI;
use std::path::Path;

/// The glint light for `light`, placed by `world_from_node`; a warning when its `range` is
/// dropped.
pub(super) fn convert_light(
    path: &Path,
    node: usize,
    light: &gltf::khr_lights_punctual::Light,
    world_from_node: &Mat4,
    warnings: &mut Vec<String>,
) -> Result<Light, FormatError> {
    let place = format!("KHR_lights_punctual.lights[{}] (on nodes[{node}])", light.index());
    let colour = Rgb::from_array(light.color());
    let intensity = light.intensity();
    if !(colour.is_finite() && colour.min_element() >= 0.0 && intensity.is_finite() && intensity >= 0.0) {
        return Err(FormatError::malformed(path, place, "color and intensity must be finite and non-negative"));
    }
    if light.range().is_some() {
        warnings.push(format!(
            "{}: {place}: `range` ignored (glint's lights fall off as 1/d² without a cut-off)",
            file_name(path)
        ));
    }
    let position = world_from_node.transform_point3(Vec3::ZERO);
    let direction = world_from_node.transform_vector3(-Vec3::Z).try_normalize();
    let (position, direction) = match (position.is_finite(), direction) {
        (true, Some(d)) => (position, d),
        _ => return Err(FormatError::malformed(path, place, "the node's transform is singular or not finite")),
    };
    let intensity = intensity / PI;
    Ok(match light.kind() {
        gltf::khr_lights_punctual::Kind::Point => {
            Light::Point { position, colour, intensity, attenuation: Attenuation::InverseSquare }
        }
        gltf::khr_lights_punctual::Kind::Directional => Light::Directional { direction, colour, intensity },
        gltf::khr_lights_punctual::Kind::Spot { inner_cone_angle, outer_cone_angle } => {
            if !(0.0 <= inner_cone_angle && inner_cone_angle <= outer_cone_angle && outer_cone_angle <= PI / 2.0) {
                return Err(FormatError::malformed(
                    path,
                    place,
                    format!(
                        "spot cone angles need 0 <= innerConeAngle ({inner_cone_angle}) <= outerConeAngle \
                         ({outer_cone_angle}) <= π/2"
                    ),
                ));
            }
            let (inner_deg, outer_deg) = smoothstep_cone(inner_cone_angle, outer_cone_angle);
            Light::Spot {
                position,
                direction,
                inner_deg,
                outer_deg,
                colour,
                intensity,
                attenuation: Attenuation::InverseSquare,
                falloff: glint_scene::SpotFalloff::Smoothstep,
            }
        }
    })
}

/// KHR_lights_punctual's recommended spot falloff at the cosine `cos` of the angle off the
/// axis: `saturate((cos − cos_outer) / max(0.001, cos_inner − cos_outer))²`.
pub(super) fn gltf_spot_falloff(cos: f32, cos_inner: f32, cos_outer: f32) -> f32 {
    let x = ((cos - cos_outer) / (cos_inner - cos_outer).max(1e-3)).clamp(0.0, 1.0);
    x * x
}

/// glint's spot cone (inner and outer angles in degrees, smoothstep between) closest to glTF's
/// falloff for the cone `inner..outer` (radians): the largest difference over every angle is
/// minimised on a grid. In x = (cos − cos_outer)/(cos_inner − cos_outer) glTF's curve is x² on
/// [0, 1]; glint's is the smoothstep of (x − x0)/(x1 − x0), with x1 kept where the cosine is at
/// most 1 and x0 where it is at least −1.
pub(super) fn smoothstep_cone(inner: f32, outer: f32) -> (f32, f32) {
    let (cos_inner, cos_outer) = (inner.cos(), outer.cos());
    let span = cos_inner - cos_outer;
    if span < 1e-4 {
        return (inner.to_degrees(), outer.to_degrees());
    }
    let cos_at = |x: f32| cos_outer + x * span;
    let x_max = (1.0 - cos_outer) / span;
    let x_min = (-1.0 - cos_outer) / span;
    let samples: Vec<f32> =
        (0..=64).map(|k| x_min.max(-0.5) + (x_max.min(1.5) - x_min.max(-0.5)) * k as f32 / 64.0).collect();
    let angle = |x: f32| cos_at(x).clamp(-1.0, 1.0).acos().to_degrees();
    let error = |x0: f32, x1: f32| {
        let (inner_deg, outer_deg) = (angle(x1), angle(x0));
        samples
            .iter()
            .map(|&x| {
                (spot_falloff(cos_at(x), inner_deg, outer_deg) - gltf_spot_falloff(cos_at(x), cos_inner, cos_outer))
                    .abs()
            })
            .fold(0.0f32, f32::max)
    };
    let mut best = (f32::INFINITY, 0.0, 1.0);
    for i in 0..=100 {
        let x0 = (-0.3 + 0.01 * i as f32).max(x_min);
        for j in 0..=60 {
            let x1 = (0.8 + 0.01 * j as f32).min(x_max);
            if x1 <= x0 {
                continue;
            }
            let e = error(x0, x1);
            if e < best.0 {
                best = (e, x0, x1);
            }
        }
    }
    (angle(best.2), angle(best.1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fitted_cone_follows_gltf_falloff() {
        for (inner_deg, outer_deg, tolerance) in
            [(0.0f32, 45.0f32, 0.15), (20.0, 30.0, 0.07), (10.0, 60.0, 0.13), (30.0, 30.0, 1e-6)]
        {
            let (inner, outer) = (inner_deg.to_radians(), outer_deg.to_radians());
            let (gi, go) = smoothstep_cone(inner, outer);
            assert!(0.0 <= gi && gi <= go && go <= 180.0, "{gi} {go}");
            let mut worst = 0.0f32;
            for k in 0..=900 {
                let angle = (k as f32 * 0.1).to_radians();
                if inner == outer && (angle - outer).abs() < 0.01 {
                    continue; // a hard edge: glTF's ramps over 0.001 in the cosine, glint's jumps
                }
                let want = gltf_spot_falloff(angle.cos(), inner.cos(), outer.cos());
                worst = worst.max((spot_falloff(angle.cos(), gi, go) - want).abs());
            }
            assert!(worst <= tolerance, "cone {inner_deg}..{outer_deg}: worst difference {worst}");
        }
    }
}
