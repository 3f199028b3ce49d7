//! PLY cloud tests: the three encodings, attribute names and types, recentring, colour modes,
//! and every kind of broken file.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use super::*;
use crate::ply::PlyFormat;
use crate::points::ColourBy;
use crate::test_util::TempDir;
use glint_core::colour::srgb_to_linear;

/// A PLY whose vertex element has `props` (type, name) and one row of values per vertex,
/// followed by `faces` empty faces.
fn ply(format: PlyFormat, props: &[(&str, &str)], rows: &[Vec<f64>], faces: usize) -> Vec<u8> {
    let name = match format {
        PlyFormat::Ascii => "ascii",
        PlyFormat::BinaryLittleEndian => "binary_little_endian",
        PlyFormat::BinaryBigEndian => "binary_big_endian",
    };
    let mut out = format!("ply\nformat {name} 1.0\ncomment test\nelement vertex {}\n", rows.len());
    for (ty, p) in props {
        out += &format!("property {ty} {p}\n");
    }
    out += &format!("element face {faces}\nproperty list uchar int vertex_indices\nend_header\n");
    let mut out = out.into_bytes();
    let big = format == PlyFormat::BinaryBigEndian;
    for row in rows {
        if format == PlyFormat::Ascii {
            let words: Vec<String> = row.iter().map(|v| v.to_string()).collect();
            out.extend(format!("{}\n", words.join(" ")).bytes());
            continue;
        }
        for ((ty, _), &v) in props.iter().zip(row) {
            let le: Vec<u8> = match *ty {
                "uchar" => vec![v as u8],
                "ushort" => (v as u16).to_le_bytes().to_vec(),
                "int" => (v as i32).to_le_bytes().to_vec(),
                "float" => (v as f32).to_le_bytes().to_vec(),
                "double" => v.to_le_bytes().to_vec(),
                _ => unreachable!("{ty}"),
            };
            out.extend(if big { le.into_iter().rev().collect::<Vec<_>>() } else { le });
        }
    }
    out.extend(std::iter::repeat_n(0u8, if format == PlyFormat::Ascii { 0 } else { faces }));
    if format == PlyFormat::Ascii {
        out.extend("0\n".repeat(faces).bytes());
    }
    out
}

fn parse(bytes: &[u8], by: ColourBy) -> Result<PointCloud, FormatError> {
    parse_ply_cloud(Path::new("c.ply"), bytes, &PointReadOptions { colour_by: by })
}

const FORMATS: [PlyFormat; 3] = [PlyFormat::Ascii, PlyFormat::BinaryLittleEndian, PlyFormat::BinaryBigEndian];

#[test]
fn every_encoding_reads_the_same_cloud() {
    let props = [
        ("double", "x"),
        ("float", "y"),
        ("float", "z"),
        ("float", "nx"),
        ("float", "ny"),
        ("float", "nz"),
        ("float", "radius"),
        ("uchar", "red"),
        ("uchar", "green"),
        ("uchar", "blue"),
        ("uchar", "alpha"),
    ];
    let rows = vec![
        vec![0.5, 1.0, -2.0, 0.0, 0.0, 2.0, 0.25, 255.0, 128.0, 0.0, 7.0],
        vec![-1.5, 0.0, 3.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 7.0],
    ];
    let mut first = None;
    for format in FORMATS {
        let c = parse(&ply(format, &props, &rows, 0), ColourBy::Auto).unwrap();
        assert_eq!(c.name, "c");
        assert_eq!(c.positions, vec![Vec3::new(0.5, 1.0, -2.0), Vec3::new(-1.5, 0.0, 3.0)]);
        assert_eq!(c.origin, DVec3::ZERO);
        assert_eq!(c.normals.as_ref().unwrap(), &vec![Vec3::Z, Vec3::ZERO], "normalised, zero kept");
        assert_eq!(c.orientation, Orientation::Oriented);
        assert_eq!(c.radii.as_ref().unwrap(), &vec![0.25, 0.5]);
        let k = c.colours.as_ref().unwrap();
        assert_eq!(k[0], Rgb::new(1.0, srgb_to_linear(128.0 / 255.0), 0.0));
        assert_eq!(k[1], Rgb::ZERO);
        if let Some(f) = &first {
            assert_eq!(f, &c, "{format:?}");
        }
        first = Some(c);
    }
}

