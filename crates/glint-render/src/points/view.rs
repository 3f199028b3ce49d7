//! The per-frame view of the point clouds: the camera as a projection to pixels, and each
//! cloud's transform to camera space.
//!
//! Camera space: x right, y down (image rows), z forward along the view axis, so a point at
//! camera-space c lands on pixel `centre + focal · (c.x, c.y) / c.z` and its depth is c.z — the
//! linear eye depth of every AOV.

use super::prepared::PreparedPoints;
use glint_core::{Affine3A, Mat3, Vec2, Vec3};
use glint_scene::Camera;

#[derive(Clone, Copy, Debug)]
pub struct View {
    pub width: u32,
    pub height: u32,
    pub width_f: f32,
    pub height_f: f32,
    /// Focal length in pixels.
    pub focal: f32,
    /// Image centre in pixels.
    pub centre: Vec2,
    pub eye: Vec3,
    pub right: Vec3,
    pub down: Vec3,
    pub forward: Vec3,
    /// Points nearer than this (camera units) are clipped.
    pub near: f32,
}

impl View {
    pub fn new(camera: &Camera, width: u32, height: u32) -> View {
        let rays = camera.rays(width, height);
        let forward = rays.forward;
        let right = forward.cross(camera.up).normalize_or(Vec3::X);
        let down = forward.cross(right);
        View {
            width,
            height,
            width_f: width as f32,
            height_f: height as f32,
            focal: rays.focal_pixels,
            centre: Vec2::new(width as f32 * 0.5, height as f32 * 0.5),
            eye: camera.position,
            right,
            down,
            forward,
            near: 1e-6,
        }
    }

    pub fn camera_from_world(&self) -> Affine3A {
        let rotation = Mat3::from_cols(self.right, self.down, self.forward).transpose();
        Affine3A::from_mat3_translation(rotation, -(rotation * self.eye))
    }

    /// World direction (not normalised) of the view ray through image position `p` (pixels),
    /// scaled so that its component along the view axis is 1: `eye + dir · z` is the point of
    /// eye depth z.
    #[inline]
    pub fn ray_at_depth_one(&self, p: Vec2) -> Vec3 {
        let q = (p - self.centre) / self.focal;
        self.forward + self.right * q.x + self.down * q.y
    }

    /// Camera-space direction through image position `p`, z = 1.
    #[inline]
    pub fn camera_ray(&self, p: Vec2) -> Vec3 {
        let q = (p - self.centre) / self.focal;
        Vec3::new(q.x, q.y, 1.0)
    }

    /// World vector of a camera-space vector.
    #[inline]
    pub fn world_from_camera(&self, v: Vec3) -> Vec3 {
        self.right * v.x + self.down * v.y + self.forward * v.z
    }
}

/// One cloud as this frame sees it.
#[derive(Clone, Copy, Debug)]
pub struct CloudView {
    pub start: u32,
    pub end: u32,
    pub camera_from_object: Affine3A,
    /// Object-space normals → camera space (not normalised).
    pub camera_normal_from_object: Mat3,
    /// The eye in object space (for back-face culling there).
    pub eye_object: Vec3,
    pub radius_scale: f32,
    pub material: u32,
    pub cull: bool,
    pub has_normals: bool,
}

pub fn cloud_views(points: &PreparedPoints, view: &View, cull: bool) -> Vec<CloudView> {
    let camera_from_world = view.camera_from_world();
    points
        .clouds
        .iter()
        .map(|c| CloudView {
            start: c.start,
            end: c.end,
            camera_from_object: camera_from_world * c.world_from_object,
            camera_normal_from_object: Mat3::from(camera_from_world.matrix3) * c.world_normal_from_object,
            eye_object: c.world_from_object.inverse().transform_point3(view.eye),
            radius_scale: c.radius_scale,
            material: c.material,
            cull: cull && c.oriented,
            has_normals: c.has_normals,
        })
        .collect()
}

/// The view of the cloud point `index` belongs to.
#[inline]
pub fn cloud_for(clouds: &[CloudView], index: u32) -> &CloudView {
    // Scenes hold few clouds: a linear scan beats a search.
    clouds.iter().find(|c| index < c.end).unwrap_or(&clouds[clouds.len() - 1])
}
