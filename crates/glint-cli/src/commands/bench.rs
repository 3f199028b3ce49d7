//! `glint bench`: measured, never guessed. `rays` times traversal on a fixed ray set (and dumps
//! it for the Embree scripts in ../shared/bench); `whitted` times whole frames.

use crate::cli::{
    BenchCommand, BenchPathArgs, BenchRaysArgs, BenchWhittedArgs, BuildArg, FilterOptions, KernelArg, PathKernelArg,
    RayKind, ScheduleArg, clap_defaults,
};
use crate::input;
use anyhow::{Context, Result, bail};
use glint_accel::BuildOptions;
use glint_core::random::SampleStream;
use glint_core::sampling::sample_cosine_hemisphere;
use glint_core::{Frame, Ray, Vec2, Vec3};
use glint_image::PngOptions;
use glint_render::{Hooks, ImageSettings, Mode, Renderer, Schedule, WhittedSettings, World};
use glint_scene::{Mesh, Scene};
use rayon::prelude::*;
use std::io::Write;

use std::path::{Path, PathBuf};
use std::time::Instant;

/// The thesis's benchmark scene (DESIGN.md §1), as shipped in scenes/.
const WHITTED_BENCH_SCENE: &str = include_str!("../../../../scenes/whitted-bench.toml");

pub fn run(cmd: BenchCommand) -> Result<()> {
    match cmd {
        BenchCommand::Rays(a) => rays(&a),
        BenchCommand::Whitted(a) => whitted(&a),
        BenchCommand::Filters(a) => super::bench_gi::filters(&a),
        BenchCommand::Gi(a) => super::bench_gi::gi(&a),
        BenchCommand::Points(a) => super::bench_points::run(&a),
        BenchCommand::View(a) => super::bench_view::run(&a),
        BenchCommand::Path(a) => path(&a),
    }
}

pub(super) fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// Each named stage's times over a run's frames, in the order the stages first appeared.
#[derive(Clone, Debug, Default)]
pub(super) struct StageTimes(Vec<(&'static str, Vec<f64>)>);

impl StageTimes {
    /// Add one frame's time of stage `name`, in ms.
    pub(super) fn push(&mut self, name: &'static str, ms: f64) {
        match self.0.iter_mut().find(|(n, _)| *n == name) {
            Some((_, v)) => v.push(ms),
            None => self.0.push((name, vec![ms])),
        }
    }

    /// Every stage's median: "trace 12.30, filter 4.50".
    pub(super) fn medians(&mut self) -> String {
        let split: Vec<String> = self.0.iter_mut().map(|(n, v)| format!("{n} {:.2}", median(v))).collect();
        split.join(", ")
    }
}

/// Pixels in 4×2 tiles (row-major inside a tile, tiles row-major, edge tiles clipped), so that
/// 8 consecutive primary rays form a coherent packet.
fn tile_order(width: u32, height: u32) -> impl Iterator<Item = (u32, u32)> {
    (0..height.div_ceil(2)).flat_map(move |ty| {
        (0..width.div_ceil(4)).flat_map(move |tx| {
            (0..8u32).map(move |i| (tx * 4 + i % 4, ty * 2 + i / 4)).filter(move |&(x, y)| x < width && y < height)
        })
    })
}

/// The ray set of a benchmark: generated once, primary rays in 4×2 pixel tiles (secondary rays
/// follow their primary ray's order), deterministic in the seed. The dump keeps this order.
fn make_rays(world: &World, kind: RayKind, width: u32, height: u32, seed: u64) -> Vec<Ray> {
    let cam = world.scene().camera.rays(width, height);
    let primary: Vec<Ray> =
        tile_order(width, height).map(|(x, y)| cam.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5))).collect();
    if kind == RayKind::Primary {
        return primary;
    }
    let light = world.scene().lights.iter().find_map(|l| l.position()).unwrap_or_else(|| {
        let b = world.scene().bounds();
        b.centre() + Vec3::new(0.3, 1.0, 0.5) * b.diagonal_length().max(1.0) * 2.0
    });
    primary
        .par_iter()
        .enumerate()
        .filter_map(|(i, r)| {
            let hit = world.intersect(r)?;
            Some(match kind {
                RayKind::Shadow => hit.spawn_ray_to(light),
                _ => {
                    let n = if hit.geometric_normal.dot(r.dir) < 0.0 {
                        hit.geometric_normal
                    } else {
                        -hit.geometric_normal
                    };
                    let mut s = SampleStream::new(i as u64, 0, seed);
                    let d = Frame::from_z(n).to_world(sample_cosine_hemisphere(s.next_2d()));
                    hit.spawn_ray(d)
                }
            })
        })
        .collect()
}

