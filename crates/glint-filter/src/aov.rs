//! Filtering a stored AOV image: the indirect light is filtered demodulated and put back under
//! the albedo (Bauszat et al. §3.1, DESIGN.md §2), everything else is left as it was.
//!
//! Channels read: `R G B` (beauty), `Albedo.R/G/B`, `Ns.X/Y/Z` (unit shading normals), `Z`
//! (linear depth, +inf where nothing was hit), `Indirect.R/G/B` (demodulated incident indirect
//! light). Any other channel (`A`, `Direct.*`, `SampleCount`, ...) is copied unchanged.
//!
//! The depth guide is `Z / (1.25 · max finite Z)`: hits land in [0, 0.8], and pixels where
//! nothing was hit get 1.0 (and a zero normal), so the background sits at least 0.2 — several
//! filter sigmas — behind the farthest surface. A single image has no other notion of the
//! scene's extent; callers filtering an animation should build the [`Guide`] themselves with
//! a constant scale (the paper divides by a constant from the scene's extent).

use glint_image::Image;

use crate::check::Names;
use crate::{Filter, FilterError, Guide, Isa};

/// The farthest finite depth maps to 1/DEPTH_MARGIN.
pub const DEPTH_MARGIN: f32 = 1.25;

const BEAUTY: [&str; 3] = ["R", "G", "B"];
const ALBEDO: [&str; 3] = ["Albedo.R", "Albedo.G", "Albedo.B"];
const NORMAL: [&str; 3] = ["Ns.X", "Ns.Y", "Ns.Z"];
const INDIRECT: [&str; 3] = ["Indirect.R", "Indirect.G", "Indirect.B"];

/// Filters a stored AOV image: returns a copy whose `R,G,B = R,G,B + Albedo·(F(Indirect) −
/// Indirect)` and whose `Indirect.* = F(Indirect)`, F being `filter` guided by the image's
/// normals and depth (see the module documentation for the depth scale). `R`, `G`, `B` are
/// otherwise passed through. Fails naming the missing channels, or the channel and first
/// pixel of a non-finite value (`Z` may be +inf, nothing else may be infinite or NaN).
pub fn filter_image(img: &Image, filter: &Filter) -> Result<Image, FilterError> {
    filter_image_with(Isa::detect(), img, filter)
}

