//! Model files (OBJ, PLY, glTF) as meshes, and a scene to look at one model without a scene file.
//!
//! Every loader ends in [`finish_meshes`]: zero-area triangles are dropped with a warning (a
//! mesh that has none left is an error), so the scene builder and the BVH never see them.

use crate::error::FormatError;
use crate::scene_toml::Shading;
use crate::{gltf_file, obj, ply};
use glint_core::{Affine3A, Bounds3, Rgb, Vec3};
use glint_scene::{
    Attenuation, BsdfKind, Camera, CloudObject, Fov, Light, Material, Mesh, Object, PointCloud, RenderDefaults,
    RenderMode, Scene, Shape, Sky, Texture,
};
use std::path::Path;
use std::sync::Arc;

/// A model file read into memory.
#[derive(Clone, Debug, Default)]
pub struct Model {
    pub meshes: Vec<Mesh>,
    /// Referenced by `Mesh::triangle_materials` (indices into this Vec).
    pub materials: Vec<Material>,
    /// Physically based models, referenced by `Material::bsdf` (indices into this Vec).
    pub bsdfs: Vec<BsdfKind>,
    /// Referenced by `Material::texture`, `Material::emission_texture` and the models
    /// (indices into this Vec).
    pub textures: Vec<Texture>,
    /// What was recovered from (each starts with the file name).
    pub warnings: Vec<String>,
}

/// The model formats glint reads, by file extension.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum ModelFormat {
    Obj,
    Ply,
    Gltf,
}

impl ModelFormat {
    pub(crate) fn from_extension(ext: &str) -> Option<Self> {
        match ext.to_ascii_lowercase().as_str() {
            "obj" => Some(Self::Obj),
            "ply" => Some(Self::Ply),
            "gltf" | "glb" => Some(Self::Gltf),
            _ => None,
        }
    }
}

pub(crate) fn extension(path: &Path) -> String {
    path.extension().map_or_else(String::new, |e| e.to_string_lossy().into_owned())
}

/// Reads a model file (by extension: .obj, .ply, .gltf, .glb; case-insensitive).
pub fn load_model(path: &Path) -> Result<Model, FormatError> {
    let ext = extension(path);
    match ModelFormat::from_extension(&ext) {
        Some(ModelFormat::Obj) => obj::load(path),
        Some(ModelFormat::Ply) => ply::load(path),
        Some(ModelFormat::Gltf) => gltf_file::load(path),
        None => Err(FormatError::UnsupportedFormat { file: path.to_path_buf(), extension: ext }),
    }
}

/// Polygons with up to this many corners are split into a fan from their first corner.
const FAN_CORNERS: usize = 8;

/// Splits a (convex) polygon into `corners.len() - 2` triangles, appended to `out`, in time
/// linear in its corners. Small polygons become a fan from the first corner (what every
/// modeller expects of a quad). A large one is split in halves recursively instead: corners
/// `a, m, b` (m halfway from a to b) make a triangle and the chains a..m and m..b are split the
/// same way. A fan of a 2-million-corner disc is 2 million slivers that all reach the disc's
/// first corner, whose bounding boxes overlap so much that the BVH cannot separate them (an
/// image took 47 s); the halves make compact triangles, nested like the BVH wants them.
pub(crate) fn split_polygon(corners: &[u32], out: &mut Vec<[u32; 3]>) {
    let n = corners.len();
    if n < 3 {
        return;
    }
    if n <= FAN_CORNERS {
        out.extend((1..n - 1).map(|k| [corners[0], corners[k], corners[k + 1]]));
        return;
    }
    let mut chains = vec![(0usize, n - 1)];
    while let Some((a, b)) = chains.pop() {
        if b - a < 2 {
            continue;
        }
        let m = a + (b - a) / 2;
        out.push([corners[a], corners[m], corners[b]]);
        chains.push((m, b));
        chains.push((a, m));
    }
}