fn write_f32s(path: &Path, data: impl Iterator<Item = f32>) -> Result<()> {
    let mut bytes = Vec::new();
    for v in data {
        bytes.extend_from_slice(&v.to_le_bytes());
    }
    let mut f = std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    f.write_all(&bytes).with_context(|| format!("cannot write {}", path.display()))?;
    Ok(())
}

fn with_suffix(prefix: &Path, suffix: &str) -> PathBuf {
    let mut s = prefix.as_os_str().to_owned();
    s.push(suffix);
    PathBuf::from(s)
}

/// Midpoint subdivision: each triangle becomes four. Edge midpoints are computed from the same
/// two endpoints in either order (IEEE addition commutes), so neighbours agree exactly and the
/// surface stays watertight although midpoints are not shared.
fn subdivide(m: &Mesh) -> Mesh {
    let mut out = Mesh { name: m.name.clone(), ..Mesh::default() };
    let mut normals = m.normals.as_ref().map(|_| Vec::new());
    let mut mats = m.triangle_materials.as_ref().map(|_| Vec::new());
    for (ti, t) in m.triangles.iter().enumerate() {
        let p = t.map(|i| m.positions[i as usize]);
        let mid = |a: usize, b: usize| (p[a] + p[b]) * 0.5;
        let pts = [p[0], p[1], p[2], mid(0, 1), mid(1, 2), mid(2, 0)];
        let base = out.positions.len() as u32;
        out.positions.extend_from_slice(&pts);
        if let (Some(ns), Some(src)) = (&mut normals, &m.normals) {
            let n = t.map(|i| src[i as usize]);
            let nm = |a: usize, b: usize| (n[a] + n[b]).normalize_or(n[a]);
            ns.extend_from_slice(&[n[0], n[1], n[2], nm(0, 1), nm(1, 2), nm(2, 0)]);
        }
        for tri in [[0, 3, 5], [3, 1, 4], [5, 4, 2], [3, 4, 5]] {
            out.triangles.push(tri.map(|k| base + k));
            if let (Some(ms), Some(src)) = (&mut mats, &m.triangle_materials) {
                ms.push(src[ti]);
            }
        }
    }
    out.normals = normals;
    out.triangle_materials = mats;
    out
}

