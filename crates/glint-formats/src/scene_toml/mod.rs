//! The TOML scene format (documented in docs/scene-format.md): text → [`Scene`].
//!
//! Two steps. serde reads the text into the plain structs of [`defs`] (unknown keys, wrong
//! types and non-finite numbers stop there, with the toml crate's span of the culprit); then
//! [`Builder`] resolves names, checks which keys each `type` allows, loads the referenced model
//! and image files (paths relative to the scene file) and assembles the scene, reporting every
//! problem at the line of the key that caused it. The result is validated once more by
//! [`Scene::validate`], so nothing downstream can meet a value this module let through.

mod defs;
mod values;

pub(crate) use defs::Shading;

use crate::error::FormatError;
use crate::model::{self, Model};
use crate::points::{self, ColourBy, PointReadOptions};
use crate::sky::{FaceTransform, LoadedSky, SkyLoadOptions, SkySource, load_sky};
use crate::{Loaded, texture_file};
use defs::{
    AnimationDef, CameraDef, Falloff, Flip, LightDef, LightKind, MaterialDef, ObjectDef, ObjectKind, RepeatDef,
    SceneDef, SkyDef, SkyKind, Span, TextureDef, TextureKind,
};
use glint_core::{Affine3A, Mat3, Rgb, Vec2, Vec3};
use glint_scene::scene::MAX_IMAGE_SIDE;
use glint_scene::{
    AnimationTarget, Attenuation, Camera, CloudObject, CubeFace, Fov, Keyframes, Light, Material, Mesh, Motion, Object,
    RenderDefaults, RenderMode, Repeat, Rotation, Scene, Shape, Sky, Texture, TextureImage,
};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::rc::Rc;
use std::sync::Arc;
use toml::Spanned;
use values::{Num, V3};

/// Default ambient light I_a when a scene gives none: white, so that a material's `ambient`
/// (K_a) is the fraction of its colour seen in full shadow.
const DEFAULT_AMBIENT: Rgb = Rgb::ONE;

/// Largest `max_depth` accepted: far beyond any useful depth, small enough for any integrator.
const MAX_DEPTH: u32 = 64;

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

