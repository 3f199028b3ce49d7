//! PLY (Stanford polygon file format): ASCII, binary little- and big-endian.
//!
//! Two layers. [`read_ply`] / [`parse_ply`] are a general element/property reader returning
//! named columns, for meshes and point clouds alike ([`header`], [`body`]). [`load`] builds a
//! mesh on top: vertex `x y z` (+ `nx ny nz`, + `u v` / `s t` / `texture_u texture_v`), faces
//! from `vertex_indices` (or `vertex_index`) lists of any integer type, polygons split into
//! fans. Meshes without normals get smooth (area-weighted) vertex normals: PLY meshes are
//! almost always scans of smooth surfaces.

mod body;
mod header;

pub use body::{Column, ElementData, PlyData};
pub use header::{Element, Header, PlyFormat, Property, PropertyKind, ScalarType};

use crate::error::FormatError;
use crate::model::{self, Model};
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::{Mesh, MeshAttribute};
use std::path::Path;

/// Reads a PLY file, keeping the properties `select` picks (by element and property).
pub fn read_ply(path: &Path, select: &dyn Fn(&Element, &Property) -> bool) -> Result<PlyData, FormatError> {
    let data = read_bytes(path)?;
    parse_ply(path, &data, select)
}

/// The bytes of a PLY file, refused after its first line if that is not `ply`.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, FormatError> {
    crate::files::read_sniffed(path, None, |head| {
        let first = head.split(|&b| b == b'\n').next().unwrap_or_default();
        if first.strip_suffix(b"\r").unwrap_or(first) == b"ply" || head.len() < 4 && b"ply\n".starts_with(head) {
            Ok(())
        } else {
            Err("not a PLY file (the first line is not `ply`)".to_string())
        }
    })
}

/// Reads PLY data already in memory; `path` names it in messages.
pub fn parse_ply(
    path: &Path,
    data: &[u8],
    select: &dyn Fn(&Element, &Property) -> bool,
) -> Result<PlyData, FormatError> {
    let header = header::parse_header(path, data)?;
    body::read_body(path, data, header, select)
}

const VERTEX_PROPERTIES: [&str; 14] =
    ["x", "y", "z", "nx", "ny", "nz", "u", "v", "s", "t", "texture_u", "texture_v", "texture_s", "texture_t"];
const UV_NAMES: [(&str, &str); 4] = [("u", "v"), ("s", "t"), ("texture_u", "texture_v"), ("texture_s", "texture_t")];

fn mesh_selection(e: &Element, p: &Property) -> bool {
    match e.name.as_str() {
        "vertex" => VERTEX_PROPERTIES.contains(&p.name.as_str()),
        "face" => p.name == "vertex_indices" || p.name == "vertex_index",
        _ => false,
    }
}

/// [`mesh_selection`] and the properties that are mesh attributes ([`attribute_channel`]).
fn mesh_and_attribute_selection(e: &Element, p: &Property) -> bool {
    mesh_selection(e, p) || (matches!(e.name.as_str(), "vertex" | "face") && attribute_channel(&p.name).is_some())
}

/// Mitsuba's reading of a PLY property as a mesh attribute's channel: `<name>_<k>` is channel
/// k (0..3) of attribute `<name>`, and `r g b` / `red green blue` are the channels of `color`
/// (src/shapes/ply.cpp). The attribute is then `vertex_<name>` or `face_<name>`.
fn attribute_channel(property: &str) -> Option<(&str, usize)> {
    match property {
        "r" | "red" => Some(("color", 0)),
        "g" | "green" => Some(("color", 1)),
        "b" | "blue" => Some(("color", 2)),
        _ => {
            let (name, k) = property.rsplit_once('_')?;
            let k: usize = k.parse().ok()?;
            (!name.is_empty() && k < 3 && VERTEX_PROPERTIES.iter().all(|v| *v != property)).then_some((name, k))
        }
    }
}

