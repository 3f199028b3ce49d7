//! Mitsuba 3 XML scenes → [`Scene`] (pipeline: files → **formats** → scene).
//!
//! Reads what Mitsuba's own parser reads (src/core/parser.cpp): `<default>` and `$name`
//! parameters, `<include>`, `<path>`, ids and `<ref>`, typed properties and `<transform>`s,
//! and maps each plugin to glint's scene model with Mitsuba's defaults: sensors, films and
//! filters, samplers and integrators become [`MitsubaSettings`]; shapes become meshes and
//! spheres; BSDFs become [`glint_scene::BsdfKind`]s (plus the nearest Phong parameters for the
//! Whitted mode); emitters become emissive materials, lights and the sky. Colours are what
//! Mitsuba's RGB variants compute ([`spectrum`]).
//!
//! Strict by default: anything glint cannot represent (an unknown plugin, an unused property,
//! a textured emitter) is a [`FormatError`] at its file:line:column. With `lenient`, each such
//! thing becomes one warning and the nearest supported thing is used instead.
//!
//! Depends on glint-scene only (and this crate's OBJ/PLY/image readers); never renders.

mod bsdfs;
mod cie_tables;
mod emitters;
mod props;
mod sensor;
mod serialized;
mod shapes;
mod spectrum;
mod textures;
mod xml;

#[cfg(test)]
mod tests;

pub use serialized::read_serialized;

use crate::error::FormatError;
use glint_core::Rgb;
use glint_scene::{RenderMode, Scene, Tex};
use props::{Ids, Props};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use xml::{Element, Loc};

/// A Mitsuba scene read into glint's model, with the render settings it asks for.
#[derive(Clone, Debug)]
pub struct MitsubaScene {
    pub scene: Scene,
    pub settings: MitsubaSettings,
    /// What glint substituted or recovered from, each starting with file:line:column.
    pub warnings: Vec<String>,
}

/// The sensor, film, sampler and integrator of a Mitsuba scene.
#[derive(Clone, Debug, PartialEq)]
pub struct MitsubaSettings {
    /// The sampler's `sample_count`; None when the scene has no sampler (Mitsuba uses 4).
    pub spp: Option<u32>,
    /// `independent` stays independent (Mitsuba's default); its stratified samplers
    /// (`stratified`, `multijitter`, `ldsampler`, `orthogonal`) become glint's Sobol sampler.
    pub sampler: glint_core::random::Sampler,
    pub integrator: MitsubaIntegrator,
    /// The film's full size (Mitsuba's default 768 × 576).
    pub width: u32,
    pub height: u32,
    /// The part of the film rendered: offset x, y and size w, h (None: all of it).
    pub crop: Option<[u32; 4]>,
    pub filter: PixelFilter,
    /// The sensor's `to_world` mirrors (negative determinant): Mitsuba's image is then flipped
    /// left to right relative to glint's camera, which keeps right = forward × up.
    pub camera_flip_x: bool,
}

impl Default for MitsubaSettings {
    fn default() -> Self {
        MitsubaSettings {
            spp: None,
            sampler: glint_core::random::Sampler::Independent,
            integrator: MitsubaIntegrator::Path { max_depth: None, rr_depth: 5, hide_emitters: false },
            width: 768,
            height: 576,
            crop: None,
            filter: PixelFilter::Gaussian { stddev: 0.5 },
            camera_flip_x: false,
        }
    }
}

/// Mitsuba's integrators that glint can follow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MitsubaIntegrator {
    /// `path` (and `ptracer`, approximated): `max_depth` None is Mitsuba's −1 (unbounded).
    Path { max_depth: Option<u32>, rr_depth: u32, hide_emitters: bool },
    /// `direct`: samples per emitter and of the BSDF at each hit.
    Direct { emitter_samples: u32, bsdf_samples: u32, hide_emitters: bool },
}

