//! Cameras beyond the pinhole, from a TOML scene through `glint render`: a thin lens keeps its
//! focal plane sharp and blurs an edge off it by the circle of confusion the lens equation
//! gives; an orthographic camera shows a sphere at the same size whatever its distance.

#![allow(clippy::unwrap_used, clippy::expect_used)] // test code: a failure is the report

mod common;

use common::{assert_fails_cleanly, glint, scratch, stderr};

const W: usize = 128;
const H: usize = 32;

/// A scene with an unlit white `shape` (its colour is its ambient term) on black, seen by a
/// camera at the origin looking down −Z with the `[camera]` keys `camera`.
fn scene(camera: &str, shape: &str) -> String {
    format!(
        r#"background = [0, 0, 0]
ambient = [1, 1, 1]
[image]
width = {W}
height = {H}
[camera]
position = [0, 0, 0]
{camera}
[[material]]
name = "white"
colour = [1, 1, 1]
ambient = 1.0
diffuse = 0.0
specular = 0.0
{shape}
"#
    )
}

/// The right half-plane x ≥ 0 at z = −4 (a quad far wider than the view).
const HALF_PLANE: &str = r#"[[object]]
type = "mesh"
material = "white"
vertices = [[0, -50, -4], [50, -50, -4], [50, 50, -4], [0, 50, -4]]
triangles = [[0, 1, 2], [0, 2, 3]]"#;

/// The red channel of `scene` rendered in Whitted mode at 64 samples per pixel.
fn render(name: &str, scene: &str) -> Vec<f32> {
    let d = scratch(&format!("lens-{name}"));
    std::fs::write(d.join("s.toml"), scene).unwrap();
    let o = glint(&["render", "s.toml", "--spp", "64", "-o", "out.exr"], &d);
    assert!(o.status.success(), "{name}: {}", stderr(&o));
    let img = glint_image::read_image(&d.join("out.exr")).unwrap();
    assert_eq!((img.width as usize, img.height as usize), (W, H));
    img.channel("R").unwrap().to_vec()
}

/// Columns of the middle row that are neither background nor surface: the edge's width.
fn edge_width(red: &[f32]) -> usize {
    red[(H / 2) * W..(H / 2 + 1) * W].iter().filter(|&&v| v > 0.03 && v < 0.97).count()
}

#[test]
fn a_thin_lens_is_sharp_at_its_focus_and_blurs_by_its_circle_of_confusion() {
    let fov = "look_at = [0, 0, -4]\nfov = 45";
    let pinhole = edge_width(&render("pinhole", &scene(fov, HALF_PLANE)));
    // focus_distance defaults to the distance to look_at: the plane's.
    let focused = edge_width(&render("focused", &scene(&format!("{fov}\naperture_radius = 0.4"), HALF_PLANE)));
    let near = format!("{fov}\naperture_radius = 0.4\nfocus_distance = 2");
    let blurred = edge_width(&render("blurred", &scene(&near, HALF_PLANE)));
    eprintln!("edge widths in columns: pinhole {pinhole}, focused {focused}, blurred {blurred}");
    assert!(pinhole <= 1 && focused <= 2, "pinhole {pinhole}, focused {focused}");
    // A point 4 away seen through a lens of radius R focused at 2 spreads over a disc of
    // radius R·(1/2 − 1/4)·f pixels on the image (f = H / (2 tan 22.5°) = 38.6): 3.9 px.
    // The edge ramps over that disc's diameter, 7.7 columns.
    assert!((6..=9).contains(&blurred), "blurred edge {blurred} columns wide");
}

#[test]
fn an_orthographic_camera_shows_a_sphere_at_one_size_at_any_distance() {
    let coverage = |z: f32| {
        let sphere = format!("[[object]]\ntype = \"sphere\"\nmaterial = \"white\"\ncentre = [0, 0, {z}]\nradius = 1");
        let red = render(&format!("ortho{z}"), &scene("forward = [0, 0, -1]\nview_height = 4", &sphere));
        red.iter().sum::<f32>()
    };
    let (near, far) = (coverage(-3.0), coverage(-300.0));
    // The view is 4 high and 16 wide: a pixel is 1/8 on a side, the unit disc π·64 pixels.
    let disc = std::f32::consts::PI * 64.0;
    assert!((near - disc).abs() < 0.01 * disc, "{near} px² vs {disc}");
    assert!((near - far).abs() < 1e-3 * disc, "near {near}, far {far}");
}

#[test]
fn lens_keys_are_checked() {
    let d = scratch("lens-bad");
    std::fs::write(d.join("out.png"), b"precious").unwrap();
    let cases = [
        ("forward = [0, 0, -1]\naperture_radius = 0.1", "focus_distance"),
        ("look_at = [0, 0, -4]\naperture_radius = -1", "must be > 0"),
        ("forward = [0, 0, -1]\nview_height = 2\nfov = 30", "no field of view"),
        ("forward = [0, 0, -1]\nview_height = 2\naperture_radius = 1", "exclude each other"),
        ("forward = [0, 0, -1]\nfocus_distance = 3", "needs `aperture_radius`"),
    ];
    for (i, (camera, needle)) in cases.into_iter().enumerate() {
        let name = format!("s{i}.toml");
        std::fs::write(d.join(&name), scene(camera, HALF_PLANE)).unwrap();
        assert_fails_cleanly(&["render", &name, "-o", "out.png"], needle, &d);
    }
}
