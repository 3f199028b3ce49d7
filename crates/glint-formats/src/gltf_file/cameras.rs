//! glTF cameras → glint's [`Camera`]: the camera's node gives the position (its origin), the
//! view direction (its −Z) and up (its +Y).
//!
//! A perspective camera keeps its vertical field of view; its aspectRatio, when given, sets
//! the default image size (720 rows, the width to match). An orthographic camera keeps its
//! half height `ymag` (the width follows the image, whose default aspect is xmag / ymag).
//! znear and zfar are not used (glint does not clip).

use crate::error::FormatError;
use glint_core::{Mat4, Vec3};
use glint_scene::{Camera, Fov, Lens, ViewSize};
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
pub(super) fn convert_camera(path: &Path, chosen: &NodeCamera) -> Result<(Camera, Option<f32>), FormatError> {
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
            Ok((Camera { position, forward, up, fov: Fov::Vertical(fov), lens: Lens::Pinhole }, aspect))
        }
        Projection::Orthographic { xmag, ymag } => {
            let (xmag, ymag) = (xmag.abs(), ymag.abs());
            if !(xmag.is_finite() && ymag.is_finite() && xmag > 0.0 && ymag > 0.0) {
                return Err(FormatError::malformed(path, place, "xmag and ymag must be finite and non-zero"));
            }
            let lens = Lens::Orthographic(ViewSize::HalfHeight(ymag));
            Ok((Camera { position, forward, up, fov: Fov::Vertical(45.0), lens }, Some(xmag / ymag)))
        }
    }
}
