//! Loading what the user named: a scene file, a model file, or the built-in demo scene.

use crate::cli::SceneArgs;
use anyhow::{Context, Result, bail};
use glint_core::Vec3;
use glint_formats::points::{ColourBy, PointReadOptions};
use glint_scene::Scene;
use std::path::Path;

/// Load a scene, model or point cloud (the demo scene when `path` is None); warnings go to
/// stderr.
pub fn load(path: Option<&Path>, quiet: bool) -> Result<Scene> {
    load_with(path, ColourBy::Auto, quiet)
}

/// [`load`], colouring a point-cloud file's points by `colour_by`.
pub fn load_with(path: Option<&Path>, colour_by: ColourBy, quiet: bool) -> Result<Scene> {
    load_scene(path, colour_by, &SceneArgs::default(), quiet)
}

/// What kind of file the options of [`SceneArgs`] apply to, by extension.
fn kind_of(path: &Path) -> &'static str {
    match path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() {
        Some("xml") => "xml",
        Some("gltf" | "glb") => "gltf",
        _ => "other",
    }
}

/// `-D NAME=VALUE` pairs.
fn defines(args: &SceneArgs) -> Result<Vec<(String, String)>> {
    args.define
        .iter()
        .map(|d| match d.split_once('=') {
            Some((name, value)) if !name.trim().is_empty() => Ok((name.trim().to_string(), value.to_string())),
            _ => bail!("-D {d:?}: expected NAME=VALUE"),
        })
        .collect()
}

/// [`load_with`] with the options of scene files from other renderers (`-D`, `--lenient`,
/// `--camera-name`), refused for files they do not apply to.
pub fn load_scene(path: Option<&Path>, colour_by: ColourBy, args: &SceneArgs, quiet: bool) -> Result<Scene> {
    let options = PointReadOptions { colour_by };
    let kind = path.map_or("demo", kind_of);
    if !args.define.is_empty() && kind != "xml" {
        bail!("-D sets parameters of a Mitsuba XML scene (.xml); this input is not one");
    }
    if args.camera_name.is_some() && kind != "gltf" {
        bail!("--camera-name picks a camera of a glTF file (.gltf, .glb); this input is not one");
    }
    if args.lenient && kind != "xml" {
        bail!("--lenient applies to Mitsuba XML files (.xml); this input is not one");
    }
    let policy = match &args.sandbox {
        Some(dir) => glint_formats::FilePolicy::sandbox(dir).context("--sandbox")?,
        None => glint_formats::FilePolicy::open(),
    };
    policy.apply(|| load_policed(path, kind, &options, args, quiet))
}

/// [`load_scene`] under the file policy in force.
fn load_policed(
    path: Option<&Path>,
    kind: &str,
    options: &PointReadOptions,
    args: &SceneArgs,
    quiet: bool,
) -> Result<Scene> {
    let loaded = match path {
        Some(p) if kind == "xml" => {
            let m = glint_formats::mitsuba::load(p, &defines(args)?, args.lenient)
                .with_context(|| format!("cannot load {}", p.display()))?;
            glint_formats::Loaded { scene: m.scene, warnings: m.warnings }
        }
        Some(p) if kind == "gltf" => {
            let o = glint_formats::GltfOptions { camera_name: args.camera_name.clone() };
            glint_formats::load_gltf(p, &o).with_context(|| format!("cannot load {}", p.display()))?
        }
        Some(p) => glint_formats::load_with(p, options).with_context(|| format!("cannot load {}", p.display()))?,
        None => glint_formats::load_scene_str(glint_formats::DEMO_SCENE, Path::new("."), "<built-in demo scene>")
            .context("the built-in demo scene does not load (a bug)")?,
    };
    if !quiet {
        for w in &loaded.warnings {
            eprintln!("glint: warning: {}", glint_formats::printable(w));
        }
    }
    Ok(loaded.scene)
}

/// Parse "X,Y,Z" into a vector of finite numbers.
pub fn parse_vec3(flag: &str, text: &str) -> Result<Vec3> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        bail!("--{flag} {text:?}: expected three comma-separated numbers X,Y,Z");
    }
    let mut v = [0.0f32; 3];
    for (slot, p) in v.iter_mut().zip(&parts) {
        let x: f32 = p.parse().with_context(|| format!("--{flag} {text:?}: {p:?} is not a number"))?;
        if !x.is_finite() {
            bail!("--{flag} {text:?}: {p:?} is not a finite number");
        }
        *slot = x;
    }
    Ok(Vec3::from_array(v))
}

/// A rayon pool builder for `threads` workers (all cores when None), the count checked.
fn pool_builder(threads: Option<usize>) -> Result<rayon::ThreadPoolBuilder> {
    let b = rayon::ThreadPoolBuilder::new();
    Ok(match threads {
        Some(n) if n == 0 || n > 1024 => bail!("--threads {n}: must be between 1 and 1024"),
        Some(n) => b.num_threads(n),
        None => b,
    })
}

/// A rayon pool with `threads` workers (all cores when None).
pub fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    pool_builder(threads)?.build().context("cannot start worker threads")
}

/// Make `threads` workers (all cores when None) rayon's global pool: for the viewer, whose
/// window must stay on the main thread while frames are drawn by the pool.
pub fn global_thread_pool(threads: Option<usize>) -> Result<()> {
    pool_builder(threads)?.build_global().context("cannot start worker threads")
}
