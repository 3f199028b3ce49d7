//! glTF 2.0 (`.gltf` + buffers, or `.glb`) → one mesh in world space.
//!
//! The `gltf` crate parses and validates the JSON; buffers and images are read here (not by
//! the crate's importer) so that a missing file is reported by name and a bad URI cannot
//! panic. The node hierarchy of the default scene (or else the first scene, or else every root
//! node) is baked into world-space vertices, all primitives of all meshes into one mesh with
//! per-triangle materials. Only triangle lists are read; other modes are skipped with a warning.
//! Texture coordinates are flipped (v → 1 − v): glTF's v runs down the image, glint's up.
//!
//! PBR materials map to glint's Phong parameters as follows: base colour factor (× base colour
//! texture, sRGB-decoded) → colour; roughness r → shininess 2/r⁴ − 2 (the Blinn-Phong exponent
//! matching the GGX width α = r², clamped to [1, 2000]) and specular weight 1 − r; metallic m →
//! reflectivity m·(1 − r) and diffuse weight 1 − 0.9·m; alpha mode BLEND → transparency 1 − alpha;
//! emissive factor → emission. Primitives without normals are shaded flat (as glTF specifies).

use crate::error::FormatError;
use crate::model::{self, Model, file_name};
use crate::texture_file;
use glint_core::colour::srgb_to_linear;
use glint_core::{Mat3, Mat4, Rgb, Vec2, Vec3};
use glint_scene::{Material, Mesh, Texture, TextureImage};
use gltf::Gltf;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub(crate) fn load(path: &Path) -> Result<Model, FormatError> {
    let data = std::fs::read(path).map_err(|e| FormatError::io(path, e))?;
    // The gltf crate trusts its validation in a few `unwrap`s; a file that slips past it must
    // still be an error, not a crash.
    let result = std::panic::catch_unwind(|| read(path, &data));
    let mut model = result.unwrap_or_else(|_| {
        Err(FormatError::malformed(path, "file", "the glTF parser failed on this file (inconsistent content)"))
    })?;
    model::finish_meshes(path, &mut model.meshes, &mut model.warnings)?;
    Ok(model)
}

fn gltf_error(path: &Path, e: gltf::Error) -> FormatError {
    match e {
        gltf::Error::Deserialize(e) => FormatError::malformed(
            path,
            format!("line {}, column {}", e.line(), e.column()),
            format!("invalid JSON: {e}"),
        ),
        gltf::Error::Binary(e) => FormatError::malformed(path, "header", format!("invalid .glb container: {e}")),
        gltf::Error::Validation(errors) => {
            let more =
                if errors.len() > 1 { format!(" (and {} more problems)", errors.len() - 1) } else { String::new() };
            match errors.first() {
                Some((where_, what)) => FormatError::malformed(path, where_.to_string(), format!("{what}{more}")),
                None => FormatError::malformed(path, "file", "invalid glTF"),
            }
        }
        other => FormatError::malformed(path, "file", other.to_string()),
    }
}

