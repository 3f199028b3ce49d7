//! Scenes from other renderers on the command line (issue 17; docs/scene-format.md): a Mitsuba
//! XML scene renders in path mode with its own size, sample count and depth, `-D` sets its
//! parameters, `--lenient` turns what glint cannot represent into warnings, and the options
//! are refused for inputs they do not apply to.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, scratch, stderr};

fn mitsuba(rel: &str) -> Option<String> {
    glint_testkit::shared(&format!("data/mitsuba/{rel}")).map(|p| p.display().to_string())
}

#[test]
fn a_mitsuba_scene_renders_with_its_parameters() {
    let Some(scene) = mitsuba("tests/scenes/floating_sphere/test_directional_direct.xml") else { return };
    let d = scratch("import-xml");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    // Its film is 48x48 and its spp a $spp parameter (default 32); -D spp=3 sets it.
    let o = glint(&["render", &scene, "-D", "spp=3", "--filter", "none", "-o", "x.exr"], &d);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = glint_image::read_image(&d.join("x.exr")).unwrap();
    assert_eq!((img.width, img.height), (48, 48));
    assert!(img.channel("SampleCount").unwrap().iter().all(|&n| n == 3.0));
    assert!(img.channel("Variance.R").is_some());
    // A parameter without a value is refused, naming it.
    assert_fails_cleanly(&["render", &scene, "-D", "spp", "-o", "out.png"], "NAME=VALUE", &d);
}

#[test]
fn lenient_reads_what_strict_refuses_and_options_fit_their_inputs() {
    let Some(spot) = mitsuba("tests/scenes/spot_light/test_spot_direct.xml") else { return };
    let d = scratch("import-lenient");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    // The spot light's texture: an error naming file and line, strictly; a warning leniently.
    assert_fails_cleanly(&["render", &spot, "-o", "out.png"], "test_spot_direct.xml:11", &d);
    let o = glint(&["render", &spot, "--lenient", "-D", "spp=1", "-o", "a.png"], &d);
    assert!(o.status.success() && stderr(&o).contains("warning"), "{}", stderr(&o));
    // Options for other renderers' files, refused for glint's own.
    assert_fails_cleanly(&["render", "-D", "spp=4", "-o", "out.png"], "Mitsuba XML", &d);
    assert_fails_cleanly(&["render", "--camera-name", "Cam", "-o", "out.png"], "glTF", &d);
    assert_fails_cleanly(&["render", &spot, "--camera-name", "Cam", "-o", "out.png"], "glTF", &d);
}

/// The commands of docs/scene-format.md's Mitsuba section, as written (with `$M` the shared
/// data's Mitsuba folder).
#[test]
fn the_mitsuba_commands_of_the_docs_run() {
    let Some(m) = mitsuba("") else { return };
    let d = scratch("import-docs");
    let doc = std::fs::read_to_string(glint_testkit::repo().join("docs/scene-format.md")).unwrap();
    let section = &doc[doc.find("## Mitsuba 3 XML").expect("the section")..];
    let block = &section[section.find("```sh").unwrap() + 5..];
    let block = &block[..block.find("```").unwrap()];
    let mut ran = 0;
    for line in block.lines().filter(|l| l.starts_with("glint ")) {
        let command = line.split('#').next().unwrap().trim().replace("$M/", &m);
        let args: Vec<&str> = command.split_whitespace().skip(1).collect();
        let o = glint(&args, &d);
        assert!(o.status.success(), "{command}: {}", stderr(&o));
        let out = args[args.iter().position(|a| *a == "-o").unwrap() + 1];
        assert!(d.join(out).exists(), "{command} wrote no {out}");
        ran += 1;
    }
    assert_eq!(ran, 3);
}
