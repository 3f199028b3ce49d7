//! load_sky on small synthetic sets written to a scratch folder: every naming scheme, every
//! single-image layout, transforms, the seam warning, and every bad input.

use super::test_util::{painted_faces, smooth_faces, write_texture};
use super::*;
use crate::test_util::TempDir;
use glint_core::Vec3;

fn load(source: SkySource, options: &SkyLoadOptions) -> Result<LoadedSky, FormatError> {
    load_sky(&source, options)
}

fn path(p: &Path) -> SkySource {
    SkySource::Path(p.to_path_buf())
}

fn cube(loaded: &LoadedSky) -> &CubeMap {
    match &loaded.sky {
        Sky::CubeMap { map, .. } => map,
        other => panic!("not a cube map: {other:?}"),
    }
}

fn faces_of(loaded: &LoadedSky) -> [TextureImage; 6] {
    CubeFace::ALL.map(|f| cube(loaded).face_image(f))
}

/// Writes `faces` as `dir/<prefix><name>.<ext>` for the six names given in CubeFace::ALL order.
fn write_set(dir: &Path, prefix: &str, names: [&str; 6], ext: &str, faces: &[TextureImage; 6]) {
    for (name, face) in names.iter().zip(faces) {
        write_texture(&dir.join(format!("{prefix}{name}.{ext}")), face);
    }
}

fn assert_close(a: &[TextureImage; 6], b: &[TextureImage; 6], tolerance: f32) {
    for (face, (x, y)) in CubeFace::ALL.iter().zip(a.iter().zip(b)) {
        assert_eq!((x.width, x.height), (y.width, y.height), "{face:?}");
        for (p, q) in x.texels.iter().zip(&y.texels) {
            assert!((*p - *q).abs().max_element() <= tolerance, "{face:?}: {p} vs {q}");
        }
    }
}

