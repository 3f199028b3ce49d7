//! The sky as a light: `SkySampler` against its pdf (χ²), its pdf against the sky (proportional
//! to luminance, integrating to one) and its estimates against brute-force quadrature.

use glint_core::chi2::{chi2_sphere, integrate_sphere};
use glint_core::colour::luminance;
use glint_core::random::SampleStream;
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::{CubeFace, CubeMap, LatLongMap, Sky, SkySampler, SkyTransform, TextureImage, cube_face_st};
use std::f64::consts::PI;
use std::sync::Arc;

/// χ² tests in this file, for the suite's significance level.
const CHI2_TESTS: usize = 7;

fn sun_direction() -> Vec3 {
    Vec3::new(0.3, 0.5, -0.8).normalize()
}

/// A blue sky over dark ground with a bright sun-like spot (a few texels wide at height 64).
fn spotty(d: Vec3) -> Rgb {
    let d = d.normalize();
    let sky = if d.y >= 0.0 { Rgb::new(0.2, 0.3, 0.6) * (0.3 + 0.7 * d.y) } else { Rgb::splat(0.05) };
    sky + Rgb::new(60.0, 50.0, 40.0) * ((d.dot(sun_direction()) - 1.0) * 400.0).exp()
}

fn latlong_sky() -> Sky {
    Sky::LatLong { map: Arc::new(LatLongMap::from_fn(64, spotty)), transform: SkyTransform::new(30.0, 1.5) }
}

/// A dim cube map with a bright patch at a corner of the front face (+Z, world −Z), a bright
/// strip along an edge of the +X face, and a black region (the −Y face).
fn cube_sky() -> Sky {
    let map = CubeMap::from_fn(32, |d| {
        let (face, s, t) = cube_face_st(d);
        match face {
            CubeFace::PosZ if s < 0.15 && t < 0.15 => Rgb::new(40.0, 30.0, 20.0),
            CubeFace::PosX if t > 0.92 => Rgb::new(5.0, 8.0, 12.0),
            CubeFace::NegY => Rgb::ZERO,
            _ => Rgb::new(0.1, 0.12, 0.15) * (1.5 + d.x),
        }
    });
    Sky::CubeMap { map: Arc::new(map), transform: SkyTransform::new(75.0, 0.8) }
}

fn gradient_sky() -> Sky {
    Sky::Gradient {
        zenith: Rgb::new(0.1, 0.2, 0.9),
        horizon: Rgb::new(0.8, 0.8, 0.7),
        ground: Rgb::new(0.1, 0.08, 0.05),
    }
}

/// `n` draws of `sampler` (draw i from stream (i, 0, `seed`)), skipping any that return nothing.
fn draws(sampler: &SkySampler, sky: &Sky, n: usize, seed: u64) -> Vec<glint_scene::SkySample> {
    (0..n).filter_map(|i| sampler.sample(sky, SampleStream::new(i as u64, 0, seed).next_2d())).collect()
}

/// χ² of `sky`'s sampler on a `theta_bins × phi_bins` grid about world +Z, or, `about_y`, about
/// +Y (the lat-long map's poles: the grid's polar cells then test the sin θ Jacobian where it
/// is singular).
fn check_chi2(sky: &Sky, n: usize, theta_bins: usize, phi_bins: usize, about_y: bool) {
    let sampler = SkySampler::new(sky);
    let samples = draws(&sampler, sky, n, 1);
    assert_eq!(samples.len(), n, "a non-black sky always gives a sample");
    // (x, y, z) → (z, x, y) turns +Y into the grid's +Z; a rotation keeps solid angles.
    let to_grid = |d: Vec3| if about_y { Vec3::new(d.z, d.x, d.y) } else { d };
    let from_grid = |g: Vec3| if about_y { Vec3::new(g.y, g.z, g.x) } else { g };
    let dirs: Vec<Vec3> = samples.iter().map(|s| to_grid(s.dir)).collect();
    let out = chi2_sphere(&dirs, n, |g| sampler.pdf(sky, from_grid(g)) as f64, theta_bins, phi_bins);
    assert!(out.passes(CHI2_TESTS), "{out}");
}

