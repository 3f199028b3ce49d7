//! Do six faces meet at their edges? A diagnostic for sets stored in another convention.
//!
//! Across each of the cube's 12 edges, the border texels of the two faces that meet there sit
//! one texel apart, as do a border texel and the texel just inside it. For a correctly
//! oriented set the jump across an edge is therefore about as large as the step just inside
//! the faces; for a flipped, turned or misnamed face it is the difference between unrelated
//! content. The score of an edge is the mean jump across it over the mean step inside
//! (values compressed by `x/(1+x)` and sRGB-encoded first, so HDR suns do not dominate); the
//! score of a set is the median over the 12 edges, which one flat or odd face cannot move, and
//! each face is also scored on its own 4 edges, so that one face turned alone is noticed.
//! Correct photographs score about 1 (JPEG blocks, ≈ 1–1.5), wrong ones several times that.

use super::transform::FaceTransform;
use glint_core::Rgb;
use glint_core::colour::linear_to_srgb;
use glint_scene::{CubeFace, TextureImage, cube_direction, cube_face_st};

/// Above this a set's faces do not meet.
pub(crate) const MISMATCHED: f32 = 2.5;
/// At or below this they do.
pub(crate) const MATCHED: f32 = 2.0;

/// How badly the faces (in [`CubeFace::ALL`] order) fail to meet along the cube's 12 edges:
/// the median over the edges of (mean |difference| between the border texels of the two faces
/// meeting there) / (mean |difference| between those border texels and the texels just inside
/// them). About 1 when the faces fit, several times that when a face is flipped, turned or
/// misnamed. NaN unless the faces are square, equal and at least 2 texels wide.
pub fn seam_mismatch(faces: &[TextureImage; 6]) -> f32 {
    match Seams::new(faces) {
        Some(seams) => seams.score(&[FaceTransform::IDENTITY; 6]),
        None => f32::NAN,
    }
}

/// One texel pair across an edge, with the texels just inside each.
#[derive(Clone, Copy, Debug)]
struct Pair {
    edge: usize,
    a: (usize, u32, u32),
    a_in: (u32, u32),
    b: (usize, u32, u32),
    b_in: (u32, u32),
}

/// The two outermost rings of texels of a face, compressed: all the seams look at. Flips and
/// quarter turns map these rings onto themselves.
struct Rings {
    n: u32,
    /// Rows 0, 1, n−2, n−1, then columns 0, 1, n−2, n−1; each n texels.
    lines: Vec<Rgb>,
}

impl Rings {
    fn new(face: &TextureImage) -> Rings {
        let n = face.width;
        let at = |x: u32, y: u32| compress(face.texels[(y * n + x) as usize]);
        let ends = [0, 1, n - 2, n - 1];
        let mut lines = Vec::with_capacity(8 * n as usize);
        for &y in &ends {
            lines.extend((0..n).map(|x| at(x, y)));
        }
        for &x in &ends {
            lines.extend((0..n).map(|y| at(x, y)));
        }
        Rings { n, lines }
    }

    /// Texel (x, y), which must lie on one of the two outer rings.
    fn get(&self, x: u32, y: u32) -> Rgb {
        let n = self.n;
        let line = |v: u32| if v < 2 { v } else { v + 4 - n };
        let i = if y < 2 || y >= n - 2 { line(y) * n + x } else { (4 + line(x)) * n + y };
        self.lines[i as usize]
    }
}

/// The faces' outer rings and the texel pairs along all 12 edges.
pub(crate) struct Seams {
    rings: [Rings; 6],
    n: u32,
    pairs: Vec<Pair>,
}

impl Seams {
    pub(crate) fn new(faces: &[TextureImage; 6]) -> Option<Seams> {
        let n = faces[0].width;
        let fits = |f: &TextureImage| f.width == n && f.height == n && f.texels.len() == (n * n) as usize;
        if n < 2 || !faces.iter().all(fits) {
            return None;
        }
        Some(Seams { rings: std::array::from_fn(|f| Rings::new(&faces[f])), n, pairs: pairs(n) })
    }

    /// Texel (x, y) of face `f` after `transform`, compressed.
    fn texel(&self, f: usize, transform: &FaceTransform, x: u32, y: u32) -> Rgb {
        let (sx, sy) = transform.source_texel(x, y, self.n, self.n);
        self.rings[f].get(sx, sy)
    }

