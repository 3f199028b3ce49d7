//! Scene-file tests: the shipped scenes load, and every kind of bad input is rejected with an
//! error naming the file and the line.

use super::*;
use crate::test_util::TempDir;
use crate::{DEMO_SCENE, load, load_scene_str};
use glint_core::{Affine3A, Vec2};
use glint_scene::{Attenuation, Fov, Material, Repeat, Shape, Sky, Texture};

const SCENES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../scenes");

/// A minimal valid scene; tests append to it or replace parts.
const BASE: &str = r#"
[camera]
position = [0, 1, 5]
look_at = [0, 0, 0]

[[material]]
name = "red"
colour = [0.8, 0.1, 0.1]

[[object]]
type = "sphere"
centre = [0, 0, 0]
radius = 1
material = "red"
"#;

fn parse(text: &str) -> Result<Loaded, FormatError> {
    load_scene_str(text, Path::new("."), "test.toml")
}

fn error(text: &str) -> FormatError {
    match parse(text) {
        Ok(_) => panic!("expected an error for:\n{text}"),
        Err(e) => e,
    }
}

/// The 1-based line of the first line of `text` containing `needle`.
fn line_of(text: &str, needle: &str) -> usize {
    text.lines().position(|l| l.contains(needle)).map(|i| i + 1).expect("needle in text")
}

fn assert_at(e: &FormatError, want_line: usize) {
    let msg = e.to_string();
    assert!(msg.starts_with(&format!("test.toml:{want_line}:")), "expected line {want_line}: {msg}");
}

#[test]
fn base_scene_loads() {
    let l = parse(BASE).expect("valid");
    assert_eq!(l.scene.objects.len(), 1);
    assert!(l.warnings.is_empty());
    assert_eq!(l.scene.ambient, DEFAULT_AMBIENT);
}

#[test]
fn demo_scene_loads_and_validates() {
    let l = load_scene_str(DEMO_SCENE, Path::new(SCENES), "demo.toml").expect("demo is valid");
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let s = &l.scene;
    assert_eq!((s.render.width, s.render.height), (1280, 720));
    assert_eq!(s.lights.len(), 2);
    assert!(s.lights.iter().any(|l| matches!(l, Light::Spot { .. })));
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.meshes[0].triangles.len(), 32);
    assert!(s.meshes[0].normals.is_some());
    assert!(s.objects.iter().any(|o| matches!(o.shape, Shape::Plane { .. })));
    assert!(s.materials.iter().any(|m| m.reflectivity >= 0.9));
    assert!(s.materials.iter().any(|m| m.transparency >= 0.9));
    // The file on disk is the embedded one.
    let from_disk = load(&Path::new(SCENES).join("demo.toml")).expect("demo from disk");
    assert_eq!(from_disk.scene.objects, l.scene.objects);
}

#[test]
fn whitted_bench_has_design_md_values() {
    let l = load(&Path::new(SCENES).join("whitted-bench.toml")).expect("whitted bench is valid");
    let s = &l.scene;
    assert_eq!(s.camera.position, Vec3::new(0.0, 1.6, 6.0));
    assert!((s.camera.forward - (Vec3::new(0.0, 0.9, 0.0) - s.camera.position).normalize()).length() < 1e-6);
    assert_eq!(s.camera.fov, Fov::Horizontal(60.0));
    assert_eq!(s.sky, Sky::Colour(Rgb::new(0.35, 0.55, 0.85)));
    assert_eq!((s.render.width, s.render.height, s.render.samples_per_side, s.render.max_depth), (1280, 720, 1, 8));
    let lights: Vec<(Vec3, f32)> = s
        .lights
        .iter()
        .map(|l| match *l {
            Light::Point { position, intensity, attenuation, .. } => {
                assert_eq!(attenuation, Attenuation::None);
                (position, intensity)
            }
            _ => panic!("only point lights"),
        })
        .collect();
    assert_eq!(lights, vec![(Vec3::new(-6.0, 8.0, 6.0), 0.9), (Vec3::new(5.0, 6.0, 3.0), 0.5)]);
    let object = |name: &str| s.objects.iter().find(|o| o.name == name).expect("object");
    let material = |name: &str| &s.materials[object(name).material];
    assert_eq!(object("ground").shape, Shape::Plane { normal: Vec3::Y, offset: 0.0 });
    let ground = material("ground");
    assert_eq!((ground.diffuse, ground.ambient, ground.specular, ground.reflectivity), (0.8, 0.05, 0.2, 0.1));
    let checker = &s.textures[ground.texture.expect("checker")];
    assert_eq!(*checker, Texture::Checker { size: 1.0, even: Rgb::splat(0.9), odd: Rgb::splat(0.15) });
    let spheres = [
        ("mirror sphere", Vec3::new(-1.6, 1.0, -0.5), 1.0),
        ("glass sphere", Vec3::new(0.6, 0.9, 1.2), 0.9),
        ("red sphere", Vec3::new(2.2, 0.7, -1.2), 0.7),
        ("green sphere", Vec3::new(0.4, 0.35, -1.8), 0.35),
    ];
    for (name, centre, radius) in spheres {
        assert_eq!(object(name).shape, Shape::Sphere { centre, radius }, "{name}");
    }
    let mirror = material("mirror sphere");
    assert_eq!((mirror.reflectivity, mirror.specular), (0.9, 0.8));
    let glass = material("glass sphere");
    assert_eq!((glass.ior, glass.transparency, glass.reflectivity), (1.5, 0.95, 0.05));
    let red = material("red sphere");
    assert_eq!((red.colour, red.diffuse, red.specular, red.shininess), (Rgb::new(0.85, 0.2, 0.15), 0.8, 0.7, 60.0));
    let green = material("green sphere");
    assert_eq!((green.colour, green.reflectivity), (Rgb::new(0.6, 0.8, 0.6), 0.6));
}

