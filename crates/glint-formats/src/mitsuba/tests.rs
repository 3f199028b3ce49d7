//! Tests of the Mitsuba reader on the shared Mitsuba scenes and on inline bad input. Reference
//! values marked "Mitsuba" were read from Mitsuba 3.9.1 (`scalar_rgb`, `mi.traverse`).

use super::*;
use crate::test_util::TempDir;
use glint_core::glam::{DMat4, DVec3};
use glint_core::{Vec2, Vec3};
use glint_scene::{
    Attenuation, BsdfKind, Distribution, Fov, Lens, Light, Shape, Sky, SpotFalloff, Tex, Texture, ViewSize,
};

const DATA: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../../shared/data/mitsuba");

fn data(rel: &str) -> PathBuf {
    Path::new(DATA).join(rel)
}

fn close(a: f32, b: f64, rel: f64) -> bool {
    (f64::from(a) - b).abs() <= rel * b.abs().max(1e-6)
}

fn assert_rgb(c: Rgb, want: [f64; 3]) {
    for (i, w) in want.iter().enumerate() {
        assert!(close(c[i], *w, 1e-4), "{c} vs {want:?}");
    }
}

fn xml_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            xml_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "xml") {
            out.push(p);
        }
    }
}

#[test]
fn every_shared_scene_loads() {
    let mut files = Vec::new();
    xml_files(&data("scenes"), &mut files);
    xml_files(&data("tests/scenes"), &mut files);
    files.sort();
    assert!(files.len() >= 28, "found {} scene files under {DATA}", files.len());
    let mut strict_failures = Vec::new();
    for f in &files {
        let fragment = f.components().any(|c| c.as_os_str() == "fragments");
        match load(f, &[], true) {
            Ok(m) => {
                m.scene.validate().expect("a loaded scene is valid");
                assert!(!fragment || !m.scene.objects.is_empty());
            }
            // Fragments are pieces of scenes: alone they may lack a search path or shapes.
            Err(e) if fragment => assert!(e.to_string().starts_with('/'), "{e}"),
            Err(e) => panic!("{}: {e}", f.display()),
        }
        if !fragment && let Err(e) = load(f, &[], false) {
            let text = e.to_string();
            assert!(text.contains(".xml:"), "a strict error names the place: {text}");
            strict_failures.push(text);
        }
    }
    // Strictly too: every shared scene is one glint represents.
    assert!(strict_failures.is_empty(), "{strict_failures:#?}");
}

#[test]
fn cornell_box_in_detail() {
    let m = load(&data("scenes/cbox/cbox.xml"), &[], false).expect("cbox loads");
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let s = &m.settings;
    assert_eq!((s.width, s.height, s.spp, s.crop), (256, 256, Some(128), None));
    assert_eq!(s.integrator, MitsubaIntegrator::Path { max_depth: Some(6), rr_depth: 5, hide_emitters: false });
    assert_eq!(s.filter, PixelFilter::Gaussian { stddev: 0.5 });
    assert!(!s.camera_flip_x);
    // The render defaults say so: Mitsuba's film filter, no image filter, emitters shown.
    let r = &m.scene.render;
    assert_eq!(
        (r.pixel_filter, r.image_filter, r.hide_emitters),
        (PixelFilter::Gaussian { stddev: 0.5 }, false, false)
    );
    let c = &m.scene.camera;
    assert_eq!(c.position, Vec3::new(278.0, 273.0, -800.0));
    assert!((c.forward - Vec3::Z).length() < 1e-6 && (c.up - Vec3::Y).length() < 1e-6);
    // fov_axis smaller: kept as the smaller axis (on this square film, x and y alike).
    assert_eq!(c.fov, Fov::Smaller(39.3077));
    assert_eq!(m.scene.objects.len(), 8);
    assert_eq!((m.scene.render.width, m.scene.render.height), (256, 256));
    // Spectral reflectances and radiance as Mitsuba's RGB variant sees them (Mitsuba).
    let bsdf_of = |name: &str| {
        let o = m.scene.objects.iter().position(|o| {
            m.scene.meshes[match o.shape {
                Shape::Mesh(i) => i,
                _ => unreachable!(),
            }]
            .name
            .contains(name)
        });
        let mat = &m.scene.materials[m.scene.objects[o.expect(name)].material];
        (mat.clone(), m.scene.bsdfs[mat.bsdf.expect("a bsdf")].clone())
    };
    let (light, light_bsdf) = bsdf_of("luminaire");
    assert_rgb(light.emission, [20.7108, 10.8546, 2.77115]);
    let BsdfKind::Diffuse { reflectance: Tex::Value(r) } = light_bsdf else { panic!("{light_bsdf:?}") };
    assert_rgb(r, [0.776367, 0.77981, 0.776029]);
    let (red, red_bsdf) = bsdf_of("redwall");
    let BsdfKind::Diffuse { reflectance: Tex::Value(r) } = red_bsdf else { panic!("{red_bsdf:?}") };
    assert_rgb(r, [0.49132, 0.0492281, 0.0509219]);
    assert_eq!(red.colour, r, "Whitted colour is the reflectance");
    assert_eq!(red.emission, Rgb::ZERO);
    let (_, green) = bsdf_of("greenwall");
    let BsdfKind::Diffuse { reflectance: Tex::Value(g) } = green else { panic!() };
    assert_rgb(g, [0.0682825, 0.39776, 0.0862909]);
    let (_, bx) = bsdf_of("smallbox");
    let BsdfKind::Diffuse { reflectance: Tex::Value(b) } = bx else { panic!() };
    assert_rgb(b, [0.735013, 0.735625, 0.736264]);
    // The luminaire moved down by 0.5.
    let lum = m.scene.objects.iter().find(|o| m.scene.materials[o.material].emission != Rgb::ZERO);
    assert_eq!(lum.expect("an emissive object").world_from_object.translation, Vec3::new(0.0, -0.5, 0.0).into());
}

