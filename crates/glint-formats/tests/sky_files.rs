//! load_sky on every sky in the shared test data (../shared/data, outside the repository):
//! each loads, has the size and layout it should, and the seam check says what each set needs.
//! Skipped, with a note, when the data folder is absent.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

use glint_core::Vec3;
use glint_formats::{FaceTransform, LoadedSky, SkyLayout, SkyLoadOptions, SkySource, load_sky, seam_mismatch};
use glint_scene::{CubeFace, CubeMap, Sky, TextureImage};
use std::path::{Path, PathBuf};
use std::time::Instant;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

fn data(relative: &str) -> Option<PathBuf> {
    let path = Path::new(DATA).join(relative);
    if path.exists() {
        Some(path)
    } else {
        eprintln!("note: {} is absent; skipped", path.display());
        None
    }
}

fn load(path: &Path, options: &SkyLoadOptions) -> LoadedSky {
    let start = Instant::now();
    let loaded = load_sky(&SkySource::Path(path.to_path_buf()), options).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "{}: {:?} in {:.0} ms; warnings: {:?}",
        path.display(),
        loaded.layout,
        start.elapsed().as_secs_f64() * 1e3,
        loaded.warnings
    );
    loaded
}

fn cube(loaded: &LoadedSky) -> &CubeMap {
    match &loaded.sky {
        Sky::CubeMap { map, .. } => map,
        other => panic!("not a cube map: {other:?}"),
    }
}

fn faces(loaded: &LoadedSky) -> [TextureImage; 6] {
    CubeFace::ALL.map(|f| cube(loaded).face_image(f))
}

fn flipped(flip: FaceTransform) -> SkyLoadOptions {
    SkyLoadOptions { all_faces: flip, ..SkyLoadOptions::default() }
}

/// The seam score of the set under each whole-set transform, for the log.
fn print_scores(name: &str, faces: &[TextureImage; 6]) {
    for t in FaceTransform::ALL_DISTINCT {
        let moved: [TextureImage; 6] = std::array::from_fn(|f| t.apply(&faces[f]));
        println!("{name}: all faces {}: seam score {:.2}", t.describe(), seam_mismatch(&moved));
    }
}

fn mean(texels: &[glint_core::Rgb]) -> glint_core::Rgb {
    texels.iter().copied().sum::<glint_core::Rgb>() / texels.len() as f32
}

#[test]
fn humus_magnum_is_stored_upside_down_and_flipping_fixes_it() {
    let Some(dir) = data("skyboxes/humus_magnum_512") else { return };
    let as_stored = load(&dir, &SkyLoadOptions::default());
    assert_eq!(as_stored.layout, SkyLayout::Faces);
    assert_eq!(cube(&as_stored).face_size(), 512);
    print_scores("humus_magnum_512", &faces(&as_stored));
    let score = seam_mismatch(&faces(&as_stored));
    assert!(score > 2.0, "as stored the faces must not meet: {score}");
    assert_eq!(as_stored.warnings.len(), 1, "{:?}", as_stored.warnings);
    let w = &as_stored.warnings[0];
    assert!(w.contains("flipped vertically") && w.contains("flip = \"vertical\""), "{w}");

    let fixed = load(&dir, &flipped(FaceTransform::flip(false, true)));
    assert!(fixed.warnings.is_empty(), "{:?}", fixed.warnings);
    let score = seam_mismatch(&faces(&fixed));
    assert!(score < 1.6, "flipped, the faces must meet: {score}");
    // Upright: the sky (up) is brighter than the ground (down), and the top row of a side
    // face is sky.
    let m = cube(&fixed);
    let up = m.lookup(Vec3::Y);
    let down = m.lookup(Vec3::NEG_Y);
    assert!(up.element_sum() > down.element_sum(), "{up} {down}");
    let front = m.face_image(CubeFace::PosZ);
    let n = front.width as usize;
    assert!(mean(&front.texels[..n]).element_sum() > mean(&front.texels[n * (n - 1)..]).element_sum());
}

#[test]
fn hipshot_miramar_loads_by_right_left_up_down_front_back() {
    let Some(dir) = data("skyboxes/hipshot_miramar_1024") else { return };
    let loaded = load(&dir, &SkyLoadOptions::default());
    assert_eq!(loaded.layout, SkyLayout::Faces);
    assert_eq!(cube(&loaded).face_size(), 1024);
    let names: Vec<String> = loaded.files.iter().map(|p| p.file_name().unwrap().to_string_lossy().into()).collect();
    assert_eq!(names, ["right.png", "left.png", "up.png", "down.png", "front.png", "back.png"]);
    print_scores("hipshot_miramar_1024", &faces(&loaded));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert!(seam_mismatch(&faces(&loaded)) < 1.6);
}

#[test]
fn humus_storforsen_cross_slices_into_faces_that_meet() {
    let Some(file) = data("skyboxes/cross/humus_storforsen4_cross.jpg") else { return };
    let loaded = load(&file, &SkyLoadOptions::default());
    assert_eq!(loaded.layout, SkyLayout::HorizontalCross);
    assert_eq!(cube(&loaded).face_size(), 2048);
    print_scores("humus_storforsen4_cross", &faces(&loaded));
    assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
    assert!(seam_mismatch(&faces(&loaded)) < 1.6);
    let m = cube(&loaded);
    assert!(m.lookup(Vec3::Y).element_sum() > m.lookup(Vec3::NEG_Y).element_sum());
}

#[test]
fn envmaps_load_as_latlong() {
    for name in ["envmaps/venice_sunset_1k.hdr", "envmaps/overcast_soil_puresky_1k.hdr"] {
        let Some(file) = data(name) else { return };
        let loaded = load(&file, &SkyLoadOptions::default());
        assert_eq!(loaded.layout, SkyLayout::LatLong);
        assert!(loaded.warnings.is_empty(), "{:?}", loaded.warnings);
        let Sky::LatLong { map, .. } = &loaded.sky else { panic!("not lat-long") };
        assert_eq!((map.width(), map.height()), (1024, 512));
        let image = map.image();
        assert!(image.texels.iter().all(|t| t.is_finite() && t.min_element() >= 0.0));
        let max = image.texels.iter().map(|t| t.max_element()).fold(0.0, f32::max);
        println!("{name}: max {max}, mean {}", mean(&image.texels));
        assert!(max > 1.0, "an HDR map keeps values above 1");
        let err = load_sky(&SkySource::Path(file.clone()), &flipped(FaceTransform::flip(false, true)))
            .expect_err("flip on lat-long");
        assert!(err.to_string().contains("lat-long"), "{err}");
    }
}

#[test]
fn every_file_and_set_in_the_data_loads() {
    let Some(root) = data("") else { return };
    let mut count = 0;
    for sub in ["skyboxes", "envmaps"] {
        let mut entries: Vec<PathBuf> = std::fs::read_dir(root.join(sub)).unwrap().map(|e| e.unwrap().path()).collect();
        entries.sort();
        for entry in entries {
            // A folder of faces, or a folder holding single images (skyboxes/cross).
            let targets: Vec<PathBuf> =
                if entry.is_dir() && !entry.join("README.TXT").exists() && entry.ends_with("cross") {
                    std::fs::read_dir(&entry).unwrap().map(|e| e.unwrap().path()).collect()
                } else {
                    vec![entry]
                };
            for target in targets {
                let loaded = load(&target, &SkyLoadOptions::default());
                assert!(matches!(loaded.sky, Sky::CubeMap { .. } | Sky::LatLong { .. }));
                count += 1;
            }
        }
    }
    assert_eq!(count, 5, "three skyboxes and two envmaps");
}
