//! Cube maps: six square faces, looked up by direction (DESIGN.md §4).
//!
//! Face selection and (s, t) follow the OpenGL cube-map table, which is left-handed; glint's
//! world is right-handed, so a world direction (x, y, z) is looked up as the cube direction
//! (x, y, −z). The default camera, looking along world −Z, therefore sees the +Z ("front") face,
//! upright and not mirrored. t = 0 is a face's first stored row (the top of its image).
//!
//! Filtering is seamless: every face of every mip level carries a one-texel border copied from
//! the faces it meets, and at each of the 8 cube corners, where three faces meet and no fourth
//! texel exists, the border corner holds the mean of the three corner texels (what GPUs do). A
//! bilinear lookup is then four reads from one face, with no branch on the edges.

use super::level::{Level, fast_log2, level_count, mip_blend};
use crate::{SceneError, TextureImage};
use glint_core::{Rgb, Vec3};

/// The six faces in the order cube maps store them (OpenGL, Direct3D, KTX, DDS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum CubeFace {
    PosX,
    NegX,
    PosY,
    NegY,
    PosZ,
    NegZ,
}

impl CubeFace {
    pub const ALL: [CubeFace; 6] =
        [CubeFace::PosX, CubeFace::NegX, CubeFace::PosY, CubeFace::NegY, CubeFace::PosZ, CubeFace::NegZ];

    pub fn index(self) -> usize {
        self as usize
    }

    /// "px", "nx", "py", "ny", "pz", "nz".
    pub fn short_name(self) -> &'static str {
        ["px", "nx", "py", "ny", "pz", "nz"][self.index()]
    }

    pub fn from_index(i: usize) -> Option<CubeFace> {
        CubeFace::ALL.get(i).copied()
    }
}

/// Cube-map face and (s, t) ∈ [0, 1]² of a world direction (any non-zero length).
pub fn cube_face_st(dir: Vec3) -> (CubeFace, f32, f32) {
    let (f, s, t, _) = face_st_cube(Vec3::new(dir.x, dir.y, -dir.z));
    (CubeFace::ALL[f], s, t)
}

/// The world direction (not normalised) through (s, t) ∈ [0, 1]² of `face`; values outside
/// [0, 1] continue the face's plane.
pub fn cube_direction(face: CubeFace, s: f32, t: f32) -> Vec3 {
    let c = direction_cube(face.index(), s, t);
    Vec3::new(c.x, c.y, -c.z)
}

/// The OpenGL table in cube coordinates: (face index, s, t, |major axis|).
#[inline(always)]
pub(super) fn face_st_cube(c: Vec3) -> (usize, f32, f32, f32) {
    let a = c.abs();
    let (face, sc, tc, ma) = if a.x >= a.y && a.x >= a.z {
        if c.x > 0.0 { (0, -c.z, -c.y, a.x) } else { (1, c.z, -c.y, a.x) }
    } else if a.y >= a.z {
        if c.y > 0.0 { (2, c.x, c.z, a.y) } else { (3, c.x, -c.z, a.y) }
    } else if c.z > 0.0 {
        (4, c.x, -c.y, a.z)
    } else {
        (5, -c.x, -c.y, a.z)
    };
    let inv = 0.5 / ma;
    (face, sc * inv + 0.5, tc * inv + 0.5, ma)
}

/// Inverse of [`face_st_cube`], in cube coordinates.
fn direction_cube(face: usize, s: f32, t: f32) -> Vec3 {
    let (sc, tc) = (2.0 * s - 1.0, 2.0 * t - 1.0);
    match face {
        0 => Vec3::new(1.0, -tc, -sc),
        1 => Vec3::new(-1.0, -tc, sc),
        2 => Vec3::new(sc, 1.0, tc),
        3 => Vec3::new(sc, -1.0, -tc),
        4 => Vec3::new(sc, -tc, 1.0),
        _ => Vec3::new(-sc, -tc, -1.0),
    }
}

