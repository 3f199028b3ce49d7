//! Shared helpers of the unit tests: random rays and hit comparison.

use crate::Hit;
use crate::procedural::{Mesh, Rng};
use glint_core::{Ray, Vec3};

/// Random rays around the unit cube: origins in [-0.5, 1.5]³ (many inside the geometry's
/// bounds), random directions with some axis-aligned ones (zero and negative-zero components),
/// and a mix of intervals.
pub fn random_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|i| {
            let origin = rng.next_vec3() * 2.0 - 0.5;
            let mut dir = rng.next_dir();
            match i % 8 {
                0 => dir = Vec3::new(0.0, 0.0, if dir.z < 0.0 { -1.0 } else { 1.0 }),
                1 => dir.y = if dir.y < 0.0 { -0.0 } else { 0.0 },
                2 => dir *= 7.5,
                _ => {}
            }
            let (tmin, tmax) = match i % 5 {
                0 => (0.0, rng.next_f32() * 2.0),
                1 => (rng.next_f32() * 0.5, f32::INFINITY),
                _ => (0.0, f32::INFINITY),
            };
            Ray::segment(origin, dir, tmin, tmax)
        })
        .collect()
}

/// Same closest hit: both none, or the same primitive, or the same distance within 1e-6
/// relative (ties between coincident or touching triangles).
pub fn same_hit(a: Option<Hit>, b: Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => {
            if a.prim == b.prim {
                a.t == b.t && a.u == b.u && a.v == b.v
            } else {
                (a.t - b.t).abs() <= 1e-6 * a.t.abs().max(b.t.abs()).max(1e-6)
            }
        }
        _ => false,
    }
}

/// Rays from outside aimed exactly at vertices and at points on shared edges of closed convex
/// meshes (centred on the origin): every one must hit (Woop 2013 leaves + Ize 2013 boxes).
/// Only rays that enter through the target are used — pointing inwards against every face
/// around it — since a ray grazing the silhouette may rightly miss when rounding puts the
/// target a hair outside.
pub fn shoot_at_edges(m: &Mesh, rays: usize, seed: u64, hit: impl Fn(&Ray) -> (bool, bool)) {
    let mut around: Vec<Vec<u32>> = vec![Vec::new(); m.positions.len()];
    for (i, t) in m.triangles.iter().enumerate() {
        for &v in t {
            around[v as usize].push(i as u32);
        }
    }
    let normal = |t: u32| {
        let [a, b, c] = m.triangles[t as usize].map(|i| m.positions[i as usize]);
        let n = (b - a).cross(c - a).normalize();
        if n.dot(a + b + c) < 0.0 { -n } else { n }
    };
    let mut rng = Rng::new(seed);
    let (mut failures, mut shot) = (0, 0);
    while shot < rays {
        let t = m.triangles[(rng.next_f32() * m.triangles.len() as f32) as usize % m.triangles.len()];
        let k = shot % 3;
        let (ia, ib) = (t[k], t[(k + 1) % 3]);
        let (a, b) = (m.positions[ia as usize], m.positions[ib as usize]);
        let on_vertex = shot % 2 == 0;
        let target = if on_vertex { a } else { a + (b - a) * rng.next_f32() };
        let origin = rng.next_dir() * (2.0 + 3.0 * rng.next_f32());
        let dir = target - origin;
        let faces = around[ia as usize].iter().filter(|&&f| on_vertex || m.triangles[f as usize].contains(&ib));
        if faces.clone().any(|&f| dir.normalize().dot(normal(f)) > -0.05) {
            continue;
        }
        shot += 1;
        let ray = Ray::new(origin, dir);
        let (closest, any) = hit(&ray);
        if !closest || !any {
            if failures < 5 {
                eprintln!("miss: {ray:?} target {target:?} closest {closest} any {any}");
            }
            failures += 1;
        }
    }
    assert_eq!(failures, 0, "{failures} of {rays} rays slipped through");
}
