//! Camera control for the viewer: fly (WASD + mouse look, as in a game or Blender's walk mode)
//! and orbit (drag to turn around a target, scroll to zoom, as in Blender's viewport and point
//! cloud viewers). The controller owns yaw/pitch angles so that looking around never rolls the
//! camera, and derives every speed from the size of the scene, so a 2 m bunny and a 1 km LiDAR
//! tile both move at a sensible pace.
//!
//! Angles: yaw 0 looks along −Z (glint's default view), positive yaw turns right (toward +X);
//! pitch is the elevation above the horizon, kept within ±`MAX_PITCH`.

use glint_core::{Bounds3, Vec2, Vec3};
use glint_scene::{Camera, Fov};

/// Largest |pitch|: just short of straight up or down, where "up" would be undefined.
pub const MAX_PITCH: f32 = 89.0 * std::f32::consts::PI / 180.0;
/// Radians of turn per pixel of mouse motion.
pub const LOOK_PER_PIXEL: f32 = 0.003;
/// Distance factor per scroll notch in orbit mode.
pub const ZOOM_PER_NOTCH: f32 = 1.1;
/// Fly speed, in scene diagonals per second.
pub const DIAGONALS_PER_SECOND: f32 = 0.25;
/// Factor of the fly speed while the "fast" key is held.
pub const FAST_FACTOR: f32 = 4.0;

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ControlMode {
    /// Move with WASD (+ up/down), turn with the mouse.
    #[default]
    Fly,
    /// Turn around `target` by dragging, zoom by scrolling (and W/S).
    Orbit,
}

/// What the user is doing during one frame: keys held and mouse motion since the last frame.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InputState {
    pub forward: bool,
    pub back: bool,
    pub left: bool,
    pub right: bool,
    pub up: bool,
    pub down: bool,
    /// Move faster (shift).
    pub fast: bool,
    /// Mouse motion in pixels (x right, y down) while looking (fly) or dragging (orbit).
    pub look: Vec2,
    /// Scroll notches (positive: zoom in).
    pub scroll: f32,
}