    /// The 12 edge scores with `transforms[f]` applied to face f.
    fn edge_scores(&self, transforms: &[FaceTransform; 6]) -> [f32; 12] {
        let mut jump = [0.0f64; 12];
        let mut step = [0.0f64; 12];
        for p in &self.pairs {
            let (fa, xa, ya) = p.a;
            let (fb, xb, yb) = p.b;
            let a = self.texel(fa, &transforms[fa], xa, ya);
            let b = self.texel(fb, &transforms[fb], xb, yb);
            let a_in = self.texel(fa, &transforms[fa], p.a_in.0, p.a_in.1);
            let b_in = self.texel(fb, &transforms[fb], p.b_in.0, p.b_in.1);
            jump[p.edge] += f64::from((a - b).abs().element_sum());
            step[p.edge] += f64::from(((a - a_in).abs() + (b - b_in).abs()).element_sum()) * 0.5;
        }
        // Per edge the counts of both sums are equal, so the ratio of sums is the ratio of means;
        // the offset (about a quarter of an 8-bit step, per texel and channel) keeps flat areas
        // from dividing nothing by nothing.
        let offset = 1.0e-3 * 3.0 * f64::from(self.n);
        std::array::from_fn(|e| ((jump[e] + offset) / (step[e] + offset)) as f32)
    }

    /// The set's score: the median edge score.
    pub(crate) fn score(&self, transforms: &[FaceTransform; 6]) -> f32 {
        let mut scores = self.edge_scores(transforms);
        scores.sort_by(f32::total_cmp);
        0.5 * (scores[5] + scores[6])
    }

    /// Face `f`'s own score: the median of its 4 edges (the mean of the middle two). A face
    /// turned or flipped against its neighbours spoils all four of its edges, while each of its
    /// neighbours loses only one of theirs, so this singles the turned face out where the set's
    /// median over 12 edges does not move.
    fn face_median(&self, f: usize, transforms: &[FaceTransform; 6]) -> f32 {
        let scores = self.edge_scores(transforms);
        let mut own: Vec<f32> =
            EDGES.iter().zip(scores).filter(|((a, b), _)| *a == f || *b == f).map(|(_, s)| s).collect();
        own.sort_by(f32::total_cmp);
        0.5 * (own[1] + own[2])
    }

    /// The worst face by [`Seams::face_median`], with its score.
    fn worst_face(&self, transforms: &[FaceTransform; 6]) -> (usize, f32) {
        (0..6).map(|f| (f, self.face_median(f, transforms))).fold((0, f32::MIN), |a, b| if b.1 > a.1 { b } else { a })
    }

    /// The mean score of the 4 edges of face `f`.
    fn face_score(&self, f: usize, transforms: &[FaceTransform; 6]) -> f32 {
        let scores = self.edge_scores(transforms);
        EDGES.iter().zip(scores).filter(|((a, b), _)| *a == f || *b == f).map(|(_, s)| s).sum::<f32>() / 4.0
    }
}

/// The 12 edges as pairs of face indices (each pair of non-opposite faces meets once).
const EDGES: [(usize, usize); 12] =
    [(0, 2), (0, 3), (0, 4), (0, 5), (1, 2), (1, 3), (1, 4), (1, 5), (2, 4), (2, 5), (3, 4), (3, 5)];

fn edge_index(f: usize, g: usize) -> usize {
    let key = (f.min(g), f.max(g));
    EDGES.iter().position(|&e| e == key).unwrap_or(0)
}

