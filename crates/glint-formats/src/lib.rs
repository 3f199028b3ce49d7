//! glint-formats: files → [`Scene`]. All parsing in glint lives here.
//!
//! - the TOML scene format (docs/scene-format.md): serde with unknown keys rejected, every
//!   error at its file:line:column, names and paths resolved, the result validated;
//! - Mitsuba 3 XML scenes ([`mitsuba`]), with their render settings;
//! - model files: OBJ/MTL (own parser, fast, errors with line numbers), PLY (own parser:
//!   ASCII and binary, general element/property reader shared with point clouds), glTF 2.0
//!   (.gltf/.glb through the `gltf` crate, read as a whole scene by [`load_gltf`]: cameras,
//!   punctual lights, physically based materials);
//! - [`scene_for_model`]: a camera, lights and a sky to look at a model without a scene file;
//! - sky images ([`load_sky`], [`write_sky`]): six faces by name, crosses, strips and lat-long
//!   maps, LDR and HDR (docs/skies.md).
//!
//! Sits between glint-scene (what it produces) and the binaries; it never renders, and nothing
//! but the binaries and tests depends on it. A file is fully understood or rejected: unknown
//! keys, NaN, absurd counts and dangling references are errors ([`FormatError`]), and what was
//! recovered from (zero-area triangles, a missing .mtl) is reported in [`Loaded::warnings`].
#![forbid(unsafe_code)]

pub mod error;
pub mod files;
mod gltf_file;
pub mod mitsuba;
mod model;
mod obj;
pub mod ply;
pub mod points;
mod scene_toml;
pub mod sky;
mod texture_file;

pub use error::{FormatError, printable};
pub use files::FilePolicy;
pub use gltf_file::{GltfOptions, load_gltf};
pub use model::{Model, default_camera, load_model, scene_for_cloud, scene_for_model};
pub use sky::{
    FaceTransform, LoadedSky, SkyLayout, SkyLoadOptions, SkyMapRef, SkySource, SkyWriteOptions, WrittenSky, load_sky,
    seam_mismatch, write_sky,
};

use glint_scene::{Material, Mesh, Scene, Texture};
use model::ModelFormat;
use std::path::Path;

/// The default scene, built into the binary (self-contained: no external files).
pub const DEMO_SCENE: &str = include_str!("../../../scenes/demo.toml");

/// A scene read from files, and what was recovered from on the way.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub scene: Scene,
    /// Problems glint worked around, each starting with the file it is about, e.g.
    /// "bunny.ply: dropped 3 zero-area triangles".
    pub warnings: Vec<String>,
}

/// Reads a scene (`.toml`; a Mitsuba 3 `.xml` read strictly with no parameters: see
/// [`mitsuba::load`] for parameters, leniency and the render settings; a glTF file,
/// `.gltf`/`.glb`: see [`load_gltf`]), a model to look at (`.obj`, `.ply`; see
/// [`scene_for_model`]) or a point cloud (`.las`, `.laz`, `.xyz`, `.pts`, and a `.ply` without
/// faces; see [`scene_for_cloud`]), by extension, case-insensitive.
pub fn load(path: &Path) -> Result<Loaded, FormatError> {
    load_with(path, &points::PointReadOptions::default())
}

/// [`load`], colouring a point cloud file as `points` says (scene files say it themselves).
pub fn load_with(path: &Path, points: &points::PointReadOptions) -> Result<Loaded, FormatError> {
    let ext = model::extension(path);
    if points::is_point_cloud_path(path) || (ext.eq_ignore_ascii_case("ply") && points::ply_is_point_cloud(path)?) {
        let cloud = points::read_point_cloud(path, points)?;
        let warnings = points::coincident_warning(path, &cloud).into_iter().collect();
        let scene = scene_for_cloud(cloud);
        scene.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
        return Ok(Loaded { scene, warnings });
    }
    if ext.eq_ignore_ascii_case("xml") {
        let m = mitsuba::load(path, &[], false)?;
        return Ok(Loaded { scene: m.scene, warnings: m.warnings });
    }
    if ext.eq_ignore_ascii_case("toml") {
        let text = files::read_text(path, None, "a TOML scene")?;
        let base_dir = path.parent().unwrap_or(Path::new(""));
        return scene_toml::load_scene_text(&text, base_dir, path);
    }
    match ModelFormat::from_extension(&ext) {
        None => return Err(FormatError::UnsupportedFormat { file: path.to_path_buf(), extension: ext }),
        // A glTF file is a scene of its own: its cameras, lights and materials.
        Some(ModelFormat::Gltf) => return load_gltf(path, &GltfOptions::default()),
        Some(_) => {}
    }
    let mut model = load_model(path)?;
    let warnings = std::mem::take(&mut model.warnings);
    let scene = scene_for_model(model);
    scene.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    Ok(Loaded { scene, warnings })
}

/// Reads a TOML scene from memory (the embedded [`DEMO_SCENE`], tests). Relative paths in it
/// are resolved against `base_dir`; `name` stands for the file in messages.
pub fn load_scene_str(text: &str, base_dir: &Path, name: &str) -> Result<Loaded, FormatError> {
    scene_toml::load_scene_text(text, base_dir, Path::new(name))
}

/// Meshes, the materials their `triangle_materials` index, the textures those index.
pub type MeshParts = (Vec<Mesh>, Vec<Material>, Vec<Texture>);

/// A model file as meshes, with the materials their `triangle_materials` index and the
/// textures those materials index. Warnings are dropped; use [`load_model`] to see them.
pub fn load_mesh(path: &Path) -> Result<MeshParts, FormatError> {
    let m = load_model(path)?;
    Ok((m.meshes, m.materials, m.textures))
}

#[cfg(test)]
pub(crate) mod test_util {
    use std::path::{Path, PathBuf};

    /// A fresh directory under the system temp dir, removed when dropped.
    pub struct TempDir(PathBuf);

    impl TempDir {
        pub fn new(name: &str) -> TempDir {
            let dir = std::env::temp_dir().join(format!("glint-formats-{}-{name}", std::process::id()));
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).expect("create temp dir");
            TempDir(dir)
        }

        pub fn path(&self) -> &Path {
            &self.0
        }

        pub fn join(&self, name: &str) -> PathBuf {
            self.0.join(name)
        }
    }

    impl Drop for TempDir {
        fn drop(&mut self) {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}
