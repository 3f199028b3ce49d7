//! The sky as a light: directions drawn in proportion to its luminance (DESIGN.md §4, "in the
//! path tracer the sky is a light, importance-sampled by luminance, as pbrt does").
//!
//! Maps get a piecewise-constant density over their own parameter space — (u, v) of a lat-long
//! map, (s, t) of each cube face — cell by cell: a marginal CDF over rows and a conditional CDF
//! per row (pbrt-v3's `Distribution2D`), each inverted through a guide table in O(1) expected
//! time (O(log n) at worst). A direction is drawn uniformly *within* its cell in that parameter
//! space, so the solid-angle pdf is the cell's probability p times an exact Jacobian:
//!
//! - lat-long cell of a W × H grid, at polar angle θ: `p · W·H / (2π² sin θ)`;
//! - cube cell of an n × n face grid, at face coordinates (S, T) ∈ [−1, 1]²:
//!   `p · n²/4 · (1 + S² + T²)^{3/2}`.
//!
//! A cell's weight is the mean Rec. 709 luminance of [`Sky::radiance`] over the cell (in
//! parameter space) times the cell's solid angle. The mean is exact: the finest level's
//! bilinear reconstruction integrated over the cell — for a one-texel cell, its 3 × 3
//! neighbourhood weighted by (1/8, 3/4, 1/8) ⊗ (1/8, 3/4, 1/8), borders included, so seams are
//! handled as lookups handle them. Every tap weight is positive and so is the Rec. 709
//! luminance of any non-black colour, so a cell weighs zero only where the radiance is zero all
//! over it: the pdf is positive wherever the radiance is, with no luminance floor or uniform
//! mixture to spend samples on black sky.
//!
//! Maps above [`MAX_CELLS`] texels (over all faces) are sampled on a grid halved in each
//! direction until it fits, each cell's weight still the exact mean of the finest level's
//! lookup over it (so the support argument holds): a 4096 × 2048 lat-long map is sampled on
//! 2048 × 1024 cells, 1024² cube faces on 512² cells. Tables cost 9 bytes per cell (CDF and
//! density as f32, a 4-byte guide entry per 4 cells).
//!
//! A constant colour is sampled uniformly over the sphere; a gradient exactly in proportion to
//! its luminance (linear in y above the horizon, constant below; φ uniform), in closed form.
//! The [`SkyTransform`](super::SkyTransform)'s rotation turns sampled directions back to the
//! world (a rotation leaves solid-angle pdfs unchanged); its intensity scales the radiance and
//! [`SkySampler::integral`].

use super::level::Level;
use super::{CubeFace, Sky, cube_direction, cube_face_st};
use glint_core::colour::luminance;
use glint_core::{Rgb, Vec2, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

/// Most cells a map's sampling table holds (36 MB of tables); larger maps are sampled on a
/// coarser grid (see the module notes).
pub const MAX_CELLS: usize = 1 << 22;

/// Smallest sin θ a lat-long pdf divides by: the pdf stays finite at the poles (its value there
/// differs from the exact density only within 10⁻⁶ rad of the pole, a set of measure ~10⁻¹²).
const MIN_SIN_THETA: f32 = 1e-6;

/// The largest f32 below 1, where uniform numbers are clamped.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// A direction toward the sky drawn by [`SkySampler::sample`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkySample {
    /// Unit world direction (a ray travelling along it sees the sky).
    pub dir: Vec3,
    /// `sky.radiance(dir)`.
    pub radiance: Rgb,
    /// Solid-angle density `dir` was drawn with (> 0, finite).
    pub pdf: f32,
}

/// Importance sampler for a [`Sky`], proportional to luminance (see the module notes). Built once
/// per sky; `sample` and `pdf` take the same sky it was built from (they read its radiance and
/// rotation, not a copy of them).
#[derive(Clone, Debug)]
pub struct SkySampler {
    kind: Kind,
    /// ∫ luminance(L) dω, intensity included.
    integral: f32,
}

#[derive(Clone, Debug)]
enum Kind {
    /// Zero radiance everywhere: nothing to sample.
    Black,
    /// A constant colour: uniform over the sphere.
    Uniform,
    Gradient(GradientDensity),
    LatLong(Table),
    /// Rows are face-major: face f's rows are f·n .. (f + 1)·n of an n-column table.
    Cube(Table),
}