#[test]
fn cornell_box_from_fragments() {
    // base.xml, bsdfs-rgb.xml and shapes.xml included; an area emitter declared after the
    // shapes that refer to it.
    let m = load(&data("scenes/cbox/cbox-rgb.xml"), &[], false).expect("cbox-rgb loads");
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    assert_eq!((m.settings.spp, m.settings.filter), (Some(256), PixelFilter::Box));
    assert_eq!(m.scene.objects.len(), 8);
    let emissive: Vec<Rgb> = m.scene.materials.iter().map(|m| m.emission).filter(|e| *e != Rgb::ZERO).collect();
    assert_eq!(emissive, vec![Rgb::new(18.387, 10.9873, 2.75357)]);
}

#[test]
fn defines_override_defaults() {
    let defs = [("spp".to_string(), "7".to_string()), ("max_depth".to_string(), "-1".to_string())];
    let m = load(&data("scenes/cbox/cbox.xml"), &defs, false).expect("cbox loads");
    assert_eq!(m.settings.spp, Some(7));
    assert_eq!(m.settings.integrator, MitsubaIntegrator::Path { max_depth: None, rr_depth: 5, hide_emitters: false });
}

#[test]
fn matpreview_in_detail() {
    let m = load(&data("scenes/matpreview/matpreview.xml"), &[], false).expect("matpreview loads");
    let s = &m.settings;
    assert_eq!((s.width, s.height, s.spp), (683, 512, Some(64)));
    assert_eq!(s.integrator, MitsubaIntegrator::Path { max_depth: None, rr_depth: 5, hide_emitters: false });
    // fov_axis smaller on a wide film is y: x fov = 2 atan(tan(fov/2) · aspect), and at any
    // other size the smaller side keeps the 28.8415° (a tall image: its width).
    let c = &m.scene.camera;
    assert_eq!(c.fov, Fov::Smaller(28.8415));
    let half = (28.8415f32.to_radians() / 2.0).tan();
    assert!((c.tan_half_vertical(683.0 / 512.0) - half).abs() < 1e-6);
    assert!((c.tan_half_vertical(0.5) * 0.5 - half).abs() < 1e-6);
    let tris: Vec<usize> = m
        .scene
        .objects
        .iter()
        .map(|o| match o.shape {
            Shape::Mesh(i) => m.scene.meshes[i].triangles.len(),
            _ => 0,
        })
        .collect();
    assert_eq!(tris, vec![512, 3936, 57152]);
    let kinds: Vec<&BsdfKind> =
        m.scene.objects.iter().map(|o| &m.scene.bsdfs[m.scene.materials[o.material].bsdf.unwrap_or(0)]).collect();
    assert!(matches!(kinds[0], BsdfKind::Diffuse { reflectance: Tex::Texture(_) }));
    let BsdfKind::Plastic { eta, diffuse_reflectance, nonlinear: false, .. } = kinds[2] else {
        panic!("{:?}", kinds[2])
    };
    assert!(close(*eta, 1.899_473_786, 1e-6), "{eta}"); // Mitsuba
    assert_eq!(*diffuse_reflectance, Tex::Value(Rgb::new(0.94, 0.271, 0.361)));
    let Sky::LatLong { transform, .. } = &m.scene.sky else { panic!("an envmap sky") };
    assert_eq!(transform.intensity, 3.0);
    assert!(transform.map_from_world().is_some());
    // The checkerboard: 8× on Mitsuba's uv, color0 0.4 where both halves agree.
    let Tex::Texture(t) = (match kinds[0] {
        BsdfKind::Diffuse { reflectance } => *reflectance,
        _ => unreachable!(),
    }) else {
        unreachable!()
    };
    let tex = &m.scene.textures[t];
    // Mitsuba uv (0.01, 0.01) → scaled (0.08, 0.08): both halves low → color0. glint's v is 1 − v.
    assert_eq!(tex.evaluate(Vec2::new(0.01, 0.99)), Rgb::splat(0.4));
    assert_eq!(tex.evaluate(Vec2::new(0.07, 0.99)), Rgb::splat(0.2));
    assert_eq!(tex.evaluate(Vec2::new(0.07, 1.0 - 0.07)), Rgb::splat(0.4));
}

