//! Point clouds (DESIGN.md §3): positions with optional normals, radii and colours, in
//! structure-of-arrays form (the projection pass reads positions alone).

pub mod estimate;
pub mod sample;

pub use estimate::{EstimateSettings, estimate_normals, estimate_radii, prepare};
pub use sample::sample_mesh;

use crate::SceneError;
use glint_core::glam::DVec3;
use glint_core::{Bounds3, Rgb, Vec3};

/// What the sign of the normals can be trusted for, and how estimation should orient them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum Orientation {
    /// Normals point out of the surface: back faces may be culled.
    Oriented,
    /// Normals (to be estimated) should face this point, the sensor that scanned the cloud.
    TowardSensor(Vec3),
    /// Normals (to be estimated) should have a positive component along this direction
    /// (airborne LiDAR: up).
    Up(Vec3),
    /// No reliable sign: the cloud is drawn two-sided.
    #[default]
    Unknown,
}

#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Unit normals, when the file gives them (or after estimation).
    pub normals: Option<Vec<Vec3>>,
    /// Splat radii in the cloud's units.
    pub radii: Option<Vec<f32>>,
    /// Linear RGB.
    pub colours: Option<Vec<Rgb>>,
    /// The file's coordinates are `origin + position`: large (geo-referenced) coordinates are
    /// recentred in f64 before they become f32.
    pub origin: DVec3,
    pub orientation: Orientation,
}

impl PointCloud {
    pub fn len(&self) -> usize {
        self.positions.len()
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    pub fn bounds(&self) -> Bounds3 {
        Bounds3::from_points(self.positions.iter().copied())
    }

    /// Every attribute has one value per point, every value is finite, radii are positive,
    /// colours non-negative, normals of unit length (or zero: unknown).
    pub fn validate(&self) -> Result<(), SceneError> {
        let what = || format!("point cloud {:?}", self.name);
        if self.positions.is_empty() {
            return Err(SceneError::invalid(what(), "has no points"));
        }
        let n = self.positions.len();
        let check_len = |attr: &str, len: Option<usize>| match len {
            Some(l) if l != n => Err(SceneError::invalid(what(), format!("{l} {attr} for {n} points"))),
            _ => Ok(()),
        };
        check_len("normals", self.normals.as_ref().map(Vec::len))?;
        check_len("radii", self.radii.as_ref().map(Vec::len))?;
        check_len("colours", self.colours.as_ref().map(Vec::len))?;
        if let Some(i) = self.positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::invalid(what(), format!("point {i} has a non-finite position")));
        }
        if let Some(ns) = &self.normals
            && let Some(i) = ns.iter().position(|v| {
                let l = v.length();
                !(l == 0.0 || (l - 1.0).abs() < 1e-3)
            })
        {
            return Err(SceneError::invalid(what(), format!("normal {i} is not of unit length")));
        }
        if let Some(rs) = &self.radii
            && let Some(i) = rs.iter().position(|r| !(r.is_finite() && *r > 0.0))
        {
            return Err(SceneError::invalid(what(), format!("radius {i} is not a finite number > 0")));
        }
        if let Some(cs) = &self.colours
            && let Some(i) = cs.iter().position(|c| !(c.is_finite() && c.min_element() >= 0.0))
        {
            return Err(SceneError::invalid(what(), format!("colour {i} is not finite and >= 0")));
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn attributes_must_match_and_be_finite() {
        let mut c = PointCloud { name: "c".into(), positions: vec![Vec3::ZERO, Vec3::X], ..PointCloud::default() };
        assert!(c.validate().is_ok());
        assert_eq!(c.bounds().extent(), Vec3::X);
        c.radii = Some(vec![0.1]);
        assert!(c.validate().unwrap_err().to_string().contains("1 radii for 2 points"));
        c.radii = Some(vec![0.1, 0.0]);
        assert!(c.validate().unwrap_err().to_string().contains("radius 1"));
        c.radii = None;
        c.normals = Some(vec![Vec3::Y, Vec3::splat(2.0)]);
        assert!(c.validate().unwrap_err().to_string().contains("normal 1"));
        c.normals = None;
        c.positions[0].x = f32::NAN;
        assert!(c.validate().unwrap_err().to_string().contains("point 0"));
        assert!(PointCloud::default().validate().is_err());
    }
}
