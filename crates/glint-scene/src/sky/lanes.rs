//! Eight sky lookups at once (issue 19): [`CubeMap::lookup_filtered8`] and
//! [`LatLongMap::lookup_filtered8`] do what `lookup_filtered` does for each of eight
//! directions, bit for bit on x86-64 (where `filter_taps` adds in the order used here), with
//! the arithmetic across lanes. Each stage is a loop over the eight lanes that the compiler turns
//! into one vector operation per step (the AVX2 + FMA copy is chosen at run time; Rust never
//! fuses a multiply and an add by itself, so both copies compute the scalar code's values):
//!
//! 1. the face and its (s, t) by the major axis (a lat-long map: longitude and latitude by
//!    polynomial atan2 and acos);
//! 2. the level of detail from bit-trick logs and the "brilinear" blend (`mip_blend`'s
//!    arithmetic), giving each lane the level it reads (`lo`), the next one (`hi`) and the
//!    weight between them;
//! 3. each level's texel coordinates, fractions and index (the bordered grid of [`Level`]);
//! 4. the four RGB9E5 taps of both levels, loaded lane by lane (the only scalar step: a lane
//!    reads its own face and level);
//! 5. decoding and bilinear weighting in the order `filter_taps` adds them, then the blend.
//!
//! When some lane blends two levels, every lane loads a second one (and the others drop it);
//! when none does (neighbouring footprints are alike), the second level is not read.

use super::cube::{CubeMap, face_st_cube};
use super::latlong::{LatLongMap, latlong_uv};
use super::level::{Level, blend_weight, fast_log2};
use glint_core::{Rgb, Vec3};
use std::f32::consts::PI;

/// Lookups per call.
pub const LANES: usize = 8;

/// Eight directions, one per lane.
type Dirs8 = [Vec3; LANES];

/// A map whose filtered lookup runs across eight lanes.
trait Lookup8 {
    /// Texels of the finest level (with its border): the lanes index texels in u32.
    fn finest_texels(&self) -> usize;
    /// The scalar lookup (`lookup_filtered`).
    fn one(&self, dir: Vec3, cone: f32) -> Rgb;
    /// The eight lookups, written as loops over the lanes (inlined into each instruction
    /// set's copy).
    fn lookup8(&self, dirs: &Dirs8, cones: &[f32; LANES]) -> [Rgb; LANES];
}

/// `map`'s eight lookups with the best instruction set the CPU has.
fn lookup_filtered8<M: Lookup8>(map: &M, dirs: &Dirs8, cones: &[f32; LANES]) -> [Rgb; LANES] {
    if map.finest_texels() > u32::MAX as usize {
        // Texel indices are u32 across the lanes: a level this large (beyond 65 534² texels,
        // far past what an image may hold) is looked up lane by lane.
        return std::array::from_fn(|i| map.one(dirs[i], cones[i]));
    }
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") && std::is_x86_feature_detected!("fma") {
        // SAFETY: the CPU has AVX2 and FMA (checked just above), all the function needs; it
        // only computes on its arguments.
        #[allow(unsafe_code)]
        return unsafe { lookup8_avx2(map, dirs, cones) };
    }
    map.lookup8(dirs, cones)
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn lookup8_avx2<M: Lookup8>(map: &M, dirs: &Dirs8, cones: &[f32; LANES]) -> [Rgb; LANES] {
    map.lookup8(dirs, cones)
}

/// Whether any lane blends two levels (0 < w < 1): else the second level is not read.
#[inline(always)]
fn blends(w: &[f32; LANES]) -> bool {
    let mut any = false;
    for &w in w {
        any |= w > 0.0 && w < 1.0;
    }
    any
}

/// `a + (b − a) · w` in the lanes that blend, `a` in the others (the scalar lookups' step).
#[inline(always)]
fn mix8(a: &mut [Rgb; LANES], b: &[Rgb; LANES], w: &[f32; LANES]) {
    for i in 0..LANES {
        let mixed = a[i] + (b[i] - a[i]) * w[i];
        a[i] = if w[i] > 0.0 && w[i] < 1.0 { mixed } else { a[i] };
    }
}

impl CubeMap {
    /// [`CubeMap::lookup_filtered`] of eight directions and footprints (the same values, bit
    /// for bit).
    #[must_use]
    pub fn lookup_filtered8(&self, dirs: &Dirs8, cones: &[f32; LANES]) -> [Rgb; LANES] {
        lookup_filtered8(self, dirs, cones)
    }

