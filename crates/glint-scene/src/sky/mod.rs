//! What a ray that leaves the scene sees (DESIGN.md §4): a colour, a gradient, a cube map or a
//! lat-long map, looked up by direction only — moving the camera never changes the sky.
//!
//! Maps carry a rotation about +Y and an intensity ([`SkyTransform`]). Lookups come in two
//! kinds: [`Sky::radiance`] (the finest level, bilinear: for light transport) and
//! [`Sky::radiance_filtered`] (trilinear over the mip pyramid for a ray footprint: for what a
//! pixel sees, so a 2048² face in a 640-pixel image does not shimmer). [`IrradianceSh`] turns
//! any sky into the ambient light of a surface with a given normal; [`SkySampler`] draws
//! directions toward it in proportion to its luminance (the sky as a light of the path tracer).

mod cube;
mod lanes;
mod latlong;
mod level;
mod sampling;
mod sh;

pub use cube::{CubeFace, CubeMap, cube_direction, cube_face_st};
use lanes::LANES;
pub use latlong::{LatLongMap, latlong_direction, latlong_uv};
pub use sampling::{SkySample, SkySampler};
pub use sh::IrradianceSh;

use glint_core::{Mat3, Rgb, Vec3};
use std::sync::Arc;

/// Where a map sits: turned by `rotation_degrees` about +Y (counter-clockwise seen from above,
/// so a positive angle moves what was straight ahead to the left), scaled by `intensity`. A
/// transform made by [`SkyTransform::from_rotation`] turns the map by any rotation instead
/// (Mitsuba's `envmap` `to_world`); its `rotation_degrees` is 0 and unused.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyTransform {
    pub rotation_degrees: f32,
    pub intensity: f32,
    cos: f32,
    sin: f32,
    /// A general rotation: (map_from_world, world_from_map), orthonormal.
    rotation: Option<(Mat3, Mat3)>,
}

impl SkyTransform {
    pub fn new(rotation_degrees: f32, intensity: f32) -> Self {
        let (sin, cos) = rotation_degrees.to_radians().sin_cos();
        Self { rotation_degrees, intensity, cos, sin, rotation: None }
    }

    /// A map turned by the rotation `map_from_world` (map-space direction of a world
    /// direction); None unless it is a finite rotation (orthonormal, determinant +1, to 1e-4).
    pub fn from_rotation(map_from_world: Mat3, intensity: f32) -> Option<Self> {
        let m = map_from_world;
        let ortho = (m * m.transpose() - Mat3::IDENTITY).to_cols_array().iter().all(|e| e.abs() < 1e-4);
        if !m.is_finite() || !ortho || (m.determinant() - 1.0).abs() > 1e-4 {
            return None;
        }
        Some(Self { rotation_degrees: 0.0, intensity, cos: 1.0, sin: 0.0, rotation: Some((m, m.transpose())) })
    }

    /// The general rotation (map_from_world), when this transform has one.
    pub fn map_from_world(&self) -> Option<Mat3> {
        self.rotation.map(|r| r.0)
    }

    /// This transform with `--sky-rotation`-style adjustments: `degrees` about +y (replacing a
    /// plain turn; applied on the world side of a general rotation, which it keeps) and the
    /// intensity scaled by `factor`. No adjustment leaves the transform as it is.
    pub fn adjusted(&self, degrees: Option<f32>, factor: f32) -> Self {
        let intensity = self.intensity * factor;
        match (self.rotation, degrees) {
            (None, _) => SkyTransform::new(degrees.unwrap_or(self.rotation_degrees), intensity),
            (Some((m, w)), None) => Self { intensity, rotation: Some((m, w)), ..*self },
            (Some((m, _)), Some(deg)) => {
                let turn = SkyTransform::new(deg, 1.0);
                let turn = Mat3::from_cols(turn.to_map(Vec3::X), turn.to_map(Vec3::Y), turn.to_map(Vec3::Z));
                let m = m * turn;
                Self { rotation_degrees: 0.0, intensity, cos: 1.0, sin: 0.0, rotation: Some((m, m.transpose())) }
            }
        }
    }

