//! Behaviour every filter must have, through the public API: constants stay constant, geometry
//! edges survive, errors name the plane and pixel, results do not depend on the thread count.

use proptest::prelude::*;

use crate::test_util::{MINUS_Y, PLUS_X, PLUS_Y, PLUS_Z, Rng, Scene, random_scene, two_halves};
use crate::{
    AtrousParams, BilateralParams, Filter, FilterError, GuideChannels, GuidedParams, Isa, apply, apply_into, apply_with,
};

const CHANNELS: [GuideChannels; 3] = [GuideChannels::Grey, GuideChannels::Normal, GuideChannels::NormalDepth];

fn guided(radius: usize, channels: GuideChannels) -> Filter {
    Filter::Guided(GuidedParams { radius, eps_normal: 0.01, eps_depth: 0.02, channels })
}

/// A spread of settings for every filter, including extreme ones.
fn all_filters() -> Vec<Filter> {
    let mut filters = vec![Filter::None];
    for channels in CHANNELS {
        for radius in [1, 4, 30, 1000] {
            filters.push(guided(radius, channels));
        }
        filters.push(Filter::Guided(GuidedParams { radius: 3, eps_normal: 1e-6, eps_depth: 1e-6, channels }));
        filters.push(Filter::Guided(GuidedParams { radius: 3, eps_normal: 100.0, eps_depth: 100.0, channels }));
    }
    for (radius, s) in [(1, 0.5), (5, 2.0), (40, 1e3)] {
        filters.push(Filter::Bilateral(BilateralParams {
            radius,
            sigma_spatial: s,
            sigma_normal: 0.2,
            sigma_depth: 0.05,
        }));
    }
    filters.push(Filter::Bilateral(BilateralParams {
        radius: 3,
        sigma_spatial: 1e-3,
        sigma_normal: 1e-3,
        sigma_depth: 1e-3,
    }));
    for iterations in [1, 5, 9] {
        filters.push(Filter::Atrous(AtrousParams { iterations, ..AtrousParams::default() }));
    }
    filters.push(Filter::Atrous(AtrousParams {
        iterations: 3,
        sigma_colour: 1e-4,
        sigma_normal: 1e-3,
        sigma_depth: 1e-3,
    }));
    filters
}

#[test]
fn a_constant_stays_constant_under_every_filter() {
    let mut scene = random_scene(37, 29, 21);
    for (c, level) in [0.25f32, 3.0, 0.0].into_iter().enumerate() {
        scene.input[c].fill(level);
    }
    for filter in all_filters() {
        for isa in [Isa::Portable, Isa::Avx2, Isa::Avx512] {
            let out = apply_with(isa, &filter, scene.input(), &scene.guide()).expect("valid");
            for (c, level) in [0.25f32, 3.0, 0.0].into_iter().enumerate() {
                // The guided filter's a_k is 0 only up to f32 rounding of cov(I, N) (about 1e-7
                // of N's magnitude, amplified by at most 1/ε); the weighted means are exact up to
                // the rounding of their sums.
                let worst = out[c].iter().fold(0.0f32, |m, v| m.max((v - level).abs()));
                assert!(worst <= 2e-5 * level.max(1.0), "{filter:?} {isa:?} plane {c}: off by {worst}");
            }
        }
    }
}

/// A 96×24 image split at column 48: input 0.2 | 0.8, depth 0.3 | 0.6, the given normals.
fn edge_scene(normals: [[f32; 3]; 2]) -> Scene {
    two_halves(96, 24, 48, [0.2, 0.8], [0.3, 0.6], normals)
}

/// Largest deviation from each half's own level, as a fraction of the 0.6 step.
fn bleed(scene: &Scene, out: &[f32]) -> f32 {
    out.iter().enumerate().map(|(i, v)| (v - if i % scene.w < 48 { 0.2 } else { 0.8 }).abs() / 0.6).fold(0.0, f32::max)
}