#[test]
fn attribute_names_and_colour_types() {
    let rows = vec![vec![0.0, 0.0, 0.0, 65535.0, 0.0, 0.0, 0.1], vec![1.0, 0.0, 0.0, 0.0, 32768.0, 0.0, 0.2]];
    let props = [
        ("float", "x"),
        ("float", "y"),
        ("float", "z"),
        ("ushort", "diffuse_red"),
        ("ushort", "diffuse_green"),
        ("ushort", "diffuse_blue"),
        ("float", "Scale"),
    ];
    let c = parse(&ply(PlyFormat::BinaryLittleEndian, &props, &rows, 0), ColourBy::Rgb).unwrap();
    let k = c.colours.unwrap();
    assert_eq!(k[0], Rgb::X);
    assert!((k[1].y - srgb_to_linear(32768.0 / 65535.0)).abs() < 1e-6);
    assert_eq!(c.radii.unwrap(), vec![0.1, 0.2]);
    assert!(c.normals.is_none() && c.orientation == Orientation::Unknown);
    // Float colours in [0, 1] are taken as they are.
    let props = [("float", "x"), ("float", "y"), ("float", "z"), ("float", "r"), ("float", "g"), ("float", "b")];
    let rows = vec![vec![0.0, 0.0, 0.0, 0.5, 0.5, 0.5]];
    let c = parse(&ply(PlyFormat::Ascii, &props, &rows, 0), ColourBy::Auto).unwrap();
    assert!(c.colours.is_none(), "r g b are not colour names");
    let props =
        [("float", "x"), ("float", "y"), ("float", "z"), ("float", "red"), ("float", "green"), ("float", "blue")];
    let c = parse(&ply(PlyFormat::Ascii, &props, &rows, 0), ColourBy::Auto).unwrap();
    assert_eq!(c.colours.unwrap()[0], Rgb::splat(srgb_to_linear(0.5)));
}

#[test]
fn large_double_coordinates_are_recentred_precisely() {
    let props = [("double", "x"), ("double", "y"), ("double", "z")];
    let rows = vec![vec![500_000.01, 4_000_000.02, 10.0], vec![500_100.03, 4_000_050.04, 30.0]];
    let c = parse(&ply(PlyFormat::BinaryBigEndian, &props, &rows, 0), ColourBy::Auto).unwrap();
    assert!((c.origin - DVec3::new(500_050.02, 4_000_025.03, 20.0)).abs().max_element() < 1e-9);
    for (row, p) in rows.iter().zip(&c.positions) {
        let back = c.origin + p.as_dvec3();
        assert!((back - DVec3::new(row[0], row[1], row[2])).abs().max_element() < 1e-4, "{back}");
    }
}

#[test]
fn colour_modes_need_their_attribute() {
    let props =
        [("float", "x"), ("float", "y"), ("float", "z"), ("ushort", "scalar_Intensity"), ("uchar", "classification")];
    let rows = vec![vec![0.0, 0.0, 0.0, 100.0, 2.0], vec![0.0, 1.0, 0.0, 0.0, 6.0]];
    let bytes = ply(PlyFormat::Ascii, &props, &rows, 0);
    let c = parse(&bytes, ColourBy::Auto).unwrap();
    assert_eq!(c.colours.unwrap(), vec![Rgb::ONE, Rgb::ZERO], "Auto falls back to intensity");
    let c = parse(&bytes, ColourBy::Classification).unwrap().colours.unwrap();
    assert_eq!(c[0], Rgb::from(class_linear(2)));
    assert!(parse(&bytes, ColourBy::Elevation).unwrap().colours.is_some());
    let e = parse(&bytes, ColourBy::Rgb).unwrap_err().to_string();
    assert!(e.starts_with("c.ply: header: cannot colour by RGB"), "{e}");
    let bare = ply(PlyFormat::Ascii, &props[..3], &[vec![0.0, 0.0, 0.0]], 0);
    assert!(parse(&bare, ColourBy::Auto).unwrap().colours.is_none());
    for by in [ColourBy::Intensity, ColourBy::Classification] {
        let e = parse(&bare, by).unwrap_err().to_string();
        assert!(e.starts_with("c.ply: header: cannot colour by"), "{e}");
    }
}

