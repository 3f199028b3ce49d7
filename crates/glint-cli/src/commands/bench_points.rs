//! `glint bench points`: the point-rendering paper's table 1 on this machine (DESIGN.md §3).
//!
//! Each cloud is loaded, prepared (normals and radii estimated where the file has none), laid
//! out once, then drawn `reps` times from its default view; the median frame is reported with
//! its split into projection, pull-push (down to level 1) and the final push fused with the
//! shading. A frame is validated before it is timed:
//! it must cover some pixels and hold no NaN.

use super::bench::median;
use crate::cli::{BenchPointsArgs, PointArgs, clap_defaults};
use crate::input;
use anyhow::{Context, Result, bail};
use glint_formats::points::PointReadOptions;
use glint_render::points::{Fill, PassBytes, PointSettings};
use glint_render::{FrameStats, Hooks, ImageSettings, Mode, Renderer, WhittedSettings};
use glint_scene::Scene;
use std::io::Write;
use std::path::Path;

/// The benchmark's clouds: name, how to make it.
const CLOUDS: [&str; 5] = ["bunny", "dragon", "autzen", "sampled-1m", "sampled-5m"];

fn load_cloud(name: &str, data: &Path) -> Result<Scene> {
    let file = |rel: &str| data.join(rel);
    let read = |path: &Path| -> Result<Scene> {
        let loaded = glint_formats::load_with(path, &PointReadOptions::default())
            .with_context(|| format!("cannot load {} (use --data DIR)", path.display()))?;
        Ok(loaded.scene)
    };
    let sampled = |count: usize| -> Result<Scene> {
        let mesh_path = file("meshes/stanford_dragon_100k.ply");
        let (meshes, _, _) = glint_formats::load_mesh(&mesh_path)
            .with_context(|| format!("cannot load {} (use --data DIR)", mesh_path.display()))?;
        let mesh = meshes.into_iter().next().context("the dragon mesh is empty")?;
        let mut cloud = glint_scene::sample_mesh(&mesh, count, 1)?;
        cloud.name = format!("dragon sampled {}M", count / 1_000_000);
        Ok(glint_formats::scene_for_cloud(cloud))
    };
    match name {
        "bunny" => read(&file("pointclouds/stanford_bunny_rawscan_40256.xyz")),
        "dragon" => read(&file("pointclouds/stanford_dragon_rawscan_41841.xyz")),
        "autzen" => read(&file("pointclouds/autzen_trim.las")),
        "sampled-1m" => sampled(1_000_000),
        "sampled-5m" => sampled(5_000_000),
        other => bail!("--clouds: unknown cloud {other:?} (use {})", CLOUDS.join(", ")),
    }
}

fn parse_fill(name: &str) -> Result<Fill> {
    Ok(match name {
        "full" => Fill::Ellipses,
        "pull-push" => Fill::PullPush,
        "raw" => Fill::Raw,
        "squares" => Fill::Squares,
        other => bail!("--fills: unknown fill {other:?} (use full, pull-push, raw, squares)"),
    })
}

