//! Pull-push interpolation with depth intervals and elliptical box filters (Marroquim, Kraus
//! and Cavalcanti 2007, §3.2–3.3; DESIGN.md §3).
//!
//! A [`Texel`] is one pixel of one pyramid level: a depth interval, a camera-space normal, a
//! radius and a displacement vector in that level's pixels, a colour and a material. The pull
//! builds coarser levels from finer ones (each coarse texel averages the children whose depth
//! interval meets the frontmost child's); the push recomputes, from the coarser level, the fine
//! texels that are invalid or occluded (behind their parent's interval), weighting the four
//! nearest coarse texels 9/3/3/1 and leaving out those whose ellipse misses the fine pixel's
//! centre. Level 0 is not stored here: the renderer reads it from the depth buffer (see
//! `mod.rs`), so the finest level costs no extra pass.
//!
//! Coordinates: texel (x, y) of a level covers [x, x+1) × [y, y+1) in that level's pixels; the
//! coarse texel (X, Y) covers the fine texels (2X..2X+1, 2Y..2Y+1), so a fine coordinate is
//! twice the coarse one.

use glint_core::{Rgb, Vec2, Vec3};
use rayon::prelude::*;

/// One pixel of a pyramid level. Invalid texels have `z_min = +inf`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Texel {
    /// Depth interval [z, z + r] in linear eye depth (camera units).
    pub z_min: f32,
    pub z_max: f32,
    /// Mean depth of the points averaged into the texel: the surface's depth for shading and
    /// the depth AOV (the interval's ends are biased toward the front and back).
    pub depth: f32,
    /// Camera-space unit normal (x right, y down, z forward), facing the camera (z ≤ 0 mostly).
    pub normal: Vec3,
    /// Radius of the disc in this level's pixels.
    pub radius: f32,
    pub colour: Rgb,
    /// Ellipse centre − texel centre, in this level's pixels.
    pub displacement: Vec2,
    /// Material of the point(s) that made the texel.
    pub material: u32,
}

impl Texel {
    pub const INVALID: Texel = Texel {
        z_min: f32::INFINITY,
        z_max: f32::INFINITY,
        depth: f32::INFINITY,
        normal: Vec3::ZERO,
        radius: 0.0,
        colour: Rgb::ZERO,
        displacement: Vec2::ZERO,
        material: u32::MAX,
    };

    #[inline]
    pub fn is_valid(&self) -> bool {
        self.z_min < f32::INFINITY
    }
}

impl Default for Texel {
    fn default() -> Self {
        Texel::INVALID
    }
}

/// The texels x in `lo..hi` of a row: where its valid texels lie (every texel outside is
/// invalid). Most rows of most images hold a surface in part of their width only, or none:
/// the passes skip the rest of the row.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Span {
    pub lo: u32,
    pub hi: u32,
}

impl Span {
    pub const EMPTY: Span = Span { lo: 0, hi: 0 };

    #[inline]
    pub fn is_empty(self) -> bool {
        self.lo >= self.hi
    }

    /// The smallest span holding both.
    #[inline]
    pub fn union(self, o: Span) -> Span {
        match (self.is_empty(), o.is_empty()) {
            (true, _) => o,
            (_, true) => self,
            _ => Span { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi) },
        }
    }

    /// The fine texels (of a row `width` wide) whose four nearest coarse texels (the push's
    /// 9/3/3/1 stencil: the parent x/2 and the one beside it, x/2 − 1 for even x and x/2 + 1
    /// for odd x) include one of this coarse span: 2·lo − 1 (odd, beside lo) up to 2·hi (even,
    /// beside hi − 1).
    #[inline]
    pub fn to_fine(self, width: u32) -> Span {
        if self.is_empty() {
            return Span::EMPTY;
        }
        Span { lo: (2 * self.lo).saturating_sub(1), hi: (2 * self.hi + 1).min(width) }
    }

    /// The coarse texels with a child in this fine span.
    #[inline]
    pub fn to_coarse(self) -> Span {
        if self.is_empty() {
            return Span::EMPTY;
        }
        Span { lo: self.lo / 2, hi: self.hi.div_ceil(2) }
    }

    /// The span of the valid texels among `row[range]` (`range` holding every valid one).
    #[inline]
    fn of_valid(row: &[Texel], range: Span) -> Span {
        let r = &row[range.lo as usize..range.hi as usize];
        match (r.iter().position(Texel::is_valid), r.iter().rposition(Texel::is_valid)) {
            (Some(a), Some(b)) => Span { lo: range.lo + a as u32, hi: range.lo + b as u32 + 1 },
            _ => Span::EMPTY,
        }
    }
}

/// One level of the pyramid.
#[derive(Clone, Debug, Default)]
pub struct Level {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Texel>,
    /// Per row, where its valid texels lie.
    pub spans: Vec<Span>,
}