/// What the guided filter leaves of a step in N that coincides with a step ΔI in the guide,
/// at the pixel next to the edge, as a fraction of the step. A window with a fraction f of its
/// columns across the edge has Σ = f(1−f)·ΔIΔIᵀ, so (Sherman–Morrison) its fit recovers
/// 1 − 1/(1 + f(1−f)·m) of the step, m = ΔIᵀE⁻¹ΔI, and predicts the near pixel off by
/// f/(1 + f(1−f)·m) of it; the output averages that over the 2r + 1 window columns
/// (f = 0, 1/(2r+1), …). A box filter would leave about 1/2.
fn predicted_bleed(radius: usize, m: f64) -> f64 {
    let l = (2 * radius + 1) as f64;
    (0..2 * radius + 1).map(|j| j as f64 / l).map(|f| f / (1.0 + f * (1.0 - f) * m)).sum::<f64>() / l
}

#[test]
fn the_guided_filter_keeps_an_edge_of_the_guide() {
    // −Y | +Y: (n + 1)/2 differs by 1 in y, the grey guide by the luma weight 0.7152, and the
    // depth by 0.3.
    let scene = edge_scene([MINUS_Y, PLUS_Y]);
    let m = |channels| match channels {
        GuideChannels::Grey => 0.7152f64.powi(2) / 0.01,
        GuideChannels::Normal => 1.0 / 0.01,
        GuideChannels::NormalDepth => 1.0 / 0.01 + 0.3f64.powi(2) / 0.02,
    };
    for channels in CHANNELS {
        let out = apply(&guided(12, channels), scene.input(), &scene.guide()).expect("valid");
        let (got, want) = (bleed(&scene, &out[0]) as f64, predicted_bleed(12, m(channels)));
        assert!((got - want).abs() < 2e-4, "{channels:?}: bleed {got}, predicted {want}");
        assert!(got < 0.07, "{channels:?}: bleed {got}");
    }
    // Normals +Z | +X look alike to the grey guide (lumas 0.536 and 0.606): it blurs the edge
    // almost like a box filter, the halo of Bauszat et al. fig. 5a.
    let scene = edge_scene([PLUS_Z, PLUS_X]);
    let out = apply(&guided(12, GuideChannels::Grey), scene.input(), &scene.guide()).expect("valid");
    let (got, want) = (bleed(&scene, &out[0]) as f64, predicted_bleed(12, (0.5361 - 0.6063f64).powi(2) / 0.01));
    assert!((got - want).abs() < 2e-3 && got > 0.4, "grey: bleed {got}, predicted {want}");
    // Only the depth differs: only the 4-D guide sees the edge.
    let scene = edge_scene([PLUS_Z, PLUS_Z]);
    let out = apply(&guided(12, GuideChannels::NormalDepth), scene.input(), &scene.guide()).expect("valid");
    let (got, want) = (bleed(&scene, &out[0]) as f64, predicted_bleed(12, 0.09 / 0.02));
    assert!((got - want).abs() < 2e-4, "depth: bleed {got}, predicted {want}");
    let out = apply(&guided(12, GuideChannels::Normal), scene.input(), &scene.guide()).expect("valid");
    assert!(bleed(&scene, &out[0]) > 0.45);
}

#[test]
fn weighted_filters_keep_normal_and_depth_edges() {
    for normals in [[PLUS_Z, PLUS_X], [PLUS_Z, PLUS_Z]] {
        let scene = edge_scene(normals);
        let bilateral = Filter::Bilateral(BilateralParams::for_width(1024));
        let out = apply(&bilateral, scene.input(), &scene.guide()).expect("valid");
        // Across Δz = 0.3 = 6σz the depth factor alone is e^−18.
        assert!(bleed(&scene, &out[0]) < 1e-5, "bilateral: {}", bleed(&scene, &out[0]));
        let out = apply(&Filter::Atrous(AtrousParams::default()), scene.input(), &scene.guide()).expect("valid");
        // Across Δz = 3σz: e^−9 times the kernel weight, cut further by the colour term.
        assert!(bleed(&scene, &out[0]) < 1e-3, "atrous: {}", bleed(&scene, &out[0]));
    }
}

