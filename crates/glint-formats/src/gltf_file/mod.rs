//! glTF 2.0 (`.gltf` + buffers, or `.glb`) → a glint scene: the default scene's nodes (or else
//! the first scene's, or else every root node), their meshes baked into one world-space mesh
//! ([`geometry`]), their camera ([`cameras`]) and lights ([`lights`]), and the materials
//! ([`materials`]: a physically based model for the path mode, Phong parameters for Whitted).
//!
//! The `gltf` crate parses and validates the JSON; buffers and images are read here (not by
//! the crate's importer) so that a missing file is reported by name and a bad URI cannot
//! panic, and every buffer view and accessor is checked against its bytes before it is read.
//! Extensions read: KHR_lights_punctual, KHR_texture_transform, KHR_materials_transmission,
//! KHR_materials_ior, KHR_materials_volume (thickness only), KHR_materials_emissive_strength.
//! A file that *requires* another extension is refused; one that merely uses it is read
//! without it. Not read: skins, morph targets, animations, KHR_materials_unlit, clearcoat,
//! sheen, specular, variants, Draco and meshopt compression, texture formats other than PNG
//! and JPEG.
//!
//! Without a camera, the model is framed as [`crate::scene_for_model`] does; without lights,
//! it gets that function's key and fill lights. The sky is a dim grey either way.

mod buffers;
mod cameras;
mod geometry;
mod lights;
mod materials;

use crate::Loaded;
use crate::error::FormatError;
use crate::model::{self, Model};
use buffers::{check_views, read_buffers};
use cameras::NodeCamera;
use geometry::{Baked, NodeFrame};
use glint_core::{Mat4, Quat, Vec3};
use glint_scene::{Light, RenderDefaults};
use gltf::Gltf;
use std::path::Path;

/// How [`load_gltf`] reads a file.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct GltfOptions {
    /// The camera to look through, by the camera's name (or else its node's); `None`: the
    /// first camera of the scene, depth first in the order the file lists the nodes.
    pub camera_name: Option<String>,
}

/// Reads a glTF file as a scene to render: its geometry, materials, camera and lights
/// (see the module documentation for what is read and how it maps), validated.
pub fn load_gltf(path: &Path, options: &GltfOptions) -> Result<Loaded, FormatError> {
    let GltfScene { mut model, cameras, lights } = read_guarded(path)?;
    let warnings = std::mem::take(&mut model.warnings);
    let chosen = cameras::choose(path, &cameras, options.camera_name.as_deref())?;
    let mut scene = crate::scene_for_model(model);
    if let Some(chosen) = chosen {
        let (camera, aspect) = cameras::convert_camera(path, chosen)?;
        scene.camera = camera;
        if let Some(aspect) = aspect {
            let height = RenderDefaults::default().height;
            scene.render.height = height;
            scene.render.width = ((height as f32 * aspect).round() as u32).clamp(1, glint_scene::scene::MAX_IMAGE_SIDE);
        }
    }
    if !lights.is_empty() {
        scene.lights = lights;
    }
    scene.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    Ok(Loaded { scene, warnings })
}

/// The file's geometry and materials alone (a mesh for a TOML scene, or [`crate::load_model`]).
pub(crate) fn load(path: &Path) -> Result<Model, FormatError> {
    Ok(read_guarded(path)?.model)
}

/// What a glTF file holds for glint.
struct GltfScene {
    model: Model,
    /// Every camera of the scene, in walk order.
    cameras: Vec<NodeCamera>,
    lights: Vec<Light>,
}

/// [`read`], with the `gltf` crate's panics turned into errors, and zero-area triangles
/// dropped.
fn read_guarded(path: &Path) -> Result<GltfScene, FormatError> {
    let data = crate::files::read_sniffed(path, None, sniff_gltf)?;
    // The gltf crate trusts its validation in a few `unwrap`s; a file that slips past it must
    // still be an error, not a crash.
    let result = std::panic::catch_unwind(|| read(path, &data));
    let mut scene = result.unwrap_or_else(|_| {
        Err(FormatError::malformed(path, "file", "the glTF parser failed on this file (inconsistent content)"))
    })?;
    model::finish_meshes(path, &mut scene.model.meshes, &mut scene.model.warnings)?;
    Ok(scene)
}

