//! Procedural meshes with a fixed seed, for tests and benchmarks: a subdivided icosphere and a
//! tessellated cube (closed, with shared vertices: the watertightness tests shoot at their
//! edges), a displaced sphere (the benchmark mesh) and random triangle soups.

use glint_core::Vec3;
use glint_core::random::{mix64, unit_float};
use std::collections::HashMap;

/// A deterministic stream of uniform floats in [0, 1).
#[derive(Clone, Debug)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Self(mix64(seed ^ 0x5851_f42d_4c95_7f2d))
    }
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        unit_float(mix64(self.0))
    }
    pub fn next_vec3(&mut self) -> Vec3 {
        Vec3::new(self.next_f32(), self.next_f32(), self.next_f32())
    }
    /// A uniformly distributed unit vector.
    pub fn next_dir(&mut self) -> Vec3 {
        let z = 1.0 - 2.0 * self.next_f32();
        let r = (1.0 - z * z).max(0.0).sqrt();
        let phi = std::f32::consts::TAU * self.next_f32();
        Vec3::new(r * phi.cos(), r * phi.sin(), z)
    }
}

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// Unit icosphere: the icosahedron with every triangle split into four `subdivisions` times
/// (20·4^s triangles), vertices shared between neighbours.
pub fn icosphere(subdivisions: u32) -> Mesh {
    let t = (1.0 + 5f32.sqrt()) / 2.0;
    let mut positions: Vec<Vec3> = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .iter()
    .map(|&(x, y, z)| Vec3::new(x, y, z).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut midpoint = |a: u32, b: u32, positions: &mut Vec<Vec3>| {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                let p = ((positions[a as usize] + positions[b as usize]) * 0.5).normalize();
                positions.push(p);
                positions.len() as u32 - 1
            })
        };
        let mut next = Vec::with_capacity(triangles.len() * 4);
        for &[a, b, c] in &triangles {
            let ab = midpoint(a, b, &mut positions);
            let bc = midpoint(b, c, &mut positions);
            let ca = midpoint(c, a, &mut positions);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        triangles = next;
    }
    Mesh { positions, triangles }
}

/// The cube [-1, 1]³ with each face split into an `n × n` grid of quads (two triangles each),
/// vertices shared along face borders: 12 n² triangles.
pub fn tessellated_cube(n: u32) -> Mesh {
    let n = n.max(1);
    let mut index: HashMap<[i64; 3], u32> = HashMap::new();
    let mut mesh = Mesh::default();
    let mut vertex = |p: Vec3, mesh: &mut Mesh| {
        // Key on the exact lattice coordinates so that face borders share vertices.
        let key = [(p.x * n as f32).round() as i64, (p.y * n as f32).round() as i64, (p.z * n as f32).round() as i64];
        *index.entry(key).or_insert_with(|| {
            mesh.positions.push(p);
            mesh.positions.len() as u32 - 1
        })
    };
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let (u_axis, v_axis) = ((axis + 1) % 3, (axis + 2) % 3);
            let point = |i: u32, j: u32| {
                let mut p = [0.0f32; 3];
                p[axis] = side;
                p[u_axis] = -1.0 + 2.0 * i as f32 / n as f32;
                p[v_axis] = -1.0 + 2.0 * j as f32 / n as f32;
                Vec3::from_array(p)
            };
            for i in 0..n {
                for j in 0..n {
                    let a = vertex(point(i, j), &mut mesh);
                    let b = vertex(point(i + 1, j), &mut mesh);
                    let c = vertex(point(i + 1, j + 1), &mut mesh);
                    let d = vertex(point(i, j + 1), &mut mesh);
                    mesh.triangles.push([a, b, c]);
                    mesh.triangles.push([a, c, d]);
                }
            }
        }
    }
    mesh
}

/// A sphere of about `target` triangles (a latitude–longitude grid closed by a vertex at each
/// pole) with a smooth, fixed displacement of its radius: the benchmark mesh.
pub fn displaced_sphere(target: usize) -> Mesh {
    // About 2 · rings · segments triangles with segments = 2 rings.
    let rings = ((target as f32 / 4.0).sqrt().ceil() as u32).max(3);
    let segments = 2 * rings;
    let displace =
        |d: Vec3| d * (1.0 + 0.15 * (5.0 * d.x).sin() * (7.0 * d.y).cos() + 0.05 * (17.0 * d.z + 3.0 * d.x).sin());
    let mut mesh = Mesh::default();
    mesh.positions.push(displace(Vec3::Y));
    for r in 1..rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            mesh.positions.push(displace(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin())));
        }
    }
    mesh.positions.push(displace(-Vec3::Y));
    let south = mesh.positions.len() as u32 - 1;
    // Vertex of ring r (1..rings) and segment s.
    let idx = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    for s in 0..segments {
        mesh.triangles.push([0, idx(1, s + 1), idx(1, s)]);
        mesh.triangles.push([south, idx(rings - 1, s), idx(rings - 1, s + 1)]);
    }
    for r in 1..rings - 1 {
        for s in 0..segments {
            let (a, b, c, d) = (idx(r, s), idx(r, s + 1), idx(r + 1, s + 1), idx(r + 1, s));
            mesh.triangles.push([a, b, c]);
            mesh.triangles.push([a, c, d]);
        }
    }
    mesh
}

/// `n` random triangles in the unit cube, each with edges up to `size`.
pub fn triangle_soup(n: usize, size: f32, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let mut mesh = Mesh::default();
    for i in 0..n as u32 {
        let c = rng.next_vec3();
        for _ in 0..3 {
            mesh.positions.push(c + (rng.next_vec3() - 0.5) * size);
        }
        mesh.triangles.push([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every edge of a closed mesh is shared by exactly two triangles.
    fn assert_closed(m: &Mesh) {
        let mut edges: HashMap<(u32, u32), u32> = HashMap::new();
        for t in &m.triangles {
            for k in 0..3 {
                let (a, b) = (t[k], t[(k + 1) % 3]);
                *edges.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        assert!(edges.values().all(|&c| c == 2));
    }

    #[test]
    fn closed_meshes_are_closed() {
        let ico = icosphere(2);
        assert_eq!(ico.triangles.len(), 320);
        assert_closed(&ico);
        let cube = tessellated_cube(3);
        assert_eq!(cube.triangles.len(), 108);
        assert_closed(&cube);
        let s = displaced_sphere(1000);
        assert_closed(&s);
    }
}