#[test]
fn a_window_larger_than_the_image_gives_the_global_least_squares_fit() {
    // With every window the whole image, a and b are one global linear fit of N on I, and the
    // output is that fit evaluated at each pixel, whatever the radius beyond the image size.
    let scene = random_scene(19, 13, 33);
    for channels in CHANNELS {
        let d = channels.dimension();
        let eps = [0.01f64, 0.01, 0.01, 0.02];
        let guide_vector = |i: usize| -> [f64; 4] {
            let n = scene.normal.each_ref().map(|p| (p[i] as f64 + 1.0) * 0.5);
            match channels {
                GuideChannels::Grey => [0.2126 * n[0] + 0.7152 * n[1] + 0.0722 * n[2], 0.0, 0.0, 0.0],
                GuideChannels::Normal => [n[0], n[1], n[2], 0.0],
                GuideChannels::NormalDepth => [n[0], n[1], n[2], (scene.depth[i] as f64).min(1.0)],
            }
        };
        let count = scene.w * scene.h;
        let guides: Vec<[f64; 4]> = (0..count).map(guide_vector).collect();
        let mean_i: Vec<f64> = (0..d).map(|j| guides.iter().map(|g| g[j]).sum::<f64>() / count as f64).collect();
        let mut sigma = vec![vec![0.0; d]; d];
        for g in &guides {
            for j in 0..d {
                for k in 0..d {
                    sigma[j][k] += (g[j] - mean_i[j]) * (g[k] - mean_i[k]) / count as f64;
                }
            }
        }
        for (j, row) in sigma.iter_mut().enumerate() {
            row[j] += eps[j];
        }
        for radius in [19, 25, 10_000] {
            let out = apply(&guided(radius, channels), scene.input(), &scene.guide()).expect("valid");
            for c in 0..3 {
                let p: Vec<f64> = scene.input[c].iter().map(|&v| v as f64).collect();
                let mean_p = p.iter().sum::<f64>() / count as f64;
                let cov: Vec<f64> = (0..d)
                    .map(|j| {
                        guides.iter().zip(&p).map(|(g, v)| (g[j] - mean_i[j]) * (v - mean_p)).sum::<f64>()
                            / count as f64
                    })
                    .collect();
                let a = solve(sigma.clone(), cov);
                let b = mean_p - (0..d).map(|j| a[j] * mean_i[j]).sum::<f64>();
                for (i, g) in guides.iter().enumerate() {
                    let want = (0..d).map(|j| a[j] * g[j]).sum::<f64>() + b;
                    let got = out[c][i] as f64;
                    assert!((got - want).abs() < 1e-5, "{channels:?} r {radius} plane {c} pixel {i}: {got} vs {want}");
                }
            }
        }
    }
}

/// Gaussian elimination without pivoting (SPD systems only).
fn solve(mut m: Vec<Vec<f64>>, mut rhs: Vec<f64>) -> Vec<f64> {
    let d = rhs.len();
    for col in 0..d {
        for r in col + 1..d {
            let f = m[r][col] / m[col][col];
            for c in col..d {
                m[r][c] -= f * m[col][c];
            }
            rhs[r] -= f * rhs[col];
        }
    }
    let mut x = vec![0.0; d];
    for r in (0..d).rev() {
        x[r] = (rhs[r] - (r + 1..d).map(|c| m[r][c] * x[c]).sum::<f64>()) / m[r][r];
    }
    x
}

#[test]
fn bad_values_are_reported_by_plane_and_first_pixel() {
    let names = ["input[0] (R)", "input[1] (G)", "input[2] (B)", "normal.x", "normal.y", "normal.z", "depth"];
    let filters = [
        Filter::None,
        guided(2, GuideChannels::Grey),
        guided(2, GuideChannels::Normal),
        guided(2, GuideChannels::NormalDepth),
        Filter::Bilateral(BilateralParams::for_width(20)),
        Filter::Atrous(AtrousParams::default()),
    ];
    for (plane, name) in names.iter().enumerate() {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
            let mut scene = random_scene(20, 70, 3);
            let target = match plane {
                0..3 => &mut scene.input[plane],
                3..6 => &mut scene.normal[plane - 3],
                _ => &mut scene.depth,
            };
            // Two bad pixels: the first in row-major order must be named.
            target[20 * 61 + 7] = bad;
            target[20 * 40 + 11] = bad;
            for filter in &filters {
                for isa in [Isa::Portable, Isa::Avx2, Isa::Avx512] {
                    let err = apply_with(isa, filter, scene.input(), &scene.guide()).expect_err("bad value");
                    let want = format!("{name} is not finite at pixel (11, 40)");
                    assert!(err.to_string().starts_with(&want), "{filter:?}: {err}");
                }
            }
        }
    }
}

