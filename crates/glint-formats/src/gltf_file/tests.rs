//! glTF tests on small files written by the test: .gltf with a .bin, .glb, data URIs, and
//! broken files; a node hierarchy with cameras and lights; materials and their textures.

use super::*;
use crate::test_util::TempDir;
use buffers::decode_base64;
use glint_core::colour::srgb_to_linear;
use glint_core::{Rgb, Vec2};
use glint_scene::{BsdfKind, Filter, Fov, Mesh, Principled, Scene, Tex, Texture, Wrap};
use std::f32::consts::PI;
use std::path::PathBuf;

fn load(path: &Path) -> Result<Model, FormatError> {
    super::load(path)
}

/// Two triangles (a quad in z = 0) as positions, uvs and u16 indices, packed into one buffer.
fn quad_buffer() -> Vec<u8> {
    let mut b = Vec::new();
    for p in [[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]] {
        for c in p {
            b.extend(c.to_le_bytes());
        }
    }
    for t in [[0.0f32, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]] {
        for c in t {
            b.extend(c.to_le_bytes());
        }
    }
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend(i.to_le_bytes());
    }
    b
}

fn quad_json(buffer: &str, index_count: usize, mode: u32) -> String {
    format!(
        r#"{{
  "asset": {{ "version": "2.0" }},
  "scene": 0,
  "scenes": [ {{ "nodes": [0] }} ],
  "nodes": [ {{ "translation": [0, 0, -2], "children": [1] }}, {{ "mesh": 0, "scale": [2, 2, 2] }} ],
  "meshes": [ {{ "primitives": [ {{
      "attributes": {{ "POSITION": 0, "TEXCOORD_0": 1 }}, "indices": 2, "material": 0, "mode": {mode} }} ] }} ],
  "materials": [ {{ "name": "red", "pbrMetallicRoughness": {{ "baseColorFactor": [0.8, 0.1, 0.1, 1.0],
      "metallicFactor": 0.0, "roughnessFactor": 0.5 }} }} ],
  "buffers": [ {{ {buffer} "byteLength": 92 }} ],
  "bufferViews": [
    {{ "buffer": 0, "byteOffset": 0, "byteLength": 48 }},
    {{ "buffer": 0, "byteOffset": 48, "byteLength": 32 }},
    {{ "buffer": 0, "byteOffset": 80, "byteLength": 12 }} ],
  "accessors": [
    {{ "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }},
    {{ "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" }},
    {{ "bufferView": 2, "componentType": 5123, "count": {index_count}, "type": "SCALAR" }} ]
}}"#
    )
}

fn write_gltf(dir: &TempDir, json: &str) -> PathBuf {
    std::fs::write(dir.join("quad.bin"), quad_buffer()).expect("bin");
    let path = dir.join("quad.gltf");
    std::fs::write(&path, json).expect("gltf");
    path
}

