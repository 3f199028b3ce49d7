//! XYZ text point clouds (.xyz, .txt, .pts): one point per line, `x y z`, optionally followed
//! by an intensity, a normal `nx ny nz` and/or a colour `r g b`, separated by spaces, tabs or
//! commas.
//!
//! - 3 columns: positions; 4: + intensity; 7: + intensity + colour (Leica PTS);
//!   9: + normal + colour.
//! - 6 columns are ambiguous: the extra triple is a normal when every row's triple has unit
//!   length (within 2 %, or is zero), otherwise a colour.
//! - Colours are 0–255 when any component exceeds 1, else 0–1; either way they are sRGB-encoded
//!   and become linear. [`ColourBy`](super::ColourBy) picks colour or intensity.
//! - Coordinates are read as f64 and recentred by the shared rule ([`super::recentre`]).
//! - Blank lines and lines starting with `#` or `//` are skipped; in a `.pts` file, a first line
//!   holding only a point count is skipped too. Every other line must have the same number of
//!   columns as the first. A NaN or infinite value, a stray word, or a file with no point is an
//!   error naming the line.

use super::colour::{ColourSources, PointReadOptions, colours};
use super::recentre::recentre;
use crate::FormatError;
use glint_core::glam::DVec3;
use glint_core::{Rgb, Vec3};
use glint_scene::{Orientation, PointCloud};
use std::path::Path;

/// Reads an XYZ file (positions and what it has; colour when it has one).
pub fn read_xyz(path: &Path) -> Result<PointCloud, FormatError> {
    read_xyz_with(path, &PointReadOptions::default())
}

pub(crate) fn read_xyz_with(path: &Path, options: &PointReadOptions) -> Result<PointCloud, FormatError> {
    let bytes = crate::files::read_sniffed(path, None, crate::files::text("an XYZ/PTS point file"))?;
    parse_xyz_with(&bytes, path, options)
}

fn malformed(path: &Path, line: usize, message: impl Into<String>) -> FormatError {
    FormatError::Malformed { file: path.to_path_buf(), place: format!("line {line}"), message: message.into() }
}

/// Parse XYZ text; `path` names it in errors and gives the cloud its name.
pub fn parse_xyz(bytes: &[u8], path: &Path) -> Result<PointCloud, FormatError> {
    parse_xyz_with(bytes, path, &PointReadOptions::default())
}

fn words(line: &str) -> impl Iterator<Item = &str> {
    line.split(|c: char| c.is_whitespace() || c == ',').filter(|w| !w.is_empty())
}

