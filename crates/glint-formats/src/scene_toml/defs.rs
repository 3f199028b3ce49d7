//! The TOML scene file as written, before names are resolved and files loaded.
//!
//! Every table denies unknown keys. Tables whose keys depend on a `type` (objects, lights,
//! textures, the sky) are flat structs with every key optional; the builder then checks which
//! keys the type allows, using the spans kept here to point at the offending line. (A serde
//! internally tagged enum would buffer its content and lose the spans.)

use super::values::{Num, Scale, V2, V3};
use serde::Deserialize;
use toml::Spanned;

pub(crate) type Span = std::ops::Range<usize>;

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct SceneDef {
    pub image: Option<ImageDef>,
    pub render: Option<RenderDef>,
    pub camera: Option<Spanned<CameraDef>>,
    pub sky: Option<Spanned<SkyDef>>,
    pub background: Option<Spanned<V3>>,
    pub ambient: Option<Spanned<V3>>,
    #[serde(default)]
    pub texture: Vec<Spanned<TextureDef>>,
    #[serde(default)]
    pub material: Vec<Spanned<MaterialDef>>,
    #[serde(default)]
    pub light: Vec<Spanned<LightDef>>,
    #[serde(default)]
    pub object: Vec<Spanned<ObjectDef>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct ImageDef {
    pub width: Option<Spanned<u32>>,
    pub height: Option<Spanned<u32>>,
    pub samples: Option<Spanned<u32>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct RenderDef {
    pub max_depth: Option<Spanned<u32>>,
    pub min_contribution: Option<Spanned<Num>>,
    pub mode: Option<Spanned<String>>,
    pub max_bounces: Option<Spanned<u32>>,
    pub sampler: Option<Spanned<String>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct CameraDef {
    pub position: Option<Spanned<V3>>,
    pub look_at: Option<Spanned<V3>>,
    pub forward: Option<Spanned<V3>>,
    pub up: Option<Spanned<V3>>,
    pub fov: Option<Spanned<Num>>,
    pub hfov: Option<Spanned<Num>>,
    pub aperture_radius: Option<Spanned<Num>>,
    pub focus_distance: Option<Spanned<Num>>,
    pub view_height: Option<Spanned<Num>>,
}

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(crate) enum SkyKind {
    #[serde(alias = "color")]
    Colour,
    Gradient,
    #[serde(alias = "cube_map", alias = "cube")]
    Cubemap,
    #[serde(alias = "lat_long", alias = "equirectangular")]
    Latlong,
}

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Flip {
    None,
    Horizontal,
    Vertical,
    Both,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct SkyDef {
    #[serde(rename = "type")]
    pub kind: Option<Spanned<SkyKind>>,
    #[serde(alias = "color")]
    pub colour: Option<Spanned<V3>>,
    pub zenith: Option<Spanned<V3>>,
    pub horizon: Option<Spanned<V3>>,
    pub ground: Option<Spanned<V3>>,
    /// An image (cross, strip or lat-long) or a folder of six faces.
    pub path: Option<Spanned<String>>,
    /// Six face images, in the order px, nx, py, ny, pz, nz.
    pub faces: Option<Spanned<Vec<Spanned<String>>>>,
    /// Flip every face as it is read.
    pub flip: Option<Spanned<Flip>>,
    /// Per-face fixes: `[sky.face.py] rotate = 90`.
    pub face: Option<Spanned<std::collections::BTreeMap<String, Spanned<FaceDef>>>>,
    /// Degrees about +Y.
    pub rotation: Option<Spanned<Num>>,
    pub intensity: Option<Spanned<Num>>,
    /// The sky is the scene's ambient light (by normal, through its irradiance).
    pub ambient: Option<bool>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct FaceDef {
    pub flip: Option<Spanned<Flip>>,
    /// Clockwise degrees: 0, 90, 180 or 270.
    pub rotate: Option<Spanned<u32>>,
}

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(crate) enum TextureKind {
    Checker,
    Image,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct TextureDef {
    pub name: Spanned<String>,
    #[serde(rename = "type")]
    pub kind: Spanned<TextureKind>,
    pub size: Option<Spanned<Num>>,
    pub even: Option<Spanned<V3>>,
    pub odd: Option<Spanned<V3>>,
    pub path: Option<Spanned<String>>,
    pub scale: Option<Spanned<V2>>,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct MaterialDef {
    pub name: Spanned<String>,
    #[serde(alias = "color")]
    pub colour: Option<Spanned<V3>>,
    pub texture: Option<Spanned<String>>,
    pub ambient: Option<Spanned<Num>>,
    pub diffuse: Option<Spanned<Num>>,
    pub specular: Option<Spanned<Num>>,
    pub shininess: Option<Spanned<Num>>,
    pub reflectivity: Option<Spanned<Num>>,
    pub transparency: Option<Spanned<Num>>,
    pub ior: Option<Spanned<Num>>,
    pub fresnel: Option<bool>,
    pub emission: Option<Spanned<V3>>,
    /// Emit from both faces (default: the front face only).
    pub two_sided: Option<bool>,
    /// Fresnel (Schlick) reflection with this reflectance at normal incidence.
    pub f0: Option<Spanned<Scale>>,
}

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(crate) enum LightKind {
    Point,
    Directional,
    Spot,
}

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(crate) enum Falloff {
    None,
    InverseSquare,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct LightDef {
    #[serde(rename = "type")]
    pub kind: Spanned<LightKind>,
    pub position: Option<Spanned<V3>>,
    pub direction: Option<Spanned<V3>>,
    pub look_at: Option<Spanned<V3>>,
    #[serde(alias = "color")]
    pub colour: Option<Spanned<V3>>,
    pub intensity: Option<Spanned<Num>>,
    pub inner_angle: Option<Spanned<Num>>,
    pub outer_angle: Option<Spanned<Num>>,
    pub falloff: Option<Spanned<Falloff>>,
    /// `[light.animation]`: any type of light.
    pub animation: Option<Spanned<AnimationDef>>,
}

#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub(crate) enum ObjectKind {
    Sphere,
    Plane,
    Mesh,
    /// A point cloud file (drawn by the points mode).
    Points,
}

/// How a mesh is shaded: with interpolated vertex normals or with its face normals.
#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[serde(rename_all = "snake_case")]
pub enum Shading {
    /// Interpolated vertex normals, computed (area-weighted) when the mesh has none.
    Smooth,
    /// Face normals only: vertex normals of the file are dropped.
    Flat,
}

#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct ObjectDef {
    pub name: Option<String>,
    #[serde(rename = "type")]
    pub kind: Spanned<ObjectKind>,
    pub material: Option<Spanned<String>>,
    pub centre: Option<Spanned<V3>>,
    pub radius: Option<Spanned<Num>>,
    pub normal: Option<Spanned<V3>>,
    pub offset: Option<Spanned<Num>>,
    pub point: Option<Spanned<V3>>,
    pub path: Option<Spanned<String>>,
    pub vertices: Option<Spanned<Vec<V3>>>,
    pub triangles: Option<Spanned<Vec<Spanned<[u32; 3]>>>>,
    pub normals: Option<Spanned<Vec<V3>>>,
    pub uvs: Option<Spanned<Vec<V2>>>,
    pub shading: Option<Spanned<Shading>>,
    pub translate: Option<Spanned<V3>>,
    pub rotate: Option<Spanned<V3>>,
    pub rotate_axis: Option<Spanned<V3>>,
    pub rotate_angle: Option<Spanned<Num>>,
    pub scale: Option<Spanned<Scale>>,
    /// Points: how points without colours are coloured (auto, rgb, intensity, classification,
    /// elevation).
    pub colour_by: Option<Spanned<String>>,
    /// Points: the scanner's position, toward which estimated normals are turned.
    pub sensor: Option<Spanned<V3>>,
    /// `[object.animation]`: spheres, planes and meshes (not point clouds).
    pub animation: Option<Spanned<AnimationDef>>,
}

/// What keyframes do outside their times.
#[derive(Deserialize, Debug, Clone, Copy, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum RepeatDef {
    Hold,
    Loop,
    #[serde(alias = "ping_pong", alias = "pingpong")]
    PingPong,
}

/// `[object.animation]` / `[light.animation]`: a rotation, keyframes, or both.
#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct AnimationDef {
    pub rotate: Option<Spanned<RotateDef>>,
    pub keyframes: Option<Spanned<Vec<Spanned<KeyframeDef>>>>,
    pub repeat: Option<Spanned<RepeatDef>>,
}

/// `rotate = { axis = [0, 1, 0], degrees_per_second = 45, pivot = [0, 1, 0], phase_deg = 0 }`.
#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct RotateDef {
    pub axis: Option<Spanned<V3>>,
    pub degrees_per_second: Option<Spanned<Num>>,
    pub pivot: Option<Spanned<V3>>,
    pub phase_deg: Option<Spanned<Num>>,
}

/// `{ time = 2, offset = [0, 1, 0] }`.
#[derive(Deserialize, Debug)]
#[serde(deny_unknown_fields)]
pub(crate) struct KeyframeDef {
    pub time: Option<Spanned<Num>>,
    pub offset: Option<Spanned<V3>>,
}

fn span_of<T>(v: &Option<Spanned<T>>) -> Option<Span> {
    v.as_ref().map(Spanned::span)
}

impl ObjectDef {
    /// The type-dependent keys that are present, with their spans.
    pub fn shape_keys(&self) -> Vec<(&'static str, Span)> {
        [
            ("centre", span_of(&self.centre)),
            ("radius", span_of(&self.radius)),
            ("normal", span_of(&self.normal)),
            ("offset", span_of(&self.offset)),
            ("point", span_of(&self.point)),
            ("path", span_of(&self.path)),
            ("vertices", span_of(&self.vertices)),
            ("triangles", span_of(&self.triangles)),
            ("normals", span_of(&self.normals)),
            ("uvs", span_of(&self.uvs)),
            ("shading", span_of(&self.shading)),
            ("translate", span_of(&self.translate)),
            ("rotate", span_of(&self.rotate)),
            ("rotate_axis", span_of(&self.rotate_axis)),
            ("rotate_angle", span_of(&self.rotate_angle)),
            ("scale", span_of(&self.scale)),
            ("colour_by", span_of(&self.colour_by)),
            ("sensor", span_of(&self.sensor)),
        ]
        .into_iter()
        .filter_map(|(k, s)| s.map(|s| (k, s)))
        .collect()
    }
}

impl LightDef {
    pub fn keys(&self) -> Vec<(&'static str, Span)> {
        [
            ("position", span_of(&self.position)),
            ("direction", span_of(&self.direction)),
            ("look_at", span_of(&self.look_at)),
            ("inner_angle", span_of(&self.inner_angle)),
            ("outer_angle", span_of(&self.outer_angle)),
            ("falloff", span_of(&self.falloff)),
        ]
        .into_iter()
        .filter_map(|(k, s)| s.map(|s| (k, s)))
        .collect()
    }
}

impl TextureDef {
    pub fn keys(&self) -> Vec<(&'static str, Span)> {
        [
            ("size", span_of(&self.size)),
            ("even", span_of(&self.even)),
            ("odd", span_of(&self.odd)),
            ("path", span_of(&self.path)),
            ("scale", span_of(&self.scale)),
        ]
        .into_iter()
        .filter_map(|(k, s)| s.map(|s| (k, s)))
        .collect()
    }
}
