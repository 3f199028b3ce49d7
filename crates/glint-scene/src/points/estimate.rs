//! Normal and radius estimation for point clouds that lack them (scanner exports, PLY files with
//! positions only), so that the points renderer can shade and splat every cloud.
//!
//! Sits between loading (glint-formats) and validation: it reads positions only and fills
//! [`PointCloud::normals`] / [`PointCloud::radii`]. Depends on a k-d tree (kiddo) and rayon, not
//! on any renderer.
//!
//! - Normals: principal component analysis of the k nearest neighbours (Hoppe et al. 1992,
//!   "Surface reconstruction from unorganized points", §3.2): the normal is the eigenvector of
//!   the neighbourhood's 3×3 covariance with the smallest eigenvalue, found by cyclic Jacobi
//!   rotations (Golub and Van Loan, "Matrix Computations", 4th ed., §8.5), which stay accurate for the
//!   repeated and zero eigenvalues that flat, collinear and coincident neighbourhoods produce.
//!   PCA gives no sign; it comes from the cloud's [`Orientation`] (towards the sensor, or up).
//!   Hoppe's propagation over a Riemannian graph is not attempted: with no hint the sign is only
//!   made deterministic and the cloud stays [`Orientation::Unknown`] (drawn two-sided).
//! - Radii: `radius_scale` × the mean distance to the `min(k, 8)` nearest other points, so that
//!   the discs of neighbours overlap (on a square grid of spacing h: (4h + 4√2h)/8 ≈ 1.21h).
//!
//! Determinism: every point's result is a pure function of the positions. Neighbour sets are
//! made canonical (ties at the k-th distance are settled by position, not by tree layout), sums
//! run in that canonical order, and chunks run in parallel with no shared reduction, so the
//! results are bit-identical whatever the number of threads and whatever the order of the points.

use super::{Orientation, PointCloud};
use crate::SceneError;
use glint_core::Vec3;
use kiddo::{ImmutableKdTree, SquaredEuclidean};
use rayon::prelude::*;
use std::cmp::Ordering;
use std::num::NonZeroUsize;

/// Neighbourhood sizes accepted by [`EstimateSettings::validate`]; the estimators clamp to it.
pub const K_RANGE: std::ops::RangeInclusive<usize> = 3..=256;

/// At most this many nearest neighbours set a radius (a ring of 8 reaches the diagonal
/// neighbours of a grid, which is what makes the discs overlap).
const RADIUS_NEIGHBOURS: usize = 8;

/// Points per parallel work item, and per call of the progress callback.
const CHUNK: usize = 4096;

/// Relative margin (on squared distances) within which two neighbours count as tied. Wider
/// than the rounding difference between kiddo's distance kernels and ours.
const TIE_MARGIN: f32 = 1e-5;

/// The normal given where no plane can be fitted (a point with no neighbour, or a neighbourhood
/// of coincident points) before orientation: +Y.
const FALLBACK_NORMAL: Vec3 = Vec3::Y;

/// The radius given when no point of the cloud has a neighbour at a non-zero distance (a single
/// point, or all points coincident): there is no length to infer, so 1 × `radius_scale`.
const FALLBACK_SPACING: f32 = 1.0;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EstimateSettings {
    /// Neighbours per point for the normal fit (clamped to [`K_RANGE`] and to the cloud size);
    /// radii use the nearest `min(k, 8)` of them.
    pub k: usize,
    /// Multiplies the estimated radii.
    pub radius_scale: f32,
}

impl Default for EstimateSettings {
    fn default() -> Self {
        Self { k: 16, radius_scale: 1.0 }
    }
}

impl EstimateSettings {
    /// `k` in [`K_RANGE`], `radius_scale` finite and > 0. The estimators run with any settings
    /// (clamping `k`), but a bad `radius_scale` gives radii that [`PointCloud::validate`] rejects.
    pub fn validate(&self) -> Result<(), SceneError> {
        if !K_RANGE.contains(&self.k) {
            return Err(SceneError::invalid(
                "normal estimation",
                format!("k = {} is outside {}..={}", self.k, K_RANGE.start(), K_RANGE.end()),
            ));
        }
        if !(self.radius_scale.is_finite() && self.radius_scale > 0.0) {
            return Err(SceneError::invalid(
                "radius estimation",
                format!("radius scale {} is not a finite number > 0", self.radius_scale),
            ));
        }
        Ok(())
    }
}

/// Estimate a unit normal per point (replacing any normals the cloud has) and orient it by
/// `cloud.orientation`: `TowardSensor(s)` makes n·(s − p) ≥ 0, `Up(u)` makes n·u ≥ 0, and the
/// cloud becomes [`Orientation::Oriented`]. With `Unknown` (or `Oriented`, whose sign the new
/// normals cannot inherit) the sign only is made deterministic (largest component positive)
/// and the cloud is left `Unknown`. `progress(n)` is called, from worker threads, as each chunk
/// of `n` points is done.
pub fn estimate_normals(cloud: &mut PointCloud, settings: &EstimateSettings, progress: &(dyn Fn(usize) + Sync)) {
    let index = NeighbourIndex::new(&cloud.positions);
    run(cloud, &index, settings, Wanted { normals: true, radii: false }, progress);
}

