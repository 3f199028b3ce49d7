//! BVH benchmarks: build time, and Mrays/s of closest-hit and any-hit queries, single thread,
//! on a displaced sphere of 100 k and 1 M triangles, for brute force (small n only), the binary
//! BVH, and the 4- and 8-wide layouts with each kernel. Every structure is validated against
//! brute force / the binary BVH before it is timed; a mismatch panics.
//!
//! `cargo bench -p glint-accel --bench bvh` (criterion; `-- <filter>` to select). Throughput
//! is reported as elements = rays per second.

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glint_accel::procedural::{Mesh, Rng, displaced_sphere};
use glint_accel::{
    BuildOptions, Bvh2, Bvh4, Bvh8, Hit, Isa, MeshBvh, Width, brute_force_intersect, brute_force_occluded,
};
use glint_core::{Ray, Vec3};
use std::hint::black_box;
use std::time::Instant;

const IMAGE: u32 = 384;

/// Primary rays of a pinhole camera at (0, 0, 3.2) looking along −Z, in 8×8 pixel tiles.
fn primary_rays() -> Vec<Ray> {
    let mut rays = Vec::with_capacity((IMAGE * IMAGE) as usize);
    let half = (30f32.to_radians()).tan();
    for ty in (0..IMAGE).step_by(8) {
        for tx in (0..IMAGE).step_by(8) {
            for y in ty..ty + 8 {
                for x in tx..tx + 8 {
                    let u = ((x as f32 + 0.5) / IMAGE as f32 * 2.0 - 1.0) * half;
                    let v = (1.0 - (y as f32 + 0.5) / IMAGE as f32 * 2.0) * half;
                    rays.push(Ray::new(Vec3::new(0.0, 0.0, 3.2), Vec3::new(u, v, -1.0).normalize()));
                }
            }
        }
    }
    rays
}

/// Incoherent rays: random origins in the mesh's box, random directions.
fn random_rays(n: usize) -> Vec<Ray> {
    let mut rng = Rng::new(42);
    (0..n).map(|_| Ray::new((rng.next_vec3() * 2.0 - 1.0) * 1.2, rng.next_dir())).collect()
}

/// Shadow segments from the primary hits toward a point light (coherent any-hit).
fn shadow_rays(bvh: &Bvh2, mesh: &Mesh, primary: &[Ray]) -> Vec<Ray> {
    let light = Vec3::new(4.0, 5.0, 6.0);
    primary
        .iter()
        .filter_map(|r| {
            let h = bvh.intersect(&mesh.positions, &mesh.triangles, r)?;
            let p = r.at(h.t * 0.9999);
            Some(Ray::segment(p, light - p, 1e-4, 1.0))
        })
        .collect()
}

/// Incoherent segments between random points (any-hit).
fn random_segments(n: usize) -> Vec<Ray> {
    let mut rng = Rng::new(7);
    (0..n)
        .map(|_| {
            let a = (rng.next_vec3() * 2.0 - 1.0) * 1.5;
            let b = (rng.next_vec3() * 2.0 - 1.0) * 1.5;
            Ray::segment(a, b - a, 0.0, 1.0)
        })
        .collect()
}

fn same(a: Option<Hit>, b: Option<Hit>) -> bool {
    match (a, b) {
        (None, None) => true,
        (Some(a), Some(b)) => a.prim == b.prim || (a.t - b.t).abs() <= 1e-6 * a.t.abs().max(b.t.abs()),
        _ => false,
    }
}

fn validate(name: &str, rays: &[Ray], want: &[Option<Hit>], got: impl Fn(&Ray) -> Option<Hit>) {
    for (i, (r, w)) in rays.iter().zip(want).enumerate() {
        let g = got(r);
        assert!(same(g, *w), "{name}: ray {i} {r:?}: got {g:?}, want {w:?}");
    }
}

fn validate_any(name: &str, rays: &[Ray], want: &[bool], got: impl Fn(&Ray) -> bool) {
    for (i, (r, w)) in rays.iter().zip(want).enumerate() {
        assert_eq!(got(r), *w, "{name}: ray {i} {r:?}");
    }
}