pub fn run(args: &BenchPointsArgs) -> Result<()> {
    if args.reps == 0 || args.reps > 10_000 {
        bail!("--reps {}: must be 1..=10000", args.reps);
    }
    let names: Vec<String> = match &args.clouds {
        Some(list) => list.split(',').map(|s| s.trim().to_string()).collect(),
        None => CLOUDS.iter().map(|s| s.to_string()).collect(),
    };
    let sizes: Vec<u32> = args
        .sizes
        .split(',')
        .map(|s| s.trim().parse::<u32>().with_context(|| format!("--sizes: {s:?} is not a number")))
        .collect::<Result<_>>()?;
    let fills: Vec<Fill> = args.fills.split(',').map(|s| parse_fill(s.trim())).collect::<Result<_>>()?;
    // Every argument is checked before the table starts (and before a large cloud is read).
    if let Some(bad) = names.iter().find(|n| !CLOUDS.contains(&n.as_str())) {
        bail!("--clouds: unknown cloud {bad:?} (use {})", CLOUDS.join(", "));
    }
    for &side in &sizes {
        PointSettings::default()
            .validate(&ImageSettings::new(side, side))
            .with_context(|| format!("--sizes: {side}"))?;
    }
    if let Some(dir) = &args.images {
        std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    }
    let pool = input::thread_pool(args.threads)?;
    pool.install(|| -> Result<()> {
        out!("threads: {}, reps: {} (medians)", rayon::current_num_threads(), args.reps);
        let memory = super::stream::measure()?;
        out!("{}", memory.line());
        out!("GB/s: the bytes each stage streams at the least (PassBytes: its frame-sized buffers read or written once) over its median, project / pull-push / push+shade");
        out!("| cloud | points | image | fill | frame ms | fps | project ms | pull-push ms | push+shade ms | M points/s | projection M points/s | coverage | GB/s | of triad |");
        out!("|---|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---|");
        for name in &names {
            let mut scene = load_cloud(name, &args.data)?;
            super::points::prepare_clouds(&mut scene, &clap_defaults::<PointArgs>()?, true)?;
            let meshes = WhittedSettings::from_defaults(&scene.render);
            let default_view = |side| glint_formats::default_camera(&scene, side, side);
            let views: Vec<_> = sizes.iter().map(|&side| default_view(side)).collect();
            let mut renderer = Renderer::new(scene)?;
            for (&side, camera) in sizes.iter().zip(&views) {
                for &fill in &fills {
                    // Square images: the default view refitted.
                    let image = ImageSettings::new(side, side);
                    let mode = Mode::Points { points: PointSettings { fill, ..PointSettings::default() }, meshes };
                    let first = renderer.render(camera, &image, &mode, &Hooks::default())?;
                    let film = renderer.film();
                    let coverage = film.pixels.iter().filter(|p| p.coverage > 0.0).count() as f64
                        / film.pixels.len().max(1) as f64;
                    if coverage < 0.01 || film.pixels.iter().any(|p| !p.colour.is_finite()) {
                        bail!("{name} at {side}²: the frame is empty or holds NaN: not timed");
                    }
                    if let Some(dir) = &args.images {
                        let path = dir.join(format!("{name}-{side}-{}.png", fill_name(fill)));
                        glint_image::write_image(&path, &film.beauty_image(false), &glint_image::PngOptions::default())?;
                    }
                    let mut runs: Vec<FrameStats> = vec![first];
                    for _ in 1..args.reps {
                        runs.push(renderer.render(camera, &image, &mode, &Hooks::default())?);
                    }
                    let med = |f: &dyn Fn(&FrameStats) -> f64| median(&mut runs.iter().map(f).collect::<Vec<_>>());
                    let stage = |name: &'static str| move |s: &FrameStats| s.stage(name).unwrap_or_default().as_secs_f64() * 1e3;
                    let total = med(&|s| s.elapsed.as_secs_f64() * 1e3);
                    let project = med(&stage("project"));
                    let points = runs[0].points as f64;
                    let (pull_push, shade) = (med(&stage("pull-push")), med(&stage("push+shade")));
                    let bytes = PassBytes::of_frame(runs[0].points, side, side);
                    let gbs = [(bytes.project, project), (bytes.pull_push, pull_push), (bytes.shade, shade)]
                        .map(|(b, ms)| super::stream::gbs(b, ms));
                    let of_triad = gbs.map(|g| format!("{:.0} %", 100.0 * g / memory.triad_gbs)).join(" / ");
                    out!(
                        "| {name} | {points} | {side}² | {} | {total:.2} | {:.1} | {project:.2} | {pull_push:.2} | {shade:.2} | {:.1} | {:.0} | {:.3} | {:.1} / {:.1} / {:.1} | {of_triad} |",
                        fill_name(fill),
                        1e3 / total,
                        points / total * 1e-3,
                        points / project * 1e-3,
                        coverage,
                        gbs[0],
                        gbs[1],
                        gbs[2]
                    );
                }
            }
        }
        Ok(())
    })
}

fn fill_name(fill: Fill) -> &'static str {
    match fill {
        Fill::Ellipses => "full",
        Fill::PullPush => "pull-push",
        Fill::Raw => "raw",
        Fill::Squares => "squares",
    }
}