/// Estimate a splat radius per point (replacing any radii the cloud has): `radius_scale` × the
/// mean distance to the `min(k, 8)` nearest other points. Coincident duplicates count at the
/// nearest non-zero distance of the neighbourhood; points with no neighbour at a non-zero
/// distance take the median radius of the others (1 × `radius_scale` if there are none).
pub fn estimate_radii(cloud: &mut PointCloud, settings: &EstimateSettings, progress: &(dyn Fn(usize) + Sync)) {
    let index = NeighbourIndex::new(&cloud.positions);
    run(cloud, &index, settings, Wanted { normals: false, radii: true }, progress);
}

/// Make a cloud ready to render: estimate whichever of normals and radii it lacks, from one
/// k-d tree and one neighbour query per point (`progress` counts each point once). Normals the
/// cloud already has are kept; if its orientation is `TowardSensor` or `Up` they are flipped to
/// agree with it and the cloud becomes `Oriented`.
pub fn prepare(cloud: &mut PointCloud, settings: &EstimateSettings, progress: &(dyn Fn(usize) + Sync)) {
    let wanted = Wanted { normals: cloud.normals.is_none(), radii: cloud.radii.is_none() };
    if let Some(normals) = &mut cloud.normals
        && matches!(cloud.orientation, Orientation::TowardSensor(_) | Orientation::Up(_))
    {
        for (n, p) in normals.iter_mut().zip(&cloud.positions) {
            *n = orient(*n, *p, cloud.orientation);
        }
        cloud.orientation = Orientation::Oriented;
    }
    if !wanted.normals && !wanted.radii {
        return;
    }
    let index = NeighbourIndex::new(&cloud.positions);
    run(cloud, &index, settings, wanted, progress);
}

#[derive(Clone, Copy)]
struct Wanted {
    normals: bool,
    radii: bool,
}

/// What one point's neighbourhood gives.
#[derive(Clone, Copy, Default)]
struct Estimate {
    normal: Vec3,
    /// Mean neighbour distance; 0 when unknown (no neighbour at a non-zero distance).
    spacing: f32,
}

fn run(
    cloud: &mut PointCloud,
    index: &NeighbourIndex,
    settings: &EstimateSettings,
    wanted: Wanted,
    progress: &(dyn Fn(usize) + Sync),
) {
    let k = settings.k.clamp(*K_RANGE.start(), *K_RANGE.end());
    let k_query = if wanted.normals { k } else { k.min(RADIUS_NEIGHBOURS) };
    let k_radius = k.min(RADIUS_NEIGHBOURS);
    let orientation = cloud.orientation;
    let positions = &cloud.positions;

    // Visit the points in the tree's leaf order, so that consecutive queries touch the same
    // leaves (twice as fast as the file's order on a shuffled cloud); each result is a pure
    // function of its point, so the order changes nothing else.
    let order = index.spatial_order(positions.len());
    let mut visited = vec![Estimate::default(); positions.len()];
    visited.par_chunks_mut(CHUNK).zip(order.par_chunks(CHUNK)).for_each_init(Vec::new, |scratch, (chunk, points)| {
        for (e, &i) in chunk.iter_mut().zip(points) {
            let p = positions[i];
            let nbhd = index.neighbourhood(positions, p, k_query, scratch);
            if wanted.normals {
                let n = pca_normal(p, nbhd).unwrap_or(FALLBACK_NORMAL);
                e.normal = orient(n, p, orientation);
            }
            if wanted.radii {
                e.spacing = mean_spacing(nbhd, k_radius).unwrap_or(0.0);
            }
        }
        progress(chunk.len());
    });
    let mut out = vec![Estimate::default(); positions.len()];
    for (e, &i) in visited.iter().zip(&order) {
        out[i] = *e;
    }

    if wanted.normals {
        cloud.normals = Some(out.iter().map(|e| e.normal).collect());
        cloud.orientation = match orientation {
            Orientation::TowardSensor(_) | Orientation::Up(_) => Orientation::Oriented,
            Orientation::Oriented | Orientation::Unknown => Orientation::Unknown,
        };
    }
    if wanted.radii {
        let mut known: Vec<f32> = out.iter().map(|e| e.spacing).filter(|s| *s > 0.0).collect();
        let fallback = if known.is_empty() {
            FALLBACK_SPACING
        } else {
            let mid = known.len() / 2;
            *known.select_nth_unstable_by(mid, f32::total_cmp).1
        };
        let scale = settings.radius_scale;
        cloud.radii = Some(out.iter().map(|e| scale * if e.spacing > 0.0 { e.spacing } else { fallback }).collect());
    }
}

/// Flip `n` so that it agrees with the orientation hint; without one, so that its
/// largest-magnitude component (the first, among equals) is positive.
fn orient(n: Vec3, p: Vec3, orientation: Orientation) -> Vec3 {
    let flip = match orientation {
        Orientation::TowardSensor(s) => n.dot(s - p) < 0.0,
        Orientation::Up(u) => n.dot(u) < 0.0,
        Orientation::Oriented | Orientation::Unknown => {
            let a = n.abs();
            let largest = if a.x >= a.y && a.x >= a.z {
                n.x
            } else if a.y >= a.z {
                n.y
            } else {
                n.z
            };
            largest < 0.0
        }
    };
    if flip { -n } else { n }
}

