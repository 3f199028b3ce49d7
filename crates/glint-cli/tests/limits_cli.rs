//! Limits end to end (issue 20; docs/limits.md): the memory budget refuses what does not fit
//! instead of aborting, no output holds a non-finite value however bright the scene, and
//! negative numbers on the command line are read as values.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, repo, scratch, stderr};
use std::path::Path;
use std::process::{Command, Output};

/// One triangle in front of the default camera.
fn write_triangle(dir: &Path) {
    std::fs::write(dir.join("tri.obj"), "v -1 -1 -3\nv 1 -1 -3\nv 0 1 -3\nf 1 2 3\n").unwrap();
}

/// `glint args` under `ulimit -v kib` (the address-space limit, RLIMIT_AS).
fn glint_under_ulimit(kib: u64, args: &[&str], dir: &Path) -> Output {
    let bin = env!("CARGO_BIN_EXE_glint");
    let script = format!("ulimit -v {kib} && exec \"$0\" \"$@\"");
    Command::new("sh").arg("-c").arg(script).arg(bin).args(args).current_dir(dir).output().expect("sh runs")
}

/// A clean refusal: exit code 1 (not 134, the abort of a failed allocation, nor a signal) and
/// a message containing every needle.
fn assert_refused(o: &Output, needles: &[&str]) {
    let msg = stderr(o);
    assert_eq!(o.status.code(), Some(1), "expected a clean error, got {:?}: {msg}", o.status);
    assert!(!msg.contains("panicked") && !msg.contains("memory allocation"), "{msg}");
    for n in needles {
        assert!(msg.contains(n), "message does not say {n:?}: {msg}");
    }
}

#[test]
fn a_film_larger_than_max_memory_is_refused_with_what_it_needs() {
    let d = scratch("limits-max-memory");
    write_triangle(&d);
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    for mode in ["whitted", "path"] {
        let args =
            ["--max-memory", "100M", "render", "tri.obj", "--mode", mode, "--width", "32768", "--height", "4096"];
        let o = glint(&[&args[..], &["-o", "out.png"]].concat(), &d);
        assert_refused(&o, &["32768 x 4096", "GiB", "memory budget of 100.00 MiB", "--max-memory"]);
        assert_eq!(std::fs::read(d.join("out.png")).unwrap(), b"precious");
    }
    // A PNG's Whitted frame is encoded as it is traced, with no float film: 1024² needs about
    // 8 MB and fits in 20 MB; the same frame to EXR (film and every AOV) does not.
    let args = ["--max-memory", "20M", "render", "tri.obj", "--width", "1024", "--height", "1024", "-q"];
    let o = glint(&[&args[..], &["-o", "fits.png"]].concat(), &d);
    assert!(o.status.success() && d.join("fits.png").exists(), "{}", stderr(&o));
    let o = glint(&[&args[..], &["-o", "film.exr"]].concat(), &d);
    assert_refused(&o, &["1024 x 1024", "film and buffers", "memory budget of 20.00 MiB"]);
    assert!(!d.join("film.exr").exists());
    // The option itself is checked.
    assert_fails_cleanly(&["--max-memory", "lots", "render", "-o", "out.png"], "--max-memory", &d);
}