/// A .glb starts with `glTF`; a .gltf is JSON, an object (after an optional byte-order mark
/// and white space).
fn sniff_gltf(head: &[u8]) -> Result<(), String> {
    let text = head.strip_prefix(b"\xef\xbb\xbf").unwrap_or(head);
    let first = text.iter().find(|b| !b.is_ascii_whitespace());
    if head.starts_with(b"glTF") || matches!(first, Some(b'{') | None) {
        Ok(())
    } else {
        Err("not a glTF file (neither a .glb container starting with `glTF` nor a JSON object)".to_string())
    }
}

fn gltf_error(path: &Path, e: gltf::Error) -> FormatError {
    match e {
        gltf::Error::Deserialize(e) => FormatError::malformed(
            path,
            format!("line {}, column {}", e.line(), e.column()),
            format!("invalid JSON: {e}"),
        ),
        gltf::Error::Binary(e) => FormatError::malformed(path, "header", format!("invalid .glb container: {e}")),
        gltf::Error::Validation(errors) => {
            let more =
                if errors.len() > 1 { format!(" (and {} more problems)", errors.len() - 1) } else { String::new() };
            match errors.first() {
                Some((where_, what)) => FormatError::malformed(path, where_.to_string(), format!("{what}{more}")),
                None => FormatError::malformed(path, "file", "invalid glTF"),
            }
        }
        other => FormatError::malformed(path, "file", other.to_string()),
    }
}

/// A .glb's 12-byte header, checked before the `gltf` crate reads it: its reader subtracts
/// the header size from the declared length unchecked (an overflow panic in builds with
/// overflow checks, found by fuzzing: tests/corpus/gltf/glb_length_zero.glb). Version 2, and a
/// length that holds the header and one chunk header and no more than the file.
fn check_glb_header(data: &[u8]) -> Result<(), String> {
    if !data.starts_with(b"glTF") {
        return Ok(());
    }
    let word = |i: usize| data.get(i..i + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    let (Some(version), Some(length)) = (word(4), word(8)) else {
        return Err(format!("the .glb header is cut short ({} of its 12 bytes)", data.len()));
    };
    if version != 2 {
        return Err(format!(".glb version {version}: glint reads glTF 2.0 containers"));
    }
    if length < 20 || length as usize > data.len() {
        return Err(format!(
            "the .glb header declares {length} bytes; the container needs at least 20 and the file has {}",
            data.len()
        ));
    }
    Ok(())
}

/// The document, validated. The `gltf` crate's validation indexes a primitive's POSITION
/// accessor without checking that it exists (a panic, found by fuzzing:
/// tests/corpus/gltf/position_accessor_missing.gltf), so that reference is checked first.
fn parse(path: &Path, data: &[u8]) -> Result<Gltf, FormatError> {
    use gltf::json::validation::{Checked, Validate};
    check_glb_header(data).map_err(|m| FormatError::malformed(path, "header", m))?;
    let gltf = Gltf::from_slice_without_validation(data).map_err(|e| gltf_error(path, e))?;
    let root = gltf.document.as_json();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive.attributes.get(&Checked::Valid(gltf::Semantic::Positions));
            if let Some(index) = position
                && index.value() >= root.accessors.len()
            {
                return Err(FormatError::malformed(
                    path,
                    format!("meshes[{m}].primitives[{p}].attributes.POSITION"),
                    format!("accessors[{}] does not exist ({} accessors)", index.value(), root.accessors.len()),
                ));
            }
        }
    }
    let mut errors = Vec::new();
    root.validate(root, gltf::json::Path::new, &mut |at, error| errors.push((at(), error)));
    if !errors.is_empty() {
        return Err(gltf_error(path, gltf::Error::Validation(errors)));
    }
    Ok(gltf)
}

