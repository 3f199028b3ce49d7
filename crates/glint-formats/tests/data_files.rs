//! The loaders on every mesh and scene folder of the shared test data (../shared/data, outside
//! the repository): each file loads, is non-empty and finite, and validates. OBJ files are
//! cross-checked against `tobj`. Skipped, with a note, when the data folder is absent.

use glint_formats::{load, load_model};
use std::path::{Path, PathBuf};
use std::time::Instant;

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");
const SCENES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes");

fn data(relative: &str) -> Option<PathBuf> {
    let root = Path::new(DATA);
    if !root.is_dir() {
        eprintln!("note: {DATA} is absent; skipping the shared-data tests");
        return None;
    }
    Some(root.join(relative))
}

/// Loads a model file as a scene and checks it; returns its triangle count.
fn check_model(path: &Path) -> usize {
    let start = Instant::now();
    let loaded = load(path).unwrap_or_else(|e| panic!("{e}"));
    let ms = start.elapsed().as_secs_f64() * 1e3;
    let scene = &loaded.scene;
    assert_eq!(scene.validate(), Ok(()), "{}", path.display());
    assert!(!scene.meshes.is_empty(), "{}", path.display());
    let triangles: usize = scene.meshes.iter().map(|m| m.triangles.len()).sum();
    assert!(triangles > 0);
    for m in &scene.meshes {
        assert!(m.positions.iter().all(|p| p.is_finite()));
        assert!(m.normals.iter().flatten().all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-3));
        assert!(m.uvs.iter().flatten().all(|t| t.is_finite()));
    }
    let bounds = scene.bounds();
    assert!(!bounds.is_empty() && bounds.min.is_finite() && bounds.max.is_finite());
    println!("{}: {triangles} triangles in {ms:.1} ms; warnings: {:?}", path.display(), loaded.warnings);
    triangles
}

/// Triangles of an OBJ file according to tobj (fan-triangulated like glint).
fn tobj_triangles(path: &Path) -> usize {
    let options = tobj::LoadOptions { triangulate: true, single_index: true, ..Default::default() };
    let (models, _) = tobj::load_obj(path, &options).unwrap_or_else(|e| panic!("tobj: {e}"));
    models.iter().map(|m| m.mesh.indices.len() / 3).sum()
}

#[test]
fn meshes_folder_loads() {
    let Some(dir) = data("meshes") else { return };
    let expected = [
        ("armadillo_remeshed_29k.obj", 29_170),
        ("happy_buddha_100k.obj", 100_000),
        ("lucy_decimated.ply", 15_000),
        ("stanford_bunny_bun_zipper.ply", 69_451),
        ("stanford_dragon_100k.ply", 100_000),
    ];
    for (name, triangles) in expected {
        let path = dir.join(name);
        let loaded = check_model(&path);
        // Zero-area triangles of the scans are dropped (with a warning), nothing else.
        assert!(loaded <= triangles && loaded + triangles / 1000 >= triangles, "{name}: {loaded} vs {triangles}");
        if name.ends_with(".obj") {
            assert!(tobj_triangles(&path) >= loaded);
        }
    }
}

#[test]
fn ply_normals_are_kept_or_computed() {
    let Some(dir) = data("meshes") else { return };
    let dragon = load_model(&dir.join("stanford_dragon_100k.ply")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(dragon.meshes[0].positions.len(), 50_000);
    assert!(dragon.meshes[0].normals.is_some());
    let bunny = load_model(&dir.join("stanford_bunny_bun_zipper.ply")).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(bunny.meshes[0].positions.len(), 35_947);
    assert!(bunny.meshes[0].normals.is_some(), "computed smooth normals");
}

fn obj_files(folder: &str) -> Vec<PathBuf> {
    let Some(dir) = data(folder) else { return Vec::new() };
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj")))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no OBJ in {}", dir.display());
    files
}

#[test]
fn scene_folders_load() {
    for folder in ["scenes/cornell_box", "scenes/sponza_dabrovic", "scenes/nori_table/meshes", "scenes/nori_veach_mi"] {
        for path in obj_files(folder) {
            let ours = check_model(&path);
            // Equal but for the zero-area triangles glint drops (one in Sponza).
            let theirs = tobj_triangles(&path);
            assert!(ours <= theirs && ours + theirs / 1000 >= theirs, "{}: {ours} vs {theirs}", path.display());
        }
    }
}

