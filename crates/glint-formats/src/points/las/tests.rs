//! LAS/LAZ tests: small files written with the `las` crate (axes, recentring precision, colour
//! modes, LAZ), damaged copies of them, and the Autzen tile from ../shared/data when present.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use super::*;
use crate::points::colour::{class_colour, ramp};
use crate::points::read_point_cloud;
use crate::test_util::TempDir;
use ::las::point::{Classification, Format};
use ::las::{Builder, Color, Point, Transform, Vector, Writer};
use glint_core::colour::srgb_to_linear;

/// (x, y, z, classification, intensity, rgb) in LAS axes.
type Spec = (f64, f64, f64, u8, u16, [u16; 3]);

const POINTS: [Spec; 3] = [
    (500_000.00, 4_000_000.00, 100.00, 2, 100, [255, 0, 0]),
    (500_010.01, 4_000_020.02, 105.50, 5, 200, [0, 255, 0]),
    (500_020.03, 4_000_010.07, 110.00, 6, 0, [0, 0, 255]),
];

fn write(path: &Path, version: (u8, u8), format: u8, points: &[Spec]) {
    let mut b = Builder::from(version);
    b.point_format = Format::new(format).unwrap();
    let t = |offset| Transform { scale: 0.01, offset };
    b.transforms = Vector { x: t(500_000.0), y: t(4_000_000.0), z: t(0.0) };
    let mut w = Writer::from_path(path, b.into_header().unwrap()).unwrap();
    let f = Format::new(format).unwrap();
    for &(x, y, z, class, intensity, [r, g, bl]) in points {
        w.write_point(Point {
            x,
            y,
            z,
            intensity,
            classification: Classification::new(class).unwrap(),
            color: f.has_color.then(|| Color::new(r, g, bl)),
            gps_time: f.has_gps_time.then_some(0.0),
            ..Point::default()
        })
        .unwrap();
    }
    w.close().unwrap();
}

fn read(path: &Path, by: ColourBy) -> Result<PointCloud, FormatError> {
    read_point_cloud(path, &PointReadOptions { colour_by: by })
}

fn linear(c: Rgb) -> Rgb {
    Rgb::new(srgb_to_linear(c.x), srgb_to_linear(c.y), srgb_to_linear(c.z))
}

#[test]
fn axes_origin_and_centimetres() {
    let dir = TempDir::new("las-axes");
    for (version, format) in [((1, 2), 3), ((1, 4), 7), ((1, 0), 0)] {
        let path = dir.join(&format!("t{format}.las"));
        write(&path, version, format, &POINTS);
        let c = read(&path, ColourBy::Auto).unwrap();
        assert_eq!(c.name, format!("t{format}"));
        assert_eq!(c.len(), 3);
        assert_eq!(c.orientation, Orientation::Up(Vec3::Y));
        // The bounds' centre, in glint axes: (x, z, -y); the writer rounds the bounds outward
        // to its 0.01 grid.
        let want = DVec3::new(500_010.015, 105.0, -4_000_010.01);
        assert!((c.origin - want).abs().max_element() < 0.011, "{}", c.origin);
        for (&(x, y, z, ..), p) in POINTS.iter().zip(&c.positions) {
            let file = c.origin + p.as_dvec3();
            let back = DVec3::new(file.x, -file.z, file.y);
            assert!((back - DVec3::new(x, y, z)).abs().max_element() < 1e-4, "{back} vs {x} {y} {z}");
        }
        let d = c.positions[1] - c.positions[0];
        assert!((d - Vec3::new(10.01, 5.5, -20.02)).abs().max_element() < 1e-5, "{d}");
    }
}

#[test]
fn every_colour_mode() {
    let dir = TempDir::new("las-colour");
    let path = dir.join("c.las");
    write(&path, (1, 2), 3, &POINTS);
    let rgb = read(&path, ColourBy::Auto).unwrap().colours.unwrap();
    assert_eq!(rgb, vec![Rgb::X, Rgb::Y, Rgb::Z], "8-bit values in 16-bit fields");
    assert_eq!(read(&path, ColourBy::Rgb).unwrap().colours.unwrap(), rgb);
    let grey = read(&path, ColourBy::Intensity).unwrap().colours.unwrap();
    assert_eq!(grey, vec![Rgb::splat(srgb_to_linear(0.5)), Rgb::ONE, Rgb::ZERO]);
    let class = read(&path, ColourBy::Classification).unwrap().colours.unwrap();
    assert_eq!(class, [2, 5, 6].map(|k| linear(class_colour(k))).to_vec());
    let height = read(&path, ColourBy::Elevation).unwrap().colours.unwrap();
    assert_eq!(height[0], linear(ramp(0.0)));
    assert_eq!(height[2], linear(ramp(1.0)));

    // 16-bit colour.
    let deep = [(1.0, 2.0, 3.0, 1, 0, [65535, 32768, 0])];
    write(&path, (1, 2), 2, &deep);
    let c = read(&path, ColourBy::Auto).unwrap().colours.unwrap();
    assert!((c[0] - Rgb::new(1.0, srgb_to_linear(32768.0 / 65535.0), 0.0)).abs().max_element() < 1e-6);

    // No colour in the point format: Auto falls back to intensity, then to elevation.
    let path = dir.join("grey.las");
    write(&path, (1, 2), 1, &POINTS);
    assert_eq!(read(&path, ColourBy::Auto).unwrap().colours.unwrap(), grey);
    let e = read(&path, ColourBy::Rgb).unwrap_err().to_string();
    assert!(e.contains("grey.las: header (point format 1): cannot colour by RGB"), "{e}");
    let dark: Vec<Spec> = POINTS.iter().map(|&(x, y, z, k, _, c)| (x, y, z, k, 0, c)).collect();
    write(&path, (1, 2), 1, &dark);
    assert_eq!(read(&path, ColourBy::Auto).unwrap().colours.unwrap(), height);
}