impl InputState {
    /// Nothing is pressed and the mouse rests: the picture may refine.
    pub fn is_idle(&self) -> bool {
        *self == InputState::default()
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraController {
    pub mode: ControlMode,
    pub position: Vec3,
    pub yaw: f32,
    pub pitch: f32,
    /// Orbit centre.
    pub target: Vec3,
    /// Fly speed in scene units per second.
    pub speed: f32,
    pub fov: Fov,
    /// The scene camera's lens, kept as the camera moves.
    pub lens: glint_scene::Lens,
}

/// Unit view direction for yaw and pitch.
pub fn direction(yaw: f32, pitch: f32) -> Vec3 {
    let (sy, cy) = yaw.sin_cos();
    let (sp, cp) = pitch.sin_cos();
    Vec3::new(sy * cp, sp, -cy * cp)
}

impl CameraController {
    /// Start from `camera` (the scene's, framed on its content) in a scene of `bounds`. The orbit
    /// target is the bounds' centre when the camera looks at it roughly, else the point in front
    /// of the camera at the centre's distance.
    pub fn new(camera: &Camera, bounds: Bounds3, mode: ControlMode) -> Self {
        let forward = camera.forward.normalize_or(Vec3::NEG_Z);
        let pitch = forward.y.clamp(-1.0, 1.0).asin().clamp(-MAX_PITCH, MAX_PITCH);
        let yaw = forward.x.atan2(-forward.z);
        let (centre, diagonal) = if bounds.is_empty() || !bounds.diagonal_length().is_finite() {
            (camera.position + forward, 1.0)
        } else {
            (bounds.centre(), bounds.diagonal_length().max(1e-6))
        };
        let to_centre = centre - camera.position;
        let target = if to_centre.normalize_or_zero().dot(forward) > 0.95 {
            centre
        } else {
            camera.position + forward * to_centre.length().max(0.1 * diagonal)
        };
        Self {
            mode,
            position: camera.position,
            yaw,
            pitch,
            target,
            speed: DIAGONALS_PER_SECOND * diagonal,
            fov: camera.fov,
            lens: camera.lens,
        }
    }

    pub fn forward(&self) -> Vec3 {
        direction(self.yaw, self.pitch)
    }

    /// Horizontal right vector (never tilted: the camera does not roll).
    pub fn right(&self) -> Vec3 {
        let (s, c) = self.yaw.sin_cos();
        Vec3::new(c, 0.0, s)
    }

    pub fn camera(&self) -> Camera {
        Camera { position: self.position, forward: self.forward(), up: Vec3::Y, fov: self.fov, lens: self.lens }
    }

    /// Switch between fly and orbit; orbiting starts around the point the camera looks at.
    pub fn set_mode(&mut self, mode: ControlMode) {
        if mode == ControlMode::Orbit && self.mode != mode {
            let d = (self.target - self.position).length();
            self.target = self.position + self.forward() * d.max(self.speed * 0.1);
        }
        self.mode = mode;
    }

    /// Apply one frame of input over `dt` seconds; true when the camera moved (the viewer then
    /// restarts refinement).
    pub fn update(&mut self, input: &InputState, dt: f32) -> bool {
        if input.is_idle() || !(dt.is_finite() && dt >= 0.0) {
            return false;
        }
        let before = *self;
        let turn = input.look * LOOK_PER_PIXEL;
        let axis = |pos: bool, neg: bool| f32::from(u8::from(pos)) - f32::from(u8::from(neg));
        let step = self.speed * dt * if input.fast { FAST_FACTOR } else { 1.0 };
        match self.mode {
            ControlMode::Fly => {
                self.yaw += turn.x;
                self.pitch = (self.pitch - turn.y).clamp(-MAX_PITCH, MAX_PITCH);
                let (f, r) = (self.forward(), self.right());
                let mv = f * axis(input.forward, input.back)
                    + r * axis(input.right, input.left)
                    + Vec3::Y * axis(input.up, input.down);
                self.position += mv.normalize_or_zero() * step;
                self.target += mv.normalize_or_zero() * step;
            }
            ControlMode::Orbit => {
                self.yaw += turn.x;
                self.pitch = (self.pitch - turn.y).clamp(-MAX_PITCH, MAX_PITCH);
                let mut distance = (self.target - self.position).length().max(1e-6);
                distance /= ZOOM_PER_NOTCH.powf(input.scroll);
                // W/S dolly toward and away from the target, never through it.
                distance = (distance - step * axis(input.forward, input.back)).max(self.speed * 1e-3);
                self.yaw += axis(input.right, input.left) * dt;
                self.position = self.target - self.forward() * distance;
            }
        }
        *self != before
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).length() < 1e-5
    }

    fn framed() -> (Camera, Bounds3) {
        let bounds = Bounds3::new(Vec3::splat(-1.0), Vec3::splat(1.0));
        (Camera { position: Vec3::new(0.0, 0.0, 5.0), ..Camera::default() }, bounds)
    }

    #[test]
    fn the_scene_camera_comes_back_unchanged() {
        for forward in
            [Vec3::NEG_Z, Vec3::X, Vec3::new(0.3, -0.4, 0.5).normalize(), Vec3::new(-1.0, 0.2, 0.1).normalize()]
        {
            let cam = Camera { forward, ..Camera::default() };
            let c = CameraController::new(&cam, Bounds3::EMPTY, ControlMode::Fly);
            assert!(close(c.camera().forward, forward), "{forward} -> {}", c.camera().forward);
            assert_eq!(c.camera().position, cam.position);
        }
        assert!(close(direction(0.0, 0.0), Vec3::NEG_Z));
        assert!(direction(0.5, 0.0).x > 0.0, "positive yaw turns toward +X");
    }

    #[test]
    fn speed_and_target_follow_the_scene() {
        let (cam, bounds) = framed();
        let c = CameraController::new(&cam, bounds, ControlMode::Orbit);
        assert!((c.speed - DIAGONALS_PER_SECOND * 12f32.sqrt()).abs() < 1e-5);
        assert_eq!(c.target, Vec3::ZERO);
        // A tile a thousand times larger moves a thousand times faster.
        let big = Bounds3::new(Vec3::splat(-1000.0), Vec3::splat(1000.0));
        let b = CameraController::new(&Camera { position: Vec3::new(0.0, 0.0, 5000.0), ..cam }, big, ControlMode::Fly);
        assert!((b.speed / c.speed - 1000.0).abs() < 1e-2);
    }

    #[test]
    fn flying_moves_along_the_view_and_looking_turns_without_roll() {
        let (cam, bounds) = framed();
        let mut c = CameraController::new(&cam, bounds, ControlMode::Fly);
        assert!(!c.update(&InputState::default(), 0.1), "idle input does not move");
        let start = c.position;
        assert!(c.update(&InputState { forward: true, ..InputState::default() }, 0.5));
        assert!(close(c.position, start + Vec3::NEG_Z * c.speed * 0.5));
        c.update(&InputState { forward: true, fast: true, ..InputState::default() }, 0.5);
        assert!(close(c.position, start + Vec3::NEG_Z * c.speed * 0.5 * (1.0 + FAST_FACTOR)));
        // Mouse right: the view turns right; mouse up: it looks up; never past the zenith.
        c.update(&InputState { look: Vec2::new(100.0, 0.0), ..InputState::default() }, 0.0);
        assert!(c.forward().x > 0.25);
        c.update(&InputState { look: Vec2::new(0.0, -100_000.0), ..InputState::default() }, 0.0);
        assert!((c.pitch - MAX_PITCH).abs() < 1e-6);
        let cam = c.camera();
        assert!(cam.forward.cross(cam.up).length() > 1e-3, "up never parallel to the view");
        assert_eq!(c.right().y, 0.0, "no roll");
        // Strafing is horizontal and perpendicular to the view.
        let p = c.position;
        c.update(&InputState { right: true, ..InputState::default() }, 1.0);
        assert!(((c.position - p).dot(c.forward())).abs() < 1e-4 && (c.position - p).y.abs() < 1e-6);
    }

    #[test]
    fn orbiting_keeps_the_target_in_view_at_its_distance() {
        let (cam, bounds) = framed();
        let mut c = CameraController::new(&cam, bounds, ControlMode::Orbit);
        c.update(&InputState { look: Vec2::new(300.0, -120.0), ..InputState::default() }, 0.016);
        assert!(((c.position - c.target).length() - 5.0).abs() < 1e-4);
        assert!(close(c.forward(), (c.target - c.position).normalize()));
        // Scrolling in zooms by ZOOM_PER_NOTCH per notch; dollying never passes the target.
        c.update(&InputState { scroll: 2.0, ..InputState::default() }, 0.016);
        assert!(((c.position - c.target).length() - 5.0 / ZOOM_PER_NOTCH.powi(2)).abs() < 1e-4);
        c.update(&InputState { forward: true, ..InputState::default() }, 1000.0);
        assert!((c.position - c.target).length() > 0.0);
        assert!(close(c.forward(), (c.target - c.position).normalize()));
    }

    #[test]
    fn switching_to_orbit_turns_around_the_point_in_view() {
        let (cam, bounds) = framed();
        let mut c = CameraController::new(&cam, bounds, ControlMode::Fly);
        c.update(&InputState { look: Vec2::new(400.0, 0.0), ..InputState::default() }, 0.0);
        c.set_mode(ControlMode::Orbit);
        let before = c.position;
        assert!(close((c.target - c.position).normalize(), c.forward()));
        c.update(&InputState { scroll: 0.0, look: Vec2::new(1.0, 0.0), ..InputState::default() }, 0.0);
        assert!((c.position - before).length() > 0.0);
        // Bad time steps are ignored.
        let still = c;
        assert!(!c.update(&InputState { forward: true, ..InputState::default() }, f32::NAN));
        assert_eq!(c, still);
    }
}
