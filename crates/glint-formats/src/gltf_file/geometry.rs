//! A glTF file's triangle primitives baked into one world-space mesh with per-triangle
//! materials: positions by the node's world transform, normals by its inverse transpose,
//! winding turned where the transform mirrors, texture coordinates flipped (v → 1 − v: glTF's
//! v runs down the image, glint's up). Triangle lists, strips and fans are read (strips and
//! fans as the spec unrolls them), indexed or not; points and lines are skipped with a warning.
//! Primitives without normals are shaded flat (as glTF specifies). Every accessor is checked
//! against its buffer view before it is read.

use super::buffers::check_accessor;
use crate::error::FormatError;
use crate::model::file_name;
use glint_core::{Mat3, Mat4, Vec2, Vec3};
use glint_scene::{Material, Mesh};
use std::path::Path;

/// A node's transform and what follows from it for its vertices.
pub(super) struct NodeFrame {
    world: Mat4,
    /// Inverse transpose of the linear part: normals' transform.
    normal_matrix: Mat3,
    /// The transform mirrors (negative determinant): triangles turn the other way round.
    mirrored: bool,
}

impl NodeFrame {
    pub(super) fn new(world: Mat4) -> Self {
        let linear = Mat3::from_mat4(world);
        Self { world, normal_matrix: linear.inverse().transpose(), mirrored: linear.determinant() < 0.0 }
    }
}

/// The one world-space mesh every triangle primitive of the file is baked into. Normals and
/// uvs are kept per vertex for every primitive (zero where a primitive has none) and only
/// attached to the mesh when some primitive has them.
pub(super) struct Baked {
    mesh: Mesh,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    triangle_materials: Vec<u32>,
    any_normals: bool,
    any_uvs: bool,
    /// The material of primitives that name none: one past the file's materials.
    default_material: u32,
    uses_default: bool,
    /// Primitives of points or lines, by place.
    skipped: Vec<String>,
}

