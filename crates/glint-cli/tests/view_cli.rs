//! `glint bench view`: the viewer's frame loop, headless, end to end.
#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
use common::{glint, scratch, shared, stderr};

#[test]
fn the_headless_frame_loop_measures_every_mode() {
    let dir = scratch("bench-view");
    let o = glint(&["bench", "view", "--frames", "3", "--width", "64", "--height", "48"], &dir);
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.starts_with("Whitted 64x48, 3 frames") && text.contains("fps") && text.contains("Mrays/s"), "{text}");
    let o = glint(
        &["bench", "view", "--mode", "path", "--frames", "2", "--width", "48", "--height", "32", "--per-frame"],
        &dir,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("frame 1:") && text.contains("filter"), "{text}");
    if let Some(bunny) = shared("data/pointclouds/stanford_bunny_rawscan_40256.xyz") {
        let o = glint(
            &["bench", "view", bunny.to_str().unwrap(), "--frames", "3", "--width", "64", "--height", "48"],
            &dir,
        );
        assert!(o.status.success(), "{}", stderr(&o));
        let text = String::from_utf8(o.stdout).unwrap();
        assert!(text.starts_with("Points") && text.contains("pull-push") && text.contains("Mpoints/s"), "{text}");
        // The demo scene has no clouds for the points mode.
        let o = glint(&["bench", "view", "--mode", "points", "--frames", "1"], &dir);
        assert!(!o.status.success() && stderr(&o).contains("no point clouds"), "{}", stderr(&o));
    }
    for bad in [&["--frames", "0"][..], &["--width", "0"][..], &["--mode", "path", "--spp", "0"][..]] {
        let mut args = vec!["bench", "view"];
        args.extend_from_slice(bad);
        let o = glint(&args, &dir);
        assert!(!o.status.success(), "{bad:?} should fail");
        assert!(!stderr(&o).contains("panicked"), "{}", stderr(&o));
    }
}
