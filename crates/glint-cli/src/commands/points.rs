//! `glint points sample`, and what `glint render --mode points` needs from the command line:
//! normal and radius estimation for clouds without them (with a progress bar), and the points
//! mode's settings.

use crate::cli::{PointArgs, PointsCommand, SampleArgs};
use crate::progress::LazyProgress;
use anyhow::{Context, Result, bail};
use glint_render::ImageSettings;
use glint_render::points::PointSettings;
use glint_scene::{EstimateSettings, Mesh, Scene};
use std::sync::Arc;
use std::time::Instant;

pub fn run(cmd: PointsCommand) -> Result<()> {
    match cmd {
        PointsCommand::Sample(args) => sample(&args),
    }
}

/// Give every cloud of `scene` normals and radii (k-nearest-neighbour estimation where the file
/// had none), and scale the radii by `--radius-scale`.
pub fn prepare_clouds(scene: &mut Scene, args: &PointArgs, quiet: bool) -> Result<()> {
    let settings = estimate_settings(args)?;
    for object in &mut scene.clouds {
        let missing_normals = object.cloud.normals.is_none();
        let missing_radii = object.cloud.radii.is_none();
        if !missing_normals && !missing_radii {
            if args.radius_scale != 1.0 {
                let cloud = Arc::make_mut(&mut object.cloud);
                if let Some(r) = &mut cloud.radii {
                    r.iter_mut().for_each(|r| *r *= args.radius_scale);
                }
            }
            continue;
        }
        let start = Instant::now();
        let cloud = Arc::make_mut(&mut object.cloud);
        if !missing_radii
            && args.radius_scale != 1.0
            && let Some(r) = &mut cloud.radii
        {
            r.iter_mut().for_each(|r| *r *= args.radius_scale);
        }
        let n = cloud.len() as u64;
        let bar = LazyProgress::new(n * (u64::from(missing_normals) + u64::from(missing_radii)), !quiet);
        glint_scene::prepare(cloud, &settings, &|done| bar.advance(done as u64));
        bar.finish();
        cloud.validate().with_context(|| format!("point cloud '{}' after estimation", object.name))?;
        if !quiet {
            let what = match (missing_normals, missing_radii) {
                (true, true) => "normals and radii",
                (true, false) => "normals",
                _ => "radii",
            };
            eprintln!(
                "glint: estimated {what} of '{}' ({} points, k = {}) in {:.2} s{}",
                object.name,
                cloud.len(),
                settings.k,
                start.elapsed().as_secs_f64(),
                if missing_normals && cloud.orientation == glint_scene::Orientation::Unknown {
                    "; orientation unknown: drawn two-sided"
                } else {
                    ""
                }
            );
        }
    }
    Ok(())
}

/// The normal and radius estimation settings of `--neighbours` and `--radius-scale`.
fn estimate_settings(args: &PointArgs) -> Result<EstimateSettings> {
    let settings = EstimateSettings { k: args.neighbours, radius_scale: args.radius_scale };
    settings
        .validate()
        .with_context(|| format!("--neighbours {} --radius-scale {}", args.neighbours, args.radius_scale))?;
    Ok(settings)
}

/// Check the points-mode options that do not depend on the image, naming the flag at fault:
/// called before any cloud is read, so a typo does not wait for a large file.
pub fn check_point_args(args: &PointArgs) -> Result<()> {
    estimate_settings(args)?;
    point_settings(args, &ImageSettings::new(1, 1)).map(|_| ())
}

/// The points mode's settings from the command line, checked for `image`.
pub fn point_settings(args: &PointArgs, image: &ImageSettings) -> Result<PointSettings> {
    let settings = PointSettings {
        fill: args.fill.into(),
        shading: args.shading.into(),
        square_side: args.square_size,
        edl_strength: args.edl_strength,
        cull: !args.two_sided,
    };
    settings.validate(image).with_context(|| {
        format!(
            "points mode ({}x{}, --square-size {}, --edl-strength {})",
            image.width, image.height, args.square_size, args.edl_strength
        )
    })?;
    Ok(settings)
}

/// The meshes of a model file as one mesh (positions and triangles concatenated; normals kept
/// when every part has them).
fn merged_mesh(meshes: Vec<Mesh>) -> Mesh {
    let keep_normals = meshes.iter().all(|m| m.normals.is_some());
    let mut out = Mesh { name: "merged".into(), normals: keep_normals.then(Vec::new), ..Mesh::default() };
    for m in meshes {
        let base = out.positions.len() as u32;
        out.positions.extend(&m.positions);
        if let (Some(all), Some(n)) = (&mut out.normals, &m.normals) {
            all.extend(n);
        }
        out.triangles.extend(m.triangles.iter().map(|t| t.map(|i| i + base)));
    }
    out
}

fn sample(args: &SampleArgs) -> Result<()> {
    let ext = args.output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if ext.as_deref() != Some("ply") {
        bail!("output {}: point clouds are written as .ply", args.output.display());
    }
    if args.count == 0 {
        bail!("--count 0: ask for at least one point");
    }
    let start = Instant::now();
    let (meshes, _, _) =
        glint_formats::load_mesh(&args.mesh).with_context(|| format!("cannot load {}", args.mesh.display()))?;
    let mesh = merged_mesh(meshes);
    let mut cloud = glint_scene::sample_mesh(&mesh, args.count, args.seed)
        .with_context(|| format!("cannot sample {}", args.mesh.display()))?;
    cloud.name = args.mesh.file_stem().map_or_else(|| "points".into(), |s| s.to_string_lossy().into_owned());
    glint_formats::points::write_ply_cloud(&args.output, &cloud)
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    if !args.quiet {
        eprintln!(
            "glint: {} points from {} ({} triangles) in {:.2} s -> {}",
            cloud.len(),
            args.mesh.display(),
            mesh.triangles.len(),
            start.elapsed().as_secs_f64(),
            args.output.display()
        );
    }
    Ok(())
}