/// A neighbour: squared distance to the query point, and position.
type Neighbour = (f32, Vec3);

/// Canonical order of neighbours: by distance, then by position, so that which of several
/// equidistant points is taken never depends on the tree's layout or the points' order
/// (coincident points are interchangeable).
fn neighbour_order(a: &Neighbour, b: &Neighbour) -> Ordering {
    a.0.total_cmp(&b.0).then(a.1.x.total_cmp(&b.1.x)).then(a.1.y.total_cmp(&b.1.y)).then(a.1.z.total_cmp(&b.1.z))
}

/// The k-d tree over the cloud's usable points (finite, and short of `f32::MAX`, which kiddo
/// reserves), one entry per distinct position with its number of copies. Coincident points are
/// stored once: a k-d tree cannot split copies of one position, so a leaf of 40 000 copies made
/// every query near it scan them all (80 000 identical points took 21.6 s). Unusable points
/// (which validation rejects anyway) get the fallbacks, as does every point of a cloud too big
/// for the tree's u32 items (over 2³² points).
struct NeighbourIndex {
    tree: Option<ImmutableKdTree<f32, 3>>,
    /// Distinct position `u` is `distinct[u]`; its points are `members[starts[u]..starts[u + 1]]`.
    distinct: Vec<Vec3>,
    starts: Vec<usize>,
    members: Vec<usize>,
    /// Usable points, copies counted.
    size: usize,
}

impl NeighbourIndex {
    fn new(positions: &[Vec3]) -> Self {
        let none = Self { tree: None, distinct: Vec::new(), starts: vec![0], members: Vec::new(), size: 0 };
        if u32::try_from(positions.len()).is_err() {
            return none;
        }
        // Points sorted by their position's bits (then index): copies become runs.
        let key = |p: Vec3| p.to_array().map(f32::to_bits);
        let mut members: Vec<usize> = (0..positions.len()).filter(|&i| usable(positions[i])).collect();
        members.sort_unstable_by_key(|&i| (key(positions[i]), i));
        let mut distinct = Vec::new();
        let mut starts = Vec::new();
        for (k, &i) in members.iter().enumerate() {
            if k == 0 || key(positions[members[k - 1]]) != key(positions[i]) {
                distinct.push(positions[i]);
                starts.push(k);
            }
        }
        starts.push(members.len());
        let size = members.len();
        let entries: Vec<(u32, [f32; 3])> = (0u32..).zip(&distinct).map(|(u, p)| (u, p.to_array())).collect();
        let tree = if size > 1 { ImmutableKdTree::new_from_entries(&entries).ok() } else { None };
        Self { tree, distinct, starts, members, size }
    }

    /// How many points sit at distinct position `u`.
    fn copies(&self, u: usize) -> usize {
        self.starts[u + 1] - self.starts[u]
    }

    /// Every index below `len` once: the tree's points leaf by leaf (copies together), then any
    /// the tree left out.
    fn spatial_order(&self, len: usize) -> Vec<usize> {
        let Some(tree) = &self.tree else { return (0..len).collect() };
        let mut order: Vec<usize> = Vec::with_capacity(len);
        for (u, _) in tree.iter() {
            let u = u as usize;
            order.extend_from_slice(&self.members[self.starts[u]..self.starts[u + 1]]);
        }
        if order.len() < len {
            let mut seen = vec![false; len];
            for &i in &order {
                seen[i] = true;
            }
            order.extend((0..len).filter(|&i| !seen[i]));
        }
        order
    }

    /// Point `p` and its `k` nearest other points (fewer if the cloud is smaller), nearest
    /// first, in [`neighbour_order`]. Empty if `p` is not in the tree.
    ///
    /// The k-nearest set is unique unless the (k+1)-th point ties with a farther one, so one
    /// more neighbour than needed is fetched; on a tie, every point out to that distance is
    /// gathered (capped, for clouds with many coincident points, where which copies are taken
    /// makes no difference) and sorted canonically. The tree answers with distinct positions;
    /// each stands for its copies (at most as many as could be kept), so the result is the one
    /// a tree of every point would give, at a cost that does not grow with the copies.
    fn neighbourhood<'s>(
        &self,
        _positions: &[Vec3],
        p: Vec3,
        k: usize,
        scratch: &'s mut Vec<Neighbour>,
    ) -> &'s [Neighbour] {
        scratch.clear();
        let Some(tree) = &self.tree else { return scratch };
        if !usable(p) {
            return scratch;
        }
        let want = (k + 1).min(self.size);
        let fetch = (want + 1).min(self.size);
        let cap = 2 * want + 64;
        let query = p.to_array();
        let gather = |scratch: &mut Vec<Neighbour>, items: &mut dyn Iterator<Item = u32>| {
            scratch.clear();
            for u in items {
                let q = self.distinct[u as usize];
                let d = (q - p).length_squared();
                scratch.extend(std::iter::repeat_n((d, q), self.copies(u as usize).min(fetch)));
            }
            scratch.sort_unstable_by(neighbour_order);
        };
        let Some(n) = NonZeroUsize::new(fetch.min(self.distinct.len())) else { return scratch };
        let found = tree.query(&query).nearest_n::<SquaredEuclidean<f32>>(n).execute();
        gather(scratch, &mut found.iter().map(|r| r.item));
        if fetch > want && scratch.len() > want && scratch[want].0 <= scratch[want - 1].0 * (1.0 + TIE_MARGIN) {
            let radius = scratch[want - 1].0 * (1.0 + 2.0 * TIE_MARGIN);
            let cap = NonZeroUsize::new(cap.min(self.distinct.len())).unwrap_or(n);
            let found = tree.query(&query).nearest_n::<SquaredEuclidean<f32>>(cap).within(radius).execute();
            gather(scratch, &mut found.iter().map(|r| r.item));
        }
        scratch.truncate(want);
        scratch
    }
}