#[test]
fn unknown_top_level_key_is_reported_at_its_line() {
    let text = format!("{BASE}\nbackgroud = [0, 0, 0]\n");
    let e = error(&text);
    assert!(matches!(e, FormatError::Syntax { .. }), "{e}");
    assert_at(&e, line_of(&text, "backgroud"));
    assert!(e.to_string().contains("backgroud"), "{e}");
}

#[test]
fn unknown_key_in_an_object_is_reported_at_its_line() {
    let text = BASE.replace("radius = 1", "radius = 1\nradios = 2");
    let e = error(&text);
    assert_at(&e, line_of(&text, "radios"));
}

#[test]
fn unknown_key_in_camera_and_light_are_errors() {
    let text = BASE.replace("look_at = [0, 0, 0]", "look_at = [0, 0, 0]\nzoom = 2");
    assert_at(&error(&text), line_of(&text, "zoom"));
    let text = format!("{BASE}\n[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\nshadows = true\n");
    assert_at(&error(&text), line_of(&text, "shadows"));
}

#[test]
fn unknown_type_is_an_error() {
    let text = BASE.replace("type = \"sphere\"", "type = \"cube\"");
    let e = error(&text);
    assert_at(&e, line_of(&text, "cube"));
    assert!(e.to_string().contains("cube"), "{e}");
}

#[test]
fn key_of_another_type_is_an_error() {
    let text = BASE.replace("radius = 1", "radius = 1\nnormal = [0, 1, 0]");
    let e = error(&text);
    assert!(matches!(e, FormatError::Value { .. }), "{e}");
    assert_at(&e, line_of(&text, "normal ="));
    let text = format!("{BASE}\n[[object]]\ntype = \"plane\"\nnormal = [0, 1, 0]\ntranslate = [0, 1, 0]\n");
    assert_at(&error(&text), line_of(&text, "translate"));
}

#[test]
fn wrong_type_is_reported_at_the_value() {
    let text = BASE.replace("radius = 1", "radius = \"big\"");
    let e = error(&text);
    assert!(matches!(e, FormatError::Syntax { .. }), "{e}");
    assert_at(&e, line_of(&text, "big"));
    let text = BASE.replace("centre = [0, 0, 0]", "centre = [0, 0]");
    assert_at(&error(&text), line_of(&text, "centre"));
}

#[test]
fn missing_required_key_names_the_table() {
    let text = BASE.replace("radius = 1\n", "");
    let e = error(&text);
    assert!(e.to_string().contains("radius"), "{e}");
    assert!(e.to_string().starts_with("test.toml:"), "{e}");
    let text = BASE.replace("position = [0, 1, 5]\n", "");
    assert!(error(&text).to_string().contains("position"));
}

#[test]
fn unknown_material_name_is_reported_at_the_reference() {
    let text = BASE.replace("material = \"red\"", "material = \"blue\"");
    let e = error(&text);
    assert_at(&e, line_of(&text, "\"blue\""));
    assert!(e.to_string().contains("blue"), "{e}");
}

#[test]
fn unknown_texture_name_is_reported_at_the_reference() {
    let text = BASE.replace("colour = [0.8, 0.1, 0.1]", "texture = \"wood\"");
    assert_at(&error(&text), line_of(&text, "wood"));
}

#[test]
fn duplicate_material_name_is_an_error() {
    let text = format!("{BASE}\n[[material]]\nname = \"red\"\n");
    let last = text.lines().enumerate().filter(|(_, l)| l.contains("\"red\"")).last().expect("line").0 + 1;
    assert_at(&error(&text), last);
}

#[test]
fn missing_mesh_file_names_it_and_the_reference() {
    let text = format!("{BASE}\n[[object]]\ntype = \"mesh\"\npath = \"nowhere/bunny.ply\"\n");
    let e = error(&text);
    let FormatError::MissingFile { file, referenced_from } = &e else { panic!("{e}") };
    assert!(file.ends_with("nowhere/bunny.ply"), "{e}");
    assert_eq!(referenced_from, &format!("test.toml:{}", line_of(&text, "nowhere")));
    assert!(e.to_string().contains("bunny.ply") && e.to_string().contains("test.toml:"), "{e}");
}

#[test]
fn missing_texture_file_names_it_and_the_reference() {
    let text = format!("{BASE}\n[[texture]]\nname = \"wood\"\ntype = \"image\"\npath = \"wood.png\"\n");
    let e = error(&text);
    assert!(matches!(e, FormatError::MissingFile { .. }), "{e}");
    assert!(e.to_string().contains(&format!("test.toml:{}", line_of(&text, "wood.png"))), "{e}");
}

