//! Indexed triangle meshes.

use glint_core::{Bounds3, Vec2, Vec3};

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
    /// many were removed. Per-triangle materials follow their triangles.
    pub fn remove_degenerate_triangles(&mut self) -> usize {
        let keep: Vec<bool> = (0..self.triangles.len())
            .map(|i| {
                let a = self.double_area(i);
                a.is_finite() && a > 0.0
            })
            .collect();
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
        removed
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
}
