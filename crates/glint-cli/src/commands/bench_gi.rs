//! `glint bench filters` and `glint bench gi`: the guided-filtering paper's tables and figure,
//! reproduced on this machine (Bauszat et al. 2011: table 2 = filter times, table 1 = render
//! times, figure 8 = MSE against a converged reference).
//!
//! Scenes are the repository's scenes/*.toml, embedded in the binary, whose model paths point
//! into ../shared/data; `--data DIR` points them elsewhere.

use super::bench::median;
use crate::cli::{BenchFiltersArgs, BenchGiArgs};
use crate::input;
use anyhow::{Context, Result, bail};
use glint_filter::{AtrousParams, BilateralParams, Filter, Guide, GuideChannels, GuidedParams};
use glint_image::{Image, PngOptions};
use glint_render::path::PathSettings;
use glint_render::{Film, FrameStats, Hooks, ImageSettings, Mode, Renderer};
use glint_scene::Scene;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// The scenes of the paper's comparisons, built from ../shared/data.
const SCENES: [(&str, &str); 4] = [
    ("sponza", include_str!("../../../../scenes/sponza.toml")),
    ("cornell-dragon", include_str!("../../../../scenes/cornell-dragon.toml")),
    ("buddha", include_str!("../../../../scenes/buddha.toml")),
    ("cornell-box", include_str!("../../../../scenes/cornell-box.toml")),
];

/// How the scene files name the data folder.
const DATA_PREFIX: &str = "../../shared/data/";

fn load_scene(name: &str, text: &str, data: &Path) -> Result<Scene> {
    if !data.is_dir() {
        bail!("data folder {} not found (give it with --data DIR)", data.display());
    }
    let data = data.canonicalize().with_context(|| format!("cannot resolve {}", data.display()))?;
    let text = text.replace(DATA_PREFIX, &format!("{}/", data.display()));
    let loaded = glint_formats::load_scene_str(&text, Path::new("."), &format!("scenes/{name}.toml"))
        .with_context(|| format!("cannot load scene {name}"))?;
    Ok(loaded.scene)
}

/// A whole path-traced frame of `width × height` with `seed`, seen by the scene's camera (its
/// delta chains as deep as the scene's `max_depth`); the picture is then `r.film()`.
fn path_frame(r: &mut Renderer, (width, height): (u32, u32), seed: u64, p: PathSettings) -> Result<FrameStats> {
    let image = ImageSettings { seed, ..ImageSettings::new(width, height) };
    let camera = r.scene().camera;
    let mode = Mode::Path(PathSettings { max_chain: r.scene().render.max_depth, ..p });
    Ok(r.render(&camera, &image, &mode, &Hooks::default())?)
}

fn path_settings(spp: u32, bounces: u32, filter: Filter) -> PathSettings {
    PathSettings { spp, max_bounces: bounces, filter, ..PathSettings::default() }
}