#[test]
fn cornell_box_materials_come_from_its_mtl() {
    let Some(path) = data("scenes/cornell_box/cornell_box.obj") else { return };
    let model = load_model(&path).unwrap_or_else(|e| panic!("{e}"));
    let names: Vec<&str> = model.materials.iter().map(|m| m.name.as_str()).collect();
    assert!(names.starts_with(&["white", "red", "green", "blue", "light"]), "{names:?}");
    let light = &model.materials[4];
    assert!(light.emission.min_element() >= 20.0, "Ka 20 read as emission");
    let mesh = &model.meshes[0];
    let used: std::collections::BTreeSet<u32> = mesh.triangle_materials.iter().flatten().copied().collect();
    assert!(used.contains(&1) && used.contains(&2) && used.contains(&4), "{used:?}");
}

#[test]
fn shipped_scenes_load() {
    let mut found = 0;
    for entry in std::fs::read_dir(SCENES).unwrap_or_else(|e| panic!("{SCENES}: {e}")) {
        let path = entry.unwrap_or_else(|e| panic!("{e}")).path();
        if path.extension().is_some_and(|e| e == "toml") {
            if !Path::new(DATA).is_dir() && std::fs::read_to_string(&path).is_ok_and(|t| t.contains("shared/data")) {
                eprintln!("note: {} needs {DATA}; skipped", path.display());
                continue;
            }
            let loaded = load(&path).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(loaded.scene.validate(), Ok(()));
            println!("{}: {} objects; warnings {:?}", path.display(), loaded.scene.objects.len(), loaded.warnings);
            found += 1;
        }
    }
    assert!(found >= 2);
}

/// Load speed on large generated files: a 1M-triangle OBJ (positions, normals, uvs) and a
/// 2M-triangle binary PLY. Ignored by default (writes ~100 MB); run with
/// `cargo test --release -p glint-formats --test data_files -- --ignored --nocapture`.
#[test]
#[ignore]
fn large_files_load_fast() {
    use std::fmt::Write as _;
    let dir = std::env::temp_dir().join(format!("glint-formats-large-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{e}"));
    let grid = |n: usize| {
        let vertices: Vec<[f32; 3]> = (0..=n)
            .flat_map(|j| (0..=n).map(move |i| [i as f32 / n as f32, (i * j % 7) as f32 * 0.01, j as f32 / n as f32]))
            .collect();
        let mut quads = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let v = (j * (n + 1) + i) as u32;
                quads.push([v, v + 1, v + n as u32 + 2, v + n as u32 + 1]);
            }
        }
        (vertices, quads)
    };

    let (vertices, quads) = grid(708); // 1.0M triangles
    let mut obj = String::new();
    for v in &vertices {
        let _ = writeln!(obj, "v {} {} {}", v[0], v[1], v[2]);
        let _ = writeln!(obj, "vn 0 1 0");
        let _ = writeln!(obj, "vt {} {}", v[0], v[2]);
    }
    for q in &quads {
        let [a, b, c, d] = q.map(|i| i + 1);
        let _ = writeln!(obj, "f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c} {d}/{d}/{d}");
    }
    let obj_path = dir.join("grid.obj");
    std::fs::write(&obj_path, obj).unwrap_or_else(|e| panic!("{e}"));
    let start = Instant::now();
    let model = load_model(&obj_path).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "1M-triangle OBJ ({} triangles): {:.0} ms",
        model.meshes[0].triangles.len(),
        start.elapsed().as_secs_f64() * 1e3
    );

    let (vertices, quads) = grid(1000); // 2.0M triangles
    let mut ply = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        vertices.len(),
        quads.len() * 2
    )
    .into_bytes();
    for v in &vertices {
        for c in v {
            ply.extend(c.to_le_bytes());
        }
    }
    for q in &quads {
        for t in [[q[0], q[1], q[2]], [q[0], q[2], q[3]]] {
            ply.push(3);
            for i in t {
                ply.extend((i as i32).to_le_bytes());
            }
        }
    }
    let ply_path = dir.join("grid.ply");
    std::fs::write(&ply_path, ply).unwrap_or_else(|e| panic!("{e}"));
    let start = Instant::now();
    let model = load_model(&ply_path).unwrap_or_else(|e| panic!("{e}"));
    println!(
        "2M-triangle binary PLY ({} triangles): {:.0} ms",
        model.meshes[0].triangles.len(),
        start.elapsed().as_secs_f64() * 1e3
    );
    let _ = std::fs::remove_dir_all(&dir);
}
