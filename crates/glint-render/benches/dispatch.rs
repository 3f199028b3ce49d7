//! The thesis's polymorphism experiment: the cost of calling primitive intersection through
//! virtual calls (`Box<dyn Trait>`) against a closed `enum` + `match` (what glint does).
//! Brute force over a mixed list of spheres, planes and triangles, the same rays for both;
//! results are checked equal before timing.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

use criterion::{Criterion, criterion_group, criterion_main};
use glint_accel::primitives::{intersect_plane, intersect_sphere, intersect_triangle};
use glint_core::random::{hash4, unit_float};
use glint_core::{Ray, Vec3};
use std::hint::black_box;

#[derive(Clone, Copy)]
enum Prim {
    Sphere { c: Vec3, r: f32 },
    Plane { n: Vec3, d: f32 },
    Triangle { a: Vec3, b: Vec3, c: Vec3 },
}

impl Prim {
    #[inline]
    fn hit(&self, ray: &Ray) -> Option<f32> {
        match *self {
            Prim::Sphere { c, r } => intersect_sphere(ray, c, r),
            Prim::Plane { n, d } => intersect_plane(ray, n, d),
            Prim::Triangle { a, b, c } => intersect_triangle(ray, a, b, c).map(|h| h.t),
        }
    }
}

trait Intersect {
    fn hit(&self, ray: &Ray) -> Option<f32>;
}
struct DynSphere(Vec3, f32);
struct DynPlane(Vec3, f32);
struct DynTriangle(Vec3, Vec3, Vec3);
impl Intersect for DynSphere {
    fn hit(&self, ray: &Ray) -> Option<f32> {
        intersect_sphere(ray, self.0, self.1)
    }
}
impl Intersect for DynPlane {
    fn hit(&self, ray: &Ray) -> Option<f32> {
        intersect_plane(ray, self.0, self.1)
    }
}
impl Intersect for DynTriangle {
    fn hit(&self, ray: &Ray) -> Option<f32> {
        intersect_triangle(ray, self.0, self.1, self.2).map(|h| h.t)
    }
}

fn rnd(i: u64, d: u64) -> f32 {
    unit_float(hash4(i, 0, d, 99)) * 2.0 - 1.0
}

fn scene(n: usize) -> Vec<Prim> {
    (0..n as u64)
        .map(|i| {
            let p = Vec3::new(rnd(i, 0), rnd(i, 1), rnd(i, 2)) * 10.0;
            match i % 3 {
                0 => Prim::Sphere { c: p, r: 0.3 },
                1 => Prim::Plane { n: Vec3::new(rnd(i, 3), rnd(i, 4), 1.0).normalize(), d: 40.0 + p.x },
                _ => Prim::Triangle { a: p, b: p + Vec3::X, c: p + Vec3::Y },
            }
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let prims = scene(300);
    let dyns: Vec<Box<dyn Intersect>> = prims
        .iter()
        .map(|p| -> Box<dyn Intersect> {
            match *p {
                Prim::Sphere { c, r } => Box::new(DynSphere(c, r)),
                Prim::Plane { n, d } => Box::new(DynPlane(n, d)),
                Prim::Triangle { a, b, c } => Box::new(DynTriangle(a, b, c)),
            }
        })
        .collect();
    let rays: Vec<Ray> = (0..1000u64)
        .map(|i| Ray::new(Vec3::new(0.0, 0.0, 30.0), Vec3::new(rnd(i, 10) * 0.4, rnd(i, 11) * 0.4, -1.0).normalize()))
        .collect();
    let run_enum = |ray: &Ray| {
        let mut best = f32::INFINITY;
        for p in &prims {
            let r = Ray { tmax: best, ..*ray };
            if let Some(t) = p.hit(&r) {
                best = t;
            }
        }
        best
    };
    let run_dyn = |ray: &Ray| {
        let mut best = f32::INFINITY;
        for p in &dyns {
            let r = Ray { tmax: best, ..*ray };
            if let Some(t) = p.hit(&r) {
                best = t;
            }
        }
        best
    };
    for r in &rays {
        assert_eq!(run_enum(r), run_dyn(r), "enum and dyn disagree");
    }
    let mut g = c.benchmark_group("dispatch_300_prims_1000_rays");
    g.bench_function("enum_match", |b| b.iter(|| rays.iter().map(|r| run_enum(black_box(r))).sum::<f32>()));
    g.bench_function("dyn_trait", |b| b.iter(|| rays.iter().map(|r| run_dyn(black_box(r))).sum::<f32>()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