fn rays(a: &BenchRaysArgs) -> Result<()> {
    if a.reps == 0 {
        bail!("--reps must be at least 1");
    }
    let pool = input::thread_pool(a.threads)?;
    if a.subdivide > 4 {
        bail!("--subdivide {}: at most 4 (256 triangles per input triangle)", a.subdivide);
    }
    let mut scene = input::load(Some(&a.scene), false)?;
    for _ in 0..a.subdivide {
        scene.meshes = scene.meshes.iter().map(|m| std::sync::Arc::new(subdivide(m))).collect();
    }
    if a.builds == 0 {
        bail!("--builds must be at least 1");
    }
    pool.install(|| -> Result<()> {
        // Not sized from the user's count: a huge `--builds` only takes long.
        let options = match a.build {
            BuildArg::Spatial => BuildOptions::spatial(),
            BuildArg::Fast => BuildOptions::default(),
        };
        let mut builds = Vec::new();
        for _ in 1..a.builds {
            builds.push(World::with_build(scene.clone(), options.clone()).stats.build_ms);
        }
        let world = World::with_build(scene, options);
        builds.push(world.stats.build_ms);
        let build = if a.builds == 1 {
            format!("build {:.1} ms", builds[0])
        } else {
            format!("build median {:.1} ms, fastest {:.1} ms of {}", median(&mut builds), builds[0], a.builds)
        };
        out!(
            "scene: {} triangles, {} instances, {} planes; {build}; {:.1} bytes of BVH nodes per triangle",
            world.stats.triangles,
            world.stats.instances,
            world.stats.planes,
            world.stats.node_bytes as f64 / world.stats.triangles.max(1) as f64
        );
        let rays = make_rays(&world, a.kind, a.width, a.height, a.seed);
        if rays.is_empty() {
            bail!("no {:?} rays: the camera sees nothing of the scene", a.kind);
        }
        let occlusion = a.kind == RayKind::Shadow || a.any_hit;
        // Primary and shadow rays go 8 consecutive rays at a time (a 4×2 tile, or the shadow
        // rays of one) through the 8-ray queries; the others one at a time.
        let grouped = matches!(a.kind, RayKind::Primary | RayKind::Shadow);
        let one = |r: &Ray| {
            if occlusion {
                if world.occluded(r) { 1.0 } else { f32::INFINITY }
            } else {
                world.hit_distance(r).unwrap_or(f32::INFINITY)
            }
        };
        let eight = |h: &mut [f32], r: &[Ray; 8]| {
            if occlusion {
                let mut o = [false; 8];
                world.occluded8(r, &mut o);
                for (h, o) in h.iter_mut().zip(o) {
                    *h = if o { 1.0 } else { f32::INFINITY };
                }
            } else {
                let mut d = [None; 8];
                world.hit_distance8(r, &mut d);
                for (h, d) in h.iter_mut().zip(d) {
                    *h = d.unwrap_or(f32::INFINITY);
                }
            }
        };
        let trace = |hits: &mut [f32]| {
            hits.par_chunks_mut(4096).zip(rays.par_chunks(4096)).for_each(|(h, r)| {
                if !grouped {
                    for (h, r) in h.iter_mut().zip(r) {
                        *h = one(r);
                    }
                    return;
                }
                let mut hs = h.chunks_exact_mut(8);
                let mut rs = r.chunks_exact(8);
                for (h8, r8) in (&mut hs).zip(&mut rs) {
                    if let Ok(r8) = <&[Ray; 8]>::try_from(r8) {
                        eight(h8, r8);
                    }
                }
                for (h, r) in hs.into_remainder().iter_mut().zip(rs.remainder()) {
                    *h = one(r);
                }
            })
        };
        let mode = match (grouped, world.traces_packets()) {
            (true, true) => "8-ray packets (one untransformed mesh)",
            (true, false) => "groups of 8, single-ray traversal (scene is not one untransformed mesh)",
            (false, _) => "single rays",
        };
        out!("trace mode: {mode}");
        let mut hits = vec![0.0f32; rays.len()];
        trace(&mut hits); // warm-up, and the hits that are dumped
        let mut times = Vec::with_capacity(a.reps);
        for _ in 0..a.reps {
            let t0 = Instant::now();
            trace(&mut hits);
            times.push(t0.elapsed().as_secs_f64());
        }
        let med = median(&mut times);
        let mrays = rays.len() as f64 / med / 1e6;
        let hit_count = hits.iter().filter(|h| h.is_finite()).count();
        out!(
            "{:?} rays{}: {} ({} hit), {} threads, median of {} passes {:.2} ms",
            a.kind,
            if occlusion { ", any-hit queries" } else { "" },
            rays.len(),
            hit_count,
            rayon::current_num_threads(),
            a.reps,
            med * 1e3
        );
        if let Some(prefix) = &a.dump {
            let tris = world.world_triangles();
            if world.stats.planes > 0 || world.stats.spheres > 0 {
                eprintln!("glint: note: the dump holds triangles only; spheres and planes are left out");
            }
            write_f32s(
                &with_suffix(prefix, ".tris.f32"),
                tris.iter().flat_map(|t| t.iter().flat_map(|v| v.to_array())),
            )?;
            write_f32s(
                &with_suffix(prefix, ".rays.f32"),
                rays.iter()
                    .flat_map(|r| [r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax]),
            )?;
            write_f32s(&with_suffix(prefix, ".hits.f32"), hits.iter().copied())?;
            out!("dumped {} triangles and {} rays to {}.*", tris.len(), rays.len(), prefix.display());
        }
        out!("mrays_per_s_median={mrays:.3}");
        Ok(())
    })
}

