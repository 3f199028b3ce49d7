//! PLY point clouds (ASCII, binary little- and big-endian) on top of the general PLY element
//! reader ([`crate::ply`]): the `vertex` element becomes the points, any `face` element is
//! ignored (a mesh's vertices read as a cloud).
//!
//! Vertex properties, matched case-insensitively: `x y z` (required; `double` columns keep
//! their precision until recentring), `nx ny nz` (the cloud is then [`Orientation::Oriented`]),
//! `radius` / `scale` / `size`, `red green blue` or `diffuse_red ...` (uchar /255, ushort
//! /65535, float as is when ≤ 1; sRGB-encoded), `intensity` / `scalar_intensity` and
//! `classification` / `scalar_classification` for [`ColourBy`](super::ColourBy).
//!
//! Files glint wrote ([`super::write_ply_cloud`]) carry `comment origin X Y Z`, read back into
//! [`PointCloud::origin`]; their positions are taken as they are, so a round trip is
//! bit-exact. Other files go through the shared recentring rule ([`super::recentre`]).

use super::colour::{ColourSources, PointReadOptions, colours};
use super::recentre::{origin_for, relative};
use crate::FormatError;
use crate::ply::{Column, ElementData, PlyData, PropertyKind, ScalarType, parse_ply};
use glint_core::glam::DVec3;
use glint_core::{Rgb, Vec3};
use glint_scene::{Orientation, PointCloud};
use std::path::Path;

/// The comment glint's writer puts in every PLY cloud.
pub(crate) const WRITTEN_BY: &str = "written by glint";

const RADIUS_NAMES: [&str; 3] = ["radius", "scale", "size"];
const COLOUR_NAMES: [[&str; 3]; 2] = [["red", "green", "blue"], ["diffuse_red", "diffuse_green", "diffuse_blue"]];
const INTENSITY_NAMES: [&str; 2] = ["intensity", "scalar_intensity"];
const CLASS_NAMES: [&str; 2] = ["classification", "scalar_classification"];

fn wanted(name: &str) -> bool {
    let known = ["x", "y", "z", "nx", "ny", "nz"]
        .iter()
        .chain(&RADIUS_NAMES)
        .chain(COLOUR_NAMES.iter().flatten())
        .chain(&INTENSITY_NAMES)
        .chain(&CLASS_NAMES);
    known.into_iter().any(|k| k.eq_ignore_ascii_case(name))
}

/// Reads a PLY file as a point cloud.
pub(crate) fn read_ply_cloud(path: &Path, options: &PointReadOptions) -> Result<PointCloud, FormatError> {
    let bytes = crate::ply::read_bytes(path)?;
    parse_ply_cloud(path, &bytes, options)
}

/// True when the PLY file is a point cloud: it has a `vertex` element and no `face` element,
/// or one with no faces. (The whole file is parsed: the body must match the header.)
pub fn ply_is_point_cloud(path: &Path) -> Result<bool, FormatError> {
    let bytes = crate::ply::read_bytes(path)?;
    let ply = parse_ply(path, &bytes, &|_, _| false)?;
    Ok(ply.element("vertex").is_some() && ply.element("face").is_none_or(|f| f.count == 0))
}

/// One selected scalar column of the vertex element, with its type in the file.
struct Scalar<'a> {
    name: &'a str,
    ty: ScalarType,
    column: &'a Column,
}

impl Scalar<'_> {
    #[inline]
    fn at(&self, i: usize) -> f64 {
        match self.column {
            Column::Float(v) => f64::from(v[i]),
            Column::Double(v) => v[i],
            Column::IndexList { .. } => f64::NAN, // never built: lists are rejected in `scalar`
        }
    }

    /// Every value, checked finite; the error names the first bad vertex.
    fn finite_f32(&self, path: &Path, count: usize) -> Result<Vec<f32>, FormatError> {
        (0..count)
            .map(|i| {
                let v = self.at(i);
                if v.is_finite() { Ok(v as f32) } else { Err(not_finite(path, i, self.name)) }
            })
            .collect()
    }
}

fn not_finite(path: &Path, i: usize, what: &str) -> FormatError {
    FormatError::malformed(path, format!("vertex {i}"), format!("'{what}' is NaN or infinite"))
}

/// The vertex property called (case-insensitively) `name`, if the file has it as a scalar.
fn scalar<'a>(
    path: &Path,
    ply: &'a PlyData,
    vertex: &'a ElementData,
    name: &str,
) -> Result<Option<Scalar<'a>>, FormatError> {
    let Some((found, column)) = vertex.columns.iter().find(|(n, _)| n.eq_ignore_ascii_case(name)) else {
        return Ok(None);
    };
    let kind = ply
        .header
        .elements
        .iter()
        .find(|e| e.name == "vertex")
        .and_then(|e| e.properties.iter().find(|p| p.name == *found).map(|p| p.kind));
    match kind {
        Some(PropertyKind::Scalar(ty)) if !matches!(column, Column::IndexList { .. }) => {
            Ok(Some(Scalar { name: found, ty, column }))
        }
        _ => Err(FormatError::malformed(path, "header", format!("vertex property '{found}' is a list, not a number"))),
    }
}

/// The first of `names` the file has.
fn first_of<'a>(
    path: &Path,
    ply: &'a PlyData,
    vertex: &'a ElementData,
    names: &[&str],
) -> Result<Option<Scalar<'a>>, FormatError> {
    for name in names {
        if let Some(s) = scalar(path, ply, vertex, name)? {
            return Ok(Some(s));
        }
    }
    Ok(None)
}