/// Drops zero-area triangles (warning per mesh) and meshes left without triangles. It is an
/// error when no triangle at all remains.
pub(crate) fn finish_meshes(
    path: &Path,
    meshes: &mut Vec<Mesh>,
    warnings: &mut Vec<String>,
) -> Result<(), FormatError> {
    let name = file_name(path);
    let total: usize = meshes.iter().map(|m| m.triangles.len()).sum();
    if total == 0 {
        return Err(FormatError::malformed(path, "geometry", "the file has no triangles"));
    }
    let mut dropped_total = 0;
    for m in meshes.iter_mut() {
        if let Some(message) = m.out_of_range_message() {
            let which = if m.name.is_empty() { String::new() } else { format!("mesh {:?}: ", m.name) };
            return Err(FormatError::limits(path, format!("{which}{message}")));
        }
        let copies = m.remove_duplicate_triangles();
        if copies > 0 {
            let which = if m.name.is_empty() { String::new() } else { format!(" (mesh {:?})", m.name) };
            warnings.push(format!("{name}: dropped {copies} duplicate triangles{which}"));
        }
        let dropped = m.remove_degenerate_triangles();
        if dropped > 0 {
            dropped_total += dropped;
            let which = if m.name.is_empty() { String::new() } else { format!(" (mesh '{}')", m.name) };
            warnings.push(format!("{name}: dropped {dropped} zero-area triangles{which}"));
        }
    }
    meshes.retain(|m| !m.triangles.is_empty());
    if meshes.is_empty() {
        return Err(FormatError::malformed(
            path,
            "geometry",
            format!("all {dropped_total} triangles have zero area: nothing is left to render"),
        ));
    }
    Ok(())
}

/// The file's name without its folders, for warnings.
pub(crate) fn file_name(path: &Path) -> String {
    path.file_name().map_or_else(|| path.display().to_string(), |n| n.to_string_lossy().into_owned())
}

/// Applies a scene's `shading` choice to a mesh; `None` keeps what the loader produced.
pub(crate) fn apply_shading(mesh: &mut Mesh, shading: Option<Shading>) {
    match shading {
        Some(Shading::Flat) => mesh.normals = None,
        Some(Shading::Smooth) if mesh.normals.is_none() => mesh.compute_vertex_normals(),
        Some(Shading::Smooth) | None => {}
    }
}

/// Vertical field of view of the camera [`scene_for_model`] places.
const MODEL_FOV_DEG: f32 = 40.0;

/// Space left around a framed model, as a fraction of the field of view.
const MODEL_MARGIN: f32 = 1.25;

/// A scene showing `model` on its own: the camera on the model's +Z side looking along −Z
/// (DESIGN.md's convention), framed on its bounding box with a small margin for the default
/// image size (1280×720; a narrower image may cut the sides of a wide model); a key light
/// (upper left, in front) and a fill light (right, weaker), so that shape reads; a grey sky;
/// [`Material::default`] where the file gives no material.
pub fn scene_for_model(model: Model) -> Scene {
    let Model { meshes, mut materials, bsdfs, textures, .. } = model;
    let bounds = meshes.iter().fold(Bounds3::EMPTY, |b, m| b.union(m.bounds()));
    let (camera, lights) = framing(bounds, false, default_aspect());
    let default_material = materials.len();
    materials.push(Material::default());
    let objects = (0..meshes.len())
        .map(|i| Object {
            name: if meshes[i].name.is_empty() { format!("mesh {i}") } else { meshes[i].name.clone() },
            shape: Shape::Mesh(i),
            material: default_material,
            world_from_object: Affine3A::IDENTITY,
        })
        .collect();
    Scene {
        camera,
        sky: Sky::Colour(Rgb::splat(0.2)),
        render: RenderDefaults::default(),
        ambient: Rgb::ONE,
        sky_ambient: false,
        materials,
        bsdfs,
        textures,
        meshes: meshes.into_iter().map(Arc::new).collect(),
        objects,
        clouds: Vec::new(),
        lights,
        animations: Vec::new(),
    }
}

/// A scene to look at one point cloud, drawn by the points mode: framed like a model (seen
/// from +Z, looking along −Z), except that a flat cloud (an airborne scan: a tile much wider
/// than tall) is seen from 40° above the horizon on that side, since edge-on it would be a
/// line.
pub fn scene_for_cloud(cloud: PointCloud) -> Scene {
    let bounds = cloud.bounds();
    let (camera, lights) = framing(bounds, is_airborne(&cloud), default_aspect());
    Scene {
        camera,
        sky: Sky::Colour(Rgb::splat(0.2)),
        render: RenderDefaults { mode: RenderMode::Points, ..RenderDefaults::default() },
        ambient: Rgb::ONE,
        sky_ambient: false,
        materials: vec![Material::default()],
        clouds: vec![CloudObject {
            name: cloud.name.clone(),
            cloud: Arc::new(cloud),
            material: 0,
            world_from_object: Affine3A::IDENTITY,
        }],
        lights,
        ..Scene::default()
    }
}