impl SkySampler {
    /// The sampler of `sky`. Maps are tabulated in parallel, in one pass over the finest level.
    pub fn new(sky: &Sky) -> SkySampler {
        let (kind, integral) = match sky {
            Sky::Colour(c) => (Kind::Uniform, 4.0 * PI * luminance(*c)),
            Sky::Gradient { zenith, horizon, ground } => {
                let g = GradientDensity::new(luminance(*zenith), luminance(*horizon), luminance(*ground));
                let integral = g.integral;
                (Kind::Gradient(g), integral)
            }
            Sky::LatLong { map, transform } => {
                let (table, integral) = latlong_table(map.finest());
                (Kind::LatLong(table), integral as f32 * transform.intensity)
            }
            Sky::CubeMap { map, transform } => {
                let (table, integral) = cube_table(map.finest());
                (Kind::Cube(table), integral as f32 * transform.intensity)
            }
        };
        if integral > 0.0 && integral.is_finite() {
            SkySampler { kind, integral }
        } else {
            SkySampler { kind: Kind::Black, integral: 0.0 }
        }
    }

    /// A direction toward `sky` (the sky this sampler was built from) for the uniform numbers
    /// `u` ∈ [0, 1)², its radiance and solid-angle pdf. `None` only for an entirely black sky.
    pub fn sample(&self, sky: &Sky, u: Vec2) -> Option<SkySample> {
        let u = Vec2::new(unit(u.x), unit(u.y));
        let (dir, pdf) = match (&self.kind, sky) {
            (Kind::Black, _) => return None,
            (Kind::Uniform, Sky::Colour(_)) => (glint_core::sampling::sample_uniform_sphere(u), 1.0 / (4.0 * PI)),
            (Kind::Gradient(g), Sky::Gradient { .. }) => g.sample(u),
            (Kind::LatLong(table), Sky::LatLong { transform, .. }) => {
                let (row, col, f, density) = table.sample(u);
                let uu = (col as f32 + f.x) / table.cols as f32;
                let vv = (row as f32 + f.y) / table.rows as f32;
                let (sin_t, cos_t) = (vv * PI).sin_cos();
                let (sin_p, cos_p) = ((uu - 0.5) * (2.0 * PI)).sin_cos();
                // latlong_direction, keeping sin θ for the Jacobian.
                let d = Vec3::new(sin_t * sin_p, cos_t, -sin_t * cos_p);
                (transform.to_world(d), latlong_pdf(density, sin_t))
            }
            (Kind::Cube(table), Sky::CubeMap { transform, .. }) => {
                let (row, col, f, density) = table.sample(u);
                let n = table.cols;
                let face = CubeFace::ALL[(row / n).min(5)];
                let s = (col as f32 + f.x) / n as f32;
                let t = ((row % n) as f32 + f.y) / n as f32;
                let d = cube_direction(face, s, t); // length² = 1 + S² + T²
                let q = d.length_squared();
                (transform.to_world(d / q.sqrt()), cube_pdf(density, q))
            }
            _ => {
                debug_assert!(false, "SkySampler used with a different kind of sky");
                return None;
            }
        };
        let radiance = match sky {
            // The height the sample was drawn at (its pdf's): normalising the direction
            // again only to read it back cost a square root and a division on the path
            // tracer's every sky sample (3.4 % of a Sponza frame was this function).
            Sky::Gradient { zenith, horizon, ground } => super::gradient_at(dir.y, *zenith, *horizon, *ground),
            _ => sky.radiance(dir),
        };
        (pdf > 0.0 && pdf.is_finite()).then_some(SkySample { dir, radiance, pdf })
    }

    /// Solid-angle density with which [`SkySampler::sample`] draws `dir` (any non-zero length;
    /// 0 for zero or non-finite vectors and for a black sky).
    pub fn pdf(&self, sky: &Sky, dir: Vec3) -> f32 {
        if !dir.is_finite() || dir == Vec3::ZERO {
            return 0.0;
        }
        match (&self.kind, sky) {
            (Kind::Black, _) => 0.0,
            (Kind::Uniform, Sky::Colour(_)) => 1.0 / (4.0 * PI),
            (Kind::Gradient(g), Sky::Gradient { .. }) => g.pdf(dir),
            (Kind::LatLong(table), Sky::LatLong { transform, .. }) => {
                let d = transform.to_map(dir);
                let r_xz = (d.x * d.x + d.z * d.z).sqrt();
                // Exact libm angles (not the lookups' polynomials), so that a sampled direction
                // maps back to the cell it was drawn in.
                let theta = r_xz.atan2(d.y);
                let u = 0.5 + d.x.atan2(-d.z) * (0.5 / PI);
                let v = theta * (1.0 / PI);
                let density = table.density(cell(v, table.rows), cell(u, table.cols));
                latlong_pdf(density, r_xz / d.length())
            }
            (Kind::Cube(table), Sky::CubeMap { transform, .. }) => {
                let (face, s, t) = cube_face_st(transform.to_map(dir));
                let n = table.cols;
                let density = table.density(face.index() * n + cell(t, n), cell(s, n));
                let (sc, tc) = (2.0 * s - 1.0, 2.0 * t - 1.0);
                cube_pdf(density, 1.0 + sc * sc + tc * tc)
            }
            _ => {
                debug_assert!(false, "SkySampler used with a different kind of sky");
                0.0
            }
        }
    }