#[test]
fn laz_reads_like_las() {
    let dir = TempDir::new("las-laz");
    let (las_path, laz_path) = (dir.join("a.las"), dir.join("a.LAZ"));
    write(&las_path, (1, 2), 3, &POINTS);
    write(&laz_path, (1, 2), 3, &POINTS);
    assert_ne!(std::fs::read(&las_path).unwrap(), std::fs::read(&laz_path).unwrap(), "compressed");
    let (a, b) = (read(&las_path, ColourBy::Auto).unwrap(), read(&laz_path, ColourBy::Auto).unwrap());
    assert_eq!((a.positions, a.colours, a.origin), (b.positions, b.colours, b.origin));
}

/// Overwrites `bytes` at `at` in the file.
fn patch(path: &Path, at: usize, bytes: &[u8]) {
    let mut data = std::fs::read(path).unwrap();
    data[at..at + bytes.len()].copy_from_slice(bytes);
    std::fs::write(path, data).unwrap();
}

#[test]
fn damaged_files_fail_cleanly_naming_the_file() {
    let dir = TempDir::new("las-damaged");
    let path = dir.join("d.las");
    let check = |want: &str| {
        let e = read(&path, ColourBy::Auto).unwrap_err().to_string();
        assert!(e.starts_with(&path.display().to_string()) && e.contains(want), "{want}: {e}");
    };
    // Truncated: the last point is cut.
    write(&path, (1, 2), 3, &POINTS);
    let data = std::fs::read(&path).unwrap();
    std::fs::write(&path, &data[..data.len() - 10]).unwrap();
    check("truncated");
    // An absurd legacy point count (byte 107), and an absurd 64-bit one (byte 247, LAS 1.4).
    write(&path, (1, 2), 3, &POINTS);
    patch(&path, 107, &0xffff_fff0u32.to_le_bytes());
    check("the header promises 4294967280 points of 34 bytes");
    patch(&path, 107, &50_000_000u32.to_le_bytes());
    check("the header promises 50000000 points");
    write(&path, (1, 4), 6, &POINTS);
    patch(&path, 107, &0u32.to_le_bytes());
    patch(&path, 247, &u64::MAX.to_le_bytes());
    check("points are more than glint can index");
    // An extended VLR beyond the end (start at byte 235, count at 243).
    write(&path, (1, 4), 6, &POINTS);
    let len = std::fs::metadata(&path).unwrap().len();
    patch(&path, 235, &(len - 30).to_le_bytes());
    patch(&path, 243, &1u32.to_le_bytes());
    check("extended VLR");
    // A NaN x offset (byte 155) would make every coordinate NaN.
    write(&path, (1, 2), 3, &POINTS);
    patch(&path, 155, &f64::NAN.to_le_bytes());
    check("header: x scale factor 0.01 and offset NaN");
    // A zero scale (byte 139: y) would put every point at the offset: a cloud of one point
    // that took 40 s to estimate normals for (issue 20, defect 5).
    write(&path, (1, 2), 3, &POINTS);
    patch(&path, 139, &0f64.to_le_bytes());
    check("header: y scale factor 0 and offset");
    // Not a LAS file at all.
    std::fs::write(&path, b"ply\nformat ascii 1.0\n").unwrap();
    check("header");
    std::fs::write(&path, b"LASF").unwrap();
    check("header: the file ends early");
}

#[test]
fn the_autzen_tile_reads() {
    let p = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/pointclouds/autzen_trim.las"));
    if !p.exists() {
        eprintln!("skipped: {} is not there", p.display());
        return;
    }
    let c = read(p, ColourBy::Auto).unwrap();
    assert_eq!(c.len(), 110_000);
    assert_eq!(c.name, "autzen_trim");
    let e = c.bounds().extent();
    assert!(e.max_element() < 5000.0 && e.min_element() > 1.0, "recentred to the tile: {e}");
    assert!(e.y * 3.0 < e.x.min(e.z), "flat along +Y (up): {e}");
    let centre = c.bounds().centre();
    assert!(centre.abs().max_element() < e.max_element(), "centred: {centre}");
    assert!(c.origin.length() > 1e5, "geo-referenced origin kept: {}", c.origin);
    let colours = c.colours.unwrap();
    assert!(colours.iter().all(|k| k.min_element() >= 0.0 && k.max_element() <= 1.0));
    assert!(colours.iter().any(|k| k.max_element() > 0.1), "RGB is used");
    let class = read(p, ColourBy::Classification).unwrap();
    assert!(class.colours.is_some());
}
