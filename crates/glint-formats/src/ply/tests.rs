//! PLY tests: round trips through all three encodings, and every kind of broken file.

use super::*;
use crate::test_util::TempDir;
use std::time::Instant;

/// A unit cube: 8 shared vertices, 6 quads (split into 12 triangles on reading).
fn cube() -> (Vec<Vec3>, Vec<Vec<u32>>) {
    let p = (0..8).map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)).collect();
    let quads = vec![
        vec![0, 2, 3, 1],
        vec![4, 5, 7, 6],
        vec![0, 1, 5, 4],
        vec![2, 6, 7, 3],
        vec![0, 4, 6, 2],
        vec![1, 3, 7, 5],
    ];
    (p, quads)
}

/// Writes a PLY with extra properties and elements the mesh reader must skip.
fn write_ply(format: PlyFormat, positions: &[Vec3], faces: &[Vec<u32>]) -> Vec<u8> {
    let name = match format {
        PlyFormat::Ascii => "ascii",
        PlyFormat::BinaryLittleEndian => "binary_little_endian",
        PlyFormat::BinaryBigEndian => "binary_big_endian",
    };
    let mut out = format!(
        "ply\nformat {name} 1.0\ncomment test\nelement vertex {}\nproperty float x\nproperty uchar red\n\
         property double y\nproperty float z\nproperty list uchar int junk\nelement face {}\n\
         property int flags\nproperty list uchar ushort vertex_indices\nelement extra 2\nproperty list int float w\n\
         property short k\nend_header\n",
        positions.len(),
        faces.len()
    )
    .into_bytes();
    let big = format == PlyFormat::BinaryBigEndian;
    fn put<const N: usize>(out: &mut Vec<u8>, le: [u8; N], big: bool) {
        if big {
            out.extend(le.iter().rev());
        } else {
            out.extend(le);
        }
    }
    for p in positions {
        if format == PlyFormat::Ascii {
            out.extend(format!("{} 200 {} {} 2 7 8\n", p.x, p.y, p.z).bytes());
        } else {
            put(&mut out, p.x.to_le_bytes(), big);
            out.push(200);
            put(&mut out, (p.y as f64).to_le_bytes(), big);
            put(&mut out, p.z.to_le_bytes(), big);
            out.push(2);
            put(&mut out, 7i32.to_le_bytes(), big);
            put(&mut out, 8i32.to_le_bytes(), big);
        }
    }
    for f in faces {
        if format == PlyFormat::Ascii {
            let idx: Vec<String> = f.iter().map(|i| i.to_string()).collect();
            out.extend(format!("-1 {} {}\n", f.len(), idx.join(" ")).bytes());
        } else {
            put(&mut out, (-1i32).to_le_bytes(), big);
            out.push(f.len() as u8);
            for &i in f {
                put(&mut out, (i as u16).to_le_bytes(), big);
            }
        }
    }
    for _ in 0..2 {
        if format == PlyFormat::Ascii {
            out.extend(b"1 0.5 3\n");
        } else {
            put(&mut out, 1i32.to_le_bytes(), big);
            put(&mut out, 0.5f32.to_le_bytes(), big);
            put(&mut out, 3i16.to_le_bytes(), big);
        }
    }
    out
}

fn mesh_of(bytes: &[u8]) -> Result<(Mesh, Vec<String>), FormatError> {
    let path = Path::new("test.ply");
    let data = parse_ply(path, bytes, &mesh_and_attribute_selection)?;
    let mut warnings = Vec::new();
    let mesh = mesh_from_ply(path, &data, &mut warnings)?;
    Ok((mesh, warnings))
}