/// The film's reconstruction filter (glint samples positions from it: `glint_core::pixel_filter`).
pub use glint_core::PixelFilter;

/// Reads a Mitsuba 3 scene. `defines` set `$name` parameters (winning over `<default>`);
/// `lenient` turns what glint cannot represent into warnings and substitutes.
pub fn load(path: &Path, defines: &[(String, String)], lenient: bool) -> Result<MitsubaScene, FormatError> {
    let mut reader = xml::Reader::new(defines);
    let root = reader.read(path, None)?;
    let mut ids: Ids = HashMap::new();
    collect_ids(&root, &mut ids)?;
    let mut b = Builder {
        lenient,
        warnings: Vec::new(),
        ids,
        search_paths: reader.search_paths,
        main_dir: path.parent().unwrap_or(Path::new("")).to_path_buf(),
        scene: Scene::default(),
        settings: MitsubaSettings::default(),
        bsdf_cache: HashMap::new(),
        bsdf_busy: Vec::new(),
        texture_cache: HashMap::new(),
        float_twins: HashMap::new(),
        group_cache: HashMap::new(),
        has_sensor: false,
    };
    b.scene.render.mode = RenderMode::Path;
    b.scene.ambient = Rgb::ZERO;
    b.scene.sky = glint_scene::Sky::Colour(Rgb::ZERO);
    for el in &root.children {
        b.top_level(el)?;
    }
    if !b.has_sensor {
        b.warnings.push(format!("{}: the scene has no <sensor>: glint's default camera is used", path.display()));
    }
    b.scene.render.width = b.settings.width;
    b.scene.render.height = b.settings.height;
    apply_integrator(&mut b.scene.render, &b.settings);
    b.scene.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    Ok(MitsubaScene { scene: b.scene, settings: b.settings, warnings: b.warnings })
}

/// The scene's render defaults from its sampler and integrator: the sample count, and
/// Mitsuba's depth budget (`max_depth`; −1, unbounded, becomes glint's own budgets at their
/// largest, which differ from Mitsuba's only past 64 bounces; `direct` is a budget of 2,
/// direct light only).
fn apply_integrator(render: &mut glint_scene::RenderDefaults, settings: &MitsubaSettings) {
    use glint_scene::limits;
    render.spp = settings.spp;
    render.sampler = settings.sampler;
    render.image_filter = false;
    render.pixel_filter = settings.filter;
    render.crop = settings.crop;
    render.hide_emitters = match settings.integrator {
        MitsubaIntegrator::Path { hide_emitters, .. } | MitsubaIntegrator::Direct { hide_emitters, .. } => {
            hide_emitters
        }
    };
    match settings.integrator {
        MitsubaIntegrator::Path { max_depth, rr_depth, .. } => {
            render.rr_depth = Some(rr_depth);
            match max_depth {
                Some(d) => render.path_depth = Some(d.clamp(*limits::PATH_DEPTH.start(), *limits::PATH_DEPTH.end())),
                None => {
                    render.path_depth = None;
                    render.max_bounces = *limits::MAX_BOUNCES.end();
                    render.max_depth = *limits::MAX_DEPTH.end();
                }
            }
        }
        MitsubaIntegrator::Direct { .. } => render.path_depth = Some(2),
    }
}

fn collect_ids<'a>(el: &'a Element, ids: &mut Ids<'a>) -> Result<(), FormatError> {
    for c in &el.children {
        if c.tag != "ref"
            && let Some(id) = c.attr("id")
            && ids.insert(id, c).is_some()
        {
            return Err(c.loc.error(format!("id \"{id}\" is used twice")));
        }
        collect_ids(c, ids)?;
    }
    Ok(())
}

/// Key of an element in the caches (elements live as long as the tree).
fn key(el: &Element) -> usize {
    std::ptr::from_ref(el) as usize
}