impl Baked {
    pub(super) fn new(path: &Path, default_material: u32) -> Self {
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
            skipped: Vec::new(),
        }
    }

    /// Appends one primitive (`place` names it in messages), its vertices in world space, its
    /// texture coordinates from set `uv_set` (its material's).
    pub(super) fn primitive(
        &mut self,
        path: &Path,
        place: &str,
        primitive: &gltf::Primitive,
        buffers: &[Vec<u8>],
        frame: &NodeFrame,
        uv_set: u32,
    ) -> Result<(), FormatError> {
        use gltf::mesh::Mode;
        let mode = primitive.mode();
        if !matches!(mode, Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan) {
            self.skipped.push(place.to_string());
            return Ok(());
        }
        let Some(position) = primitive.get(&gltf::Semantic::Positions) else {
            return Err(FormatError::malformed(path, place, "no POSITION attribute"));
        };
        let normal = primitive.get(&gltf::Semantic::Normals);
        let uv = primitive.get(&gltf::Semantic::TexCoords(uv_set));
        for accessor in [Some(position.clone()), normal.clone(), uv.clone(), primitive.indices()].iter().flatten() {
            check_accessor(path, accessor)?;
        }
        // The gltf crate's readers assume the types the specification allows (it reaches
        // `unreachable!` on others): check them here, naming the accessor.
        use gltf::accessor::{DataType as T, Dimensions as D};
        expect_kind(path, place, "POSITION", &position, D::Vec3, &[T::F32])?;
        if let Some(n) = &normal {
            expect_kind(path, place, "NORMAL", n, D::Vec3, &[T::F32])?;
        }
        if let Some(t) = &uv {
            expect_kind(path, place, "TEXCOORD", t, D::Vec2, &[T::F32, T::U8, T::U16])?;
        }
        if let Some(i) = primitive.indices() {
            expect_kind(path, place, "indices", &i, D::Scalar, &[T::U8, T::U16, T::U32])?;
        }
        let reader = primitive.reader(|b| buffers.get(b.index()).map(Vec::as_slice));
        let Some(positions) = reader.read_positions() else {
            return Err(FormatError::malformed(path, place, "POSITION cannot be read (its buffer is missing)"));
        };
        let first = self.mesh.positions.len();
        self.positions(path, place, positions, &frame.world)?;
        let count = self.mesh.positions.len() - first;
        let indices: Vec<u32> = match reader.read_indices() {
            Some(indices) => indices.into_u32().collect(),
            None => (0..count as u32).collect(),
        };
        if let Some(k) = indices.iter().position(|&i| i as usize >= count) {
            return Err(FormatError::malformed(
                path,
                format!("{place} index {k}"),
                format!("vertex {} is out of range ({count} vertices)", indices[k]),
            ));
        }
        let local = match mode {
            Mode::TriangleStrip => strip_triangles(&indices),
            Mode::TriangleFan => fan_triangles(&indices),
            _ => list_triangles(path, place, &indices)?,
        };
        self.normals(path, place, reader.read_normals(), count, &frame.normal_matrix)?;
        let set_name = format!("TEXCOORD_{uv_set}");
        self.uvs(path, place, &set_name, reader.read_tex_coords(uv_set).map(|t| t.into_f32()), count)?;
        if let Some(k) = self.normals[first..].iter().position(|n| !n.is_finite()) {
            return Err(FormatError::malformed(path, format!("{place} vertex {k}"), "normal is NaN or infinite"));
        }
        if let Some(k) = self.uvs[first..].iter().position(|t| !t.is_finite()) {
            return Err(FormatError::malformed(
                path,
                format!("{place} vertex {k}"),
                format!("{set_name} is NaN or infinite"),
            ));
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

    /// The primitive's `count` texture coordinates (of `set`), v flipped; zeros when it has none.
    fn uvs(
        &mut self,
        path: &Path,
        place: &str,
        set: &str,
        uvs: Option<impl Iterator<Item = [f32; 2]>>,
        count: usize,
    ) -> Result<(), FormatError> {
        match uvs {
            Some(ts) => {
                self.any_uvs = true;
                let before = self.uvs.len();
                self.uvs.extend(ts.map(|[u, v]| Vec2::new(u, 1.0 - v)));
                if self.uvs.len() - before != count {
                    return Err(FormatError::malformed(path, place, format!("{set} and POSITION counts differ")));
                }
            }
            None => self.uvs.resize(self.mesh.positions.len(), Vec2::ZERO),
        }
        Ok(())
    }

    /// The mesh (none when no triangle was read), with normals and uvs where some primitive
    /// had them; the default material joins `materials` when some primitive uses it.
    pub(super) fn finish(
        mut self,
        path: &Path,
        warnings: &mut Vec<String>,
        materials: &mut Vec<Material>,
    ) -> Vec<Mesh> {
        if !self.skipped.is_empty() {
            let more =
                if self.skipped.len() > 3 { format!(" and {} more", self.skipped.len() - 3) } else { String::new() };
            warnings.push(format!(
                "{}: skipped {} primitives of points or lines, which glint does not render ({}{more})",
                file_name(path),
                self.skipped.len(),
                self.skipped[..self.skipped.len().min(3)].join(", ")
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

/// Triangles of a triangle list (indices local to the primitive, checked in range).
fn list_triangles(path: &Path, place: &str, indices: &[u32]) -> Result<Vec<[u32; 3]>, FormatError> {
    if !indices.len().is_multiple_of(3) {
        return Err(FormatError::malformed(
            path,
            place,
            format!(
                "{} vertex references (indices, or vertices without them) do not make whole triangles",
                indices.len()
            ),
        ));
    }
    Ok(indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect())
}

/// Triangles of a strip, as glTF unrolls it: triangle i is (v_i, v_{i+1+i%2}, v_{i+2−i%2}),
/// so that every triangle turns the same way round.
fn strip_triangles(indices: &[u32]) -> Vec<[u32; 3]> {
    (0..indices.len().saturating_sub(2)).map(|i| [indices[i], indices[i + 1 + i % 2], indices[i + 2 - i % 2]]).collect()
}

/// Triangles of a fan, as glTF unrolls it: triangle i is (v_{i+1}, v_{i+2}, v_0).
fn fan_triangles(indices: &[u32]) -> Vec<[u32; 3]> {
    (0..indices.len().saturating_sub(2)).map(|i| [indices[i + 1], indices[i + 2], indices[0]]).collect()
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

/// Refuse an accessor whose type the specification does not allow for `what`.
fn expect_kind(
    path: &Path,
    place: &str,
    what: &str,
    accessor: &gltf::Accessor,
    dimensions: gltf::accessor::Dimensions,
    types: &[gltf::accessor::DataType],
) -> Result<(), FormatError> {
    if accessor.dimensions() == dimensions && types.contains(&accessor.data_type()) {
        return Ok(());
    }
    Err(FormatError::malformed(
        path,
        format!("{place} {what} (accessors[{}])", accessor.index()),
        format!(
            "is {:?} of {:?}; glTF allows {dimensions:?} of {}",
            accessor.dimensions(),
            accessor.data_type(),
            types.iter().map(|t| format!("{t:?}")).collect::<Vec<_>>().join(" or ")
        ),
    ))
}

#[cfg(test)]
pub(super) mod tests_support {
    pub fn strip(indices: &[u32]) -> Vec<[u32; 3]> {
        super::strip_triangles(indices)
    }

    pub fn fan(indices: &[u32]) -> Vec<[u32; 3]> {
        super::fan_triangles(indices)
    }
}