fn read(path: &Path, data: &[u8]) -> Result<Model, FormatError> {
    let Gltf { document, blob } = Gltf::from_slice(data).map_err(|e| gltf_error(path, e))?;
    let base = path.parent().unwrap_or(Path::new(""));
    let name = file_name(path);
    let mut warnings = Vec::new();
    let buffers = read_buffers(path, base, &document, blob)?;

    let mut textures = Vec::new();
    let mut image_textures: HashMap<usize, Option<usize>> = HashMap::new();
    let mut materials = Vec::new();
    for (i, m) in document.materials().enumerate() {
        let mut material = convert_material(i, &m);
        if let Some(info) = m.pbr_metallic_roughness().base_color_texture() {
            if info.tex_coord() != 0 {
                warnings.push(format!(
                    "{name}: material {i} uses texture coordinate set {}; glint reads set 0",
                    info.tex_coord()
                ));
            }
            let image = info.texture().source();
            let index = image.index();
            let texture = match image_textures.get(&index) {
                Some(t) => *t,
                None => {
                    let t = match read_image(path, base, &image, &buffers, &mut warnings)? {
                        Some(img) => {
                            textures.push(Texture::Image { image: Arc::new(img), scale: Vec2::ONE });
                            Some(textures.len() - 1)
                        }
                        None => None,
                    };
                    image_textures.insert(index, t);
                    t
                }
            };
            material.texture = texture;
        }
        materials.push(material);
    }
    let default_material = materials.len() as u32;

    let mut mesh = Mesh {
        name: path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
        ..Mesh::default()
    };
    let mut normals: Vec<Vec3> = Vec::new();
    let mut uvs: Vec<Vec2> = Vec::new();
    let mut triangle_materials: Vec<u32> = Vec::new();
    let mut any_normals = false;
    let mut any_uvs = false;
    let mut uses_default = false;
    let mut skipped_modes = 0;

    let roots: Vec<gltf::Node> = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; document.nodes().len()];
            for n in document.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            document.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    let mut visited = vec![false; document.nodes().len()];
    let mut stack: Vec<(gltf::Node, Mat4)> = roots.into_iter().map(|n| (n, Mat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(FormatError::malformed(
                path,
                format!("nodes[{}]", node.index()),
                "the node is reached twice (a cycle, or a node with two parents)",
            ));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        for child in node.children() {
            stack.push((child, world));
        }
        let Some(gltf_mesh) = node.mesh() else { continue };
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let mirrored = Mat3::from_mat4(world).determinant() < 0.0;
        for (p, primitive) in gltf_mesh.primitives().enumerate() {
            let place = format!("meshes[{}].primitives[{p}]", gltf_mesh.index());
            if primitive.mode() != gltf::mesh::Mode::Triangles {
                skipped_modes += 1;
                continue;
            }
            let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
            let Some(positions) = reader.read_positions() else {
                return Err(FormatError::malformed(path, place, "no POSITION data (or its buffer is too short)"));
            };
            let first = mesh.positions.len();
            for (k, p) in positions.enumerate() {
                let v = world.transform_point3(Vec3::from_array(p));
                if !v.is_finite() {
                    return Err(FormatError::malformed(
                        path,
                        format!("{place} vertex {k}"),
                        "position is NaN or infinite",
                    ));
                }
                mesh.positions.push(v);
            }
            let count = mesh.positions.len() - first;
            if mesh.positions.len() > u32::MAX as usize {
                return Err(FormatError::limits(path, "more vertices than glint can index"));
            }
            let mut local: Vec<[u32; 3]> = Vec::new();
            match reader.read_indices() {
                Some(indices) => {
                    let indices: Vec<u32> = indices.into_u32().collect();
                    if !indices.len().is_multiple_of(3) {
                        return Err(FormatError::malformed(
                            path,
                            place,
                            format!("{} indices do not make triangles", indices.len()),
                        ));
                    }
                    if let Some(k) = indices.iter().position(|&i| i as usize >= count) {
                        return Err(FormatError::malformed(
                            path,
                            format!("{place} index {k}"),
                            format!("vertex {} is out of range ({count} vertices)", indices[k]),
                        ));
                    }
                    local.extend(indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]));
                }
                None => {
                    if !count.is_multiple_of(3) {
                        return Err(FormatError::malformed(
                            path,
                            place,
                            format!("{count} vertices do not make triangles"),
                        ));
                    }
                    local.extend((0..count as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]));
                }
            }
            match reader.read_normals() {
                Some(ns) => {
                    any_normals = true;
                    let before = normals.len();
                    normals.extend(ns.map(|n| (normal_matrix * Vec3::from_array(n)).normalize_or(Vec3::Y)));
                    if normals.len() - before != count {
                        return Err(FormatError::malformed(path, place, "NORMAL and POSITION counts differ"));
                    }
                }
                None => normals.resize(mesh.positions.len(), Vec3::ZERO),
            }
            match reader.read_tex_coords(0) {
                Some(ts) => {
                    any_uvs = true;
                    let before = uvs.len();
                    uvs.extend(ts.into_f32().map(|[u, v]| Vec2::new(u, 1.0 - v)));
                    if uvs.len() - before != count {
                        return Err(FormatError::malformed(path, place, "TEXCOORD_0 and POSITION counts differ"));
                    }
                }
                None => uvs.resize(mesh.positions.len(), Vec2::ZERO),
            }
            if let Some(k) = normals[first..].iter().position(|n| !n.is_finite()) {
                return Err(FormatError::malformed(path, format!("{place} vertex {k}"), "normal is NaN or infinite"));
            }
            if let Some(k) = uvs[first..].iter().position(|t| !t.is_finite()) {
                return Err(FormatError::malformed(
                    path,
                    format!("{place} vertex {k}"),
                    "TEXCOORD_0 is NaN or infinite",
                ));
            }
            let material = match primitive.material().index() {
                Some(i) => i as u32,
                None => {
                    uses_default = true;
                    default_material
                }
            };
            let offset = first as u32;
            for [a, b, c] in local {
                let t = [a + offset, b + offset, c + offset];
                mesh.triangles.push(if mirrored { [t[0], t[2], t[1]] } else { t });
                triangle_materials.push(material);
            }
        }
    }
    if skipped_modes > 0 {
        warnings.push(format!(
            "{name}: skipped {skipped_modes} primitives that are not triangle lists (points, lines, strips, fans)"
        ));
    }
    if any_normals {
        flat_normals_where_missing(&mut mesh, &mut normals, &mut uvs);
        mesh.normals = Some(normals);
    }
    if any_uvs {
        mesh.uvs = Some(uvs);
    }
    if uses_default {
        materials.push(Material::default());
    }
    mesh.triangle_materials = Some(triangle_materials);
    let meshes = if mesh.triangles.is_empty() { Vec::new() } else { vec![mesh] };
    Ok(Model { meshes, materials, textures, warnings })
}

