//! Indexed triangle meshes.

use glint_core::{Bounds3, Rgb, Vec2, Vec3};

/// The largest vertex coordinate (in magnitude) a mesh may have. Ray–triangle tests multiply
/// coordinates in pairs (edge cross products, determinants), which stays finite in f32 up to
/// about 1e19; beyond it a triangle's area overflows and it would read as degenerate.
pub const MAX_COORDINATE: f32 = 1e18;

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (unit), if the file gave them.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates.
    pub uvs: Option<Vec<Vec2>>,
    pub triangles: Vec<[u32; 3]>,
    /// Per-triangle material index into `Scene::materials`; `None` uses the object's material.
    pub triangle_materials: Option<Vec<u32>>,
    /// Values a file attaches to vertices or faces (Mitsuba's mesh attributes, read from PLY
    /// properties: `vertex_color`, `face_color`, …), read by [`crate::Texture::MeshAttribute`].
    pub attributes: Vec<MeshAttribute>,
}

/// A named value per vertex or per triangle, one or three channels (one is stored grey).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttribute {
    /// Mitsuba's name: `vertex_*` for per-vertex values, `face_*` for per-face ones.
    pub name: String,
    /// One per vertex, or one per triangle (a polygon's value repeated over its triangles).
    pub values: Vec<Rgb>,
}

impl MeshAttribute {
    /// Is this a per-face attribute (by Mitsuba's naming)?
    #[must_use]
    pub fn per_face(&self) -> bool {
        self.name.starts_with("face_")
    }
}