#[test]
fn serialized_meshes_by_index() {
    let file = data("scenes/matpreview/matpreview.serialized");
    let want = [(289, 512), (2078, 3936), (29439, 57152)]; // Mitsuba
    for (i, (v, t)) in want.into_iter().enumerate() {
        let mesh = read_serialized(&file, i as u32).expect("mesh reads");
        assert_eq!((mesh.positions.len(), mesh.triangles.len()), (v, t));
        assert!(mesh.normals.is_some() && mesh.uvs.is_some());
    }
    let first = read_serialized(&file, 0).expect("mesh 0");
    assert!((first.positions[0] - Vec3::new(-0.504_866_24, 0.574_720_86, 0.784_379)).length() < 1e-6);
    let err = read_serialized(&file, 3).expect_err("out of range");
    assert!(err.to_string().contains("shape_index 3"), "{err}");
    // A damaged copy is an error, not a panic.
    let dir = TempDir::new("mitsuba-serialized");
    let bytes = std::fs::read(&file).expect("read");
    for cut in [10, bytes.len() / 2] {
        let mut damaged = bytes.clone();
        damaged[cut..cut + 64].iter_mut().for_each(|b| *b ^= 0x5A);
        let path = dir.join("bad.serialized");
        std::fs::write(&path, &damaged).expect("write");
        for i in 0..3 {
            let _ = read_serialized(&path, i);
        }
    }
    std::fs::write(dir.join("short.serialized"), [1u8, 2, 3]).expect("write");
    assert!(read_serialized(&dir.join("short.serialized"), 0).is_err());
}

#[test]
fn hello_direct_and_point_lights() {
    let m = load(&data("scenes/hello.xml"), &[], false).expect("hello loads");
    assert_eq!(
        m.settings.integrator,
        MitsubaIntegrator::Direct { emitter_samples: 4, bsdf_samples: 0, hide_emitters: false }
    );
    assert_eq!((m.settings.width, m.settings.height, m.settings.spp), (1024, 768, Some(4)));
    assert_eq!(m.settings.filter, PixelFilter::Box);
    assert_eq!(m.scene.lights.len(), 2);
    let Light::Point { position, colour, attenuation, intensity } = m.scene.lights[0] else { panic!() };
    assert_eq!(position, Vec3::new(2.0, -6.0, 4.5));
    assert!(close(colour.x * intensity, 10.0 / std::f64::consts::PI, 1e-6));
    assert_eq!(attenuation, Attenuation::InverseSquare);
    // Rotations compose in document order: the second left-multiplies the first.
    let r1 = DMat4::from_axis_angle(DVec3::new(0.0, 1.0, 1.0).normalize(), 15f64.to_radians());
    let r2 = DMat4::from_axis_angle(DVec3::Z, (-15f64).to_radians());
    let want = (r2 * r1).as_mat4();
    let got = glint_core::Mat4::from(m.scene.objects[0].world_from_object);
    assert!(got.abs_diff_eq(want, 1e-6), "{got} vs {want}");
}

#[test]
fn spectra_convert_as_mitsuba() {
    let uniform = Value::Spectrum(props::Spectrum::Uniform(2.0));
    let e = spectrum::to_rgb(&uniform, spectrum::Use::Emitter).expect("colour");
    for (a, b) in e.iter().zip([2.40959, 1.89658, 1.81783]) {
        assert!((a - b).abs() < 1e-4 * b, "{e:?}"); // Mitsuba
    }
    assert_eq!(spectrum::to_rgb(&uniform, spectrum::Use::Bounded), Some([2.0; 3]));
    // Reflectances are clamped to [0, 1], emitters only at 0.
    let list = Value::Spectrum(props::Spectrum::List { wavelengths: vec![400.0, 700.0], values: vec![3.0, 3.0] });
    let r = spectrum::to_rgb(&list, spectrum::Use::Bounded).expect("colour");
    assert!(r.iter().all(|&c| c <= 1.0));
    let r = spectrum::to_rgb(&list, spectrum::Use::Emitter).expect("colour");
    assert!(r.iter().any(|&c| c > 1.0));
}