/// The filters of the comparisons, with the paper's settings scaled to the image width; the
/// flag also filters the diffuse light of area lights and the sky (glint's extension).
fn named_filters(width: usize) -> [(&'static str, Filter, bool); 5] {
    let guided = Filter::Guided(GuidedParams::for_width(width));
    [
        ("unfiltered", Filter::None, false),
        ("bilateral", Filter::Bilateral(BilateralParams::for_width(width)), false),
        ("a-trous", Filter::Atrous(AtrousParams::default()), false),
        ("guided", guided, false),
        ("guided+area", guided, true),
    ]
}

/// Table 2: filter times on a real indirect buffer.
pub fn filters(a: &BenchFiltersArgs) -> Result<()> {
    let pool = input::thread_pool(a.threads)?;
    let (name, text) = SCENES[0];
    let scene = load_scene(name, text, &a.data)?;
    pool.install(|| -> Result<()> {
        let (w, h) = (a.width, a.height);
        let mut renderer = Renderer::new(scene)?;
        path_frame(&mut renderer, (w, h), 0, path_settings(1, 1, Filter::None))?;
        let buffers = GuideBuffers::from_film(renderer.film());
        let guide = buffers.guide();
        let input = [&buffers.indirect[0][..], &buffers.indirect[1][..], &buffers.indirect[2][..]];
        let base = GuidedParams::for_width(w as usize);
        // Each case with the f32 planes it must stream at the least: its inputs read once and its
        // three outputs written once (A-Trous: every iteration reads colour, normal and depth
        // and writes colour; the 1-D guide is made from the three normal planes).
        let mut cases: Vec<(String, Filter, usize)> = Vec::new();
        for r in [16, 24, 32] {
            let p = BilateralParams { radius: r, ..BilateralParams::for_width(w as usize) };
            cases.push((format!("cross-bilateral r={r}"), Filter::Bilateral(p), 10));
        }
        for it in [4, 5, 6] {
            cases.push((
                format!("A-Trous {it} iterations"),
                Filter::Atrous(AtrousParams { iterations: it, ..AtrousParams::default() }),
                10 * it as usize,
            ));
        }
        for (label, channels, planes) in [
            ("1-D", GuideChannels::Grey, 9),
            ("3-D", GuideChannels::Normal, 9),
            ("4-D", GuideChannels::NormalDepth, 10),
        ] {
            let filter = Filter::Guided(GuidedParams { channels, ..base });
            cases.push((format!("guided {label} r={}", base.radius), filter, planes));
        }
        for r in [8, 16, 32, 64] {
            cases.push((format!("guided 4-D r={r}"), Filter::Guided(GuidedParams { radius: r, ..base }), 10));
        }
        out!(
            "# glint bench filters: {name} indirect buffer {w}x{h}, {} threads, median of {} runs, kernels {:?}",
            rayon::current_num_threads(),
            a.reps,
            glint_filter::Isa::detect()
        );
        let memory = super::stream::measure()?;
        out!("# {}", memory.line());
        out!("# GB/s: the planes each filter must read and write at the least (4 bytes a pixel each), over its median");
        out!("{:<28} {:>10} {:>10} {:>8} {:>12}", "filter", "median ms", "min ms", "GB/s", "of triad");
        let mut medians = Vec::with_capacity(cases.len());
        for (label, filter, planes) in &cases {
            let reps = if matches!(filter, Filter::Bilateral(_)) { a.reps.min(3) } else { a.reps };
            let mut times = Vec::with_capacity(reps);
            for _ in 0..reps.max(1) {
                let t = Instant::now();
                let outp = glint_filter::apply(filter, input, &guide)?;
                times.push(t.elapsed().as_secs_f64() * 1e3);
                std::hint::black_box(outp);
            }
            let min = times.iter().copied().fold(f64::INFINITY, f64::min);
            let m = median(&mut times);
            let gbs = super::stream::gbs((planes * 4 * w as usize * h as usize) as f64, m);
            out!("{:<28} {:>10.2} {:>10.2} {:>8.1} {:>11.0} %", label, m, min, gbs, 100.0 * gbs / memory.triad_gbs);
            medians.push((label.clone(), m));
        }
        if a.check {
            let regressions = check_filter_ratios(&medians, glint_filter::Isa::detect())?;
            if !regressions.is_empty() {
                bail!("bench filters --check: {}", regressions.join("; "));
            }
            out!("# --check: every filter within 2x its recorded ratio to {CHECK_REFERENCE}");
        }
        Ok(())
    })
}

/// The filter every other one is timed against in `--check`.
const CHECK_REFERENCE: &str = "guided 4-D r=28";

/// Median time over the reference's, as recorded in BENCHMARKS.md §6.1 (1024×768, 2 threads).
/// A filter whose ratio in a run is more than twice its recorded one has regressed (A-Trous
/// at 328 ms against a guided filter at 17 ms, ratio 19, was the case that asked for this).
const RECORDED_RATIOS: [(&str, f64); 12] = [
    ("cross-bilateral r=16", 11.5),
    ("cross-bilateral r=24", 26.5),
    ("cross-bilateral r=32", 44.8),
    ("A-Trous 4 iterations", 1.8),
    ("A-Trous 5 iterations", 2.5),
    ("A-Trous 6 iterations", 3.1),
    ("guided 1-D r=28", 0.34),
    ("guided 3-D r=28", 0.76),
    ("guided 4-D r=8", 0.82),
    ("guided 4-D r=16", 0.65),
    ("guided 4-D r=32", 0.71),
    ("guided 4-D r=64", 1.35),
];

/// Where the CPU runs a filter with AVX-512 (`glint_filter::Isa::Avx512`: A-Trous in 16
/// lanes), its own ratios (BENCHMARKS.md §13.5: the medians of three `--check` runs); the
/// rest as [`RECORDED_RATIOS`].
const RECORDED_RATIOS_AVX512: [(&str, f64); 3] =
    [("A-Trous 4 iterations", 1.22), ("A-Trous 5 iterations", 1.55), ("A-Trous 6 iterations", 1.85)];

/// The recorded ratio of the filter labelled `label` on a CPU running `isa`.
fn recorded_ratio(label: &str, isa: glint_filter::Isa) -> Option<f64> {
    let wide = if isa == glint_filter::Isa::Avx512 { &RECORDED_RATIOS_AVX512[..] } else { &[] };
    wide.iter().chain(&RECORDED_RATIOS).find(|(l, _)| *l == label).map(|&(_, r)| r)
}

/// Each timed filter's ratio to the reference against twice its recorded ratio; prints the
/// ratios and returns the filters past their bound.
fn check_filter_ratios(medians: &[(String, f64)], isa: glint_filter::Isa) -> Result<Vec<String>> {
    let Some(&(_, reference)) = medians.iter().find(|(l, _)| l == CHECK_REFERENCE) else {
        bail!("bench filters --check: the run has no {CHECK_REFERENCE} (a size other than 1024 wide?)");
    };
    let mut regressions = Vec::new();
    for (label, m) in medians {
        let Some(recorded) = recorded_ratio(label, isa) else { continue };
        let ratio = m / reference;
        let verdict = if ratio > 2.0 * recorded { "REGRESSED" } else { "ok" };
        out!(
            "# {label:<26} {ratio:>6.2} x {CHECK_REFERENCE} (recorded {recorded:.2}, bound {:.2}) {verdict}",
            2.0 * recorded
        );
        if ratio > 2.0 * recorded {
            regressions.push(format!("{label} at {ratio:.2} x {CHECK_REFERENCE} (recorded {recorded:.2})"));
        }
    }
    Ok(regressions)
}

/// The guide and indirect planes of a film, as the path mode hands them to the filter.
struct GuideBuffers {
    indirect: [Vec<f32>; 3],
    normal: [Vec<f32>; 3],
    depth: Vec<f32>,
    width: usize,
    height: usize,
}

impl GuideBuffers {
    fn from_film(film: &Film) -> GuideBuffers {
        // A path frame's film holds its AOVs (the benchmark renders one just before).
        let max_depth = film.surface.iter().map(|p| p.depth).filter(|d| d.is_finite()).fold(0.0f32, f32::max).max(1e-6);
        let pick = |f: &dyn Fn(&glint_render::SurfacePixel) -> f32| film.surface.iter().map(f).collect::<Vec<f32>>();
        GuideBuffers {
            indirect: [0, 1, 2].map(|c| film.path.iter().map(|p| p.indirect.to_array()[c]).collect()),
            normal: [pick(&|p| p.normal.x), pick(&|p| p.normal.y), pick(&|p| p.normal.z)],
            depth: pick(&|p| if p.depth.is_finite() { p.depth / max_depth } else { 2.0 }),
            width: film.width as usize,
            height: film.height as usize,
        }
    }

    fn guide(&self) -> Guide<'_> {
        Guide {
            width: self.width,
            height: self.height,
            normal: [&self.normal[0], &self.normal[1], &self.normal[2]],
            depth: &self.depth,
        }
    }
}