#[test]
fn image_texture_is_read_relative_to_the_scene() {
    let dir = TempDir::new("scene-image-texture");
    let img = image::RgbImage::from_fn(2, 1, |x, _| image::Rgb(if x == 0 { [255, 0, 0] } else { [0, 0, 255] }));
    img.save(dir.join("tex.png")).expect("write png");
    let text = format!(
        "{}\n[[texture]]\nname = \"t\"\ntype = \"image\"\npath = \"tex.png\"\nscale = [2, 2]\n",
        BASE.replace("colour = [0.8, 0.1, 0.1]", "texture = \"t\"")
    );
    // Textures must be defined before use: [[texture]] tables may come anywhere in the file.
    let l = load_scene_str(&text, dir.path(), "test.toml").expect("valid");
    let Texture::Image { image, scale, .. } = &l.scene.textures[0] else { panic!("image texture") };
    assert_eq!((image.width, image.height, *scale), (2, 1, Vec2::splat(2.0)));
    assert_eq!(image.texels[0], Rgb::new(1.0, 0.0, 0.0));
}

#[test]
fn nan_in_a_vector_is_reported_at_its_place() {
    let text = BASE.replace("centre = [0, 0, 0]", "centre = [0, nan, 0]");
    let e = error(&text);
    assert_at(&e, line_of(&text, "nan"));
    assert!(e.to_string().contains("finite"), "{e}");
    let text = BASE.replace("radius = 1", "radius = inf");
    assert_at(&error(&text), line_of(&text, "inf"));
}

#[test]
fn negative_radius_is_an_error() {
    let text = BASE.replace("radius = 1", "radius = -2");
    let e = error(&text);
    assert_at(&e, line_of(&text, "-2"));
}

#[test]
fn empty_scene_is_an_error() {
    let e = error("");
    assert!(matches!(e, FormatError::Invalid { source: glint_scene::SceneError::Empty, .. }), "{e}");
    assert!(e.to_string().starts_with("test.toml"), "{e}");
    let e = error(&BASE[..BASE.find("[[object]]").expect("object")]);
    assert!(e.to_string().contains("empty"), "{e}");
}

#[test]
fn image_size_zero_is_an_error() {
    let text = format!("[image]\nwidth = 0\nheight = 720\n{BASE}");
    assert_at(&error(&text), line_of(&text, "width = 0"));
}

#[test]
fn huge_image_size_is_an_error() {
    let text = format!("[image]\nwidth = 1280\nheight = 1000000000\n{BASE}");
    assert_at(&error(&text), line_of(&text, "1000000000"));
    let text = format!("[image]\nwidth = 100000000000\n{BASE}");
    assert_at(&error(&text), line_of(&text, "100000000000"));
}

#[test]
fn absurd_max_depth_is_an_error() {
    let text = format!("[render]\nmax_depth = 100000\n{BASE}");
    assert_at(&error(&text), 2);
}

#[test]
fn render_mode_and_bounces_are_read_and_checked() {
    let text = format!("[render]\nmode = \"path\"\nmax_bounces = 2\n{BASE}");
    let s = load_scene_str(&text, Path::new("."), "t.toml").expect("valid").scene;
    assert_eq!((s.render.mode, s.render.max_bounces), (glint_scene::RenderMode::Path, 2));
    let e = error(&format!("[render]\nmode = \"radiosity\"\n{BASE}"));
    assert_at(&e, 2);
    assert!(e.to_string().contains("radiosity"), "{e}");
    assert_at(&error(&format!("[render]\nmode = \"path\"\nmax_bounces = 1000\n{BASE}")), 3);
}

#[test]
fn the_sampler_is_read_and_checked() {
    use glint_core::random::Sampler;
    let load = |text: &str| load_scene_str(text, Path::new("."), "t.toml").expect("valid").scene.render.sampler;
    assert_eq!(load(BASE), Sampler::Sobol);
    assert_eq!(load(&format!("[render]\nsampler = \"independent\"\n{BASE}")), Sampler::Independent);
    assert_eq!(load(&format!("[render]\nsampler = \"sobol\"\n{BASE}")), Sampler::Sobol);
    let e = error(&format!("[render]\nmode = \"path\"\nsampler = \"halton\"\n{BASE}"));
    assert_at(&e, 3);
    assert!(e.to_string().contains("halton") && e.to_string().contains("independent"), "{e}");
}

#[test]
fn malformed_toml_is_a_syntax_error_with_position() {
    let text = BASE.replace("radius = 1", "radius = = 1");
    let e = error(&text);
    assert!(matches!(e, FormatError::Syntax { .. }), "{e}");
    assert_at(&e, line_of(&text, "= ="));
    let e = error("[camera\nposition = [0, 0, 0]");
    assert_at(&e, 1);
}

#[test]
fn background_and_sky_together_are_an_error() {
    let text = format!("background = [0, 0, 0]\n{BASE}\n[sky]\ncolour = [1, 1, 1]\n");
    assert_at(&error(&text), 1);
}

