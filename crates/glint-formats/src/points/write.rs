//! Writing a [`PointCloud`] as a binary little-endian PLY, the one point-cloud format every tool
//! (CloudCompare, MeshLab, Open3D, Blender) reads, so sampled or converted clouds can leave glint.
//!
//! Properties: `float x y z`, then `float nx ny nz`, `float radius` and `uchar red green blue`
//! (8-bit sRGB) when the cloud has them. A `comment written by glint` line marks the file, and a
//! non-zero [`PointCloud::origin`] is kept as `comment origin X Y Z` (f64, shortest exact
//! decimal), which [`super::read_point_cloud`] reads back: positions, normals and radii round
//! trip bit for bit, colours to 8-bit sRGB. The file is written whole to a temporary file in
//! the same folder and renamed ([`glint_image::atomic_write`]), so a failure never leaves half
//! a cloud under the name.

use super::ply_cloud::WRITTEN_BY;
use crate::FormatError;
use glint_core::colour::linear_to_srgb;
use glint_core::glam::DVec3;
use glint_image::ImageError;
use glint_scene::PointCloud;
use std::fmt::Write as _;
use std::path::Path;

/// Writes `cloud` to `path` as a binary little-endian PLY, atomically. The cloud is validated
/// first; an invalid cloud is an [`FormatError::Invalid`] naming `path`.
pub fn write_ply_cloud(path: &Path, cloud: &PointCloud) -> Result<(), FormatError> {
    cloud.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    let bytes = encode(cloud);
    glint_image::atomic_write(path, &bytes).map_err(|e| {
        let message = match e {
            ImageError::Io { source, .. } => source.to_string(),
            other => other.to_string(),
        };
        FormatError::write(path, message)
    })
}

/// The PLY file's bytes.
fn encode(cloud: &PointCloud) -> Vec<u8> {
    let mut header = String::from("ply\nformat binary_little_endian 1.0\n");
    let _ = writeln!(header, "comment {WRITTEN_BY} {}", env!("CARGO_PKG_VERSION"));
    if cloud.origin != DVec3::ZERO {
        let o = cloud.origin;
        let _ = writeln!(header, "comment origin {:?} {:?} {:?}", o.x, o.y, o.z);
    }
    let _ = writeln!(header, "element vertex {}", cloud.len());
    header.push_str("property float x\nproperty float y\nproperty float z\n");
    if cloud.normals.is_some() {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    if cloud.radii.is_some() {
        header.push_str("property float radius\n");
    }
    if cloud.colours.is_some() {
        header.push_str("property uchar red\nproperty uchar green\nproperty uchar blue\n");
    }
    header.push_str("end_header\n");

    let stride = 12
        + 12 * cloud.normals.is_some() as usize
        + 4 * cloud.radii.is_some() as usize
        + 3 * cloud.colours.is_some() as usize;
    let mut out = Vec::with_capacity(header.len() + stride * cloud.len());
    out.extend_from_slice(header.as_bytes());
    let floats = |out: &mut Vec<u8>, v: &[f32]| v.iter().for_each(|f| out.extend_from_slice(&f.to_le_bytes()));
    let byte = |c: f32| (linear_to_srgb(c) * 255.0).round() as u8;
    for (i, p) in cloud.positions.iter().enumerate() {
        floats(&mut out, &p.to_array());
        if let Some(n) = &cloud.normals {
            floats(&mut out, &n[i].to_array());
        }
        if let Some(r) = &cloud.radii {
            floats(&mut out, &[r[i]]);
        }
        if let Some(c) = &cloud.colours {
            out.extend_from_slice(&[byte(c[i].x), byte(c[i].y), byte(c[i].z)]);
        }
    }
    out
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::points::{PointReadOptions, read_point_cloud};
    use crate::test_util::TempDir;
    use glint_core::colour::srgb_to_linear;
    use glint_core::{Rgb, Vec3};
    use glint_scene::Orientation;

    fn cloud() -> PointCloud {
        let n = 50;
        let positions = (0..n).map(|i| Vec3::new(i as f32 * 0.1, (i as f32).sin(), -1.0 / (i as f32 + 3.0))).collect();
        let normals = (0..n).map(|i| Vec3::new(1.0, i as f32, 0.3).normalize()).collect();
        let radii = (0..n).map(|i| 0.01 + i as f32 * 1e-4).collect();
        let colours = (0..n).map(|i| Rgb::new(i as f32 / 49.0, 0.5, srgb_to_linear(0.2))).collect();
        PointCloud {
            name: "c".into(),
            positions,
            normals: Some(normals),
            radii: Some(radii),
            colours: Some(colours),
            origin: DVec3::new(512_345.678_9, 87.25, -4_100_000.125),
            orientation: Orientation::Oriented,
        }
    }

    #[test]
    fn round_trip_is_bit_exact_but_for_8_bit_colour() {
        let dir = TempDir::new("points-write");
        let path = dir.join("c.ply");
        let c = cloud();
        write_ply_cloud(&path, &c).unwrap();
        let back = read_point_cloud(&path, &PointReadOptions::default()).unwrap();
        assert_eq!(back.positions, c.positions);
        assert_eq!(back.normals, c.normals);
        assert_eq!(back.radii, c.radii);
        assert_eq!(back.origin, c.origin);
        assert_eq!(back.orientation, Orientation::Oriented);
        for (a, b) in back.colours.unwrap().iter().zip(c.colours.unwrap()) {
            let (a, b) = (a.to_array().map(linear_to_srgb), b.to_array().map(linear_to_srgb));
            assert!(a.iter().zip(b).all(|(x, y)| (x - y).abs() <= 0.5 / 255.0 + 1e-6), "{a:?} {b:?}");
        }
        // Only positions, no origin: still exact, and no recentring on the way back even
        // though the coordinates are far from the origin for their size.
        let bare = PointCloud {
            name: "b".into(),
            positions: vec![Vec3::new(5000.0, 1.0, 2.0), Vec3::new(5000.5, 1.25, 2.0)],
            ..PointCloud::default()
        };
        write_ply_cloud(&path, &bare).unwrap();
        let text = std::fs::read(&path).unwrap();
        assert!(!String::from_utf8_lossy(&text).contains("origin"));
        let back = read_point_cloud(&path, &PointReadOptions::default()).unwrap();
        assert_eq!((back.positions, back.origin), (bare.positions, DVec3::ZERO));
        assert!(back.normals.is_none() && back.radii.is_none() && back.colours.is_none());
        let entries = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(entries, 1, "no temporary file left");
    }

    #[test]
    fn failures_name_the_file() {
        let dir = TempDir::new("points-write-fail");
        let path = dir.join("missing/folder/c.ply");
        let e = write_ply_cloud(&path, &cloud()).unwrap_err();
        assert!(matches!(e, FormatError::Write { .. }) && e.to_string().contains("folder/c.ply"), "{e}");
        let e = write_ply_cloud(&dir.join("empty.ply"), &PointCloud::default()).unwrap_err();
        assert!(matches!(e, FormatError::Invalid { .. }) && e.to_string().contains("empty.ply"), "{e}");
        assert!(!dir.join("empty.ply").exists());
    }
}
