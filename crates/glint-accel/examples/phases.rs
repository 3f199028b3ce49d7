//! Times the build phases and the kernels once (a quick look while tuning; the benchmark
//! proper is `benches/bvh.rs`). `cargo run --release -p glint-accel --example phases [tris]`
//!
//! `phases <tris> <leaf> packets`: single-ray vs 8-ray packet queries of [`MeshBvh`] (default
//! build) on the same rays, 1 thread: 1024×768 primary rays in 4×2 pixel tiles, and shadow
//! segments from their hits toward a point light, grouped 8 consecutive. Packet results are
//! checked bit for bit against the single-ray ones before timing (a mismatch panics); single
//! and packet runs alternate, 7 rounds each, and the medians are printed with their ratio.
use glint_accel::procedural::{Mesh, Rng, displaced_sphere};
use glint_accel::{BuildOptions, Bvh2, Bvh4, Bvh8, Hit, Isa, MeshBvh};
use glint_core::{Ray, Vec3};
use std::time::Instant;

fn main() {
    let tris: usize = std::env::args().nth(1).and_then(|s| s.parse().ok()).unwrap_or(100_000);
    let leaf: usize = std::env::args().nth(2).and_then(|s| s.parse().ok()).unwrap_or(4);
    let mesh = displaced_sphere(tris);
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    let opts = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
    pool.install(|| {
        if std::env::args().nth(3).as_deref() == Some("packets") {
            packets(&mesh);
            return;
        }
        if std::env::args().nth(3).as_deref() == Some("build") {
            for _ in 0..20 {
                let t = Instant::now();
                let b2 = Bvh2::build(&mesh.positions, &mesh.triangles, &opts);
                println!("bvh2 {:.1} ms", t.elapsed().as_secs_f64() * 1e3);
                std::hint::black_box(b2);
            }
            return;
        }
        for _ in 0..3 {
            let t = Instant::now();
            let b2 = Bvh2::build(&mesh.positions, &mesh.triangles, &opts);
            let t_b2 = t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            let b4 = Bvh4::from_bvh2(&b2, &mesh.positions, &mesh.triangles);
            let t_b4 = t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            let b8 = Bvh8::from_bvh2(&b2, &mesh.positions, &mesh.triangles);
            let t_b8 = t.elapsed().as_secs_f64() * 1e3;
            println!(
                "bvh2 {t_b2:.1} ms ({} nodes, {} leaves, sah {:.2}), bvh4 {t_b4:.1} ms ({} nodes, {:.1} B/tri), bvh8 {t_b8:.1} ms ({} nodes, {:.1} B/tri, {} packets)",
                b2.nodes().len(),
                b2.leaf_count(),
                b2.sah_cost(),
                b4.nodes().len(),
                b4.node_bytes() as f64 / mesh.triangles.len() as f64,
                b8.nodes().len(),
                b8.node_bytes() as f64 / mesh.triangles.len() as f64,
                b8.packets().len()
            );
        }
        let b2 = Bvh2::build(&mesh.positions, &mesh.triangles, &opts);
        let b4 = Bvh4::from_bvh2(&b2, &mesh.positions, &mesh.triangles);
        let b8 = Bvh8::from_bvh2(&b2, &mesh.positions, &mesh.triangles);
        let size = 384u32;
        let half = 30f32.to_radians().tan();
        let mut primary = Vec::new();
        for ty in (0..size).step_by(8) {
            for tx in (0..size).step_by(8) {
                for y in ty..ty + 8 {
                    for x in tx..tx + 8 {
                        let u = ((x as f32 + 0.5) / size as f32 * 2.0 - 1.0) * half;
                        let v = (1.0 - (y as f32 + 0.5) / size as f32 * 2.0) * half;
                        primary.push(Ray::new(Vec3::new(0.0, 0.0, 3.2), Vec3::new(u, v, -1.0).normalize()));
                    }
                }
            }
        }
        let mut rng = Rng::new(42);
        let random: Vec<Ray> =
            (0..primary.len()).map(|_| Ray::new((rng.next_vec3() * 2.0 - 1.0) * 1.2, rng.next_dir())).collect();
        for (name, rays) in [("primary", &primary), ("random", &random)] {
            let time = |f: &dyn Fn(&Ray) -> bool| {
                let mut best = f64::MAX;
                for _ in 0..5 {
                    let t = Instant::now();
                    let c = rays.iter().filter(|r| f(r)).count();
                    std::hint::black_box(c);
                    best = best.min(t.elapsed().as_secs_f64());
                }
                rays.len() as f64 / best / 1e6
            };
            let c4 = time(&|r| b4.intersect_isa(Isa::Avx2, r).is_some());
            let c4s = time(&|r| b4.intersect_isa(Isa::Sse2, r).is_some());
            let c8 = time(&|r| b8.intersect_isa(Isa::Avx2, r).is_some());
            let a4 = time(&|r| b4.occluded_isa(Isa::Avx2, r));
            let a8 = time(&|r| b8.occluded_isa(Isa::Avx2, r));
            println!(
                "{name}: closest bvh4 avx2 {c4:.2} sse {c4s:.2}, bvh8 {c8:.2} Mrays/s; any bvh4 {a4:.2}, bvh8 {a8:.2}"
            );
        }
    });
}

