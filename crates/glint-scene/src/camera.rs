//! The pinhole camera (DESIGN.md §1): position, forward, up, field of view; aspect from the image.
//! World convention: right-handed, +Y up, the default camera looks along −Z with +X to its right.

use glint_core::{Ray, Vec2, Vec3};

/// Field of view, in degrees, along one image axis (Mitsuba's `fov_axis` names them all): the
/// axis is resolved against the image's aspect when rays are made, so a field of view keeps
/// its meaning at any image size.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fov {
    Vertical(f32),
    Horizontal(f32),
    /// Along the shorter side of the image.
    Smaller(f32),
    /// Along the longer side of the image.
    Larger(f32),
    /// Along the image's diagonal.
    Diagonal(f32),
}

impl Fov {
    /// The angle in degrees, whichever the axis.
    pub fn degrees(&self) -> f32 {
        match *self {
            Fov::Vertical(f) | Fov::Horizontal(f) | Fov::Smaller(f) | Fov::Larger(f) | Fov::Diagonal(f) => f,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Approximate up direction; orthogonalised against `forward` when rays are generated.
    pub up: Vec3,
    pub fov: Fov,
}

impl Default for Camera {
    fn default() -> Self {
        Self { position: Vec3::new(0.0, 0.0, 5.0), forward: -Vec3::Z, up: Vec3::Y, fov: Fov::Vertical(45.0) }
    }
}

impl Camera {
    /// A camera at `position` looking at `target`.
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, fov: Fov) -> Self {
        Self { position, forward: (target - position).normalize_or(-Vec3::Z), up, fov }
    }

    /// Tangent of half the vertical field of view for an image of the given aspect (w / h).
    pub fn tan_half_vertical(&self, aspect: f32) -> f32 {
        let tan = (self.fov.degrees().to_radians() * 0.5).tan();
        match self.fov {
            Fov::Vertical(_) => tan,
            Fov::Horizontal(_) => tan / aspect,
            Fov::Smaller(_) => tan / aspect.min(1.0),
            Fov::Larger(_) => tan / aspect.max(1.0),
            Fov::Diagonal(_) => tan / (1.0 + aspect * aspect).sqrt(),
        }
    }

    /// Precomputed per-frame ray generator for an image of `width × height` pixels.
    pub fn rays(&self, width: u32, height: u32) -> CameraRays {
        let aspect = width as f32 / height as f32;
        let forward = self.forward.normalize_or(-Vec3::Z);
        let right = forward.cross(self.up).normalize_or(Vec3::X);
        let up = right.cross(forward);
        let tan_v = self.tan_half_vertical(aspect);
        let tan_h = tan_v * aspect;
        CameraRays {
            origin: self.position,
            forward,
            right_step: right * (2.0 * tan_h / width as f32),
            down_step: -up * (2.0 * tan_v / height as f32),
            top_left: forward - right * tan_h + up * tan_v,
            focal_pixels: height as f32 / (2.0 * tan_v),
        }
    }
}

/// Rays through continuous image positions; pixel `(x, y)` covers `[x, x+1) × [y, y+1)`,
/// y growing downwards.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    pub origin: Vec3,
    pub forward: Vec3,
    right_step: Vec3,
    down_step: Vec3,
    top_left: Vec3,
    /// Focal length in pixels (for projecting world sizes to pixels).
    pub focal_pixels: f32,
}

impl CameraRays {
    /// The primary ray through image position `p` (in pixels). The direction is unit length.
    #[inline]
    pub fn ray(&self, p: Vec2) -> Ray {
        let dir = (self.top_left + self.right_step * p.x + self.down_step * p.y).normalize();
        Ray::new(self.origin, dir)
    }

    /// The image plane as [`CameraRays::ray`] uses it: the direction toward pixel position
    /// (x, y) is `top_left + right_step·x + down_step·y`, normalised.
    #[must_use]
    pub fn image_plane(&self) -> (Vec3, Vec3, Vec3) {
        (self.top_left, self.right_step, self.down_step)
    }

    /// Linear eye-space depth (distance along the view axis) of a world point.
    #[inline]
    pub fn depth(&self, p: Vec3) -> f32 {
        (p - self.origin).dot(self.forward)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_forward_and_right_is_plus_x() {
        let cam = Camera::default();
        let rays = cam.rays(100, 50);
        let c = rays.ray(Vec2::new(50.0, 25.0));
        assert!((c.dir - -Vec3::Z).length() < 1e-6);
        let r = rays.ray(Vec2::new(99.0, 25.0));
        assert!(r.dir.x > 0.0);
        let t = rays.ray(Vec2::new(50.0, 0.0));
        assert!(t.dir.y > 0.0);
    }

    #[test]
    fn horizontal_fov_spans_the_width() {
        let cam = Camera { fov: Fov::Horizontal(90.0), ..Camera::default() };
        let rays = cam.rays(200, 100);
        let edge = rays.ray(Vec2::new(200.0, 50.0));
        // 45° to the right of forward at the right edge.
        assert!((edge.dir.x - edge.dir.z.abs()).abs() < 1e-5);
    }

    #[test]
    fn every_fov_axis_resolves_against_the_aspect() {
        let tan = (40f32.to_radians() * 0.5).tan();
        let v = |fov: Fov, aspect: f32| Camera { fov, ..Camera::default() }.tan_half_vertical(aspect);
        for aspect in [0.5f32, 1.0, 16.0 / 9.0] {
            let (h, w) = (v(Fov::Vertical(40.0), aspect), v(Fov::Horizontal(40.0), aspect) * aspect);
            assert!((h - tan).abs() < 1e-6 && (w - tan).abs() < 1e-6);
            let smaller = v(Fov::Smaller(40.0), aspect);
            let larger = v(Fov::Larger(40.0), aspect);
            // The named side spans the angle: the shorter one for Smaller, the longer for Larger.
            assert!((smaller * aspect.min(1.0) - tan).abs() < 1e-6, "{aspect}");
            assert!((larger * aspect.max(1.0) - tan).abs() < 1e-6, "{aspect}");
            let d = v(Fov::Diagonal(40.0), aspect);
            assert!(((d * d + (d * aspect).powi(2)).sqrt() - tan).abs() < 1e-6, "{aspect}");
        }
    }
}
