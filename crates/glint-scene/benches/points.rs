//! Milliseconds to make a point cloud renderable: `prepare` (k-d tree, PCA normals and radii) on
//! points on a sphere, and `sample_mesh` drawing as many points from a mesh. Results are checked
//! against the analytic sphere (normals radial within 3°, radii finite and positive) before they
//! are timed. `POINTS_N` sets the size (default 1 M).
//! Run: `cargo bench -p glint-scene --bench points`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glint_core::random::{hash4, unit_float};
use glint_core::sampling::sample_uniform_sphere;
use glint_core::{Vec2, Vec3};
use glint_scene::{EstimateSettings, Mesh, Orientation, PointCloud, prepare, sample_mesh};
use std::hint::black_box;

fn sphere_cloud(n: usize) -> PointCloud {
    let positions = (0..n as u64)
        .map(|i| 10.0 * sample_uniform_sphere(Vec2::new(unit_float(hash4(i, 0, 0, 7)), unit_float(hash4(i, 0, 1, 7)))))
        .collect();
    PointCloud {
        name: "sphere".into(),
        positions,
        orientation: Orientation::TowardSensor(Vec3::ZERO),
        ..PointCloud::default()
    }
}

/// A UV sphere of about 20 k triangles.
fn sphere_mesh() -> Mesh {
    let (rings, segments) = (100u32, 100u32);
    let mut positions = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            positions.push(Vec3::new(theta.sin() * phi.cos(), theta.cos(), theta.sin() * phi.sin()));
        }
    }
    let mut triangles = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * segments + s, r * segments + (s + 1) % segments);
            let (c, d) = (a + segments, b + segments);
            triangles.push([a, b, d]);
            triangles.push([a, d, c]);
        }
    }
    let mut mesh = Mesh { name: "uv sphere".into(), positions, triangles, ..Mesh::default() };
    mesh.remove_degenerate_triangles();
    mesh.compute_vertex_normals();
    mesh
}

fn bench(c: &mut Criterion) {
    let n = std::env::var("POINTS_N").ok().and_then(|v| v.parse().ok()).unwrap_or(1_000_000);
    let settings = EstimateSettings::default();
    let cloud = sphere_cloud(n);

    let mut checked = cloud.clone();
    prepare(&mut checked, &settings, &|_| {});
    checked.validate().unwrap();
    for (p, normal) in checked.positions.iter().zip(checked.normals.as_ref().unwrap()) {
        let cos = normal.dot(-p.normalize());
        assert!(cos > 3f32.to_radians().cos(), "normal at {p} is {normal}, not radial");
    }

    let mut group = c.benchmark_group("points");
    group.sample_size(10);
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function(format!("prepare normals+radii {n}"), |b| {
        b.iter_batched(
            || cloud.clone(),
            |mut cloud| {
                prepare(&mut cloud, &settings, &|_| {});
                black_box(cloud)
            },
            criterion::BatchSize::LargeInput,
        )
    });

    let mesh = sphere_mesh();
    let sampled = sample_mesh(&mesh, n, 1).unwrap();
    sampled.validate().unwrap();
    assert!(sampled.positions.iter().all(|p| (p.length() - 1.0).abs() < 1e-3));
    group.bench_function(format!("sample_mesh {n}"), |b| b.iter(|| black_box(sample_mesh(&mesh, n, 1).unwrap())));
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