use props::Value;

#[test]
fn envmap_rotation_reproduces_mitsubas_texels() {
    // Mitsuba: v = to_world⁻¹ d, uv = (atan2(v.x, −v.z)/2π, acos(v.y)/π) (mod 1).
    let to_world = DMat4::from_axis_angle(DVec3::new(0.3, 1.0, -0.2).normalize(), 1.1) * DMat4::from_rotation_y(0.4);
    let (w, h) = (64.0f64, 32.0f64);
    for d in [Vec3::X, Vec3::Y * 0.9 + Vec3::Z * 0.1, -Vec3::Z, Vec3::new(0.3, -0.5, 0.8), Vec3::new(-0.7, 0.1, -0.2)] {
        let d = d.normalize();
        let v = to_world.inverse().transform_vector3(d.as_dvec3()).normalize();
        let mu = (v.x.atan2(-v.z) / std::f64::consts::TAU).rem_euclid(1.0);
        let mv = v.y.clamp(-1.0, 1.0).acos() / std::f64::consts::PI;
        let (gu, gv) = glint_scene::latlong_uv(emitters::map_direction(&to_world, d));
        let (gu, gv) = (f64::from(gu).rem_euclid(1.0), f64::from(gv));
        // Same column (texel centres at (i + ½)/W in both) and the same row to within Mitsuba's
        // row placement (j/(H − 1) vs glint's (j + ½)/H).
        assert_eq!((mu * w).floor(), (gu * w).floor(), "u {mu} vs {gu} for {d}");
        assert!((mv * (h - 1.0) - (gv * h - 0.5)).abs() <= 0.5 + 1e-3, "v {mv} vs {gv} for {d}");
    }
    assert!(emitters::envmap_map_from_world(&DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))).is_none());
}

#[test]
fn spot_and_directional_lights() {
    let m = load(&data("tests/scenes/spot_light/test_spot_direct.xml"), &[], false).expect("loads");
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let Light::Spot { inner_deg, outer_deg, falloff, direction, colour, projection, .. } = m.scene.lights[0] else {
        panic!()
    };
    // The scene's own textures/ folder holds the projected pattern (found before <path>).
    let Some(p) = projection else { panic!("a projected texture") };
    assert!(matches!(&m.scene.textures[p.texture], glint_scene::Texture::Image { image, .. } if image.width > 1));
    assert_eq!((inner_deg, outer_deg, falloff), (15.0, 20.0, SpotFalloff::LinearAngle));
    assert!((direction - Vec3::Z).length() < 1e-6);
    assert!(close(colour.x, 5.0 / std::f64::consts::PI, 1e-6));
    assert_eq!(m.scene.sky, Sky::Colour(Rgb::splat(0.1)));
    assert_eq!(
        m.settings.integrator,
        MitsubaIntegrator::Direct { emitter_samples: 1, bsdf_samples: 1, hide_emitters: false }
    );
}

