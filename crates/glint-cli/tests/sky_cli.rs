//! `glint sky convert` end to end: lat-long ↔ faces round trips, crosses, and bad input that
//! fails cleanly without touching existing output.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, scratch, shared, stderr};

use glint_image::{Image, metrics::psnr_srgb8};
use glint_testkit::skies::smooth_latlong;
use std::path::Path;

fn ok(args: &[&str], dir: &Path) -> String {
    let o = glint(args, dir);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    stderr(&o)
}

fn read(path: &Path) -> Image {
    glint_image::read_image(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn latlong_to_faces_and_back_is_faithful() {
    let d = scratch("roundtrip");
    glint_image::write_hdr(&d.join("env.hdr"), &smooth_latlong(256)).unwrap();
    ok(&["sky", "convert", "env.hdr", "faces", "--to", "faces"], &d);
    for name in ["px", "nx", "py", "ny", "pz", "nz"] {
        let face = read(&d.join(format!("faces/{name}.hdr")));
        assert_eq!((face.width, face.height), (128, 128), "{name}: faces of W/2");
    }
    ok(&["sky", "convert", "faces", "back.hdr", "--to", "latlong"], &d);
    let (a, b) = (read(&d.join("env.hdr")), read(&d.join("back.hdr")));
    assert_eq!((b.width, b.height), (256, 128));
    let psnr = psnr_srgb8(&a, &b).unwrap();
    println!("synthetic lat-long → faces → lat-long: {psnr:.1} dB");
    assert!(psnr >= 35.0, "{psnr} dB");
}

#[test]
fn real_hdr_maps_round_trip_through_faces() {
    for name in ["venice_sunset_1k.hdr", "overcast_soil_puresky_1k.hdr"] {
        let Some(env) = shared(&format!("data/envmaps/{name}")) else { return };
        let d = scratch(&format!("real-{name}"));
        let env = env.to_str().unwrap();
        ok(&["sky", "convert", env, "faces", "--to", "faces"], &d);
        assert_eq!(read(&d.join("faces/pz.hdr")).width, 512);
        ok(&["sky", "convert", "faces", "back.hdr", "--to", "latlong"], &d);
        let psnr = psnr_srgb8(&read(Path::new(env)), &read(&d.join("back.hdr"))).unwrap();
        println!("{name} → faces → lat-long: {psnr:.1} dB");
        assert!(psnr >= 35.0, "{name}: {psnr} dB");
    }
}

#[test]
fn a_cross_becomes_faces_and_back() {
    let d = scratch("cross");
    glint_image::write_hdr(&d.join("env.hdr"), &smooth_latlong(64)).unwrap();
    ok(&["sky", "convert", "env.hdr", "cross.exr", "--to", "cross"], &d);
    let cross = read(&d.join("cross.exr"));
    assert_eq!((cross.width, cross.height), (4 * 32, 3 * 32));
    ok(&["sky", "convert", "cross.exr", "faces", "--to", "faces"], &d);
    // Faces keep the input's format (EXR) and are the cross's cells, bit for bit.
    let pz = read(&d.join("faces/pz.exr"));
    let (r, rc) = (pz.channel("R").unwrap(), cross.channel("R").unwrap());
    for y in 0..32 {
        for x in 0..32 {
            assert_eq!(r[y * 32 + x], rc[(32 + y) * 128 + 32 + x]);
        }
    }
    // Vertical cross and strips, and back to a horizontal cross: the same pixels.
    ok(&["sky", "convert", "faces", "v.exr", "--to", "vertical-cross"], &d);
    ok(&["sky", "convert", "v.exr", "s.exr", "--to", "strip"], &d);
    ok(&["sky", "convert", "s.exr", "again.exr", "--to", "cross"], &d);
    assert_eq!(read(&d.join("again.exr")), cross);
}

#[test]
fn the_real_cross_converts_to_png_faces() {
    let Some(cross) = shared("data/skyboxes/cross/humus_storforsen4_cross.jpg") else { return };
    let d = scratch("storforsen");
    let msg = ok(&["sky", "convert", cross.to_str().unwrap(), "faces", "--to", "faces", "--size", "256"], &d);
    assert!(!msg.contains("warning"), "{msg}");
    for name in ["px", "nx", "py", "ny", "pz", "nz"] {
        let face = read(&d.join(format!("faces/{name}.png")));
        assert_eq!((face.width, face.height), (256, 256));
    }
    // Sky above, ground below.
    let mean = |img: &Image| img.channel("G").unwrap().iter().sum::<f32>() / img.pixel_count() as f32;
    assert!(mean(&read(&d.join("faces/py.png"))) > mean(&read(&d.join("faces/ny.png"))));
}

#[test]
fn an_upside_down_set_is_flagged_and_flip_fixes_it() {
    let Some(set) = shared("data/skyboxes/humus_magnum_512") else { return };
    let d = scratch("magnum");
    let set = set.to_str().unwrap();
    let msg = ok(&["sky", "convert", set, "a.png", "--to", "cross", "--size", "64"], &d);
    assert!(msg.contains("warning") && msg.contains("flip = \"vertical\""), "{msg}");
    let msg = ok(&["sky", "convert", set, "b.png", "--to", "cross", "--size", "64", "--flip", "vertical"], &d);
    assert!(!msg.contains("warning"), "{msg}");
    let msg = ok(&["sky", "convert", "b.png", "c.png", "--to", "cross", "-q"], &d);
    assert!(msg.is_empty(), "{msg}");
}

#[test]
fn ldr_output_of_hdr_warns_about_clipping() {
    let d = scratch("clip");
    glint_image::write_hdr(&d.join("env.hdr"), &smooth_latlong(32)).unwrap();
    let msg = ok(&["sky", "convert", "env.hdr", "env.png", "--to", "latlong", "--size", "8"], &d);
    assert!(msg.contains("clipped"), "{msg}");
    assert_eq!(read(&d.join("env.png")).width, 16);
}

/// Every failing conversion: non-zero exit, a message naming the problem, existing output
/// untouched, no stray files.
#[test]
fn bad_input_fails_cleanly_without_touching_the_output() {
    let d = scratch("sky-bad");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    std::fs::create_dir(d.join("faces")).unwrap();
    std::fs::write(d.join("faces/right.png"), b"mine").unwrap();
    std::fs::write(d.join("corrupt.hdr"), b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 8 +X 16\n\x02\x02").unwrap();
    glint_image::write_hdr(&d.join("square.hdr"), &Image::from_rgb(4, 4, &[[1.0; 3]; 16])).unwrap();
    glint_image::write_hdr(&d.join("env.hdr"), &smooth_latlong(16)).unwrap();
    std::fs::create_dir(d.join("five")).unwrap();
    for name in ["px", "nx", "py", "ny", "pz"] {
        glint_image::write_hdr(&d.join(format!("five/{name}.hdr")), &Image::from_rgb(2, 2, &[[1.0; 3]; 4])).unwrap();
    }
    let cases: &[(&[&str], &str)] = &[
        (&["sky", "convert", "missing.hdr", "out.png", "--to", "latlong"], "missing.hdr"),
        (&["sky", "convert", "corrupt.hdr", "out.png", "--to", "latlong"], "corrupt.hdr"),
        (&["sky", "convert", "square.hdr", "out.png", "--to", "latlong"], "4x4"),
        (&["sky", "convert", "five", "out.png", "--to", "cross"], "missing cube face nz"),
        (&["sky", "convert", "env.hdr", "out.png", "--to", "cross", "--flip", "vertical"], "lat-long"),
        (&["sky", "convert", "env.hdr", "out.png", "--to", "latlong", "--size", "0"], "out.png"),
        (&["sky", "convert", "env.hdr", "out.png", "--to", "faces"], "not a folder"),
        (&["sky", "convert", "env.hdr", "faces", "--to", "faces"], "right.png"),
        (&["sky", "convert", "env.hdr", "out.tga", "--to", "cross"], "out.tga"),
        (&["sky", "convert", "env.hdr", "no/such/dir/out.png", "--to", "cross"], "out.png"),
        (&["sky", "convert", "env.hdr", "out.png", "--to", "sphere"], "sphere"),
    ];
    for (args, needle) in cases {
        assert_fails_cleanly(args, needle, &d);
        assert_eq!(std::fs::read(d.join("faces/right.png")).unwrap(), b"mine", "{args:?} touched faces/");
    }
    let mut left: Vec<String> =
        std::fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into()).collect();
    left.sort();
    assert_eq!(left, ["corrupt.hdr", "env.hdr", "faces", "five", "out.png", "square.hdr"]);
    assert_eq!(std::fs::read_dir(d.join("faces")).unwrap().count(), 1);
}

/// `glint render --sky`: the sky replaces the scene's, turns with `--sky-rotation`, scales with
/// `--sky-intensity`; bad sky options fail without touching the output.
#[test]
fn render_takes_a_sky_from_the_command_line() {
    let d = scratch("render-sky");
    // A lat-long map, red toward −Z (ahead of the default camera), blue toward +X.
    let (w, h) = (64u32, 32u32);
    let mut r = vec![0.0f32; (w * h) as usize];
    let mut b = vec![0.0f32; (w * h) as usize];
    for y in 0..h as usize {
        for x in 0..w as usize {
            let u = (x as f32 + 0.5) / w as f32;
            r[y * w as usize + x] = if (u - 0.5).abs() < 0.1 { 1.0 } else { 0.0 };
            b[y * w as usize + x] = if (u - 0.75).abs() < 0.1 { 1.0 } else { 0.0 };
        }
    }
    let mut env = Image::new(w, h);
    env.add_channel("R", r).unwrap();
    env.add_channel("G", vec![0.0; (w * h) as usize]).unwrap();
    env.add_channel("B", b).unwrap();
    glint_image::write_exr(&d.join("env.exr"), &env).unwrap();
    // The demo scene's camera looks at its objects; look up and ahead past them into the sky.
    let view = ["--eye", "0,50,0", "--look-at", "0,50.2,-1", "--width", "16", "--height", "16", "-q"];
    let centre = |file: &str| {
        let img = read(&d.join(file));
        let i = 8 * 16 + 8;
        (img.channel("R").unwrap()[i], img.channel("B").unwrap()[i])
    };
    let mut args = vec!["render", "--sky", "env.exr", "-o", "ahead.exr"];
    args.extend(view);
    ok(&args, &d);
    let (r, b) = centre("ahead.exr");
    assert!(r > 0.9 && b < 0.1, "ahead should be red: r {r} b {b}");
    // Turned by 90° counter-clockwise seen from above, what was to the right (+X) is ahead.
    let mut args =
        vec!["render", "--sky", "env.exr", "--sky-rotation", "90", "--sky-intensity", "2", "-o", "turned.exr"];
    args.extend(view);
    ok(&args, &d);
    let (r, b) = centre("turned.exr");
    assert!(r < 0.1 && b > 1.8, "after the turn, ahead should be blue at intensity 2: r {r} b {b}");
    // Bad options: non-zero exit, the file named, out.png untouched.
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    std::fs::write(d.join("odd.png"), b"not a png").unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["render", "--sky", "nowhere.hdr", "-o", "out.png"], "nowhere.hdr"),
        (&["render", "--sky", "odd.png", "-o", "out.png"], "odd.png"),
        (&["render", "--sky", "env.exr", "--sky-flip", "vertical", "-o", "out.png"], "lat-long"),
        (&["render", "--sky", "env.exr", "--sky-intensity", "-1", "-o", "out.png"], "intensity"),
        (&["render", "--sky-flip", "vertical", "-o", "out.png"], "--sky-flip"),
    ];
    for (args, needle) in cases {
        assert_fails_cleanly(args, needle, &d);
    }
}
