//! Filter benchmarks at 1024×768 (the paper's resolution, table 2) with rayon's default thread
//! count: guided 1-D/3-D/4-D (radius 28, and 4-D at radii 8 and 32 to show the cost does not grow
//! with r), cross-bilateral r = 16/24/32, À-Trous 4/5/6 iterations, and each filter's portable
//! build beside its AVX2 one. Throughput is reported in pixels, so criterion prints Mpixel/s;
//! ms per megapixel = 1 / that.
//!
//! Before anything is timed the outputs are validated (fail hard): the AVX2 build against the
//! portable one (bit for bit for the guided filter), and every filter against its direct f64
//! definition (`glint_filter::oracle`) on a 64×48 crop of the same scene.
//!
//! `cargo bench -p glint-filter --bench filters` (`-- guided` etc. to select).

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glint_filter::{
    AtrousParams, BilateralParams, Filter, Guide, GuideChannels, GuidedParams, Isa, apply_with, oracle,
};

const W: usize = 1024;
const H: usize = 768;

/// A ray-cast stand-in for a render's guide and noisy indirect light: a ground plane and three
/// spheres under a pinhole camera, background where nothing is hit; the "indirect light" is a
/// smooth function of position and normal plus uniform noise of ±0.4.
struct Scene {
    w: usize,
    h: usize,
    input: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    depth: Vec<f32>,
}

impl Scene {
    fn new(w: usize, h: usize) -> Scene {
        let spheres = [([-1.2f32, 0.8, -4.0], 0.8f32), ([0.9, 0.6, -3.2], 0.6), ([0.2, 1.6, -6.0], 1.2)];
        let n = w * h;
        let mut s = Scene {
            w,
            h,
            input: std::array::from_fn(|_| Vec::with_capacity(n)),
            normal: std::array::from_fn(|_| Vec::with_capacity(n)),
            depth: Vec::with_capacity(n),
        };
        let mut seed = 0x2545_F491_4F6C_DD1Du64;
        let mut noise = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            ((seed >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * 0.8
        };
        for y in 0..h {
            for x in 0..w {
                let d = [
                    (x as f32 + 0.5) / h as f32 * 1.2 - 0.6 * w as f32 / h as f32,
                    0.6 - (y as f32 + 0.5) / h as f32 * 1.2,
                    -1.0,
                ];
                let o = [0.0f32, 1.0, 0.0];
                let mut best = (f32::INFINITY, [0.0f32; 3]);
                if d[1] < 0.0 {
                    best = (-o[1] / d[1], [0.0, 1.0, 0.0]);
                }
                for (c, r) in spheres {
                    let oc = [o[0] - c[0], o[1] - c[1], o[2] - c[2]];
                    let (a, b) = (dot(d, d), dot(oc, d));
                    let disc = b * b - a * (dot(oc, oc) - r * r);
                    if disc > 0.0 {
                        let t = (-b - disc.sqrt()) / a;
                        if t > 0.0 && t < best.0 {
                            let p = [o[0] + t * d[0] - c[0], o[1] + t * d[1] - c[1], o[2] + t * d[2] - c[2]];
                            best = (t, p.map(|v| v / r));
                        }
                    }
                }
                let (t, nrm) = best;
                let hit = t < 40.0;
                for (plane, n) in s.normal.iter_mut().zip(nrm) {
                    plane.push(if hit { n } else { 0.0 });
                }
                s.depth.push(if hit { t / 50.0 } else { 1.0 });
                let smooth = if hit { 0.4 + 0.3 * nrm[1] + 0.2 * (t * 0.7).sin() } else { 0.9 };
                for (k, plane) in s.input.iter_mut().enumerate() {
                    plane.push((smooth * [1.0, 0.8, 0.6][k] + noise()).max(0.0));
                }
            }
        }
        s
    }

    fn input(&self) -> [&[f32]; 3] {
        [&self.input[0], &self.input[1], &self.input[2]]
    }

    fn guide(&self) -> Guide<'_> {
        Guide {
            width: self.w,
            height: self.h,
            normal: [&self.normal[0], &self.normal[1], &self.normal[2]],
            depth: &self.depth,
        }
    }