impl Level {
    pub fn resize(&mut self, width: u32, height: u32) {
        self.width = width;
        self.height = height;
        crate::first_touch::resize(&mut self.texels, width as usize * height as usize, Texel::INVALID);
        self.spans.clear();
        self.spans.resize(height as usize, Span::EMPTY);
    }

    /// The span of row `y`, empty outside the level.
    #[inline]
    pub fn span(&self, y: i64) -> Span {
        if y < 0 { Span::EMPTY } else { self.spans.get(y as usize).copied().unwrap_or(Span::EMPTY) }
    }

    /// The texel at (x, y), or an invalid one outside the level.
    #[inline]
    pub fn at(&self, x: i64, y: i64) -> Texel {
        if x < 0 || y < 0 || x >= i64::from(self.width) || y >= i64::from(self.height) {
            Texel::INVALID
        } else {
            self.texels[y as usize * self.width as usize + x as usize]
        }
    }
}

/// Smallest |n_z| used for the ellipse's minor axis: a disc seen exactly edge-on would cover no
/// pixel centre at all, yet its own pixel shows it.
const MIN_NZ: f32 = 0.1;

/// What a child left out of [`pull_texel`]'s sums adds: zero to the sums, nothing to the
/// interval (+∞ to its minimum, −∞ to its maximum).
const LEFT_OUT: Texel = Texel {
    z_min: f32::INFINITY,
    z_max: f32::NEG_INFINITY,
    depth: 0.0,
    normal: Vec3::ZERO,
    radius: 0.0,
    colour: Rgb::ZERO,
    displacement: Vec2::ZERO,
    material: u32::MAX,
};

/// Pull (§3.2): the coarse texel made of the valid children (given with their offsets from the
/// coarse texel's centre, in fine pixels) whose depth intervals meet the frontmost child's.
#[inline]
pub fn pull_texel(children: [(Texel, Vec2); 4]) -> Texel {
    let front = children.iter().fold(Texel::INVALID, |f, (c, _)| if c.z_min < f.z_min { *c } else { f });
    if !front.is_valid() {
        return Texel::INVALID;
    }
    let (mut n, mut z_min, mut z_max, mut depth) = (0.0f32, f32::INFINITY, f32::NEG_INFINITY, 0.0f32);
    let (mut normal, mut radius, mut colour, mut displacement) = (Vec3::ZERO, 0.0, Rgb::ZERO, Vec2::ZERO);
    for (c, offset) in &children {
        // Valid and its interval meets the frontmost one's (whose z_min is the smallest).
        // Without a branch (which children join varies near silhouettes): one left out adds
        // +0.0 to each sum, which leaves its bits as they are (no sum is ever −0.0).
        let joins = c.z_min <= front.z_max;
        let (c, add) = if joins { (c, c.displacement + *offset) } else { (&LEFT_OUT, Vec2::ZERO) };
        n += if joins { 1.0 } else { 0.0 };
        z_min = z_min.min(c.z_min);
        z_max = z_max.max(c.z_max);
        depth += c.depth;
        normal += c.normal;
        radius += c.radius;
        colour += c.colour;
        displacement += add;
    }
    let inv = 1.0 / n;
    Texel {
        z_min,
        z_max,
        depth: depth * inv,
        normal: normal.normalize_or(front.normal),
        // Halved: the coarse level's pixels are twice as large.
        radius: radius * inv * 0.5,
        colour: colour * inv,
        displacement: displacement * (inv * 0.5),
        material: front.material,
    }
}

/// The children's offsets from their coarse texel's centre, in fine pixels, in the order
/// (x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1).
pub const CHILD_OFFSETS: [Vec2; 4] =
    [Vec2::new(-0.5, -0.5), Vec2::new(0.5, -0.5), Vec2::new(-0.5, 0.5), Vec2::new(0.5, 0.5)];

/// Pull one coarse row: texels in `candidates` made by `make(cx)`, the others invalid; the
/// row's span is that of what `make` gave valid.
#[inline]
pub fn pull_row(row: &mut [Texel], span: &mut Span, candidates: Span, make: impl Fn(usize) -> Texel) {
    let c = Span { lo: candidates.lo.min(row.len() as u32), hi: candidates.hi.min(row.len() as u32) };
    let (lo, hi) = if c.is_empty() { (0, 0) } else { (c.lo as usize, c.hi as usize) };
    row[..lo].fill(Texel::INVALID);
    row[hi..].fill(Texel::INVALID);
    for (cx, out) in row[lo..hi].iter_mut().enumerate() {
        *out = make(lo + cx);
    }
    *span = Span::of_valid(row, c);
}