fn expect_err(bytes: &[u8]) -> String {
    match mesh_of(bytes) {
        Ok(_) => panic!("expected an error"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn round_trip_in_every_encoding() {
    let (positions, quads) = cube();
    for format in [PlyFormat::Ascii, PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian] {
        let (mesh, warnings) = mesh_of(&write_ply(format, &positions, &quads)).expect("valid");
        assert!(warnings.is_empty(), "{warnings:?}");
        assert_eq!(mesh.positions, positions, "{format:?}");
        assert_eq!(mesh.triangles.len(), 12);
        assert_eq!(&mesh.triangles[..2], &[[0, 2, 3], [0, 3, 1]]);
        assert!(mesh.normals.is_none() && mesh.uvs.is_none());
    }
}

#[test]
fn load_from_disk_computes_normals() {
    let dir = TempDir::new("ply-load");
    let (positions, quads) = cube();
    let path = dir.join("cube.PLY");
    std::fs::write(&path, write_ply(PlyFormat::BinaryLittleEndian, &positions, &quads)).expect("write");
    let loaded = crate::load(&path).expect("valid model");
    assert_eq!(loaded.scene.meshes[0].triangles.len(), 12);
    assert!(loaded.scene.meshes[0].normals.is_some());
    assert_eq!(loaded.scene.validate(), Ok(()));
}

#[test]
fn normals_and_uvs_are_read() {
    let text = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                property float nx\nproperty float ny\nproperty float nz\nproperty float s\nproperty float t\n\
                element face 1\nproperty list uchar uint vertex_index\nend_header\n\
                0 0 0 0 0 2 0 0\n1 0 0 0 0 1 1 0\n0 1 0 0 0 1 0 1\n3 0 1 2\n";
    let (mesh, _) = mesh_of(text.as_bytes()).expect("valid");
    assert_eq!(mesh.normals, Some(vec![Vec3::Z; 3]));
    assert_eq!(mesh.uvs.as_ref().map(|u| u[2]), Some(Vec2::new(0.0, 1.0)));
}

#[test]
fn general_reader_returns_named_columns() {
    let text = "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty uchar red\n\
                property float intensity\nproperty float y\nproperty float z\nend_header\n\
                123456789.25 255 0.5 0 0\n-1 0 1.5 0 0\n";
    let data = parse_ply(Path::new("cloud.ply"), text.as_bytes(), &|_, _| true).expect("valid");
    let v = data.element("vertex").expect("vertex");
    assert_eq!(v.column("x"), Some(&Column::Double(vec![123456789.25, -1.0])));
    assert_eq!(v.column("red"), Some(&Column::Float(vec![255.0, 0.0])));
    assert_eq!(v.column("intensity").and_then(Column::to_f32), Some(vec![0.5, 1.5]));
    let e = mesh_of(text.as_bytes()).expect_err("not a mesh");
    assert!(e.to_string().contains("point cloud"), "{e}");
}

#[test]
fn truncated_ascii_names_the_line() {
    let (positions, quads) = cube();
    let full = write_ply(PlyFormat::Ascii, &positions, &quads);
    let text = String::from_utf8(full).expect("ascii");
    let cut = &text[..text.find("0 1 1 2").map_or(text.len() / 2, |i| i + 3)];
    let msg = expect_err(cut.as_bytes());
    assert!(msg.starts_with("test.ply: line "), "{msg}");
    assert!(msg.contains("truncated"), "{msg}");
}

#[test]
fn truncated_binary_names_the_row_and_byte() {
    let (positions, quads) = cube();
    let full = write_ply(PlyFormat::BinaryLittleEndian, &positions, &quads);
    let msg = expect_err(&full[..full.len() - 40]);
    assert!(msg.contains("byte"), "{msg}");
    assert!(msg.starts_with("test.ply: face "), "{msg}");
    let header_end = full.windows(11).position(|w| w == b"end_header\n").expect("header") + 11;
    let msg = expect_err(&full[..header_end + 30]);
    assert!(msg.starts_with("test.ply: vertex 1 (byte"), "{msg}");
}

#[test]
fn absurd_vertex_count_fails_fast_without_allocating() {
    let text = "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\n\
                property float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\n\
                end_header\n";
    let start = Instant::now();
    let err = mesh_of(text.as_bytes()).expect_err("absurd");
    assert!(matches!(err, FormatError::Limits { .. }), "{err}");
    assert!(err.to_string().contains("1000000000000"), "{err}");
    assert!(start.elapsed().as_millis() < 100);
}

#[test]
fn bad_format_line_is_an_error() {
    let msg = expect_err(b"ply\nformat binary 1.0\nelement vertex 0\nend_header\n");
    assert!(msg.starts_with("test.ply: header line 2"), "{msg}");
}

#[test]
fn absurd_list_count_is_an_error() {
    let mut data = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                     property float z\nelement face 1\nproperty list uint int vertex_indices\nend_header\n"
        .to_vec();
    data.extend(std::iter::repeat_n(0u8, 36));
    data.extend(u32::MAX.to_le_bytes());
    data.extend([0u8; 12]);
    let msg = expect_err(&data);
    assert!(msg.starts_with("test.ply: face 0 (byte"), "{msg}");
    assert!(msg.contains("4294967295"), "{msg}");
}

#[test]
fn face_index_out_of_range_is_an_error() {
    let (positions, mut quads) = cube();
    quads[3][1] = 8;
    let msg = expect_err(&write_ply(PlyFormat::Ascii, &positions, &quads));
    assert!(msg.starts_with("test.ply: face 3"), "{msg}");
}

#[test]
fn nan_vertex_is_an_error() {
    let (mut positions, quads) = cube();
    positions[5].y = f32::NAN;
    for format in [PlyFormat::Ascii, PlyFormat::BinaryBigEndian] {
        let msg = expect_err(&write_ply(format, &positions, &quads));
        assert!(msg.starts_with("test.ply: vertex 5"), "{msg}");
    }
}

#[test]
fn garbage_value_is_an_error() {
    let (positions, quads) = cube();
    let text = String::from_utf8(write_ply(PlyFormat::Ascii, &positions, &quads)).expect("ascii");
    let text = text.replacen("0 200 0 0", "0 200 zero 0", 1);
    let msg = expect_err(text.as_bytes());
    assert!(msg.contains("`zero` is not a number"), "{msg}");
    assert!(msg.starts_with("test.ply: line 17 (vertex 0)"), "{msg}");
}

#[test]
fn zero_area_triangles_are_dropped_and_all_degenerate_is_rejected() {
    let dir = TempDir::new("ply-degenerate");
    let (positions, mut quads) = cube();
    quads.push(vec![0, 0, 1]);
    let path = dir.join("d.ply");
    std::fs::write(&path, write_ply(PlyFormat::Ascii, &positions, &quads)).expect("write");
    let model = load(&path).expect("valid");
    assert_eq!(model.meshes[0].triangles.len(), 12);
    assert_eq!(model.warnings, vec!["d.ply: dropped 1 zero-area triangles (mesh 'd')".to_string()]);
    std::fs::write(&path, write_ply(PlyFormat::Ascii, &positions, &[vec![0, 1, 1], vec![2, 2, 2]])).expect("write");
    let err = load(&path).expect_err("degenerate");
    assert!(err.to_string().contains("zero area"), "{err}");
}

/// Mitsuba's mesh attributes: `r g b` / `red green blue` are `color`, `<name>_<k>` channel k
/// of `<name>`; per-face values follow a polygon onto each of its triangles; a two-channel
/// attribute is skipped with a warning.
#[test]
fn vertex_and_face_attributes_are_read_as_mitsuba_names_them() {
    let text = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
                property float red\nproperty float green\nproperty float blue\nproperty float weight_0\n\
                property float uv_0\nproperty float uv_1\n\
                element face 2\nproperty list uchar int vertex_indices\nproperty float r\nproperty float g\nproperty float b\n\
                end_header\n\
                0 0 0 1 0 0 0.5 0 0\n1 0 0 0 1 0 1 0 0\n1 1 0 0 0 1 2 0 0\n0 1 0 0.2 0.2 0.2 4 0 0\n\
                4 0 1 2 3 0.1 0.2 0.3\n3 0 1 3 0.9 0.8 0.7\n";
    let (mesh, warnings) = mesh_of(text.as_bytes()).expect("valid");
    let names: Vec<&str> = mesh.attributes.iter().map(|a| a.name.as_str()).collect();
    assert_eq!(names, ["vertex_color", "vertex_weight", "face_color"]);
    assert_eq!(mesh.attributes[0].values[1], Rgb::new(0.0, 1.0, 0.0));
    assert_eq!(mesh.attributes[1].values[3], Rgb::splat(4.0));
    // The quad's two triangles, then the triangle.
    let face = &mesh.attributes[2].values;
    assert_eq!(face, &[Rgb::new(0.1, 0.2, 0.3), Rgb::new(0.1, 0.2, 0.3), Rgb::new(0.9, 0.8, 0.7)]);
    assert_eq!(mesh.triangles.len(), 3);
    assert!(warnings.iter().any(|w| w.contains("vertex_uv") && w.contains("neither 1 nor 3")), "{warnings:?}");
    // Mid-edge of the first triangle's first two corners.
    assert_eq!(mesh.attribute_at("vertex_color", 0, 0.5, 0.0), Some(Rgb::new(0.5, 0.5, 0.0)));
    assert_eq!(mesh.attribute_at("face_color", 2, 0.3, 0.3), Some(Rgb::new(0.9, 0.8, 0.7)));
}
