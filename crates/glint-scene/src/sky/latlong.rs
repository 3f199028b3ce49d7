//! Latitude-longitude (equirectangular) maps, W × H with W = 2H (DESIGN.md §4).
//!
//! For a world direction (x, y, z): `u = 0.5 + atan2(x, −z) / 2π` (the default view direction
//! −Z is the image centre), `v = acos(y) / π` (v = 0 is the top row, straight up). u wraps
//! (the border columns hold the opposite edge), v clamps (the border rows repeat the first and
//! last rows), so no lookup reads outside the image. Mip levels are chosen by the vertical texel
//! angle π/H, which is the same everywhere; near the poles, where a row's texels shrink
//! horizontally, this keeps the poles sharp rather than blurring them to the coarsest level.

use super::level::{Level, fast_log2, level_count, mip_blend};
use crate::{SceneError, TextureImage};
use glint_core::{Rgb, Vec3};
use std::f32::consts::{FRAC_PI_2, PI, TAU};

/// (u, v) ∈ [0, 1]² of a world direction (any non-zero length).
#[inline(always)]
pub fn latlong_uv(dir: Vec3) -> (f32, f32) {
    let len = dir.length();
    let u = 0.5 + fast_atan2(dir.x, -dir.z) * (1.0 / TAU);
    let v = fast_acos(dir.y / len) * (1.0 / PI);
    (u, v)
}

/// The unit world direction at (u, v).
pub fn latlong_direction(u: f32, v: f32) -> Vec3 {
    let (phi, theta) = ((u - 0.5) * TAU, v * PI);
    let (sin_t, cos_t) = theta.sin_cos();
    let (sin_p, cos_p) = phi.sin_cos();
    Vec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p)
}

/// atan2 to within 2e-5 rad (a sixteenth of a texel of a 16k-wide map), without a libm call.
#[inline(always)]
pub(crate) fn fast_atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (x.abs(), y.abs());
    let (lo, hi) = (ax.min(ay), ax.max(ay));
    if hi == 0.0 {
        return 0.0;
    }
    let a = lo / hi;
    let s = a * a;
    // Odd minimax polynomial of atan on [0, 1].
    let r = (((((((-0.004_054_058 * s + 0.021_861_23) * s - 0.055_909_886) * s + 0.096_420_04) * s - 0.139_085_34)
        * s
        + 0.199_465_36)
        * s
        - 0.333_298_56)
        * s
        + 0.999_999_3)
        * a;
    let mut r = r;
    if ay > ax {
        r = FRAC_PI_2 - r;
    }
    if x < 0.0 {
        r = PI - r;
    }
    if y < 0.0 { -r } else { r }
}

/// acos to within 1e-6 rad for x ∈ [−1, 1] (Abramowitz & Stegun 4.4.46); clamps outside.
#[inline(always)]
pub(crate) fn fast_acos(x: f32) -> f32 {
    let a: f32 = x.abs().min(1.0);
    let p = ((((((-0.001_262_491_1_f32 * a + 0.006_670_09) * a - 0.017_088_126) * a + 0.030_891_88) * a
        - 0.050_174_303)
        * a
        + 0.088_978_99)
        * a
        - 0.214_598_8)
        * a
        + FRAC_PI_2;
    let r = p * (1.0 - a).sqrt();
    if x < 0.0 {
        PI - r
    } else if x.is_nan() {
        FRAC_PI_2
    } else {
        r
    }
}

/// A lat-long map with a mip pyramid.
#[derive(Clone, Debug, PartialEq)]
pub struct LatLongMap {
    levels: Vec<Level>,
    /// Rows span the poles (Mitsuba 3's `envmap`: row j at v = j / (H − 1), the first row the
    /// north pole, the last the south pole) rather than sitting at the centres of H equal
    /// bands (v = (j + ½) / H, glint's and most renderers' convention). Finest-level lookups
    /// honour it; filtered lookups of coarser levels read the bands (a sub-texel shift).
    rows_span_poles: bool,
}

impl LatLongMap {
    /// What [`LatLongMap::from_image`] requires: width = 2 × height, finite texels ≥ 0.
    pub fn check_image(image: &TextureImage) -> Result<(), SceneError> {
        let what = "lat-long map";
        if image.width == 0 || image.height == 0 {
            return Err(SceneError::invalid(what, "is empty"));
        }
        if image.width != 2 * image.height {
            return Err(SceneError::invalid(
                what,
                format!(
                    "is {}x{}: an equirectangular map must be twice as wide as it is high",
                    image.width, image.height
                ),
            ));
        }
        let (w, h) = (image.width as usize, image.height as usize);
        if image.texels.len() != w * h {
            return Err(SceneError::invalid(what, "texel count does not match its size"));
        }
        if let Some(i) = image.texels.iter().position(|t| !t.is_finite() || t.min_element() < 0.0) {
            return Err(SceneError::invalid(
                what,
                format!("texel ({}, {}) is {} (must be finite, ≥ 0)", i % w, i / w, image.texels[i]),
            ));
        }
        Ok(())
    }