#[test]
fn gradient_sky_and_lights_are_read() {
    let text = format!(
        "{BASE}\n[sky]\ntype = \"gradient\"\nzenith = [0, 0, 1]\nhorizon = [1, 1, 1]\nground = [0.2, 0.2, 0.2]\n\
         [[light]]\ntype = \"directional\"\ndirection = [0, -2, 0]\n\
         [[light]]\ntype = \"spot\"\nposition = [0, 4, 0]\nlook_at = [0, 0, 0]\nouter_angle = 40\n\
         falloff = \"inverse_square\"\nintensity = 3\n"
    );
    let s = parse(&text).expect("valid").scene;
    assert!(matches!(s.sky, Sky::Gradient { .. }));
    assert_eq!(s.lights[0], Light::Directional { direction: -Vec3::Y, colour: Rgb::ONE, intensity: 1.0 });
    let Light::Spot { direction, outer_deg, attenuation, intensity, .. } = s.lights[1] else { panic!("spot") };
    assert_eq!((direction, outer_deg, attenuation, intensity), (-Vec3::Y, 40.0, Attenuation::InverseSquare, 3.0));
}

#[test]
fn spot_cone_angles_are_checked() {
    let text = format!(
        "{BASE}\n[[light]]\ntype = \"spot\"\nposition = [0, 4, 0]\ndirection = [0, -1, 0]\n\
         inner_angle = 50\nouter_angle = 40\n"
    );
    assert_at(&error(&text), line_of(&text, "inner_angle"));
}

#[test]
fn transforms_are_composed_scale_rotate_translate() {
    let text = BASE.replace("radius = 1", "radius = 1\ntranslate = [1, 2, 3]\nrotate = [0, 90, 0]\nscale = 2");
    let s = parse(&text).expect("valid").scene;
    let m = s.objects[0].world_from_object;
    let p = m.transform_point3(Vec3::X);
    assert!((p - Vec3::new(1.0, 2.0, 1.0)).length() < 1e-5, "{p}");
    let text = BASE.replace("radius = 1", "radius = 1\nrotate_axis = [0, 0, 0]\nrotate_angle = 10");
    assert_at(&error(&text), line_of(&text, "rotate_axis"));
    let text = BASE.replace("radius = 1", "radius = 1\nscale = [1, 0, 1]");
    assert_at(&error(&text), line_of(&text, "scale"));
}

const GEM: &str = r#"
[[object]]
name = "tri"
type = "mesh"
material = "red"
vertices = [[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0]]
triangles = [[0, 1, 2], [0, 1, 3]]
"#;

#[test]
fn inline_mesh_drops_zero_area_triangles_with_a_warning() {
    let l = parse(&format!("{BASE}{GEM}")).expect("one good triangle");
    assert_eq!(l.scene.meshes[0].triangles, vec![[0, 1, 2]]);
    assert_eq!(l.warnings.len(), 1, "{:?}", l.warnings);
    assert!(l.warnings[0].starts_with("test.toml:") && l.warnings[0].contains("dropped 1"), "{:?}", l.warnings);
}

#[test]
fn inline_mesh_with_only_zero_area_triangles_is_an_error() {
    let text = format!("{BASE}{}", GEM.replace("[[0, 1, 2], [0, 1, 3]]", "[[0, 1, 3]]"));
    assert_at(&error(&text), line_of(&text, "triangles"));
}

#[test]
fn inline_mesh_index_out_of_range_is_an_error() {
    let text = format!("{BASE}{}", GEM.replace("[0, 1, 3]]", "[0, 1, 4]]"));
    let e = error(&text);
    assert_at(&e, line_of(&text, "triangles"));
    assert!(e.to_string().contains("4"), "{e}");
}

#[test]
fn inline_mesh_normals_must_match_vertices() {
    let text = format!("{BASE}{GEM}normals = [[0, 0, 1]]\n");
    assert_at(&error(&text), line_of(&text, "normals"));
}

#[test]
fn inline_mesh_smooth_shading_computes_normals() {
    let text = format!("{BASE}{GEM}shading = \"smooth\"\n");
    let s = parse(&text).expect("valid").scene;
    assert_eq!(s.meshes[0].normals.as_ref().map(Vec::len), Some(4));
}

#[test]
fn objects_without_material_share_one_default() {
    let text = BASE.replace("material = \"red\"\n", "") + "[[object]]\ntype = \"sphere\"\nradius = 2\n";
    let s = parse(&text).expect("valid").scene;
    assert_eq!(s.objects[0].material, s.objects[1].material);
    assert_eq!(s.materials[s.objects[0].material], Material::default());
}

#[test]
fn line_column_counts_characters() {
    assert_eq!(line_column("ab\ncdé\nf", 0), (1, 1));
    assert_eq!(line_column("ab\ncdé\nf", 3), (2, 1));
    assert_eq!(line_column("ab\ncdé\nf", 8), (3, 1));
    assert_eq!(line_column("ab\ncdé\nf", 100), (3, 2));
}

const QUAD_OBJ: &str = "mtllib q.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nusemtl blue\nf 1 2 3 4\n";

fn quad_files(dir: &TempDir) {
    std::fs::write(dir.join("q.obj"), QUAD_OBJ).expect("obj");
    std::fs::write(dir.join("q.mtl"), "newmtl blue\nKd 0 0 1\n").expect("mtl");
}