/// Whether the tree can hold `p`: finite, and short of `f32::MAX`, which kiddo reserves.
fn usable(p: Vec3) -> bool {
    p.is_finite() && p.abs().max_element() < f32::MAX
}

/// The PCA normal of a neighbourhood (Hoppe et al. 1992): the unit eigenvector of the smallest
/// eigenvalue of the covariance. `None` when the neighbourhood has no extent.
fn pca_normal(p: Vec3, nbhd: &[Neighbour]) -> Option<Vec3> {
    if nbhd.len() < 2 {
        return None;
    }
    // Offsets from p (small even far from the origin), accumulated in f64.
    let m = nbhd.len() as f64;
    let offsets = || nbhd.iter().map(|(_, q)| (*q - p).as_dvec3());
    let mean = offsets().sum::<glint_core::glam::DVec3>() / m;
    let mut c = [[0.0f64; 3]; 3];
    for d in offsets() {
        let d = (d - mean).to_array();
        for r in 0..3 {
            for s in r..3 {
                c[r][s] += d[r] * d[s];
            }
        }
    }
    c[1][0] = c[0][1];
    c[2][0] = c[0][2];
    c[2][1] = c[1][2];
    let trace = c[0][0] + c[1][1] + c[2][2];
    if !(trace.is_finite() && trace > 0.0) {
        return None;
    }
    let (values, vectors) = symmetric_eigen(c);
    let smallest = (0..3).min_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap_or(0);
    let v = Vec3::new(vectors[0][smallest] as f32, vectors[1][smallest] as f32, vectors[2][smallest] as f32);
    v.try_normalize()
}

/// Mean distance from the neighbourhood's first point (the query point, or a copy of it) to the
/// next `k` points; zero distances (coincident duplicates) count as the nearest non-zero
/// distance in the whole neighbourhood. `None` if there is none.
fn mean_spacing(nbhd: &[Neighbour], k: usize) -> Option<f32> {
    let others = nbhd.get(1..)?;
    let nearest_nonzero = others.iter().map(|(d2, _)| *d2).find(|d2| *d2 > 0.0)?.sqrt();
    let used = &others[..k.min(others.len())];
    let sum: f32 = used.iter().map(|(d2, _)| if *d2 > 0.0 { d2.sqrt() } else { nearest_nonzero }).sum();
    let mean = sum / used.len() as f32;
    (mean.is_finite() && mean > 0.0).then_some(mean)
}