fn bits(h: Option<Hit>) -> Option<(u32, u32, u32, u32)> {
    h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
}

/// Medians (Mrays/s) of `single` and `packet` over alternating runs.
fn compare(n: usize, single: &dyn Fn() -> usize, packet: &dyn Fn() -> usize) -> (f64, f64) {
    let (mut s, mut p) = (Vec::new(), Vec::new());
    for _ in 0..7 {
        let t = Instant::now();
        std::hint::black_box(single());
        s.push(n as f64 / t.elapsed().as_secs_f64() / 1e6);
        let t = Instant::now();
        std::hint::black_box(packet());
        p.push(n as f64 / t.elapsed().as_secs_f64() / 1e6);
    }
    s.sort_by(f64::total_cmp);
    p.sort_by(f64::total_cmp);
    (s[3], p[3])
}

fn packets(mesh: &Mesh) {
    let bvh = MeshBvh::build(&mesh.positions, &mesh.triangles, &BuildOptions::default());
    let (w, h) = (1024u32, 768u32);
    let half = 30f32.to_radians().tan();
    let aspect = w as f32 / h as f32;
    let mut primary = Vec::new();
    for ty in (0..h).step_by(2) {
        for tx in (0..w).step_by(4) {
            for y in ty..ty + 2 {
                for x in tx..tx + 4 {
                    let u = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * half * aspect;
                    let v = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * half;
                    primary.push(Ray::new(Vec3::new(0.0, 0.0, 3.2), Vec3::new(u, v, -1.0).normalize()));
                }
            }
        }
    }
    let light = Vec3::new(4.0, 5.0, 6.0);
    let shadow: Vec<Ray> = primary
        .iter()
        .filter_map(|r| {
            let p = r.at(bvh.intersect(r)?.t * 0.9999);
            Some(Ray::segment(p, light - p, 1e-4, 1.0))
        })
        .collect();
    let shadow = &shadow[..shadow.len() / 8 * 8];
    let groups =
        |rays: &[Ray]| -> Vec<[Ray; 8]> { rays.chunks_exact(8).map(|c| std::array::from_fn(|i| c[i])).collect() };
    let (pg, sg) = (groups(&primary), groups(shadow));
    // Validate before timing: packets equal single rays bit for bit.
    for (k, g) in pg.iter().enumerate() {
        let mut out = [None; 8];
        bvh.intersect8(g, &mut out);
        for i in 0..8 {
            assert_eq!(bits(out[i]), bits(bvh.intersect(&g[i])), "primary packet {k} lane {i}");
        }
    }
    for (k, g) in sg.iter().enumerate() {
        let mut out = [false; 8];
        bvh.occluded8(g, &mut out);
        for i in 0..8 {
            assert_eq!(out[i], bvh.occluded(&g[i]), "shadow packet {k} lane {i}");
        }
    }
    let (s, p) = compare(primary.len(), &|| primary.iter().filter(|r| bvh.intersect(r).is_some()).count(), &|| {
        let mut out = [None; 8];
        pg.iter()
            .map(|g| {
                bvh.intersect8(g, &mut out);
                out.iter().filter(|h| h.is_some()).count()
            })
            .sum()
    });
    println!(
        "{} tris, primary {w}x{h} (4x2 tiles), closest: single {s:.2}, packet8 {p:.2} Mrays/s, ratio {:.2}",
        mesh.triangles.len(),
        p / s
    );
    let (s, p) = compare(shadow.len(), &|| shadow.iter().filter(|r| bvh.occluded(r)).count(), &|| {
        let mut out = [false; 8];
        sg.iter()
            .map(|g| {
                bvh.occluded8(g, &mut out);
                out.iter().filter(|&&o| o).count()
            })
            .sum()
    });
    println!(
        "{} tris, shadow ({} rays), any: single {s:.2}, packet8 {p:.2} Mrays/s, ratio {:.2}",
        mesh.triangles.len(),
        shadow.len(),
        p / s
    );
}