#[test]
fn bad_sizes_and_parameters_are_errors_not_panics() {
    let scene = random_scene(8, 6, 4);
    let mut short = scene.clone();
    short.normal[1].pop();
    let err = apply(&guided(2, GuideChannels::Normal), short.input(), &short.guide()).expect_err("short plane");
    assert_eq!(err.to_string(), "normal.y has 47 values, but a 8x6 image needs 48");

    let mut empty = scene.clone();
    empty.w = 0;
    for filter in all_filters() {
        let err = apply(&filter, empty.input(), &empty.guide()).expect_err("empty");
        assert!(matches!(err, FilterError::Empty { width: 0, height: 6 }), "{err}");
    }
    let mut empty = random_scene(1, 1, 1);
    empty.h = 0;
    empty.input = Default::default();
    empty.normal = Default::default();
    empty.depth.clear();
    assert!(matches!(apply(&Filter::None, empty.input(), &empty.guide()), Err(FilterError::Empty { .. })));

    let bad = [
        guided(0, GuideChannels::Grey),
        Filter::Guided(GuidedParams { radius: 2, eps_normal: 0.0, eps_depth: 0.1, channels: GuideChannels::Grey }),
        Filter::Guided(GuidedParams {
            radius: 2,
            eps_normal: 0.1,
            eps_depth: -1.0,
            channels: GuideChannels::NormalDepth,
        }),
        Filter::Guided(GuidedParams {
            radius: 2,
            eps_normal: f32::NAN,
            eps_depth: 0.1,
            channels: GuideChannels::NormalDepth,
        }),
        Filter::Bilateral(BilateralParams { radius: 0, ..BilateralParams::for_width(8) }),
        Filter::Bilateral(BilateralParams { sigma_depth: 0.0, ..BilateralParams::for_width(8) }),
        Filter::Bilateral(BilateralParams { sigma_spatial: f32::INFINITY, ..BilateralParams::for_width(8) }),
        Filter::Atrous(AtrousParams { iterations: 0, ..AtrousParams::default() }),
        Filter::Atrous(AtrousParams { iterations: 17, ..AtrousParams::default() }),
        Filter::Atrous(AtrousParams { sigma_colour: -1.0, ..AtrousParams::default() }),
    ];
    for filter in bad {
        let err = apply(&filter, scene.input(), &scene.guide()).expect_err("bad parameter");
        assert!(matches!(err, FilterError::InvalidParameter { .. }), "{filter:?}: {err}");
    }

    let mut out = [vec![0.0; 48], vec![0.0; 47], vec![0.0; 48]];
    let [a, b, c] = &mut out;
    let err = apply_into(&Filter::None, scene.input(), &scene.guide(), [a, b, c]).expect_err("short output");
    assert!(err.to_string().starts_with("output[1] has 47 values"), "{err}");
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    // Tall enough for the guided filter to run several strips (and the others several bands).
    let scene = random_scene(45, 300, 8);
    let run = |threads: usize, filter: &Filter| {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("thread pool");
        pool.install(|| apply(filter, scene.input(), &scene.guide()).expect("valid"))
    };
    for filter in all_filters() {
        let one = run(1, &filter);
        let two = run(2, &filter);
        let bits = |p: &[Vec<f32>; 3]| p.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert!(bits(&one) == bits(&two), "{filter:?}");
    }
}

#[test]
fn the_guided_filter_builds_agree_bit_for_bit() {
    let scene = random_scene(61, 47, 12);
    for channels in CHANNELS {
        for radius in [1, 7, 20] {
            let filter = guided(radius, channels);
            let a = apply_with(Isa::Portable, &filter, scene.input(), &scene.guide()).expect("valid");
            let b = apply_with(Isa::Avx2, &filter, scene.input(), &scene.guide()).expect("valid");
            assert!(a.iter().flatten().zip(b.iter().flatten()).all(|(x, y)| x.to_bits() == y.to_bits()));
        }
    }
}

