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

mod buffers;

use crate::error::FormatError;
use crate::model::{self, Model, file_name};
use buffers::{read_buffers, read_image};
use glint_core::{Mat3, Mat4, Rgb, Vec2, Vec3};
use glint_scene::{Material, Mesh, Texture};
use gltf::Gltf;
use std::collections::HashMap;
use std::path::Path;
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

/// The file's materials, one world-space mesh of all its triangle primitives, and warnings.
fn read(path: &Path, data: &[u8]) -> Result<Model, FormatError> {
    let Gltf { document, blob } = Gltf::from_slice(data).map_err(|e| gltf_error(path, e))?;
    let base = path.parent().unwrap_or(Path::new(""));
    let mut warnings = Vec::new();
    let buffers = read_buffers(path, base, &document, blob)?;
    let (mut materials, textures) = read_materials(path, base, &document, &buffers, &mut warnings)?;
    let mut baked = Baked::new(path, materials.len() as u32);
    for_each_node(path, &document, |node, world| {
        let Some(gltf_mesh) = node.mesh() else { return Ok(()) };
        let frame = NodeFrame::new(world);
        for (p, primitive) in gltf_mesh.primitives().enumerate() {
            let place = format!("meshes[{}].primitives[{p}]", gltf_mesh.index());
            baked.primitive(path, &place, &primitive, &buffers, &frame)?;
        }
        Ok(())
    })?;
    let meshes = baked.finish(path, &mut warnings, &mut materials);
    Ok(Model { meshes, materials, textures, warnings })
}