/// Eigen-decomposition of a symmetric 3×3 matrix by cyclic Jacobi rotations (Golub and Van
/// Loan, 4th ed., §8.5; rotation as in Numerical Recipes §11.1). Returns the eigenvalues and the
/// matrix whose columns are the matching orthonormal eigenvectors. Accurate for repeated and
/// zero eigenvalues; converges quadratically (a handful of sweeps for 3×3).
fn symmetric_eigen(mut a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
    let mut v = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    let scale: f64 = a.iter().flatten().map(|x| x * x).sum();
    for _sweep in 0..32 {
        let off = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
        if off.is_nan() || off <= scale * (f64::EPSILON * f64::EPSILON) {
            break;
        }
        for (p, q) in [(0, 1), (0, 2), (1, 2)] {
            let apq = a[p][q];
            if apq == 0.0 {
                continue;
            }
            let theta = (a[q][q] - a[p][p]) / (2.0 * apq);
            // tan of the rotation angle, the smaller root of t² + 2tθ − 1 = 0.
            let t = if theta.abs() > 1e150 {
                0.5 / theta
            } else {
                theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt())
            };
            let c = 1.0 / (t * t + 1.0).sqrt();
            let s = t * c;
            a[p][p] -= t * apq;
            a[q][q] += t * apq;
            a[p][q] = 0.0;
            a[q][p] = 0.0;
            let r = 3 - p - q;
            let (arp, arq) = (a[r][p], a[r][q]);
            a[r][p] = c * arp - s * arq;
            a[p][r] = a[r][p];
            a[r][q] = s * arp + c * arq;
            a[q][r] = a[r][q];
            for row in &mut v {
                let (vp, vq) = (row[p], row[q]);
                row[p] = c * vp - s * vq;
                row[q] = s * vp + c * vq;
            }
        }
    }
    ([a[0][0], a[1][1], a[2][2]], v)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::random::{hash4, unit_float};
    use std::sync::atomic::{AtomicUsize, Ordering as AtomicOrdering};

    fn cloud(positions: Vec<Vec3>, orientation: Orientation) -> PointCloud {
        PointCloud { name: "test".into(), positions, orientation, ..PointCloud::default() }
    }

    fn rand(i: u64, d: u64) -> f32 {
        unit_float(hash4(i, 0, d, 99))
    }

    fn angle_degrees(a: Vec3, b: Vec3) -> f32 {
        a.dot(b).clamp(-1.0, 1.0).acos().to_degrees()
    }

    fn no_progress(_: usize) {}

    /// Random points on the plane through `origin` spanned by `u`, `v` (square of side 2).
    fn plane(count: u64, origin: Vec3, u: Vec3, v: Vec3, noise: f32) -> Vec<Vec3> {
        let n = u.cross(v).normalize();
        (0..count)
            .map(|i| {
                let (a, b, c) = (rand(i, 0) * 2.0 - 1.0, rand(i, 1) * 2.0 - 1.0, rand(i, 2) * 2.0 - 1.0);
                origin + a * u + b * v + noise * c * n
            })
            .collect()
    }

    fn sphere(count: u64, radius: f32) -> Vec<Vec3> {
        (0..count)
            .map(|i| {
                glint_core::sampling::sample_uniform_sphere(glint_core::Vec2::new(rand(i, 0), rand(i, 1))) * radius
            })
            .collect()
    }

    fn check_eigen(a: [[f64; 3]; 3]) -> ([f64; 3], [[f64; 3]; 3]) {
        let (values, v) = symmetric_eigen(a);
        let norm = a.iter().flatten().map(|x| x * x).sum::<f64>().sqrt().max(1e-300);
        for col in 0..3 {
            for row in 0..3 {
                let av: f64 = (0..3).map(|k| a[row][k] * v[k][col]).sum();
                assert!((av - values[col] * v[row][col]).abs() <= 1e-12 * norm, "A v ≠ λ v for {a:?}");
            }
            for other in 0..3 {
                let dot: f64 = (0..3).map(|k| v[k][col] * v[k][other]).sum();
                let expected = if col == other { 1.0 } else { 0.0 };
                assert!((dot - expected).abs() < 1e-12, "eigenvectors of {a:?} are not orthonormal");
            }
        }
        (values, v)
    }

    fn sorted(mut values: [f64; 3]) -> [f64; 3] {
        values.sort_by(f64::total_cmp);
        values
    }

    #[test]
    fn eigen_solver_on_known_matrices() {
        // Diagonal, and already-decoupled blocks.
        assert_eq!(sorted(check_eigen([[3.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 2.0]]).0), [1.0, 2.0, 3.0]);
        // [[2,1,0],[1,2,0],[0,0,5]]: eigenvalues 1, 3, 5.
        let values = sorted(check_eigen([[2.0, 1.0, 0.0], [1.0, 2.0, 0.0], [0.0, 0.0, 5.0]]).0);
        assert!((values[0] - 1.0).abs() < 1e-14 && (values[1] - 3.0).abs() < 1e-14 && values[2] == 5.0);
        // The all-ones matrix: eigenvalues 0, 0, 3 (repeated zero), eigenvector (1,1,1)/√3 for 3.
        let (values, v) = check_eigen([[1.0; 3]; 3]);
        let top = (0..3).max_by(|&a, &b| values[a].total_cmp(&values[b])).unwrap();
        assert!((sorted(values)[2] - 3.0).abs() < 1e-14 && sorted(values)[0].abs() < 1e-14);
        assert!((v[0][top].abs() - 3f64.sqrt().recip()).abs() < 1e-14);
        // Zero, identity (fully repeated) and huge / tiny scales.
        assert_eq!(check_eigen([[0.0; 3]; 3]).0, [0.0; 3]);
        assert_eq!(check_eigen([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]).0, [1.0; 3]);
        for s in [1e-30, 1e30] {
            let values = sorted(check_eigen([[2.0 * s, s, 0.0], [s, 2.0 * s, 0.0], [0.0, 0.0, 5.0 * s]]).0);
            assert!((values[0] / s - 1.0).abs() < 1e-12 && (values[2] / s - 5.0).abs() < 1e-12);
        }
    }

    #[test]
    fn eigen_solver_recovers_rotated_spectra() {
        for i in 0..200u64 {
            let axis = glint_core::sampling::sample_uniform_sphere(glint_core::Vec2::new(rand(i, 0), rand(i, 1)));
            let q = glint_core::glam::DQuat::from_axis_angle(axis.as_dvec3().normalize(), rand(i, 2) as f64 * 6.0);
            let r = glint_core::glam::DMat3::from_quat(q);
            // Include repeated and zero eigenvalues.
            let lambda = match i % 4 {
                0 => [0.0, 0.0, 1.0],
                1 => [0.5, 0.5, 2.0],
                2 => [1e-9, 1.0, 1.0],
                _ => [rand(i, 3) as f64, rand(i, 4) as f64, rand(i, 5) as f64],
            };
            let m = r * glint_core::glam::DMat3::from_diagonal(lambda.into()) * r.transpose();
            let a = [0, 1, 2].map(|row| [0, 1, 2].map(|col| m.col(col)[row]));
            let a = [
                a[0],
                [a[0][1], a[1][1], a[1][2]],
                [a[0][2], a[1][2], a[2][2]], // exactly symmetric
            ];
            let values = sorted(check_eigen(a).0);
            let expected = sorted(lambda);
            for (got, want) in values.iter().zip(expected) {
                assert!((got - want).abs() < 1e-12, "{values:?} vs {expected:?}");
            }
        }
    }

    #[test]
    fn plane_normals_follow_the_orientation_hint() {
        let u = Vec3::new(1.0, 0.2, 0.0);
        let v = Vec3::new(0.0, 0.3, 1.0);
        let n = u.cross(v).normalize();
        let origin = Vec3::new(3.0, -2.0, 1.0);
        let positions = plane(2000, origin, u, v, 0.0);

        let mut up = cloud(positions.clone(), Orientation::Up(-n));
        estimate_normals(&mut up, &EstimateSettings::default(), &no_progress);
        assert_eq!(up.orientation, Orientation::Oriented);
        for m in up.normals.as_ref().unwrap() {
            assert!(angle_degrees(*m, -n) < 0.1, "{m} vs {}", -n);
        }

        // A sensor on the +n side.
        let mut scanned = cloud(positions.clone(), Orientation::TowardSensor(origin + 5.0 * n));
        estimate_normals(&mut scanned, &EstimateSettings::default(), &no_progress);
        assert_eq!(scanned.orientation, Orientation::Oriented);
        assert!(scanned.normals.as_ref().unwrap().iter().all(|m| angle_degrees(*m, n) < 0.1));

        // No hint: the same plane, one deterministic sign (largest component positive).
        let mut unknown = cloud(positions, Orientation::Unknown);
        estimate_normals(&mut unknown, &EstimateSettings::default(), &no_progress);
        assert_eq!(unknown.orientation, Orientation::Unknown);
        let sign = n[n.abs().max_position()].signum(); // here −1: n ≈ (0.19, −0.93, 0.28)
        assert!(unknown.normals.as_ref().unwrap().iter().all(|m| angle_degrees(*m, sign * n) < 0.1));
        assert!(unknown.validate().is_ok());
    }

    #[test]
    fn sphere_normals_are_radial() {
        let positions = sphere(20_000, 2.0);
        let mut c = cloud(positions, Orientation::TowardSensor(Vec3::ZERO));
        estimate_normals(&mut c, &EstimateSettings::default(), &no_progress);
        let worst = c
            .positions
            .iter()
            .zip(c.normals.as_ref().unwrap())
            .map(|(p, n)| angle_degrees(*n, -p.normalize()))
            .fold(0.0, f32::max);
        // 16 neighbours span ≈ 3 % of the radius: their chord tilts the fit by about a degree.
        assert!(worst < 3.0, "worst {worst}°");
    }

    #[test]
    fn noisy_plane_normals_stay_within_five_degrees() {
        // 10 k points on a 2 × 2 square (spacing ≈ 0.02), ±0.002 off the plane: noise of 10 % of the spacing.
        let positions = plane(10_000, Vec3::ZERO, Vec3::X, Vec3::Z, 0.002);
        let mut c = cloud(positions, Orientation::Up(Vec3::Y));
        estimate_normals(&mut c, &EstimateSettings::default(), &no_progress);
        let angles: Vec<f32> = c.normals.as_ref().unwrap().iter().map(|n| angle_degrees(*n, Vec3::Y)).collect();
        let mean = angles.iter().sum::<f32>() / angles.len() as f32;
        let worst = angles.iter().copied().fold(0.0, f32::max);
        assert!(mean < 2.0 && worst < 5.0, "mean {mean}°, worst {worst}°");
    }

    #[test]
    fn grid_radius_is_about_one_point_two_spacings() {
        let h = 0.25;
        let positions: Vec<Vec3> =
            (0..40 * 40).map(|i| Vec3::new((i % 40) as f32 * h, 7.0, (i / 40) as f32 * h)).collect();
        let mut c = cloud(positions, Orientation::Unknown);
        estimate_radii(&mut c, &EstimateSettings::default(), &no_progress);
        let expected = (4.0 + 4.0 * 2f32.sqrt()) / 8.0 * h; // 1.207 h
        let radii = c.radii.as_ref().unwrap();
        // Interior points (away from the border) see the full ring.
        for (i, r) in radii.iter().enumerate() {
            let (x, z) = (i % 40, i / 40);
            if (1..39).contains(&x) && (1..39).contains(&z) {
                assert!((r - expected).abs() < 1e-5, "point {i}: {r} vs {expected}");
            }
        }
        assert!(radii.iter().all(|r| *r >= h && *r < 2.0 * h));
        // On a grid the 16th neighbour ties with three others: the normals must still be exact.
        estimate_normals(&mut c, &EstimateSettings::default(), &no_progress);
        assert!(c.normals.as_ref().unwrap().iter().all(|n| *n == Vec3::Y));
    }

    #[test]
    fn radius_scale_multiplies() {
        let positions = plane(500, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0);
        let mut a = cloud(positions.clone(), Orientation::Unknown);
        let mut b = cloud(positions, Orientation::Unknown);
        estimate_radii(&mut a, &EstimateSettings::default(), &no_progress);
        estimate_radii(&mut b, &EstimateSettings { radius_scale: 2.0, ..EstimateSettings::default() }, &no_progress);
        for (ra, rb) in a.radii.unwrap().iter().zip(b.radii.unwrap()) {
            assert_eq!(2.0 * ra, rb);
        }
    }

    #[test]
    fn coincident_points_are_indexed_once_and_still_count_as_neighbours() {
        // 2500 points of a plane and 40 000 more at one of them (issue 20: 5.5 s
        // instead of 0.19 s, every query near the spot scanning all copies).
        let mut positions = plane(2500, Vec3::ZERO, Vec3::X, Vec3::Z, 0.0);
        positions.extend(std::iter::repeat_n(positions[0], 40_000));
        let index = NeighbourIndex::new(&positions);
        assert_eq!(index.distinct.len(), 2500);
        assert_eq!(index.copies(index.distinct.iter().position(|q| *q == positions[0]).unwrap()), 40_001);
        let mut order = index.spatial_order(positions.len());
        order.sort_unstable();
        assert!(order.iter().enumerate().all(|(k, &i)| k == i), "every point visited once");
        let mut scratch = Vec::new();
        let nbhd = index.neighbourhood(&positions, positions[0], 16, &mut scratch);
        assert_eq!(nbhd.len(), 17);
        assert!(nbhd.iter().all(|(d, q)| *d == 0.0 && *q == positions[0]));
        // Away from the spot the plane's own neighbours are found, and its normals are +Y (the
        // few points whose neighbours are mostly the copies see a line and get some
        // perpendicular to it, as without the index).
        let mut c = cloud(positions, Orientation::Up(Vec3::Y));
        estimate_normals(&mut c, &EstimateSettings::default(), &no_progress);
        let normals = c.normals.unwrap();
        let flat = normals[1..2500].iter().filter(|n| (n.y - 1.0).abs() < 1e-5).count();
        assert!(flat > 2400, "{flat} of 2499 plane normals are +Y");
    }

    #[test]
    fn duplicates_and_tiny_clouds_get_finite_fallbacks() {
        let settings = EstimateSettings::default();
        // One point: +Y (then oriented), radius 1 × scale.
        let mut one = cloud(vec![Vec3::new(5.0, 5.0, 5.0)], Orientation::Up(-Vec3::Y));
        prepare(&mut one, &settings, &no_progress);
        assert_eq!(one.normals, Some(vec![-Vec3::Y]));
        assert_eq!(one.radii, Some(vec![1.0]));
        assert!(one.validate().is_ok());

        // Two points: the radius is their distance; the normal is some unit perpendicular.
        let mut two = cloud(vec![Vec3::ZERO, Vec3::new(0.0, 0.0, 3.0)], Orientation::Unknown);
        prepare(&mut two, &settings, &no_progress);
        assert_eq!(two.radii, Some(vec![3.0, 3.0]));
        assert!(two.normals.as_ref().unwrap().iter().all(|n| n.z.abs() < 1e-6));
        assert!(two.validate().is_ok());

        // Collinear points: finite unit normals perpendicular to the line.
        let mut line = cloud((0..50).map(|i| Vec3::new(i as f32, 2.0 * i as f32, 0.0)).collect(), Orientation::Unknown);
        prepare(&mut line, &settings, &no_progress);
        let dir = Vec3::new(1.0, 2.0, 0.0).normalize();
        assert!(line.normals.as_ref().unwrap().iter().all(|n| n.dot(dir).abs() < 1e-5));
        assert!(line.validate().is_ok());

        // 300 copies of one point: no length anywhere, so radius 1; normals the fallback.
        let mut same = cloud(vec![Vec3::splat(1.5); 300], Orientation::Unknown);
        prepare(&mut same, &settings, &no_progress);
        assert!(same.normals.as_ref().unwrap().iter().all(|n| *n == Vec3::Y));
        assert!(same.radii.as_ref().unwrap().iter().all(|r| *r == 1.0));
        assert!(same.validate().is_ok());

        // A grid where every point is stored 3 times, plus a far cluster of 20 copies: the copies
        // count at the grid spacing, the cluster (no non-zero distance within its k) takes the
        // median.
        let h = 0.5;
        let mut positions: Vec<Vec3> =
            (0..30 * 30).flat_map(|i| [Vec3::new((i % 30) as f32 * h, (i / 30) as f32 * h, 0.0); 3]).collect();
        positions.extend([Vec3::splat(1000.0); 20]);
        let mut dup = cloud(positions, Orientation::Unknown);
        prepare(&mut dup, &settings, &no_progress);
        let radii = dup.radii.as_ref().unwrap();
        assert!(radii.iter().all(|r| r.is_finite() && *r >= h * 0.99 && *r < 2.0 * h), "{radii:?}");
        assert!(dup.normals.as_ref().unwrap()[..2700].iter().all(|n| *n == Vec3::Z));
        assert!(dup.validate().is_ok());

        // Empty: nothing to do, nothing breaks.
        let mut empty = cloud(Vec::new(), Orientation::Unknown);
        prepare(&mut empty, &settings, &no_progress);
        assert_eq!(empty.normals, Some(Vec::new()));
    }

    #[test]
    fn non_finite_points_do_not_panic() {
        let mut positions = plane(100, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0);
        positions[3] = Vec3::NAN;
        positions[7] = Vec3::splat(f32::MAX);
        positions[9] = Vec3::new(f32::INFINITY, 0.0, 0.0);
        let mut c = cloud(positions, Orientation::Unknown);
        prepare(&mut c, &EstimateSettings::default(), &no_progress);
        let normals = c.normals.as_ref().unwrap();
        let radii = c.radii.as_ref().unwrap();
        assert!(normals.iter().all(|n| n.is_finite() && (n.length() - 1.0).abs() < 1e-5));
        assert!(radii.iter().all(|r| r.is_finite() && *r > 0.0));
        assert!(normals[0].z.abs() > 0.999);
    }

    #[test]
    fn prepare_keeps_what_the_cloud_has() {
        let positions = plane(400, Vec3::ZERO, Vec3::X, Vec3::Y, 0.0);
        // Given normals (pointing -Z) with an Up(+Z) hint: kept, flipped, cloud oriented; radii filled.
        let mut c = cloud(positions.clone(), Orientation::Up(Vec3::Z));
        c.normals = Some(vec![-Vec3::Z; 400]);
        let count = AtomicUsize::new(0);
        prepare(&mut c, &EstimateSettings::default(), &|n| {
            count.fetch_add(n, AtomicOrdering::Relaxed);
        });
        assert_eq!(count.into_inner(), 400);
        assert_eq!(c.normals, Some(vec![Vec3::Z; 400]));
        assert_eq!(c.orientation, Orientation::Oriented);
        assert!(c.radii.is_some());
        // Nothing missing: nothing estimated, no progress.
        let radii = Some(vec![0.125; 400]);
        let mut full = cloud(positions, Orientation::Oriented);
        full.normals = Some(vec![Vec3::X; 400]);
        full.radii = radii.clone();
        prepare(&mut full, &EstimateSettings::default(), &|_| panic!("nothing to do"));
        assert_eq!((full.normals, full.radii), (Some(vec![Vec3::X; 400]), radii));
    }

    #[test]
    fn results_do_not_depend_on_thread_count_or_point_order() {
        // A jittered plane, a sphere and a grid (neighbour ties): ≥ a few chunks each.
        let mut positions = plane(6000, Vec3::ZERO, Vec3::X, Vec3::Z, 0.01);
        positions.extend(sphere(6000, 3.0).iter().map(|p| *p + Vec3::splat(10.0)));
        positions.extend((0..4000).map(|i| Vec3::new((i % 64) as f32, -10.0, (i / 64) as f32)));
        let run_with = |threads: usize, positions: Vec<Vec3>| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut c = cloud(positions, Orientation::Unknown);
            pool.install(|| prepare(&mut c, &EstimateSettings::default(), &no_progress));
            c
        };
        let one = run_with(1, positions.clone());
        let two = run_with(2, positions.clone());
        assert_eq!(one.normals, two.normals);
        assert_eq!(one.radii, two.radii);
        // Reversed input: the same value for each point.
        let reversed = run_with(2, positions.iter().rev().copied().collect());
        let (n, r) = (reversed.normals.unwrap(), reversed.radii.unwrap());
        let len = positions.len();
        for i in 0..len {
            assert_eq!(one.normals.as_ref().unwrap()[i], n[len - 1 - i], "normal {i}");
            assert_eq!(one.radii.as_ref().unwrap()[i], r[len - 1 - i], "radius {i}");
        }
    }

    #[test]
    fn settings_are_validated() {
        assert!(EstimateSettings::default().validate().is_ok());
        assert!(EstimateSettings { k: 2, ..Default::default() }.validate().is_err());
        assert!(EstimateSettings { radius_scale: 0.0, ..Default::default() }.validate().is_err());
        assert!(EstimateSettings { radius_scale: f32::NAN, ..Default::default() }.validate().is_err());
    }

    /// `cargo test -p glint-scene --release -- --ignored --nocapture one_million`
    #[test]
    #[ignore = "timing"]
    fn one_million_points_timing() {
        let positions = sphere(1_000_000, 10.0);
        let mut c = cloud(positions, Orientation::TowardSensor(Vec3::ZERO));
        let start = std::time::Instant::now();
        let index = NeighbourIndex::new(&c.positions);
        let built = start.elapsed();
        run(&mut c, &index, &EstimateSettings::default(), Wanted { normals: true, radii: true }, &no_progress);
        let total = start.elapsed();
        println!(
            "1M points, {} threads: tree {:.0} ms, normals + radii {:.0} ms in all",
            rayon::current_num_threads(),
            built.as_secs_f64() * 1e3,
            total.as_secs_f64() * 1e3
        );
    }
}
