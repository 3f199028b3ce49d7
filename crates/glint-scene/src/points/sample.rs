//! Meshes → point clouds: uniform random points on a triangle mesh's surface, with normals and
//! one shared splat radius, so that any mesh scene can be rendered by the points mode (and the
//! points renderer compared against the ray-traced mesh).
//!
//! Area-weighted triangle choice (a cumulative area table, binary search) and the square-root
//! warp to uniform barycentrics (Turk 1990, "Generating random points in triangles"; pbrt-v3
//! `UniformSampleTriangle`). Point i draws from the hash streams of glint-core keyed by
//! (i, seed) only, so the cloud depends on the seed alone, never on threads or chunking.

use super::{Orientation, PointCloud};
use crate::{Mesh, SceneError};
use glint_core::Vec3;
use glint_core::random::{SampleStream, hash4};
use rayon::prelude::*;

/// Most points one call may draw (positions and normals alone would then take 48 GiB).
pub const MAX_SAMPLES: usize = 1 << 31;

/// Splat radius in units of `sqrt(A / (π N))`, the radius of a disc with the area per point.
///
/// The points are independent and uniform (a Poisson process of density N/A), not a
/// Poisson-disc set, so discs of radius r leave a fraction `exp(−N π r² / A)` of the surface
/// uncovered (Boolean-model coverage; Hall 1988, "Introduction to the Theory of Coverage
/// Processes") — with the factor c that is `exp(−c²)`. c = 1 would leave 37 % of the
/// surface bare, c = 2 1.8 %. The points renderer needs more than bare coverage: its elliptical
/// box filter stands for a coarse texel's children by one disc of their mean radius at their
/// mean centre (Marroquim et al. 2007 §3.2), which covers less than their union, so with c = 2
/// a sampled million-point dragon at 1024² showed 10.6 % of its interior pixels empty; c = 3
/// 0.9 %, c = 4 0.11 %, its outline growing by 0.11 % (BENCHMARKS.md §8.3). Hence 4: each disc
/// overlaps about sixteen others, which the pull-push averages without blurring covered pixels.
pub const COVERAGE_FACTOR: f32 = 4.0;

/// `count` points drawn uniformly by area over `mesh`, deterministic for `seed`. Normals are the
/// mesh's vertex normals interpolated (or the face normal where those cancel, or if the mesh has
/// none); the cloud is `Oriented`. Every point gets the radius `COVERAGE_FACTOR · sqrt(A / (π ·
/// count))` (A the total area); no colours.
///
/// Errors: `count` 0 or above [`MAX_SAMPLES`], a triangle referring to a missing vertex, vertex
/// normals not one per vertex, a triangle of non-finite area, or a total area of zero.
pub fn sample_mesh(mesh: &Mesh, count: usize, seed: u64) -> Result<PointCloud, SceneError> {
    let what = || format!("sampling mesh {:?}", mesh.name);
    if count == 0 || count > MAX_SAMPLES {
        return Err(SceneError::invalid(what(), format!("{count} points asked for; 1..={MAX_SAMPLES} can be drawn")));
    }
    let vertices = mesh.positions.len();
    if let Some(t) = mesh.triangles.iter().position(|t| t.iter().any(|&v| v as usize >= vertices)) {
        return Err(SceneError::invalid(
            what(),
            format!("triangle {t} refers to a vertex beyond the {vertices} given"),
        ));
    }
    if let Some(normals) = &mesh.normals
        && normals.len() != vertices
    {
        return Err(SceneError::invalid(what(), format!("{} normals for {vertices} vertices", normals.len())));
    }
    let table =
        AreaTable::new(mesh).map_err(|t| SceneError::invalid(what(), format!("triangle {t} has a non-finite area")))?;
    let area = table.total() * 0.5;
    if area.is_nan() || area <= 0.0 {
        return Err(SceneError::invalid(what(), "has zero total area"));
    }
    let radius = COVERAGE_FACTOR * (area / (std::f64::consts::PI * count as f64)).sqrt() as f32;
    if !(radius.is_finite() && radius > 0.0) {
        return Err(SceneError::invalid(what(), format!("area {area:e} gives no usable splat radius")));
    }

    let (positions, normals): (Vec<Vec3>, Vec<Vec3>) = (0..count as u64)
        .into_par_iter()
        .map(|i| {
            let s = sample_point(mesh, &table, i, seed);
            (s.position, s.normal)
        })
        .unzip();
    Ok(PointCloud {
        name: mesh.name.clone(),
        positions,
        normals: Some(normals),
        radii: Some(vec![radius; count]),
        colours: None,
        origin: glint_core::glam::DVec3::ZERO,
        orientation: Orientation::Oriented,
    })
}