    /// The map-space direction of world direction `d` (the inverse rotation).
    #[inline(always)]
    pub fn to_map(&self, d: Vec3) -> Vec3 {
        if let Some((m, _)) = &self.rotation {
            return *m * d;
        }
        if self.sin == 0.0 && self.cos == 1.0 {
            return d;
        }
        Vec3::new(self.cos * d.x - self.sin * d.z, d.y, self.sin * d.x + self.cos * d.z)
    }

    /// The world direction of map-space direction `d` (inverse of [`SkyTransform::to_map`]).
    #[inline(always)]
    pub fn to_world(&self, d: Vec3) -> Vec3 {
        if let Some((_, m)) = &self.rotation {
            return *m * d;
        }
        if self.sin == 0.0 && self.cos == 1.0 {
            return d;
        }
        Vec3::new(self.cos * d.x + self.sin * d.z, d.y, -self.sin * d.x + self.cos * d.z)
    }
}

impl Default for SkyTransform {
    fn default() -> Self {
        SkyTransform::new(0.0, 1.0)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Sky {
    /// One colour in every direction (the thesis's background colour).
    Colour(Rgb),
    /// Blend from `horizon` (y = 0) to `zenith` (y = 1); `ground` below the horizon.
    Gradient { zenith: Rgb, horizon: Rgb, ground: Rgb },
    /// Six square faces (from separate images, a cross or a strip).
    CubeMap { map: Arc<CubeMap>, transform: SkyTransform },
    /// An equirectangular image.
    LatLong { map: Arc<LatLongMap>, transform: SkyTransform },
}

impl Default for Sky {
    fn default() -> Self {
        Sky::Colour(Rgb::new(0.35, 0.55, 0.85))
    }
}

impl Sky {
    /// Radiance arriving from direction `dir` (any non-zero length), i.e. seen by a ray
    /// travelling along `dir`; maps are read at their finest level.
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Rgb {
        match self {
            Sky::Colour(c) => *c,
            Sky::Gradient { zenith, horizon, ground } => gradient(dir, *zenith, *horizon, *ground),
            Sky::CubeMap { map, transform } => map.lookup(transform.to_map(dir)) * transform.intensity,
            Sky::LatLong { map, transform } => map.lookup(transform.to_map(dir)) * transform.intensity,
        }
    }

    /// Radiance averaged over a cone `cone_angle` radians wide around `dir`: maps pick their
    /// mip level from it (trilinear). A zero angle is [`Sky::radiance`].
    #[inline]
    pub fn radiance_filtered(&self, dir: Vec3, cone_angle: f32) -> Rgb {
        match self {
            Sky::Colour(c) => *c,
            Sky::Gradient { zenith, horizon, ground } => gradient(dir, *zenith, *horizon, *ground),
            Sky::CubeMap { map, transform } => {
                map.lookup_filtered(transform.to_map(dir), cone_angle) * transform.intensity
            }
            Sky::LatLong { map, transform } => {
                map.lookup_filtered(transform.to_map(dir), cone_angle) * transform.intensity
            }
        }
    }

    /// [`Sky::radiance_filtered`] of the directions and footprints of the lanes set in
    /// `active` (bit i: lane i; the others are zero): the same values, with a map's eight
    /// lookups done across lanes ([`CubeMap::lookup_filtered8`],
    /// [`LatLongMap::lookup_filtered8`]).
    pub fn radiance_filtered8(&self, dirs: &[Vec3; LANES], cones: &[f32; LANES], active: u8) -> [Rgb; LANES] {
        let mut out = [Rgb::ZERO; LANES];
        match self {
            Sky::CubeMap { map, transform } if active.count_ones() > 1 => {
                let seen = map.lookup_filtered8(&dirs.map(|d| transform.to_map(d)), cones);
                scaled_lanes(&mut out, seen, transform.intensity, active);
            }
            Sky::LatLong { map, transform } if active.count_ones() > 1 => {
                let seen = map.lookup_filtered8(&dirs.map(|d| transform.to_map(d)), cones);
                scaled_lanes(&mut out, seen, transform.intensity, active);
            }
            _ => {
                for (i, o) in out.iter_mut().enumerate() {
                    if active >> i & 1 != 0 {
                        *o = self.radiance_filtered(dirs[i], cones[i]);
                    }
                }
            }
        }
        out
    }

    /// True for skies that are the same in every direction.
    pub fn is_constant(&self) -> bool {
        matches!(self, Sky::Colour(_))
    }

    /// The sky's irradiance as spherical harmonics (the ambient light of a surface).
    pub fn irradiance_sh(&self) -> IrradianceSh {
        IrradianceSh::project(|d, footprint| self.radiance_filtered(d, footprint))
    }
}

/// `out[i] = seen[i] · intensity` for the lanes set in `active`.
fn scaled_lanes(out: &mut [Rgb; LANES], seen: [Rgb; LANES], intensity: f32, active: u8) {
    for (i, (o, c)) in out.iter_mut().zip(seen).enumerate() {
        if active >> i & 1 != 0 {
            *o = c * intensity;
        }
    }
}

#[inline]
fn gradient(dir: Vec3, zenith: Rgb, horizon: Rgb, ground: Rgb) -> Rgb {
    gradient_at(dir.normalize_or(Vec3::Y).y, zenith, horizon, ground)
}

/// A gradient sky's radiance at the height `y` (the up component of a unit direction).
#[inline]
pub(crate) fn gradient_at(y: f32, zenith: Rgb, horizon: Rgb, ground: Rgb) -> Rgb {
    if y >= 0.0 { horizon.lerp(zenith, y.min(1.0)) } else { ground }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rotation_turns_the_map_about_up() {
        // A map bright only around −Z (ahead), turned 90°: now bright toward −X (to the left).
        let map = Arc::new(LatLongMap::from_fn(32, |d| Rgb::splat((-d.z).max(0.0).powi(8))));
        let sky = Sky::LatLong { map, transform: SkyTransform::new(90.0, 2.0) };
        assert!(sky.radiance(-Vec3::X).x > 1.9, "{}", sky.radiance(-Vec3::X));
        assert!(sky.radiance(-Vec3::Z).x < 0.01);
        assert!(sky.radiance(Vec3::X).x < 0.01);
    }

    #[test]
    fn a_general_rotation_turns_both_ways() {
        let m = Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let t = SkyTransform::from_rotation(m, 1.0).expect("a rotation");
        let d = Vec3::new(0.3, -0.5, 0.8).normalize();
        assert!((t.to_map(d) - m * d).length() < 1e-6);
        assert!((t.to_world(t.to_map(d)) - d).length() < 1e-5);
        assert!(SkyTransform::from_rotation(Mat3::from_diagonal(Vec3::new(-1.0, 1.0, 1.0)), 1.0).is_none());
        assert!(SkyTransform::from_rotation(Mat3::from_diagonal(Vec3::splat(2.0)), 1.0).is_none());
    }

    #[test]
    fn adjusting_keeps_a_general_rotation() {
        let m = Mat3::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let t = SkyTransform::from_rotation(m, 3.0).expect("a rotation");
        let d = Vec3::new(0.3, -0.5, 0.8).normalize();
        // No flags: the same transform (the CLI once dropped the rotation here).
        let same = t.adjusted(None, 1.0);
        assert!((same.to_map(d) - m * d).length() < 1e-6);
        assert_eq!(same.intensity, 3.0);
        // A turn about +y is applied on the world side, then the file's rotation.
        let turned = t.adjusted(Some(90.0), 0.5);
        let plain = SkyTransform::new(90.0, 1.0);
        assert!((turned.to_map(d) - m * plain.to_map(d)).length() < 1e-5);
        assert!((turned.to_world(turned.to_map(d)) - d).length() < 1e-5);
        assert_eq!(turned.intensity, 1.5);
        // A plain transform: the rotation is replaced, as --sky-rotation always did.
        let p = SkyTransform::new(30.0, 1.0).adjusted(Some(90.0), 2.0);
        assert_eq!((p.rotation_degrees, p.intensity), (90.0, 2.0));
    }

    #[test]
    fn gradient_and_colour_ignore_footprints() {
        let g = Sky::Gradient { zenith: Rgb::ONE, horizon: Rgb::ZERO, ground: Rgb::splat(0.5) };
        assert_eq!(g.radiance(Vec3::Y), Rgb::ONE);
        assert_eq!(g.radiance_filtered(-Vec3::Y, 3.0), Rgb::splat(0.5));
        assert_eq!(Sky::Colour(Rgb::X).radiance_filtered(Vec3::Z, 1.0), Rgb::X);
    }
}