    /// The `w`×`h` block at (x0, y0).
    fn crop(&self, x0: usize, y0: usize, w: usize, h: usize) -> Scene {
        let cut = |p: &Vec<f32>| (y0..y0 + h).flat_map(|y| p[y * self.w + x0..y * self.w + x0 + w].to_vec()).collect();
        Scene {
            w,
            h,
            input: self.input.each_ref().map(cut),
            normal: self.normal.each_ref().map(cut),
            depth: cut(&self.depth),
        }
    }
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn max_diff(a: &[Vec<f32>; 3], b: &[Vec<f32>; 3]) -> f32 {
    (0..3).flat_map(|c| a[c].iter().zip(&b[c]).map(|(x, y)| (x - y).abs())).fold(0.0, f32::max)
}

fn guided_params(radius: usize, channels: GuideChannels) -> GuidedParams {
    GuidedParams { radius, eps_normal: 0.01, eps_depth: 0.02, channels }
}

/// Fails hard unless the AVX2 build matches the portable one and the filter matches its
/// definition on a crop. `bitwise` demands identical bits between the builds.
fn validate(scene: &Scene, crop: &Scene, filter: &Filter, bitwise: bool) {
    let fast = apply_with(Isa::detect(), filter, scene.input(), &scene.guide()).expect("valid input");
    let portable = apply_with(Isa::Portable, filter, scene.input(), &scene.guide()).expect("valid input");
    let d = max_diff(&fast, &portable);
    assert!(if bitwise { fast == portable } else { d <= 1e-5 }, "{filter:?}: AVX2 vs portable differ by {d}");
    let got = apply_with(Isa::detect(), filter, crop.input(), &crop.guide()).expect("valid input");
    let want = match filter {
        Filter::Guided(p) => oracle::guided_direct(crop.input(), &crop.guide(), p),
        Filter::Bilateral(p) => oracle::bilateral_direct(crop.input(), &crop.guide(), p),
        Filter::Atrous(p) => oracle::atrous_direct(crop.input(), &crop.guide(), p),
        Filter::None => crop.input.clone(),
    };
    let d = max_diff(&got, &want);
    // The crop's input spans about [0, 1.4]: 2e-5 of its range.
    assert!(d <= 3e-5, "{filter:?}: differs from its definition by {d}");
}

fn bench(c: &mut Criterion) {
    let scene = Scene::new(W, H);
    let crop = scene.crop(480, 380, 64, 48);
    println!("scene {W}x{H}, {} threads, ISA {:?}", rayon::current_num_threads(), Isa::detect());
    let run = |group: &str, id: String, filter: Filter, isa: Isa, c: &mut Criterion| {
        let mut g = c.benchmark_group(group);
        g.throughput(Throughput::Elements((W * H) as u64));
        if matches!(filter, Filter::Bilateral(_)) {
            g.sample_size(10);
        }
        g.bench_function(BenchmarkId::from_parameter(id), |b| {
            b.iter(|| apply_with(isa, black_box(&filter), scene.input(), &scene.guide()).expect("valid"))
        });
        g.finish();
    };
    let fast = Isa::detect();

    for (name, channels) in
        [("1d", GuideChannels::Grey), ("3d", GuideChannels::Normal), ("4d", GuideChannels::NormalDepth)]
    {
        let f = Filter::Guided(guided_params(28, channels));
        validate(&scene, &crop, &f, true);
        run("guided", format!("{name}_r28"), f, fast, c);
    }
    for r in [8, 32] {
        let f = Filter::Guided(guided_params(r, GuideChannels::NormalDepth));
        validate(&scene, &crop, &f, true);
        run("guided", format!("4d_r{r}"), f, fast, c);
    }
    run(
        "guided",
        "4d_r28_portable".into(),
        Filter::Guided(guided_params(28, GuideChannels::NormalDepth)),
        Isa::Portable,
        c,
    );

    for iterations in [4, 5, 6] {
        let f = Filter::Atrous(AtrousParams { iterations, ..AtrousParams::default() });
        validate(&scene, &crop, &f, false);
        run("atrous", format!("{iterations}_iterations"), f, fast, c);
    }
    run("atrous", "5_iterations_portable".into(), Filter::Atrous(AtrousParams::default()), Isa::Portable, c);

    for r in [16, 24, 32] {
        let f = Filter::Bilateral(BilateralParams {
            radius: r,
            sigma_spatial: r as f32 * 0.5,
            ..BilateralParams::for_width(W)
        });
        validate(&scene, &crop, &f, false);
        run("bilateral", format!("r{r}"), f, fast, c);
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