/// Every border texel of every face, paired with the texel of the neighbouring face that a
/// point just past the edge lands on (found through the cube geometry itself, so the pairing
/// follows DESIGN.md §4 by construction).
fn pairs(n: u32) -> Vec<Pair> {
    const PAST: f32 = 1.0e-4;
    let nf = n as f32;
    let centre = |i: u32| (i as f32 + 0.5) / nf;
    let mut pairs = Vec::with_capacity(24 * n as usize);
    for face in CubeFace::ALL {
        let f = face.index();
        for i in 0..n {
            // (s, t) just past the edge, this face's border texel and the one inside it.
            let sides = [
                ((-PAST, centre(i)), (0, i), (1, i)),
                ((1.0 + PAST, centre(i)), (n - 1, i), (n - 2, i)),
                ((centre(i), -PAST), (i, 0), (i, 1)),
                ((centre(i), 1.0 + PAST), (i, n - 1), (i, n - 2)),
            ];
            for ((s, t), (x, y), inside) in sides {
                let (g_face, gs, gt) = cube_face_st(cube_direction(face, s, t));
                let g = g_face.index();
                if g == f {
                    continue;
                }
                let gx = ((gs * nf) as u32).min(n - 1);
                let gy = ((gt * nf) as u32).min(n - 1);
                // Which border of g the point is on: the coordinate nearest 0 or 1.
                let distances = [gs, 1.0 - gs, gt, 1.0 - gt];
                let nearest = (0..4).min_by(|&a, &b| distances[a].total_cmp(&distances[b])).unwrap_or(0);
                let b_in = match nearest {
                    0 => (1, gy),
                    1 => (n - 2, gy),
                    2 => (gx, 1),
                    _ => (gx, n - 2),
                };
                pairs.push(Pair { edge: edge_index(f, g), a: (f, x, y), a_in: inside, b: (g, gx, gy), b_in });
            }
        }
    }
    pairs
}

/// Linear radiance → a perceptual value in [0, 1): `x/(1+x)`, then the sRGB OETF.
fn compress(c: Rgb) -> Rgb {
    let f = |v: f32| if v > 0.0 { linear_to_srgb(v / (1.0 + v)) } else { 0.0 };
    Rgb::new(f(c.x), f(c.y), f(c.z))
}

/// A fix found for faces that do not meet.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct SeamFix {
    /// The transform for all faces (only flips are suggested for all faces).
    pub all_faces: FaceTransform,
    /// Further transforms of single faces, after `all_faces`.
    pub per_face: [FaceTransform; 6],
    /// The score with the fix.
    pub score: f32,
}

impl SeamFix {
    /// The scene-file keys that apply the fix: `flip = "vertical"`,
    /// `[sky.face.py] rotate = 90`, … joined by "; ".
    pub(crate) fn toml(&self) -> String {
        let mut parts = Vec::new();
        if !self.all_faces.is_identity() {
            parts.push(format!("set flip = \"{}\"", self.all_faces.flip_name()));
        }
        for face in CubeFace::ALL {
            let t = self.per_face[face.index()];
            if t.is_identity() {
                continue;
            }
            let mut keys = Vec::new();
            // Flipped both ways is a half turn: said as the turn, which is how sets differ.
            let both = t.flip_horizontal && t.flip_vertical;
            let rotate = if both { (t.rotate_degrees + 180) % 360 } else { t.rotate_degrees };
            if (t.flip_horizontal || t.flip_vertical) && !both {
                keys.push(format!("flip = \"{}\"", t.flip_name()));
            }
            if rotate != 0 {
                keys.push(format!("rotate = {rotate}"));
            }
            parts.push(format!("[sky.face.{}] {}", face.short_name(), keys.join(", ")));
        }
        parts.join("; ")
    }

    /// In words: "flipped vertically", "with py turned 90° clockwise", …
    pub(crate) fn describe(&self) -> String {
        let mut parts = Vec::new();
        if !self.all_faces.is_identity() {
            parts.push(self.all_faces.describe());
        }
        for face in CubeFace::ALL {
            let t = self.per_face[face.index()];
            if t.flip_horizontal && t.flip_vertical {
                // Flipped both ways is a half turn (as `toml` says it).
                let turn = FaceTransform::rotate((t.rotate_degrees + 180) % 360);
                parts.push(format!("{} {}", face.short_name(), turn.describe()));
            } else if !t.is_identity() {
                parts.push(format!("{} {}", face.short_name(), t.describe()));
            }
        }
        parts.join(", ")
    }
}