/// The attributes of `element`'s rows (`scope` is `vertex` or `face`): every name whose
/// channels are 0 alone (kept grey) or 0, 1 and 2; other channel sets are skipped with a
/// warning. Values are kept as stored, as Mitsuba keeps them (it expects colours in [0, 1]).
fn attributes_of(element: &ElementData, scope: &str, file: &str, warnings: &mut Vec<String>) -> Vec<MeshAttribute> {
    let mut channels: Vec<(&str, [Option<Vec<f32>>; 3])> = Vec::new();
    for (property, column) in &element.columns {
        let (Some((name, k)), Some(values)) = (attribute_channel(property), column.to_f32()) else { continue };
        let at = match channels.iter().position(|(n, _)| *n == name) {
            Some(i) => i,
            None => {
                channels.push((name, [None, None, None]));
                channels.len() - 1
            }
        };
        channels[at].1[k] = Some(values);
    }
    let mut out = Vec::new();
    for (name, [c0, c1, c2]) in channels {
        let full = format!("{scope}_{name}");
        let values: Vec<Rgb> = match (c0, c1, c2) {
            (Some(a), None, None) => a.iter().map(|&v| Rgb::splat(v)).collect(),
            (Some(r), Some(g), Some(b)) => r.iter().zip(&g).zip(&b).map(|((&r, &g), &b)| Rgb::new(r, g, b)).collect(),
            _ => {
                warnings.push(format!("{file}: attribute '{full}' has neither 1 nor 3 channels: ignored"));
                continue;
            }
        };
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            warnings.push(format!("{file}: attribute '{full}' is not a finite number at {scope} {i}: ignored"));
            continue;
        }
        out.push(MeshAttribute { name: full, values });
    }
    out
}

/// Reads a PLY mesh file (geometry, normals, uvs).
pub(crate) fn load(path: &Path) -> Result<Model, FormatError> {
    load_selected(path, &mesh_selection)
}

/// Reads a PLY mesh file with its mesh attributes (for Mitsuba's `mesh_attribute` textures;
/// other loaders leave them unread: a scan's colours would cost 12 bytes a vertex).
pub fn load_with_attributes(path: &Path) -> Result<Model, FormatError> {
    load_selected(path, &mesh_and_attribute_selection)
}

fn load_selected(path: &Path, select: &dyn Fn(&Element, &Property) -> bool) -> Result<Model, FormatError> {
    let data = read_ply(path, select)?;
    let mut warnings = Vec::new();
    let mesh = mesh_from_ply(path, &data, &mut warnings)?;
    let mut meshes = vec![mesh];
    model::finish_meshes(path, &mut meshes, &mut warnings)?;
    for m in &mut meshes {
        if m.normals.is_none() {
            m.compute_vertex_normals();
        }
    }
    Ok(Model { meshes, warnings, ..Model::default() })
}

fn scalar_column(path: &Path, e: &ElementData, name: &str) -> Result<Option<Vec<f32>>, FormatError> {
    match e.column(name) {
        None => Ok(None),
        Some(c) => c.to_f32().map(Some).ok_or_else(|| {
            FormatError::malformed(path, "header", format!("property '{name}' of '{}' is a list, not a number", e.name))
        }),
    }
}

