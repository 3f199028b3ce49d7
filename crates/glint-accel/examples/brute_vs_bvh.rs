//! The thesis's first speed experiment: brute force against the BVH, 10 to 10^6 triangles.
//! `cargo run --release -p glint-accel --example brute_vs_bvh`
//! Rays: a pinhole camera's primary rays at the displaced-sphere test mesh. Every BVH answer is
//! checked against brute force before anything is timed (a mismatch aborts). One thread.
use glint_accel::procedural::displaced_sphere;
use glint_accel::{BuildOptions, MeshBvh, brute_force_intersect};
use glint_core::{Ray, Vec3};
use std::time::Instant;

fn rays(n: usize) -> Vec<Ray> {
    let side = (n as f64).sqrt().ceil() as usize;
    (0..side * side)
        .map(|i| {
            let (x, y) = ((i % side) as f32 / side as f32 - 0.5, (i / side) as f32 / side as f32 - 0.5);
            Ray::new(Vec3::new(0.0, 0.0, 3.0), Vec3::new(x * 0.9, y * 0.9, -1.0).normalize())
        })
        .collect()
}

fn mrays(rays: &[Ray], f: impl Fn(&Ray) -> Option<f32>) -> (f64, Vec<Option<f32>>) {
    let t = Instant::now();
    let hits: Vec<Option<f32>> = rays.iter().map(&f).collect();
    (rays.len() as f64 / t.elapsed().as_secs_f64() / 1e6, hits)
}

fn main() {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    pool.install(|| {
        println!("| triangles | brute force rays/s | BVH Mrays/s | speed-up | build ms |");
        println!("|---:|---:|---:|---:|---:|");
        for target in [10usize, 100, 1_000, 10_000, 100_000, 1_000_000] {
            let mesh = displaced_sphere(target);
            let t = Instant::now();
            let bvh = MeshBvh::build(&mesh.positions, &mesh.triangles, &BuildOptions::default());
            let build_ms = t.elapsed().as_secs_f64() * 1e3;
            // Brute force costs n tests per ray: keep its work near 2·10^8 triangle tests.
            let brute_rays = rays((200_000_000 / mesh.triangles.len()).clamp(64, 65_536));
            let (brute, want) =
                mrays(&brute_rays, |r| brute_force_intersect(&mesh.positions, &mesh.triangles, r).map(|h| h.t));
            let (_, got) = mrays(&brute_rays, |r| bvh.intersect(r).map(|h| h.t));
            assert_eq!(got, want, "BVH and brute force disagree at {} triangles", mesh.triangles.len());
            let bvh_rays = rays(1 << 20);
            let best = (0..5).map(|_| mrays(&bvh_rays, |r| bvh.intersect(r).map(|h| h.t)).0).fold(0.0, f64::max);
            println!(
                "| {} | {:.0} | {:.2} | {:.0}x | {:.1} |",
                mesh.triangles.len(),
                brute * 1e6,
                best,
                best / brute,
                build_ms
            );
        }
    });
}
