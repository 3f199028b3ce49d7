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
//! **Spot cones.** glTF's recommended falloff, the square of a linear ramp in the cosine from
//! the outer cone (0) to the inner (1), is glint's [`SpotFalloff::SquaredCosine`].

use crate::error::FormatError;
use crate::model::file_name;
use glint_core::{Mat4, Rgb, Vec3};
use glint_scene::{Attenuation, Light, SpotFalloff};
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
            let (inner_deg, outer_deg) = (inner_cone_angle.to_degrees(), outer_cone_angle.to_degrees());
            Light::Spot {
                position,
                direction,
                inner_deg,
                outer_deg,
                colour,
                intensity,
                attenuation: Attenuation::InverseSquare,
                falloff: SpotFalloff::SquaredCosine,
                projection: None,
            }
        }
    })
}
