//! XYZ text point clouds: one point per line, `x y z`, optionally followed by a normal
//! `nx ny nz` and/or a colour `r g b`, separated by spaces, tabs or commas.
//!
//! - 3 columns: positions; 9 columns: position, normal, colour.
//! - 6 columns are ambiguous: the extra triple is a normal when every row's triple has unit
//!   length (within 2 %, or is zero), otherwise a colour.
//! - Colours are 0–255 when any component exceeds 1, else 0–1; either way they are sRGB-encoded
//!   and become linear.
//! - Blank lines and lines starting with `#` or `//` are skipped; every other line must have the
//!   same number of columns as the first. A NaN or infinite value, a stray word, or a file with
//!   no point is an error naming the line.

use crate::FormatError;
use glint_core::colour::srgb_to_linear;
use glint_core::{Rgb, Vec3};
use glint_scene::{Orientation, PointCloud};
use std::path::Path;

/// Read an XYZ file.
pub fn read_xyz(path: &Path) -> Result<PointCloud, FormatError> {
    let bytes = std::fs::read(path).map_err(|e| FormatError::io(path, e))?;
    parse_xyz(&bytes, path)
}

fn malformed(path: &Path, line: usize, message: impl Into<String>) -> FormatError {
    FormatError::Malformed { file: path.to_path_buf(), place: format!("line {line}"), message: message.into() }
}

/// Parse XYZ text; `path` names it in errors and gives the cloud its name.
pub fn parse_xyz(bytes: &[u8], path: &Path) -> Result<PointCloud, FormatError> {
    let text = std::str::from_utf8(bytes).map_err(|e| {
        let line = bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count() + 1;
        malformed(path, line, "not UTF-8 text (a binary file with an .xyz name?)")
    })?;
    let mut columns = 0usize;
    let mut values: Vec<f32> = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with("//") {
            continue;
        }
        let start = values.len();
        for word in line.split(|c: char| c.is_whitespace() || c == ',').filter(|w| !w.is_empty()) {
            let v: f32 = word.parse().map_err(|_| malformed(path, i + 1, format!("{word:?} is not a number")))?;
            if !v.is_finite() {
                return Err(malformed(path, i + 1, format!("{word} is not a finite number")));
            }
            values.push(v);
        }
        let n = values.len() - start;
        if columns == 0 {
            if !matches!(n, 3 | 6 | 9) {
                return Err(malformed(
                    path,
                    i + 1,
                    format!("{n} columns: expected 3 (x y z), 6 (+ normal or colour) or 9 (+ normal + colour)"),
                ));
            }
            columns = n;
        } else if n != columns {
            return Err(malformed(path, i + 1, format!("{n} columns where the first point has {columns}")));
        }
    }
    if columns == 0 {
        return Err(malformed(path, 1, "no points"));
    }
    let rows: Vec<&[f32]> = values.chunks_exact(columns).collect();
    let triple = |r: &[f32], k: usize| Vec3::new(r[k], r[k + 1], r[k + 2]);
    let positions = rows.iter().map(|r| triple(r, 0)).collect();
    let is_normal = |k: usize| {
        rows.iter().all(|r| {
            let l = triple(r, k).length();
            l == 0.0 || (l - 1.0).abs() <= 0.02
        })
    };
    let (normal_at, colour_at) = match columns {
        3 => (None, None),
        6 if is_normal(3) => (Some(3), None),
        6 => (None, Some(3)),
        _ => (Some(3), Some(6)),
    };
    let normals = normal_at.map(|k| rows.iter().map(|r| triple(r, k).normalize_or_zero()).collect());
    let colours = colour_at.map(|k| {
        let scale = if rows.iter().any(|r| r[k..k + 3].iter().any(|&c| c > 1.0)) { 1.0 / 255.0 } else { 1.0 };
        rows.iter()
            .map(|r| {
                let c = triple(r, k) * scale;
                Rgb::new(
                    srgb_to_linear(c.x.clamp(0.0, 1.0)),
                    srgb_to_linear(c.y.clamp(0.0, 1.0)),
                    srgb_to_linear(c.z.clamp(0.0, 1.0)),
                )
            })
            .collect()
    });
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "points".into());
    let orientation = if normals.is_some() { Orientation::Oriented } else { Orientation::Unknown };
    let cloud = PointCloud { name, positions, normals, radii: None, colours, orientation, ..PointCloud::default() };
    cloud.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    Ok(cloud)
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used, clippy::expect_used)]
    use super::*;

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
            ("0 0 0\n1 1e40 1\n", "line 2"),
        ];
        for (text, want) in cases {
            let e = parse(text).unwrap_err().to_string();
            assert!(e.starts_with("t.xyz: ") && e.contains(want), "{text:?}: {e}");
        }
        let e = parse_xyz(&[0x30, 0x20, 0xff, 0xfe], Path::new("b.xyz")).unwrap_err().to_string();
        assert!(e.contains("UTF-8"), "{e}");
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