impl Mesh {
    pub fn bounds(&self) -> Bounds3 {
        Bounds3::from_points(self.positions.iter().copied())
    }

    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        let [a, b, c] = self.triangles[i];
        [self.positions[a as usize], self.positions[b as usize], self.positions[c as usize]]
    }

    /// Twice the area of triangle `i`.
    pub fn double_area(&self, i: usize) -> f32 {
        let [a, b, c] = self.triangle(i);
        (b - a).cross(c - a).length()
    }

    /// Remove triangles of zero area (and those whose area is not a finite number); returns how
    /// many were removed. Per-triangle materials and face attributes follow their triangles.
    pub fn remove_degenerate_triangles(&mut self) -> usize {
        let keep: Vec<bool> = (0..self.triangles.len())
            .map(|i| {
                let a = self.double_area(i);
                a.is_finite() && a > 0.0
            })
            .collect();
        self.retain_triangles(&keep)
    }

    /// Remove every triangle that repeats an earlier one: the same three vertex positions in
    /// the same winding (any rotation of its corners) and the same material. Returns how many
    /// were removed. Exact copies add nothing to the picture, and a BVH cannot separate boxes
    /// that coincide: a ray that reaches them tests every copy (20 000 copies of one triangle
    /// took 4.4 s at 160 × 120). The first copy is kept, with its normals and uvs.
    pub fn remove_duplicate_triangles(&mut self) -> usize {
        let mut seen = std::collections::HashSet::with_capacity(self.triangles.len());
        let keep: Vec<bool> = (0..self.triangles.len())
            .map(|i| {
                let corners = self.triangle(i).map(|p| p.to_array().map(f32::to_bits));
                // The rotation that starts at the smallest corner: one key per winding.
                let first = (0..3).min_by_key(|&k| corners[k]).unwrap_or(0);
                let key = (
                    [corners[first], corners[(first + 1) % 3], corners[(first + 2) % 3]],
                    self.triangle_materials.as_ref().map(|m| m[i]),
                );
                seen.insert(key)
            })
            .collect();
        self.retain_triangles(&keep)
    }

    /// The first vertex whose position lies beyond ±[`MAX_COORDINATE`] (or is not finite), with
    /// its index.
    #[must_use]
    pub fn first_out_of_range_vertex(&self) -> Option<(usize, Vec3)> {
        self.positions
            .iter()
            .position(|p| !p.is_finite() || p.abs().max_element() > MAX_COORDINATE)
            .map(|i| (i, self.positions[i]))
    }

    /// What is wrong with [`Mesh::first_out_of_range_vertex`], in words (vertices numbered
    /// from 1), for a loader to put its file and place before.
    pub fn out_of_range_message(&self) -> Option<String> {
        let (i, p) = self.first_out_of_range_vertex()?;
        Some(format!(
            "vertex {} is at ({:e}, {:e}, {:e}): glint takes coordinates within ±{MAX_COORDINATE:e} (the scene's \
             units can be scaled down)",
            i + 1,
            p.x,
            p.y,
            p.z
        ))
    }

    fn retain_triangles(&mut self, keep: &[bool]) -> usize {
        let removed = keep.iter().filter(|k| !**k).count();
        if removed == 0 {
            return 0;
        }
        let mut k = keep.iter();
        self.triangles.retain(|_| *k.next().unwrap_or(&true));
        if let Some(m) = &mut self.triangle_materials {
            let mut k = keep.iter();
            m.retain(|_| *k.next().unwrap_or(&true));
        }
        for a in self.attributes.iter_mut().filter(|a| a.per_face()) {
            let mut k = keep.iter();
            a.values.retain(|_| *k.next().unwrap_or(&true));
        }
        removed
    }

    /// The attribute `name` at barycentric position (`b1`, `b2`) of triangle `triangle`: the
    /// face's value, or the vertices' values interpolated. `None` when the mesh has no such
    /// attribute.
    #[must_use]
    pub fn attribute_at(&self, name: &str, triangle: usize, b1: f32, b2: f32) -> Option<Rgb> {
        let a = self.attributes.iter().find(|a| a.name == name)?;
        if a.per_face() {
            return a.values.get(triangle).copied();
        }
        let [i0, i1, i2] = self.triangles.get(triangle)?.map(|i| i as usize);
        let (v0, v1, v2) = (*a.values.get(i0)?, *a.values.get(i1)?, *a.values.get(i2)?);
        Some(v0 * (1.0 - b1 - b2) + v1 * b1 + v2 * b2)
    }

    /// Area-weighted vertex normals, for meshes that have none.
    pub fn compute_vertex_normals(&mut self) {
        let mut n = vec![Vec3::ZERO; self.positions.len()];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.positions[i as usize]);
            let face = (b - a).cross(c - a);
            for &i in t {
                n[i as usize] += face;
            }
        }
        self.normals = Some(n.into_iter().map(|v| v.normalize_or(Vec3::Y)).collect());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degenerate_triangles_are_removed_with_their_materials() {
        let mut m = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::X * 2.0],
            triangles: vec![[0, 1, 2], [0, 1, 3], [1, 2, 0]],
            triangle_materials: Some(vec![5, 6, 7]),
            ..Default::default()
        };
        assert_eq!(m.remove_degenerate_triangles(), 1);
        assert_eq!(m.triangles, vec![[0, 1, 2], [1, 2, 0]]);
        assert_eq!(m.triangle_materials, Some(vec![5, 7]));
    }

    #[test]
    fn duplicate_triangles_are_removed_whatever_their_indices_or_rotation() {
        let mut m = Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ZERO, Vec3::X, Vec3::Y],
            // 1: same corners through other indices; 2: rotated; 3: flipped winding (kept);
            // 4: same corners, other material (kept); 5: copy of 0.
            triangles: vec![[0, 1, 2], [3, 4, 5], [1, 2, 0], [0, 2, 1], [0, 1, 2], [0, 1, 2]],
            triangle_materials: Some(vec![7, 7, 7, 7, 8, 7]),
            ..Default::default()
        };
        assert_eq!(m.remove_duplicate_triangles(), 3);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 1], [0, 1, 2]]);
        assert_eq!(m.triangle_materials, Some(vec![7, 7, 8]));
        let mut copies =
            Mesh { positions: m.positions.clone(), triangles: vec![[0, 1, 2]; 20_000], ..Default::default() };
        assert_eq!(copies.remove_duplicate_triangles(), 19_999);
    }

    #[test]
    fn far_vertices_are_found() {
        let mut m = Mesh { positions: vec![Vec3::ZERO, Vec3::splat(-1e18), Vec3::X], ..Default::default() };
        assert_eq!(m.first_out_of_range_vertex(), None);
        m.positions.push(Vec3::new(0.0, 1e30, 0.0));
        assert_eq!(m.first_out_of_range_vertex(), Some((3, Vec3::new(0.0, 1e30, 0.0))));
        m.positions[0] = Vec3::NAN;
        assert_eq!(m.first_out_of_range_vertex().map(|(i, _)| i), Some(0));
    }
}