    /// ∫ luminance(L(ω)) dω over the sphere (intensity included): the sky's weight when a light
    /// is chosen among several. Exact for colours and gradients; for maps, each cell's mean
    /// luminance times its exact solid angle.
    pub fn integral(&self) -> f32 {
        self.integral
    }
}

/// A uniform number forced into [0, 1) (NaN → 0).
#[inline]
fn unit(x: f32) -> f32 {
    if x > 0.0 { x.min(ONE_MINUS_EPSILON) } else { 0.0 }
}

/// The cell of `x` ∈ [0, 1] in a grid of `count` cells.
#[inline]
fn cell(x: f32, count: usize) -> usize {
    ((x * count as f32) as usize).min(count - 1)
}

/// Lat-long pdf: density over the unit (u, v) square divided by dω / du dv = 2π² sin θ.
#[inline]
fn latlong_pdf(density: f32, sin_theta: f32) -> f32 {
    density / (2.0 * PI * PI * sin_theta.max(MIN_SIN_THETA))
}

/// Cube pdf: density over a unit (s, t) face square, /4 for (S, T) ∈ [−1, 1]², divided by
/// dω / dS dT = (1 + S² + T²)^{-3/2}; `q` = 1 + S² + T².
#[inline]
fn cube_pdf(density: f32, q: f32) -> f32 {
    density * 0.25 * q * q.sqrt()
}

/// A piecewise-constant 2-D distribution over `rows` × `cols` cells: a marginal CDF over rows,
/// a conditional CDF per row, each with a guide table (Chen & Asau 1974) so that inverting
/// one reads a bucket of a few entries — one or two cache lines — instead of binary-searching
/// the whole row (a 2048-cell row is 16 KB: eight cache misses).
#[derive(Clone, Debug)]
struct Table {
    cols: usize,
    rows: usize,
    /// Row-major cells.
    cells: Vec<Cell>,
    /// Per row, `guide_size` entries (see [`guide`]).
    guides: Vec<u32>,
    guide_size: usize,
    /// The CDF over rows, at the end of each (the last exactly 1), and its guide.
    marginal: Vec<f32>,
    marginal_guide: Vec<u32>,
}

/// One cell: its row's CDF at its end and its density side by side, so that the search's last
/// read and the density share a cache line.
#[derive(Clone, Copy, Debug, Default)]
struct Cell {
    cdf: f32,
    /// The cell's probability × the number of cells in a unit parameter square (W·H of a
    /// lat-long grid, n² of a cube face): the density over that square.
    density: f32,
}

/// Conditional CDF entries per guide entry.
const CELLS_PER_GUIDE: usize = 4;

impl Table {
    /// The table of `weights` (rows × cols, ≥ 0, not all zero), and their sum; `cells_per_unit`
    /// turns a probability into the density over one unit parameter square. Sums run in a fixed
    /// order (rows in parallel, then the row sums in turn): the thread count changes no bit.
    fn new(cols: usize, rows: usize, weights: Vec<f32>, cells_per_unit: f64) -> (Table, f64) {
        let guide_size = cols.div_ceil(CELLS_PER_GUIDE);
        let mut cells = vec![Cell::default(); cols * rows];
        let mut guides = vec![0u32; guide_size * rows];
        let row_sums: Vec<f64> = cells
            .par_chunks_mut(cols)
            .zip(guides.par_chunks_mut(guide_size))
            .zip(weights.par_chunks(cols))
            .map(|((row, row_guide), w)| {
                let total: f64 = w.iter().map(|&x| x as f64).sum();
                let mut running = 0.0f64;
                for (i, (c, &x)) in row.iter_mut().zip(w).enumerate() {
                    running += x as f64;
                    // A row that is all zero is never chosen; give it a harmless uniform CDF.
                    c.cdf = if total > 0.0 { (running / total) as f32 } else { (i + 1) as f32 / cols as f32 };
                }
                row[cols - 1].cdf = 1.0;
                guide(|i| row[i].cdf, cols, row_guide);
                total
            })
            .collect();
        let total: f64 = row_sums.iter().sum();
        let scale = cells_per_unit / total;
        cells.par_iter_mut().zip(weights.par_iter()).for_each(|(c, &w)| c.density = (w as f64 * scale) as f32);
        let mut running = 0.0f64;
        let mut marginal: Vec<f32> = row_sums
            .iter()
            .map(|&s| {
                running += s;
                (running / total) as f32
            })
            .collect();
        marginal[rows - 1] = 1.0;
        let mut marginal_guide = vec![0u32; rows];
        guide(|i| marginal[i], rows, &mut marginal_guide);
        (Table { cols, rows, cells, guides, guide_size, marginal, marginal_guide }, total)
    }

