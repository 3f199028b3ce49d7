//! The camera (DESIGN.md §1): position, forward, up, field of view, aspect from the image; a
//! pinhole by default, or a thin lens (depth of field) or an orthographic projection ([`Lens`]).
//! World convention: right-handed, +Y up, the default camera looks along −Z with +X to its right.

use glint_core::sampling::sample_disc_concentric;
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

/// Half an orthographic view's extent in world units along one image axis; the other axis
/// follows the image's aspect (as a [`Fov`] does for angles).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ViewSize {
    HalfWidth(f32),
    HalfHeight(f32),
}

/// How the camera turns image positions into rays.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Lens {
    /// Every ray leaves the camera's position (the field of view sets the image plane).
    #[default]
    Pinhole,
    /// A thin lens of radius `aperture_radius` (world units) focused on the plane
    /// `focus_distance` ahead along the view axis: rays leave a point of the lens and pass
    /// through the point of the focal plane the pinhole ray through the same image position
    /// would reach (Mitsuba's `thinlens`, pbrt's `PerspectiveCamera` with a lens), so points on
    /// that plane are sharp and others blur with their distance from it.
    ThinLens { aperture_radius: f32, focus_distance: f32 },
    /// Parallel rays along the view axis from the plane through the camera's position; the
    /// field of view is not used.
    Orthographic(ViewSize),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: Vec3,
    /// Unit view direction.
    pub forward: Vec3,
    /// Approximate up direction; orthogonalised against `forward` when rays are generated.
    pub up: Vec3,
    pub fov: Fov,
    pub lens: Lens,
}

impl Default for Camera {
    fn default() -> Self {
        Self {
            position: Vec3::new(0.0, 0.0, 5.0),
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(45.0),
            lens: Lens::Pinhole,
        }
    }
}

impl Camera {
    /// A camera at `position` looking at `target`.
    pub fn look_at(position: Vec3, target: Vec3, up: Vec3, fov: Fov) -> Self {
        Self { position, forward: (target - position).normalize_or(-Vec3::Z), up, fov, lens: Lens::Pinhole }
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
        let (half_h, half_v, plane_centre, focal_pixels) = match self.lens {
            Lens::Orthographic(size) => {
                let half_v = match size {
                    ViewSize::HalfHeight(h) => h,
                    ViewSize::HalfWidth(w) => w / aspect,
                };
                // Rays are parallel: a pixel subtends no angle (sky lookups read the finest level).
                (half_v * aspect, half_v, Vec3::ZERO, f32::INFINITY)
            }
            Lens::Pinhole | Lens::ThinLens { .. } => {
                let tan_v = self.tan_half_vertical(aspect);
                (tan_v * aspect, tan_v, forward, height as f32 / (2.0 * tan_v))
            }
        };
        let kind = match self.lens {
            Lens::Pinhole => RayKind::Pinhole,
            Lens::ThinLens { aperture_radius, focus_distance } => {
                RayKind::ThinLens { lens_right: right * aperture_radius, lens_up: up * aperture_radius, focus_distance }
            }
            Lens::Orthographic(_) => RayKind::Orthographic,
        };
        CameraRays {
            origin: self.position,
            forward,
            right_step: right * (2.0 * half_h / width as f32),
            down_step: -up * (2.0 * half_v / height as f32),
            top_left: plane_centre - right * half_h + up * half_v,
            focal_pixels,
            kind,
        }
    }
}

/// [`Lens`] as [`CameraRays`] uses it.
#[derive(Clone, Copy, Debug, PartialEq)]
enum RayKind {
    /// `top_left`, `right_step`, `down_step` span the image plane at distance 1, as directions.
    Pinhole,
    /// As `Pinhole`, and the lens's half axes in world units.
    ThinLens { lens_right: Vec3, lens_up: Vec3, focus_distance: f32 },
    /// `top_left`, `right_step`, `down_step` span the view rectangle as offsets from `origin`.
    Orthographic,
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
    /// Focal length in pixels (for projecting world sizes to pixels); infinite for an
    /// orthographic camera.
    pub focal_pixels: f32,
    kind: RayKind,
}

impl CameraRays {
    /// The primary ray through image position `p` (in pixels); through the lens's centre for a
    /// thin lens. The direction is unit length.
    #[inline]
    pub fn ray(&self, p: Vec2) -> Ray {
        let q = self.top_left + self.right_step * p.x + self.down_step * p.y;
        match self.kind {
            RayKind::Orthographic => Ray::new(self.origin + q, self.forward),
            RayKind::Pinhole | RayKind::ThinLens { .. } => Ray::new(self.origin, q.normalize()),
        }
    }