#[test]
fn a_mesh_file_used_twice_is_loaded_once_and_shared() {
    let dir = TempDir::new("scene-shared-mesh");
    quad_files(&dir);
    let text = format!(
        "{BASE}\n[[object]]\ntype = \"mesh\"\npath = \"q.obj\"\n\
         [[object]]\ntype = \"mesh\"\npath = \"q.obj\"\ntranslate = [2, 0, 0]\n"
    );
    let s = load_scene_str(&text, dir.path(), "test.toml").expect("valid").scene;
    assert_eq!(s.meshes.len(), 1);
    assert_eq!(s.objects[1].shape, Shape::Mesh(0));
    assert_eq!(s.objects[2].shape, Shape::Mesh(0));
    // The file's material is in the scene, and the mesh's triangles point at it.
    let m = s.meshes[0].triangle_materials.as_ref().expect("file materials")[0] as usize;
    assert_eq!(s.materials[m].name, "q.obj/blue");
    assert_eq!(s.materials[m].colour, Vec3::Z);
}

#[test]
fn an_object_material_overrides_the_files() {
    let dir = TempDir::new("scene-override");
    quad_files(&dir);
    let text =
        format!("{BASE}\n[[object]]\ntype = \"mesh\"\npath = \"q.obj\"\nmaterial = \"red\"\nshading = \"smooth\"\n");
    let s = load_scene_str(&text, dir.path(), "test.toml").expect("valid").scene;
    assert_eq!(s.meshes[0].triangle_materials, None);
    assert_eq!(s.materials[s.objects[1].material].name, "red");
    assert!(s.meshes[0].normals.is_some());
    assert!(!s.materials.iter().any(|m| m.name.contains("blue")));
}

#[test]
fn mesh_keys_are_checked() {
    let text = format!("{BASE}\n[[object]]\ntype = \"mesh\"\npath = \"q.obj\"\nradius = 2\n");
    assert_at(&error(&text), line_of(&text, "radius = 2"));
    let text = format!("{BASE}\n[[object]]\ntype = \"mesh\"\n");
    assert!(error(&text).to_string().contains("vertices"));
}

#[test]
fn a_corrupt_texture_is_an_error_naming_it() {
    let dir = TempDir::new("scene-corrupt-texture");
    std::fs::write(dir.join("bad.png"), b"\x89PNG\r\n\x1a\nnot really").expect("write");
    let text = format!("{BASE}\n[[texture]]\nname = \"t\"\ntype = \"image\"\npath = \"bad.png\"\n");
    let e = load_scene_str(&text, dir.path(), "test.toml").expect_err("corrupt");
    assert!(e.to_string().starts_with(&dir.join("bad.png").display().to_string()), "{e}");
}

#[test]
fn model_errors_name_the_model_file() {
    let dir = TempDir::new("scene-bad-model");
    std::fs::write(dir.join("bad.obj"), "v 0 0 0\nv 1 0 x\n").expect("write");
    let text = format!("{BASE}\n[[object]]\ntype = \"mesh\"\npath = \"bad.obj\"\n");
    let e = load_scene_str(&text, dir.path(), "test.toml").expect_err("bad obj");
    assert!(e.to_string().starts_with(&format!("{}: line 2", dir.join("bad.obj").display())), "{e}");
}

#[test]
fn unknown_extension_is_an_error_naming_it() {
    let e = load(Path::new("model.stl")).expect_err("stl");
    assert!(matches!(e, FormatError::UnsupportedFormat { .. }), "{e}");
    assert!(e.to_string().starts_with("model.stl") && e.to_string().contains("stl"), "{e}");
    let dir = TempDir::new("scene-mesh-ext");
    std::fs::write(dir.join("m.stl"), "solid").expect("write");
    let text = format!("{BASE}\n[[object]]\ntype = \"mesh\"\npath = \"m.stl\"\n");
    let e = load_scene_str(&text, dir.path(), "test.toml").expect_err("stl");
    assert_at(&e, line_of(&text, "m.stl"));
}

#[test]
fn the_documented_example_loads() {
    let doc = include_str!("../../../../docs/scene-format.md");
    let start = doc.find("```toml\n").expect("example") + "```toml\n".len();
    let example = &doc[start..start + doc[start..].find("```").expect("end of example")];
    let dir = TempDir::new("scene-doc-example");
    std::fs::create_dir_all(dir.join("textures")).expect("dir");
    image::RgbImage::from_pixel(4, 4, image::Rgb([180, 120, 60])).save(dir.join("textures/wood.png")).expect("png");
    let bunny =
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/meshes/stanford_bunny_bun_zipper.ply"));
    let text = if bunny.is_file() {
        example.replace("../../shared/data/meshes/stanford_bunny_bun_zipper.ply", &bunny.display().to_string())
    } else {
        eprintln!("note: {} is absent; the example's bunny is left out", bunny.display());
        let cut = example.find("[[object]]\nname = \"bunny\"").expect("bunny object");
        let end = cut + example[cut..].find("\n\n").expect("end of bunny");
        format!("{}{}", &example[..cut], &example[end..])
    };
    let l = load_scene_str(&text, dir.path(), "scene-format.md").expect("the documented example is valid");
    assert_eq!(l.scene.lights.len(), 3);
    assert_eq!(l.scene.textures.len(), 2);
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
}

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data");

fn parse_in_data(text: &str) -> Result<Loaded, FormatError> {
    load_scene_str(text, Path::new(DATA), "test.toml")
}