    /// A map from an equirectangular image (width = 2 × height, finite, ≥ 0).
    pub fn from_image(image: TextureImage) -> Result<LatLongMap, SceneError> {
        LatLongMap::check_image(&image)?;
        let (w, h) = (image.width as usize, image.height as usize);
        Ok(LatLongMap::from_level0(Level::from_interior(w, h, &image.texels)))
    }

    /// A map `2·height × height` whose texels are `f` of the unit world direction through each
    /// texel centre.
    pub fn from_fn(height: u32, f: impl Fn(Vec3) -> Rgb + Sync) -> LatLongMap {
        let h = height.max(1) as usize;
        let w = 2 * h;
        let texels: Vec<Rgb> = (0..w * h)
            .map(|i| f(latlong_direction(((i % w) as f32 + 0.5) / w as f32, ((i / w) as f32 + 0.5) / h as f32)))
            .collect();
        LatLongMap::from_level0(Level::from_interior(w, h, &texels))
    }

    fn from_level0(mut base: Level) -> LatLongMap {
        fill_borders(&mut base);
        let count = level_count(base.width.max(base.height));
        let mut levels = vec![base];
        while levels.len() < count {
            let (w, h, t) = levels.last().expect("at least one level").downsampled_interior();
            let mut next = Level::from_interior(w, h, &t);
            fill_borders(&mut next);
            levels.push(next);
        }
        LatLongMap { levels, rows_span_poles: false }
    }

    /// This map with Mitsuba's row placement (see the field `rows_span_poles`).
    #[must_use]
    pub fn with_rows_spanning_poles(mut self) -> LatLongMap {
        self.rows_span_poles = true;
        self
    }

    pub fn width(&self) -> u32 {
        self.levels[0].width as u32
    }

    pub fn height(&self) -> u32 {
        self.levels[0].height as u32
    }

    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// The finest level, border included (what [`LatLongMap::lookup`] reads).
    pub(crate) fn finest(&self) -> &Level {
        &self.levels[0]
    }

    /// The finest level as an image.
    pub fn image(&self) -> TextureImage {
        let l = &self.levels[0];
        TextureImage { width: l.width as u32, height: l.height as u32, texels: l.interior() }
    }

    /// Bilinear lookup at the finest level.
    #[inline]
    pub fn lookup(&self, dir: Vec3) -> Rgb {
        let (u, v) = latlong_uv(dir);
        self.finest_sample(u, v)
    }

    /// Level `level` (finest first).
    #[inline(always)]
    pub(super) fn level(&self, level: usize) -> &Level {
        &self.levels[level]
    }

    /// Whether the finest level's rows span the poles (see the field).
    #[inline(always)]
    pub(super) fn rows_span_poles(&self) -> bool {
        self.rows_span_poles
    }

    #[inline(always)]
    fn finest_sample(&self, u: f32, v: f32) -> Rgb {
        let l = &self.levels[0];
        if self.rows_span_poles {
            // `bilinear` reads texel centres at half-integers: row j at v (H − 1) = j.
            l.bilinear(u * l.size.x, v * (l.size.y - 1.0) + 0.5)
        } else {
            sample(l, u, v)
        }
    }

    /// Trilinear lookup for a footprint `cone_angle` radians wide.
    #[inline]
    pub fn lookup_filtered(&self, dir: Vec3, cone_angle: f32) -> Rgb {
        let (u, v) = latlong_uv(dir);
        let texels = cone_angle * self.levels[0].size.y * (1.0 / PI); // footprint in rows
        if texels.is_nan() || texels <= 1.0 {
            return self.finest_sample(u, v);
        }
        let lambda = fast_log2(texels);
        if lambda <= 0.0 {
            return self.finest_sample(u, v);
        }
        let (l0, w) = mip_blend(lambda, self.levels.len());
        if w >= 1.0 {
            return sample(&self.levels[l0 + 1], u, v);
        }
        let a = sample(&self.levels[l0], u, v);
        if w <= 0.0 {
            return a;
        }
        let b = sample(&self.levels[l0 + 1], u, v);
        a + (b - a) * w
    }
}

#[inline(always)]
fn sample(level: &Level, u: f32, v: f32) -> Rgb {
    level.bilinear(u * level.size.x, v * level.size.y)
}