fn class_linear(c: u8) -> Rgb {
    let k = crate::points::colour::class_colour(c);
    Rgb::new(srgb_to_linear(k.x), srgb_to_linear(k.y), srgb_to_linear(k.z))
}

#[test]
fn broken_files_name_the_file_and_the_place() {
    let xyz = [("float", "x"), ("float", "y"), ("float", "z")];
    let good = ply(PlyFormat::BinaryLittleEndian, &xyz, &[vec![0.0; 3], vec![1.0; 3]], 0);
    let truncated = &good[..good.len() - 5];
    let absurd = String::from_utf8_lossy(&good).replace("element vertex 2", "element vertex 99999999999").into_bytes();
    let nan = ply(PlyFormat::Ascii, &xyz, &[vec![0.0; 3], vec![1.0, f64::NAN, 0.0]], 0);
    let no_x = ply(PlyFormat::Ascii, &xyz[1..], &[vec![0.0; 2]], 0);
    let inf_radius =
        ply(PlyFormat::Ascii, &[xyz[0], xyz[1], xyz[2], ("float", "size")], &[vec![0.0, 0.0, 0.0, f64::INFINITY]], 0);
    let zero_radius = ply(PlyFormat::Ascii, &[xyz[0], xyz[1], xyz[2], ("float", "size")], &[vec![0.0; 4]], 0);
    let bad_origin = String::from_utf8_lossy(&good).replace("comment test", "comment origin 1 2").into_bytes();
    let cases: [(&[u8], &str); 7] = [
        (truncated, "vertex 1 (byte"),
        (&absurd, "absurd"),
        (&nan, "vertex 1: a coordinate is NaN"),
        (&no_x, "header: element 'vertex' has no property 'x'"),
        (&inf_radius, "vertex 0: 'size' is NaN"),
        (&zero_radius, "radius 0"),
        (&bad_origin, "header: `comment origin 1 2`"),
    ];
    for (bytes, want) in cases {
        let e = parse(bytes, ColourBy::Auto).unwrap_err().to_string();
        assert!(e.starts_with("c.ply: ") && e.contains(want), "{want}: {e}");
    }
}

#[test]
fn clouds_are_told_from_meshes() {
    let dir = TempDir::new("ply-is-cloud");
    let xyz = [("float", "x"), ("float", "y"), ("float", "z")];
    for (faces, cloud) in [(0, true), (2, false)] {
        let path = dir.join(&format!("f{faces}.ply"));
        std::fs::write(&path, ply(PlyFormat::BinaryLittleEndian, &xyz, &[vec![0.0; 3]], faces)).unwrap();
        assert_eq!(ply_is_point_cloud(&path).unwrap(), cloud, "{faces} faces");
    }
    let path = dir.join("v.ply");
    std::fs::write(&path, "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n1\n").unwrap();
    assert!(ply_is_point_cloud(&path).unwrap());
    std::fs::write(&path, "ply\nformat ascii 1.0\nelement face 0\nend_header\n").unwrap();
    assert!(!ply_is_point_cloud(&path).unwrap());
    std::fs::write(&path, "not a ply").unwrap();
    assert!(ply_is_point_cloud(&path).unwrap_err().to_string().contains("v.ply"));
}