/// The origin a glint-written file records in `comment origin X Y Z`.
fn comment_origin(path: &Path, comments: &[String]) -> Result<Option<DVec3>, FormatError> {
    let Some(rest) = comments.iter().find_map(|c| c.strip_prefix("origin ")) else { return Ok(None) };
    let v: Vec<f64> = rest.split_ascii_whitespace().filter_map(|w| w.parse().ok()).collect();
    match v.as_slice() {
        [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(Some(DVec3::new(*x, *y, *z))),
        _ => {
            Err(FormatError::malformed(path, "header", format!("`comment origin {rest}` is not three finite numbers")))
        }
    }
}

/// Parses PLY bytes as a point cloud; `path` names it in messages and gives the cloud its name.
pub(crate) fn parse_ply_cloud(
    path: &Path,
    bytes: &[u8],
    options: &PointReadOptions,
) -> Result<PointCloud, FormatError> {
    let ply = parse_ply(path, bytes, &|e, p| e.name == "vertex" && wanted(&p.name))?;
    let Some(vertex) = ply.element("vertex") else {
        return Err(FormatError::malformed(path, "header", "no `element vertex`"));
    };
    let n = vertex.count;
    if n > u32::MAX as usize {
        return Err(FormatError::limits(path, format!("{n} vertices are more than glint can index")));
    }
    let mut xyz = Vec::with_capacity(3);
    for c in ["x", "y", "z"] {
        let s = scalar(path, &ply, vertex, c)?;
        xyz.push(s.ok_or_else(|| {
            FormatError::malformed(path, "header", format!("element 'vertex' has no property '{c}'"))
        })?);
    }
    let mut coords = Vec::with_capacity(n);
    for i in 0..n {
        let p = DVec3::new(xyz[0].at(i), xyz[1].at(i), xyz[2].at(i));
        if !p.is_finite() {
            return Err(FormatError::malformed(path, format!("vertex {i}"), "a coordinate is NaN or infinite"));
        }
        coords.push(p);
    }
    // What the file's coordinates are relative to, and what to subtract from them.
    let comments = &ply.header.comments;
    let (origin, shift) = match comment_origin(path, comments)? {
        Some(o) => (o, DVec3::ZERO),
        None if comments.iter().any(|c| c.starts_with(WRITTEN_BY)) => (DVec3::ZERO, DVec3::ZERO),
        None => {
            let o = origin_for(&coords);
            (o, o)
        }
    };
    let positions: Vec<Vec3> = coords.iter().map(|&p| relative(p, shift)).collect();
    drop(coords);

    let (nx, ny, nz) =
        (scalar(path, &ply, vertex, "nx")?, scalar(path, &ply, vertex, "ny")?, scalar(path, &ply, vertex, "nz")?);
    let normals = match (nx, ny, nz) {
        (Some(nx), Some(ny), Some(nz)) => {
            let mut normals = Vec::with_capacity(n);
            for i in 0..n {
                let v = Vec3::new(nx.at(i) as f32, ny.at(i) as f32, nz.at(i) as f32);
                if !v.is_finite() {
                    return Err(not_finite(path, i, "normal"));
                }
                // Unit normals are kept bit for bit; others are normalised (zero stays zero).
                normals.push(if (v.length() - 1.0).abs() <= 1e-4 { v } else { v.normalize_or_zero() });
            }
            Some(normals)
        }
        _ => None,
    };
    let radii = first_of(path, &ply, vertex, &RADIUS_NAMES)?.map(|r| r.finite_f32(path, n)).transpose()?;

    let mut rgb = None;
    for names in COLOUR_NAMES {
        if let [Some(r), Some(g), Some(b)] = names.map(|c| scalar(path, &ply, vertex, c).ok().flatten()) {
            rgb = Some(srgb_colours(path, [&r, &g, &b], n)?);
            break;
        }
    }
    let intensity = first_of(path, &ply, vertex, &INTENSITY_NAMES)?.map(|s| s.finite_f32(path, n)).transpose()?;
    let classification = first_of(path, &ply, vertex, &CLASS_NAMES)?
        .map(|s| s.finite_f32(path, n).map(|v| v.iter().map(|&c| c.clamp(0.0, 255.0) as u8).collect()))
        .transpose()?;
    let sources = ColourSources { rgb, intensity, classification, auto_elevation: false };
    let colours = colours(path, "header", options.colour_by, sources, &positions)?;

    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "points".into());
    let orientation = if normals.is_some() { Orientation::Oriented } else { Orientation::Unknown };
    let cloud = PointCloud { name, positions, normals, radii, colours, origin, orientation };
    cloud.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    Ok(cloud)
}

/// sRGB colours in [0, 1] from three columns, scaled by their type: uchar /255, ushort /65535,
/// floats as they are when none exceeds 1 (else /255), other integers /255 or /65535 by range.
fn srgb_colours(path: &Path, rgb: [&Scalar; 3], n: usize) -> Result<Vec<Rgb>, FormatError> {
    let mut out = Vec::with_capacity(n);
    let mut max = 0.0f64;
    for i in 0..n {
        let [r, g, b] = rgb.map(|c| c.at(i));
        if !(r.is_finite() && g.is_finite() && b.is_finite()) {
            return Err(not_finite(path, i, "colour"));
        }
        max = max.max(r).max(g).max(b);
        out.push(Rgb::new(r as f32, g as f32, b as f32));
    }
    let scale = match rgb[0].ty {
        ScalarType::U8 => 1.0 / 255.0,
        ScalarType::U16 => 1.0 / 65535.0,
        ScalarType::F32 | ScalarType::F64 if max <= 1.0 => 1.0,
        _ if max <= 255.0 => 1.0 / 255.0,
        _ => 1.0 / 65535.0,
    };
    Ok(out.into_iter().map(|c| (c * scale).clamp(Rgb::ZERO, Rgb::ONE)).collect())
}

#[cfg(test)]
mod tests;
