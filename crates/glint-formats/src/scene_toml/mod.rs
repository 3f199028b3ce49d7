//! The TOML scene format (documented in docs/scene-format.md): text → [`Scene`].
//!
//! Two steps. serde reads the text into the plain structs of [`defs`] (unknown keys, wrong
//! types and non-finite numbers stop there, with the toml crate's span of the culprit); then
//! [`Builder`] resolves names, checks which keys each `type` allows, loads the referenced model
//! and image files (paths relative to the scene file) and assembles the scene, reporting every
//! problem at the line of the key that caused it. The result is validated once more by
//! [`Scene::validate`], so nothing downstream can meet a value this module let through.
//!
//! This file holds the builder, its error helpers and the value checks every table shares; each
//! kind of table is built in its own file, in the order [`Builder::build`] reads them:
//! [`render`] (`[image]`, `[render]`), [`camera`], [`sky`] (`background`, `[sky]`),
//! [`materials`] (`[[texture]]`, `[[material]]`), [`lights`], [`objects`] (with [`meshes`] for
//! mesh objects) and [`animation`] (`[light.animation]`, `[object.animation]`).

mod animation;
mod camera;
mod defs;
mod lights;
mod materials;
mod meshes;
mod objects;
mod render;
mod sky;
mod values;

pub(crate) use defs::Shading;

use crate::Loaded;
use crate::error::FormatError;
use crate::files;
use crate::model::Model;
use defs::{SceneDef, Span};
use glint_core::{Rgb, Vec3};
use glint_scene::{AnimationTarget, Light, Motion, Scene, TextureImage};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;
use toml::Spanned;
use values::{Num, V3};

/// Default ambient light I_a when a scene gives none: white, so that a material's `ambient`
/// (K_a) is the fraction of its colour seen in full shadow.
const DEFAULT_AMBIENT: Rgb = Rgb::ONE;

/// Reads a scene from TOML text. `file` names the text in messages; relative paths in it are
/// resolved against `base_dir`.
pub(crate) fn load_scene_text(text: &str, base_dir: &Path, file: &Path) -> Result<Loaded, FormatError> {
    let def: SceneDef = toml::from_str(text).map_err(|e| syntax_error(text, file, &e))?;
    let mut b = Builder {
        text,
        file,
        base_dir,
        scene: Scene { ambient: DEFAULT_AMBIENT, ..Scene::default() },
        warnings: Vec::new(),
        texture_names: HashMap::new(),
        material_names: HashMap::new(),
        default_material: None,
        models: HashMap::new(),
        meshes: HashMap::new(),
        images: HashMap::new(),
    };
    b.build(def)?;
    let Builder { scene, warnings, .. } = b;
    scene.validate().map_err(|source| FormatError::Invalid { file: file.to_path_buf(), source })?;
    Ok(Loaded { scene, warnings })
}

/// 1-based line and column (in characters) of byte offset `at` in `text`.
pub(crate) fn line_column(text: &str, at: usize) -> (usize, usize) {
    let at = at.min(text.len());
    let mut start = at;
    while start > 0 && !text.is_char_boundary(start) {
        start -= 1;
    }
    let before = &text[..start];
    let line = before.bytes().filter(|&b| b == b'\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    let column = before[line_start..].chars().count() + 1;
    (line, column)
}

fn syntax_error(text: &str, file: &Path, e: &toml::de::Error) -> FormatError {
    let (line, column) = e.span().map_or((1, 1), |s| line_column(text, s.start));
    let mut message = e.message().trim().to_string();
    if ["`background`", "`ambient`"].iter().any(|k| message.starts_with(&format!("unknown field {k}"))) {
        message.push_str(" (top-level keys must come before the first [table]: TOML puts later keys inside it)");
    }
    FormatError::Syntax { file: file.to_path_buf(), line, column, message }
}

/// A mesh file read once, its materials and textures already in the scene (unless overridden).
type ModelKey = (PathBuf, Option<Shading>);

struct Builder<'a> {
    text: &'a str,
    file: &'a Path,
    base_dir: &'a Path,
    scene: Scene,
    warnings: Vec<String>,
    texture_names: HashMap<String, usize>,
    material_names: HashMap<String, usize>,
    default_material: Option<usize>,
    models: HashMap<ModelKey, Rc<Model>>,
    /// Scene mesh indices of a model file, keyed also by whether the object overrides the
    /// file's materials (then the meshes carry no per-triangle materials).
    meshes: HashMap<(PathBuf, Option<Shading>, bool), Vec<usize>>,
    images: HashMap<PathBuf, Arc<TextureImage>>,
}