#[test]
fn latlong_with_a_sun_matches_its_pdf_chi2() {
    check_chi2(&latlong_sky(), 500_000, 32, 64, false);
    check_chi2(&latlong_sky(), 500_000, 32, 64, true);
}

#[test]
fn cube_with_a_bright_corner_and_edge_matches_its_pdf_chi2() {
    check_chi2(&cube_sky(), 500_000, 32, 64, false);
}

/// Maps of a few texels on fine χ² grids: the density *within* a texel follows the Jacobian
/// (uniform in (u, v) or (s, t), so 1 / sin θ across a lat-long row near a pole).
#[test]
fn coarse_maps_match_their_pdf_within_texels_chi2() {
    let latlong =
        Sky::LatLong { map: Arc::new(LatLongMap::from_fn(8, spotty)), transform: SkyTransform::new(-20.0, 1.0) };
    check_chi2(&latlong, 300_000, 64, 32, true);
    let cube = Sky::CubeMap { map: Arc::new(CubeMap::from_fn(2, spotty)), transform: SkyTransform::new(-20.0, 1.0) };
    check_chi2(&cube, 300_000, 32, 64, false);
}

#[test]
fn colour_matches_its_pdf_chi2() {
    let sky = Sky::Colour(Rgb::new(0.2, 0.4, 0.8));
    check_chi2(&sky, 100_000, 16, 32, false);
    let sampler = SkySampler::new(&sky);
    let s = sampler.sample(&sky, Vec2::new(0.3, 0.7)).expect("a lit sky");
    assert_eq!(s.radiance, Rgb::new(0.2, 0.4, 0.8));
    assert!((s.pdf as f64 - 0.25 / PI).abs() < 1e-7);
    assert!((sampler.integral() as f64 - 4.0 * PI * luminance(Rgb::new(0.2, 0.4, 0.8)) as f64).abs() < 1e-5);
}

#[test]
fn gradient_matches_its_pdf_chi2() {
    check_chi2(&gradient_sky(), 200_000, 16, 32, true);
}

/// For every kind of sky: sampled directions are unit, their radiance is the sky's (a
/// gradient's is read at the height it was drawn at, which normalising the direction again
/// gives back up to rounding; the maps' and colours' are exact), their pdf is `pdf(dir)` (up to
/// the rounding of the direction: exact in all but a few cells' edges).
#[test]
fn samples_agree_with_pdf_and_radiance() {
    for sky in [latlong_sky(), cube_sky(), gradient_sky(), Sky::Colour(Rgb::ONE)] {
        let sampler = SkySampler::new(&sky);
        let samples = draws(&sampler, &sky, 20_000, 2);
        let mut mismatched = 0;
        for s in &samples {
            assert!((s.dir.length() - 1.0).abs() < 1e-5, "{s:?}");
            let want = sky.radiance(s.dir);
            match sky {
                Sky::Gradient { .. } => {
                    let off = (s.radiance - want).abs().max_element();
                    assert!(off <= 1e-6 * want.max_element(), "{s:?}: the sky gives {want:?}");
                }
                _ => assert_eq!(s.radiance, want),
            }
            let p = sampler.pdf(&sky, s.dir);
            if (p - s.pdf).abs() > 1e-4 * s.pdf {
                mismatched += 1;
            }
        }
        assert!(mismatched <= 10, "{mismatched} of {} samples have pdf(dir) ≠ their pdf", samples.len());
    }
}

#[test]
fn pdf_integrates_to_one() {
    for sky in [latlong_sky(), cube_sky(), gradient_sky()] {
        let sampler = SkySampler::new(&sky);
        let total = integrate_sphere(|d| sampler.pdf(&sky, d) as f64, 768, 1536);
        assert!((total - 1.0).abs() < 0.01, "{sky:?}: ∫ pdf = {total}");
    }
}