#[test]
fn a_mesh_whose_trees_exceed_max_memory_is_refused() {
    let d = scratch("limits-mesh-memory");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    let dragon = repo().join("../shared/data/meshes/stanford_dragon_100k.ply");
    if !dragon.exists() {
        eprintln!("skipped: {} is not here", dragon.display());
        return;
    }
    let dragon = dragon.display().to_string();
    // The file (3 MB) loads within 20 MB; its trees (about 26 MB) do not.
    let args = ["--max-memory", "20M", "render", &dragon, "--width", "32", "--height", "32", "-o", "out.png"];
    assert_refused(&glint(&args, &d), &["100000 triangles", "memory budget of 20.00 MiB", "--max-memory"]);
    assert_eq!(std::fs::read(d.join("out.png")).unwrap(), b"precious");
    let args = ["--max-memory", "200M", "render", &dragon, "--width", "32", "--height", "32", "-o", "ok.png"];
    let o = glint(&args, &d);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn a_film_larger_than_ulimit_v_is_refused_not_aborted() {
    let d = scratch("limits-ulimit");
    write_triangle(&d);
    // 1.5 GiB of address space: enough to start, far from the 16 GiB frame (a film with every
    // AOV, as EXR output needs).
    let args = ["render", "tri.obj", "--mode", "whitted", "--width", "32768", "--height", "4096", "-o", "out.exr"];
    let o = glint_under_ulimit(1_572_864, &args, &d);
    assert_refused(&o, &["32768 x 4096", "ulimit -v"]);
    assert!(!d.join("out.exr").exists());
    // A frame that fits renders under the same limit.
    let o = glint_under_ulimit(1_572_864, &["render", "tri.obj", "--width", "64", "--height", "48", "-q"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// Six `n`² PNG faces of one colour (continuous at every edge) in `dir/sky`.
fn write_flat_faces(dir: &Path, n: u32) {
    let sky = dir.join("sky");
    std::fs::create_dir_all(&sky).unwrap();
    let face = glint_image::Image::from_rgb(n, n, &vec![[0.1, 0.2, 0.5]; (n * n) as usize]);
    for name in ["px", "nx", "py", "ny", "pz", "nz"] {
        glint_image::write_png(&sky.join(format!("{name}.png")), &face, &glint_image::PngOptions::default()).unwrap();
    }
}

#[test]
fn sky_faces_larger_than_the_budget_are_refused_before_decoding() {
    let d = scratch("limits-sky");
    write_triangle(&d);
    write_flat_faces(&d, 2048);
    // Six 2048² faces keep about 450 MiB once read: refused under 100 MiB.
    let args = ["--max-memory", "100M", "render", "tri.obj", "--sky", "sky", "--width", "32", "--height", "24"];
    let o = glint(&[&args[..], &["-o", "out.png"]].concat(), &d);
    assert_refused(&o, &["six sky faces", "memory budget of 100.00 MiB"]);
    // Under 700 MiB they fit when decoded one after another (not all six at once) and render.
    let args = ["--max-memory", "700M", "render", "tri.obj", "--sky", "sky", "--width", "32", "--height", "24"];
    let o = glint(&[&args[..], &["-o", "out.png", "-q"]].concat(), &d);
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A diffuse floor under an emitting sphere of radiance `emission` per channel.
fn write_bright_scene(dir: &Path, emission: &str) {
    let scene = format!(
        "[image]\nwidth = 48\nheight = 32\n\n[camera]\nposition = [0.0, 1.5, 5.0]\nlook_at = [0.0, 0.5, 0.0]\nfov = 45\n\n\
         [[material]]\nname = \"lamp\"\nemission = [{emission}, {emission}, {emission}]\n\n\
         [[material]]\nname = \"floor\"\ncolour = [0.7, 0.7, 0.7]\n\n\
         [[object]]\ntype = \"plane\"\nnormal = [0.0, 1.0, 0.0]\noffset = 0.0\nmaterial = \"floor\"\n\n\
         [[object]]\ntype = \"sphere\"\ncentre = [0.0, 1.0, 0.0]\nradius = 0.5\nmaterial = \"lamp\"\n"
    );
    std::fs::write(dir.join("bright.toml"), scene).unwrap();
}

#[test]
fn no_output_holds_a_non_finite_value_however_bright_the_emitter() {
    let d = scratch("limits-bright");
    for emission in ["1e37", "3e38"] {
        write_bright_scene(&d, emission);
        for filter in ["none", "guided", "bilateral", "atrous"] {
            for (mode, out) in [("path", "out.exr"), ("path", "out.png"), ("whitted", "out.exr")] {
                let args = ["render", "bright.toml", "--mode", mode, "--filter", filter, "--spp", "4", "-o", out];
                let o = glint(&args, &d);
                let msg = stderr(&o);
                assert!(o.status.success(), "{emission} {mode} {filter}: {msg}");
                let image = glint_image::read_image(&d.join(out)).unwrap();
                for c in &image.channels {
                    // Z is +inf where nothing was hit, by definition (docs/aovs.md).
                    if c.name == "Z" {
                        assert!(c.data.iter().all(|v| !v.is_nan()), "{emission} {mode} {filter}: NaN depth");
                        continue;
                    }
                    let bad = c.data.iter().filter(|v| !v.is_finite()).count();
                    assert_eq!(bad, 0, "{emission} {mode} {filter} {out}: {bad} non-finite values in {}", c.name);
                }
                if mode == "path" {
                    // The clamp is counted, not hidden.
                    assert!(msg.contains("clamped to it"), "{emission} {filter}: {msg}");
                }
                if mode == "whitted" {
                    break; // Whitted has no filter.
                }
            }
        }
    }
}

#[test]
fn negative_numbers_are_values_not_flags() {
    let d = scratch("limits-negative");
    write_triangle(&d);
    let o = glint(
        &["render", "tri.obj", "--eye", "-1,0.5,2", "--look-at", "0,0,-3", "--width", "16", "--height", "12", "-q"],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    for (args, needle) in [
        (&["render", "tri.obj", "--spp", "-1", "-o", "out.png"][..], "-1 is negative"),
        (&["render", "tri.obj", "--width", "-16", "-o", "out.png"][..], "--width"),
    ] {
        let o = glint(args, &d);
        let msg = stderr(&o);
        assert_fails_cleanly(args, needle, &d);
        assert!(!msg.contains("-- -1"), "the suggested fix is wrong: {msg}");
    }
}

#[test]
fn duplicate_triangles_are_merged_with_a_warning() {
    let d = scratch("limits-duplicates");
    let mut obj = String::from("v -1 -1 -3\nv 1 -1 -3\nv 0 1 -3\nv 0 0 -4\n");
    obj.push_str(&"f 1 2 3\n".repeat(20_000));
    obj.push_str("f 2 3 1\nf 1 3 2\nf 1 2 4\n"); // a rotation (a copy), the back face and another
    std::fs::write(d.join("dup.obj"), obj).unwrap();
    let o = glint(&["render", "dup.obj", "--width", "160", "--height", "120", "-o", "out.png"], &d);
    let msg = stderr(&o);
    assert!(o.status.success(), "{msg}");
    assert!(msg.contains("dup.obj: dropped 20000 duplicate triangles"), "{msg}");
    assert!(msg.contains("3 triangles"), "{msg}");
}

#[test]
fn messages_name_the_real_cause() {
    let d = scratch("limits-messages");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    // A cube scaled by 1e30: not "zero area".
    let mut cube = String::new();
    for x in [-1e30, 1e30] {
        for y in [-1e30, 1e30] {
            for z in [-1e30, 1e30] {
                cube.push_str(&format!("v {x:e} {y:e} {z:e}\n"));
            }
        }
    }
    cube.push_str("f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n");
    std::fs::write(d.join("huge.obj"), cube).unwrap();
    // One vertex far away: not "light #0: position must be finite" nor a camera message.
    std::fs::write(d.join("far.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 3e38 -3e38 0\nf 1 2 3\nf 2 3 4\n").unwrap();
    for (file, needle) in [("huge.obj", "mesh \"huge\": vertex 1 is at (-1e30"), ("far.obj", "vertex 4")] {
        let args = ["render", file, "-o", "out.png"];
        assert_fails_cleanly(&args, needle, &d);
        let msg = stderr(&glint(&args, &d));
        assert!(msg.contains("coordinates within ±1e18"), "{msg}");
        assert!(!msg.contains("zero area") && !msg.contains("must be finite"), "{msg}");
    }
    // An OS error is printed once, not in the context and again as its source.
    write_triangle(&d);
    let o = glint(&["render", "tri.obj", "-o", "no-such-folder/out.png"], &d);
    let msg = stderr(&o);
    assert!(!o.status.success());
    assert_eq!(msg.matches("(os error 2)").count(), 1, "{msg}");
}

#[test]
fn a_sky_face_turned_alone_is_found_and_fixed_with_sky_fix_auto() {
    let d = scratch("limits-sky-turned");
    write_triangle(&d);
    // A continuous cube map: a smooth lat-long map converted to six EXR faces (lossless).
    glint_image::write_exr(&d.join("ll.exr"), &glint_testkit::skies::smooth_latlong(128)).unwrap();
    let o = glint(&["sky", "convert", "ll.exr", "faces", "--to", "faces", "--size", "32"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let render = |sky: &str, out: &str, extra: &[&str]| {
        let args = [&["render", "tri.obj", "--sky", sky, "--width", "32", "--height", "24", "-o", out][..], extra];
        let o = glint(&args.concat(), &d);
        assert!(o.status.success(), "{}", stderr(&o));
        stderr(&o)
    };
    let plain = render("faces", "a.exr", &[]);
    assert!(!plain.contains("do not meet"), "{plain}");
    // The down face turned 180° against glint's convention, as some skybox packs store it.
    std::fs::create_dir_all(d.join("turned")).unwrap();
    for name in ["px", "nx", "py", "ny", "pz", "nz"] {
        let mut face = glint_image::read_image(&d.join(format!("faces/{name}.exr"))).unwrap();
        if name == "ny" {
            for c in &mut face.channels {
                c.data.reverse(); // a half turn of a row-major image
            }
        }
        glint_image::write_exr(&d.join(format!("turned/{name}.exr")), &face).unwrap();
    }
    let warned = render("turned", "b.exr", &[]);
    assert!(warned.contains("[sky.face.ny] rotate = 180") && warned.contains("--sky-fix auto"), "{warned}");
    let fixed = render("turned", "c.exr", &["--sky-fix", "auto"]);
    assert!(fixed.contains("applied the fix"), "{fixed}");
    assert_eq!(std::fs::read(d.join("c.exr")).unwrap(), std::fs::read(d.join("a.exr")).unwrap());
    assert_ne!(std::fs::read(d.join("b.exr")).unwrap(), std::fs::read(d.join("a.exr")).unwrap());
}

/// The commands of docs/limits.md, as written: each refused or rendered as its comment
/// says (`model.obj` is one triangle).
#[test]
fn the_commands_of_the_limits_docs_run() {
    let d = scratch("limits-docs");
    std::fs::write(d.join("model.obj"), "v -1 -1 -3\nv 1 -1 -3\nv 0 1 -3\nf 1 2 3\n").unwrap();
    let doc = std::fs::read_to_string(glint_testkit::repo().join("docs/limits.md")).unwrap();
    let block = &doc[doc.find("```sh").expect("a command block") + 5..];
    let block = &block[..block.find("```").unwrap()];
    let mut ran = 0;
    for line in block.lines().filter(|l| l.starts_with("glint ")) {
        let (command, outcome) = line.split_once('#').unwrap();
        let args: Vec<&str> = command.split_whitespace().skip(1).collect();
        let o = glint(&args, &d);
        match outcome.trim() {
            "refused" => assert_refused(&o, &["memory budget", "--max-memory"]),
            "fits" => assert!(o.status.success(), "{line}: {}", stderr(&o)),
            other => panic!("{line}: unknown outcome {other:?}"),
        }
        ran += 1;
    }
    assert_eq!(ran, 2);
}

/// A texture whose decoded texels exceed the budget is refused from its header, before it is
/// decoded, naming the image file (or the glTF and its image) and its size; with room it
/// renders.
#[test]
fn a_texture_larger_than_the_budget_is_refused_before_decoding() {
    let d = scratch("limits-texture");
    let obj = "mtllib m.mtl\nv -1 -1 -3\nv 1 -1 -3\nv 0 1 -3\nvt 0 0\nvt 1 0\nvt 0.5 1\nusemtl t\nf 1/1 2/2 3/3\n";
    std::fs::write(d.join("tex.obj"), obj).unwrap();
    std::fs::write(d.join("m.mtl"), "newmtl t\nKd 1 1 1\nmap_Kd big.png\n").unwrap();
    let n = 2048;
    let img = glint_image::Image::from_rgb(n, n, &vec![[0.3, 0.6, 0.2]; (n * n) as usize]);
    glint_image::write_png(&d.join("big.png"), &img, &glint_image::PngOptions::default()).unwrap();
    // 2048² texels at 36 bytes each from decoder to texture: about 144 MiB.
    let o =
        glint(&["--max-memory", "64M", "render", "tex.obj", "--width", "32", "--height", "24", "-o", "out.png"], &d);
    assert_refused(&o, &["big.png", "the texture image (2048 x 2048)", "memory budget of 64.00 MiB"]);
    assert!(!d.join("out.png").exists());
    let o = glint(
        &["--max-memory", "400M", "render", "tex.obj", "--width", "32", "--height", "24", "-q", "-o", "out.png"],
        &d,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    // The same image as a glTF material's base colour: refused naming the glTF and images[0].
    let floats: [f32; 15] = [-1.0, -1.0, -3.0, 1.0, -1.0, -3.0, 0.0, 1.0, -3.0, 0.0, 0.0, 1.0, 0.0, 0.5, 1.0];
    std::fs::write(d.join("tri.bin"), floats.iter().flat_map(|f| f.to_le_bytes()).collect::<Vec<u8>>()).unwrap();
    let gltf = r#"{"asset":{"version":"2.0"},"buffers":[{"uri":"tri.bin","byteLength":60}],
      "bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":24}],
      "accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[-1,-1,-3],"max":[1,1,-3]},
                   {"bufferView":1,"componentType":5126,"count":3,"type":"VEC2"}],
      "images":[{"uri":"big.png"}],"textures":[{"source":0}],
      "materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],
      "meshes":[{"primitives":[{"attributes":{"POSITION":0,"TEXCOORD_0":1},"material":0}]}],
      "nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}],"scene":0}"#;
    std::fs::write(d.join("tex.gltf"), gltf).unwrap();
    let args = ["--max-memory", "64M", "render", "tex.gltf", "--width", "32", "--height", "24", "-o", "out.png"];
    assert_refused(
        &glint(&args, &d),
        &["tex.gltf", "the texture images[0] (2048 x 2048)", "memory budget of 64.00 MiB"],
    );
    let args = ["--max-memory", "400M", "render", "tex.gltf", "--width", "32", "--height", "24", "-q", "-o", "g.png"];
    let o = glint(&args, &d);
    assert!(o.status.success(), "{}", stderr(&o));
}