/// Table 1 (render times) and figure 8 (MSE against a reference).
pub fn gi(a: &BenchGiArgs) -> Result<()> {
    let pool = input::thread_pool(a.threads)?;
    let scenes: Vec<(&str, &str)> = SCENES
        .iter()
        .copied()
        .filter(|(name, _)| a.scenes.as_ref().is_none_or(|list| list.split(',').any(|s| s.trim() == *name)))
        .collect();
    if scenes.is_empty() {
        bail!("--scenes: none of {:?} is one of sponza, cornell-dragon, buddha, cornell-box", a.scenes);
    }
    pool.install(|| -> Result<()> {
        if !a.skip_times {
            out!("# Table 1: render times, {}x{}, guided filter, {} threads, median of {} frames", a.width, a.height, rayon::current_num_threads(), a.reps);
            out!("{:<16} {:>8} {:>5} {:>10} {:>10} {:>10} {:>9}", "scene", "bounces", "spp", "total ms", "trace ms", "filter ms", "Mrays/s");
            for &(name, text) in &scenes {
                let mut renderer = Renderer::new(load_scene(name, text, &a.data)?)?;
                for (bounces, spp) in [(1, 1), (1, 4), (2, 4)] {
                    let p = path_settings(spp, bounces, Filter::Guided(GuidedParams::for_width(a.width as usize)));
                    let (mut total, mut trace, mut filter, mut mrays) = (vec![], vec![], vec![], vec![]);
                    for _ in 0..a.reps.max(1) {
                        let st = path_frame(&mut renderer, (a.width, a.height), 0, p)?;
                        total.push(st.elapsed.as_secs_f64() * 1e3);
                        trace.push(st.stage("trace").unwrap_or_default().as_secs_f64() * 1e3);
                        filter.push(st.stage("filter").unwrap_or_default().as_secs_f64() * 1e3);
                        mrays.push(st.mrays_per_second());
                    }
                    out!(
                        "{:<16} {:>8} {:>5} {:>10.1} {:>10.1} {:>10.2} {:>9.2}",
                        name,
                        bounces,
                        spp,
                        median(&mut total),
                        median(&mut trace),
                        median(&mut filter),
                        median(&mut mrays)
                    );
                }
            }
        }
        if a.skip_quality {
            return Ok(());
        }
        std::fs::create_dir_all(&a.out).with_context(|| format!("cannot create {}", a.out.display()))?;
        let (w, h) = (a.quality_width, a.quality_height);
        out!(
            "# Figure 8: MSE against a {}-spp plain path-traced reference (seed 1), {}x{}, {} bounces; MSE on linear RGB and on 8-bit sRGB (0..255)",
            a.ref_spp, w, h, a.bounces
        );
        out!("{:<16} {:>4} {:<11} {:>12} {:>12} {:>9} {:>10}", "scene", "spp", "filter", "MSE linear", "MSE sRGB8", "PSNR dB", "time ms");
        let mut sheet_rows: Vec<Vec<Image>> = Vec::new();
        for &(name, text) in &scenes {
            let mut renderer = Renderer::new(load_scene(name, text, &a.data)?)?;
            let reference = reference_image(&mut renderer, name, w, h, a)?;
            let mut row = vec![reference.clone()];
            for spp in [1u32, 4] {
                for (label, filter, filter_area_direct) in named_filters(w as usize) {
                    let t = Instant::now();
                    let p = PathSettings { filter_area_direct, ..path_settings(spp, a.bounces, filter) };
                    path_frame(&mut renderer, (w, h), 0, p)?;
                    let ms = t.elapsed().as_secs_f64() * 1e3;
                    let img = renderer.film().beauty_image(false);
                    let report = glint_image::metrics::compare(&img, &reference)?;
                    out!(
                        "{:<16} {:>4} {:<11} {:>12.3e} {:>12.2} {:>9.2} {:>10.1}",
                        name, spp, label, report.mse, report.mse_srgb8, report.psnr_srgb8, ms
                    );
                    let file = a.out.join(format!("{name}-{label}-{spp}spp.png"));
                    glint_image::write_png(&file, &img, &PngOptions::default())
                        .with_context(|| format!("cannot write {}", file.display()))?;
                    if spp == 1 {
                        row.push(img);
                    }
                }
            }
            sheet_rows.push(row);
        }
        let sheet = contact_sheet(&sheet_rows, 2);
        let file = a.out.join("gi-contact-sheet.png");
        glint_image::write_png(&file, &sheet, &PngOptions::default()).with_context(|| format!("cannot write {}", file.display()))?;
        out!("# contact sheet (rows: scenes; columns: reference, then 1 spp unfiltered, bilateral, A-Trous, guided, guided+area): {}", file.display());
        Ok(())
    })
}