#[test]
fn bsdf_defaults_and_wrappers() {
    let dir = TempDir::new("mitsuba-bsdfs");
    let scene = dir.join("s.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0">
  <bsdf type="roughconductor" id="rc"/>
  <bsdf type="conductor" id="al"><string name="material" value="Al"/></bsdf>
  <bsdf type="twosided" id="ts"><ref id="al"/></bsdf>
  <bsdf type="dielectric" id="d"><string name="int_ior" value="water"/><float name="ext_ior" value="1.0"/></bsdf>
  <shape type="rectangle"><ref id="ts"/></shape>
  <shape type="cube"><ref id="rc"/><transform name="to_world"><translate x="1"/><scale value="2"/></transform></shape>
  <shape type="sphere"><ref id="d"/><point name="center" value="0 1 0"/><float name="radius" value="0.5"/></shape>
  <shape type="disk"/>
  <shape type="cylinder"><float name="radius" value="0.2"/></shape>
</scene>"#,
    )
    .expect("write");
    let m = load(&scene, &[], false).expect("loads");
    let b = &m.scene.bsdfs;
    let rc = b.iter().find_map(|k| {
        if let BsdfKind::RoughConductor { roughness, eta, k, .. } = k { Some((roughness, eta, k)) } else { None }
    });
    let (r, eta, k) = rc.expect("rough conductor");
    assert_eq!((r.distribution, r.alpha_u, r.sample_visible), (Distribution::Beckmann, Tex::Value(0.1), true));
    assert_eq!((*eta, *k), (Rgb::ZERO, Rgb::ONE));
    let al = b.iter().find_map(|k| if let BsdfKind::Conductor { eta, k, .. } = k { Some((*eta, *k)) } else { None });
    // Mitsuba's Al (glint-scene's presets, read from Mitsuba 3.9.1).
    let (eta, k) = al.expect("Al");
    assert_rgb(eta, [1.657_501, 0.880_404_7, 0.521_244_5]);
    assert_rgb(k, [9.223_811, 6.269_502, 4.837_004]);
    assert!(b.iter().any(|k| matches!(k, BsdfKind::TwoSided { front, back } if front == back)));
    assert!(b.iter().any(|k| matches!(k, BsdfKind::Dielectric { eta, .. } if *eta == 1.333)));
    assert_eq!(m.scene.objects.len(), 5);
    let cube = &m.scene.objects[1];
    assert_eq!(cube.world_from_object.translation, Vec3::new(2.0, 0.0, 0.0).into(), "scale after translate");
    let Shape::Mesh(i) = cube.shape else { panic!() };
    assert_eq!(m.scene.meshes[i].triangles.len(), 12);
    assert_eq!(m.scene.objects[2].shape, Shape::Sphere { centre: Vec3::Y, radius: 0.5 });
    // Whitted: the mirror-like aluminium, glass with its ior.
    let ts_mat = &m.scene.materials[m.scene.objects[0].material];
    assert!(ts_mat.reflection_f0.is_some_and(|f| f.x > 0.8));
    assert!((m.scene.materials[m.scene.objects[2].material].ior - 1.333).abs() < 1e-6);
    // Rectangle: Mitsuba uv (x+1)/2, (y+1)/2 → glint v flipped; normal +z.
    let Shape::Mesh(r) = m.scene.objects[0].shape else { panic!() };
    let rect = &m.scene.meshes[r];
    assert_eq!(rect.uvs.as_ref().map(|u| u[0]), Some(Vec2::new(0.0, 1.0)));
    let t = rect.triangle(0);
    assert!((t[1] - t[0]).cross(t[2] - t[0]).z > 0.0);
}

fn write(dir: &TempDir, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).expect("write");
    p
}

const SHAPE: &str = r#"<shape type="rectangle"/>"#;

#[test]
fn bad_input_is_a_clear_error() {
    let dir = TempDir::new("mitsuba-bad");
    let cases: &[(&str, String, &str)] = &[
        ("malformed.xml", "<scene><shape type=\"rectangle\"></scene>".into(), "malformed.xml:1:"),
        ("unknown.xml", format!("<scene>{SHAPE}<shape type=\"teapot\"/></scene>"), "shape 'teapot'"),
        ("missing.xml", "<scene><shape type=\"obj\"><string name=\"filename\" value=\"nope.obj\"/></shape></scene>".into(), "nope.obj: file not found"),
        ("param.xml", format!("<scene>{SHAPE}<sensor type=\"perspective\"><float name=\"fov\" value=\"$fov\"/></sensor></scene>"), "$fov"),
        ("number.xml", format!("<scene>{SHAPE}<sensor type=\"perspective\"><float name=\"fov\" value=\"4x5\"/></sensor></scene>"), "'4x5' is not a number"),
        ("nan.xml", format!("<scene>{SHAPE}<sensor type=\"perspective\"><float name=\"fov\" value=\"NaN\"/></sensor></scene>"), "not a finite number"),
        ("unused.xml", "<scene><shape type=\"rectangle\"><float name=\"wobble\" value=\"1\"/></shape></scene>".into(), "'wobble'"),
        ("ref.xml", "<scene><shape type=\"rectangle\"><ref id=\"ghost\"/></shape></scene>".into(), "ghost"),
        ("root.xml", "<mesh/>".into(), "<scene>"),
        ("empty.xml", "<scene/>".into(), "invalid scene"),
        ("rgb.xml", "<scene><shape type=\"rectangle\"><bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"1 2\"/></bsdf></shape></scene>".into(), "2 numbers"),
    ];
    for (name, text, want) in cases {
        let path = write(&dir, name, text);
        let err = load(&path, &[], false).expect_err(name);
        let msg = err.to_string();
        assert!(msg.contains(want), "{name}: {msg}");
        assert!(msg.starts_with(&dir.path().display().to_string()), "{name}: {msg}");
    }
    // Circular includes.
    write(&dir, "a.xml", "<scene><include filename=\"b.xml\"/></scene>");
    write(&dir, "b.xml", "<scene><include filename=\"a.xml\"/></scene>");
    let err = load(&dir.join("a.xml"), &[], false).expect_err("circular");
    assert!(err.to_string().contains("circular include"), "{err}");
    // Lenient: one warning each, the nearest thing substituted.
    let m = load(&dir.join("unknown.xml"), &[], true).expect("lenient");
    let about: Vec<&String> = m.warnings.iter().filter(|w| w.contains("teapot")).collect();
    assert_eq!(about.len(), 1, "{:?}", m.warnings);
    assert!(about[0].contains("unknown.xml:1:"), "{about:?}");
    assert_eq!(m.scene.objects.len(), 1);
}