/// Build `coarse` (already sized `ceil(w/2) × ceil(h/2)`) from `fine`, row-parallel, visiting
/// only the texels whose children lie in the fine rows' spans.
pub fn pull_level(fine: &Level, coarse: &mut Level) {
    let cw = coarse.width as usize;
    let rows = coarse.texels.par_chunks_mut(cw).zip(coarse.spans.par_iter_mut());
    rows.enumerate().with_min_len(4).for_each(|(cy, (row, span))| {
        let fy = 2 * cy as i64;
        let candidates = fine.span(fy).union(fine.span(fy + 1)).to_coarse();
        pull_row(row, span, candidates, |cx| {
            let fx = 2 * cx as i64;
            pull_texel([
                (fine.at(fx, fy), CHILD_OFFSETS[0]),
                (fine.at(fx + 1, fy), CHILD_OFFSETS[1]),
                (fine.at(fx, fy + 1), CHILD_OFFSETS[2]),
                (fine.at(fx + 1, fy + 1), CHILD_OFFSETS[3]),
            ])
        });
    });
}

/// Does the ellipse of `t` (the orthographic projection of its disc: major axis ⟂ the projected
/// normal, semi-axes r and r·|n_z|) centred at `centre` contain the point `q`?
#[inline]
pub fn ellipse_contains(t: &Texel, centre: Vec2, q: Vec2) -> bool {
    let u = q - centre;
    let r2 = t.radius * t.radius;
    let uu = u.length_squared();
    let nxy = Vec2::new(t.normal.x, t.normal.y);
    let nxy2 = nxy.length_squared();
    if nxy2 < 1e-12 {
        return uu <= r2;
    }
    // s: the component of u along the projected normal (the minor axis), t² = |u|² − s²;
    // (t/r)² + (s/(r·nz))² ≤ 1, multiplied by r²·nz² and by |n_xy|² (s·|n_xy| = u·n_xy), so
    // that no division is needed.
    let s = u.dot(nxy);
    let s2 = s * s;
    let nz = t.normal.z.abs().max(MIN_NZ);
    let nz2 = nz * nz;
    nz2 * (uu * nxy2 - s2) + s2 <= r2 * nz2 * nxy2
}

/// The four coarse texels nearest to the fine texels of one fine row: the parent row and the
/// row beside it (above for even fine rows, below for odd ones), `None` outside the level.
#[derive(Clone, Copy)]
pub struct CoarseRows<'a> {
    parent: &'a [Texel],
    beside: Option<&'a [Texel]>,
    py: i64,
    ny: i64,
    /// Where the valid texels of both rows lie.
    span: Span,
}

impl<'a> CoarseRows<'a> {
    #[inline]
    pub fn new(coarse: &'a Level, y: i64) -> Self {
        let w = coarse.width as usize;
        let py = y >> 1;
        let ny = if y & 1 == 1 { py + 1 } else { py - 1 };
        let row = |r: i64| {
            (r >= 0 && r < i64::from(coarse.height)).then(|| &coarse.texels[r as usize * w..(r as usize + 1) * w])
        };
        let parent = row(py).unwrap_or(&[]);
        Self { parent, beside: row(ny), py, ny, span: coarse.span(py).union(coarse.span(ny)) }
    }

    /// Where the valid texels of the two coarse rows lie.
    #[inline]
    pub fn span(&self) -> Span {
        self.span
    }