    /// (row, column, position in the cell ∈ [0, 1)², density) for `u` ∈ [0, 1)²: row by the
    /// marginal CDF and u.y, column by the row's CDF and u.x; each number's remainder inside its
    /// CDF step places the point inside the cell (the exact inverse of the piecewise-constant
    /// CDF, which keeps stratified `u` stratified).
    #[inline]
    fn sample(&self, u: Vec2) -> (usize, usize, Vec2, f32) {
        let (row, fy) = invert(&self.marginal, |c| *c, &self.marginal_guide, u.y);
        let cells = &self.cells[row * self.cols..(row + 1) * self.cols];
        let guide = &self.guides[row * self.guide_size..(row + 1) * self.guide_size];
        let (col, fx) = invert(cells, |c| c.cdf, guide, u.x);
        (row, col, Vec2::new(fx, fy), cells[col].density)
    }

    #[inline]
    fn density(&self, row: usize, col: usize) -> f32 {
        self.cells[row * self.cols + col].density
    }
}

/// Fills `out` with the guide of a CDF of `len` entries: `out[k]` is the first entry whose CDF
/// exceeds k / out.len(), so the entry holding u lies in `out[k] ..= out[k + 1]` for
/// k = ⌊u · out.len()⌋.
fn guide(cdf: impl Fn(usize) -> f32, len: usize, out: &mut [u32]) {
    let g = out.len();
    let mut i = 0;
    for (k, o) in out.iter_mut().enumerate() {
        let threshold = k as f32 / g as f32;
        while i + 1 < len && cdf(i) <= threshold {
            i += 1;
        }
        *o = i as u32;
    }
}

/// The step of a CDF (entries `items`, non-decreasing, the last 1) that holds `u` ∈ [0, 1),
/// and where in it; steps of zero width are never chosen. `guide` narrows the search to its
/// bucket (the whole CDF if rounding put `u` in the wrong one).
#[inline]
fn invert<T>(items: &[T], cdf: impl Fn(&T) -> f32, guide: &[u32], u: f32) -> (usize, f32) {
    let (len, g) = (items.len(), guide.len());
    let k = ((u * g as f32) as usize).min(g - 1);
    let mut lo = guide[k] as usize;
    let mut hi = if k + 1 < g { (guide[k + 1] as usize + 1).min(len) } else { len };
    if lo > 0 && cdf(&items[lo - 1]) > u {
        lo = 0;
    }
    if cdf(&items[hi - 1]) <= u {
        hi = len;
    }
    let i = (lo + items[lo..hi].partition_point(|c| cdf(c) <= u)).min(len - 1);
    let below = if i == 0 { 0.0 } else { cdf(&items[i - 1]) };
    let width = cdf(&items[i]) - below;
    let f = if width > 0.0 { ((u - below) / width).clamp(0.0, ONE_MINUS_EPSILON) } else { 0.5 };
    (i, f)
}

/// The grid a `width × height` map (times `faces`) is sampled on: halved until it fits.
fn sampling_grid(width: usize, height: usize, faces: usize) -> (usize, usize) {
    let (mut cols, mut rows) = (width.max(1), height.max(1));
    while cols * rows * faces > MAX_CELLS && (cols > 1 || rows > 1) {
        (cols, rows) = ((cols / 2).max(1), (rows / 2).max(1));
    }
    (cols, rows)
}

/// Lat-long table: weights are the mean luminance of each cell times its solid angle
/// (2π / cols)(cos θ₀ − cos θ₁). Returns the table and Σ weights (∫ lum dω).
fn latlong_table(level: &Level) -> (Table, f64) {
    let (cols, rows) = sampling_grid(level.width, level.height, 1);
    let mut weights = cell_means(level, cols, rows);
    weights.par_chunks_mut(cols).enumerate().for_each(|(r, row)| {
        let theta = |r: usize| std::f64::consts::PI * r as f64 / rows as f64;
        let omega = std::f64::consts::TAU / cols as f64 * (theta(r).cos() - theta(r + 1).cos());
        for w in row {
            *w = (*w as f64 * omega) as f32;
        }
    });
    Table::new(cols, rows, weights, (cols * rows) as f64)
}