#[test]
fn every_naming_scheme_loads_the_right_faces() {
    let faces = smooth_faces(8);
    let schemes: [(&str, [&str; 6], &str); 6] = [
        ("", ["px", "nx", "py", "ny", "pz", "nz"], "exr"),
        ("sky_", ["posx", "negx", "posy", "negy", "posz", "negz"], "exr"),
        ("", ["+x", "-x", "+y", "-y", "+z", "-z"], "hdr"),
        ("miramar_", ["right", "left", "up", "down", "front", "back"], "png"),
        ("a-", ["Right", "LEFT", "top", "bottom", "front", "back"], "png"),
        ("sky.", ["PX", "NX", "PY", "NY", "PZ", "NZ"], "exr"),
    ];
    for (i, (prefix, names, ext)) in schemes.iter().enumerate() {
        let dir = TempDir::new(&format!("sky-scheme-{i}"));
        write_set(dir.path(), prefix, *names, ext, &faces);
        let loaded = load(path(dir.path()), &SkyLoadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(loaded.layout, SkyLayout::Faces);
        assert_eq!(loaded.files.len(), 6);
        // The faces of one smooth sky meet: the seam check must not cry wolf.
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        let tolerance = if *ext == "exr" { 0.0 } else { 0.01 };
        assert_close(&faces_of(&loaded), &faces, tolerance);
    }
}

#[test]
fn explicit_faces_in_any_names() {
    let dir = TempDir::new("sky-explicit");
    let faces = painted_faces(3);
    let names = ["a", "b", "c", "d", "e", "f"];
    write_set(dir.path(), "", names, "exr", &faces);
    let paths = names.map(|n| dir.join(&format!("{n}.exr")));
    let loaded = load(SkySource::Faces(paths.clone()), &SkyLoadOptions::default()).expect("load");
    assert_eq!(faces_of(&loaded), faces);
    assert_eq!(loaded.files, paths.to_vec());
}

#[test]
fn crosses_and_strips_are_sliced_into_the_right_faces() {
    let dir = TempDir::new("sky-layouts");
    let faces = painted_faces(8);
    let source = CubeMap::from_faces(faces.clone()).expect("cube");
    for (layout, name) in [
        (SkyLayout::HorizontalCross, "h.exr"),
        (SkyLayout::VerticalCross, "v.exr"),
        (SkyLayout::HorizontalStrip, "s.exr"),
        (SkyLayout::VerticalStrip, "vs.exr"),
    ] {
        let out = dir.join(name);
        write_sky(SkyMapRef::Cube(&source), layout, &out, &SkyWriteOptions::default()).expect("write");
        let loaded = load(path(&out), &SkyLoadOptions::default()).expect("load");
        assert_eq!(loaded.layout, layout);
        assert_eq!(faces_of(&loaded), faces, "{layout:?}");
    }
}

#[test]
fn a_hand_built_cross_places_faces_as_documented() {
    // Built pixel by pixel from the diagram, independently of the writer.
    let n = 2u32;
    let colour = |face: usize| [face as f32 / 8.0, 0.25, 0.75];
    let cells = [(2, 1, 0), (0, 1, 1), (1, 0, 2), (1, 2, 3), (1, 1, 4), (3, 1, 5)];
    let (w, h) = (4 * n, 3 * n);
    let mut pixels = vec![[0.0f32; 3]; (w * h) as usize];
    for (col, row, face) in cells {
        for y in 0..n {
            for x in 0..n {
                pixels[((row * n + y) * w + col * n + x) as usize] = colour(face);
            }
        }
    }
    let dir = TempDir::new("sky-hand-cross");
    let file = dir.join("cross.exr");
    glint_image::write_exr(&file, &Image::from_rgb(w, h, &pixels)).expect("write");
    let loaded = load(path(&file), &SkyLoadOptions::default()).expect("load");
    for face in CubeFace::ALL {
        let t = cube(&loaded).face_image(face).texels[0];
        assert_eq!(t.to_array(), colour(face.index()), "{face:?}");
    }
    // And the front face is what the default camera (looking along −Z) sees.
    let front = cube(&loaded).lookup(Vec3::NEG_Z);
    assert_eq!(front.to_array(), colour(CubeFace::PosZ.index()));
}

#[test]
fn transforms_apply_after_slicing_in_order() {
    let dir = TempDir::new("sky-transforms");
    let faces = smooth_faces(6);
    write_set(dir.path(), "", ["px", "nx", "py", "ny", "pz", "nz"], "exr", &faces);
    let mut options = SkyLoadOptions { all_faces: FaceTransform::flip(false, true), ..SkyLoadOptions::default() };
    options.per_face[2] = FaceTransform::rotate(90);
    let loaded = load(path(dir.path()), &options).expect("load");
    let got = faces_of(&loaded);
    for f in 0..6 {
        let mut want = FaceTransform::flip(false, true).apply(&faces[f]);
        if f == 2 {
            want = FaceTransform::rotate(90).apply(&want);
        }
        assert_eq!(got[f], want, "face {f}");
    }
    // The faces no longer meet: the warning says so and names the folder.
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    assert!(loaded.warnings[0].starts_with(&dir.path().display().to_string()), "{:?}", loaded.warnings);
    assert!(loaded.warnings[0].contains("with the flips and turns given"), "{:?}", loaded.warnings);
}

#[test]
fn a_flipped_set_gets_a_warning_with_the_fix() {
    let dir = TempDir::new("sky-flipped");
    let faces = smooth_faces(32).map(|f| FaceTransform::flip(false, true).apply(&f));
    write_set(dir.path(), "", ["posx", "negx", "posy", "negy", "posz", "negz"], "exr", &faces);
    let loaded = load(path(dir.path()), &SkyLoadOptions::default()).expect("load");
    assert_eq!(loaded.warnings.len(), 1, "{:?}", loaded.warnings);
    let w = &loaded.warnings[0];
    assert!(
        w.contains("faces do not meet") && w.contains("flipped vertically") && w.contains("flip = \"vertical\""),
        "{w}"
    );
    let fixed = SkyLoadOptions { all_faces: FaceTransform::flip(false, true), ..SkyLoadOptions::default() };
    let loaded = load(path(dir.path()), &fixed).expect("load");
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert_eq!(faces_of(&loaded), smooth_faces(32));
}

#[test]
fn latlong_loads_and_refuses_face_transforms() {
    let dir = TempDir::new("sky-latlong");
    let file = dir.join("env.hdr");
    let map = LatLongMap::from_fn(16, super::test_util::smooth);
    write_texture(&file, &map.image());
    let options = SkyLoadOptions { rotation_degrees: 30.0, intensity: 2.0, ..SkyLoadOptions::default() };
    let loaded = load(path(&file), &options).expect("load");
    assert_eq!(loaded.layout, SkyLayout::LatLong);
    match &loaded.sky {
        Sky::LatLong { map, transform } => {
            assert_eq!((map.width(), map.height()), (32, 16));
            assert_eq!(*transform, SkyTransform::new(30.0, 2.0));
        }
        other => panic!("{other:?}"),
    }
    let mut flip = SkyLoadOptions::default();
    flip.per_face[0] = FaceTransform::flip(true, false);
    let err = load(path(&file), &flip).expect_err("transform on lat-long").to_string();
    assert!(err.starts_with(&file.display().to_string()) && err.contains("lat-long"), "{err}");
}

#[test]
fn rotation_and_intensity_go_into_the_sky_transform() {
    let dir = TempDir::new("sky-transform-values");
    write_set(dir.path(), "", ["px", "nx", "py", "ny", "pz", "nz"], "exr", &painted_faces(2));
    let options = SkyLoadOptions { rotation_degrees: -45.0, intensity: 0.5, ..SkyLoadOptions::default() };
    let loaded = load(path(dir.path()), &options).expect("load");
    match &loaded.sky {
        Sky::CubeMap { transform, .. } => assert_eq!(*transform, SkyTransform::new(-45.0, 0.5)),
        other => panic!("{other:?}"),
    }
    for bad in [
        SkyLoadOptions { intensity: -1.0, ..SkyLoadOptions::default() },
        SkyLoadOptions { intensity: f32::NAN, ..SkyLoadOptions::default() },
        SkyLoadOptions { rotation_degrees: f32::INFINITY, ..SkyLoadOptions::default() },
        SkyLoadOptions { all_faces: FaceTransform::rotate(45), ..SkyLoadOptions::default() },
    ] {
        let err = load(path(dir.path()), &bad).expect_err("bad option");
        assert!(matches!(err, FormatError::Sky { .. }), "{err}");
    }
}

#[test]
fn nan_and_negative_texels_are_zeroed_with_a_warning() {
    let dir = TempDir::new("sky-nan");
    let mut faces = painted_faces(2);
    faces[1].texels[2] = Rgb::new(f32::NAN, -1.0, 0.5);
    write_set(dir.path(), "", ["px", "nx", "py", "ny", "pz", "nz"], "exr", &faces);
    let loaded = load(path(dir.path()), &SkyLoadOptions::default()).expect("load");
    assert_eq!(faces_of(&loaded)[1].texels[2], Rgb::new(0.0, 0.0, 0.5));
    assert!(loaded.warnings.iter().any(|w| w.contains("nx.exr") && w.contains("1 texels")), "{:?}", loaded.warnings);
}

/// Every bad input: an error (never a panic) whose message starts with the file or folder.
#[test]
fn bad_inputs_are_clear_errors_naming_the_file() {
    let dir = TempDir::new("sky-bad");
    let names = ["px", "nx", "py", "ny", "pz", "nz"];
    let d = SkyLoadOptions::default();
    let starts = |err: &FormatError, p: &Path| {
        let text = err.to_string();
        assert!(text.starts_with(&p.display().to_string()), "{text}");
        text
    };

    // Non-square face.
    let set = dir.join("nonsquare");
    std::fs::create_dir(&set).expect("mkdir");
    write_set(&set, "", names, "png", &painted_faces(4));
    let odd = TextureImage { width: 4, height: 3, texels: vec![Rgb::ONE; 12] };
    write_texture(&set.join("py.png"), &odd);
    let err = load(path(&set), &d).expect_err("non-square");
    assert!(starts(&err, &set.join("py.png")).contains("4x3"), "{err}");

    // Unequal faces.
    let set = dir.join("unequal");
    std::fs::create_dir(&set).expect("mkdir");
    write_set(&set, "", names, "png", &painted_faces(4));
    write_texture(&set.join("nz.png"), &painted_faces(8)[5]);
    let err = load(path(&set), &d).expect_err("unequal");
    assert!(starts(&err, &set.join("nz.png")).contains("same size"), "{err}");

    // Corrupt and truncated face files.
    let set = dir.join("corrupt");
    std::fs::create_dir(&set).expect("mkdir");
    write_set(&set, "", names, "png", &painted_faces(4));
    std::fs::write(set.join("ny.png"), b"not a png").expect("write");
    let err = load(path(&set), &d).expect_err("corrupt");
    starts(&err, &set.join("ny.png"));
    let bytes = std::fs::read(set.join("px.png")).expect("read");
    std::fs::write(set.join("ny.png"), &bytes[..bytes.len() / 2]).expect("write");
    let err = load(path(&set), &d).expect_err("truncated");
    starts(&err, &set.join("ny.png"));

    // Missing face, duplicate face, empty folder, unrecognised names.
    let set = dir.join("missing");
    std::fs::create_dir(&set).expect("mkdir");
    write_set(&set, "", names, "png", &painted_faces(2));
    std::fs::remove_file(set.join("pz.png")).expect("rm");
    let err = load(path(&set), &d).expect_err("missing");
    assert!(starts(&err, &set).contains("missing cube face pz"), "{err}");
    write_texture(&set.join("front.png"), &painted_faces(2)[4]);
    write_texture(&set.join("sky_pz.jpg"), &painted_faces(2)[4]);
    let err = load(path(&set), &d).expect_err("duplicate");
    assert!(starts(&err, &set).contains("front.png and sky_pz.jpg"), "{err}");
    let empty = dir.join("empty");
    std::fs::create_dir(&empty).expect("mkdir");
    assert!(starts(&load(path(&empty), &d).expect_err("empty"), &empty).contains("no images"));

    // Wrong aspect, with and without a near miss.
    for (w, h, hint) in [(10u32, 10u32, false), (1025, 768, true)] {
        let file = dir.join(&format!("wrong-{w}.png"));
        write_texture(&file, &TextureImage { width: w, height: h, texels: vec![Rgb::ONE; (w * h) as usize] });
        let err = load(path(&file), &d).expect_err("aspect");
        let text = starts(&err, &file);
        assert!(text.contains(&format!("{w}x{h}")) && text.contains("4:3 horizontal cross"), "{text}");
        assert_eq!(text.contains("close to a horizontal cross"), hint, "{text}");
    }

    // A corrupt single image, a non-image file, a path that is not there.
    let file = dir.join("cross.jpg");
    std::fs::write(&file, b"\xff\xd8\xff\xe0 truncated jpeg").expect("write");
    starts(&load(path(&file), &d).expect_err("corrupt jpeg"), &file);
    let file = dir.join("notes.txt");
    std::fs::write(&file, b"hello").expect("write");
    starts(&load(path(&file), &d).expect_err("text"), &file);
    let nowhere = dir.join("no/such/sky.hdr");
    let err = load(path(&nowhere), &d).expect_err("missing path");
    assert!(matches!(err, FormatError::Io { .. }), "{err}");
    starts(&err, &nowhere);
    let missing_face = dir.join("nope.png");
    let mut listed = names.map(|n| dir.join(&format!("nonsquare/{n}.png")));
    listed[3] = missing_face.clone();
    starts(&load(SkySource::Faces(listed), &d).expect_err("listed face missing"), &missing_face);
}