fn single_thread<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("1-thread pool").install(f)
}

fn run_mesh(c: &mut Criterion, tris: usize) {
    let mesh = displaced_sphere(tris);
    let n = mesh.triangles.len();
    let label = if n >= 1000 { format!("{}k", n / 1000) } else { n.to_string() };
    let opts = BuildOptions::default();
    let bvh2 = single_thread(|| Bvh2::build(&mesh.positions, &mesh.triangles, &opts));
    let b4 = Bvh4::from_bvh2(&bvh2, &mesh.positions, &mesh.triangles);
    let b8 = Bvh8::from_bvh2(&bvh2, &mesh.positions, &mesh.triangles);
    let mesh_bvh = single_thread(|| MeshBvh::build(&mesh.positions, &mesh.triangles, &opts));
    let stats = mesh_bvh.stats();
    println!(
        "{label}: {n} triangles, SAH cost {:.2}, bvh2 {} nodes ({:.1} B/tri), bvh4 {} nodes ({:.1} B/tri), bvh8 {} nodes ({:.1} B/tri); MeshBvh width {} build {:.1} ms (1 thread)",
        bvh2.sah_cost(),
        bvh2.nodes().len(),
        (bvh2.nodes().len() * 32) as f64 / n as f64,
        b4.nodes().len(),
        b4.node_bytes() as f64 / n as f64,
        b8.nodes().len(),
        b8.node_bytes() as f64 / n as f64,
        mesh_bvh.width(),
        stats.build_ms,
    );

    let primary = primary_rays();
    let random = random_rays(primary.len());
    let shadow = shadow_rays(&bvh2, &mesh, &primary);
    let segments = random_segments(primary.len());

    // Validation: brute force on a sample, the binary BVH on every ray.
    let sample: Vec<Ray> = primary.iter().chain(&random).step_by(primary.len() / 100).copied().collect();
    let brute: Vec<Option<Hit>> =
        sample.iter().map(|r| brute_force_intersect(&mesh.positions, &mesh.triangles, r)).collect();
    validate("bvh2 vs brute", &sample, &brute, |r| bvh2.intersect(&mesh.positions, &mesh.triangles, r));
    let any_sample: Vec<Ray> = shadow.iter().chain(&segments).step_by(shadow.len() / 100).copied().collect();
    let brute_any: Vec<bool> =
        any_sample.iter().map(|r| brute_force_occluded(&mesh.positions, &mesh.triangles, r)).collect();
    validate_any("bvh2 any vs brute", &any_sample, &brute_any, |r| bvh2.occluded(&mesh.positions, &mesh.triangles, r));
    let mut isas = vec![Isa::Scalar, Isa::Sse2];
    if Isa::detect() == Isa::Avx2 {
        isas.push(Isa::Avx2);
    }
    for (kind, rays) in [("primary", &primary), ("random", &random)] {
        let want: Vec<Option<Hit>> = rays.iter().map(|r| bvh2.intersect(&mesh.positions, &mesh.triangles, r)).collect();
        for &isa in &isas {
            validate(&format!("bvh4 {isa:?} {kind}"), rays, &want, |r| b4.intersect_isa(isa, r));
            validate(&format!("bvh8 {isa:?} {kind}"), rays, &want, |r| b8.intersect_isa(isa, r));
        }
        validate(&format!("MeshBvh {kind}"), rays, &want, |r| mesh_bvh.intersect(r));
    }
    for (kind, rays) in [("shadow", &shadow), ("segments", &segments)] {
        let want: Vec<bool> = rays.iter().map(|r| bvh2.occluded(&mesh.positions, &mesh.triangles, r)).collect();
        for &isa in &isas {
            validate_any(&format!("bvh4 {isa:?} {kind}"), rays, &want, |r| b4.occluded_isa(isa, r));
            validate_any(&format!("bvh8 {isa:?} {kind}"), rays, &want, |r| b8.occluded_isa(isa, r));
        }
        validate_any(&format!("MeshBvh {kind}"), rays, &want, |r| mesh_bvh.occluded(r));
    }

    // Build.
    let mut g = c.benchmark_group(format!("build/{label}"));
    g.sample_size(10);
    g.throughput(Throughput::Elements(n as u64));
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        g.bench_function(BenchmarkId::new("mesh_bvh", format!("{threads}t")), |b| {
            b.iter(|| pool.install(|| MeshBvh::build(black_box(&mesh.positions), &mesh.triangles, &opts)))
        });
    }
    g.finish();

    // Closest hit.
    for (kind, rays) in [("primary", &primary), ("random", &random)] {
        let mut g = c.benchmark_group(format!("closest/{label}/{kind}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function("bvh2", |b| {
            b.iter(|| rays.iter().filter(|r| bvh2.intersect(&mesh.positions, &mesh.triangles, r).is_some()).count())
        });
        for &isa in &isas {
            g.bench_function(format!("bvh4_{isa:?}"), |b| {
                b.iter(|| rays.iter().filter(|r| b4.intersect_isa(isa, r).is_some()).count())
            });
            if isa != Isa::Sse2 {
                g.bench_function(format!("bvh8_{isa:?}"), |b| {
                    b.iter(|| rays.iter().filter(|r| b8.intersect_isa(isa, r).is_some()).count())
                });
            }
        }
        g.bench_function("mesh_bvh", |b| b.iter(|| rays.iter().filter(|r| mesh_bvh.intersect(r).is_some()).count()));
        if n <= 2000 {
            g.bench_function("brute_force", |b| {
                b.iter(|| {
                    rays.iter().filter(|r| brute_force_intersect(&mesh.positions, &mesh.triangles, r).is_some()).count()
                })
            });
        }
        g.finish();
    }

    // Any hit.
    for (kind, rays) in [("shadow", &shadow), ("segments", &segments)] {
        let mut g = c.benchmark_group(format!("any/{label}/{kind}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function("bvh2", |b| {
            b.iter(|| rays.iter().filter(|r| bvh2.occluded(&mesh.positions, &mesh.triangles, r)).count())
        });
        for &isa in &isas {
            g.bench_function(format!("bvh4_{isa:?}"), |b| {
                b.iter(|| rays.iter().filter(|r| b4.occluded_isa(isa, r)).count())
            });
            if isa != Isa::Sse2 {
                g.bench_function(format!("bvh8_{isa:?}"), |b| {
                    b.iter(|| rays.iter().filter(|r| b8.occluded_isa(isa, r)).count())
                });
            }
        }
        g.bench_function("mesh_bvh", |b| b.iter(|| rays.iter().filter(|r| mesh_bvh.occluded(r)).count()));
        g.finish();
    }
}

fn small(c: &mut Criterion) {
    run_mesh(c, 1000);
}

fn medium(c: &mut Criterion) {
    run_mesh(c, 100_000);
}

fn large(c: &mut Criterion) {
    run_mesh(c, 1_000_000);
}

/// Quick single-run figures (build ms, Mrays/s) printed before criterion's, easy to copy.
fn quick_table(_: &mut Criterion) {
    for tris in [100_000, 1_000_000] {
        let mesh = displaced_sphere(tris);
        let opts = BuildOptions::default();
        let mut builds = Vec::new();
        for _ in 0..5 {
            let t = Instant::now();
            let b = single_thread(|| MeshBvh::build(&mesh.positions, &mesh.triangles, &opts));
            builds.push(t.elapsed().as_secs_f64() * 1e3);
            black_box(b);
        }
        builds.sort_by(f64::total_cmp);
        println!("quick {}k: build 1 thread median {:.1} ms", mesh.triangles.len() / 1000, builds[2]);
        let _ = Width::Auto;
    }
}

criterion_group!(benches, quick_table, small, medium, large);
criterion_main!(benches);