    /// The parent of fine texel x of this row.
    #[inline]
    pub fn parent(&self, x: i64) -> Option<&'a Texel> {
        self.parent.get((x >> 1) as usize)
    }

    /// Is any of the four coarse texels around fine texel x valid? (Most texels of most images
    /// have no surface anywhere near: this keeps them to four loads.)
    #[inline(always)]
    fn any_near(&self, x: i64) -> bool {
        let px = x >> 1;
        let nx = if x & 1 == 1 { px + 1 } else { px - 1 };
        let valid = |row: &[Texel], cx: i64| cx >= 0 && row.get(cx as usize).is_some_and(Texel::is_valid);
        let beside = self.beside.unwrap_or(&[]);
        valid(self.parent, px) || valid(self.parent, nx) || valid(beside, px) || valid(beside, nx)
    }

    /// The renormalised 9/3/3/1 interpolation of fine texel (x, y) of this row (§3.3): `None`
    /// when no coarse texel contributes.
    #[inline(always)]
    pub fn interpolate(&self, x: i64, y: i64, ellipses: bool) -> Option<Texel> {
        if !self.any_near(x) {
            return None;
        }
        self.interpolate_near(x, y, ellipses)
    }

    #[inline(never)]
    fn interpolate_near(&self, x: i64, y: i64, ellipses: bool) -> Option<Texel> {
        let px = x >> 1;
        let nx = if x & 1 == 1 { px + 1 } else { px - 1 };
        let get = |row: &'a [Texel], cx: i64| if cx >= 0 { row.get(cx as usize) } else { None };
        let beside = self.beside.unwrap_or(&[]);
        let candidates = [
            (get(self.parent, px), px, self.py, 9.0f32),
            (get(self.parent, nx), nx, self.py, 3.0),
            (get(beside, px), px, self.ny, 3.0),
            (get(beside, nx), nx, self.ny, 1.0),
        ];
        // The fine pixel's centre in coarse pixels.
        let q = Vec2::new((x as f32 + 0.5) * 0.5, (y as f32 + 0.5) * 0.5);
        let mut w_sum = 0.0f32;
        let (mut z_min, mut z_max, mut depth, mut radius) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let (mut normal, mut colour, mut centre) = (Vec3::ZERO, Rgb::ZERO, Vec2::ZERO);
        let mut material = u32::MAX;
        // Without branches on the texels (which of the four contribute varies from pixel to
        // pixel near a silhouette): a texel left out adds w = 0 times a zero texel, +0.0, which
        // leaves every sum's bits as they are (no sum is ever −0.0: they start at +0.0).
        const NONE: Texel = Texel { z_min: 0.0, z_max: 0.0, depth: 0.0, radius: 0.0, ..Texel::INVALID };
        for (t, cx, cy, w) in candidates {
            let t = t.unwrap_or(&Texel::INVALID);
            let c = Vec2::new(cx as f32 + 0.5, cy as f32 + 0.5) + t.displacement;
            let include = t.is_valid() & (!ellipses | ellipse_contains(t, c, q));
            let (t, w) = if include { (t, w) } else { (&NONE, 0.0) };
            if include && material == u32::MAX {
                material = t.material;
            }
            w_sum += w;
            z_min += w * t.z_min;
            z_max += w * t.z_max;
            depth += w * t.depth;
            normal += w * t.normal;
            radius += w * t.radius;
            colour += w * t.colour;
            centre += w * c;
        }
        if w_sum == 0.0 {
            return None;
        }
        let inv = 1.0 / w_sum;
        Some(Texel {
            z_min: z_min * inv,
            z_max: z_max * inv,
            depth: depth * inv,
            normal: normal.normalize_or(Vec3::NEG_Z),
            // In fine pixels: twice the coarse ones.
            radius: 2.0 * radius * inv,
            colour: colour * inv,
            displacement: 2.0 * centre * inv - Vec2::new(x as f32 + 0.5, y as f32 + 0.5),
            material,
        })
    }

    /// Push (§3.3) for fine texel (x, y) of this row: `None` to keep its own value — it is valid
    /// and not occluded (not entirely behind its parent's depth interval), or nothing
    /// contributes — else the interpolation.
    #[inline]
    pub fn push(&self, x: i64, y: i64, own: &Texel, ellipses: bool) -> Option<Texel> {
        if own.is_valid() {
            match self.parent(x) {
                Some(p) if p.is_valid() && own.z_min > p.z_max => {}
                _ => return None,
            }
        }
        self.interpolate(x, y, ellipses)
    }
}

/// The renormalised 9/3/3/1 interpolation of fine texel (x, y) from `coarse` (§3.3): `None`
/// when no coarse texel contributes. (The renderer interpolates row by row through
/// `CoarseRows`; this is the per-texel form the tests check against the paper.)
#[cfg(test)]
pub fn interpolate(coarse: &Level, x: i64, y: i64, ellipses: bool) -> Option<Texel> {
    CoarseRows::new(coarse, y).interpolate(x, y, ellipses)
}

/// Push `coarse` into `fine` in place, row-parallel, visiting only the fine texels that are
/// valid or have a valid coarse texel near; the fine rows' spans grow to what the push filled.
pub fn push_level(coarse: &Level, fine: &mut Level, ellipses: bool) {
    let fw = fine.width as usize;
    let rows = fine.texels.par_chunks_mut(fw).zip(fine.spans.par_iter_mut());
    rows.enumerate().with_min_len(4).for_each(|(y, (row, span))| {
        let rows = CoarseRows::new(coarse, y as i64);
        let range = span.union(rows.span().to_fine(fw as u32));
        if range.is_empty() {
            return;
        }
        for (x, t) in row.iter_mut().enumerate().take(range.hi as usize).skip(range.lo as usize) {
            if let Some(new) = rows.push(x as i64, y as i64, t, ellipses) {
                *t = new;
            }
        }
        *span = Span::of_valid(row, range);
    });
}

/// Number of pyramid levels above level 0 for a `width × height` image (down to 1 × 1).
pub fn level_count(width: u32, height: u32) -> usize {
    let mut n = 0;
    let (mut w, mut h) = (width, height);
    while w > 1 || h > 1 {
        w = w.div_ceil(2);
        h = h.div_ceil(2);
        n += 1;
    }
    n
}