impl Builder<'_> {
    fn err(&self, span: &Span, message: impl Into<String>) -> FormatError {
        let (line, column) = line_column(self.text, span.start);
        FormatError::Value { file: self.file.to_path_buf(), line, column, message: message.into() }
    }

    /// `missing key` errors point at the table that lacks it.
    fn missing(&self, span: &Span, message: impl Into<String>) -> FormatError {
        let (line, column) = line_column(self.text, span.start);
        FormatError::Syntax { file: self.file.to_path_buf(), line, column, message: message.into() }
    }

    fn place(&self, span: &Span) -> String {
        let (line, _) = line_column(self.text, span.start);
        format!("{}:{line}", self.file.display())
    }

    /// The tables in dependency order: textures before the materials that name them,
    /// materials before the objects, and animations right after what they move.
    fn build(&mut self, def: SceneDef) -> Result<(), FormatError> {
        if def.object.is_empty() {
            return Err(FormatError::Invalid { file: self.file.to_path_buf(), source: glint_scene::SceneError::Empty });
        }
        self.scene.render = self.render_defaults(&def)?;
        self.scene.camera = match &def.camera {
            Some(c) => self.camera(c)?,
            None => return Err(self.missing(&(0..0), "the scene has no [camera] table")),
        };
        self.scene.sky = self.sky(def.sky.as_ref(), def.background.as_ref())?;
        if let Some(a) = &def.ambient {
            self.scene.ambient = self.colour(a, "ambient")?;
        }
        for t in &def.texture {
            self.texture(t)?;
        }
        for m in &def.material {
            self.material(m)?;
        }
        for l in &def.light {
            let light = self.light(l)?;
            self.scene.lights.push(light);
            if let Some(a) = &l.get_ref().animation {
                let directional = matches!(light, Light::Directional { .. });
                let motion = self.animation(a, directional)?;
                self.animate(&[AnimationTarget::Light(self.scene.lights.len() - 1)], motion)?;
            }
        }
        for (i, o) in def.object.iter().enumerate() {
            self.object(i + 1, o)?;
        }
        // Animated scenes load as they are at t = 0.
        self.scene.set_time(0.0);
        Ok(())
    }

    fn animate(&mut self, targets: &[AnimationTarget], motion: Motion) -> Result<(), FormatError> {
        self.scene
            .animate(targets, motion)
            .map_err(|source| FormatError::Invalid { file: self.file.to_path_buf(), source })
    }

    fn colour(&self, c: &Spanned<V3>, key: &str) -> Result<Rgb, FormatError> {
        let v = c.get_ref().0;
        if v.min_element() < 0.0 {
            return Err(self.err(&c.span(), format!("`{key}` must not be negative (linear RGB)")));
        }
        Ok(v)
    }

    fn non_negative(&self, v: &Spanned<Num>, key: &str) -> Result<f32, FormatError> {
        let x = v.get_ref().0;
        if x < 0.0 {
            return Err(self.err(&v.span(), format!("`{key}` = {x} must not be negative")));
        }
        Ok(x)
    }

    fn unit_interval(&self, v: &Spanned<Num>, key: &str) -> Result<f32, FormatError> {
        let x = v.get_ref().0;
        if !(0.0..=1.0).contains(&x) {
            return Err(self.err(&v.span(), format!("`{key}` = {x} must be in [0, 1]")));
        }
        Ok(x)
    }

    /// A unit direction from a vector that must not vanish.
    fn direction(&self, v: &Spanned<V3>, key: &str) -> Result<Vec3, FormatError> {
        v.get_ref().0.try_normalize().ok_or_else(|| self.err(&v.span(), format!("`{key}` has zero length")))
    }

    /// The file a scene's `key` names: it must exist, be a regular file and (under a
    /// sandbox) lie inside it ([`files::check`]).
    fn resolve(&self, path: &Spanned<String>, key: &str) -> Result<PathBuf, FormatError> {
        let p = self.base_dir.join(path.get_ref());
        if !p.exists() {
            return Err(FormatError::MissingFile { file: p, referenced_from: self.place(&path.span()) });
        }
        let field = format!("line {} `{key}`", line_column(self.text, path.span().start).0);
        files::check(&p, Some(files::Referrer::new(self.file, &field)))?;
        Ok(p)
    }

    fn disallow(&self, keys: &[(&'static str, Span)], allowed: &[&str], what: &str) -> Result<(), FormatError> {
        match keys.iter().find(|(k, _)| !allowed.contains(k)) {
            Some((k, span)) => Err(self.err(span, format!("`{k}` does not apply to {what}"))),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests;