    /// Bilinear samples of face `face[i]` of level `level[i]` at (s, t) for each lane:
    /// [`Level::bilinear`] at (s · size, t · size).
    #[inline(always)]
    fn sample8(&self, level: &[u32; LANES], face: &[usize; LANES], s: &[f32; LANES], t: &[f32; LANES]) -> [Rgb; LANES] {
        let mut levels: [&Level; LANES] = [&self.finest()[0]; LANES];
        for i in 0..LANES {
            levels[i] = self.level(level[i] as usize, face[i]);
        }
        bilinear8(&levels, s, t)
    }
}

impl Lookup8 for CubeMap {
    fn finest_texels(&self) -> usize {
        self.finest()[0].texels.len()
    }

    fn one(&self, dir: Vec3, cone: f32) -> Rgb {
        self.lookup_filtered(dir, cone)
    }

    #[inline(always)]
    fn lookup8(&self, dirs: &Dirs8, cones: &[f32; LANES]) -> [Rgb; LANES] {
        let count = self.level_count();
        // 1. Faces, (s, t) and the major axis (cube coordinates: z flipped).
        let (mut face, mut s, mut t, mut major, mut l2) =
            ([0usize; LANES], [0f32; LANES], [0f32; LANES], [0f32; LANES], [0f32; LANES]);
        for i in 0..LANES {
            let c = Vec3::new(dirs[i].x, dirs[i].y, -dirs[i].z);
            (face[i], s[i], t[i], major[i]) = face_st_cube(c);
            l2[i] = c.length_squared();
        }
        // 2. Level of detail, levels and blend weight ([`mip_blend`]'s arithmetic, in i32).
        let (mut lo, mut hi, mut w) = ([0u32; LANES], [0u32; LANES], [0f32; LANES]);
        let coarsest = (count - 1) as f32;
        for i in 0..LANES {
            let (cone, ma) = (cones[i], major[i]);
            let k = cone * self.half_size;
            let ma3 = ma * ma * ma;
            let magnified = (k * k) * (k * k) * (l2[i] * l2[i] * l2[i]) <= ma3 * ma3 || cone.is_nan();
            let lambda = fast_log2(cone) + self.log2_half_size + 0.75 * fast_log2(l2[i]) - 1.5 * fast_log2(ma);
            let single = magnified || lambda.is_nan() || lambda <= 0.0;
            let lambda = if single { 0.0 } else { lambda.min(coarsest) };
            let l0 = lambda as i32;
            let weight = blend_weight(lambda - l0 as f32);
            let l0 = l0 as u32;
            let weight = if single { 0.0 } else { weight };
            lo[i] = if weight >= 1.0 { l0 + 1 } else { l0 };
            hi[i] = (l0 + 1).min(count as u32 - 1);
            w[i] = weight;
        }
        // 3–5. The levels' bilinear samples, then the blend. Neighbouring footprints are
        // alike: often no lane blends, and the second level is not read at all.
        let mut out = self.sample8(&lo, &face, &s, &t);
        if blends(&w) {
            mix8(&mut out, &self.sample8(&hi, &face, &s, &t), &w);
        }
        out
    }
}

impl LatLongMap {
    /// [`LatLongMap::lookup_filtered`] of eight directions and footprints (the same values,
    /// bit for bit).
    #[must_use]
    pub fn lookup_filtered8(&self, dirs: &Dirs8, cones: &[f32; LANES]) -> [Rgb; LANES] {
        lookup_filtered8(self, dirs, cones)
    }
}

impl Lookup8 for LatLongMap {
    fn finest_texels(&self) -> usize {
        self.level(0).texels.len()
    }

    fn one(&self, dir: Vec3, cone: f32) -> Rgb {
        self.lookup_filtered(dir, cone)
    }

    #[inline(always)]
    fn lookup8(&self, dirs: &Dirs8, cones: &[f32; LANES]) -> [Rgb; LANES] {
        let count = self.level_count();
        let finest = self.level(0);
        let coarsest = (count - 1) as f32;
        let (mut u, mut v) = ([0f32; LANES], [0f32; LANES]);
        let (mut lo, mut hi, mut w, mut at_finest) = ([0u32; LANES], [0u32; LANES], [0f32; LANES], [false; LANES]);
        for i in 0..LANES {
            (u[i], v[i]) = latlong_uv(dirs[i]);
            // The footprint in rows, its level and blend weight (as `lookup_filtered`).
            let texels = cones[i] * finest.size.y * (1.0 / PI);
            let lambda = fast_log2(texels);
            let single = texels.is_nan() || texels <= 1.0 || lambda <= 0.0;
            let lambda = if single { 0.0 } else { lambda.min(coarsest) };
            let l0 = lambda as i32;
            let weight = if single { 0.0 } else { blend_weight(lambda - l0 as f32) };
            let l0 = l0 as u32;
            at_finest[i] = single;
            lo[i] = if weight >= 1.0 { l0 + 1 } else { l0 };
            hi[i] = (l0 + 1).min(count as u32 - 1);
            w[i] = weight;
        }
        let mut out = self.sample8(&lo, &at_finest, &u, &v);
        if blends(&w) {
            mix8(&mut out, &self.sample8(&hi, &[false; LANES], &u, &v), &w);
        }
        out
    }
}

