//! Nanoseconds per sky lookup (issue 3's measure): seamless bilinear and mip-mapped trilinear
//! (one at a time, and eight at once: `cube_mip8`, `latlong_mip8`), on camera-ray directions in pixel order
//! (coherent) and on random directions, for a cube map
//! of 1024² faces and a 2048×1024 lat-long map. Lookups are validated against the scalar
//! definitions before they are timed. Run: `cargo bench -p glint-scene --bench sky`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glint_core::random::{hash4, unit_float};
use glint_core::sampling::sample_uniform_sphere;
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::{Camera, CubeMap, Fov, LatLongMap};

/// Directions per `lookup_filtered8` call.
const LANES: usize = 8;
use std::hint::black_box;

const COUNT: usize = 640 * 360;

fn pattern(d: Vec3) -> Rgb {
    Rgb::new((d.x * 9.0).sin().abs(), (d.y * 7.0).cos().abs(), (d.z * 5.0 + d.x).sin().abs())
}

/// Directions of a 640×360 camera (60° vertical field), in pixel order.
fn coherent() -> Vec<Vec3> {
    let cam = Camera {
        position: Vec3::ZERO,
        forward: Vec3::new(0.3, 0.1, -1.0),
        up: Vec3::Y,
        fov: Fov::Vertical(60.0),
        lens: glint_scene::Lens::Pinhole,
    };
    let rays = cam.rays(640, 360);
    (0..COUNT).map(|i| rays.ray(Vec2::new((i % 640) as f32 + 0.5, (i / 640) as f32 + 0.5)).dir).collect()
}

fn random() -> Vec<Vec3> {
    (0..COUNT as u64)
        .map(|i| {
            let u = Vec2::new(unit_float(hash4(i, 0, 0, 7)), unit_float(hash4(i, 1, 0, 7)));
            sample_uniform_sphere(u)
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let cube = CubeMap::from_fn(std::env::var("SKY_N").ok().and_then(|v| v.parse().ok()).unwrap_or(1024), pattern);
    let latlong = LatLongMap::from_fn(1024, pattern);
    // Validate: at texel-sized footprints both maps reproduce the pattern.
    for d in random().iter().take(1000) {
        assert!((cube.lookup(*d) - pattern(d.normalize())).abs().max_element() < 0.05);
        assert!((latlong.lookup(*d) - pattern(d.normalize())).abs().max_element() < 0.05);
    }
    // A pixel of a 640-wide, 60°-high view: the footprint that makes the mip path do work
    // (about 1.9 texels of a 1024² face: trilinear between levels 0 and 1).
    let cone = (60f32.to_radians() / 360.0) * 1.0;
    let mut g = c.benchmark_group("sky_lookup");
    g.throughput(Throughput::Elements(COUNT as u64));
    for (name, dirs) in [("coherent", coherent()), ("random", random())] {
        g.bench_function(format!("cube_bilinear_{name}"), |b| {
            b.iter(|| dirs.iter().fold(Rgb::ZERO, |acc, d| acc + cube.lookup(black_box(*d))))
        });
        g.bench_function(format!("cube_mip_{name}"), |b| {
            b.iter(|| dirs.iter().fold(Rgb::ZERO, |acc, d| acc + cube.lookup_filtered(black_box(*d), cone)))
        });
        g.bench_function(format!("cube_mip8_{name}"), |b| {
            let cones = [cone; LANES];
            b.iter(|| {
                dirs.chunks_exact(LANES).fold(Rgb::ZERO, |acc, d| {
                    let d: &[Vec3; LANES] = d.try_into().unwrap();
                    cube.lookup_filtered8(black_box(d), &cones).iter().fold(acc, |a, c| a + *c)
                })
            })
        });
        g.bench_function(format!("latlong_mip8_{name}"), |b| {
            let cones = [cone; LANES];
            b.iter(|| {
                dirs.chunks_exact(LANES).fold(Rgb::ZERO, |acc, d| {
                    let d: &[Vec3; LANES] = d.try_into().unwrap();
                    latlong.lookup_filtered8(black_box(d), &cones).iter().fold(acc, |a, c| a + *c)
                })
            })
        });
        g.bench_function(format!("latlong_bilinear_{name}"), |b| {
            b.iter(|| dirs.iter().fold(Rgb::ZERO, |acc, d| acc + latlong.lookup(black_box(*d))))
        });
        g.bench_function(format!("latlong_mip_{name}"), |b| {
            b.iter(|| dirs.iter().fold(Rgb::ZERO, |acc, d| acc + latlong.lookup_filtered(black_box(*d), cone)))
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