#[test]
fn gltf_with_bin_is_baked_to_world_space() {
    let dir = TempDir::new("gltf-bin");
    let path = write_gltf(&dir, &quad_json(r#""uri": "quad.bin","#, 6, 4));
    let m = load(&path).expect("valid");
    let mesh = &m.meshes[0];
    assert_eq!(mesh.triangles.len(), 2);
    assert_eq!(mesh.positions[2], Vec3::new(2.0, 2.0, -2.0));
    // v flipped: the file's (1, 0) (top right of the image) is glint's (1, 1).
    assert_eq!(mesh.uvs.as_ref().map(|u| u[2]), Some(Vec2::new(1.0, 1.0)));
    assert!(mesh.normals.is_none());
    assert_eq!(mesh.triangle_materials, Some(vec![0, 0]));
    assert_eq!(m.materials[0].name, "red");
    assert_eq!(m.materials[0].colour, Rgb::new(0.8, 0.1, 0.1));
    let loaded = crate::load(&path).expect("scene");
    assert_eq!(loaded.scene.validate(), Ok(()));
}

#[test]
fn glb_and_data_uri_read_the_same_mesh() {
    let dir = TempDir::new("gltf-glb");
    let reference = load(&write_gltf(&dir, &quad_json(r#""uri": "quad.bin","#, 6, 4))).expect("gltf");

    let b64 = encode_base64(&quad_buffer());
    let data_uri = dir.join("inline.gltf");
    std::fs::write(&data_uri, quad_json(&format!(r#""uri": "data:application/octet-stream;base64,{b64}","#), 6, 4))
        .expect("write");
    let same = |m: Model| Mesh { name: "quad".into(), ..m.meshes[0].clone() };
    assert_eq!(same(load(&data_uri).expect("data uri")), reference.meshes[0]);

    let mut json = quad_json("", 6, 4).into_bytes();
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let bin = quad_buffer();
    let mut glb = Vec::new();
    glb.extend(b"glTF");
    glb.extend(2u32.to_le_bytes());
    glb.extend(((12 + 8 + json.len() + 8 + bin.len()) as u32).to_le_bytes());
    glb.extend((json.len() as u32).to_le_bytes());
    glb.extend(b"JSON");
    glb.extend(&json);
    glb.extend((bin.len() as u32).to_le_bytes());
    glb.extend(b"BIN\0");
    glb.extend(&bin);
    let glb_path = dir.join("quad.GLB");
    std::fs::write(&glb_path, glb).expect("write");
    assert_eq!(same(load(&glb_path).expect("glb")), reference.meshes[0]);
}

fn encode_base64(data: &[u8]) -> String {
    const ALPHABET: &[u8] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in data.chunks(3) {
        let mut v = [0u8; 3];
        v[..chunk.len()].copy_from_slice(chunk);
        let n = u32::from_be_bytes([0, v[0], v[1], v[2]]);
        for k in 0..=chunk.len() {
            out.push(ALPHABET[(n >> (18 - 6 * k) & 63) as usize] as char);
        }
    }
    out
}

#[test]
fn base64_round_trips() {
    for n in 0..10 {
        let data: Vec<u8> = (0..n).map(|i| (i * 37 + 11) as u8).collect();
        assert_eq!(decode_base64(&encode_base64(&data)), Some(data));
    }
    assert_eq!(decode_base64("QQ=="), Some(b"A".to_vec()));
    assert_eq!(decode_base64("Q!=="), None);
}

#[test]
fn malformed_json_is_reported_with_its_line() {
    let dir = TempDir::new("gltf-json");
    let path = write_gltf(&dir, "{\n  \"asset\": { \"version\": \"2.0\" },\n  \"nodes\": [ oops ]\n}\n");
    let e = load(&path).expect_err("bad json");
    let msg = e.to_string();
    assert!(msg.starts_with(&format!("{}: line 3", path.display())), "{msg}");
}

#[test]
fn missing_buffer_file_is_named() {
    let dir = TempDir::new("gltf-missing");
    let path = write_gltf(&dir, &quad_json(r#""uri": "gone.bin","#, 6, 4));
    let e = load(&path).expect_err("missing buffer");
    let FormatError::MissingFile { file, referenced_from } = &e else { panic!("{e}") };
    assert!(file.ends_with("gone.bin"), "{e}");
    assert!(referenced_from.contains("quad.gltf") && referenced_from.contains("buffers[0]"), "{e}");
}

#[test]
fn index_out_of_range_is_an_error() {
    let dir = TempDir::new("gltf-index");
    let mut bin = quad_buffer();
    bin[90] = 9; // the last index: 3 → 9
    std::fs::write(dir.join("quad.bin"), &bin).expect("bin");
    let path = dir.join("bad.gltf");
    std::fs::write(&path, quad_json(r#""uri": "quad.bin","#, 6, 4)).expect("gltf");
    let msg = load(&path).expect_err("bad index").to_string();
    assert!(msg.contains("meshes[0].primitives[0] index 5") && msg.contains("out of range"), "{msg}");
}

#[test]
fn non_triangle_primitives_are_skipped_with_a_warning() {
    let dir = TempDir::new("gltf-lines");
    let path = write_gltf(&dir, &quad_json(r#""uri": "quad.bin","#, 6, 1));
    let e = load(&path).expect_err("only lines: nothing to render");
    assert!(e.to_string().contains("no triangles"), "{e}");
}

#[test]
fn truncated_glb_is_an_error() {
    let dir = TempDir::new("gltf-truncated");
    let path = dir.join("t.glb");
    std::fs::write(&path, b"glTF\x02\x00\x00\x00\xff\x00\x00\x00JS").expect("write");
    let msg = load(&path).expect_err("truncated").to_string();
    assert!(msg.starts_with(&path.display().to_string()), "{msg}");
}

/// A glTF document around `parts` (JSON members, each followed by a comma): the quad of
/// [`quad_buffer`] as a data URI, its three accessors, and `meshes` unless `parts` has them.
fn document(parts: &str) -> String {
    let mesh = if parts.contains("\"meshes\"") {
        ""
    } else {
        r#""meshes": [ { "primitives": [ {
            "attributes": { "POSITION": 0, "TEXCOORD_0": 1 }, "indices": 2, "material": 0 } ] } ],"#
    };
    let b64 = encode_base64(&quad_buffer());
    format!(
        r#"{{
  "asset": {{ "version": "2.0" }},
  {parts}
  {mesh}
  "buffers": [ {{ "uri": "data:application/octet-stream;base64,{b64}", "byteLength": 92 }} ],
  "bufferViews": [
    {{ "buffer": 0, "byteOffset": 0, "byteLength": 48 }},
    {{ "buffer": 0, "byteOffset": 48, "byteLength": 32 }},
    {{ "buffer": 0, "byteOffset": 80, "byteLength": 12 }} ],
  "accessors": [
    {{ "bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0] }},
    {{ "bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2" }},
    {{ "bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR" }} ]
}}"#
    )
}

fn write(dir: &TempDir, name: &str, json: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, json).expect("write gltf");
    path
}

/// A 2×2 RGBA PNG of the given texels (rows top to bottom) as a data URI.
fn png_uri(texels: [[u8; 4]; 4]) -> String {
    format!("data:image/png;base64,{}", encode_base64(&png_bytes(texels)))
}

fn png_bytes(texels: [[u8; 4]; 4]) -> Vec<u8> {
    let img = image::RgbaImage::from_raw(2, 2, texels.concat()).expect("2x2");
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).expect("encode png");
    out.into_inner()
}

fn assert_close(a: Vec3, b: Vec3, what: &str) {
    assert!((a - b).length() < 1e-5, "{what}: {a} != {b}");
}

const MATTE: &str = r#""materials": [ { "pbrMetallicRoughness": { "metallicFactor": 0.0 } } ],"#;

/// A root turned 90° about +Y and moved to z = −2, holding the mesh, a perspective camera
/// 5 along its local +Z, a point light, a directional light (a matrix turning −Z down), a
/// scaled spot light, and an orthographic camera named "top".
fn lit_scene() -> String {
    let (s, c) = (std::f32::consts::FRAC_1_SQRT_2, std::f32::consts::FRAC_1_SQRT_2);
    document(&format!(
        r#""scene": 0,
  "scenes": [ {{ "nodes": [0] }} ],
  "nodes": [
    {{ "translation": [0, 0, -2], "rotation": [0, {s}, 0, {c}], "children": [1, 2, 3, 4, 5, 6] }},
    {{ "mesh": 0 }},
    {{ "name": "eye", "camera": 0, "translation": [0, 0, 5] }},
    {{ "translation": [1, 2, 0], "extensions": {{ "KHR_lights_punctual": {{ "light": 0 }} }} }},
    {{ "matrix": [1, 0, 0, 0,  0, 0, -1, 0,  0, 1, 0, 0,  0, 0, 0, 1],
       "extensions": {{ "KHR_lights_punctual": {{ "light": 1 }} }} }},
    {{ "scale": [2, 2, 2], "extensions": {{ "KHR_lights_punctual": {{ "light": 2 }} }} }},
    {{ "camera": 1, "translation": [0, 10, 0], "rotation": [-{s}, 0, 0, {c}] }} ],
  "cameras": [
    {{ "name": "persp", "type": "perspective", "perspective": {{ "yfov": 0.8, "aspectRatio": 2.0, "znear": 0.1 }} }},
    {{ "name": "top", "type": "orthographic",
       "orthographic": {{ "xmag": 3, "ymag": 1.5, "znear": 0.1, "zfar": 100 }} }} ],
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{ "KHR_lights_punctual": {{ "lights": [
    {{ "type": "point", "color": [1, 0.5, 0.25], "intensity": 100, "range": 20 }},
    {{ "type": "directional", "intensity": 3 }},
    {{ "type": "spot", "intensity": 50, "spot": {{ "innerConeAngle": 0.2, "outerConeAngle": 0.6 }} }} ] }} }},
  {MATTE}"#
    ))
}

#[test]
fn hierarchy_places_camera_and_lights_in_world_space() {
    let dir = TempDir::new("gltf-lit");
    let path = write(&dir, "lit.gltf", &lit_scene());
    let loaded = load_gltf(&path, &GltfOptions::default()).expect("valid");
    let Loaded { scene, warnings } = loaded;
    // The mesh: the quad's (1, 0, 0) turned to (0, 0, −1), then moved to z = −2.
    assert!(scene.meshes[0].positions.iter().any(|p| (*p - Vec3::new(0.0, 0.0, -3.0)).length() < 1e-5));

    // The first camera in node order; its local +Z (0, 0, 5) turned to +X.
    let cam = scene.camera;
    assert_close(cam.position, Vec3::new(5.0, 0.0, -2.0), "camera position");
    assert_close(cam.forward, -Vec3::X, "camera forward");
    assert_close(cam.up, Vec3::Y, "camera up");
    assert_eq!(cam.fov, Fov::Vertical(0.8f32.to_degrees()));
    assert_eq!((scene.render.width, scene.render.height), (1440, 720));

    assert_eq!(scene.lights.len(), 3);
    let Light::Point { position, colour, intensity, attenuation } = scene.lights[0] else { panic!("point") };
    // (1, 2, 0) turned to (0, 2, −1), moved to z = −2; 100 cd → 100/π.
    assert_close(position, Vec3::new(0.0, 2.0, -3.0), "point light");
    assert_eq!(colour, Rgb::new(1.0, 0.5, 0.25));
    assert!((intensity - 100.0 / PI).abs() < 1e-4, "{intensity}");
    assert_eq!(attenuation, glint_scene::Attenuation::InverseSquare);
    let Light::Directional { direction, intensity, .. } = scene.lights[1] else { panic!("directional") };
    assert_close(direction, -Vec3::Y, "directional light");
    assert!((intensity - 3.0 / PI).abs() < 1e-6);
    let Light::Spot { position, direction, intensity, inner_deg, outer_deg, .. } = scene.lights[2] else {
        panic!("spot")
    };
    assert_close(position, Vec3::new(0.0, 0.0, -2.0), "spot position");
    assert_close(direction, -Vec3::X, "spot direction (not scaled)");
    assert!((intensity - 50.0 / PI).abs() < 1e-4);
    // glTF's falloff: full on the axis, nothing past the outer cone, glTF's value half way.
    let at = |deg: f32| {
        let p = position + (Quat::from_rotation_y(deg.to_radians()) * direction) * 3.0;
        scene.lights[2].sample_at(p).map_or(0.0, |s| s.radiance.x * 9.0 / intensity)
    };
    assert!((at(0.0) - 1.0).abs() < 1e-4);
    assert_eq!(at(0.6f32.to_degrees() + 1.0), 0.0);
    let mid = ((0.4f32.cos() - 0.6f32.cos()) / (0.2f32.cos() - 0.6f32.cos())).powi(2);
    assert!(
        (at(0.4f32.to_degrees()) - mid).abs() < 1e-4,
        "{} vs {mid} ({inner_deg}..{outer_deg})",
        at(0.4f32.to_degrees())
    );

    assert!(warnings.iter().any(|w| w.contains("lights[0]") && w.contains("range")), "{warnings:?}");
    assert_eq!(scene.validate(), Ok(()));
}

#[test]
fn cameras_are_chosen_by_name_and_orthographic_ones_keep_their_view() {
    let dir = TempDir::new("gltf-cameras");
    let path = write(&dir, "lit.gltf", &lit_scene());
    let by_node = GltfOptions { camera_name: Some("eye".into()) };
    assert_close(load_gltf(&path, &by_node).expect("node name").scene.camera.forward, -Vec3::X, "by node name");

    let top = load_gltf(&path, &GltfOptions { camera_name: Some("top".into()) }).expect("orthographic");
    let cam = top.scene.camera;
    assert_close(cam.position, Vec3::new(0.0, 10.0, -2.0), "top camera");
    assert_close(cam.forward, -Vec3::Y, "top camera looks down");
    // ymag 1.5 is the half height; xmag / ymag the default aspect.
    assert_eq!(cam.lens, glint_scene::Lens::Orthographic(glint_scene::ViewSize::HalfHeight(1.5)));
    assert_eq!((top.scene.render.width, top.scene.render.height), (1440, 720));
    assert!(!top.warnings.iter().any(|w| w.contains("camera")), "{:?}", top.warnings);

    let missing = GltfOptions { camera_name: Some("nope".into()) };
    let msg = load_gltf(&path, &missing).expect_err("no such camera").to_string();
    assert!(msg.contains("'nope'") && msg.contains("'persp'") && msg.contains("'top'"), "{msg}");
}

#[test]
fn a_file_without_camera_or_lights_is_framed_and_lit_by_default() {
    let dir = TempDir::new("gltf-plain");
    let path = write(&dir, "plain.gltf", &document(&format!(r#""nodes": [ {{ "mesh": 0 }} ], {MATTE}"#)));
    let scene = load_gltf(&path, &GltfOptions::default()).expect("valid").scene;
    assert_eq!(scene.lights.len(), 2);
    assert_eq!(scene.camera.forward, -Vec3::Z);
    assert_eq!(scene.validate(), Ok(()));
}

fn principled(scene: &Scene, id: usize) -> &Principled {
    match &scene.bsdfs[id] {
        BsdfKind::Principled(p) => p,
        other => panic!("bsdf #{id} is {other:?}"),
    }
}

fn image_texture<'s>(
    scene: &'s Scene,
    t: &Tex<impl std::fmt::Debug>,
) -> (&'s glint_scene::TextureImage, glint_scene::Sampler) {
    let &Tex::Texture(i) = t else { panic!("textured: {t:?}") };
    texture_at(scene, i)
}

fn texture_at(scene: &Scene, i: usize) -> (&glint_scene::TextureImage, glint_scene::Sampler) {
    let Texture::Image { image, sampler, .. } = &scene.textures[i] else { panic!("image") };
    (image, *sampler)
}

#[test]
fn metallic_roughness_material_maps_to_principled_with_its_textures() {
    let dir = TempDir::new("gltf-pbr");
    // Base colour: sRGB 188 ≈ 0.5 linear; alpha 255. metallicRoughness: G 51 (0.2), B 204 (0.8).
    let base = png_uri([[188, 0, 0, 255], [0, 188, 0, 255], [0, 0, 188, 255], [255, 255, 255, 255]]);
    let mr = png_uri([[0, 51, 204, 255]; 4]);
    let normal = png_uri([[255, 128, 128, 255]; 4]);
    std::fs::write(dir.join("emit.png"), png_bytes([[255, 128, 0, 255]; 4])).expect("png");
    let json = document(&format!(
        r#""nodes": [ {{ "mesh": 0 }} ],
  "extensionsUsed": ["KHR_texture_transform", "KHR_materials_emissive_strength"],
  "images": [ {{ "uri": "{base}" }}, {{ "uri": "{mr}" }}, {{ "uri": "{normal}" }}, {{ "uri": "emit.png" }} ],
  "samplers": [ {{ "wrapS": 33648, "wrapT": 33071, "magFilter": 9728 }} ],
  "textures": [ {{ "source": 0, "sampler": 0 }}, {{ "source": 1 }}, {{ "source": 2 }}, {{ "source": 3 }} ],
  "materials": [ {{
    "name": "brushed",
    "doubleSided": true,
    "pbrMetallicRoughness": {{
      "baseColorFactor": [0.5, 1, 1, 1],
      "baseColorTexture": {{ "index": 0,
        "extensions": {{ "KHR_texture_transform": {{ "offset": [0.5, 0], "scale": [2, 2] }} }} }},
      "metallicFactor": 0.5, "roughnessFactor": 0.8,
      "metallicRoughnessTexture": {{ "index": 1 }} }},
    "normalTexture": {{ "index": 2, "scale": 0.5,
      "extensions": {{ "KHR_texture_transform": {{ "rotation": {half_pi} }} }} }},
    "occlusionTexture": {{ "index": 1 }},
    "emissiveFactor": [1, 0.5, 0],
    "emissiveTexture": {{ "index": 3 }},
    "extensions": {{ "KHR_materials_emissive_strength": {{ "emissiveStrength": 4 }} }} }} ],"#,
        half_pi = PI / 2.0
    ));
    let path = write(&dir, "pbr.gltf", &json);
    let Loaded { scene, warnings } = load_gltf(&path, &GltfOptions::default()).expect("valid");
    assert!(warnings.is_empty(), "{warnings:?}");
    assert_eq!(scene.validate(), Ok(()));
    let m = scene.materials.iter().find(|m| m.name == "brushed").expect("material");

    // doubleSided → TwoSided(NormalMap(Principled)).
    let top = m.bsdf.expect("a model");
    let BsdfKind::TwoSided { front, back } = scene.bsdfs[top] else { panic!("{:?}", scene.bsdfs[top]) };
    assert_eq!(front, back);
    let BsdfKind::NormalMap { normals, inner } = scene.bsdfs[front] else { panic!("{:?}", scene.bsdfs[front]) };
    let p = principled(&scene, inner);
    assert_eq!((p.thin, p.eta, p.spec_trans), (false, Some(1.5), Tex::Value(0.0)));
    assert!((p.specular - 0.5).abs() < 1e-6, "{}", p.specular);

    // Base colour: sRGB decoded, times the factor, for the model.
    let (base_image, base_sampler) = image_texture(&scene, &p.base_color);
    let want = Rgb::new(srgb_to_linear(188.0 / 255.0) * 0.5, 0.0, 0.0);
    assert!((base_image.texels[0] - want).length() < 1e-5, "{}", base_image.texels[0]);
    assert_eq!(
        (base_sampler.wrap_u, base_sampler.wrap_v, base_sampler.filter),
        (Wrap::MirroredRepeat, Wrap::Clamp, Filter::Nearest)
    );
    // KHR_texture_transform in glint's uv: glint (0.25, 0.75) is glTF's (0.25, 0.25), which
    // scales to (0.5, 0.5) and moves to (1.0, 0.5): glint's (1.0, 0.5).
    let uv = base_sampler.texture_from_surface.transform_point2(Vec2::new(0.25, 0.75));
    assert!((uv - Vec2::new(1.0, 0.5)).length() < 1e-6, "{uv}");
    // The Whitted mode multiplies the factor itself: the unscaled image.
    let (whitted_image, _) = texture_at(&scene, m.texture.expect("texture"));
    assert!((whitted_image.texels[0].x - srgb_to_linear(188.0 / 255.0)).abs() < 1e-5);
    assert_eq!(m.colour, Rgb::new(0.5, 1.0, 1.0));

    // Metallic = blue × 0.5, roughness = green × 0.8, linear; luminance of grey = the value.
    let (metal, _) = image_texture(&scene, &p.metallic);
    let (rough, _) = image_texture(&scene, &p.roughness);
    assert!((metal.texels[0] - Rgb::splat(0.8 * 0.5)).length() < 1e-5, "{}", metal.texels[0]);
    assert!((rough.texels[0] - Rgb::splat(0.2 * 0.8)).length() < 1e-5, "{}", rough.texels[0]);

    // The normal map's scale is baked: (1, 0, 0) scaled by 0.5 in x stays (1, 0, 0) once
    // normalised; its rotation by 90°: glTF (1, 0) → (0, 1), in glint's uv (1, 1) → (0, 0).
    let (nm, nm_sampler) = texture_at(&scene, normals);
    let n = nm.texels[0] * 2.0 - Rgb::ONE;
    assert!((n.length() - 1.0).abs() < 1e-5 && n.x > 0.99, "{n}");
    let uv = nm_sampler.texture_from_surface.transform_point2(Vec2::new(1.0, 1.0));
    assert!(uv.length() < 1e-5, "{uv}");

    // Emission: factor × strength, the texture (an external file) beside it.
    assert_eq!(m.emission, Rgb::new(4.0, 2.0, 0.0));
    let (emit, _) = texture_at(&scene, m.emission_texture.expect("emission texture"));
    assert!((emit.texels[0] - Rgb::new(1.0, srgb_to_linear(128.0 / 255.0), 0.0)).length() < 1e-5);

    // Whitted: a half metal, fairly rough.
    assert!(m.two_sided);
    assert!((m.specular - 0.2).abs() < 1e-6 && (m.diffuse - 0.55).abs() < 1e-6);
    assert!(m.reflection_f0.is_some_and(|f0| f0.max_element() <= 1.0));
}

#[test]
fn alpha_modes_become_masks() {
    let dir = TempDir::new("gltf-alpha");
    let base = png_uri([[255, 255, 255, 0], [255, 255, 255, 255], [255, 255, 255, 128], [255, 255, 255, 255]]);
    let json = document(&format!(
        r#""nodes": [ {{ "mesh": 0 }} ],
  "images": [ {{ "uri": "{base}" }} ], "textures": [ {{ "source": 0 }} ],
  "materials": [
    {{ "name": "cut", "alphaMode": "MASK", "alphaCutoff": 0.3, "pbrMetallicRoughness": {{ "baseColorFactor": [1, 1, 1, 0.2] }} }},
    {{ "name": "kept", "alphaMode": "MASK", "pbrMetallicRoughness": {{ "baseColorFactor": [1, 1, 1, 0.9] }} }},
    {{ "name": "leaves", "alphaMode": "MASK", "alphaCutoff": 0.4,
       "pbrMetallicRoughness": {{ "baseColorTexture": {{ "index": 0 }} }} }},
    {{ "name": "glaze", "alphaMode": "BLEND", "pbrMetallicRoughness": {{ "baseColorFactor": [1, 1, 1, 0.4] }} }},
    {{ "name": "opaque", "alphaMode": "OPAQUE", "pbrMetallicRoughness": {{ "baseColorFactor": [1, 1, 1, 0.1] }} }} ],"#
    ));
    let path = write(&dir, "alpha.gltf", &json);
    let scene = load_gltf(&path, &GltfOptions::default()).expect("valid").scene;
    assert_eq!(scene.validate(), Ok(()));
    let material = |name: &str| scene.materials.iter().find(|m| m.name == name).expect(name);
    let top = |name: &str| &scene.bsdfs[material(name).bsdf.expect("model")];

    assert!(
        matches!(top("cut"), BsdfKind::Mask { opacity: Tex::Value(a), cutoff: Some(c), .. } if *a == 0.2 && *c == 0.3)
    );
    assert_eq!(material("cut").transparency, 1.0);
    assert!(matches!(top("kept"), BsdfKind::Principled(_)), "{:?}", top("kept"));
    let BsdfKind::Mask { opacity, cutoff: Some(c), .. } = top("leaves") else { panic!("{:?}", top("leaves")) };
    assert_eq!(*c, 0.4);
    let (alpha, _) = image_texture(&scene, opacity);
    assert_eq!((alpha.texels[0], alpha.texels[1]), (Rgb::ZERO, Rgb::ONE));
    assert!(matches!(top("glaze"), BsdfKind::Mask { opacity: Tex::Value(a), cutoff: None, .. } if *a == 0.4));
    let glaze = material("glaze");
    assert!((glaze.transparency - 0.6).abs() < 1e-6 && glaze.ior == 1.0);
    assert!(matches!(top("opaque"), BsdfKind::Principled(_)));
    assert_eq!(material("opaque").transparency, 0.0);
}

#[test]
fn transmission_and_ior_make_a_dielectric_principled() {
    let dir = TempDir::new("gltf-glass");
    let json = document(
        r#""nodes": [ { "mesh": 0 } ],
  "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume"],
  "materials": [
    { "name": "pane", "doubleSided": true, "pbrMetallicRoughness": { "metallicFactor": 0, "roughnessFactor": 0 },
      "extensions": { "KHR_materials_transmission": { "transmissionFactor": 0.9 }, "KHR_materials_ior": { "ior": 1.33 } } },
    { "name": "solid", "pbrMetallicRoughness": { "metallicFactor": 0 },
      "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1 },
                      "KHR_materials_volume": { "thicknessFactor": 0.5 } } },
    { "name": "tinted metal", "pbrMetallicRoughness": { "metallicFactor": 0.25 },
      "extensions": { "KHR_materials_transmission": { "transmissionFactor": 1 } } } ],"#,
    );
    let path = write(&dir, "glass.gltf", &json);
    let scene = load_gltf(&path, &GltfOptions::default()).expect("valid").scene;
    assert_eq!(scene.validate(), Ok(()));
    let material = |name: &str| scene.materials.iter().find(|m| m.name == name).expect(name);

    // Thin-walled (no volume), not wrapped in TwoSided although doubleSided.
    let pane = material("pane");
    let p = principled(&scene, pane.bsdf.expect("model"));
    assert_eq!((p.thin, p.spec_trans, p.eta), (true, Tex::Value(0.9), Some(1.33)));
    let f0 = (0.33f32 / 2.33).powi(2);
    assert!((p.specular - f0 / 0.08).abs() < 1e-6);
    assert!((pane.transparency - 0.9).abs() < 1e-6 && pane.ior == 1.33 && pane.reflection_f0.is_none());

    let p = principled(&scene, material("solid").bsdf.expect("model"));
    assert_eq!((p.thin, p.spec_trans), (false, Tex::Value(1.0)));

    // principledthin has no metallic: a blend of the thin dielectric and a metal.
    let BsdfKind::Blend { weight, a, b } = scene.bsdfs[material("tinted metal").bsdf.expect("model")] else {
        panic!("blend")
    };
    assert_eq!(weight, Tex::Value(0.25));
    assert!(principled(&scene, a).thin && principled(&scene, a).metallic == Tex::Value(0.0));
    assert_eq!(principled(&scene, b).metallic, Tex::Value(1.0));
}

#[test]
fn strips_and_fans_unroll_as_the_spec_says() {
    use geometry::tests_support::{fan, strip};
    assert_eq!(strip(&[0, 1, 2, 3]), vec![[0, 1, 2], [1, 3, 2]]);
    assert_eq!(fan(&[0, 1, 2, 3]), vec![[1, 2, 0], [2, 3, 0]]);
    let dir = TempDir::new("gltf-strip");
    let json = document(
        r#""nodes": [ { "mesh": 0 } ],
  "meshes": [ { "primitives": [ { "attributes": { "POSITION": 0 }, "mode": 6 } ] } ],"#,
    );
    let m = load(&write(&dir, "fan.gltf", &json)).expect("fan");
    // Vertices 0 (0,0) 1 (1,0) 2 (1,1) 3 (0,1) as a fan: both triangles face +Z.
    let mesh = &m.meshes[0];
    for t in 0..mesh.triangles.len() {
        let [a, b, c] = mesh.triangle(t);
        assert!((b - a).cross(c - a).z > 0.0, "triangle {t}");
    }
}

fn expect_error(dir: &TempDir, name: &str, json: &str, wanted: &[&str]) {
    let path = write(dir, name, json);
    let e = load_gltf(&path, &GltfOptions::default()).expect_err(name);
    let msg = e.to_string();
    assert!(msg.starts_with(&path.display().to_string()), "{msg}");
    for w in wanted {
        assert!(msg.contains(w), "{name}: `{w}` not in: {msg}");
    }
}

#[test]
fn bad_input_is_an_error_naming_file_and_element() {
    let dir = TempDir::new("gltf-bad");
    let nodes = format!(r#""nodes": [ {{ "mesh": 0 }} ], {MATTE}"#);
    let good = document(&nodes);
    // An accessor longer than its view.
    let json = good.replace(
        r#""componentType": 5126, "count": 4, "type": "VEC2""#,
        r#""componentType": 5126, "count": 40, "type": "VEC2""#,
    );
    expect_error(&dir, "accessor.gltf", &json, &["accessors[1]", "bufferViews[1]"]);
    // A view beyond its buffer.
    let json = good.replace(r#""byteOffset": 80, "byteLength": 12"#, r#""byteOffset": 88, "byteLength": 12"#);
    expect_error(&dir, "view.gltf", &json, &["bufferViews[2]", "buffers[0]"]);
    // A bad data URI.
    let json = good.replace("base64,", "base64,!!");
    expect_error(&dir, "uri.gltf", &json, &["buffers[0]", "base64"]);
    // A NaN position.
    let mut bin = quad_buffer();
    bin[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
    let json = good.replace(&encode_base64(&quad_buffer()), &encode_base64(&bin));
    expect_error(&dir, "nan.gltf", &json, &["meshes[0].primitives[0] vertex 1", "NaN"]);
    // A transform too large for f32.
    let json =
        good.replace(r#""nodes": [ { "mesh": 0 } ]"#, r#""nodes": [ { "mesh": 0, "translation": [1e39, 0, 0] } ]"#);
    expect_error(&dir, "inf.gltf", &json, &["nodes[0]", "not finite"]);
    // Lights: an impossible cone, an infinite intensity.
    let light = |l: &str| {
        good.replace(
            r#""nodes": [ { "mesh": 0 } ]"#,
            &format!(
                r#""nodes": [ {{ "mesh": 0, "extensions": {{ "KHR_lights_punctual": {{ "light": 0 }} }} }} ],
                "extensions": {{ "KHR_lights_punctual": {{ "lights": [ {l} ] }} }}"#
            ),
        )
    };
    let cone = light(r#"{ "type": "spot", "spot": { "innerConeAngle": 0.7, "outerConeAngle": 0.5 } }"#);
    expect_error(&dir, "cone.gltf", &cone, &["lights[0]", "nodes[0]", "innerConeAngle"]);
    let bright = light(r#"{ "type": "point", "intensity": 1e39 }"#);
    expect_error(&dir, "bright.gltf", &bright, &["lights[0]", "finite"]);
    // An image that is not one.
    let json = good.replace(
        MATTE,
        r#""images": [ { "uri": "data:image/png;base64,AAAA" } ], "textures": [ { "source": 0 } ],
           "materials": [ { "pbrMetallicRoughness": { "baseColorTexture": { "index": 0 } } } ],"#,
    );
    expect_error(&dir, "image.gltf", &json, &["images[0]", "decode"]);
    // A required extension glint does not read.
    let json = good.replace(MATTE, &format!(r#"{MATTE} "extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"],"#));
    expect_error(&dir, "draco.gltf", &json, &["extensionsRequired"]);
}

#[test]
fn a_missing_image_is_a_warning_naming_it() {
    let dir = TempDir::new("gltf-noimage");
    let json = document(
        r#""nodes": [ { "mesh": 0 } ], "images": [ { "uri": "gone.png" } ], "textures": [ { "source": 0 } ],
  "materials": [ { "pbrMetallicRoughness": { "baseColorFactor": [1, 0, 0, 1], "baseColorTexture": { "index": 0 } } } ],"#,
    );
    let path = write(&dir, "noimage.gltf", &json);
    let Loaded { scene, warnings } = load_gltf(&path, &GltfOptions::default()).expect("warning only");
    assert!(warnings.iter().any(|w| w.contains("gone.png") && w.contains("images[0]")), "{warnings:?}");
    let p = principled(&scene, scene.materials[0].bsdf.expect("model"));
    assert_eq!(p.base_color, Tex::Value(Rgb::new(1.0, 0.0, 0.0)));
}

#[test]
fn a_gltf_mesh_in_a_toml_scene_keeps_its_models() {
    let dir = TempDir::new("gltf-in-toml");
    write(
        &dir,
        "glass.gltf",
        &document(
            r#""nodes": [ { "mesh": 0 } ],
  "materials": [ { "doubleSided": true, "normalTexture": { "index": 0 } } ],
  "images": [ { "uri": "data:image/png;base64,PLACEHOLDER" } ], "textures": [ { "source": 0 } ],"#,
        )
        .replace("data:image/png;base64,PLACEHOLDER", &png_uri([[128, 128, 255, 255]; 4])),
    );
    let text = r#"
[camera]
position = [0, 0, 5]
look_at = [0, 0, 0]

[[material]]
name = "red"
colour = [0.8, 0.1, 0.1]

[[object]]
type = "sphere"
centre = [0, 0, 0]
radius = 1
material = "red"

[[object]]
type = "mesh"
path = "glass.gltf"
"#;
    let loaded = crate::load_scene_str(text, dir.path(), "test.toml").expect("valid");
    let s = &loaded.scene;
    assert_eq!(s.validate(), Ok(()));
    let m = s.materials.iter().find(|m| m.bsdf.is_some()).expect("the glTF material");
    let BsdfKind::TwoSided { front, .. } = s.bsdfs[m.bsdf.expect("model")] else { panic!("two-sided") };
    assert!(matches!(s.bsdfs[front], BsdfKind::NormalMap { normals, .. } if normals < s.textures.len()));
}

#[test]
fn real_gltf_files_in_shared_data_load_and_validate() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data");
    let mut found = Vec::new();
    let mut dirs = vec![root];
    while let Some(d) = dirs.pop() {
        let Ok(entries) = std::fs::read_dir(&d) else { continue };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                dirs.push(p);
            } else if p.extension().is_some_and(|x| x.eq_ignore_ascii_case("gltf") || x.eq_ignore_ascii_case("glb")) {
                found.push(p);
            }
        }
    }
    for p in &found {
        let loaded = load_gltf(p, &GltfOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(loaded.scene.validate(), Ok(()), "{}", p.display());
    }
    eprintln!("{} glTF files under shared/data", found.len());
}