fn default_aspect() -> f32 {
    let r = RenderDefaults::default();
    r.width as f32 / r.height as f32
}

/// A flat, wide cloud (airborne LiDAR, a terrain scan): lower than a quarter of its width.
fn is_airborne(cloud: &PointCloud) -> bool {
    let extent = cloud.bounds().extent();
    extent.y < 0.25 * extent.x.max(extent.z)
}

/// The default view of a scene made by [`scene_for_model`] or [`scene_for_cloud`], refitted to
/// an image of `width × height` (those scenes are framed for the default 16:9 image).
pub fn default_camera(scene: &Scene, width: u32, height: u32) -> Camera {
    let elevated = scene.objects.is_empty() && scene.clouds.len() == 1 && is_airborne(&scene.clouds[0].cloud);
    framing(scene.bounds(), elevated, width as f32 / height.max(1) as f32).0
}

/// The camera that frames `bounds` from its +Z side (from `ELEVATED_DEG` above when
/// `elevated`) in an image of the given aspect (width / height), and a key and a fill light
/// beside it.
fn framing(bounds: Bounds3, elevated: bool, aspect: f32) -> (Camera, Vec<Light>) {
    let (centre, extent) = if bounds.is_empty() {
        (Vec3::ZERO, Vec3::ONE)
    } else {
        (bounds.centre(), bounds.extent().max(Vec3::splat(1e-6)))
    };
    let radius = extent.length() * 0.5;
    let tan_v = (MODEL_FOV_DEG * 0.5).to_radians().tan();
    let camera = if elevated {
        // Seen from above at ELEVATED_DEG, the box shows its width across and its depth
        // foreshortened (plus its height) up the image; fit both, then step back by half the
        // box's depth along the view.
        let (sin_e, cos_e) = ELEVATED_DEG.to_radians().sin_cos();
        let half_up = 0.5 * (extent.z * sin_e + extent.y * cos_e);
        let to_front = (half_up / tan_v).max(0.5 * extent.x / (tan_v * aspect));
        let distance = MODEL_MARGIN * to_front + 0.5 * (extent.z * cos_e + extent.y * sin_e);
        let dir = Vec3::new(0.0, sin_e, cos_e);
        Camera::look_at(centre + dir * distance, centre, Vec3::Y, Fov::Vertical(MODEL_FOV_DEG))
    } else {
        // The box's front face (z = max) subtends the largest angles: fit its half height and
        // half width into the vertical and horizontal fields of view.
        let to_front = (0.5 * extent.y / tan_v).max(0.5 * extent.x / (tan_v * aspect));
        let distance = 0.5 * extent.z + MODEL_MARGIN * to_front;
        Camera {
            position: centre + Vec3::Z * distance,
            forward: -Vec3::Z,
            up: Vec3::Y,
            fov: Fov::Vertical(MODEL_FOV_DEG),
            lens: glint_scene::Lens::Pinhole,
        }
    };
    let key = Light::Point {
        position: centre + Vec3::new(-1.0, 1.2, 1.5) * (2.0 * radius),
        colour: Rgb::ONE,
        intensity: 0.85,
        attenuation: Attenuation::None,
    };
    let fill = Light::Point {
        position: centre + Vec3::new(1.5, 0.3, 1.0) * (2.0 * radius),
        colour: Rgb::ONE,
        intensity: 0.35,
        attenuation: Attenuation::None,
    };
    (camera, vec![key, fill])
}

/// Elevation of the default view of an airborne scan.
const ELEVATED_DEG: f32 = 40.0;

#[cfg(test)]
mod tests {
    use super::*;

    fn quad_model() -> Model {
        Model {
            meshes: vec![Mesh {
                name: "quad".into(),
                positions: vec![
                    Vec3::new(-1.0, -1.0, 0.0),
                    Vec3::new(1.0, -1.0, 0.0),
                    Vec3::new(1.0, 1.0, 0.0),
                    Vec3::new(-1.0, 1.0, 0.0),
                ],
                triangles: vec![[0, 1, 2], [0, 2, 3]],
                ..Default::default()
            }],
            ..Default::default()
        }
    }