pub(super) struct Builder<'a> {
    lenient: bool,
    warnings: Vec<String>,
    ids: Ids<'a>,
    search_paths: Vec<PathBuf>,
    main_dir: PathBuf,
    scene: Scene,
    settings: MitsubaSettings,
    bsdf_cache: HashMap<usize, usize>,
    /// BSDFs being converted (a `<ref>` back to one of them is a cycle).
    bsdf_busy: Vec<usize>,
    texture_cache: HashMap<usize, usize>,
    /// Textures whose float reading differs from their colour reading (Mitsuba's checkerboard):
    /// index → the index of the float reading.
    float_twins: HashMap<usize, usize>,
    group_cache: HashMap<usize, Vec<shapes::Part>>,
    has_sensor: bool,
}

impl<'a> Builder<'a> {
    /// Something glint cannot represent: an error, or in lenient mode a warning.
    fn unsupported(&mut self, loc: &Loc, message: impl Into<String>) -> Result<(), FormatError> {
        let message = message.into();
        if self.lenient {
            self.warnings.push(format!("{}: {message}", loc.describe()));
            Ok(())
        } else {
            Err(loc.error(message))
        }
    }

    fn props(&self, el: &'a Element) -> Result<Props<'a>, FormatError> {
        Props::parse(el, &self.ids)
    }

    /// Reports the properties no reader used.
    fn finish(&mut self, p: &Props<'a>) -> Result<(), FormatError> {
        for (at, message) in p.unused() {
            self.unsupported(&at.loc, message)?;
        }
        Ok(())
    }

    /// A file named in the scene: relative to the naming file, then the `<path>` folders
    /// (latest first), then the main scene's folder.
    fn resolve(&self, name: &str, at: &Element) -> Result<PathBuf, FormatError> {
        let given = Path::new(name);
        let candidates: Vec<PathBuf> = if given.is_absolute() {
            vec![given.to_path_buf()]
        } else {
            std::iter::once(at.loc.dir().join(given))
                .chain(self.search_paths.iter().rev().map(|d| d.join(given)))
                .chain(std::iter::once(self.main_dir.join(given)))
                .collect()
        };
        let found = candidates.iter().find(|c| c.exists()).cloned().ok_or_else(|| FormatError::MissingFile {
            file: candidates[0].clone(),
            referenced_from: format!("{} {}", at.loc.describe(), at.describe()),
        })?;
        let field = format!("line {} {} filename", at.loc.line, at.describe());
        crate::files::check(&found, Some(crate::files::Referrer::new(&at.loc.file, &field)))?;
        Ok(found)
    }

    fn top_level(&mut self, el: &'a Element) -> Result<(), FormatError> {
        match el.tag.as_str() {
            "integrator" => self.integrator(el),
            "sensor" => self.sensor(el),
            "shape" => self.shape(el),
            "bsdf" => self.bsdf(el).map(|_| ()),
            "texture" => self.texture(el).map(|_| ()),
            // An area emitter declared once for shapes to <ref>: checked here, used there.
            "emitter" if el.attr("type") == Some("area") && el.attr("id").is_some() => {
                self.area_emitter(el).map(|_| ())
            }
            "emitter" => self.emitter(el),
            _ => self.unsupported(&el.loc, format!("{} is not supported by glint", el.describe())),
        }
    }

    /// A material for a shape: its BSDF in path mode, the nearest Phong parameters for the
    /// Whitted mode, and its area emission.
    fn material(&mut self, name: String, bsdf: usize, emission: Option<Tex<Rgb>>) -> usize {
        let mut m = bsdfs::phong(&self.scene, bsdf);
        m.name = name;
        m.bsdf = Some(bsdf);
        match emission {
            Some(Tex::Value(e)) => m.emission = e,
            Some(Tex::Texture(t)) => (m.emission, m.emission_texture) = (Rgb::ONE, Some(t)),
            None => {}
        }
        self.scene.materials.push(m);
        self.scene.materials.len() - 1
    }
}
