//! Which cube face a file is, from its name: the schemes skybox sets ship with.
//!
//! A name stem (case-insensitive) is an optional prefix (`sky_`, `miramar_`, …) followed by a
//! face token; alphabetic tokens need a separator (`_`, `-` or `.`) after the prefix, signed
//! tokens (`+x`, `-x`) may follow it directly. Tokens, with the face each means in glint's
//! convention (DESIGN.md §4: the default camera looks along world −Z and sees +Z, "front"):
//!
//! | face | tokens                          |
//! |------|---------------------------------|
//! | +X   | `px` `posx` `+x` `right` `rt`        |
//! | −X   | `nx` `negx` `-x` `left` `lf`         |
//! | +Y   | `py` `posy` `+y` `up` `top`          |
//! | −Y   | `ny` `negy` `-y` `down` `bottom` `dn`|
//! | +Z   | `pz` `posz` `+z` `front` `ft`        |
//! | −Z   | `nz` `negz` `-z` `back` `bk`         |

use crate::error::FormatError;
use glint_scene::CubeFace;
use std::path::{Path, PathBuf};

/// Image extensions a face file may have (lower case).
pub(crate) const FACE_EXTENSIONS: [&str; 7] = ["png", "jpg", "jpeg", "tga", "bmp", "hdr", "exr"];

const TOKENS: [(&str, CubeFace); 31] = [
    ("px", CubeFace::PosX),
    ("nx", CubeFace::NegX),
    ("py", CubeFace::PosY),
    ("ny", CubeFace::NegY),
    ("pz", CubeFace::PosZ),
    ("nz", CubeFace::NegZ),
    ("posx", CubeFace::PosX),
    ("negx", CubeFace::NegX),
    ("posy", CubeFace::PosY),
    ("negy", CubeFace::NegY),
    ("posz", CubeFace::PosZ),
    ("negz", CubeFace::NegZ),
    ("+x", CubeFace::PosX),
    ("-x", CubeFace::NegX),
    ("+y", CubeFace::PosY),
    ("-y", CubeFace::NegY),
    ("+z", CubeFace::PosZ),
    ("-z", CubeFace::NegZ),
    ("right", CubeFace::PosX),
    ("left", CubeFace::NegX),
    ("up", CubeFace::PosY),
    ("top", CubeFace::PosY),
    ("down", CubeFace::NegY),
    ("bottom", CubeFace::NegY),
    ("front", CubeFace::PosZ),
    ("back", CubeFace::NegZ),
    // Quake-style short names (hipshot's and many game sets ship as `name_rt.tga` …); after the
    // long names, so that `left` is never read as `…ft`. Engines with +Z up store these
    // turned: the seam check then names the per-face fix.
    ("rt", CubeFace::PosX),
    ("lf", CubeFace::NegX),
    ("dn", CubeFace::NegY),
    ("ft", CubeFace::PosZ),
    ("bk", CubeFace::NegZ),
];

/// The names a face is recognised by, for messages: "px, posx, +x, right".
pub(crate) fn face_names(face: CubeFace) -> String {
    TOKENS.iter().filter(|(_, f)| *f == face).map(|(t, _)| *t).collect::<Vec<_>>().join(", ")
}

/// The face a file name stem stands for, if it follows one of the schemes.
pub(crate) fn face_from_stem(stem: &str) -> Option<CubeFace> {
    let stem = stem.to_ascii_lowercase();
    TOKENS.iter().find_map(|&(token, face)| {
        let prefix = stem.strip_suffix(token)?;
        let signed = token.starts_with(['+', '-']);
        let ok = prefix.is_empty() || prefix.ends_with(['_', '-', '.']) || signed;
        ok.then_some(face)
    })
}

/// True for a file name with one of the [`FACE_EXTENSIONS`] (case-insensitive).
pub(crate) fn has_image_extension(path: &Path) -> bool {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    ext.is_some_and(|e| FACE_EXTENSIONS.contains(&e.as_str()))
}