    /// Does a ray need a lens sample ([`CameraRays::ray_through_lens`])? Only a thin lens's do.
    #[inline]
    pub fn samples_lens(&self) -> bool {
        matches!(self.kind, RayKind::ThinLens { .. })
    }

    /// The ray through image position `p` and the point of the lens that `u` ∈ [0,1)² maps
    /// to (concentric disc); [`CameraRays::ray`] for the cameras without a lens.
    #[inline]
    pub fn ray_through_lens(&self, p: Vec2, u: Vec2) -> Ray {
        let RayKind::ThinLens { lens_right, lens_up, focus_distance } = self.kind else { return self.ray(p) };
        let through = self.top_left + self.right_step * p.x + self.down_step * p.y;
        // `through` has unit length along the view axis, so this is the focal plane's point.
        let focus = self.origin + through * focus_distance;
        let d = sample_disc_concentric(u);
        let on_lens = self.origin + lens_right * d.x + lens_up * d.y;
        Ray::new(on_lens, (focus - on_lens).normalize_or(self.forward))
    }

    /// The image plane of a pinhole camera: the direction toward pixel position (x, y) is
    /// `top_left + right_step·x + down_step·y`, normalised. `None` for the other cameras
    /// (their rays do not all leave one point).
    #[must_use]
    pub fn image_plane(&self) -> Option<(Vec3, Vec3, Vec3)> {
        (self.kind == RayKind::Pinhole).then_some((self.top_left, self.right_step, self.down_step))
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
    fn an_orthographic_camera_casts_parallel_rays_over_its_view_size() {
        let cam = Camera { lens: Lens::Orthographic(ViewSize::HalfWidth(2.0)), ..Camera::default() };
        let rays = cam.rays(200, 100);
        let top_left = rays.ray(Vec2::ZERO);
        let bottom_right = rays.ray(Vec2::new(200.0, 100.0));
        assert_eq!(top_left.dir, -Vec3::Z);
        assert_eq!(bottom_right.dir, -Vec3::Z);
        // Half width 2 → 4 units across; the height follows the 2:1 aspect.
        assert!((top_left.origin - Vec3::new(-2.0, 1.0, 5.0)).length() < 1e-6, "{:?}", top_left.origin);
        assert!((bottom_right.origin - Vec3::new(2.0, -1.0, 5.0)).length() < 1e-6);
        assert!(rays.image_plane().is_none() && !rays.samples_lens());
        let tall = Camera { lens: Lens::Orthographic(ViewSize::HalfHeight(3.0)), ..Camera::default() }.rays(100, 100);
        assert!((tall.ray(Vec2::new(100.0, 0.0)).origin - Vec3::new(3.0, 3.0, 5.0)).length() < 1e-6);
    }

    #[test]
    fn a_thin_lens_focuses_its_plane_and_blurs_the_rest() {
        let lens = Lens::ThinLens { aperture_radius: 0.5, focus_distance: 4.0 };
        let cam = Camera { lens, ..Camera::default() };
        let rays = cam.rays(64, 48);
        assert!(rays.samples_lens() && rays.image_plane().is_none());
        let p = Vec2::new(40.3, 11.7);
        let pinhole = rays.ray(p);
        // Where a ray meets the plane z = `z`.
        let at_z = |r: Ray, z: f32| r.at((r.origin.z - z) / -r.dir.z);
        let mut far = Vec::new();
        for u in [Vec2::new(0.1, 0.2), Vec2::new(0.9, 0.5), Vec2::new(0.5, 0.95), Vec2::new(0.3, 0.7)] {
            let r = rays.ray_through_lens(p, u);
            // Leaves the lens disc (radius 0.5 in the camera's plane) ...
            assert!((r.origin - cam.position).length() <= 0.5 + 1e-5 && (r.origin.z - 5.0).abs() < 1e-6);
            // ... and meets the pinhole ray on the focal plane, 4 units ahead (z = 1).
            let (a, b) = (at_z(r, 1.0), at_z(pinhole, 1.0));
            assert!((a - b).length() < 1e-4, "{a} vs {b}");
            far.push(at_z(r, -3.0));
        }
        // Off the plane the rays part: 8 units ahead, twice the focus distance, by up to a
        // lens diameter.
        assert!((far[0] - far[1]).length() > 0.2, "{far:?}");
        // The lens's centre is the pinhole ray.
        let centre = rays.ray_through_lens(p, Vec2::splat(0.5));
        assert!((centre.dir - pinhole.dir).length() < 1e-6 && centre.origin == cam.position);
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