#[test]
fn apply_into_matches_apply() {
    let scene = random_scene(30, 20, 5);
    for filter in all_filters() {
        let want = apply(&filter, scene.input(), &scene.guide()).expect("valid");
        let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![f32::NAN; 600]);
        let [a, b, c] = &mut out;
        apply_into(&filter, scene.input(), &scene.guide(), [a, b, c]).expect("valid");
        assert_eq!(out, want, "{filter:?}");
    }
}

#[test]
fn reserved_buffers_change_no_result() {
    // Reserving for this size, for another size, and for parameters a call would refuse, then
    // filtering: the same bits as the first call (kept buffers carry nothing over).
    let scene = random_scene(41, 23, 8);
    let refused = [
        Filter::Guided(GuidedParams { radius: 0, ..GuidedParams::for_width(41) }),
        Filter::Atrous(AtrousParams { iterations: 0, ..AtrousParams::default() }),
        Filter::Atrous(AtrousParams { iterations: 17, ..AtrousParams::default() }),
    ];
    for filter in all_filters() {
        let want = apply(&filter, scene.input(), &scene.guide()).expect("valid");
        for (w, h) in [(41, 23), (7, 300), (0, 5), (5, 0)] {
            crate::reserve(&filter, w, h);
        }
        for other in &refused {
            crate::reserve(other, 41, 23);
        }
        crate::reserve(&filter, 41, 23);
        let got = apply(&filter, scene.input(), &scene.guide()).expect("valid");
        assert_eq!(got, want, "{filter:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Every filter commutes with F(s·N + t) = s·F(N) + t (up to f32 rounding): the guided and
    /// bilateral filters are linear in the input, À-Trous measures colour differences in units
    /// of the input's standard deviation.
    #[test]
    fn filters_commute_with_affine_changes_of_the_input(
        w in 1usize..40, h in 1usize..40, seed in 0u64..1000, radius in 1usize..12,
        scale in 0.1f32..10.0, shift in -5.0f32..5.0, which in 0usize..3,
    ) {
        let scene = random_scene(w, h, seed);
        let (filter, s) = match which {
            0 => (guided(radius, CHANNELS[(seed % 3) as usize]), scale),
            1 => (Filter::Bilateral(BilateralParams { radius, sigma_spatial: 2.0, sigma_normal: 0.3, sigma_depth: 0.1 }), scale),
            _ => (Filter::Atrous(AtrousParams { iterations: 3, ..AtrousParams::default() }), scale),
        };
        let t = shift;
        let mut moved = scene.clone();
        for plane in &mut moved.input {
            for v in plane.iter_mut() {
                *v = *v * s + t;
            }
        }
        let base = apply(&filter, scene.input(), &scene.guide()).expect("valid");
        let out = apply(&filter, moved.input(), &moved.guide()).expect("valid");
        for c in 0..3 {
            for (i, (&b, &o)) in base[c].iter().zip(&out[c]).enumerate() {
                let want = b * s + t;
                prop_assert!((o - want).abs() <= 2e-4 * (1.0 + want.abs() + s), "plane {} pixel {}: {} vs {}", c, i, o, want);
            }
        }
    }
}

#[test]
fn random_inputs_never_panic() {
    // Extreme but finite values: huge, tiny, negative, zero normals, depth beyond 1.
    let mut rng = Rng::new(77);
    for round in 0..20 {
        let (w, h) = (1 + round % 9, 1 + (round * 7) % 11);
        let mut scene = random_scene(w, h, round as u64);
        for plane in scene.input.iter_mut().chain(scene.normal.iter_mut()).chain(std::iter::once(&mut scene.depth)) {
            for v in plane.iter_mut() {
                *v = match (rng.next_f32() * 6.0) as u32 {
                    0 => 1e30,
                    1 => -1e30,
                    2 => 1e-30,
                    3 => 0.0,
                    _ => *v,
                };
            }
        }
        for filter in all_filters() {
            let _ = apply(&filter, scene.input(), &scene.guide());
        }
    }
}
