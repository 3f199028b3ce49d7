//! Point-cloud files ↔ [`PointCloud`]: PLY (ASCII and binary, through the general PLY reader),
//! LAS/LAZ (through the `las` crate), XYZ-style text (.xyz, .txt, .pts); and binary PLY out.
//!
//! Every reader gives the same cloud shape: positions as f32 relative to an f64
//! [`PointCloud::origin`] (large coordinates are recentred so f32 keeps their precision:
//! [`recentre`] for PLY and text, always for LAS), normals when the file has them (then
//! [`Orientation::Oriented`](glint_scene::Orientation)), radii, and linear colours chosen by
//! [`ColourBy`]. Files are fully understood or rejected: every error is a [`FormatError`]
//! naming the file and the place (header, vertex or point index, line, byte).
//!
//! Sits in glint-formats with the other parsers; it depends on glint-scene for the cloud type
//! and on nothing that renders.

mod colour;
mod las;
mod ply_cloud;
mod recentre;
mod write;
mod xyz;

pub use colour::{ColourBy, PointReadOptions};
pub use ply_cloud::ply_is_point_cloud;
pub use write::write_ply_cloud;
pub use xyz::{parse_xyz, read_xyz};

use crate::FormatError;
use glint_core::glam::DVec3;
use glint_scene::PointCloud;
use std::path::Path;

/// The formats [`read_point_cloud`] knows, by extension (lower case).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum CloudFormat {
    Ply,
    Las,
    Text,
}

fn cloud_format(path: &Path) -> Option<CloudFormat> {
    let ext = path.extension()?.to_str()?.to_ascii_lowercase();
    Some(match ext.as_str() {
        "ply" => CloudFormat::Ply,
        "las" | "laz" => CloudFormat::Las,
        "xyz" | "txt" | "pts" => CloudFormat::Text,
        _ => return None,
    })
}

/// A warning when the cloud's points all lie at one position (a LAS file with a tiny scale, a
/// scan that recorded nothing): it would show as a dot or nothing, with no other word.
pub fn coincident_warning(path: &Path, cloud: &PointCloud) -> Option<String> {
    let first = *cloud.positions.first()?;
    if cloud.positions.len() < 2 || cloud.positions.iter().any(|&p| p != first) {
        return None;
    }
    let at = cloud.origin + first.as_dvec3();
    Some(format!(
        "{}: all {} points lie at one position ({:.6}, {:.6}, {:.6}); the cloud shows as a single dot at most",
        crate::model::file_name(path),
        cloud.positions.len(),
        at.x,
        at.y,
        at.z
    ))
}

/// Reads a point cloud, by extension (case-insensitive): `.ply` (its vertices; see
/// [`ply_is_point_cloud`] to tell a cloud from a mesh), `.las`, `.laz`, and `.xyz` / `.txt` /
/// `.pts` text.
pub fn read_point_cloud(path: &Path, options: &PointReadOptions) -> Result<PointCloud, FormatError> {
    match cloud_format(path) {
        Some(CloudFormat::Ply) => ply_cloud::read_ply_cloud(path, options),
        Some(CloudFormat::Las) => las::read_las(path, options),
        Some(CloudFormat::Text) => xyz::read_xyz_with(path, options),
        None => {
            let ext = path.extension().map_or_else(|| "no extension".into(), |e| format!(".{}", e.to_string_lossy()));
            Err(FormatError::malformed(
                path,
                "file name",
                format!("{ext} is not a point-cloud format glint reads (.ply, .las, .laz, .xyz, .txt, .pts)"),
            ))
        }
    }
}

/// A point given in a cloud file's own axes (a scene's `sensor`) in glint's axes, as the
/// file's points are read: LAS/LAZ are Z-up and turned by [`las::glint_from_las`]; the other
/// formats are read as they are.
pub(crate) fn glint_from_file_axes(path: &Path, p: DVec3) -> DVec3 {
    match cloud_format(path) {
        Some(CloudFormat::Las) => las::glint_from_las(p),
        Some(CloudFormat::Ply | CloudFormat::Text) | None => p,
    }
}

/// True for the extensions that are always point clouds: `.las`, `.laz`, `.xyz`, `.pts`
/// (case-insensitive). A `.ply` may be a mesh or a cloud (ask [`ply_is_point_cloud`]); a
/// `.txt` may be anything.
pub fn is_point_cloud_path(path: &Path) -> bool {
    path.extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| ["las", "laz", "xyz", "pts"].iter().any(|k| e.eq_ignore_ascii_case(k)))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::test_util::TempDir;

    #[test]
    fn extensions_are_told_apart() {
        for (name, cloud) in [("a.LAS", true), ("a.laz", true), ("a.xyz", true), ("a.Pts", true), ("a.ply", false)] {
            assert_eq!(is_point_cloud_path(Path::new(name)), cloud, "{name}");
        }
        assert!(!is_point_cloud_path(Path::new("a.txt")) && !is_point_cloud_path(Path::new("las")));
        assert_eq!(cloud_format(Path::new("x/a.TXT")), Some(CloudFormat::Text));
        assert_eq!(cloud_format(Path::new("a.PLY")), Some(CloudFormat::Ply));
    }

    #[test]
    fn unknown_extensions_and_unreadable_files_name_the_file() {
        let o = PointReadOptions::default();
        let e = read_point_cloud(Path::new("scan.e57"), &o).unwrap_err().to_string();
        assert!(e.starts_with("scan.e57: file name: .e57 is not a point-cloud format"), "{e}");
        let e = read_point_cloud(Path::new("scan"), &o).unwrap_err().to_string();
        assert!(e.contains("no extension"), "{e}");
        let dir = TempDir::new("points-unreadable");
        for name in ["missing.ply", "missing.las", "missing.xyz"] {
            let e = read_point_cloud(&dir.join(name), &o).unwrap_err();
            assert!(matches!(e, FormatError::Io { .. }) && e.to_string().contains(name), "{e}");
        }
        // A folder under a cloud's name cannot be read either.
        let folder = dir.join("folder.ply");
        std::fs::create_dir(&folder).unwrap();
        let e = read_point_cloud(&folder, &o).unwrap_err();
        assert!(e.to_string().contains("folder.ply"), "{e}");
        assert!(ply_is_point_cloud(&folder).is_err());
    }
}