/// The file's materials ([`convert_material`]) and the base colour textures they use, each
/// image read once however many materials share it.
fn read_materials(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    warnings: &mut Vec<String>,
) -> Result<(Vec<Material>, Vec<Texture>), FormatError> {
    let name = file_name(path);
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
                    let t = match read_image(path, base, &image, buffers, warnings)? {
                        Some(img) => {
                            textures.push(Texture::Image {
                                image: Arc::new(img),
                                scale: Vec2::ONE,
                                sampling: Default::default(),
                            });
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
    Ok((materials, textures))
}

/// Calls `visit(node, world_from_node)` for every node of the default scene (or else the first
/// scene, or else every root node), parents before children. A node reached twice is an error.
fn for_each_node<'a>(
    path: &Path,
    document: &'a gltf::Document,
    mut visit: impl FnMut(&gltf::Node<'a>, Mat4) -> Result<(), FormatError>,
) -> Result<(), FormatError> {
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
        visit(&node, world)?;
    }
    Ok(())
}

/// A node's transform and what follows from it for its vertices.
struct NodeFrame {
    world: Mat4,
    /// Inverse transpose of the linear part: normals' transform.
    normal_matrix: Mat3,
    /// The transform mirrors (negative determinant): triangles turn the other way round.
    mirrored: bool,
}

impl NodeFrame {
    fn new(world: Mat4) -> Self {
        let linear = Mat3::from_mat4(world);
        Self { world, normal_matrix: linear.inverse().transpose(), mirrored: linear.determinant() < 0.0 }
    }
}

/// The one world-space mesh every triangle primitive of the file is baked into. Normals and
/// uvs are kept per vertex for every primitive (zero where a primitive has none) and only
/// attached to the mesh when some primitive has them.
struct Baked {
    mesh: Mesh,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    triangle_materials: Vec<u32>,
    any_normals: bool,
    any_uvs: bool,
    /// The material of primitives that name none: one past the file's materials.
    default_material: u32,
    uses_default: bool,
    /// Primitives that are not triangle lists.
    skipped_modes: usize,
}

impl Baked {
    fn new(path: &Path, default_material: u32) -> Self {
        Self {
            mesh: Mesh {
                name: path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
                ..Mesh::default()
            },
            normals: Vec::new(),
            uvs: Vec::new(),
            triangle_materials: Vec::new(),
            any_normals: false,
            any_uvs: false,
            default_material,
            uses_default: false,
            skipped_modes: 0,
        }
    }

    /// Appends one primitive (`place` names it in messages), its vertices in world space.
    fn primitive(
        &mut self,
        path: &Path,
        place: &str,
        primitive: &gltf::Primitive,
        buffers: &[Vec<u8>],
        frame: &NodeFrame,
    ) -> Result<(), FormatError> {
        if primitive.mode() != gltf::mesh::Mode::Triangles {
            self.skipped_modes += 1;
            return Ok(());
        }
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let Some(positions) = reader.read_positions() else {
            return Err(FormatError::malformed(path, place, "no POSITION data (or its buffer is too short)"));
        };
        let first = self.mesh.positions.len();
        self.positions(path, place, positions, &frame.world)?;
        let count = self.mesh.positions.len() - first;
        let local = match reader.read_indices() {
            Some(indices) => indexed_triangles(path, place, indices.into_u32().collect(), count)?,
            None => unindexed_triangles(path, place, count)?,
        };
        self.normals(path, place, reader.read_normals(), count, &frame.normal_matrix)?;
        self.uvs(path, place, reader.read_tex_coords(0).map(|t| t.into_f32()), count)?;
        if let Some(k) = self.normals[first..].iter().position(|n| !n.is_finite()) {
            return Err(FormatError::malformed(path, format!("{place} vertex {k}"), "normal is NaN or infinite"));
        }
        if let Some(k) = self.uvs[first..].iter().position(|t| !t.is_finite()) {
            return Err(FormatError::malformed(path, format!("{place} vertex {k}"), "TEXCOORD_0 is NaN or infinite"));
        }
        let material = match primitive.material().index() {
            Some(i) => i as u32,
            None => {
                self.uses_default = true;
                self.default_material
            }
        };
        let offset = first as u32;
        for [a, b, c] in local {
            let t = [a + offset, b + offset, c + offset];
            self.mesh.triangles.push(if frame.mirrored { [t[0], t[2], t[1]] } else { t });
            self.triangle_materials.push(material);
        }
        Ok(())
    }

    fn positions(
        &mut self,
        path: &Path,
        place: &str,
        positions: impl Iterator<Item = [f32; 3]>,
        world: &Mat4,
    ) -> Result<(), FormatError> {
        for (k, p) in positions.enumerate() {
            let v = world.transform_point3(Vec3::from_array(p));
            if !v.is_finite() {
                return Err(FormatError::malformed(path, format!("{place} vertex {k}"), "position is NaN or infinite"));
            }
            self.mesh.positions.push(v);
        }
        if self.mesh.positions.len() > u32::MAX as usize {
            return Err(FormatError::limits(path, "more vertices than glint can index"));
        }
        Ok(())
    }

    /// The primitive's `count` normals, turned by `normal_matrix`; zeros when it has none.
    fn normals(
        &mut self,
        path: &Path,
        place: &str,
        normals: Option<impl Iterator<Item = [f32; 3]>>,
        count: usize,
        normal_matrix: &Mat3,
    ) -> Result<(), FormatError> {
        match normals {
            Some(ns) => {
                self.any_normals = true;
                let before = self.normals.len();
                self.normals.extend(ns.map(|n| (*normal_matrix * Vec3::from_array(n)).normalize_or(Vec3::Y)));
                if self.normals.len() - before != count {
                    return Err(FormatError::malformed(path, place, "NORMAL and POSITION counts differ"));
                }
            }
            None => self.normals.resize(self.mesh.positions.len(), Vec3::ZERO),
        }
        Ok(())
    }

    /// The primitive's `count` texture coordinates (set 0), v flipped; zeros when it has none.
    fn uvs(
        &mut self,
        path: &Path,
        place: &str,
        uvs: Option<impl Iterator<Item = [f32; 2]>>,
        count: usize,
    ) -> Result<(), FormatError> {
        match uvs {
            Some(ts) => {
                self.any_uvs = true;
                let before = self.uvs.len();
                self.uvs.extend(ts.map(|[u, v]| Vec2::new(u, 1.0 - v)));
                if self.uvs.len() - before != count {
                    return Err(FormatError::malformed(path, place, "TEXCOORD_0 and POSITION counts differ"));
                }
            }
            None => self.uvs.resize(self.mesh.positions.len(), Vec2::ZERO),
        }
        Ok(())
    }

    /// The mesh (none when no triangle was read), with normals and uvs where some primitive
    /// had them; the default material joins `materials` when some primitive uses it.
    fn finish(mut self, path: &Path, warnings: &mut Vec<String>, materials: &mut Vec<Material>) -> Vec<Mesh> {
        if self.skipped_modes > 0 {
            warnings.push(format!(
                "{}: skipped {} primitives that are not triangle lists (points, lines, strips, fans)",
                file_name(path),
                self.skipped_modes
            ));
        }
        if self.any_normals {
            flat_normals_where_missing(&mut self.mesh, &mut self.normals, &mut self.uvs);
            self.mesh.normals = Some(self.normals);
        }
        if self.any_uvs {
            self.mesh.uvs = Some(self.uvs);
        }
        if self.uses_default {
            materials.push(Material::default());
        }
        self.mesh.triangle_materials = Some(self.triangle_materials);
        if self.mesh.triangles.is_empty() { Vec::new() } else { vec![self.mesh] }
    }
}

/// Triangles of an indexed primitive of `count` vertices (indices local to it).
fn indexed_triangles(path: &Path, place: &str, indices: Vec<u32>, count: usize) -> Result<Vec<[u32; 3]>, FormatError> {
    if !indices.len().is_multiple_of(3) {
        return Err(FormatError::malformed(path, place, format!("{} indices do not make triangles", indices.len())));
    }
    if let Some(k) = indices.iter().position(|&i| i as usize >= count) {
        return Err(FormatError::malformed(
            path,
            format!("{place} index {k}"),
            format!("vertex {} is out of range ({count} vertices)", indices[k]),
        ));
    }
    Ok(indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect())
}

/// Triangles of a primitive without indices: every three vertices.
fn unindexed_triangles(path: &Path, place: &str, count: usize) -> Result<Vec<[u32; 3]>, FormatError> {
    if !count.is_multiple_of(3) {
        return Err(FormatError::malformed(path, place, format!("{count} vertices do not make triangles")));
    }
    Ok((0..count as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect())
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
        // glTF's doubleSided: both faces are seen (and emit).
        two_sided: m.double_sided(),
        ..Material::default()
    }
}

#[cfg(test)]
mod tests;