/// Primitives without normals are flat-shaded: their triangles get vertices of their own
/// carrying the face normal (vertices with a zero normal mark them).
fn flat_normals_where_missing(mesh: &mut Mesh, normals: &mut Vec<Vec3>, uvs: &mut Vec<Vec2>) {
    if !normals.contains(&Vec3::ZERO) {
        return;
    }
    for t in 0..mesh.triangles.len() {
        let tri = mesh.triangles[t];
        if tri.iter().all(|&i| normals[i as usize] != Vec3::ZERO) {
            continue;
        }
        let [a, b, c] = tri.map(|i| mesh.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize_or(Vec3::Y);
        let mut new = [0u32; 3];
        for (k, &i) in tri.iter().enumerate() {
            new[k] = mesh.positions.len() as u32;
            mesh.positions.push(mesh.positions[i as usize]);
            uvs.push(uvs.get(i as usize).copied().unwrap_or(Vec2::ZERO));
            normals.push(n);
        }
        mesh.triangles[t] = new;
    }
    // Vertices left with a zero normal are no longer used by any triangle; give them a unit
    // normal so that validation (finite, unit) holds.
    for n in normals.iter_mut() {
        if *n == Vec3::ZERO {
            *n = Vec3::Y;
        }
    }
}

fn convert_material(index: usize, m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, alpha] = pbr.base_color_factor();
    let roughness = pbr.roughness_factor().clamp(0.0, 1.0);
    let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
    let shininess = (2.0 / roughness.powi(4).max(1e-3) - 2.0).clamp(1.0, 2000.0);
    let transparency = match m.alpha_mode() {
        gltf::material::AlphaMode::Blend => (1.0 - alpha).clamp(0.0, 1.0),
        _ => 0.0,
    };
    Material {
        name: m.name().map_or_else(|| format!("material {index}"), str::to_string),
        colour: Rgb::new(r, g, b).max(Rgb::ZERO),
        diffuse: 1.0 - 0.9 * metallic,
        specular: 1.0 - roughness,
        shininess,
        reflectivity: metallic * (1.0 - roughness),
        transparency,
        emission: Rgb::from_array(m.emissive_factor()).max(Rgb::ZERO),
        ..Material::default()
    }
}