/// Cube table: six faces of n × n cells stacked face-major; weights are the mean luminance of
/// each cell times its exact solid angle. Returns the table and Σ weights (∫ lum dω).
fn cube_table(faces: &[Level; 6]) -> (Table, f64) {
    let (n, _) = sampling_grid(faces[0].width, faces[0].height, 6);
    let omega = cube_cell_solid_angles(n);
    let mut weights = Vec::with_capacity(6 * n * n);
    for face in faces {
        weights.extend(cell_means(face, n, n));
    }
    weights.par_chunks_mut(n * n).for_each(|face| {
        for (w, &o) in face.iter_mut().zip(&omega) {
            *w = (*w as f64 * o) as f32;
        }
    });
    Table::new(n, 6 * n, weights, (n * n) as f64)
}

/// Solid angles of the n × n cells of a cube face: with A(x, y) = atan2(xy, √(x² + y² + 1)) at
/// the cell corners (x, y ∈ [−1, 1]), Ω = A(x₀, y₀) − A(x₀, y₁) − A(x₁, y₀) + A(x₁, y₁).
fn cube_cell_solid_angles(n: usize) -> Vec<f64> {
    let corner = |i: usize| -1.0 + 2.0 * i as f64 / n as f64;
    // A is odd in x and in y, and corner n − i mirrors corner i: atan2 is needed only for the
    // corners with x, y ≥ 0 (a quarter of them).
    let half = n / 2;
    let quarter: Vec<f64> = (0..(n - half + 1) * (n - half + 1))
        .into_par_iter()
        .map(|k| {
            let (x, y) = (corner(half + k % (n - half + 1)), corner(half + k / (n - half + 1)));
            (x * y).atan2((x * x + y * y + 1.0).sqrt())
        })
        .collect();
    let at = |i: usize, j: usize| {
        let fold = |i: usize| if i >= half { (i - half, 1.0) } else { (n - i - half, -1.0) };
        let ((qi, si), (qj, sj)) = (fold(i), fold(j));
        si * sj * quarter[qj * (n - half + 1) + qi]
    };
    (0..n * n)
        .into_par_iter()
        .map(|k| {
            let (i, j) = (k % n, k / n);
            (at(i, j) - at(i, j + 1) - at(i + 1, j) + at(i + 1, j + 1)).abs()
        })
        .collect()
}

/// The mean over each cell of a `cols × rows` grid on the level's parameter square of the
/// luminance of its bilinear reconstruction (what `Level::bilinear` returns), exactly. The
/// reconstruction is a sum of texels times separable tents (one texel wide on either side of
/// each centre, border texels included), so a cell's mean is the texels weighted by each tent's
/// integral over the cell along x times along y ([`tent_weights`]): (1/8, 3/4, 1/8) for a cell
/// of one texel.
fn cell_means(level: &Level, cols: usize, rows: usize) -> Vec<f32> {
    // Rows of cells per parallel task.
    const CHUNK: usize = 8;
    let (w, stride) = (level.width, level.width + 2);
    let wx = tent_weights(w, cols);
    let wy = tent_weights(level.height, rows);
    let uniform_x = wx.uniform();
    let mut out = vec![0f32; cols * rows];
    out.par_chunks_mut(cols * CHUNK).enumerate().for_each(|(chunk, cells)| {
        let r0 = chunk * CHUNK;
        let r1 = r0 + cells.len() / cols;
        // Texel rows these cells read (−1 and `height` are the border rows), each filtered
        // along x into cell columns once.
        let (y_lo, y_hi) = (wy.first_texel(r0), wy.last_texel(r1 - 1));
        let mut lum = vec![0f32; stride];
        let mut across = vec![0f32; cols * (y_hi - y_lo + 1) as usize];
        for (y, filtered) in (y_lo..=y_hi).zip(across.chunks_mut(cols)) {
            let start = level.index(-1, y);
            for (l, &t) in lum.iter_mut().zip(&level.texels[start..start + stride]) {
                *l = luminance_rgb9e5(t);
            }
            // `lum` starts at texel −1.
            if let Some((step, k)) = uniform_x {
                // Whole texels per cell: every cell has the same taps, `step` texels apart.
                for (c, f) in filtered.iter_mut().enumerate() {
                    *f = lum[c * step..][..k.len()].iter().zip(k).map(|(l, k)| l * k).sum();
                }
            } else {
                for (c, f) in filtered.iter_mut().enumerate() {
                    let (first, k) = wx.taps(c);
                    *f = lum[(first + 1) as usize..][..k.len()].iter().zip(k).map(|(l, k)| l * k).sum();
                }
            }
        }
        for (r, row) in (r0..r1).zip(cells.chunks_mut(cols)) {
            let (first, k) = wy.taps(r);
            for (y, &k) in (first..).zip(k) {
                let filtered = &across[(y - y_lo) as usize * cols..][..cols];
                for (o, f) in row.iter_mut().zip(filtered) {
                    *o += k * f;
                }
            }
        }
    });
    out
}