/// [`filter_image`] with an explicit instruction set.
pub fn filter_image_with(isa: Isa, img: &Image, filter: &Filter) -> Result<Image, FilterError> {
    img.validate().map_err(|e| FilterError::InvalidImage { message: e.to_string() })?;
    let needed = BEAUTY.iter().chain(&ALBEDO).chain(&NORMAL).chain(&["Z"]).chain(&INDIRECT);
    let missing: Vec<String> = needed.filter(|n| img.channel(n).is_none()).map(|n| n.to_string()).collect();
    if !missing.is_empty() {
        let present = img.channels.iter().map(|c| c.name.clone()).collect();
        return Err(FilterError::MissingChannels { missing, present });
    }
    let (w, h) = (img.width as usize, img.height as usize);
    if w == 0 || h == 0 {
        return Err(FilterError::Empty { width: w, height: h });
    }
    let channel = |name: &str| img.channel(name).unwrap_or(&[]);
    let z = channel("Z");
    if let Some(i) = z.iter().position(|v| v.is_nan() || *v == f32::NEG_INFINITY) {
        return Err(FilterError::NotFinite { plane: "Z".into(), x: i % w, y: i / w, value: z[i] });
    }
    let max_z = z.iter().filter(|v| v.is_finite()).fold(0.0f32, |m, &v| m.max(v));
    let scale = if max_z > 0.0 { 1.0 / (DEPTH_MARGIN * max_z) } else { 1.0 };
    let depth: Vec<f32> = z.iter().map(|&v| if v.is_finite() { v * scale } else { 1.0 }).collect();
    let normal: [Vec<f32>; 3] =
        NORMAL.map(|name| channel(name).iter().zip(z).map(|(&n, &z)| if z.is_finite() { n } else { 0.0 }).collect());
    let guide = Guide { width: w, height: h, normal: [&normal[0], &normal[1], &normal[2]], depth: &depth };
    let indirect = INDIRECT.map(channel);
    let albedo = ALBEDO.map(channel);
    crate::check::finite_planes(&[(ALBEDO[0], albedo[0]), (ALBEDO[1], albedo[1]), (ALBEDO[2], albedo[2])], w)?;
    let names = Names { input: INDIRECT, guide: ["Ns.X", "Ns.Y", "Ns.Z", "Z"] };
    let filtered = crate::apply_named(isa, filter, indirect, &guide, &names)?;

    let mut out = img.clone();
    for c in 0..3 {
        let beauty = out.channel_mut(BEAUTY[c]).unwrap_or(&mut []);
        for (((b, &f), &i), &a) in beauty.iter_mut().zip(&filtered[c]).zip(indirect[c]).zip(albedo[c]) {
            *b += a * (f - i);
        }
    }
    for (c, data) in filtered.into_iter().enumerate() {
        if let Some(plane) = out.channel_mut(INDIRECT[c]) {
            plane.copy_from_slice(&data);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::GuidedParams;
    use crate::test_util::random_scene;

    /// A 24×16 AOV image: random geometry (a third of the pixels missed, Z = +inf), indirect
    /// light in [0, 1), albedo 0.5, beauty = 0.1 + albedo · indirect, plus `A` and `Direct.R`.
    fn aov_image() -> Image {
        let s = random_scene(24, 16, 9);
        let mut img = Image::new(24, 16);
        let missed = |i: usize| i.is_multiple_of(3);
        let n = 24 * 16;
        for c in 0..3 {
            let beauty = (0..n).map(|i| 0.1 + 0.5 * s.input[c][i]).collect();
            img.add_channel(BEAUTY[c], beauty).expect("size");
        }
        img.add_channel("A", vec![1.0; n]).expect("size");
        for c in 0..3 {
            img.add_channel(ALBEDO[c], vec![0.5; n]).expect("size");
            img.add_channel(NORMAL[c], s.normal[c].clone()).expect("size");
        }
        let z = (0..n).map(|i| if missed(i) { f32::INFINITY } else { 2.0 + 8.0 * s.depth[i] }).collect();
        img.add_channel("Z", z).expect("size");
        for c in 0..3 {
            img.add_channel(INDIRECT[c], s.input[c].clone()).expect("size");
        }
        img.add_channel("Direct.R", vec![0.1; n]).expect("size");
        img
    }

    #[test]
    fn round_trip_puts_filtered_light_under_the_albedo() {
        let img = aov_image();
        let filter = Filter::Guided(GuidedParams::for_width(24));
        let out = filter_image(&img, &filter).expect("valid");
        let names: Vec<_> = out.channels.iter().map(|c| c.name.as_str()).collect();
        let before: Vec<_> = img.channels.iter().map(|c| c.name.as_str()).collect();
        assert_eq!(names, before);
        for name in ["A", "Direct.R", "Z", "Ns.X", "Albedo.G"] {
            assert_eq!(out.channel(name), img.channel(name), "{name} must pass through");
        }
        for c in 0..3 {
            let f = out.channel(INDIRECT[c]).expect("kept");
            assert_ne!(f, img.channel(INDIRECT[c]).expect("kept"), "filtering changed nothing");
            for (i, (&b, &f)) in out.channel(BEAUTY[c]).expect("kept").iter().zip(f).enumerate() {
                assert!((b - (0.1 + 0.5 * f)).abs() < 1e-6, "{} pixel {i}", BEAUTY[c]);
            }
        }
        // Filter::None is the identity.
        assert_eq!(filter_image(&img, &Filter::None).expect("valid"), img);
    }

    #[test]
    fn guide_is_built_as_documented() {
        // Filtering with the documented guide by hand gives the same planes.
        let img = aov_image();
        let z = img.channel("Z").expect("has Z");
        let max_z = z.iter().filter(|v| v.is_finite()).fold(0.0f32, |m, &v| m.max(v));
        let scale = 1.0 / (DEPTH_MARGIN * max_z);
        let depth: Vec<f32> = z.iter().map(|&v| if v.is_finite() { v * scale } else { 1.0 }).collect();
        let normal: [Vec<f32>; 3] = NORMAL.map(|n| {
            img.channel(n).expect("has").iter().zip(z).map(|(&n, z)| if z.is_finite() { n } else { 0.0 }).collect()
        });
        let guide = Guide { width: 24, height: 16, normal: [&normal[0], &normal[1], &normal[2]], depth: &depth };
        let p = GuidedParams::for_width(24);
        let want = crate::guided(INDIRECT.map(|n| img.channel(n).expect("has")), &guide, &p).expect("valid");
        let out = filter_image(&img, &Filter::Guided(p)).expect("valid");
        for c in 0..3 {
            assert_eq!(out.channel(INDIRECT[c]).expect("has"), &want[c][..]);
        }
    }

    #[test]
    fn missing_and_bad_channels_are_named() {
        let mut img = aov_image();
        img.channels.retain(|c| c.name != "Indirect.G" && c.name != "Ns.Y");
        let err = filter_image(&img, &Filter::None).expect_err("missing");
        let msg = err.to_string();
        assert!(msg.contains("Ns.Y, Indirect.G"), "{msg}");

        let mut img = aov_image();
        img.channel_mut("Indirect.B").expect("has")[24 * 3 + 5] = f32::NAN;
        let err = filter_image(&img, &Filter::Guided(GuidedParams::for_width(24))).expect_err("nan");
        assert!(err.to_string().starts_with("Indirect.B is not finite at pixel (5, 3)"), "{err}");

        let mut img = aov_image();
        img.channel_mut("Z").expect("has")[2] = f32::NAN;
        let err = filter_image(&img, &Filter::None).expect_err("nan z");
        assert!(err.to_string().starts_with("Z is not finite at pixel (2, 0)"), "{err}");

        let mut img = aov_image();
        img.channels[0].data.pop();
        assert!(matches!(filter_image(&img, &Filter::None), Err(FilterError::InvalidImage { .. })));
    }
}