/// The file's materials, one world-space mesh of all its triangle primitives, its cameras and
/// lights, and warnings.
fn read(path: &Path, data: &[u8]) -> Result<GltfScene, FormatError> {
    let Gltf { document, blob } = parse(path, data)?;
    let base = path.parent().unwrap_or(Path::new(""));
    let mut warnings = Vec::new();
    let buffers = read_buffers(path, base, &document, blob)?;
    check_views(path, &document, &buffers)?;
    let materials::Materials { mut materials, bsdfs, textures, uv_sets } =
        materials::read_materials(path, base, &document, &buffers, &mut warnings)?;
    let mut baked = Baked::new(path, materials.len() as u32);
    let mut cameras = Vec::new();
    let mut lights = Vec::new();
    for_each_node(path, &document, |node, world| {
        if let Some(camera) = node.camera() {
            cameras.push(NodeCamera {
                node: node.index(),
                node_name: node.name().map(str::to_string),
                camera: camera.index(),
                name: camera.name().map(str::to_string),
                world_from_node: world,
                projection: cameras::Projection::of(&camera),
            });
        }
        if let Some(light) = node.light() {
            lights.push(lights::convert_light(path, node.index(), &light, &world, &mut warnings)?);
        }
        let Some(gltf_mesh) = node.mesh() else { return Ok(()) };
        let frame = NodeFrame::new(world);
        for (p, primitive) in gltf_mesh.primitives().enumerate() {
            let place = format!("meshes[{}].primitives[{p}]", gltf_mesh.index());
            let uv_set = primitive.material().index().and_then(|m| uv_sets.get(m).copied()).unwrap_or(0);
            baked.primitive(path, &place, &primitive, &buffers, &frame, uv_set)?;
        }
        Ok(())
    })?;
    let meshes = baked.finish(path, &mut warnings, &mut materials);
    Ok(GltfScene { model: Model { meshes, materials, bsdfs, textures, warnings }, cameras, lights })
}

/// Calls `visit(node, world_from_node)` for every node of the default scene (or else the first
/// scene, or else every root node), depth first in the order the file lists them (parents
/// before children). A node reached twice is an error, as is a transform that is not finite.
fn for_each_node<'a>(
    path: &Path,
    document: &'a gltf::Document,
    mut visit: impl FnMut(&gltf::Node<'a>, Mat4) -> Result<(), FormatError>,
) -> Result<(), FormatError> {
    let roots: Vec<gltf::Node> = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            let mut is_child = vec![false; document.nodes().len()];
            for n in document.nodes() {
                for c in n.children() {
                    is_child[c.index()] = true;
                }
            }
            document.nodes().filter(|n| !is_child[n.index()]).collect()
        }
    };
    let mut visited = vec![false; document.nodes().len()];
    let mut stack: Vec<(gltf::Node, Mat4)> = roots.into_iter().rev().map(|n| (n, Mat4::IDENTITY)).collect();
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut visited[node.index()], true) {
            return Err(FormatError::malformed(
                path,
                format!("nodes[{}]", node.index()),
                "the node is reached twice (a cycle, or a node with two parents)",
            ));
        }
        let local = match node.transform() {
            // glTF asks for a unit quaternion; a slightly long one must not scale.
            gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                Mat4::from_scale_rotation_translation(
                    Vec3::from_array(scale),
                    Quat::from_array(rotation).normalize(),
                    Vec3::from_array(translation),
                )
            }
            gltf::scene::Transform::Matrix { matrix } => Mat4::from_cols_array_2d(&matrix),
        };
        let world = parent * local;
        if !world.is_finite() {
            return Err(FormatError::malformed(
                path,
                format!("nodes[{}]", node.index()),
                "the transform is not finite (NaN, infinite, or a zero rotation quaternion)",
            ));
        }
        let children: Vec<gltf::Node> = node.children().collect();
        for child in children.into_iter().rev() {
            stack.push((child, world));
        }
        visit(&node, world)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests;
