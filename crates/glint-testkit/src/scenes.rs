//! Small scenes with a known content.

use glint_core::{Affine3A, Rgb, Vec3};
use glint_scene::{Camera, CloudObject, Light, Material, Object, Orientation, PointCloud, Scene, Shape, Sky};
use std::sync::Arc;

/// A 64 × 63 grid of oriented points (a square 1.9 wide in the plane z = 0, facing +Z) beside
/// a sphere of radius 0.3 in front of its corner, lit by a directional light along −Z, seen
/// from z = 4: content for every mode (the sphere for the ray tracers, the grid for the
/// points mode, both for the points mode's depth composite).
#[must_use]
pub fn cloud_and_sphere() -> Scene {
    let positions: Vec<Vec3> =
        (0..4000).map(|i| Vec3::new((i % 64) as f32 * 0.03 - 1.0, (i / 64) as f32 * 0.03 - 1.0, 0.0)).collect();
    let n = positions.len();
    let cloud = PointCloud {
        name: "grid".into(),
        positions,
        normals: Some(vec![Vec3::Z; n]),
        radii: Some(vec![0.03; n]),
        orientation: Orientation::Oriented,
        ..PointCloud::default()
    };
    Scene {
        camera: Camera { position: Vec3::new(0.0, 0.0, 4.0), ..Camera::default() },
        sky: Sky::Colour(Rgb::new(0.1, 0.2, 0.4)),
        ambient: Rgb::splat(0.1),
        materials: vec![Material::default()],
        lights: vec![Light::Directional { direction: Vec3::NEG_Z, colour: Rgb::ONE, intensity: 1.0 }],
        objects: vec![Object {
            name: "ball".into(),
            shape: Shape::Sphere { centre: Vec3::new(0.8, 0.8, 0.5), radius: 0.3 },
            material: 0,
            world_from_object: Affine3A::IDENTITY,
        }],
        clouds: vec![CloudObject {
            name: "grid".into(),
            cloud: Arc::new(cloud),
            material: 0,
            world_from_object: Affine3A::IDENTITY,
        }],
        ..Scene::default()
    }
}