/// The faces' score as they are — the worse of the set's median edge and the worst face's own
/// median edge ([`Seams::face_median`]), so one turned face is noticed — and, when they do not
/// meet, the simplest fix that makes them: all faces flipped (horizontally, vertically, both),
/// then single faces flipped or turned where that helps a lot.
pub(crate) fn diagnose(faces: &[TextureImage; 6]) -> Option<(f32, Option<SeamFix>)> {
    let seams = Seams::new(faces)?;
    let identity = [FaceTransform::IDENTITY; 6];
    let overall = |t: &[FaceTransform; 6]| seams.score(t).max(seams.worst_face(t).1);
    let set_score = seams.score(&identity);
    let score = overall(&identity);
    if score <= MISMATCHED {
        return Some((score, None));
    }
    let mut best = SeamFix { all_faces: FaceTransform::IDENTITY, per_face: identity, score: set_score };
    for flip in [FaceTransform::flip(false, true), FaceTransform::flip(true, false), FaceTransform::flip(true, true)] {
        let s = seams.score(&[flip; 6]);
        // Prefer the simpler fix unless another is clearly better.
        if s < best.score * 0.9 {
            best = SeamFix { all_faces: flip, per_face: identity, score: s };
        }
    }
    // Single faces, from the best global flip: a face is changed only if its own edges get
    // much better. Two passes let a fixed face help its neighbours' decisions.
    let combined =
        |fix: &SeamFix| -> [FaceTransform; 6] { std::array::from_fn(|f| compose(fix.all_faces, fix.per_face[f])) };
    for _ in 0..2 {
        for f in 0..6 {
            let mut transforms = combined(&best);
            let current = seams.face_score(f, &transforms);
            let mut choice = (best.per_face[f], current);
            for t in FaceTransform::ALL_DISTINCT {
                transforms[f] = compose(best.all_faces, t);
                let s = seams.face_score(f, &transforms);
                if s < choice.1 * 0.5 {
                    choice = (t, s);
                }
            }
            best.per_face[f] = choice.0;
        }
        best.score = overall(&combined(&best));
    }
    let fixed = best.score <= MATCHED && best.score < score * 0.5;
    if !fixed && set_score <= MISMATCHED {
        // One odd face that no flip or turn explains (a plain `down` face, a logo): not a
        // convention problem, and the set as a whole meets.
        return Some((set_score, None));
    }
    Some((score, fixed.then_some(best)))
}