fn whitted(a: &BenchWhittedArgs) -> Result<()> {
    if a.frames == 0 {
        bail!("--frames must be at least 1");
    }
    let pool = input::thread_pool(a.threads)?;
    let scene = match &a.scene {
        Some(p) => input::load(Some(p), false)?,
        None => glint_formats::load_scene_str(WHITTED_BENCH_SCENE, Path::new("."), "<whitted-bench.toml>")?.scene,
    };
    let sky_scene = match &a.sky {
        Some(p) => {
            let loaded =
                glint_formats::sky::load_sky(&glint_formats::sky::SkySource::Path(p.clone()), &Default::default())
                    .context("--sky")?;
            Some(Scene { sky: loaded.sky, ..scene.clone() })
        }
        None => None,
    };
    pool.install(|| -> Result<()> {
        let schedule = match a.schedule {
            ScheduleArg::Stealing => Schedule::WorkStealing,
            ScheduleArg::Static => Schedule::Static,
        };
        let image = ImageSettings { schedule, ..ImageSettings::new(a.width, a.height) };
        let whitted = WhittedSettings::from_defaults(&scene.render);
        let camera = scene.camera;
        let mut renderers = vec![("scene sky", Renderer::new(scene)?)];
        if let Some(s) = sky_scene {
            renderers.push(("--sky map", Renderer::new(s)?));
        }
        // Every (sky, kernel) variant, its frames interleaved with the others' so that all see
        // the same machine load; each warmed up first.
        let mut variants: Vec<(usize, KernelArg)> = Vec::new();
        for r in 0..renderers.len() {
            for &k in &a.kernel {
                variants.push((r, k));
            }
        }
        let mode = |k: KernelArg| Mode::Whitted(WhittedSettings { kernel: k.into(), ..whitted });
        // A frame as `glint render -o x.png` draws it (encoded to 8 bits band by band), or with
        // --aovs as `-o x.exr` and the viewer do (a float film with every AOV).
        let mut pixels = Vec::new();
        let mut frame = |renderer: &mut Renderer, k: KernelArg| {
            let hooks = Hooks::default();
            if a.aovs {
                renderer.render(&camera, &image, &mode(k), &hooks)
            } else {
                renderer.render_srgb8(&camera, &image, &mode(k), &hooks, &PngOptions::default(), &mut pixels)
            }
        };
        for &(r, k) in &variants {
            frame(&mut renderers[r].1, k)?;
        }
        let mut ms = vec![Vec::new(); variants.len()];
        let mut rays = vec![0; variants.len()];
        for _ in 0..a.frames {
            for (v, &(r, k)) in variants.iter().enumerate() {
                let stats = frame(&mut renderers[r].1, k)?;
                ms[v].push(stats.elapsed.as_secs_f64() * 1e3);
                rays[v] = stats.rays.total();
            }
        }
        let mut medians = Vec::new();
        for (v, times) in ms.iter_mut().enumerate() {
            let med = median(times);
            medians.push(med);
            let (r, k) = variants[v];
            out!(
                "whitted {}x{}, {} threads, {:?}, {}, {}, {k:?}: median {:.2} ms/frame ({:.1} fps), {:.1} Mrays/s, {} rays/frame",
                a.width,
                a.height,
                rayon::current_num_threads(),
                image.schedule,
                if a.aovs { "float film + AOVs" } else { "to 8-bit sRGB" },
                renderers[r].0,
                med,
                1e3 / med,
                rays[v] as f64 / med / 1e3,
                rays[v]
            );
        }
        if renderers.len() == 2 {
            let kernels = a.kernel.len();
            out!("sky_map_cost_ratio={:.4}", medians[kernels] / medians[0]);
        }
        out!("ms_per_frame_median={:.3}", medians[0]);
        Ok(())
    })
}