fn read_buffers(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, FormatError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let place = format!("buffers[{}]", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                FormatError::malformed(path, place.clone(), "refers to the BIN chunk, which the file does not have")
            })?,
            gltf::buffer::Source::Uri(uri) => match read_uri(path, base, uri, &place)? {
                UriData::Bytes(b) => b,
                UriData::Missing(file) => {
                    return Err(FormatError::MissingFile {
                        file,
                        referenced_from: format!("{} ({place})", path.display()),
                    });
                }
            },
        };
        if data.len() < buffer.length() {
            return Err(FormatError::malformed(
                path,
                place,
                format!("holds {} bytes, but the file says {}", data.len(), buffer.length()),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

enum UriData {
    Bytes(Vec<u8>),
    Missing(PathBuf),
}

/// The bytes a URI names: a base64 `data:` URI or a file relative to the glTF file.
fn read_uri(path: &Path, base: &Path, uri: &str, place: &str) -> Result<UriData, FormatError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(FormatError::malformed(path, place, "only base64 data URIs are supported"));
        };
        return decode_base64(payload)
            .map(UriData::Bytes)
            .ok_or_else(|| FormatError::malformed(path, place, "invalid base64 in data URI"));
    }
    let relative = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")).unwrap_or(uri);
    if relative.contains("://") {
        return Err(FormatError::malformed(path, place, format!("unsupported URI scheme in `{uri}`")));
    }
    let file = base.join(percent_decode(relative));
    match std::fs::read(&file) {
        Ok(bytes) => Ok(UriData::Bytes(bytes)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(UriData::Missing(file)),
        Err(e) => Err(FormatError::io(file, e)),
    }
}

fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && let Some(v) = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (RFC 4648), padding optional, whitespace not allowed.
fn decode_base64(s: &str) -> Option<Vec<u8>> {
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        } as u32)
    };
    let s = s.trim_end_matches('=').as_bytes();
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    for chunk in s.chunks(4) {
        let mut acc = 0u32;
        for &c in chunk {
            acc = (acc << 6) | value(c)?;
        }
        match chunk.len() {
            4 => out.extend_from_slice(&acc.to_be_bytes()[1..]),
            3 => out.extend_from_slice(&(acc << 6).to_be_bytes()[1..3]),
            2 => out.push((acc >> 4) as u8),
            _ => return None,
        }
    }
    Some(out)
}

/// A base colour image, decoded to linear RGB. A missing image file is a warning (`None`).
fn read_image(
    path: &Path,
    base: &Path,
    image: &gltf::Image,
    buffers: &[Vec<u8>],
    warnings: &mut Vec<String>,
) -> Result<Option<TextureImage>, FormatError> {
    let place = format!("images[{}]", image.index());
    let bytes = match image.source() {
        gltf::image::Source::View { view, .. } => {
            let start = view.offset();
            let slice = buffers.get(view.buffer().index()).and_then(|b| b.get(start..start + view.length()));
            match slice {
                Some(s) => s.to_vec(),
                None => return Err(FormatError::malformed(path, place, "the buffer view lies outside its buffer")),
            }
        }
        gltf::image::Source::Uri { uri, .. } => match read_uri(path, base, uri, &place)? {
            UriData::Bytes(b) => b,
            UriData::Missing(file) => {
                warnings.push(format!(
                    "{}: texture {} ({place}) not found; its material uses the base colour factor",
                    file_name(path),
                    file.display()
                ));
                return Ok(None);
            }
        },
    };
    let decoded = image::load_from_memory(&bytes)
        .map_err(|e| FormatError::malformed(path, place, format!("cannot decode image: {e}")))?;
    texture_file::check_size(path, decoded.width(), decoded.height())?;
    let rgb = decoded.into_rgb32f();
    let texels = rgb.pixels().map(|p| Rgb::from_array(p.0.map(srgb_to_linear))).collect();
    Ok(Some(TextureImage { width: rgb.width(), height: rgb.height(), texels }))
}

#[cfg(test)]
mod tests;