/// A cube map with a mip pyramid; faces of every level carry seam borders.
#[derive(Clone, Debug, PartialEq)]
pub struct CubeMap {
    /// Finest first; the last level has 1×1 faces.
    levels: Vec<[Level; 6]>,
    /// log2(face size / 2) and face size / 2, for mip level selection.
    pub(super) log2_half_size: f32,
    pub(super) half_size: f32,
}

impl CubeMap {
    /// What [`CubeMap::from_faces`] requires: square, equal, non-empty faces of finite,
    /// non-negative texels.
    pub fn check_faces(faces: &[TextureImage; 6]) -> Result<(), SceneError> {
        let size = faces[0].width;
        for (face, img) in CubeFace::ALL.iter().zip(faces) {
            let what = format!("cube map face {}", face.short_name());
            if img.width == 0 || img.height == 0 {
                return Err(SceneError::invalid(what, "is empty"));
            }
            if img.width != img.height {
                return Err(SceneError::invalid(what, format!("is {}x{}, not square", img.width, img.height)));
            }
            if img.width != size {
                return Err(SceneError::invalid(
                    what,
                    format!("is {0}x{0}, but face px is {1}x{1}: all six faces must be the same size", img.width, size),
                ));
            }
            if img.texels.len() != (img.width as usize) * (img.height as usize) {
                return Err(SceneError::invalid(what, "texel count does not match its size"));
            }
            if let Some(i) = img.texels.iter().position(|t| !t.is_finite() || t.min_element() < 0.0) {
                return Err(SceneError::invalid(
                    what,
                    format!(
                        "texel ({}, {}) is {} (must be finite, ≥ 0)",
                        i % size as usize,
                        i / size as usize,
                        img.texels[i]
                    ),
                ));
            }
        }
        Ok(())
    }

    /// A cube map from six faces in [`CubeFace::ALL`] order, each as a conventional set stores
    /// it (t = 0 is the top row). Faces must be square, equal and finite.
    pub fn from_faces(faces: [TextureImage; 6]) -> Result<CubeMap, SceneError> {
        CubeMap::check_faces(&faces)?;
        let size = faces[0].width;
        let n = size as usize;
        // The six faces are encoded in parallel (each on its own: the result does not depend on
        // the thread count).
        let base = par_faces(|f| Level::from_interior(n, n, &faces[f].texels));
        Ok(CubeMap::from_level0(base))
    }

    /// A cube map of `size`² faces whose texels are `f` of the unit world direction through
    /// each texel centre (how layouts are converted).
    pub fn from_fn(size: u32, f: impl Fn(Vec3) -> Rgb + Sync) -> CubeMap {
        let n = size.max(1) as usize;
        let base = std::array::from_fn(|face| {
            let texels: Vec<Rgb> = (0..n * n)
                .map(|i| {
                    let (s, t) = (((i % n) as f32 + 0.5) / n as f32, ((i / n) as f32 + 0.5) / n as f32);
                    let c = direction_cube(face, s, t).normalize();
                    f(Vec3::new(c.x, c.y, -c.z))
                })
                .collect();
            Level::from_interior(n, n, &texels)
        });
        CubeMap::from_level0(base)
    }

    fn from_level0(mut base: [Level; 6]) -> CubeMap {
        fill_borders(&mut base);
        let count = level_count(base[0].width);
        let mut levels = vec![base];
        while levels.len() < count {
            let prev = levels.last().expect("at least one level");
            let mut next = par_faces(|f| {
                let (w, h, t) = prev[f].downsampled_interior();
                Level::from_interior(w, h, &t)
            });
            fill_borders(&mut next);
            levels.push(next);
        }
        let half_size = levels[0][0].width as f32 / 2.0;
        CubeMap { levels, log2_half_size: half_size.log2(), half_size }
    }

    pub fn face_size(&self) -> u32 {
        self.levels[0][0].width as u32
    }

    pub fn level_count(&self) -> usize {
        self.levels.len()
    }

    /// The finest level's six faces, borders included (what [`CubeMap::lookup`] reads).
    pub(crate) fn finest(&self) -> &[Level; 6] {
        &self.levels[0]
    }

