//! OBJ tests: geometry, welding, materials, and broken files rejected at their line.

use super::*;
use crate::test_util::TempDir;

fn parse_str(text: &str) -> Result<Model, FormatError> {
    parse(Path::new("t.obj"), text.as_bytes())
}

fn error(text: &str) -> String {
    match parse_str(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e.to_string(),
    }
}

const QUAD: &str = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\n";

#[test]
fn a_quad_becomes_two_triangles_sharing_vertices() {
    let m = parse_str(&format!("{QUAD}f 1 2 3 4\n")).expect("valid");
    let mesh = &m.meshes[0];
    assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3]]);
    assert_eq!(mesh.positions.len(), 4);
    assert!(mesh.normals.is_none() && mesh.uvs.is_none() && mesh.triangle_materials.is_none());
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
}

#[test]
fn negative_indices_and_attributes_are_read() {
    let text = format!("{QUAD}vt 0 0\nvt 1 0\nvt 1 1\nvn 0 0 2\nf -4/-3/-1 -3/-2/-1 -2/-1/-1\nf 1//1 3//1 4//1\n");
    let m = parse_str(&text).expect("valid");
    let mesh = &m.meshes[0];
    assert_eq!(mesh.triangles.len(), 2);
    // Corners differ in their uv, so 3 + 3 welded vertices... the second face has no uvs.
    assert_eq!(mesh.positions.len(), 6);
    assert_eq!(mesh.normals.as_ref().map(|n| n[0]), Some(Vec3::Z));
    assert_eq!(mesh.uvs.as_ref().map(|u| u[2]), Some(Vec2::new(1.0, 1.0)));
}

#[test]
fn corners_without_normals_get_face_normals_when_others_have_them() {
    let text = format!("{QUAD}vn 0 0 1\nf 1//1 2//1 3//1\nf 1 3 4\n");
    let mesh = &parse_str(&text).expect("valid").meshes[0];
    let normals = mesh.normals.as_ref().expect("normals");
    assert!(normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6), "{normals:?}");
}

#[test]
fn line_continuation_and_comments_and_crlf() {
    let text = "# hi\r\nv 0 0 0\r\nv 1 0 \\\r\n 0\r\nv 0 1 0\r\n\r\n  # indented comment\r\nf 1 2 3\r\n";
    let mesh = &parse_str(text).expect("valid").meshes[0];
    assert_eq!(mesh.positions[1], Vec3::X);
}

#[test]
fn garbage_line_is_an_error_with_its_line() {
    let msg = error(&format!("{QUAD}f 1 2 3\n@@@ garbage\n"));
    assert!(msg.starts_with("t.obj: line 6:"), "{msg}");
    assert!(msg.contains("@@@"), "{msg}");
}

#[test]
fn truncated_vertex_is_an_error() {
    let msg = error("v 0 0 0\nv 1 0");
    assert!(msg.starts_with("t.obj: line 2:") && msg.contains("3 coordinates"), "{msg}");
    let msg = error(&format!("{QUAD}f 1 2"));
    assert!(msg.starts_with("t.obj: line 5:") && msg.contains("3 corners"), "{msg}");
}

#[test]
fn non_numeric_coordinate_is_an_error() {
    let msg = error("v 0 0 0\nv 1 2 abc\n");
    assert!(msg.starts_with("t.obj: line 2:") && msg.contains("abc"), "{msg}");
}

#[test]
fn face_index_out_of_range_is_an_error() {
    let msg = error(&format!("{QUAD}f 1 2 5\n"));
    assert!(msg.starts_with("t.obj: line 5:") && msg.contains("1..=4"), "{msg}");
    assert!(error(&format!("{QUAD}f 0 1 2\n")).contains("line 5"));
    assert!(error(&format!("{QUAD}f -5 1 2\n")).contains("line 5"));
    assert!(error(&format!("{QUAD}f 1/1 2/1 3/1\n")).contains("texture"));
}

#[test]
fn nan_vertex_is_an_error() {
    let msg = error("v 0 0 0\nv nan 0 0\n");
    assert!(msg.starts_with("t.obj: line 2:") && msg.contains("finite"), "{msg}");
    assert!(error("v 0 inf 0\n").contains("line 1"));
}

#[test]
fn usemtl_without_library_warns_and_uses_the_default() {
    let m = parse_str(&format!("{QUAD}f 1 2 3\nusemtl shiny\nf 1 3 4\n")).expect("valid");
    let mesh = &m.meshes[0];
    assert_eq!(mesh.triangle_materials, Some(vec![0, 0]));
    assert_eq!(m.materials, vec![Material::default()]);
    assert!(m.warnings.iter().any(|w| w.contains("shiny")), "{:?}", m.warnings);
}

#[test]
fn missing_mtl_is_a_warning() {
    let m = parse_str(&format!("mtllib none.mtl\n{QUAD}usemtl a\nf 1 2 3\n")).expect("valid");
    assert!(m.warnings.iter().any(|w| w.contains("none.mtl") && w.starts_with("t.obj:1:")), "{:?}", m.warnings);
}

#[test]
fn materials_and_textures_come_from_the_library() {
    let dir = TempDir::new("obj-mtl");
    image::RgbImage::from_pixel(2, 2, image::Rgb([255, 255, 255])).save(dir.join("wood.png")).expect("png");
    std::fs::write(dir.join("m.mtl"), "newmtl red\nKd 1 0 0\nnewmtl wood\nKd 1 1 1\nmap_Kd -s 2 2 wood.png\n")
        .expect("mtl");
    let obj = format!("mtllib m.mtl\n{QUAD}vt 0 0\nf 1/1 2/1 3/1\nusemtl wood\nf 1 3 4\nusemtl red\nf 1 2 4\n");
    std::fs::write(dir.join("m.obj"), obj).expect("obj");
    let m = load(&dir.join("m.obj")).expect("valid");
    let mesh = &m.meshes[0];
    // Material 2 is the default (for the face before any usemtl).
    assert_eq!(mesh.triangle_materials, Some(vec![2, 1, 0]));
    assert_eq!(m.materials[0].colour, Vec3::X);
    assert_eq!(m.materials[1].texture, Some(0));
    assert_eq!(m.textures.len(), 1);
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let loaded = crate::load(&dir.join("m.obj")).expect("scene");
    assert_eq!(loaded.scene.validate(), Ok(()));
}

#[test]
fn zero_area_triangles_are_dropped_and_all_degenerate_is_rejected() {
    let dir = TempDir::new("obj-degenerate");
    let path = dir.join("d.obj");
    std::fs::write(&path, format!("{QUAD}f 1 2 3\nf 1 1 2\n")).expect("write");
    let m = load(&path).expect("one good triangle");
    assert_eq!(m.meshes[0].triangles.len(), 1);
    assert_eq!(m.warnings, vec!["d.obj: dropped 1 zero-area triangles (mesh 'd')".to_string()]);
    std::fs::write(&path, format!("{QUAD}f 1 1 2\nf 1 2 2\n")).expect("write");
    let e = load(&path).expect_err("all degenerate");
    assert!(e.to_string().starts_with(&path.display().to_string()), "{e}");
}

#[test]
fn file_without_faces_is_an_error() {
    let dir = TempDir::new("obj-empty");
    let path = dir.join("e.obj");
    std::fs::write(&path, QUAD).expect("write");
    let e = load(&path).expect_err("no faces");
    assert!(e.to_string().contains("no triangles"), "{e}");
}