/// The converged reference of a scene: plain path tracing at `ref_spp` with its own seed,
/// cached as EXR in the output folder.
fn reference_image(renderer: &mut Renderer, name: &str, w: u32, h: u32, a: &BenchGiArgs) -> Result<Image> {
    let file = a.out.join(format!("{name}-reference-{w}x{h}-{}spp-{}b.exr", a.ref_spp, a.bounces));
    if file.exists() {
        let img = glint_image::read_image(&file)
            .with_context(|| format!("cannot read cached reference {}", file.display()))?;
        if img.width == w && img.height == h {
            return Ok(img);
        }
    }
    let t = Instant::now();
    path_frame(renderer, (w, h), 1, path_settings(a.ref_spp, a.bounces, Filter::None))?;
    eprintln!("glint: reference for {name} ({} spp) in {:.1} s", a.ref_spp, t.elapsed().as_secs_f64());
    let img = renderer.film().beauty_image(false);
    glint_image::write_exr(&file, &img).with_context(|| format!("cannot write {}", file.display()))?;
    Ok(img)
}

/// Tiles of the images, each shrunk by `shrink` (box filter), rows by rows.
fn contact_sheet(rows: &[Vec<Image>], shrink: u32) -> Image {
    let tile_w = rows.iter().flatten().map(|i| i.width / shrink).max().unwrap_or(1);
    let tile_h = rows.iter().flatten().map(|i| i.height / shrink).max().unwrap_or(1);
    let cols = rows.iter().map(Vec::len).max().unwrap_or(1) as u32;
    let (sw, sh) = (tile_w * cols, tile_h * rows.len() as u32);
    let mut rgb = vec![[0.0f32; 3]; (sw * sh) as usize];
    for (r, row) in rows.iter().enumerate() {
        for (c, img) in row.iter().enumerate() {
            let Some(src) = img.rgb() else { continue };
            for y in 0..img.height / shrink {
                for x in 0..img.width / shrink {
                    let mut acc = [0.0f32; 3];
                    for dy in 0..shrink {
                        for dx in 0..shrink {
                            let p = src[((y * shrink + dy) * img.width + x * shrink + dx) as usize];
                            for k in 0..3 {
                                acc[k] += p[k];
                            }
                        }
                    }
                    let n = (shrink * shrink) as f32;
                    let (ox, oy) = (c as u32 * tile_w + x, r as u32 * tile_h + y);
                    rgb[(oy * sw + ox) as usize] = acc.map(|v| v / n);
                }
            }
        }
    }
    Image::from_rgb(sw, sh, &rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_check_names_a_filter_past_twice_its_recorded_ratio() {
        use glint_filter::Isa;
        let run = |atrous5: f64, isa: Isa| {
            let medians = vec![
                ("A-Trous 5 iterations".to_string(), atrous5),
                (CHECK_REFERENCE.to_string(), 20.0),
                ("guided 1-D r=28".to_string(), 7.0),
            ];
            check_filter_ratios(&medians, isa).expect("a reference")
        };
        // Recorded 2.5: 90 ms against 20 ms is 4.5, within 5; the 328 ms is not.
        assert!(run(90.0, Isa::Avx2).is_empty());
        let bad = run(328.0, Isa::Avx2);
        assert_eq!(bad.len(), 1);
        assert!(bad[0].contains("A-Trous 5 iterations") && bad[0].contains("16.40"), "{bad:?}");
        // With AVX-512 A-Trous is recorded at 1.55: 3.0 is within its bound (3.1), 4.5 past it.
        assert!(run(60.0, Isa::Avx512).is_empty());
        assert_eq!(run(90.0, Isa::Avx512).len(), 1);
        // The guided filters keep their one ratio.
        assert_eq!(recorded_ratio("guided 1-D r=28", Isa::Avx512), Some(0.34));
        // No reference in the run: an error, not a silent pass.
        assert!(check_filter_ratios(&[("A-Trous 5 iterations".into(), 1.0)], Isa::Avx2).is_err());
    }
}