#[test]
fn map_skies_load_from_folders_crosses_and_latlong_files() {
    let text = format!(
        "{BASE}\n[sky]\npath = \"skyboxes/humus_magnum_512\"\nflip = \"vertical\"\nrotation = 30\nintensity = 2\nambient = true\n"
    );
    let l = parse_in_data(&text).expect("six faces");
    match &l.scene.sky {
        Sky::CubeMap { map, transform } => {
            assert_eq!(map.face_size(), 512);
            assert_eq!((transform.rotation_degrees, transform.intensity), (30.0, 2.0));
        }
        other => panic!("expected a cube map, got {other:?}"),
    }
    assert!(l.scene.sky_ambient);
    let text = format!("{BASE}\n[sky]\ntype = \"latlong\"\npath = \"envmaps/overcast_soil_puresky_1k.hdr\"\n");
    let l = parse_in_data(&text).expect("lat-long");
    assert!(matches!(&l.scene.sky, Sky::LatLong { map, .. } if map.width() == 1024 && map.height() == 512));
    assert!(!l.scene.sky_ambient);
    // Explicit faces, with a per-face fix.
    let dir = "skyboxes/hipshot_miramar_1024";
    let faces = ["right", "left", "up", "down", "front", "back"].map(|f| format!("\"{dir}/{f}.png\"")).join(", ");
    let text = format!("{BASE}\n[sky]\nfaces = [{faces}]\n[sky.face.ny]\nrotate = 180\n");
    assert!(matches!(parse_in_data(&text).expect("explicit faces").scene.sky, Sky::CubeMap { .. }));
}

#[test]
fn bad_map_skies_are_rejected_at_their_line() {
    let cases: [(&str, &str, &str); 9] = [
        ("path = \"skyboxes/cross/humus_storforsen4_cross.jpg\"\nfaces = [\"a\"]", "faces", "not both"),
        ("faces = [\"envmaps/venice_sunset_1k.hdr\"]", "faces", "6 images"),
        ("path = \"skyboxes/humus_magnum_512\"\n[sky.face.top]\nrotate = 90", "[sky.face.top]", "unknown face"),
        ("path = \"skyboxes/humus_magnum_512\"\n[sky.face.py]\nrotate = 45", "rotate = 45", "0, 90, 180 or 270"),
        ("type = \"latlong\"\npath = \"skyboxes/humus_magnum_512\"", "type = \"latlong\"", "does not match"),
        ("path = \"envmaps/venice_sunset_1k.hdr\"\nflip = \"vertical\"", "flip", "lat-long"),
        ("path = \"no/such/sky.hdr\"", "no/such", "not found"),
        ("colour = [1, 1, 1]\nrotation = 20", "rotation", "does not apply"),
        ("path = \"envmaps/venice_sunset_1k.hdr\"\nintensity = -1", "intensity", "negative"),
    ];
    for (sky, needle, message) in cases {
        let text = format!("{BASE}\n[sky]\n{sky}\n");
        let e = match parse_in_data(&text) {
            Ok(_) => panic!("expected an error for:\n{sky}"),
            Err(e) => e,
        };
        let msg = e.to_string();
        assert!(msg.contains(message), "{sky}: {msg}");
        if !message.contains("not found") {
            assert_at(&e, line_of(&text, needle));
        } else {
            assert!(msg.contains(&format!("test.toml:{}", line_of(&text, needle))), "{msg}");
        }
    }
}

#[test]
fn fresnel_f0_is_read_and_checked() {
    let text = BASE.replace("colour = [0.8, 0.1, 0.1]", "colour = [0.8, 0.1, 0.1]\nf0 = 0.04");
    assert_eq!(parse(&text).expect("f0").scene.materials[0].reflection_f0, Some(Rgb::splat(0.04)));
    let text = BASE.replace("colour = [0.8, 0.1, 0.1]", "colour = [0.8, 0.1, 0.1]\nf0 = [1.0, 0.71, 0.29]");
    assert_eq!(parse(&text).expect("gold").scene.materials[0].reflection_f0, Some(Rgb::new(1.0, 0.71, 0.29)));
    for (extra, message) in
        [("f0 = 1.5", "[0, 1]"), ("reflectivity = 0.5\nf0 = 0.04", "excludes"), ("f0 = [0.1, 0.2]", "3 numbers")]
    {
        let text = BASE.replace("colour = [0.8, 0.1, 0.1]", &format!("colour = [0.8, 0.1, 0.1]\n{extra}"));
        let e = error(&text);
        assert!(e.to_string().contains(message), "{extra}: {e}");
        assert_at(&e, line_of(&text, "f0"));
    }
}

/// BASE with an animation table under its sphere.
fn animated(table: &str) -> String {
    format!("{BASE}\n[object.animation]\n{table}\n")
}

