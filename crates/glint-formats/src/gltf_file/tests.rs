//! glTF tests on small files written by the test: .gltf with a .bin, .glb, data URIs, and
//! broken files.

use super::*;
use crate::test_util::TempDir;
use buffers::decode_base64;
use std::path::PathBuf;

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