/// Per cell of a row of equal cells over a row of texels, the texels whose tents reach into
/// it — a run starting at `first[cell]` — and each tent's mean over the cell (see
/// [`tent_weights`]). Flat, so that filtering reads no pointer per cell.
struct Taps {
    first: Vec<isize>,
    /// `weights[offsets[c]..offsets[c + 1]]` belong to cell c.
    offsets: Vec<usize>,
    weights: Vec<f32>,
}

impl Taps {
    #[inline]
    fn taps(&self, cell: usize) -> (isize, &[f32]) {
        (self.first[cell], &self.weights[self.offsets[cell]..self.offsets[cell + 1]])
    }

    /// When every cell covers the same whole number of texels (`step`), all cells have the
    /// same taps: `step` and those taps (cell c's first texel is c · step − 1).
    fn uniform(&self) -> Option<(usize, &[f32])> {
        let cells = self.first.len();
        let step = (self.first.get(1)? - self.first[0]) as usize;
        let width = self.offsets[1];
        let same = (0..cells)
            .all(|c| self.first[c] == (c * step) as isize - 1 && self.offsets[c + 1] - self.offsets[c] == width);
        (same && self.weights.chunks(width).all(|w| w == &self.weights[..width]))
            .then(|| (step, &self.weights[..width]))
    }

    fn first_texel(&self, cell: usize) -> isize {
        self.first[cell]
    }

    fn last_texel(&self, cell: usize) -> isize {
        self.first[cell] + (self.offsets[cell + 1] - self.offsets[cell]) as isize - 1
    }
}

/// Rec. 709 luminance of an RGB9E5 texel, written lane-friendly (integer unpacking, one
/// scale) so that a row of texels decodes in SIMD.
#[inline(always)]
fn luminance_rgb9e5(t: u32) -> f32 {
    // 2^(e − 24) from its bits, as `decode_rgb9e5` does.
    let scale = f32::from_bits(((t >> 27) + 103) << 23);
    let (r, g, b) = ((t & 511) as f32, ((t >> 9) & 511) as f32, ((t >> 18) & 511) as f32);
    (0.2126 * r + 0.7152 * g + 0.0722 * b) * scale
}

/// For each of `cells` equal cells over `texels` texel widths, the texels (−1 ..= `texels`,
/// borders included) whose tent — 1 at the texel's centre, 0 one texel away — reaches into the
/// cell, with the tent's mean over the cell. Each cell's weights sum to 1.
fn tent_weights(texels: usize, cells: usize) -> Taps {
    // ∫ from −∞ to t of the tent centred at 0.
    let ramp = |t: f64| {
        if t <= -1.0 {
            0.0
        } else if t <= 0.0 {
            0.5 * (t + 1.0) * (t + 1.0)
        } else if t <= 1.0 {
            1.0 - 0.5 * (1.0 - t) * (1.0 - t)
        } else {
            1.0
        }
    };
    let scale = texels as f64 / cells as f64;
    let mut taps = Taps { first: Vec::with_capacity(cells), offsets: vec![0], weights: Vec::new() };
    for c in 0..cells {
        let (a, b) = (c as f64 * scale, (c + 1) as f64 * scale);
        // Tents of texels first ..= last overlap [a, b]; those at the ends may add nothing.
        let mut first = (a.floor() as isize - 1).max(-1);
        let mut last = (b.ceil() as isize).min(texels as isize);
        let weight = |i: isize| {
            let centre = i as f64 + 0.5;
            (ramp(b - centre) - ramp(a - centre)) / (b - a)
        };
        while first < last && weight(first) <= 0.0 {
            first += 1;
        }
        while last > first && weight(last) <= 0.0 {
            last -= 1;
        }
        taps.first.push(first);
        taps.weights.extend((first..=last).map(|i| weight(i) as f32));
        taps.offsets.push(taps.weights.len());
    }
    taps
}

/// Sampling a gradient sky in proportion to its luminance: `a + (b − a) y` above the horizon
/// (a at the horizon, b at the zenith), `g` below; y is distributed by that, φ uniformly
/// (dω = dy dφ).
#[derive(Clone, Copy, Debug)]
struct GradientDensity {
    horizon: f32,
    zenith: f32,
    ground: f32,
    /// Probability of the upper hemisphere.
    upper: f32,
    /// ∫ luminance dω = π (a + b) + 2π g.
    integral: f32,
}

impl GradientDensity {
    fn new(zenith: f32, horizon: f32, ground: f32) -> GradientDensity {
        let (zenith, horizon, ground) = (zenith.max(0.0), horizon.max(0.0), ground.max(0.0));
        let upper_mass = PI * (horizon + zenith);
        let integral = upper_mass + 2.0 * PI * ground;
        GradientDensity { horizon, zenith, ground, upper: upper_mass / integral, integral }
    }