    /// Face `face` of level `level` (finest first).
    #[inline(always)]
    pub(super) fn level(&self, level: usize, face: usize) -> &Level {
        &self.levels[level][face]
    }

    /// The finest level of `face`, as stored (t = 0 at the top).
    pub fn face_image(&self, face: CubeFace) -> TextureImage {
        let l = &self.levels[0][face.index()];
        TextureImage { width: l.width as u32, height: l.height as u32, texels: l.interior() }
    }

    /// Seamless bilinear lookup at the finest level. `dir` is a world direction of any
    /// non-zero length.
    #[inline]
    pub fn lookup(&self, dir: Vec3) -> Rgb {
        let (f, s, t, _) = face_st_cube(Vec3::new(dir.x, dir.y, -dir.z));
        sample(&self.levels[0][f], s, t)
    }

    /// Trilinear lookup for a ray footprint of `cone_angle` radians (its angular width): the
    /// mip level is where a texel, seen from the centre at this direction, is as wide as the
    /// footprint. Footprints smaller than a finest texel read the finest level (bilinear).
    #[inline]
    pub fn lookup_filtered(&self, dir: Vec3, cone_angle: f32) -> Rgb {
        let c = Vec3::new(dir.x, dir.y, -dir.z);
        let (f, s, t, ma) = face_st_cube(c);
        // A texel of a face of side n subtends a solid angle (2/n)² m³ at the direction whose
        // major component is m = |major| / |dir|: its angular width is (2/n) m^1.5, and the
        // level is log2(cone / that) = log2(cone) + log2(n/2) + ¾ log2|dir|² − 1.5 log2|major|
        // (all in bit-trick logs: no division, no square root). Magnified footprints (λ ≤ 0,
        // most camera rays) are told apart first without logs: λ ≤ 0 ⟺ (cone·n/2)⁴ |dir|⁶ ≤ |major|⁶.
        let k = cone_angle * self.half_size;
        let (l2, ma3) = (c.length_squared(), ma * ma * ma);
        if (k * k) * (k * k) * (l2 * l2 * l2) <= ma3 * ma3 || cone_angle.is_nan() {
            return sample(&self.levels[0][f], s, t);
        }
        let lambda = fast_log2(cone_angle) + self.log2_half_size + 0.75 * fast_log2(l2) - 1.5 * fast_log2(ma);
        if lambda.is_nan() || lambda <= 0.0 {
            return sample(&self.levels[0][f], s, t);
        }
        let (l0, w) = mip_blend(lambda, self.levels.len());
        if w >= 1.0 {
            return sample(&self.levels[l0 + 1][f], s, t);
        }
        let a = sample(&self.levels[l0][f], s, t);
        if w <= 0.0 {
            return a;
        }
        let b = sample(&self.levels[l0 + 1][f], s, t);
        a + (b - a) * w
    }
}

/// `make(face)` for the six faces, on rayon's threads.
fn par_faces(make: impl Fn(usize) -> Level + Sync) -> [Level; 6] {
    use rayon::prelude::*;
    let mut levels: Vec<Level> = (0..6).into_par_iter().map(&make).collect();
    let mut take = |i: usize| std::mem::replace(&mut levels[i], Level::from_interior(0, 0, &[]));
    [take(0), take(1), take(2), take(3), take(4), take(5)]
}

#[inline(always)]
fn sample(level: &Level, s: f32, t: f32) -> Rgb {
    level.bilinear(s * level.size.x, t * level.size.y)
}