/// Cumulative doubled areas of the triangles of positive area (f64: a million small triangles
/// still get their share), and which triangles they are.
struct AreaTable {
    cumulative: Vec<f64>,
    triangles: Vec<usize>,
}

impl AreaTable {
    /// `Err(t)` if triangle `t`'s area is not finite.
    fn new(mesh: &Mesh) -> Result<Self, usize> {
        let mut cumulative = Vec::new();
        let mut triangles = Vec::new();
        let mut sum = 0.0;
        for t in 0..mesh.triangles.len() {
            let [a, b, c] = mesh.triangle(t).map(|p| p.as_dvec3());
            let double_area = (b - a).cross(c - a).length();
            if !double_area.is_finite() {
                return Err(t);
            }
            if double_area > 0.0 {
                sum += double_area;
                cumulative.push(sum);
                triangles.push(t);
            }
        }
        Ok(Self { cumulative, triangles })
    }

    fn total(&self) -> f64 {
        self.cumulative.last().copied().unwrap_or(0.0)
    }

    /// The triangle whose share of the total contains `u` ∈ [0, 1).
    fn pick(&self, u: f64) -> usize {
        let target = u * self.total();
        let slot = self.cumulative.partition_point(|c| *c <= target).min(self.cumulative.len().saturating_sub(1));
        self.triangles.get(slot).copied().unwrap_or(0)
    }
}

struct SurfaceSample {
    /// Which triangle (the tests check the point lies on it).
    #[cfg_attr(not(test), expect(dead_code))]
    triangle: usize,
    position: Vec3,
    normal: Vec3,
}

/// Point `i`: dimension 0 of its stream (53 bits) picks the triangle, dimensions 1–2 place it.
fn sample_point(mesh: &Mesh, table: &AreaTable, i: u64, seed: u64) -> SurfaceSample {
    let u = (hash4(i, 0, 0, seed) >> 11) as f64 * (1.0 / (1u64 << 53) as f64);
    let triangle = table.pick(u);
    let w = SampleStream::new(i, 0, seed).at_dimension(1).next_2d();
    // Square-root warp: uniform on the triangle (Turk 1990).
    let su = w.x.sqrt();
    let b = [1.0 - su, w.y * su, su - w.y * su];
    let [pa, pb, pc] = mesh.triangle(triangle);
    let position = b[0] * pa + b[1] * pb + b[2] * pc;
    SurfaceSample { triangle, position, normal: shading_normal(mesh, triangle, b) }
}