#[test]
fn object_animations_are_read() {
    let text = animated(
        "rotate = { axis = [0, 2, 0], degrees_per_second = 45, pivot = [0, 1, 0], phase_deg = 10 }\n\
         keyframes = [\n  { time = 0, offset = [0, 0, 0] },\n  { time = 2, offset = [0, 1, 0] },\n]\n\
         repeat = \"ping-pong\"",
    );
    let s = parse(&text).expect("valid animation").scene;
    assert!(s.is_animated());
    let a = &s.animations[0];
    assert_eq!(a.target, glint_scene::AnimationTarget::Object(0));
    assert_eq!(a.pivot, Vec3::Y);
    let r = a.motion.rotation.expect("rotation");
    assert_eq!((r.axis, r.pivot, r.degrees_per_second, r.phase_deg), (Vec3::Y, Some(Vec3::Y), 45.0, 10.0));
    let k = a.motion.translation.as_ref().expect("keyframes");
    assert_eq!(k.keys, vec![(0.0, Vec3::ZERO), (2.0, Vec3::Y)]);
    assert_eq!(k.repeat, Repeat::PingPong);
    // Loaded at t = 0: the phase already turns the sphere about the pivot (0, 1, 0).
    assert_ne!(s.objects[0].world_from_object, Affine3A::IDENTITY);
    for (word, want) in [("hold", Repeat::Hold), ("loop", Repeat::Loop), ("ping_pong", Repeat::PingPong)] {
        let text = animated(&format!("keyframes = [{{ time = 1, offset = [0, 1, 0] }}]\nrepeat = \"{word}\""));
        let s = parse(&text).expect("repeat").scene;
        assert_eq!(s.animations[0].motion.translation.as_ref().expect("keys").repeat, want);
        // One key: the sphere is offset by it from the start.
        assert_eq!(s.objects[0].world_from_object, Affine3A::from_translation(Vec3::Y));
    }
    let text = animated("keyframes = [{ time = 0, offset = [0, 0, 0] }, { time = 1, offset = [1, 0, 0] }]");
    let s = parse(&text).expect("default repeat").scene;
    assert_eq!(s.animations[0].motion.translation.as_ref().expect("keys").repeat, Repeat::Loop);
    assert!(s.animations[0].motion.rotation.is_none());
}

#[test]
fn default_pivot_is_the_centre_of_the_object_and_planes_and_meshes_animate() {
    let text = format!(
        "{BASE}\n[[object]]\ntype = \"mesh\"\nvertices = [[0, 0, 0], [2, 0, 0], [0, 2, 0]]\ntriangles = [[0, 1, 2]]\n\
         translate = [10, 0, 0]\n[object.animation]\nrotate = {{ axis = [0, 0, 1], degrees_per_second = 90 }}\n\
         [[object]]\ntype = \"plane\"\nnormal = [0, 1, 0]\noffset = 1\n[object.animation]\n\
         keyframes = [{{ time = 0, offset = [0, 0, 0] }}, {{ time = 1, offset = [0, 3, 0] }}]\n"
    );
    let mut s = parse(&text).expect("valid").scene;
    assert_eq!(s.animations.len(), 2);
    assert_eq!(s.animations[0].pivot, Vec3::new(11.0, 1.0, 0.0));
    assert_eq!(s.animations[1].target, glint_scene::AnimationTarget::Object(2));
    // Loop: at t = 0.5 the plane y = −1 has risen by 1.5.
    s.set_time(0.5);
    assert!(matches!(s.objects[2].shape, Shape::Plane { offset, .. } if (offset + 0.5).abs() < 1e-6));
}

#[test]
fn light_animations_are_read() {
    let text = format!(
        "{BASE}\n[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\n[light.animation]\n\
         keyframes = [{{ time = 0, offset = [0, 0, 0] }}, {{ time = 1, offset = [2, 0, 0] }}]\nrepeat = \"hold\"\n\
         [[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\n[light.animation]\n\
         rotate = {{ axis = [1, 0, 0], degrees_per_second = 30 }}\n"
    );
    let mut s = parse(&text).expect("valid").scene;
    assert_eq!(s.animations.len(), 2);
    assert_eq!(s.animations[0].target, glint_scene::AnimationTarget::Light(0));
    assert_eq!(s.animations[0].pivot, Vec3::new(0.0, 5.0, 0.0));
    s.set_time(2.0);
    assert_eq!(s.lights[0].position(), Some(Vec3::new(2.0, 5.0, 0.0)));
    assert!(matches!(s.lights[1], Light::Directional { direction, .. } if (direction.y + 0.5).abs() < 1e-5));
}