impl LatLongMap {
    /// Bilinear samples of level `level[i]` at (u, v) for each lane; a lane `finest[i]` reads
    /// the finest level as [`LatLongMap::lookup`] does (rows spanning the poles, when they do).
    #[inline(always)]
    fn sample8(
        &self,
        level: &[u32; LANES],
        finest: &[bool; LANES],
        u: &[f32; LANES],
        v: &[f32; LANES],
    ) -> [Rgb; LANES] {
        let mut levels: [&Level; LANES] = [self.level(0); LANES];
        for i in 0..LANES {
            levels[i] = self.level(level[i] as usize);
        }
        if !self.rows_span_poles() || !finest.contains(&true) {
            return bilinear8(&levels, u, v);
        }
        // Rows spanning the poles, at the finest level: that lane by lane.
        let mut out = bilinear8(&levels, u, v);
        for i in 0..LANES {
            if finest[i] {
                let l = levels[i];
                out[i] = l.bilinear(u[i] * l.size.x, v[i] * (l.size.y - 1.0) + 0.5);
            }
        }
        out
    }
}

/// [`Level::bilinear`] of `levels[i]` at (`u[i]` · its width, `v[i]` · its height) for each
/// lane.
#[inline(always)]
fn bilinear8(levels: &[&Level; LANES], u: &[f32; LANES], v: &[f32; LANES]) -> [Rgb; LANES] {
    // Each lane's level sizes first (loads through eight pointers), so that the arithmetic
    // below is one vector operation per step.
    let (mut width, mut height, mut stride) = ([0f32; LANES], [0f32; LANES], [0u32; LANES]);
    for i in 0..LANES {
        (width[i], height[i], stride[i]) = (levels[i].size.x, levels[i].size.y, levels[i].stride as u32);
    }
    let (mut fx, mut fy, mut index) = ([0f32; LANES], [0f32; LANES], [0u32; LANES]);
    for i in 0..LANES {
        let (x, y) = Level::bilinear_coordinates(u[i] * width[i], v[i] * height[i], width[i], height[i]);
        // x, y ∈ [½, size + ½]: their truncations are small non-negative integers, and the
        // index fits a u32 (the callers check the finest level).
        let (xi, yi) = (x as i32, y as i32);
        (fx[i], fy[i]) = (x - xi as f32, y - yi as f32);
        index[i] = (yi as u32) * stride[i] + xi as u32;
    }
    let mut taps = [[0u32; LANES]; 4];
    for i in 0..LANES {
        // SAFETY: index[i] = ⌊y⌋ · stride + ⌊x⌋ of coordinates clamped by
        // `bilinear_coordinates` (⌊x⌋ ≤ width, ⌊y⌋ ≤ height), the taps' own precondition; the
        // tests read edges, corners, NaN and infinite directions against the checked scalar
        // lookup.
        #[allow(unsafe_code)]
        let t = unsafe { levels[i].taps_unchecked(index[i] as usize) };
        [taps[0][i], taps[1][i], taps[2][i], taps[3][i]] = t;
    }
    let mut sum = [[0f32; LANES]; 3];
    for i in 0..LANES {
        let (gx, gy) = (1.0 - fx[i], 1.0 - fy[i]);
        let weight = [gx * gy, fx[i] * gy, gx * fy[i], fx[i] * fy[i]];
        let (mut r, mut g, mut b) = ([0f32; 4], [0f32; 4], [0f32; 4]);
        for k in 0..4 {
            let v = taps[k][i];
            let scaled = weight[k] * f32::from_bits(((v >> 27) + 103) << 23);
            r[k] = (v & 511) as f32 * scaled;
            g[k] = ((v >> 9) & 511) as f32 * scaled;
            b[k] = ((v >> 18) & 511) as f32 * scaled;
        }
        // `filter_taps`' order: (0 + 2) + (1 + 3).
        sum[0][i] = (r[0] + r[2]) + (r[1] + r[3]);
        sum[1][i] = (g[0] + g[2]) + (g[1] + g[3]);
        sum[2][i] = (b[0] + b[2]) + (b[1] + b[3]);
    }
    std::array::from_fn(|i| Rgb::new(sum[0][i], sum[1][i], sum[2][i]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::{Sky, SkyTransform};
    use glint_core::random::{hash4, unit_float};
    use std::sync::Arc;

    fn pattern(d: Vec3) -> Rgb {
        Rgb::new((d.x * 9.0).sin().abs() * 40.0, (d.y * 7.0).cos().abs(), (d.z * 5.0 + d.x).sin().abs() * 1e-3)
    }

    /// Directions of every kind (random, on faces' edges and corners, unnormalised, zero, NaN,
    /// infinite) and footprints from far below a texel to beyond the coarsest level (0, NaN,
    /// infinite, negative too).
    fn cases() -> Vec<(Vec3, f32)> {
        let u = |i: u64, k: u64| unit_float(hash4(i, k, 3, 11));
        let mut v = Vec::new();
        for i in 0..4000u64 {
            let d = Vec3::new(u(i, 0) - 0.5, u(i, 1) - 0.5, u(i, 2) - 0.5) * (0.1 + 10.0 * u(i, 3));
            let cone = (u(i, 4) * 14.0 - 12.0).exp2();
            v.push((d, cone));
        }
        let special = [Vec3::X, -Vec3::Y, Vec3::new(1.0, 1.0, 1.0), Vec3::new(1.0, -1.0, 0.0), Vec3::ZERO, Vec3::NAN];
        for d in special.into_iter().chain([Vec3::new(f32::INFINITY, 1.0, 0.0)]) {
            for cone in [0.0, 1e-6, 0.01, 0.3, 4.0, f32::INFINITY, f32::NAN, -0.5] {
                v.push((d, cone));
            }
        }
        v
    }

    #[test]
    fn eight_lookups_are_the_scalar_lookups_bit_for_bit() {
        for size in [1, 5, 32] {
            let map = CubeMap::from_fn(size, pattern);
            for group in cases().chunks(LANES) {
                let mut dirs = [Vec3::ZERO; LANES];
                let mut cones = [0.0; LANES];
                for (i, (d, c)) in group.iter().enumerate() {
                    (dirs[i], cones[i]) = (*d, *c);
                }
                let eight = map.lookup_filtered8(&dirs, &cones);
                let portable = map.lookup8(&dirs, &cones);
                for i in 0..LANES {
                    let one = map.lookup_filtered(dirs[i], cones[i]);
                    let bits = |c: Rgb| c.to_array().map(f32::to_bits);
                    assert_eq!(bits(eight[i]), bits(one), "size {size}, {:?} cone {}", dirs[i], cones[i]);
                    assert_eq!(bits(portable[i]), bits(one), "portable, size {size}, {:?}", dirs[i]);
                }
            }
        }
    }

    #[test]
    fn eight_lat_long_lookups_are_the_scalar_lookups_bit_for_bit() {
        for (height, poles) in [(2, false), (9, false), (64, false), (64, true)] {
            let mut map = LatLongMap::from_fn(height, pattern);
            if poles {
                map = map.with_rows_spanning_poles();
            }
            for group in cases().chunks(LANES) {
                let mut dirs = [Vec3::ZERO; LANES];
                let mut cones = [0.0; LANES];
                for (i, (d, c)) in group.iter().enumerate() {
                    (dirs[i], cones[i]) = (*d, *c);
                }
                let (eight, portable) = (map.lookup_filtered8(&dirs, &cones), map.lookup8(&dirs, &cones));
                for i in 0..LANES {
                    let one = map.lookup_filtered(dirs[i], cones[i]);
                    let bits = |c: Rgb| c.to_array().map(f32::to_bits);
                    assert_eq!(bits(eight[i]), bits(one), "height {height}, {:?} cone {}", dirs[i], cones[i]);
                    assert_eq!(bits(portable[i]), bits(one), "portable, height {height}, {:?}", dirs[i]);
                }
            }
        }
    }

    #[test]
    fn a_skys_eight_lookups_are_its_lookups() {
        let cube =
            Sky::CubeMap { map: Arc::new(CubeMap::from_fn(16, pattern)), transform: SkyTransform::new(35.0, 2.5) };
        let latlong =
            Sky::LatLong { map: Arc::new(LatLongMap::from_fn(32, pattern)), transform: SkyTransform::new(-20.0, 0.5) };
        let cases = cases();
        let dirs: [Vec3; LANES] = std::array::from_fn(|i| cases[i * 7].0);
        let cones: [f32; LANES] = std::array::from_fn(|i| cases[i * 7].1);
        for (sky, active) in [&cube, &latlong].into_iter().flat_map(|s| [0xff, 0b1010_0110, 0b1, 0].map(|a| (s, a))) {
            let eight = sky.radiance_filtered8(&dirs, &cones, active);
            for i in 0..LANES {
                let want = if active >> i & 1 != 0 { sky.radiance_filtered(dirs[i], cones[i]) } else { Rgb::ZERO };
                assert_eq!(eight[i].to_array().map(f32::to_bits), want.to_array().map(f32::to_bits), "lane {i}");
            }
        }
    }
}