    fn luminance(&self, y: f32) -> f32 {
        if y >= 0.0 { self.horizon + (self.zenith - self.horizon) * y.min(1.0) } else { self.ground }
    }

    fn pdf(&self, dir: Vec3) -> f32 {
        self.luminance(dir.normalize_or(Vec3::Y).y) / self.integral
    }

    fn sample(&self, u: Vec2) -> (Vec3, f32) {
        let y = if u.x < self.upper {
            // Invert the CDF (a y + (b − a) y²/2) / ((a + b)/2) = ξ, in the form without
            // cancellation: y = ξ (a + b) / (a + √(a² + (b² − a²) ξ)).
            // ξ > 0: at ξ = 0 a black horizon would give y = 0, a direction of zero density.
            let xi = (u.x / self.upper).clamp(f32::EPSILON * f32::EPSILON, ONE_MINUS_EPSILON);
            let (a, b) = (self.horizon, self.zenith);
            let denominator = a + (a * a + (b * b - a * a) * xi).max(0.0).sqrt();
            if denominator > 0.0 { (xi * (a + b) / denominator).clamp(0.0, 1.0) } else { 0.0 }
        } else {
            // Uniform in y ∈ [−1, 0).
            let xi = ((u.x - self.upper) / (1.0 - self.upper)).clamp(0.0, ONE_MINUS_EPSILON);
            -(1.0 - xi)
        };
        let r = (1.0 - y * y).max(0.0).sqrt();
        let (sin_p, cos_p) = (2.0 * PI * u.y).sin_cos();
        let dir = Vec3::new(r * cos_p, y, r * sin_p);
        (dir, self.luminance(y) / self.integral)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::random::{hash4, unit_float};

    #[test]
    fn guided_inversion_equals_a_binary_search() {
        for trial in 0..50u64 {
            let len = 1 + (hash4(trial, 0, 0, 1) % 300) as usize;
            // Weights with runs of zeros and a few large ones.
            let weights: Vec<f64> = (0..len as u64)
                .map(|i| {
                    let r = unit_float(hash4(trial, i, 1, 1)) as f64;
                    if r < 0.3 {
                        0.0
                    } else if r > 0.97 {
                        1000.0 * r
                    } else {
                        r
                    }
                })
                .collect();
            let total: f64 = weights.iter().sum::<f64>().max(1e-300);
            let mut running = 0.0;
            let mut cdf: Vec<f32> = weights
                .iter()
                .map(|w| {
                    running += w;
                    (running / total) as f32
                })
                .collect();
            cdf[len - 1] = 1.0;
            for g in [1, 2, len.div_ceil(4), len, 3 * len] {
                let mut guide_table = vec![0u32; g];
                guide(|i| cdf[i], len, &mut guide_table);
                let mut us: Vec<f32> = (0..400).map(|i| unit_float(hash4(trial, i, 2, 1))).collect();
                // Exactly on steps and on bucket edges, and the extremes.
                us.extend(cdf.iter().copied().filter(|&c| c < 1.0));
                us.extend((0..g).map(|k| k as f32 / g as f32));
                us.extend([0.0, ONE_MINUS_EPSILON]);
                for u in us {
                    let want = cdf.partition_point(|&c| c <= u).min(len - 1);
                    let (got, f) = invert(&cdf, |c| *c, &guide_table, u);
                    assert_eq!(got, want, "trial {trial} g {g} u {u}");
                    assert!((0.0..1.0).contains(&f));
                    if weights.iter().any(|&w| w > 0.0) {
                        assert!(weights[got] > 0.0, "a zero-width step was chosen");
                    }
                }
            }
        }
    }

    /// A level of random texels with a border of other random texels.
    fn random_level(w: usize, h: usize, seed: u64) -> Level {
        let texel = |i: u64| Rgb::new(unit_float(hash4(i, 0, 3, seed)), unit_float(hash4(i, 1, 3, seed)), 0.5) * 4.0;
        let mut level = Level::from_interior(w, h, &(0..(w * h) as u64).map(texel).collect::<Vec<_>>());
        for y in -1..=h as isize {
            for x in -1..=w as isize {
                if x < 0 || y < 0 || x >= w as isize || y >= h as isize {
                    level.set(x, y, texel(1000 + ((y + 1) * 100 + x + 1) as u64));
                }
            }
        }
        level
    }

    #[test]
    fn cell_means_are_means_of_the_bilinear_lookup() {
        let (w, h) = (12, 6);
        let level = random_level(w, h, 5);
        // Cells of one texel, of 2 × 2, of a fractional 12/5 × 6/4 texels and of all.
        for (cols, rows) in [(12, 6), (6, 3), (5, 4), (1, 1)] {
            let means = cell_means(&level, cols, rows);
            for r in 0..rows {
                for c in 0..cols {
                    // Midpoint rule, 64² points per cell: the bilinear lookup is piecewise
                    // bilinear on a grid the points straddle evenly.
                    let k = 64;
                    let mut sum = 0.0f64;
                    for j in 0..k {
                        for i in 0..k {
                            let u = (c as f32 + (i as f32 + 0.5) / k as f32) / cols as f32;
                            let v = (r as f32 + (j as f32 + 0.5) / k as f32) / rows as f32;
                            sum += luminance(level.bilinear(u * w as f32, v * h as f32)) as f64;
                        }
                    }
                    let want = sum / (k * k) as f64;
                    let got = means[r * cols + c] as f64;
                    assert!((got - want).abs() < 2e-3 * want, "{cols}x{rows} cell ({c}, {r}): {got} vs {want}");
                }
            }
        }
    }

    #[test]
    fn a_texel_weighs_zero_only_where_its_lookup_is_zero() {
        // One lit texel: its 3 × 3 neighbourhood has weight (the lookup blends it in there),
        // the rest none.
        let (w, h) = (8, 8);
        let mut texels = vec![Rgb::ZERO; w * h];
        texels[3 * w + 5] = Rgb::new(0.0, 0.0, 1e-3);
        let level = Level::from_interior(w, h, &texels);
        let means = cell_means(&level, w, h);
        for y in 0..h {
            for x in 0..w {
                let near = (x as isize - 5).abs() <= 1 && (y as isize - 3).abs() <= 1;
                assert_eq!(means[y * w + x] > 0.0, near, "({x}, {y})");
            }
        }
    }

    #[test]
    fn tables_do_not_depend_on_the_thread_count() {
        let map = super::super::LatLongMap::from_fn(128, |d| Rgb::new(d.x.abs(), (d.y * 3.0).sin().abs(), 0.1));
        let sky = Sky::LatLong { map: std::sync::Arc::new(map), transform: super::super::SkyTransform::new(12.0, 1.0) };
        let build = |threads| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("a thread pool");
            pool.install(|| SkySampler::new(&sky))
        };
        let (one, two) = (build(1), build(2));
        assert_eq!(one.integral().to_bits(), two.integral().to_bits());
        for i in 0..1000 {
            let u = Vec2::new(unit_float(hash4(i, 0, 4, 1)), unit_float(hash4(i, 1, 4, 1)));
            assert_eq!(one.sample(&sky, u), two.sample(&sky, u));
        }
    }