pub(crate) fn parse_xyz_with(bytes: &[u8], path: &Path, options: &PointReadOptions) -> Result<PointCloud, FormatError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        malformed(path, line, "not UTF-8 text (a binary file with an .xyz name?)")
    })?;
    let pts = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("pts"));
    let mut count_line_allowed = pts;
    let mut columns = 0usize;
    let mut first_line = 1;
    let mut values: Vec<f64> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with("//") {
            continue;
        }
        if std::mem::take(&mut count_line_allowed) {
            let mut w = words(line);
            if let (Some(n), None) = (w.next(), w.next())
                && n.parse::<u64>().is_ok()
            {
                continue;
            }
        }
        let start = values.len();
        for word in words(line) {
            let v: f64 = word.parse().map_err(|_| malformed(path, i + 1, format!("{word:?} is not a number")))?;
            if !v.is_finite() {
                return Err(malformed(path, i + 1, format!("{word} is not a finite number")));
            }
            if v.abs() > f64::from(f32::MAX) {
                return Err(malformed(path, i + 1, format!("{word} is beyond the range of f32")));
            }
            values.push(v);
        }
        let n = values.len() - start;
        if columns == 0 {
            if !matches!(n, 3 | 4 | 6 | 7 | 9) {
                return Err(malformed(
                    path,
                    i + 1,
                    format!(
                        "{n} columns: expected 3 (x y z), 4 (+ intensity), 6 (+ normal or colour), \
                         7 (+ intensity + colour) or 9 (+ normal + colour)"
                    ),
                ));
            }
            columns = n;
            first_line = i + 1;
        } else if n != columns {
            return Err(malformed(path, i + 1, format!("{n} columns where the first point has {columns}")));
        }
    }
    if columns == 0 {
        return Err(malformed(path, 1, "no points"));
    }
    let rows: Vec<&[f64]> = values.chunks_exact(columns).collect();
    let triple = |r: &[f64], k: usize| Vec3::new(r[k] as f32, r[k + 1] as f32, r[k + 2] as f32);
    let coords: Vec<DVec3> = rows.iter().map(|r| DVec3::new(r[0], r[1], r[2])).collect();
    let (origin, positions) = recentre(&coords);
    drop(coords);
    let is_normal = |k: usize| {
        rows.iter().all(|r| {
            let l = triple(r, k).length();
            l == 0.0 || (l - 1.0).abs() <= 0.02
        })
    };
    let (intensity_at, normal_at, colour_at) = match columns {
        3 => (None, None, None),
        4 => (Some(3), None, None),
        6 if is_normal(3) => (None, Some(3), None),
        6 => (None, None, Some(3)),
        7 => (Some(3), None, Some(4)),
        _ => (None, Some(3), Some(6)),
    };
    let normals: Option<Vec<Vec3>> = normal_at.map(|k| rows.iter().map(|r| triple(r, k).normalize_or_zero()).collect());
    let rgb = colour_at.map(|k| {
        let scale = if rows.iter().any(|r| r[k..k + 3].iter().any(|&c| c > 1.0)) { 1.0 / 255.0 } else { 1.0 };
        rows.iter().map(|r| (triple(r, k) * scale).clamp(Rgb::ZERO, Rgb::ONE)).collect()
    });
    let intensity = intensity_at.map(|k| rows.iter().map(|r| r[k] as f32).collect());
    let sources = ColourSources { rgb, intensity, classification: None, auto_elevation: false };
    let place = format!("line {first_line} ({columns} columns)");
    let colours = colours(path, &place, options.colour_by, sources, &positions)?;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "points".into());
    let orientation = if normals.is_some() { Orientation::Oriented } else { Orientation::Unknown };
    let cloud = PointCloud { name, positions, normals, radii: None, colours, origin, orientation };
    cloud.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    Ok(cloud)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;
    use crate::points::ColourBy;
    use glint_core::colour::srgb_to_linear;

    fn parse(text: &str) -> Result<PointCloud, FormatError> {
        parse_xyz(text.as_bytes(), Path::new("t.xyz"))
    }

    #[test]
    fn positions_normals_and_colours_are_told_apart() {
        let c = parse("# scan\n0 0 0\n1 2 3\n\n// end\n").unwrap();
        assert_eq!(c.positions, vec![Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0)]);
        assert!(c.normals.is_none() && c.colours.is_none());
        let c = parse("0 0 0 0 0 1\n1,2,3, 0.6,0.8,0\n").unwrap();
        assert_eq!(c.normals.as_ref().unwrap()[1], Vec3::new(0.6, 0.8, 0.0));
        let c = parse("0 0 0 255 128 0\n1 2 3 10 20 30\n").unwrap();
        let cs = c.colours.unwrap();
        assert!((cs[0].x - 1.0).abs() < 1e-6 && cs[0].z == 0.0);
        let c = parse("0 0 0 0 1 0 0.5 0.5 0.5\n").unwrap();
        assert_eq!(c.normals.unwrap()[0], Vec3::Y);
        assert!((c.colours.unwrap()[0].x - srgb_to_linear(0.5)).abs() < 1e-6);
    }

    #[test]
    fn bad_files_name_the_line() {
        let cases = [
            ("", "line 1: no points"),
            ("0 0\n", "line 1: 2 columns"),
            ("0 0 0\n1 1 1 1\n", "line 2: 4 columns where the first point has 3"),
            ("0 0 0\n1 nan 1\n", "line 2: nan is not a finite number"),
            ("0 0 0\n1 x 1\n", "line 2: \"x\" is not a number"),
            ("0 0 0\n1 1e40 1\n", "line 2: 1e40 is beyond the range of f32"),
            ("0 0 0\n1 inf 1\n", "line 2: inf is not a finite number"),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.starts_with("t.xyz: ") && e.contains(want), "{text:?}: {e}");
        }
        let e = parse_xyz(&[0x30, 0x20, 0xff, 0xfe], Path::new("b.xyz")).unwrap_err().to_string();
        assert!(e.contains("UTF-8"), "{e}");
    }

    fn parse_as(text: &str, name: &str, by: ColourBy) -> Result<PointCloud, FormatError> {
        parse_xyz_with(text.as_bytes(), Path::new(name), &PointReadOptions { colour_by: by })
    }

    #[test]
    fn pts_count_lines_and_intensity_columns() {
        let text = "3\n0 0 0 -2048 255 0 0\n1 0 0 2047 0 255 0\n0 1 0 0 0 0 255\n";
        let c = parse_as(text, "scan.PTS", ColourBy::Auto).unwrap();
        assert_eq!(c.len(), 3);
        assert_eq!(c.colours.unwrap()[1], Rgb::Y, "Auto prefers RGB");
        let c = parse_as(text, "scan.pts", ColourBy::Intensity).unwrap().colours.unwrap();
        assert_eq!((c[0], c[1]), (Rgb::ZERO, Rgb::ONE));
        // Only .pts files may start with a count, and only once.
        let e = parse_as(text, "scan.xyz", ColourBy::Auto).unwrap_err().to_string();
        assert!(e.contains("line 1: 1 columns"), "{e}");
        let e = parse_as("2\n2\n0 0 0\n", "scan.pts", ColourBy::Auto).unwrap_err().to_string();
        assert!(e.contains("line 2: 1 columns"), "{e}");
        let c = parse_as("0 0 0 5\n1 1 1 0\n", "i.txt", ColourBy::Auto).unwrap().colours.unwrap();
        assert_eq!(c, vec![Rgb::ONE, Rgb::ZERO]);
        let c = parse_as("0 0 0 5\n1 1 1 0\n", "i.txt", ColourBy::Elevation).unwrap().colours.unwrap();
        assert_ne!(c[0], c[1]);
    }

    #[test]
    fn colour_modes_the_file_cannot_give_are_errors() {
        for by in [ColourBy::Rgb, ColourBy::Intensity, ColourBy::Classification] {
            let e = parse_as("0 0 0\n# x\n1 1 1\n", "p.xyz", by).unwrap_err().to_string();
            assert!(e.starts_with("p.xyz: line 1 (3 columns): cannot colour by"), "{e}");
        }
        assert!(parse_as("0 0 0 1 0 0\n", "p.xyz", ColourBy::Rgb).is_err(), "a unit triple is a normal");
    }

    #[test]
    fn large_coordinates_are_recentred_in_f64() {
        let c = parse("500000.01 4000000.02 10\n500010.03 4000020.04 12\n").unwrap();
        assert!((c.origin - DVec3::new(500_005.02, 4_000_010.03, 11.0)).abs().max_element() < 1e-9);
        let back = c.origin + c.positions[1].as_dvec3();
        assert!((back - DVec3::new(500_010.03, 4_000_020.04, 12.0)).abs().max_element() < 1e-4, "{back}");
        assert_eq!(c.orientation, Orientation::Unknown);
        let c = parse("1e6 0 0 0 0 1\n").unwrap();
        assert_eq!((c.origin.x, c.positions[0]), (1e6, Vec3::ZERO));
        assert_eq!(c.orientation, Orientation::Oriented);
    }

    #[test]
    fn the_raw_bunny_scan_reads() {
        let p = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../../shared/data/pointclouds/stanford_bunny_rawscan_40256.xyz"
        ));
        if !p.exists() {
            eprintln!("skipped: {} is not there", p.display());
            return;
        }
        let c = read_xyz(p).unwrap();
        assert_eq!(c.len(), 40256);
        assert!(c.normals.is_none() && c.colours.is_none());
        assert!(c.bounds().extent().max_element() < 0.3);
    }
}