/// A map of 8 × 8-texel blocks of different colours: inside a block (a texel away from its
/// edges) the bilinear radiance is the block's colour and the pdf is luminance / ∫ luminance.
#[test]
fn pdf_is_proportional_to_luminance() {
    let colour = |bx: usize, by: usize| {
        let k = (bx * 7 + by * 13) % 11;
        Rgb::new(0.1 + k as f32, 0.5 + (k % 3) as f32, 2.0 + (k % 5) as f32 * 0.3)
    };
    let (w, h) = (128usize, 64usize);
    let texels = (0..w * h).map(|i| colour((i % w) / 8, (i / w) / 8)).collect();
    let latlong = LatLongMap::from_image(TextureImage { width: w as u32, height: h as u32, texels }).expect("2:1");
    let n = 64usize;
    let face = |f: usize| TextureImage {
        width: n as u32,
        height: n as u32,
        texels: (0..n * n).map(|i| colour((i % n) / 8 + f, (i / n) / 8)).collect(),
    };
    let cube = CubeMap::from_faces(std::array::from_fn(face)).expect("square faces");
    let transform = SkyTransform::new(-40.0, 2.0);
    let skies = [
        (Sky::LatLong { map: Arc::new(latlong), transform }, w, h),
        (Sky::CubeMap { map: Arc::new(cube), transform }, n, n),
    ];
    for (sky, w, h) in skies {
        let sampler = SkySampler::new(&sky);
        let mut worst = 0.0f64;
        let mut checked = 0;
        for y in 0..h {
            for x in 0..w {
                if matches!(x % 8, 0 | 7) || matches!(y % 8, 0 | 7) {
                    continue;
                }
                let (s, t) = ((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
                let dirs: Vec<Vec3> = match &sky {
                    Sky::LatLong { .. } if y > 0 && y < h - 1 => {
                        vec![transform.to_world(glint_scene::latlong_direction(s, t))]
                    }
                    Sky::CubeMap { .. } => CubeFace::ALL
                        .iter()
                        .map(|&f| transform.to_world(glint_scene::cube_direction(f, s, t).normalize()))
                        .collect(),
                    _ => vec![],
                };
                for d in dirs {
                    let want = luminance(sky.radiance(d)) as f64 / sampler.integral() as f64;
                    let got = sampler.pdf(&sky, d) as f64;
                    worst = worst.max((got / want - 1.0).abs());
                    checked += 1;
                }
            }
        }
        assert!(checked > 1000);
        assert!(worst < 0.01, "{sky:?}: pdf / (L / ∫L) off by {worst}");
    }
    // A gradient's pdf is exactly proportional everywhere.
    let sky = gradient_sky();
    let sampler = SkySampler::new(&sky);
    for i in 0..1000 {
        let d = glint_core::sampling::sample_uniform_sphere(SampleStream::new(i, 0, 9).next_2d());
        let want = luminance(sky.radiance(d)) / sampler.integral();
        assert!((sampler.pdf(&sky, d) - want).abs() <= 1e-5 * want, "{d}");
    }
}

/// E[lum(L) / pdf] is the sky's ∫ lum(L) dω (brute-force quadrature), with far less variance
/// than uniform sampling on a sky with a sun; `integral()` agrees too.
#[test]
fn estimates_match_quadrature_with_low_variance() {
    for (sky, min_gain) in [(latlong_sky(), 50.0), (cube_sky(), 20.0), (gradient_sky(), 1.5)] {
        let sampler = SkySampler::new(&sky);
        let truth = integrate_sphere(|d| luminance(sky.radiance(d)) as f64, 1024, 2048);
        let n = 100_000;
        let (mut sum, mut sum2, mut uniform_sum, mut uniform_sum2) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for i in 0..n {
            let u = SampleStream::new(i, 0, 3).next_2d();
            let s = sampler.sample(&sky, u).expect("a lit sky");
            let f = luminance(s.radiance) as f64 / s.pdf as f64;
            assert!(f.is_finite());
            sum += f;
            sum2 += f * f;
            let d = glint_core::sampling::sample_uniform_sphere(u);
            let g = luminance(sky.radiance(d)) as f64 * 4.0 * PI;
            uniform_sum += g;
            uniform_sum2 += g * g;
        }
        let n = n as f64;
        let (mean, variance) = (sum / n, (sum2 / n - (sum / n).powi(2)).max(0.0));
        let uniform_variance = uniform_sum2 / n - (uniform_sum / n).powi(2);
        let standard_error = (variance / n).sqrt();
        assert!(
            (mean - truth).abs() < 4.0 * standard_error + 2e-3 * truth,
            "{sky:?}: estimate {mean} ± {standard_error}, quadrature {truth}"
        );
        assert!(uniform_variance > min_gain * variance, "variance {variance} vs uniform {uniform_variance}");
        let integral = sampler.integral() as f64;
        assert!((integral - truth).abs() < 0.01 * truth, "integral() {integral} vs {truth}");
    }
}

#[test]
fn black_skies_give_nothing() {
    let black_latlong = Arc::new(LatLongMap::from_fn(16, |_| Rgb::ZERO));
    let lit_latlong = Arc::new(LatLongMap::from_fn(16, |_| Rgb::ONE));
    let skies = [
        Sky::Colour(Rgb::ZERO),
        Sky::Gradient { zenith: Rgb::ZERO, horizon: Rgb::ZERO, ground: Rgb::ZERO },
        Sky::LatLong { map: black_latlong, transform: SkyTransform::default() },
        Sky::LatLong { map: lit_latlong, transform: SkyTransform::new(10.0, 0.0) },
        Sky::CubeMap { map: Arc::new(CubeMap::from_fn(8, |_| Rgb::ZERO)), transform: SkyTransform::new(10.0, 1.0) },
    ];
    for sky in skies {
        let sampler = SkySampler::new(&sky);
        assert_eq!(sampler.integral(), 0.0);
        for u in [Vec2::ZERO, Vec2::splat(0.5), Vec2::splat(0.999_999)] {
            assert!(sampler.sample(&sky, u).is_none(), "{sky:?}");
        }
        assert_eq!(sampler.pdf(&sky, Vec3::Y), 0.0);
    }
    // A gradient over black ground never samples below the horizon, where its pdf is zero.
    let sky = Sky::Gradient { zenith: Rgb::ONE, horizon: Rgb::splat(0.5), ground: Rgb::ZERO };
    let sampler = SkySampler::new(&sky);
    assert_eq!(sampler.pdf(&sky, -Vec3::Y), 0.0);
    assert!(draws(&sampler, &sky, 1000, 4).iter().all(|s| s.dir.y >= 0.0));
}

/// Extreme and invalid inputs never give NaN: u at 0, just below 1, at 1 and NaN; directions at
/// the poles, zero and NaN; maps of one texel per face or a 2 × 1 lat-long map.
#[test]
fn outputs_are_finite() {
    let skies = [
        latlong_sky(),
        cube_sky(),
        gradient_sky(),
        Sky::Colour(Rgb::ONE),
        Sky::Gradient { zenith: Rgb::ONE, horizon: Rgb::ZERO, ground: Rgb::ZERO },
        Sky::Gradient { zenith: Rgb::ZERO, horizon: Rgb::ONE, ground: Rgb::ZERO },
        Sky::LatLong { map: Arc::new(LatLongMap::from_fn(1, spotty)), transform: SkyTransform::new(5.0, 1.0) },
        Sky::CubeMap { map: Arc::new(CubeMap::from_fn(1, spotty)), transform: SkyTransform::default() },
    ];
    let edges = [0.0, 1e-9, 0.5, 1.0 - f32::EPSILON, 1.0, f32::NAN, -1.0, 7.0];
    for sky in &skies {
        let sampler = SkySampler::new(sky);
        assert!(sampler.integral() > 0.0 && sampler.integral().is_finite());
        for &a in &edges {
            for &b in &edges {
                let s = sampler.sample(sky, Vec2::new(a, b)).expect("a lit sky");
                assert!(s.dir.is_finite() && s.radiance.is_finite(), "{sky:?} {a} {b}: {s:?}");
                assert!(s.pdf > 0.0 && s.pdf.is_finite(), "{sky:?} {a} {b}: {s:?}");
            }
        }
        for d in [Vec3::Y, -Vec3::Y, Vec3::X, Vec3::new(0.0, 1.0, 1e-30), Vec3::ZERO, Vec3::NAN, Vec3::INFINITY] {
            let p = sampler.pdf(sky, d);
            assert!(p.is_finite() && p >= 0.0, "{sky:?} {d}: {p}");
        }
    }
}