    #[test]
    fn texel_luminance_is_the_decoded_luminance() {
        for i in 0..10_000u64 {
            let t = hash4(i, 0, 5, 1) as u32;
            let want = luminance(super::super::level::decode_rgb9e5(t).into());
            let got = luminance_rgb9e5(t);
            assert!((got - want).abs() <= 1e-6 * want.abs(), "{t:#x}: {got} vs {want}");
        }
    }

    #[test]
    fn cells_of_whole_texels_share_their_taps() {
        let taps = tent_weights(12, 6);
        let (step, k) = taps.uniform().expect("whole texels");
        assert_eq!(step, 2);
        assert_eq!(k, [0.0625, 0.4375, 0.4375, 0.0625]);
        assert_eq!(tent_weights(8, 8).uniform(), Some((1, &[0.125f32, 0.75, 0.125][..])));
        assert!(tent_weights(12, 5).uniform().is_none());
        assert!(tent_weights(12, 1).uniform().is_none());
    }

    #[test]
    fn big_maps_are_sampled_on_capped_grids() {
        assert_eq!(sampling_grid(2048, 1024, 1), (2048, 1024));
        assert_eq!(sampling_grid(4096, 2048, 1), (2048, 1024));
        assert_eq!(sampling_grid(512, 512, 6), (512, 512));
        assert_eq!(sampling_grid(1024, 1024, 6), (512, 512));
        assert_eq!(sampling_grid(3000, 1500, 1), (1500, 750));
        assert_eq!(sampling_grid(1, 1, 6), (1, 1));
    }

    #[test]
    fn cube_cells_tile_the_sphere() {
        for n in [1, 2, 7, 64] {
            let total: f64 = cube_cell_solid_angles(n).iter().sum::<f64>() * 6.0;
            assert!((total - 4.0 * std::f64::consts::PI).abs() < 1e-9, "{n}: {total}");
        }
        // The centre cell of an odd face is the largest, a corner cell the smallest.
        let omega = cube_cell_solid_angles(7);
        assert!(omega[3 * 7 + 3] > omega[0] * 2.0);
    }
}