fn path(a: &BenchPathArgs) -> Result<()> {
    if a.frames == 0 || a.frames > 10_000 {
        bail!("--frames {}: must be 1..=10000", a.frames);
    }
    let pool = input::thread_pool(a.threads)?;
    let scene = input::load(Some(&a.scene), false)?;
    let (w, h) = (a.width.unwrap_or(scene.render.width), a.height.unwrap_or(scene.render.height));
    let image = ImageSettings { seed: a.seed, ..ImageSettings::new(w, h) };
    image.validate()?;
    let mut modes = glint_render::ModeSettings::from_defaults(&scene.render);
    modes.path.spp = a.spp;
    modes.path.max_bounces = a.max_bounces.unwrap_or(modes.path.max_bounces);
    modes.path.sampler = a.sampler.map_or(modes.path.sampler, Into::into);
    modes.path.reconstruction = a.reconstruction.into();
    modes.path.aovs = a.aovs;
    modes.path.filter = super::render::filter_from_args(a.filter, &clap_defaults::<FilterOptions>()?, w)?;
    modes.path.validate().context("path settings")?;
    if a.kernel.is_empty() {
        bail!("--kernel: name at least one path tracer");
    }
    let path = modes.path;
    let camera = scene.camera;
    pool.install(|| -> Result<()> {
        let mut renderer = Renderer::new(scene)?;
        let mode = |k: PathKernelArg| Mode::Path(glint_render::path::PathSettings { kernel: k.into(), ..path });
        for &k in &a.kernel {
            renderer.render(&camera, &image, &mode(k), &Hooks::default())?; // warm-up
        }
        let n = a.kernel.len();
        let (mut ms, mut mrays) = (vec![Vec::with_capacity(a.frames); n], vec![Vec::with_capacity(a.frames); n]);
        // Each stage's times (trace, filter), per kernel, as `glint render` reports them.
        let mut stages = vec![StageTimes::default(); n];
        for _ in 0..a.frames {
            for (i, &k) in a.kernel.iter().enumerate() {
                let stats = renderer.render(&camera, &image, &mode(k), &Hooks::default())?;
                ms[i].push(stats.elapsed.as_secs_f64() * 1e3);
                mrays[i].push(stats.mrays_per_second());
                for &(name, d) in &stats.stages {
                    stages[i].push(name, d.as_secs_f64() * 1e3);
                }
            }
        }
        let paths = f64::from(w) * f64::from(h) * f64::from(a.spp);
        let mut mpaths = Vec::with_capacity(n);
        for (i, k) in a.kernel.iter().enumerate() {
            let med = median(&mut ms[i]);
            mpaths.push(paths / med / 1e3);
            out!(
                "path {w}x{h}, {} spp, {} bounces, filter {}, {} threads, {k:?}: median {med:.2} ms/frame, {:.3} M paths/s, {:.1} Mrays/s; stages (medians, ms): {}",
                a.spp,
                path.max_bounces,
                path.filter,
                rayon::current_num_threads(),
                mpaths[i],
                median(&mut mrays[i]),
                stages[i].medians(),
            );
        }
        let mpaths = mpaths[0];
        out!("mpaths_per_s_median={mpaths:.4}");
        Ok(())
    })
}