/// A transform equal to `first` followed by `then`, as one [`FaceTransform`].
fn compose(first: FaceTransform, then: FaceTransform) -> FaceTransform {
    let probe = |t: &FaceTransform| {
        let n = 3;
        (0..n * n).map(|i| t.source_texel(i % n, i / n, n, n)).collect::<Vec<_>>()
    };
    // The composite maps output texel p to first.source(then.source(p)).
    let n = 3;
    let want: Vec<(u32, u32)> = (0..n * n)
        .map(|i| {
            let (x, y) = then.source_texel(i % n, i / n, n, n);
            first.source_texel(x, y, n, n)
        })
        .collect();
    FaceTransform::ALL_DISTINCT.into_iter().find(|t| probe(t) == want).unwrap_or(FaceTransform::IDENTITY)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::test_util::smooth_faces;

    fn transformed(faces: &[TextureImage; 6], t: [FaceTransform; 6]) -> [TextureImage; 6] {
        std::array::from_fn(|f| t[f].apply(&faces[f]))
    }

    #[test]
    fn pairs_cover_every_edge_symmetrically() {
        let n = 5;
        let p = pairs(n);
        assert_eq!(p.len(), 24 * n as usize);
        for e in 0..12 {
            assert_eq!(p.iter().filter(|q| q.edge == e).count(), 2 * n as usize, "edge {e}");
        }
        // Pairing is symmetric: if a texel of f pairs with one of g, that one pairs back.
        for q in &p {
            assert!(p.iter().any(|r| r.a == q.b && r.b == q.a), "{q:?}");
        }
    }

    #[test]
    fn a_consistent_cube_scores_about_one_and_flips_score_high() {
        let faces = smooth_faces(32);
        let score = seam_mismatch(&faces);
        assert!((0.5..1.3).contains(&score), "{score}");
        let flipped = transformed(&faces, [FaceTransform::flip(false, true); 6]);
        let bad = seam_mismatch(&flipped);
        assert!(bad > 3.0, "{bad}");
        assert!(seam_mismatch(&std::array::from_fn(|_| faces[0].clone())).is_finite());
        let mut unequal = faces.clone();
        unequal[3] = TextureImage { width: 4, height: 4, texels: vec![Rgb::ZERO; 16] };
        assert!(seam_mismatch(&unequal).is_nan());
    }

    #[test]
    fn diagnose_finds_the_flip_and_a_turned_face() {
        let faces = smooth_faces(32);
        assert_eq!(diagnose(&faces).expect("square").1, None);

        let flipped = transformed(&faces, [FaceTransform::flip(false, true); 6]);
        let (score, fix) = diagnose(&flipped).expect("square");
        let fix = fix.expect("a fix");
        assert!(score > MISMATCHED && fix.score <= MATCHED, "{score} {fix:?}");
        assert_eq!(fix.all_faces, FaceTransform::flip(false, true));
        assert_eq!(fix.per_face, [FaceTransform::IDENTITY; 6]);
        assert_eq!(fix.toml(), "set flip = \"vertical\"");

        // The up face turned a quarter clockwise: undone by a quarter turn back.
        let mut t = [FaceTransform::IDENTITY; 6];
        t[2] = FaceTransform::rotate(90);
        let turned = transformed(&faces, t);
        let (score, fix) = diagnose(&turned).expect("square");
        // One face of six spoils only 4 of 12 edges, which the set's median does not see; the
        // face's own edges do (issue 20).
        let fix = fix.expect("a fix for one turned face");
        assert!(score > MISMATCHED, "{score}");
        assert_eq!(fix.per_face[2], FaceTransform::rotate(270), "{fix:?}");
        assert!(fix.per_face.iter().enumerate().all(|(f, t)| f == 2 || t.is_identity()), "{fix:?}");
        // Two faces turned spoil 7 edges: now it must be found.
        t[4] = FaceTransform::rotate(180);
        let turned = transformed(&faces, t);
        let (score, fix) = diagnose(&turned).expect("square");
        let fix = fix.expect("a fix");
        assert!(score > MISMATCHED, "{score}");
        assert_eq!(fix.per_face[2], FaceTransform::rotate(270), "{fix:?}");
        assert!(fix.per_face[4].source_texel(0, 0, 3, 3) == (2, 2), "{fix:?}");
        assert!(fix.toml().contains("[sky.face.py] rotate = 270"), "{}", fix.toml());
    }

    #[test]
    fn one_face_turned_or_flipped_alone_is_found_with_its_fix() {
        let faces = smooth_faces(32);
        for (face, turn, undo) in [
            (3, FaceTransform::rotate(180), "[sky.face.ny] rotate = 180"),
            (5, FaceTransform::rotate(90), "[sky.face.nz] rotate = 270"),
            (0, FaceTransform::flip(true, false), "[sky.face.px] flip = \"horizontal\""),
        ] {
            let mut t = [FaceTransform::IDENTITY; 6];
            t[face] = turn;
            let turned = transformed(&faces, t);
            assert!(seam_mismatch(&turned) <= MISMATCHED, "the set's median alone does not see it");
            let (score, fix) = diagnose(&turned).expect("square");
            let fix = fix.unwrap_or_else(|| panic!("face {face}: no fix (score {score})"));
            assert!(score > MISMATCHED && fix.score <= MATCHED, "{score} {fix:?}");
            assert_eq!(fix.toml(), undo);
            // Applying the fix gives back the consistent set.
            let fixed = transformed(&turned, fix.per_face);
            assert_eq!(diagnose(&fixed).expect("square").1, None);
        }
    }

    #[test]
    fn a_plain_face_is_not_a_turned_face() {
        let mut faces = smooth_faces(32);
        faces[3].texels.fill(Rgb::new(0.2, 0.2, 0.2));
        let (score, fix) = diagnose(&faces).expect("square");
        assert!(score <= MISMATCHED && fix.is_none(), "{score} {fix:?}");
    }

    #[test]
    fn compose_matches_applying_twice() {
        let faces = smooth_faces(4);
        for a in FaceTransform::ALL_DISTINCT {
            for b in FaceTransform::ALL_DISTINCT {
                assert_eq!(compose(a, b).apply(&faces[0]), b.apply(&a.apply(&faces[0])), "{a:?} {b:?}");
            }
        }
    }
}
