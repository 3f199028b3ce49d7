//! glTF cameras → glint's pinhole [`Camera`]: the camera's node gives the position (its
//! origin), the view direction (its −Z) and up (its +Y).
//!
//! A perspective camera keeps its vertical field of view; its aspectRatio, when given, sets
//! the default image size (720 rows, the width to match); znear and zfar are not used (glint
//! does not clip). glint has no orthographic projection: an orthographic camera is an error,
//! or, when loading leniently, a warning and a perspective camera at its place whose field of
//! view spans the orthographic view's height (2·ymag) at the distance of the scene's centre.

use crate::error::FormatError;
use crate::model::file_name;
use glint_core::{Bounds3, Mat4, Vec3};
use glint_scene::{Camera, Fov};
use std::path::Path;

/// A camera met in the node walk.
pub(super) struct NodeCamera {
    pub node: usize,
    pub node_name: Option<String>,
    pub camera: usize,
    pub name: Option<String>,
    pub world_from_node: Mat4,
    pub projection: Projection,
}

/// A glTF camera's projection, as read.
#[derive(Clone, Copy, Debug)]
pub(super) enum Projection {
    Perspective { yfov: f32, aspect_ratio: Option<f32> },
    Orthographic { xmag: f32, ymag: f32 },
}

impl Projection {
    pub(super) fn of(camera: &gltf::Camera) -> Self {
        match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                Projection::Perspective { yfov: p.yfov(), aspect_ratio: p.aspect_ratio() }
            }
            gltf::camera::Projection::Orthographic(o) => Projection::Orthographic { xmag: o.xmag(), ymag: o.ymag() },
        }
    }
}

/// The camera to use: the one named `name` (a camera's name, else a node's), or else the
/// first met. `None` when the file has none (and no name was asked for).
pub(super) fn choose<'c>(
    path: &Path,
    cameras: &'c [NodeCamera],
    name: Option<&str>,
) -> Result<Option<&'c NodeCamera>, FormatError> {
    let Some(name) = name else { return Ok(cameras.first()) };
    let found = cameras
        .iter()
        .find(|c| c.name.as_deref() == Some(name))
        .or_else(|| cameras.iter().find(|c| c.node_name.as_deref() == Some(name)));
    match found {
        Some(c) => Ok(Some(c)),
        None => {
            let names: Vec<String> = cameras
                .iter()
                .map(|c| match (&c.name, &c.node_name) {
                    (Some(n), _) => format!("'{n}'"),
                    (None, Some(n)) => format!("'{n}' (node)"),
                    (None, None) => format!("cameras[{}] (unnamed)", c.camera),
                })
                .collect();
            let has = if names.is_empty() { "none".to_string() } else { names.join(", ") };
            Err(FormatError::malformed(
                path,
                "cameras",
                format!("no camera named '{name}' in the scene (it has: {has})"),
            ))
        }
    }
}

/// The glint camera for `chosen` and the image aspect (width / height) the file asks for.
/// `bounds` (the scene's) place the perspective stand-in for an orthographic camera.
pub(super) fn convert_camera(
    path: &Path,
    chosen: &NodeCamera,
    bounds: Bounds3,
    lenient: bool,
    warnings: &mut Vec<String>,
) -> Result<(Camera, Option<f32>), FormatError> {
    let place = format!("cameras[{}] (on nodes[{}])", chosen.camera, chosen.node);
    let world = chosen.world_from_node;
    let position = world.transform_point3(Vec3::ZERO);
    let forward = world.transform_vector3(-Vec3::Z).try_normalize();
    let up = world.transform_vector3(Vec3::Y).try_normalize();
    let (forward, up) = match (position.is_finite(), forward, up) {
        (true, Some(f), Some(u)) if f.cross(u).length_squared() > 1e-12 => (f, u),
        _ => return Err(FormatError::malformed(path, place, "the node's transform is singular or not finite")),
    };
    match chosen.projection {
        Projection::Perspective { yfov, aspect_ratio: aspect } => {
            let fov = yfov.to_degrees();
            if !(fov > 0.0 && fov < 180.0) {
                return Err(FormatError::malformed(path, place, format!("yfov {yfov} must be in (0, π)")));
            }
            if let Some(a) = aspect
                && !(a.is_finite() && a > 0.0)
            {
                return Err(FormatError::malformed(path, place, format!("aspectRatio {a} must be > 0")));
            }
            Ok((Camera { position, forward, up, fov: Fov::Vertical(fov) }, aspect))
        }
        Projection::Orthographic { xmag, ymag } => {
            if !lenient {
                return Err(FormatError::malformed(
                    path,
                    place,
                    "orthographic projection: glint's camera is a pinhole (perspective) camera; load leniently \
                     for a perspective camera in its place, or name another camera",
                ));
            }
            let (xmag, ymag) = (xmag.abs(), ymag.abs());
            if !(xmag.is_finite() && ymag.is_finite() && xmag > 0.0 && ymag > 0.0) {
                return Err(FormatError::malformed(path, place, "xmag and ymag must be finite and non-zero"));
            }
            let distance = if bounds.is_empty() { 0.0 } else { (bounds.centre() - position).dot(forward) };
            let fov = if distance > 1e-3 * ymag { 2.0 * (ymag / distance).atan().to_degrees() } else { 45.0 };
            warnings.push(format!(
                "{}: {place} is orthographic, which glint cannot render: using a perspective camera at its place \
                 with a {fov:.1}° vertical field of view",
                file_name(path)
            ));
            Ok((Camera { position, forward, up, fov: Fov::Vertical(fov) }, Some(xmag / ymag)))
        }
    }
}