    #[test]
    fn model_scene_looks_along_minus_z_at_the_model_and_is_valid() {
        let s = scene_for_model(quad_model());
        assert_eq!(s.validate(), Ok(()));
        assert_eq!(s.camera.forward, -Vec3::Z);
        assert!(s.camera.position.z > 1.0 && s.camera.position.x == 0.0);
        assert_eq!(s.lights.len(), 2);
    }

    #[test]
    fn model_scene_frames_the_model_tightly() {
        for scale in [Vec3::ONE, Vec3::new(10.0, 1.0, 1.0), Vec3::new(1.0, 10.0, 3.0)] {
            let mut model = quad_model();
            for p in &mut model.meshes[0].positions {
                *p = *p * scale + Vec3::new(5.0, -3.0, 2.0);
            }
            let corners = model.meshes[0].positions.clone();
            let s = scene_for_model(model);
            let tan_v = (MODEL_FOV_DEG * 0.5).to_radians().tan();
            let tan_h = tan_v * 1280.0 / 720.0;
            let mut widest = 0.0f32;
            for p in corners {
                let d = p - s.camera.position;
                let (v, h) = ((d.y / -d.z).abs() / tan_v, (d.x / -d.z).abs() / tan_h);
                assert!(v < 1.0 && h < 1.0, "{p} is outside the view ({v}, {h})");
                widest = widest.max(v).max(h);
            }
            assert!(widest > 0.75, "the model fills the view along one axis: {widest}");
        }
    }

    /// Every polygon becomes `n - 2` triangles that tile it: for a convex polygon, the areas add
    /// up to the polygon's, each triangle is wound like the polygon, and every corner is used.
    #[test]
    fn polygons_split_into_triangles_that_tile_them() {
        for n in [3usize, 4, 5, 8, 9, 10, 17, 64, 1000, 4097] {
            let corners: Vec<u32> = (0..n as u32).collect();
            let point = |i: u32| {
                let a = std::f64::consts::TAU * f64::from(i) / n as f64;
                (a.cos(), a.sin())
            };
            let mut tris = Vec::new();
            split_polygon(&corners, &mut tris);
            assert_eq!(tris.len(), n - 2, "{n} corners");
            let mut area = 0.0;
            let mut used = vec![false; n];
            for t in &tris {
                let [p, q, r] = t.map(point);
                let twice = (q.0 - p.0) * (r.1 - p.1) - (q.1 - p.1) * (r.0 - p.0);
                assert!(twice > 0.0, "{n} corners: {t:?} is not wound counter-clockwise");
                area += 0.5 * twice;
                t.iter().for_each(|&i| used[i as usize] = true);
            }
            let polygon = 0.5 * n as f64 * (std::f64::consts::TAU / n as f64).sin();
            assert!((area - polygon).abs() < 1e-9 * polygon.max(1.0), "{n}: {area} vs {polygon}");
            assert!(used.iter().all(|&u| u), "{n}: a corner is unused");
        }
        // Quads and other small polygons stay fans from the first corner.
        let mut quad = Vec::new();
        split_polygon(&[7, 8, 9, 10], &mut quad);
        assert_eq!(quad, [[7, 8, 9], [7, 9, 10]]);
    }

    #[test]
    fn all_degenerate_meshes_are_an_error() {
        let mut meshes = vec![Mesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        }];
        let err = finish_meshes(Path::new("flat.obj"), &mut meshes, &mut Vec::new()).expect_err("degenerate");
        assert!(err.to_string().starts_with("flat.obj"), "{err}");
    }

    #[test]
    fn degenerate_triangles_are_dropped_with_a_warning() {
        let mut m = quad_model();
        m.meshes[0].triangles.push([0, 0, 1]);
        let mut warnings = Vec::new();
        finish_meshes(Path::new("q.obj"), &mut m.meshes, &mut warnings).expect("one good triangle left");
        assert_eq!(m.meshes[0].triangles.len(), 2);
        assert_eq!(warnings.len(), 1);
        assert!(warnings[0].starts_with("q.obj: dropped 1 zero-area"), "{}", warnings[0]);
    }
}