/// The six face files of `folder`, in [`CubeFace::ALL`] order. Hidden files and files without
/// an image extension are ignored. Errors name the folder and what is missing or claimed twice.
pub(crate) fn find_faces(folder: &Path) -> Result<[PathBuf; 6], FormatError> {
    let entries = std::fs::read_dir(folder).map_err(|e| FormatError::io(folder, e))?;
    let mut images = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| FormatError::io(folder, e))?.path();
        let hidden = path.file_name().and_then(|n| n.to_str()).is_none_or(|n| n.starts_with('.'));
        if !hidden && path.is_file() && has_image_extension(&path) {
            images.push(path);
        }
    }
    images.sort();
    if images.is_empty() {
        return Err(FormatError::sky(
            folder,
            format!("the folder holds no images ({}) to make a cube map from", FACE_EXTENSIONS.join(", ")),
        ));
    }
    let mut found: [Vec<PathBuf>; 6] = Default::default();
    let mut unrecognised = Vec::new();
    for path in images {
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        match face_from_stem(stem) {
            Some(face) => found[face.index()].push(path),
            None => unrecognised.push(file_name(&path)),
        }
    }
    let duplicated: Vec<String> = CubeFace::ALL
        .iter()
        .filter(|f| found[f.index()].len() > 1)
        .map(|f| {
            let files: Vec<String> = found[f.index()].iter().map(|p| file_name(p)).collect();
            format!("{} by {}", f.short_name(), files.join(" and "))
        })
        .collect();
    if !duplicated.is_empty() {
        return Err(FormatError::sky(
            folder,
            format!(
                "more than one file claims a cube face: {} (keep one file per face, or list the faces explicitly)",
                duplicated.join("; ")
            ),
        ));
    }
    let missing: Vec<String> = CubeFace::ALL
        .iter()
        .filter(|f| found[f.index()].is_empty())
        .map(|f| format!("{} ({})", f.short_name(), face_names(*f)))
        .collect();
    if !missing.is_empty() {
        let what = if missing.len() == 6 {
            "no file is named like a cube face".to_string()
        } else {
            format!("missing cube face{} {}", if missing.len() > 1 { "s" } else { "" }, missing.join(", "))
        };
        let ignored = if unrecognised.is_empty() {
            String::new()
        } else {
            format!("; names not recognised: {}", unrecognised.join(", "))
        };
        return Err(FormatError::sky(
            folder,
            format!(
                "{what}{ignored} (faces are named px/nx/py/ny/pz/nz, posx/negx/…, +x/-x/…, \
                 right/left/up|top/down|bottom/front/back, or rt/lf/up/dn/ft/bk, with an optional prefix \
                 such as sky_)"
            ),
        ));
    }
    Ok(found.map(|mut v| v.remove(0)))
}

fn file_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::test_util::TempDir;
    use CubeFace::*;

    #[test]
    fn every_scheme_and_prefix_is_recognised() {
        let cases = [
            ("px", PosX),
            ("NX", NegX),
            ("posy", PosY),
            ("sky_negy", NegY),
            ("+z", PosZ),
            ("-z", NegZ),
            ("sky-x", NegX),
            ("sky_+x", PosX),
            ("sky+y", PosY),
            ("miramar_right", PosX),
            ("Left", NegX),
            ("sky.up", PosY),
            ("Top", PosY),
            ("a-b_down", NegY),
            ("bottom", NegY),
            ("front", PosZ),
            ("storforsen-back", NegZ),
            ("miramar_rt", PosX),
            ("miramar_lf", NegX),
            ("miramar_dn", NegY),
            ("miramar_ft", PosZ),
            ("BK", NegZ),
        ];
        for (stem, face) in cases {
            assert_eq!(face_from_stem(stem), Some(face), "{stem}");
        }
        for stem in
            ["skypx", "upper", "frontal", "x", "sky", "", "backup", "negative_x", "pxx", "cloudsup", "craft", "skydn"]
        {
            assert_eq!(face_from_stem(stem), None, "{stem}");
        }
    }

    #[test]
    fn names_for_messages() {
        assert_eq!(face_names(PosY), "py, posy, +y, up, top");
        assert_eq!(face_names(NegX), "nx, negx, -x, left, lf");
    }

    #[test]
    fn folder_scan_finds_faces_and_ignores_other_files() {
        let dir = TempDir::new("names-scan");
        for name in ["sky_right.png", "sky_left.png", "sky_top.JPG", "sky_bottom.png", "sky_front.png", "sky_back.hdr"]
        {
            std::fs::write(dir.join(name), b"").expect("write");
        }
        std::fs::write(dir.join("README.txt"), b"").expect("write");
        std::fs::write(dir.join(".px.png.1-0.tmp"), b"").expect("write");
        let faces = find_faces(dir.path()).expect("six faces");
        let names: Vec<String> = faces.iter().map(|p| file_name(p)).collect();
        assert_eq!(
            names,
            ["sky_right.png", "sky_left.png", "sky_top.JPG", "sky_bottom.png", "sky_front.png", "sky_back.hdr"]
        );
    }

    #[test]
    fn folder_errors_name_the_folder_and_the_faces() {
        let dir = TempDir::new("names-errors");
        let err = find_faces(dir.path()).expect_err("empty");
        assert!(err.to_string().starts_with(&dir.path().display().to_string()), "{err}");
        assert!(err.to_string().contains("no images"), "{err}");

        std::fs::write(dir.join("photo.png"), b"").expect("write");
        let err = find_faces(dir.path()).expect_err("unrecognised").to_string();
        assert!(err.contains("no file is named like a cube face") && err.contains("photo.png"), "{err}");

        for name in ["px.png", "nx.png", "py.png", "pz.png", "nz.png"] {
            std::fs::write(dir.join(name), b"").expect("write");
        }
        let err = find_faces(dir.path()).expect_err("missing").to_string();
        assert!(err.contains("missing cube face ny (ny, negy, -y, down, bottom, dn)"), "{err}");

        std::fs::write(dir.join("down.png"), b"").expect("write");
        std::fs::write(dir.join("negx.jpg"), b"").expect("write");
        let err = find_faces(dir.path()).expect_err("duplicate").to_string();
        assert!(err.contains("nx by negx.jpg and nx.png"), "{err}");
    }

    #[test]
    fn a_missing_folder_is_an_io_error() {
        let err = find_faces(Path::new("/no/such/sky")).expect_err("missing");
        assert!(matches!(err, FormatError::Io { .. }), "{err}");
        assert!(err.to_string().starts_with("/no/such/sky"), "{err}");
    }
}