/// Wrap in longitude, clamp in latitude.
fn fill_borders(l: &mut Level) {
    let (w, h) = (l.width as isize, l.height as isize);
    for y in 0..h {
        let (first, last) = (l.get(0, y), l.get(w - 1, y));
        l.set(-1, y, last);
        l.set(w, y, first);
    }
    for x in -1..=w {
        let (top, bottom) = (l.get(x, 0), l.get(x, h - 1));
        l.set(x, -1, top);
        l.set(x, h, bottom);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_formula_of_design_md() {
        // −Z is the image centre, +Y the top row, −Y the bottom row.
        let (u, v) = latlong_uv(-Vec3::Z);
        assert!((u - 0.5).abs() < 1e-6 && (v - 0.5).abs() < 1e-6);
        assert!(latlong_uv(Vec3::Y).1.abs() < 1e-3);
        assert!((latlong_uv(-Vec3::Y).1 - 1.0).abs() < 1e-3);
        // +X (the camera's right) is three quarters across; −X one quarter; +Z the seam.
        assert!((latlong_uv(Vec3::X).0 - 0.75).abs() < 1e-6);
        assert!((latlong_uv(-Vec3::X).0 - 0.25).abs() < 1e-6);
        let (u, _) = latlong_uv(Vec3::new(1e-4, 0.0, 1.0));
        assert!((u - 1.0).abs() < 1e-4);
    }

    #[test]
    fn direction_inverts_uv() {
        for i in 0..40 {
            for j in 1..20 {
                let (u, v) = ((i as f32 + 0.5) / 40.0, j as f32 / 20.0);
                let (u2, v2) = latlong_uv(latlong_direction(u, v));
                assert!((u - u2).abs() < 1e-5 && (v - v2).abs() < 1e-5, "{u} {v}: {u2} {v2}");
            }
        }
    }

    #[test]
    fn fast_trig_matches_libm() {
        let mut worst: f32 = 0.0;
        for i in 0..2000 {
            let a = i as f32 * 0.0031;
            let (y, x) = (a.sin() * (1.0 + i as f32 * 0.01), a.cos() * (1.0 + i as f32 * 0.01));
            worst = worst.max((fast_atan2(y, x) - y.atan2(x)).abs());
            worst = worst.max((fast_atan2(-y, x) - (-y).atan2(x)).abs());
            let c = (i as f32 / 1000.0) - 1.0;
            worst = worst.max((fast_acos(c) - c.acos()).abs());
        }
        assert!(worst < 2e-5, "{worst}");
        assert_eq!(fast_atan2(0.0, 0.0), 0.0);
        assert!(fast_acos(f32::NAN).is_finite());
        assert!((fast_acos(1.5) - 0.0).abs() < 1e-6 && (fast_acos(-1.5) - PI).abs() < 1e-6);
    }

    #[test]
    fn wraps_in_longitude_and_clamps_at_the_poles() {
        // Column 0 red, last column blue: across the seam (+Z) the lookup blends the two.
        let (w, h) = (8u32, 4u32);
        let mut texels = vec![Rgb::ZERO; (w * h) as usize];
        for y in 0..h as usize {
            texels[y * w as usize] = Rgb::X;
            texels[y * w as usize + w as usize - 1] = Rgb::Z;
        }
        let map = LatLongMap::from_image(TextureImage { width: w, height: h, texels }).expect("2:1");
        let c = map.lookup(Vec3::new(0.0, 0.1, 1.0)); // u = 1 (or 0): half-way between both
        assert!((c.x - 0.5).abs() < 1e-3 && (c.z - 0.5).abs() < 1e-3, "{c}");
        // The poles and anything non-finite read inside the image.
        for d in [Vec3::Y, -Vec3::Y, Vec3::new(f32::NAN, 1.0, 0.0), Vec3::ZERO] {
            let c = map.lookup_filtered(d, 0.01);
            assert!(c.is_finite());
        }
    }

    #[test]
    fn rejects_wrong_aspect_and_bad_texels() {
        let e =
            LatLongMap::from_image(TextureImage { width: 6, height: 4, texels: vec![Rgb::ONE; 24] }).expect_err("3:2");
        assert!(e.to_string().contains("6x4"), "{e}");
        let mut texels = vec![Rgb::ONE; 8];
        texels[3] = Rgb::splat(f32::INFINITY);
        assert!(LatLongMap::from_image(TextureImage { width: 4, height: 2, texels }).is_err());
    }

    #[test]
    fn mip_chain_reaches_one_row() {
        let map = LatLongMap::from_fn(64, |d| Rgb::splat(d.y.max(0.0)));
        assert_eq!(map.level_count(), 8); // 128×64 … 1×1
        let c = map.lookup_filtered(Vec3::Y, 100.0);
        assert!(c.is_finite());
    }
}