/// Builds the mesh of a PLY file read with [`mesh_selection`].
fn mesh_from_ply(path: &Path, data: &PlyData, warnings: &mut Vec<String>) -> Result<Mesh, FormatError> {
    let name = model::file_name(path);
    let Some(vertex) = data.element("vertex") else {
        return Err(FormatError::malformed(path, "header", "no `element vertex`"));
    };
    if vertex.count > u32::MAX as usize {
        return Err(FormatError::limits(path, format!("{} vertices are more than glint can index", vertex.count)));
    }
    let coords = ["x", "y", "z"].map(|c| scalar_column(path, vertex, c));
    let [Ok(Some(x)), Ok(Some(y)), Ok(Some(z))] = coords else {
        return Err(FormatError::malformed(path, "header", "element 'vertex' needs float properties x, y and z"));
    };
    let positions: Vec<Vec3> = (0..vertex.count).map(|i| Vec3::new(x[i], y[i], z[i])).collect();
    if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
        return Err(FormatError::malformed(path, format!("vertex {i}"), "a coordinate is NaN or infinite"));
    }

    let normals = match ["nx", "ny", "nz"].map(|c| scalar_column(path, vertex, c)) {
        [Ok(Some(nx)), Ok(Some(ny)), Ok(Some(nz))] => {
            let raw: Vec<Vec3> = (0..vertex.count).map(|i| Vec3::new(nx[i], ny[i], nz[i])).collect();
            if let Some(i) = raw.iter().position(|n| !n.is_finite()) {
                return Err(FormatError::malformed(path, format!("vertex {i}"), "the normal is NaN or infinite"));
            }
            let unit: Option<Vec<Vec3>> = raw.iter().map(|n| n.try_normalize()).collect();
            if unit.is_none() {
                warnings.push(format!("{name}: some vertex normals have zero length; normals recomputed"));
            }
            unit
        }
        _ => None,
    };

    let mut uvs = None;
    for (u, v) in UV_NAMES {
        if let (Some(us), Some(vs)) = (scalar_column(path, vertex, u)?, scalar_column(path, vertex, v)?) {
            let uv: Vec<Vec2> = us.iter().zip(&vs).map(|(&u, &v)| Vec2::new(u, v)).collect();
            if let Some(i) = uv.iter().position(|t| !t.is_finite()) {
                return Err(FormatError::malformed(path, format!("vertex {i}"), "a texture coordinate is NaN"));
            }
            uvs = Some(uv);
            break;
        }
    }

    let Some(face) = data.element("face") else {
        return Err(FormatError::malformed(path, "header", "no `element face`: this is a point cloud, not a mesh"));
    };
    let column = face.column("vertex_indices").or_else(|| face.column("vertex_index"));
    let Some(Column::IndexList { counts, values }) = column else {
        return Err(FormatError::malformed(path, "header", "element 'face' needs a list property 'vertex_indices'"));
    };
    let n = positions.len() as u32;
    if let Some(k) = values.iter().position(|&v| v >= n) {
        // Find the face holding item k for the message.
        let mut start = 0usize;
        let face_index = counts.iter().position(|&c| {
            start += c as usize;
            start > k
        });
        return Err(FormatError::malformed(
            path,
            format!("face {}", face_index.unwrap_or(0)),
            format!("vertex index {} is out of range (the file has {n} vertices)", values[k]),
        ));
    }
    let triangle_count: usize = counts.iter().map(|&c| (c as usize).saturating_sub(2)).sum();
    let mut triangles = Vec::with_capacity(triangle_count);
    // The face each triangle comes from (for per-face attributes).
    let mut face_of_triangle = Vec::with_capacity(triangle_count);
    let mut start = 0;
    let mut short = 0;
    for (f, &c) in counts.iter().enumerate() {
        let c = c as usize;
        let poly = &values[start..start + c];
        start += c;
        if c < 3 {
            short += 1;
            continue;
        }
        model::split_polygon(poly, &mut triangles);
        face_of_triangle.resize(triangles.len(), f);
    }
    if short > 0 {
        warnings.push(format!("{name}: skipped {short} faces with fewer than 3 vertices"));
    }
    let mut attributes = attributes_of(vertex, "vertex", &name, warnings);
    for mut a in attributes_of(face, "face", &name, warnings) {
        a.values = face_of_triangle.iter().map(|&f| a.values.get(f).copied().unwrap_or(Rgb::ZERO)).collect();
        attributes.push(a);
    }
    let stem = path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
    Ok(Mesh { name: stem, positions, normals, uvs, triangles, triangle_materials: None, attributes })
}

#[cfg(test)]
mod tests;