/// Interpolated vertex normal at barycentrics `b`, or the face normal where there are none or
/// they cancel.
fn shading_normal(mesh: &Mesh, triangle: usize, b: [f32; 3]) -> Vec3 {
    let [ia, ib, ic] = mesh.triangles[triangle].map(|v| v as usize);
    if let Some(ns) = &mesh.normals
        && let Some(n) = (b[0] * ns[ia] + b[1] * ns[ib] + b[2] * ns[ic]).try_normalize()
    {
        return n;
    }
    let [a, b, c] = mesh.triangle(triangle).map(|p| p.as_dvec3());
    (b - a).cross(c - a).normalize_or(glint_core::glam::DVec3::Y).as_vec3()
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::chi2::{chi2_p_value, significance_level};

    /// The χ² tests of this module, for the suite's significance level.
    const CHI2_TESTS: usize = 2;

    fn square(side: f32) -> Mesh {
        Mesh {
            name: "square".into(),
            positions: vec![
                Vec3::ZERO,
                Vec3::new(side, 0.0, 0.0),
                Vec3::new(side, 0.0, side),
                Vec3::new(0.0, 0.0, side),
            ],
            triangles: vec![[0, 2, 1], [0, 3, 2]],
            ..Mesh::default()
        }
    }

    /// An irregular closed mesh: an octahedron with jittered vertices.
    fn lumpy() -> Mesh {
        let positions = vec![
            Vec3::new(1.2, 0.1, 0.0),
            Vec3::new(-0.9, 0.0, 0.2),
            Vec3::new(0.1, 1.5, 0.0),
            Vec3::new(0.0, -0.7, 0.1),
            Vec3::new(0.2, 0.0, 1.1),
            Vec3::new(0.0, 0.3, -0.8),
        ];
        let triangles = vec![[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
        let mut m = Mesh { name: "lumpy".into(), positions, triangles, ..Mesh::default() };
        m.compute_vertex_normals();
        m
    }

    #[test]
    fn counts_radius_and_points_on_their_triangles() {
        let mesh = lumpy();
        let cloud = sample_mesh(&mesh, 5000, 3).unwrap();
        assert_eq!(cloud.len(), 5000);
        assert_eq!(cloud.orientation, Orientation::Oriented);
        assert!(cloud.colours.is_none());
        assert!(cloud.validate().is_ok());
        let area: f32 = (0..8).map(|t| mesh.double_area(t)).sum::<f32>() * 0.5;
        let expected = 4.0 * (area / (std::f32::consts::PI * 5000.0)).sqrt();
        assert!(cloud.radii.as_ref().unwrap().iter().all(|r| (r - expected).abs() < 1e-6 * expected));

        let table = AreaTable::new(&mesh).unwrap();
        for i in 0..5000 {
            let s = sample_point(&mesh, &table, i, 3);
            assert_eq!(s.position, cloud.positions[i as usize]);
            let [a, b, c] = mesh.triangle(s.triangle);
            let n = (b - a).cross(c - a).normalize();
            assert!((s.position - a).dot(n).abs() < 1e-6, "point {i} is off its plane");
            // Inside: on the inner side of all three edges.
            for (p, q) in [(a, b), (b, c), (c, a)] {
                assert!((q - p).cross(s.position - p).dot(n) >= -1e-6, "point {i} is outside its triangle");
            }
            // Vertex normals of a convex shape point outward, within 90° of the face normal.
            assert!(s.normal.dot(n) > 0.0 && (s.normal.length() - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn triangles_get_points_in_proportion_to_area_chi2() {
        // Two disjoint triangles, areas 0.5 and 1.5, plus a degenerate one that must get none.
        let mesh = Mesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::new(5.0, 0.0, 0.0),
                Vec3::new(8.0, 0.0, 0.0),
                Vec3::new(5.0, 1.0, 0.0),
            ],
            triangles: vec![[0, 1, 2], [0, 1, 0], [3, 4, 5]],
            ..Mesh::default()
        };
        let n = 200_000;
        let cloud = sample_mesh(&mesh, n, 17).unwrap();
        let small = cloud.positions.iter().filter(|p| p.x < 2.0).count() as f64;
        let expected = [n as f64 * 0.25, n as f64 * 0.75];
        let observed = [small, n as f64 - small];
        let statistic: f64 = observed.iter().zip(expected).map(|(o, e)| (o - e) * (o - e) / e).sum();
        let p = chi2_p_value(statistic, 1);
        assert!(p > significance_level(CHI2_TESTS), "χ² = {statistic}, p = {p}");
        assert!(cloud.normals.as_ref().unwrap().iter().all(|n| *n == Vec3::Z));
    }

    #[test]
    fn points_are_uniform_within_a_triangle_chi2() {
        // Cut the triangle into s² congruent cells (s per edge); each should get 1/s² of the points.
        let (a, b, c) = (Vec3::ZERO, Vec3::new(3.0, 0.0, 0.0), Vec3::new(0.5, 2.0, 0.0));
        let mesh = Mesh { positions: vec![a, b, c], triangles: vec![[0, 1, 2]], ..Mesh::default() };
        let n = 160_000;
        let s = 8usize;
        let cloud = sample_mesh(&mesh, n, 5).unwrap();
        let mut counts = vec![0f64; s * s * 2];
        let (e1, e2) = (b - a, c - a);
        let det = e1.x * e2.y - e1.y * e2.x;
        for p in &cloud.positions {
            let d = *p - a;
            let b1 = (d.x * e2.y - d.y * e2.x) / det;
            let b2 = (e1.x * d.y - e1.y * d.x) / det;
            let b0 = 1.0 - b1 - b2;
            let cell = |x: f32| ((x * s as f32).floor().max(0.0) as usize).min(s - 1);
            let (i, j, k) = (cell(b1), cell(b2), cell(b0));
            let up = usize::from(i + j + k == s - 1);
            counts[(i * s + j) * 2 + up] += 1.0;
        }
        // Cells that exist: upward (i + j ≤ s − 1) and downward (i + j ≤ s − 2).
        let expected = n as f64 / (s * s) as f64;
        let mut statistic = 0.0;
        let mut cells = 0;
        for i in 0..s {
            for j in 0..s {
                for up in 0..2 {
                    let exists = if up == 1 { i + j < s } else { i + j + 1 < s };
                    let o = counts[(i * s + j) * 2 + up];
                    if exists {
                        statistic += (o - expected) * (o - expected) / expected;
                        cells += 1;
                    } else {
                        assert_eq!(o, 0.0);
                    }
                }
            }
        }
        assert_eq!(cells, s * s);
        let p = chi2_p_value(statistic, cells - 1);
        assert!(p > significance_level(CHI2_TESTS), "χ² = {statistic}, p = {p}");
    }

    #[test]
    fn discs_cover_all_but_exp_minus_c_squared() {
        // The coverage argument behind COVERAGE_FACTOR, measured at c = 2 (where it is
        // measurable): the share of probe points farther than r from every sample is exp(−c²)
        // ≈ 1.8 %.
        let n = 40_000;
        let c = 2.0;
        let cloud = sample_mesh(&square(1.0), n, 9).unwrap();
        let r = cloud.radii.as_ref().unwrap()[0] * c / COVERAGE_FACTOR;
        let entries: Vec<[f32; 3]> = cloud.positions.iter().map(|p| p.to_array()).collect();
        let tree: kiddo::ImmutableKdTree<f32, 3> = kiddo::ImmutableKdTree::new_from_slice(&entries).unwrap();
        let probes = 20_000u64;
        let mut bare = 0;
        for i in 0..probes {
            let u = SampleStream::new(i, 1, 1234).next_2d();
            // Stay a disc away from the border, where coverage is one-sided.
            let p = [2.0 * r + u.x * (1.0 - 4.0 * r), 0.0, 2.0 * r + u.y * (1.0 - 4.0 * r)];
            let nearest = tree.query(&p).nearest_one::<kiddo::SquaredEuclidean<f32>>().execute();
            bare += usize::from(nearest.distance > r * r);
        }
        let fraction = bare as f64 / probes as f64;
        let expected = (-f64::from(c).powi(2)).exp();
        assert!((fraction - expected).abs() < 0.004, "{fraction} bare, expected {expected}");
    }

    #[test]
    fn deterministic_per_seed_and_thread_count() {
        let mesh = lumpy();
        let run_with = |threads: usize, seed: u64| {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            pool.install(|| sample_mesh(&mesh, 30_000, seed).unwrap())
        };
        let one = run_with(1, 7);
        let two = run_with(2, 7);
        assert_eq!(one, two);
        assert_eq!(one, sample_mesh(&mesh, 30_000, 7).unwrap());
        let other = run_with(2, 8);
        let same = one.positions.iter().zip(&other.positions).filter(|(a, b)| a == b).count();
        assert!(same < 10, "{same} of the points are the same for another seed");
    }

    #[test]
    fn vertex_normals_are_interpolated_with_a_face_fallback() {
        let mut mesh = square(2.0);
        mesh.normals = Some(vec![Vec3::Y, Vec3::Y, Vec3::X, Vec3::Y]);
        assert_eq!(shading_normal(&mesh, 0, [0.0, 0.0, 1.0]), Vec3::Y);
        let mid = shading_normal(&mesh, 0, [0.0, 0.5, 0.5]);
        assert!((mid - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        // Opposite vertex normals cancel at the midpoint: the face normal (+Y for this winding).
        mesh.normals = Some(vec![Vec3::X, -Vec3::X, Vec3::X, Vec3::X]);
        assert_eq!(shading_normal(&mesh, 0, [0.5, 0.0, 0.5]), Vec3::Y);
        let cloud = sample_mesh(&mesh, 1000, 1).unwrap();
        assert!(cloud.validate().is_ok());
    }

    #[test]
    fn bad_requests_are_errors() {
        let mesh = square(1.0);
        assert!(sample_mesh(&mesh, 0, 1).unwrap_err().to_string().contains("0 points"));
        assert!(sample_mesh(&mesh, MAX_SAMPLES + 1, 1).is_err());
        let flat =
            Mesh { positions: vec![Vec3::ZERO, Vec3::X, Vec3::X * 2.0], triangles: vec![[0, 1, 2]], ..Mesh::default() };
        assert!(sample_mesh(&flat, 10, 1).unwrap_err().to_string().contains("zero total area"));
        assert!(sample_mesh(&Mesh::default(), 10, 1).unwrap_err().to_string().contains("zero total area"));
        let mut broken = square(1.0);
        broken.triangles.push([0, 1, 9]);
        assert!(sample_mesh(&broken, 10, 1).unwrap_err().to_string().contains("triangle 2"));
        let mut wrong_normals = square(1.0);
        wrong_normals.normals = Some(vec![Vec3::Y]);
        assert!(sample_mesh(&wrong_normals, 10, 1).unwrap_err().to_string().contains("1 normals for 4"));
        let mut infinite = square(1.0);
        infinite.positions[2].x = f32::INFINITY;
        assert!(sample_mesh(&infinite, 10, 1).unwrap_err().to_string().contains("non-finite area"));
    }
}