#[test]
fn includes_paths_and_mirrored_cameras() {
    let dir = TempDir::new("mitsuba-include");
    std::fs::create_dir_all(dir.join("sub/meshes")).expect("mkdir");
    std::fs::write(dir.join("sub/meshes/tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").expect("write");
    write(
        &dir,
        "part.xml",
        "<scene><default name=\"w\" value=\"32\"/><shape type=\"obj\"><string name=\"filename\" value=\"meshes/tri.obj\"/></shape></scene>",
    );
    let main = write(
        &dir,
        "main.xml",
        r#"<scene><path value="sub"/><include filename="part.xml"/>
  <sensor type="perspective"><float name="fov" value="60"/>
    <transform name="to_world"><scale x="-1"/><lookat origin="0 0 5" target="0 0 0" up="0 1 0"/></transform>
    <film type="hdrfilm"><integer name="width" value="$w"/><integer name="height" value="16"/>
      <integer name="crop_offset_x" value="4"/><integer name="crop_width" value="8"/><rfilter type="tent"/></film>
  </sensor></scene>"#,
    );
    let m = load(&main, &[], false).expect("loads");
    assert_eq!(m.scene.objects.len(), 1);
    assert_eq!((m.settings.width, m.settings.crop), (32, Some([4, 0, 8, 16])));
    assert_eq!(m.settings.filter, PixelFilter::Tent { radius: 1.0 });
    assert!(m.settings.camera_flip_x);
    assert!((m.scene.camera.forward + Vec3::Z).length() < 1e-6);
}

#[test]
fn the_crate_dispatches_xml_here() {
    let loaded = crate::load(&data("scenes/cbox/cbox.xml")).expect("cbox through glint_formats::load");
    assert_eq!(loaded.scene.objects.len(), 8);
    assert!(matches!(loaded.scene.textures.first(), None | Some(Texture::Image { .. })));
}

/// Mitsuba's checkerboard has one parity as a colour (`eval`: color0 where both halves of uv
/// agree) and the other as a float (`eval_1`: color0 where they differ); a float parameter
/// reads its twin. (Mitsuba's textured-roughness render tests fail with one reading for both.)
#[test]
fn a_checkerboard_read_as_a_float_has_mitsubas_other_parity() {
    let dir = TempDir::new("mitsuba-checker");
    let scene = dir.join("s.xml");
    std::fs::write(
        &scene,
        r#"<scene version="3.0.0">
  <texture type="checkerboard" id="c"><float name="color0" value="0.05"/><float name="color1" value="0.3"/></texture>
  <bsdf type="diffuse" id="d"><ref name="reflectance" id="c"/></bsdf>
  <bsdf type="roughconductor" id="r"><ref name="alpha" id="c"/></bsdf>
  <shape type="rectangle"><ref id="d"/></shape>
  <shape type="rectangle"><ref id="r"/></shape>
</scene>"#,
    )
    .expect("write");
    let m = load(&scene, &[], false).expect("loads");
    let colour = m.scene.bsdfs.iter().find_map(|k| match k {
        BsdfKind::Diffuse { reflectance: Tex::Texture(t) } => Some(*t),
        _ => None,
    });
    let float = m.scene.bsdfs.iter().find_map(|k| match k {
        BsdfKind::RoughConductor { roughness, .. } => match roughness.alpha_u {
            Tex::Texture(t) => Some(t),
            Tex::Value(_) => None,
        },
        _ => None,
    });
    let (colour, float) = (colour.expect("textured diffuse"), float.expect("textured alpha"));
    // Mitsuba uv (0.2, 0.2) (glint's v is 1 − v): both halves low.
    let at = |t: usize| m.scene.textures[t].evaluate(Vec2::new(0.2, 0.8)).x;
    assert_eq!((at(colour), at(float)), (0.05, 0.3));
}

#[test]
fn independent_samplers_stay_independent_and_stratified_ones_become_sobol() {
    use glint_core::random::Sampler;
    let dir = TempDir::new("mitsuba-sampler");
    let path = dir.join("s.xml");
    for (sampler, want) in [
        ("", Sampler::Independent),
        (r#"<sampler type="independent"><integer name="sample_count" value="8"/></sampler>"#, Sampler::Independent),
        (r#"<sampler type="ldsampler"/>"#, Sampler::Sobol),
        (r#"<sampler type="multijitter"/>"#, Sampler::Sobol),
    ] {
        let xml = format!(
            r#"<scene version="3.0.0"><sensor type="perspective"><film type="hdrfilm"/>{sampler}</sensor><shape type="sphere"/></scene>"#
        );
        std::fs::write(&path, xml).expect("write");
        assert_eq!(load(&path, &[], false).expect("loads").scene.render.sampler, want, "{sampler}");
    }
}

#[test]
fn hide_emitters_and_the_film_filter_reach_the_render_defaults() {
    let dir = TempDir::new("mitsuba-hide");
    let path = dir.join("s.xml");
    let scene = |integrator: &str, rfilter: &str| {
        format!(
            r#"<scene version="3.0.0">{integrator}
  <sensor type="perspective"><film type="hdrfilm">{rfilter}</film></sensor>
  <shape type="sphere"/>
</scene>"#
        )
    };
    std::fs::write(
        &path,
        scene(
            r#"<integrator type="path"><boolean name="hide_emitters" value="true"/></integrator>"#,
            r#"<rfilter type="tent"/>"#,
        ),
    )
    .expect("write");
    let r = load(&path, &[], false).expect("loads").scene.render;
    assert!(r.hide_emitters);
    assert_eq!(r.pixel_filter, PixelFilter::Tent { radius: 1.0 });
    // A filter wider than glint takes is an error at its element.
    std::fs::write(&path, scene("", r#"<rfilter type="gaussian"><float name="stddev" value="50"/></rfilter>"#))
        .expect("write");
    let err = load(&path, &[], false).expect_err("too wide").to_string();
    assert!(err.contains("s.xml:2") && err.contains("radius"), "{err}");
}

#[test]
fn a_textured_area_emitter_becomes_an_emission_texture() {
    let dir = TempDir::new("mitsuba-area-tex");
    let path = dir.join("s.xml");
    std::fs::write(
        &path,
        r#"<scene version="3.0.0">
  <shape type="rectangle">
    <emitter type="area">
      <texture type="checkerboard" name="radiance">
        <rgb name="color0" value="2"/><rgb name="color1" value="0"/>
      </texture>
    </emitter>
  </shape>
</scene>"#,
    )
    .expect("write");
    let m = load(&path, &[], false).expect("loads");
    let mat = &m.scene.materials[m.scene.objects[0].material];
    let t = mat.emission_texture.expect("an emission texture");
    assert_eq!(mat.emission, Rgb::ONE);
    // Mitsuba uv (0.1, 0.1): color0; glint's v is 1 − v.
    assert_eq!(mat.emission_at(Vec2::new(0.1, 0.9), &m.scene.textures), Rgb::splat(2.0));
    assert_eq!(m.scene.textures[t].evaluate(Vec2::new(0.6, 0.9)), Rgb::ZERO);
}

#[test]
fn thin_lens_and_orthographic_sensors_keep_their_lens() {
    let dir = TempDir::new("mitsuba-lens");
    let sensor = |kind: &str, inner: &str| {
        format!(
            r#"<scene>{SHAPE}<sensor type="{kind}">{inner}
    <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="20"/></film>
  </sensor></scene>"#
        )
    };
    let thin = write(
        &dir,
        "thin.xml",
        &sensor("thinlens", r#"<float name="aperture_radius" value="0.25"/><float name="focus_distance" value="7"/>"#),
    );
    let m = load(&thin, &[], false).expect("thinlens");
    assert_eq!(m.scene.camera.lens, Lens::ThinLens { aperture_radius: 0.25, focus_distance: 7.0 });
    // Mitsuba requires the aperture; the focus defaults to the far clip.
    let far = write(
        &dir,
        "far.xml",
        &sensor("thinlens", r#"<float name="aperture_radius" value="1"/><float name="far_clip" value="50"/>"#),
    );
    let m = load(&far, &[], false).expect("default focus");
    assert_eq!(m.scene.camera.lens, Lens::ThinLens { aperture_radius: 1.0, focus_distance: 50.0 });
    let bare = write(&dir, "bare.xml", &sensor("thinlens", ""));
    let msg = load(&bare, &[], false).expect_err("no aperture").to_string();
    assert!(msg.contains("bare.xml:1:") && msg.contains("aperture_radius"), "{msg}");

    // The view is twice as wide as to_world scales x (camera-space x spans [-1, 1]).
    let scaled = r#"<transform name="to_world"><scale x="3" y="3"/><lookat origin="0 0 5" target="0 0 0" up="0 1 0"/></transform>"#;
    let m = load(&write(&dir, "ortho.xml", &sensor("orthographic", scaled)), &[], false).expect("orthographic");
    assert_eq!(m.scene.camera.lens, Lens::Orthographic(ViewSize::HalfWidth(3.0)));
    assert!(m.warnings.is_empty(), "{:?}", m.warnings);
    let squashed = scaled.replace(r#"y="3""#, r#"y="1""#);
    let m = load(&write(&dir, "squash.xml", &sensor("orthographic", &squashed)), &[], false).expect("non-uniform");
    assert!(m.warnings.iter().any(|w| w.contains("square pixels")), "{:?}", m.warnings);
}

#[test]
fn mesh_attribute_textures_read_the_plys_attributes() {
    let dir = TempDir::new("mitsuba-attr");
    std::fs::write(
        dir.join("tri.ply"),
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
         property float r\nproperty float g\nproperty float b\nelement face 1\nproperty list uchar int vertex_indices\n\
         end_header\n0 0 0 1 0 0\n1 0 0 0 1 0\n0 1 0 0 0 1\n3 0 1 2\n",
    )
    .expect("write");
    let scene = |inner: &str| {
        format!(r#"<scene><shape type="ply"><string name="filename" value="tri.ply"/>{inner}</shape></scene>"#)
    };
    let attr = |name: &str| {
        format!(
            r#"<texture type="mesh_attribute" name="reflectance"><string name="name" value="{name}"/><float name="scale" value="0.5"/></texture>"#
        )
    };
    let m = load(
        &write(&dir, "ok.xml", &scene(&format!(r#"<bsdf type="diffuse">{}</bsdf>"#, attr("vertex_color")))),
        &[],
        false,
    )
    .expect("mesh_attribute");
    assert!(m.scene.textures.contains(&Texture::MeshAttribute { name: "vertex_color".into(), scale: 0.5 }));
    let Shape::Mesh(i) = m.scene.objects[0].shape else { panic!("a mesh") };
    assert_eq!(m.scene.meshes[i].attributes[0].name, "vertex_color");

    let bad = write(&dir, "bad.xml", &scene(&format!(r#"<bsdf type="diffuse">{}</bsdf>"#, attr("color"))));
    let msg = load(&bad, &[], false).expect_err("bad name").to_string();
    assert!(msg.contains("bad.xml:1:") && msg.contains("neither vertex_ nor face_"), "{msg}");
    let normals = format!(
        r#"<bsdf type="normalmap">{}<bsdf type="diffuse"/></bsdf>"#,
        attr("vertex_color").replace("reflectance", "normalmap")
    );
    let msg = load(&write(&dir, "nm.xml", &scene(&normals)), &[], false).expect_err("normal map").to_string();
    assert!(msg.contains("normalmap reads its texture by uv"), "{msg}");
    let lit = format!(r#"<emitter type="area">{}</emitter>"#, attr("vertex_color").replace("reflectance", "radiance"));
    assert!(load(&write(&dir, "lit.xml", &scene(&lit)), &[], false).is_err());
    let m = load(&dir.join("lit.xml"), &[], true).expect("lenient");
    assert!(m.warnings.iter().any(|w| w.contains("mesh_attribute")), "{:?}", m.warnings);
}

#[test]
fn a_spot_lights_texture_is_projected() {
    let dir = TempDir::new("mitsuba-spot-texture");
    let spot = |cutoff: u32| {
        format!(
            r#"<scene>{SHAPE}<emitter type="spot"><float name="cutoff_angle" value="{cutoff}"/>
  <texture name="texture" type="checkerboard"/>
  <transform name="to_world"><lookat origin="0 0 0" target="0 0 1" up="0 1 0"/></transform></emitter></scene>"#
        )
    };
    let m = load(&write(&dir, "spot.xml", &spot(30)), &[], false).expect("textured spot");
    let Some(Light::Spot { projection: Some(p), direction, .. }) = m.scene.lights.first().copied() else {
        panic!("a textured spot: {:?}", m.scene.lights)
    };
    assert!((p.tan_cutoff - 30f32.to_radians().tan()).abs() < 1e-6);
    // The light frame is right-handed with +z along the beam.
    assert!((direction - Vec3::Z).length() < 1e-6 && (p.up - Vec3::Y).length() < 1e-6);
    assert!(p.right.cross(p.up).dot(direction) > 0.99, "{:?}", p);
    let msg = load(&write(&dir, "wide.xml", &spot(95)), &[], false).expect_err("too wide").to_string();
    assert!(msg.contains("wide.xml:1:") && msg.contains("below 90"), "{msg}");
}