fn flip_transform(f: Flip) -> FaceTransform {
    FaceTransform {
        flip_horizontal: matches!(f, Flip::Horizontal | Flip::Both),
        flip_vertical: matches!(f, Flip::Vertical | Flip::Both),
        rotate_degrees: 0,
    }
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

    /// `[object.animation]` or `[light.animation]`. A directional light has no position: it
    /// can only turn, about no particular point.
    fn animation(&self, a: &Spanned<AnimationDef>, directional: bool) -> Result<Motion, FormatError> {
        let def = a.get_ref();
        if def.rotate.is_none() && def.keyframes.is_none() {
            return Err(self.missing(&a.span(), "an animation needs `rotate`, `keyframes` or both"));
        }
        let rotation = match &def.rotate {
            Some(r) => {
                let rd = r.get_ref();
                let Some(axis) = &rd.axis else {
                    return Err(self.missing(&r.span(), "`rotate` needs `axis` (a direction)"));
                };
                let Some(speed) = &rd.degrees_per_second else {
                    return Err(self.missing(&r.span(), "`rotate` needs `degrees_per_second`"));
                };
                if directional && let Some(p) = &rd.pivot {
                    return Err(
                        self.err(&p.span(), "`pivot` does not apply to a directional light (it has no position)")
                    );
                }
                Some(Rotation {
                    axis: self.direction(axis, "axis")?,
                    pivot: rd.pivot.as_ref().map(|p| p.get_ref().0),
                    degrees_per_second: speed.get_ref().0,
                    phase_deg: rd.phase_deg.as_ref().map_or(0.0, |p| p.get_ref().0),
                })
            }
            None => None,
        };
        let translation = match &def.keyframes {
            Some(ks) => {
                if directional {
                    return Err(self.err(
                        &ks.span(),
                        "a directional light has no position to move: `keyframes` do not apply (use `rotate`)",
                    ));
                }
                if ks.get_ref().is_empty() {
                    return Err(self.err(&ks.span(), "`keyframes` needs at least one key"));
                }
                let mut keys: Vec<(f32, Vec3)> = Vec::with_capacity(ks.get_ref().len());
                for k in ks.get_ref() {
                    let (Some(time), Some(offset)) = (&k.get_ref().time, &k.get_ref().offset) else {
                        return Err(self.missing(&k.span(), "a key needs `time` (seconds) and `offset` ([x, y, z])"));
                    };
                    let t = time.get_ref().0;
                    if let Some(&(previous, _)) = keys.last()
                        && t <= previous
                    {
                        return Err(self.err(
                            &time.span(),
                            format!(
                                "key time {t} must be after the previous key's ({previous}): times increase strictly"
                            ),
                        ));
                    }
                    keys.push((t, offset.get_ref().0));
                }
                let repeat = match def.repeat.as_ref().map(|r| *r.get_ref()) {
                    Some(RepeatDef::Hold) => Repeat::Hold,
                    Some(RepeatDef::Loop) | None => Repeat::Loop,
                    Some(RepeatDef::PingPong) => Repeat::PingPong,
                };
                Some(Keyframes { keys, repeat })
            }
            None => {
                if let Some(r) = &def.repeat {
                    return Err(self.err(&r.span(), "`repeat` applies to `keyframes`, and there are none"));
                }
                None
            }
        };
        Ok(Motion { rotation, translation })
    }

    fn render_defaults(&self, def: &SceneDef) -> Result<RenderDefaults, FormatError> {
        let mut r = RenderDefaults::default();
        if let Some(image) = &def.image {
            for (value, slot, key) in [(&image.width, &mut r.width, "width"), (&image.height, &mut r.height, "height")]
            {
                if let Some(v) = value {
                    let n = *v.get_ref();
                    if n == 0 || n > MAX_IMAGE_SIDE {
                        return Err(self.err(&v.span(), format!("image {key} {n} must be in 1..={MAX_IMAGE_SIDE}")));
                    }
                    *slot = n;
                }
            }
            if let Some(s) = &image.samples {
                let n = *s.get_ref();
                if n == 0 || n > 64 {
                    return Err(self.err(&s.span(), format!("samples {n} must be in 1..=64 (N gives N×N per pixel)")));
                }
                r.samples_per_side = n;
            }
        }
        if let Some(render) = &def.render {
            if let Some(d) = &render.max_depth {
                let n = *d.get_ref();
                if n > MAX_DEPTH {
                    return Err(self.err(&d.span(), format!("max_depth {n} must be at most {MAX_DEPTH}")));
                }
                r.max_depth = n;
            }
            if let Some(c) = &render.min_contribution {
                r.min_contribution = self.non_negative(c, "min_contribution")?;
            }
            if let Some(m) = &render.mode {
                r.mode = match m.get_ref().as_str() {
                    "whitted" => RenderMode::Whitted,
                    "path" => RenderMode::Path,
                    "points" => RenderMode::Points,
                    other => {
                        return Err(
                            self.err(&m.span(), format!("mode {other:?}: use \"whitted\", \"path\" or \"points\""))
                        );
                    }
                };
            }
            if let Some(b) = &render.max_bounces {
                let n = *b.get_ref();
                if n > MAX_DEPTH {
                    return Err(self.err(&b.span(), format!("max_bounces {n} must be at most {MAX_DEPTH}")));
                }
                r.max_bounces = n;
            }
        }
        Ok(r)
    }

    fn camera(&self, c: &Spanned<CameraDef>) -> Result<Camera, FormatError> {
        let def = c.get_ref();
        let position = match &def.position {
            Some(p) => p.get_ref().0,
            None => return Err(self.missing(&c.span(), "[camera] needs `position`")),
        };
        let forward = match (&def.look_at, &def.forward) {
            (Some(_), Some(f)) => return Err(self.err(&f.span(), "give either `look_at` or `forward`, not both")),
            (Some(t), None) => {
                let d = t.get_ref().0 - position;
                if d.length_squared() == 0.0 {
                    return Err(self.err(&t.span(), "`look_at` equals the camera position"));
                }
                d
            }
            (None, Some(f)) => self.direction(f, "forward")?,
            (None, None) => return Err(self.missing(&c.span(), "[camera] needs `look_at` or `forward`")),
        };
        let up = match &def.up {
            Some(u) => self.direction(u, "up")?,
            None => Vec3::Y,
        };
        if forward.normalize().cross(up).length_squared() < 1e-12 {
            let span = def.up.as_ref().map_or(c.span(), Spanned::span);
            return Err(self.err(&span, "`up` is parallel to the view direction"));
        }
        let fov = match (&def.fov, &def.hfov) {
            (Some(_), Some(h)) => return Err(self.err(&h.span(), "give either `fov` (vertical) or `hfov`, not both")),
            (Some(v), None) => Fov::Vertical(self.angle(v, "fov")?),
            (None, Some(h)) => Fov::Horizontal(self.angle(h, "hfov")?),
            (None, None) => Fov::Vertical(45.0),
        };
        Ok(Camera { position, forward: forward.normalize(), up: up.normalize(), fov })
    }

    fn angle(&self, v: &Spanned<Num>, key: &str) -> Result<f32, FormatError> {
        let a = v.get_ref().0;
        if !(a > 0.0 && a < 180.0) {
            return Err(self.err(&v.span(), format!("`{key}` = {a} must be in (0, 180) degrees")));
        }
        Ok(a)
    }

    fn sky(&mut self, sky: Option<&Spanned<SkyDef>>, background: Option<&Spanned<V3>>) -> Result<Sky, FormatError> {
        let sky = match (sky, background) {
            (Some(_), Some(b)) => {
                return Err(self.err(&b.span(), "give either `background` or a [sky] table, not both"));
            }
            (None, Some(b)) => return Ok(Sky::Colour(self.colour(b, "background")?)),
            (None, None) => return Ok(Sky::default()),
            (Some(s), None) => s,
        };
        let def = sky.get_ref();
        self.scene.sky_ambient = def.ambient.unwrap_or(false);
        let gradient_keys = [&def.zenith, &def.horizon, &def.ground];
        let has_map = def.path.is_some() || def.faces.is_some();
        let kind = match &def.kind {
            Some(k) => *k.get_ref(),
            None if has_map => SkyKind::Cubemap, // refined by what the file holds
            None if def.colour.is_none() && gradient_keys.iter().any(|k| k.is_some()) => SkyKind::Gradient,
            None => SkyKind::Colour,
        };
        let intensity = match &def.intensity {
            Some(v) => self.non_negative(v, "intensity")?,
            None => 1.0,
        };
        let map_keys: Vec<(&'static str, Span)> = [
            ("path", def.path.as_ref().map(|v| v.span())),
            ("faces", def.faces.as_ref().map(|v| v.span())),
            ("flip", def.flip.as_ref().map(|v| v.span())),
            ("face", def.face.as_ref().map(|v| v.span())),
            ("rotation", def.rotation.as_ref().map(|v| v.span())),
        ]
        .into_iter()
        .filter_map(|(k, s)| s.map(|s| (k, s)))
        .collect();
        match kind {
            SkyKind::Colour => {
                if let Some(k) = gradient_keys.iter().find_map(|k| k.as_ref()) {
                    return Err(self.err(&k.span(), "zenith/horizon/ground belong to a sky of type = \"gradient\""));
                }
                self.disallow(&map_keys, &[], "a colour sky")?;
                match &def.colour {
                    Some(c) => Ok(Sky::Colour(self.colour(c, "colour")? * intensity)),
                    None => {
                        Err(self
                            .missing(&sky.span(), "[sky] needs `colour`, `path` or `faces` (or type = \"gradient\")"))
                    }
                }
            }
            SkyKind::Gradient => {
                if let Some(c) = &def.colour {
                    return Err(self.err(&c.span(), "a gradient sky takes zenith, horizon and ground, not `colour`"));
                }
                self.disallow(&map_keys, &[], "a gradient sky")?;
                let get = |v: &Option<Spanned<V3>>, key: &str| match v {
                    Some(c) => self.colour(c, key).map(|c| c * intensity),
                    None => Err(self.missing(&sky.span(), format!("a gradient sky needs `{key}`"))),
                };
                Ok(Sky::Gradient {
                    zenith: get(&def.zenith, "zenith")?,
                    horizon: get(&def.horizon, "horizon")?,
                    ground: get(&def.ground, "ground")?,
                })
            }
            SkyKind::Cubemap | SkyKind::Latlong => self.map_sky(sky, kind, intensity),
        }
    }

    /// `[sky]` with `path` or `faces`: the images are read here (see docs/skies.md).
    fn map_sky(&mut self, sky: &Spanned<SkyDef>, kind: SkyKind, intensity: f32) -> Result<Sky, FormatError> {
        let def = sky.get_ref();
        if let Some(k) = [&def.colour, &def.zenith, &def.horizon, &def.ground].iter().find_map(|k| k.as_ref()) {
            return Err(self.err(&k.span(), "a map sky takes `path` or `faces`, not colours"));
        }
        let source = match (&def.path, &def.faces) {
            (Some(_), Some(f)) => return Err(self.err(&f.span(), "give either `path` or `faces`, not both")),
            (None, None) => {
                return Err(
                    self.missing(&sky.span(), "a cube-map or lat-long sky needs `path` (a file or folder) or `faces`")
                );
            }
            (Some(p), None) => {
                let full = self.base_dir.join(p.get_ref());
                if !full.exists() {
                    return Err(FormatError::MissingFile { file: full, referenced_from: self.place(&p.span()) });
                }
                SkySource::Path(full)
            }
            (None, Some(f)) => {
                if kind == SkyKind::Latlong {
                    return Err(self.err(&f.span(), "`faces` make a cube map, not a lat-long sky"));
                }
                let list = f.get_ref();
                if list.len() != 6 {
                    return Err(self.err(
                        &f.span(),
                        format!("`faces` needs 6 images (px, nx, py, ny, pz, nz), found {}", list.len()),
                    ));
                }
                let mut paths = Vec::with_capacity(6);
                for p in list {
                    paths.push(self.resolve(p)?);
                }
                SkySource::Faces(std::array::from_fn(|i| paths[i].clone()))
            }
        };
        let mut options = SkyLoadOptions { intensity, ..SkyLoadOptions::default() };
        if let Some(r) = &def.rotation {
            options.rotation_degrees = r.get_ref().0;
        }
        if let Some(f) = &def.flip {
            options.all_faces = flip_transform(*f.get_ref());
        }
        if let Some(faces) = &def.face {
            for (name, fd) in faces.get_ref() {
                let Some(face) = CubeFace::ALL.iter().find(|f| f.short_name() == name) else {
                    return Err(self.err(
                        &fd.span(),
                        format!("unknown face `{name}` in [sky.face]: use px, nx, py, ny, pz or nz"),
                    ));
                };
                let fd = fd.get_ref();
                let mut t = fd.flip.as_ref().map_or(FaceTransform::default(), |f| flip_transform(*f.get_ref()));
                if let Some(r) = &fd.rotate {
                    let deg = *r.get_ref();
                    if ![0, 90, 180, 270].contains(&deg) {
                        return Err(self.err(&r.span(), format!("`rotate` = {deg}: use 0, 90, 180 or 270 (clockwise)")));
                    }
                    t.rotate_degrees = deg;
                }
                options.per_face[face.index()] = t;
            }
        }
        let transforms = [("flip", def.flip.as_ref().map(|f| f.span())), ("face", def.face.as_ref().map(|f| f.span()))]
            .into_iter()
            .find_map(|(k, s)| s.map(|s| (k, s)));
        let loaded = match load_sky(&source, &options) {
            Ok(l) => l,
            Err(e) => {
                // Face fixes given for what turns out to be a lat-long image: say which line.
                if let Some((key, span)) = &transforms {
                    let plain =
                        SkyLoadOptions { all_faces: FaceTransform::default(), per_face: Default::default(), ..options };
                    if let Ok(LoadedSky { sky: Sky::LatLong { .. }, .. }) = load_sky(&source, &plain) {
                        return Err(
                            self.err(span, format!("`{key}` applies to cube-map faces, not to a lat-long image"))
                        );
                    }
                }
                return Err(e);
            }
        };
        let is_latlong = matches!(loaded.sky, Sky::LatLong { .. });
        if let Some(k) = &def.kind {
            let want_latlong = *k.get_ref() == SkyKind::Latlong;
            if want_latlong != is_latlong {
                let found = if is_latlong { "a lat-long image" } else { "a cube map" };
                return Err(
                    self.err(&k.span(), format!("the sky's `type` does not match its images: they hold {found}"))
                );
            }
        }
        self.warnings.extend(loaded.warnings);
        Ok(loaded.sky)
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

    fn resolve(&self, path: &Spanned<String>) -> Result<PathBuf, FormatError> {
        let p = self.base_dir.join(path.get_ref());
        if !p.is_file() {
            return Err(FormatError::MissingFile { file: p, referenced_from: self.place(&path.span()) });
        }
        Ok(p)
    }

    fn disallow(&self, keys: &[(&'static str, Span)], allowed: &[&str], what: &str) -> Result<(), FormatError> {
        match keys.iter().find(|(k, _)| !allowed.contains(k)) {
            Some((k, span)) => Err(self.err(span, format!("`{k}` does not apply to {what}"))),
            None => Ok(()),
        }
    }

    fn texture(&mut self, t: &Spanned<TextureDef>) -> Result<(), FormatError> {
        let def = t.get_ref();
        let name = def.name.get_ref();
        if self.texture_names.contains_key(name) {
            return Err(self.err(&def.name.span(), format!("a texture named '{name}' is already defined")));
        }
        let keys = def.keys();
        let texture = match def.kind.get_ref() {
            TextureKind::Checker => {
                self.disallow(&keys, &["size", "even", "odd"], "a checker texture")?;
                let size = match &def.size {
                    Some(s) => {
                        let v = s.get_ref().0;
                        if v <= 0.0 {
                            return Err(self.err(&s.span(), format!("checker `size` = {v} must be > 0")));
                        }
                        v
                    }
                    None => 1.0,
                };
                let colour = |c: &Option<Spanned<V3>>, key: &str| match c {
                    Some(c) => self.colour(c, key),
                    None => Err(self.missing(&t.span(), format!("a checker texture needs `{key}`"))),
                };
                Texture::Checker { size, even: colour(&def.even, "even")?, odd: colour(&def.odd, "odd")? }
            }
            TextureKind::Image => {
                self.disallow(&keys, &["path", "scale"], "an image texture")?;
                let Some(path) = &def.path else {
                    return Err(self.missing(&t.span(), "an image texture needs `path`"));
                };
                let file = self.resolve(path)?;
                let image = match self.images.get(&file) {
                    Some(i) => i.clone(),
                    None => {
                        let i = Arc::new(texture_file::read_texture_image(&file)?);
                        self.images.insert(file, i.clone());
                        i
                    }
                };
                let scale = match &def.scale {
                    Some(s) => {
                        let v = s.get_ref().0;
                        if v.x == 0.0 || v.y == 0.0 {
                            return Err(self.err(&s.span(), "texture `scale` must not be 0"));
                        }
                        v
                    }
                    None => Vec2::ONE,
                };
                Texture::Image { image, scale }
            }
        };
        self.texture_names.insert(name.clone(), self.scene.textures.len());
        self.scene.textures.push(texture);
        Ok(())
    }

    fn material(&mut self, m: &Spanned<MaterialDef>) -> Result<(), FormatError> {
        let def = m.get_ref();
        let name = def.name.get_ref();
        if self.material_names.contains_key(name) {
            return Err(self.err(&def.name.span(), format!("a material named '{name}' is already defined")));
        }
        let mut mat = Material { name: name.clone(), ..Material::default() };
        if let Some(c) = &def.colour {
            mat.colour = self.colour(c, "colour")?;
        }
        if let Some(t) = &def.texture {
            let Some(&i) = self.texture_names.get(t.get_ref()) else {
                return Err(
                    self.err(&t.span(), format!("no texture named '{}' (define it with [[texture]])", t.get_ref()))
                );
            };
            mat.texture = Some(i);
        }
        for (v, slot, key) in [
            (&def.ambient, &mut mat.ambient, "ambient"),
            (&def.diffuse, &mut mat.diffuse, "diffuse"),
            (&def.specular, &mut mat.specular, "specular"),
            (&def.shininess, &mut mat.shininess, "shininess"),
        ] {
            if let Some(v) = v {
                *slot = self.non_negative(v, key)?;
            }
        }
        for (v, slot, key) in [
            (&def.reflectivity, &mut mat.reflectivity, "reflectivity"),
            (&def.transparency, &mut mat.transparency, "transparency"),
        ] {
            if let Some(v) = v {
                *slot = self.unit_interval(v, key)?;
            }
        }
        if let Some(ior) = &def.ior {
            let v = ior.get_ref().0;
            if !(1.0..=10.0).contains(&v) {
                return Err(self.err(&ior.span(), format!("`ior` = {v} must be in [1, 10]")));
            }
            mat.ior = v;
        }
        if let Some(f) = def.fresnel {
            mat.fresnel = f;
        }
        if let Some(f0) = &def.f0 {
            let v = f0.get_ref().0;
            if v.min_element() < 0.0 || v.max_element() > 1.0 {
                return Err(
                    self.err(&f0.span(), "`f0` must be in [0, 1] (0.04 for dielectrics, a metal's reflectance)")
                );
            }
            if mat.reflectivity > 0.0 || mat.transparency > 0.0 {
                return Err(self.err(
                    &f0.span(),
                    "`f0` (Fresnel reflection) excludes `reflectivity` and `transparency`: give one or the other",
                ));
            }
            mat.reflection_f0 = Some(v);
        }
        if let Some(e) = &def.emission {
            mat.emission = self.colour(e, "emission")?;
        }
        self.material_names.insert(name.clone(), self.scene.materials.len());
        self.scene.materials.push(mat);
        Ok(())
    }

    fn light(&self, l: &Spanned<LightDef>) -> Result<Light, FormatError> {
        let def = l.get_ref();
        let keys = def.keys();
        let colour = match &def.colour {
            Some(c) => self.colour(c, "colour")?,
            None => Rgb::ONE,
        };
        let intensity = match &def.intensity {
            Some(i) => self.non_negative(i, "intensity")?,
            None => 1.0,
        };
        let attenuation = match def.falloff.as_ref().map(|f| *f.get_ref()) {
            Some(Falloff::InverseSquare) => Attenuation::InverseSquare,
            Some(Falloff::None) | None => Attenuation::None,
        };
        let position = |what: &str| match &def.position {
            Some(p) => Ok(p.get_ref().0),
            None => Err(self.missing(&l.span(), format!("a {what} light needs `position`"))),
        };
        match def.kind.get_ref() {
            LightKind::Point => {
                self.disallow(&keys, &["position", "falloff"], "a point light")?;
                Ok(Light::Point { position: position("point")?, colour, intensity, attenuation })
            }
            LightKind::Directional => {
                self.disallow(&keys, &["direction"], "a directional light (it has no position)")?;
                let Some(d) = &def.direction else {
                    return Err(self.missing(&l.span(), "a directional light needs `direction`"));
                };
                Ok(Light::Directional { direction: self.direction(d, "direction")?, colour, intensity })
            }
            LightKind::Spot => {
                self.disallow(
                    &keys,
                    &["position", "direction", "look_at", "inner_angle", "outer_angle", "falloff"],
                    "a spot light",
                )?;
                let position = position("spot")?;
                let direction = match (&def.direction, &def.look_at) {
                    (Some(_), Some(t)) => {
                        return Err(self.err(&t.span(), "give either `direction` or `look_at`, not both"));
                    }
                    (Some(d), None) => self.direction(d, "direction")?,
                    (None, Some(t)) => (t.get_ref().0 - position)
                        .try_normalize()
                        .ok_or_else(|| self.err(&t.span(), "`look_at` equals the light position"))?,
                    (None, None) => return Err(self.missing(&l.span(), "a spot light needs `direction` or `look_at`")),
                };
                let outer_deg = match &def.outer_angle {
                    Some(a) => a.get_ref().0,
                    None => 30.0,
                };
                let inner_deg = match &def.inner_angle {
                    Some(a) => a.get_ref().0,
                    None => (outer_deg * 0.75).min(20.0),
                };
                if !(inner_deg >= 0.0 && inner_deg <= outer_deg && outer_deg > 0.0 && outer_deg <= 180.0) {
                    let span = def.inner_angle.as_ref().or(def.outer_angle.as_ref()).map_or(l.span(), Spanned::span);
                    return Err(self.err(
                        &span,
                        format!("cone angles need 0 <= inner_angle ({inner_deg}) <= outer_angle ({outer_deg}) <= 180"),
                    ));
                }
                Ok(Light::Spot { position, direction, inner_deg, outer_deg, colour, intensity, attenuation })
            }
        }
    }

    fn default_material(&mut self) -> usize {
        *self.default_material.get_or_insert_with(|| {
            self.scene.materials.push(Material::default());
            self.scene.materials.len() - 1
        })
    }

    fn object(&mut self, index: usize, o: &Spanned<ObjectDef>) -> Result<(), FormatError> {
        let def = o.get_ref();
        let kind = *def.kind.get_ref();
        let name = def.name.clone().unwrap_or_else(|| {
            let k = match kind {
                ObjectKind::Sphere => "sphere",
                ObjectKind::Plane => "plane",
                ObjectKind::Mesh => "mesh",
                ObjectKind::Points => "points",
            };
            format!("object {index} ({k})")
        });
        let material = match &def.material {
            Some(m) => match self.material_names.get(m.get_ref()) {
                Some(&i) => Some(i),
                None => {
                    return Err(self
                        .err(&m.span(), format!("no material named '{}' (define it with [[material]])", m.get_ref())));
                }
            },
            None => None,
        };
        let keys = def.shape_keys();
        const TRANSFORM: [&str; 5] = ["translate", "rotate", "rotate_axis", "rotate_angle", "scale"];
        let motion = match &def.animation {
            Some(a) if kind == ObjectKind::Points => {
                return Err(self.err(&a.span(), "point clouds cannot be animated (only spheres, planes and meshes)"));
            }
            Some(a) => Some(self.animation(a, false)?),
            None => None,
        };
        let first = self.scene.objects.len();
        match kind {
            ObjectKind::Sphere => {
                let allowed: Vec<&str> = ["centre", "radius"].into_iter().chain(TRANSFORM).collect();
                self.disallow(&keys, &allowed, "a sphere")?;
                let centre = def.centre.as_ref().map_or(Vec3::ZERO, |c| c.get_ref().0);
                let Some(r) = &def.radius else {
                    return Err(self.missing(&o.span(), format!("sphere '{name}' needs `radius`")));
                };
                let radius = r.get_ref().0;
                if radius <= 0.0 {
                    return Err(self.err(&r.span(), format!("sphere radius {radius} must be > 0")));
                }
                let world_from_object = self.transform(def)?;
                let material = match material {
                    Some(m) => m,
                    None => self.default_material(),
                };
                self.scene.objects.push(Object {
                    name,
                    shape: Shape::Sphere { centre, radius },
                    material,
                    world_from_object,
                });
            }
            ObjectKind::Plane => {
                self.disallow(&keys, &["normal", "offset", "point"], "a plane (its equation is in world space)")?;
                let Some(n) = &def.normal else {
                    return Err(self.missing(&o.span(), format!("plane '{name}' needs `normal`")));
                };
                let normal = self.direction(n, "normal")?;
                let offset = match (&def.offset, &def.point) {
                    (Some(_), Some(p)) => return Err(self.err(&p.span(), "give either `offset` or `point`, not both")),
                    (Some(d), None) => d.get_ref().0,
                    (None, Some(p)) => -p.get_ref().0.dot(normal),
                    (None, None) => 0.0,
                };
                let material = match material {
                    Some(m) => m,
                    None => self.default_material(),
                };
                self.scene.objects.push(Object {
                    name,
                    shape: Shape::Plane { normal, offset },
                    material,
                    world_from_object: Affine3A::IDENTITY,
                });
            }
            ObjectKind::Mesh => {
                let world_from_object = self.transform(def)?;
                let shading = def.shading.as_ref().map(|s| *s.get_ref());
                let mesh_indices = match &def.path {
                    Some(path) => {
                        let allowed: Vec<&str> = ["path", "shading"].into_iter().chain(TRANSFORM).collect();
                        self.disallow(&keys, &allowed, "a mesh read from a file")?;
                        self.file_meshes(path, shading, material.is_some())?
                    }
                    None => {
                        let allowed: Vec<&str> = ["vertices", "triangles", "normals", "uvs", "shading"]
                            .into_iter()
                            .chain(TRANSFORM)
                            .collect();
                        self.disallow(&keys, &allowed, "an inline mesh")?;
                        let mesh = self.inline_mesh(o, &name, shading)?;
                        self.scene.meshes.push(Arc::new(mesh));
                        vec![self.scene.meshes.len() - 1]
                    }
                };
                let material = match material {
                    Some(m) => m,
                    None => self.default_material(),
                };
                let single = mesh_indices.len() == 1;
                for i in mesh_indices {
                    let object_name =
                        if single { name.clone() } else { format!("{name}/{}", self.scene.meshes[i].name) };
                    self.scene.objects.push(Object {
                        name: object_name,
                        shape: Shape::Mesh(i),
                        material,
                        world_from_object,
                    });
                }
            }
            ObjectKind::Points => {
                let allowed: Vec<&str> = ["path", "colour_by", "sensor"].into_iter().chain(TRANSFORM).collect();
                self.disallow(&keys, &allowed, "a point cloud")?;
                let Some(path) = &def.path else {
                    return Err(self.missing(
                        &o.span(),
                        format!("point cloud '{name}' needs `path` (a .ply, .las, .laz, .xyz or .pts file)"),
                    ));
                };
                let colour_by = match &def.colour_by {
                    Some(c) => match ColourBy::from_name(c.get_ref()) {
                        Some(v) => v,
                        None => {
                            return Err(self.err(
                                &c.span(),
                                format!(
                                    "colour_by {:?}: use auto, rgb, intensity, classification or elevation",
                                    c.get_ref()
                                ),
                            ));
                        }
                    },
                    None => ColourBy::Auto,
                };
                let file = self.resolve(path)?;
                let mut cloud = points::read_point_cloud(&file, &PointReadOptions { colour_by })?;
                if let Some(s) = &def.sensor {
                    if cloud.normals.is_some() {
                        return Err(
                            self.err(&s.span(), "`sensor` orients estimated normals, but this cloud has its own")
                        );
                    }
                    // The sensor is given in the file's own coordinates; LAS/LAZ are Z-up and were
                    // turned to glint's Y-up axes on reading, (x, y, z) → (x, z, −y).
                    let mut sensor = s.get_ref().0.as_dvec3();
                    let ext = file.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
                    if matches!(ext.as_deref(), Some("las" | "laz")) {
                        sensor = glint_core::glam::DVec3::new(sensor.x, sensor.z, -sensor.y);
                    }
                    let p = sensor - cloud.origin;
                    cloud.orientation = glint_scene::Orientation::TowardSensor(p.as_vec3());
                }
                let world_from_object = self.transform(def)?;
                let material = match material {
                    Some(m) => m,
                    None => self.default_material(),
                };
                self.scene.clouds.push(CloudObject { name, cloud: Arc::new(cloud), material, world_from_object });
            }
        }
        if let Some(motion) = motion {
            let targets: Vec<AnimationTarget> =
                (first..self.scene.objects.len()).map(AnimationTarget::Object).collect();
            self.animate(&targets, motion)?;
        }
        Ok(())
    }

    fn transform(&self, def: &ObjectDef) -> Result<Affine3A, FormatError> {
        let translate = def.translate.as_ref().map_or(Vec3::ZERO, |t| t.get_ref().0);
        let rotation = match (&def.rotate, &def.rotate_axis, &def.rotate_angle) {
            (Some(_), Some(a), _) => {
                return Err(self.err(&a.span(), "give either `rotate` or `rotate_axis` + `rotate_angle`, not both"));
            }
            (Some(_), None, Some(a)) => {
                return Err(self.err(&a.span(), "`rotate_angle` goes with `rotate_axis`, not with `rotate`"));
            }
            (Some(r), None, None) => {
                let [x, y, z] = r.get_ref().0.to_array().map(f32::to_radians);
                // X first, then Y, then Z (about the fixed world axes).
                Mat3::from_rotation_z(z) * Mat3::from_rotation_y(y) * Mat3::from_rotation_x(x)
            }
            (None, Some(axis), Some(angle)) => {
                let axis = self.direction(axis, "rotate_axis")?;
                Mat3::from_axis_angle(axis, angle.get_ref().0.to_radians())
            }
            (None, Some(a), None) => return Err(self.err(&a.span(), "`rotate_axis` needs `rotate_angle` (degrees)")),
            (None, None, Some(a)) => return Err(self.err(&a.span(), "`rotate_angle` needs `rotate_axis`")),
            (None, None, None) => Mat3::IDENTITY,
        };
        let scale = match &def.scale {
            Some(s) => {
                let v = s.get_ref().0;
                if v.abs().min_element() < 1e-12 {
                    return Err(self.err(&s.span(), "`scale` must not be 0 (the object would vanish)"));
                }
                v
            }
            None => Vec3::ONE,
        };
        Ok(Affine3A::from_mat3_translation(rotation * Mat3::from_diagonal(scale), translate))
    }

    fn inline_mesh(
        &mut self,
        o: &Spanned<ObjectDef>,
        name: &str,
        shading: Option<Shading>,
    ) -> Result<Mesh, FormatError> {
        let def = o.get_ref();
        let (Some(vertices), Some(triangles)) = (&def.vertices, &def.triangles) else {
            return Err(self.missing(
                &o.span(),
                format!("mesh '{name}' needs `path` (a model file) or `vertices` and `triangles`"),
            ));
        };
        let positions: Vec<Vec3> = vertices.get_ref().iter().map(|v| v.0).collect();
        let n = positions.len();
        let mut tris = Vec::with_capacity(triangles.get_ref().len());
        for t in triangles.get_ref() {
            let tri = *t.get_ref();
            if let Some(&bad) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(
                    self.err(&t.span(), format!("vertex index {bad} is out of range (the mesh has {n} vertices)"))
                );
            }
            tris.push(tri);
        }
        let normals = match &def.normals {
            Some(ns) => {
                if ns.get_ref().len() != n {
                    return Err(self.err(&ns.span(), format!("{} normals for {n} vertices", ns.get_ref().len())));
                }
                let mut out = Vec::with_capacity(n);
                for (i, v) in ns.get_ref().iter().enumerate() {
                    match v.0.try_normalize() {
                        Some(u) => out.push(u),
                        None => return Err(self.err(&ns.span(), format!("normal {i} has zero length"))),
                    }
                }
                Some(out)
            }
            None => None,
        };
        let uvs = match &def.uvs {
            Some(us) => {
                if us.get_ref().len() != n {
                    return Err(self.err(&us.span(), format!("{} uvs for {n} vertices", us.get_ref().len())));
                }
                Some(us.get_ref().iter().map(|v| v.0).collect())
            }
            None => None,
        };
        let mut mesh =
            Mesh { name: name.to_string(), positions, normals, uvs, triangles: tris, triangle_materials: None };
        let dropped = mesh.remove_degenerate_triangles();
        if mesh.triangles.is_empty() {
            return Err(self.err(&triangles.span(), format!("mesh '{name}': every triangle has zero area")));
        }
        if dropped > 0 {
            let place = self.place(&triangles.span());
            self.warnings.push(format!("{place}: mesh '{name}': dropped {dropped} zero-area triangles"));
        }
        model::apply_shading(&mut mesh, shading);
        Ok(mesh)
    }

    /// The scene meshes of a model file, loading it (and its materials and textures) once.
    fn file_meshes(
        &mut self,
        path: &Spanned<String>,
        shading: Option<Shading>,
        overridden: bool,
    ) -> Result<Vec<usize>, FormatError> {
        let file = self.resolve(path)?;
        if model::ModelFormat::from_extension(&model::extension(&file)).is_none() {
            return Err(self.err(
                &path.span(),
                format!("`{}`: glint reads meshes from .obj, .ply, .gltf and .glb files", path.get_ref()),
            ));
        }
        let key = std::fs::canonicalize(&file).unwrap_or_else(|_| file.clone());
        if let Some(ids) = self.meshes.get(&(key.clone(), shading, overridden)) {
            return Ok(ids.clone());
        }
        let model = match self.models.get(&(key.clone(), shading)) {
            Some(m) => m.clone(),
            None => {
                let mut m = model::load_model(&file)?;
                self.warnings.append(&mut m.warnings);
                for mesh in &mut m.meshes {
                    model::apply_shading(mesh, shading);
                }
                let m = Rc::new(m);
                self.models.insert((key.clone(), shading), m.clone());
                m
            }
        };
        let (material_base, texture_base) = (self.scene.materials.len() as u32, self.scene.textures.len());
        if !overridden && model.meshes.iter().any(|m| m.triangle_materials.is_some()) {
            self.scene.textures.extend(model.textures.iter().cloned());
            let stem = file.file_name().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
            self.scene.materials.extend(model.materials.iter().map(|m| Material {
                name: format!("{stem}/{}", m.name),
                texture: m.texture.map(|t| t + texture_base),
                ..m.clone()
            }));
        }
        let mut ids = Vec::with_capacity(model.meshes.len());
        for mesh in &model.meshes {
            let mut mesh = mesh.clone();
            mesh.triangle_materials = match (overridden, mesh.triangle_materials.take()) {
                (false, Some(tm)) => Some(tm.into_iter().map(|m| m + material_base).collect()),
                _ => None,
            };
            self.scene.meshes.push(Arc::new(mesh));
            ids.push(self.scene.meshes.len() - 1);
        }
        self.meshes.insert((key, shading, overridden), ids.clone());
        Ok(ids)
    }
}

#[cfg(test)]
mod tests;