#[test]
fn bad_animation_values_are_reported_at_their_line() {
    let k = |rest: &str| format!("keyframes = [\n  {{ time = 0, offset = [0, 0, 0] }},\n  {rest}\n]");
    let cases: Vec<(String, &str, &str)> = vec![
        ("spin = 1".into(), "spin", "spin"),
        ("rotate = { axis = [0, 1, 0], degrees_per_second = 1, speed = 2 }".into(), "speed", "speed"),
        ("rotate = { axis = [0, 0, 0], degrees_per_second = 1 }".into(), "rotate", "zero length"),
        ("rotate = { axis = [0, 1], degrees_per_second = 1 }".into(), "rotate", "3 numbers"),
        ("rotate = { axis = [0, 1, 0], degrees_per_second = nan }".into(), "rotate", "finite"),
        ("rotate = { axis = [0, 1, 0], degrees_per_second = \"fast\" }".into(), "rotate", "fast"),
        ("rotate = { axis = [0, 1, 0], degrees_per_second = 1, phase_deg = inf }".into(), "rotate", "finite"),
        ("rotate = { axis = [0, 1, 0], degrees_per_second = 1, pivot = [0, nan, 0] }".into(), "rotate", "finite"),
        ("rotate = { axis = [0, 1, 0] }".into(), "rotate", "degrees_per_second"),
        ("rotate = { degrees_per_second = 1 }".into(), "rotate", "axis"),
        ("rotate = [0, 1, 0]".into(), "rotate", "invalid type"),
        ("keyframes = []".into(), "keyframes", "at least one key"),
        (k("{ time = 0, offset = [1, 0, 0] }"), "time = 0, offset = [1", "increase strictly"),
        (k("{ time = -1, offset = [1, 0, 0] }"), "time = -1", "increase strictly"),
        (k("{ time = 1 }"), "time = 1", "offset"),
        (k("{ offset = [1, 0, 0] }"), "{ offset", "time"),
        (k("{ time = 1, offset = [1, inf, 0] }"), "time = 1", "finite"),
        (k("{ time = 1, offset = [1, 0, 0], ease = 2 }"), "ease", "ease"),
        (k("{ time = 1, offset = [1, 0] }"), "time = 1", "3 numbers"),
        (format!("{}\nrepeat = \"bounce\"", k("{ time = 1, offset = [0, 1, 0] }")), "bounce", "bounce"),
        ("rotate = { axis = [0, 1, 0], degrees_per_second = 1 }\nrepeat = \"loop\"".into(), "repeat", "repeat"),
    ];
    for (table, needle, message) in &cases {
        let text = animated(table);
        let e = error(&text);
        assert!(e.to_string().contains(message), "{table}: {e}");
        assert_at(&e, line_of(&text, needle));
    }
    // An empty table, and a value that is no table.
    let e = error(&animated(""));
    assert!(e.to_string().contains("`rotate`, `keyframes`"), "{e}");
    assert!(e.to_string().starts_with("test.toml:"), "{e}");
    let text = BASE.replace("radius = 1", "radius = 1\nanimation = 3");
    assert_at(&error(&text), line_of(&text, "animation"));
}

#[test]
fn point_clouds_and_directional_lights_limit_animations() {
    let text = format!(
        "{BASE}\n[[object]]\ntype = \"points\"\npath = \"scan.xyz\"\n[object.animation]\n\
         rotate = {{ axis = [0, 1, 0], degrees_per_second = 10 }}\n"
    );
    let e = error(&text);
    assert!(e.to_string().contains("point clouds cannot be animated"), "{e}");
    assert_at(&e, line_of(&text, "[object.animation]"));
    let directional = "[[light]]\ntype = \"directional\"\ndirection = [0, -1, 0]\n[light.animation]\n";
    let text = format!("{BASE}\n{directional}keyframes = [{{ time = 0, offset = [0, 1, 0] }}]\n");
    let e = error(&text);
    assert!(e.to_string().contains("no position"), "{e}");
    assert_at(&e, line_of(&text, "keyframes"));
    let text =
        format!("{BASE}\n{directional}rotate = {{ axis = [1, 0, 0], degrees_per_second = 10, pivot = [0, 1, 0] }}\n");
    let e = error(&text);
    assert!(e.to_string().contains("pivot"), "{e}");
    assert_at(&e, line_of(&text, "rotate"));
    let text = format!("{BASE}\n[[light]]\ntype = \"point\"\nposition = [0, 5, 0]\n[light.animation]\nwobble = 1\n");
    assert_at(&error(&text), line_of(&text, "wobble"));
}

#[test]
fn the_documented_animation_example_and_the_animated_scene_load() {
    let doc = include_str!("../../../../docs/scene-format.md");
    let section = &doc[doc.find("### Animations").expect("animation section")..];
    let start = section.find("```toml\n").expect("example") + "```toml\n".len();
    let example = &section[start..start + section[start..].find("```").expect("end of example")];
    let l = parse(&format!("{BASE}\n{example}")).expect("the documented animation is valid");
    assert_eq!(l.scene.animations.len(), 2);
    let l = load(&Path::new(SCENES).join("animated.toml")).expect("the animated scene is valid");
    assert!(l.warnings.is_empty(), "{:?}", l.warnings);
    let s = &l.scene;
    assert_eq!(s.animations.len(), 3);
    let mut moved = s.clone();
    moved.set_time(1.0);
    let object = |s: &Scene, name: &str| s.objects.iter().find(|o| o.name == name).expect("object").clone();
    let (red, red_later) = (object(s, "red sphere"), object(&moved, "red sphere"));
    let rise = Vec3::from(red_later.world_from_object.translation - red.world_from_object.translation);
    assert!((rise - Vec3::new(0.0, 1.2, 0.0)).length() < 1e-6, "{rise}");
    assert_ne!(object(s, "box").world_from_object, object(&moved, "box").world_from_object);
    assert_ne!(s.lights[0], moved.lights[0]);
    assert_eq!(s.lights[1], moved.lights[1]);
}

#[test]
fn emitters_are_one_sided_unless_the_material_says_two_sided() {
    let text = format!(
        "{BASE}\n[[material]]\nname = \"panel\"\nemission = [4, 4, 4]\n\n[[material]]\nname = \"lamp\"\nemission = [1, 1, 1]\ntwo_sided = true\n"
    );
    let loaded = parse(&text).expect("valid scene");
    let find = |name: &str| loaded.scene.materials.iter().find(|m| m.name == name).expect("material");
    assert!(!find("panel").two_sided && find("lamp").two_sided);
    let text = format!("{BASE}\n[[material]]\nname = \"m\"\ntwo_sided = \"yes\"\n");
    assert_at(&error(&text), line_of(&text, "two_sided"));
}