/// Copies into each face's border the texels of the faces it meets, and puts the mean of the
/// three corner texels into each border corner.
fn fill_borders(faces: &mut [Level; 6]) {
    let n = faces[0].width as isize;
    // A point just past the edge of this face, on its plane, is looked up on the face it
    // lands on; the nudge keeps the along-edge coordinate well inside its texel.
    const PAST: f32 = 1e-5;
    let coord = |i: isize| -> f32 {
        if i < 0 {
            -PAST
        } else if i >= n {
            1.0 + PAST
        } else {
            (i as f32 + 0.5) / n as f32
        }
    };
    for f in 0..6 {
        let mut border = Vec::with_capacity(4 * n as usize);
        for i in 0..n {
            for (x, y) in [(-1, i), (n, i), (i, -1), (i, n)] {
                let (g, s, t, _) = face_st_cube(direction_cube(f, coord(x), coord(y)));
                let xs = ((s * n as f32) as isize).clamp(0, n - 1);
                let ys = ((t * n as f32) as isize).clamp(0, n - 1);
                border.push((x, y, faces[g].get(xs, ys)));
            }
        }
        for (x, y, c) in border {
            faces[f].set(x, y, c);
        }
    }
    for face in faces.iter_mut() {
        for (x, y) in [(-1, -1), (n, -1), (-1, n), (n, n)] {
            let (xc, yc) = (x.clamp(0, n - 1), y.clamp(0, n - 1));
            let mean = (face.get(xc, yc) + face.get(x, yc) + face.get(xc, y)) / 3.0;
            face.set(x, y, mean);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const EPS: f32 = 1e-6;

    #[test]
    fn axes_hit_face_centres() {
        // World → cube is (x, y, −z): world −Z is the +Z (front) face.
        let cases = [
            (Vec3::X, CubeFace::PosX),
            (-Vec3::X, CubeFace::NegX),
            (Vec3::Y, CubeFace::PosY),
            (-Vec3::Y, CubeFace::NegY),
            (-Vec3::Z, CubeFace::PosZ),
            (Vec3::Z, CubeFace::NegZ),
        ];
        for (d, face) in cases {
            let (f, s, t) = cube_face_st(d);
            assert_eq!(f, face, "{d}");
            assert!((s - 0.5).abs() < EPS && (t - 0.5).abs() < EPS, "{d}: {s} {t}");
        }
    }

    #[test]
    fn table_orientation_per_face() {
        // (world direction, face, s, t) straight from DESIGN.md's table with z negated.
        let k = 0.5; // a direction half-way to the face's edge lands at 0.25 / 0.75
        let cases = [
            // +X: s = −z_c = z_world, t = −y.
            (Vec3::new(1.0, k, 0.0), CubeFace::PosX, 0.5, 0.25),
            (Vec3::new(1.0, 0.0, k), CubeFace::PosX, 0.75, 0.5),
            // −X: s = z_c = −z_world, t = −y.
            (Vec3::new(-1.0, 0.0, k), CubeFace::NegX, 0.25, 0.5),
            (Vec3::new(-1.0, -k, 0.0), CubeFace::NegX, 0.5, 0.75),
            // +Y: s = x, t = z_c = −z_world.
            (Vec3::new(k, 1.0, 0.0), CubeFace::PosY, 0.75, 0.5),
            (Vec3::new(0.0, 1.0, k), CubeFace::PosY, 0.5, 0.25),
            // −Y: s = x, t = −z_c = z_world.
            (Vec3::new(k, -1.0, 0.0), CubeFace::NegY, 0.75, 0.5),
            (Vec3::new(0.0, -1.0, k), CubeFace::NegY, 0.5, 0.75),
            // +Z (world −Z, front): s = x, t = −y: right is +s, up is −t.
            (Vec3::new(k, 0.0, -1.0), CubeFace::PosZ, 0.75, 0.5),
            (Vec3::new(0.0, k, -1.0), CubeFace::PosZ, 0.5, 0.25),
            // −Z (world +Z, back): s = −x.
            (Vec3::new(k, 0.0, 1.0), CubeFace::NegZ, 0.25, 0.5),
            (Vec3::new(0.0, -k, 1.0), CubeFace::NegZ, 0.5, 0.75),
        ];
        for (d, face, s0, t0) in cases {
            let (f, s, t) = cube_face_st(d);
            assert_eq!(f, face, "{d}");
            assert!((s - s0).abs() < EPS && (t - t0).abs() < EPS, "{d}: got ({s}, {t}), want ({s0}, {t0})");
        }
    }

    #[test]
    fn diagonals_land_on_face_corners() {
        // A direction off the face diagonal by a hair picks the face of its largest component
        // and lands within a hair of that face's corner.
        for sx in [-1.0f32, 1.0] {
            for sy in [-1.0f32, 1.0] {
                for sz in [-1.0f32, 1.0] {
                    for major in 0..3 {
                        let mut d = Vec3::new(sx, sy, sz);
                        d[major] *= 1.001;
                        let (f, s, t) = cube_face_st(d);
                        assert_eq!(f.index() / 2, major, "{d}");
                        let near = |v: f32| !(0.001..=0.999).contains(&v);
                        assert!(near(s) && near(t), "{d}: {s} {t}");
                        // Going back gives the same direction.
                        let back = cube_direction(f, s, t);
                        assert!(back.normalize().dot(d.normalize()) > 1.0 - 1e-6);
                    }
                }
            }
        }
        // Edge diagonals (two equal components) stay within the face they pick.
        for d in [Vec3::new(1.0, 1.0, 0.0), Vec3::new(0.0, -1.0, 1.0), Vec3::new(-1.0, 0.0, -1.0)] {
            let (_, s, t) = cube_face_st(d);
            assert!((0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t));
        }
    }

    #[test]
    fn direction_inverts_face_st_everywhere() {
        for face in CubeFace::ALL {
            for i in 0..=10 {
                for j in 0..=10 {
                    let (s, t) = (i as f32 / 10.0 * 0.98 + 0.01, j as f32 / 10.0 * 0.98 + 0.01);
                    let (f, s2, t2) = cube_face_st(cube_direction(face, s, t));
                    assert_eq!(f, face);
                    assert!((s - s2).abs() < 1e-5 && (t - t2).abs() < 1e-5);
                }
            }
        }
    }

    /// A smooth function of direction, different on every face.
    fn smooth(d: Vec3) -> Rgb {
        let d = d.normalize();
        Rgb::new(
            1.0 + 0.5 * d.x + 0.25 * d.y * d.z,
            1.0 + 0.5 * d.y - 0.3 * d.x * d.x,
            1.0 + 0.5 * d.z + 0.2 * d.x * d.y,
        )
    }

    #[test]
    fn seamless_across_every_edge() {
        let n = 16u32;
        let map = CubeMap::from_fn(n, smooth);
        // The function's largest slope in texel units bounds the bilinear error; two samples a
        // hair apart on either side of an edge differ by no more than that error.
        let texel = 2.0 / n as f32;
        let bound = 0.25 * texel * texel * 2.0 + 1e-4; // ½ h² max|f''| with |f''| ≲ 1, both sides
        let mut worst = 0.0f32;
        for face in CubeFace::ALL {
            for i in 0..200 {
                let along = (i as f32 + 0.5) / 200.0;
                for (s, t) in [(0.0, along), (1.0, along), (along, 0.0), (along, 1.0)] {
                    let edge = cube_direction(face, s, t).normalize();
                    // Step across the edge: in along the face, and out onto the neighbour.
                    let inward = (cube_direction(face, 0.5, 0.5).normalize() - edge).normalize();
                    let a = map.lookup(edge + inward * 1e-4);
                    let b = map.lookup(edge - inward * 1e-4);
                    worst = worst.max((a - b).abs().max_element());
                    // And both agree with the function within the bilinear error.
                    let truth = smooth(edge);
                    assert!((a - truth).abs().max_element() < 0.02, "{face:?} {s} {t}: {a} vs {truth}");
                }
            }
        }
        assert!(worst <= bound, "jump across an edge {worst} > bound {bound}");
    }

    #[test]
    fn eight_corners_are_continuous() {
        let n = 16u32;
        let map = CubeMap::from_fn(n, smooth);
        for sx in [-1.0f32, 1.0] {
            for sy in [-1.0f32, 1.0] {
                for sz in [-1.0f32, 1.0] {
                    let corner = Vec3::new(sx, sy, sz);
                    let truth = smooth(corner);
                    let mut seen = Vec::new();
                    for major in 0..3 {
                        // Just inside each of the three faces that meet here.
                        let mut d = corner;
                        d[major] *= 1.0001;
                        let c = map.lookup(d);
                        // Within a texel of the corner, the bilinear error of a smooth function.
                        assert!((c - truth).abs().max_element() < 0.05, "corner {corner}: {c} vs {truth}");
                        seen.push(c);
                    }
                    for c in &seen {
                        assert!((*c - seen[0]).abs().max_element() < 0.02, "corner {corner}: {seen:?}");
                    }
                }
            }
        }
    }

    #[test]
    fn constant_map_is_constant_everywhere_at_every_level() {
        let c = Rgb::new(0.2, 0.5, 3.0);
        let map = CubeMap::from_fn(8, |_| c);
        assert_eq!(map.level_count(), 4);
        for i in 0..500 {
            let d = Vec3::new((i as f32 * 0.37).sin(), (i as f32 * 0.71).cos(), (i as f32 * 1.3).sin());
            for cone in [0.0, 0.01, 0.2, 1.0, 10.0] {
                // Within the storage precision, 2^-9 of the brightest channel.
                assert!((map.lookup_filtered(d, cone) - c).abs().max_element() < 3.0 / 256.0);
            }
        }
    }

    #[test]
    fn texel_centres_are_exact() {
        let map = CubeMap::from_fn(4, smooth);
        for face in CubeFace::ALL {
            let img = map.face_image(face);
            for y in 0..4 {
                for x in 0..4 {
                    let d = cube_direction(face, (x as f32 + 0.5) / 4.0, (y as f32 + 0.5) / 4.0);
                    let got = map.lookup(d);
                    assert!((got - img.texels[y * 4 + x]).abs().max_element() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn mip_levels_average_high_frequencies_away() {
        // A one-texel checkerboard: minified, it must read its mean, not alias.
        let n = 64usize;
        let checker = TextureImage {
            width: n as u32,
            height: n as u32,
            texels: (0..n * n).map(|i| if (i % n + i / n).is_multiple_of(2) { Rgb::ZERO } else { Rgb::ONE }).collect(),
        };
        let map = CubeMap::from_faces(std::array::from_fn(|_| checker.clone())).expect("valid faces");
        let texel = 2.0 / n as f32;
        for i in 0..100 {
            let d = Vec3::new(0.3 + i as f32 * 0.001, -0.2, -1.0);
            let c = map.lookup_filtered(d, 8.0 * texel);
            assert!((c.x - 0.5).abs() < 0.02, "{c}");
        }
    }

    #[test]
    fn bad_faces_are_rejected_with_the_face_named() {
        let sq = |n: u32| TextureImage { width: n, height: n, texels: vec![Rgb::ONE; (n * n) as usize] };
        let mut faces: [TextureImage; 6] = std::array::from_fn(|_| sq(4));
        faces[3] = TextureImage { width: 4, height: 3, texels: vec![Rgb::ONE; 12] };
        let e = CubeMap::from_faces(faces).expect_err("non-square");
        assert!(e.to_string().contains("ny") && e.to_string().contains("not square"), "{e}");
        let mut faces: [TextureImage; 6] = std::array::from_fn(|_| sq(4));
        faces[5] = sq(8);
        let e = CubeMap::from_faces(faces).expect_err("unequal");
        assert!(e.to_string().contains("nz") && e.to_string().contains("same size"), "{e}");
        let mut faces: [TextureImage; 6] = std::array::from_fn(|_| sq(4));
        faces[0].texels[5] = Rgb::new(f32::NAN, 0.0, 0.0);
        let e = CubeMap::from_faces(faces).expect_err("NaN");
        assert!(e.to_string().contains("(1, 1)"), "{e}");
        let faces: [TextureImage; 6] = std::array::from_fn(|_| sq(0));
        assert!(CubeMap::from_faces(faces).is_err());
    }
}
