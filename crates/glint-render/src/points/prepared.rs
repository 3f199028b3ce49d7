//! The scene's point clouds, laid out for the projection pass: built once per scene, read by
//! every frame.
//!
//! Points are sorted by Morton code within each cloud, so that consecutive points land on
//! nearby pixels and the scatter into the depth buffer stays in cache (DESIGN.md §6; Schütz et
//! al. 2021 sort points for the same reason). The projection pass streams 16 bytes per point
//! (position and an octahedral normal); radius, colour and the full normal are read only for
//! the points that win a pixel.

use crate::RenderError;
use glint_core::{Affine3A, Mat3, Rgb, Vec2, Vec3};
use glint_scene::{Orientation, Scene};
use rayon::prelude::*;

/// What the projection pass reads per point.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct StreamPoint {
    pub position: Vec3,
    /// Octahedral normal, 16 bits per coordinate (x low, y high); 0 for "no normal".
    pub normal: u32,
}

const _: () = assert!(std::mem::size_of::<StreamPoint>() == 16);

/// What is read of the point that wins a pixel, besides its [`StreamPoint`].
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct PointAttributes {
    /// Object-space radius.
    pub radius: f32,
    /// 8-bit sRGB colour (r low), the precision point files store; decoded by [`decode_colour`].
    pub colour: u32,
}

/// Linear colour → packed 8-bit sRGB (clamped to [0, 1]).
pub fn encode_colour(c: Rgb) -> u32 {
    let q = |v: f32| (glint_core::colour::linear_to_srgb(v.clamp(0.0, 1.0)) * 255.0).round() as u32;
    q(c.x) | q(c.y) << 8 | q(c.z) << 16
}

/// Packed 8-bit sRGB → linear colour.
#[inline]
pub fn decode_colour(c: u32) -> Rgb {
    let lut = srgb_table();
    Rgb::new(lut[(c & 0xff) as usize], lut[((c >> 8) & 0xff) as usize], lut[((c >> 16) & 0xff) as usize])
}

fn srgb_table() -> &'static [f32; 256] {
    static TABLE: std::sync::OnceLock<[f32; 256]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| std::array::from_fn(|i| glint_core::colour::srgb_to_linear(i as f32 / 255.0)))
}

/// One cloud's range of points and how it sits in the world.
#[derive(Clone, Debug)]
pub struct CloudRange {
    pub start: u32,
    pub end: u32,
    pub world_from_object: Affine3A,
    /// Transforms object-space normals to world space (inverse transpose).
    pub world_normal_from_object: Mat3,
    /// World radius = object radius × this (cube root of the transform's determinant).
    pub radius_scale: f32,
    pub material: u32,
    /// Normals point out of the surface: back faces may be culled.
    pub oriented: bool,
    pub has_normals: bool,
}

/// Every point of every cloud in the scene, ready to draw.
#[derive(Clone, Debug, Default)]
pub struct PreparedPoints {
    pub stream: Vec<StreamPoint>,
    /// Radius and colour per point, side by side: the point that wins a pixel costs one more
    /// cache line, not two.
    pub attributes: Vec<PointAttributes>,
    pub clouds: Vec<CloudRange>,
}

/// Most points the projection can index (the packed depth word keeps 32 bits of index, and one
/// value means "empty").
pub const MAX_POINTS: usize = u32::MAX as usize - 1;

impl PreparedPoints {
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        let total: usize = scene.clouds.iter().map(|c| c.cloud.len()).sum();
        if total > MAX_POINTS {
            return Err(RenderError::InvalidSetting(format!(
                "{total} points in all: the points mode draws at most {MAX_POINTS}"
            )));
        }
        let mut out = PreparedPoints {
            stream: Vec::with_capacity(total),
            attributes: Vec::with_capacity(total),
            clouds: Vec::with_capacity(scene.clouds.len()),
        };
        for object in &scene.clouds {
            let cloud = &object.cloud;
            let fallback_radius = fallback_radius(cloud.bounds().diagonal_length(), cloud.len());
            let material_colour = scene.materials.get(object.material).map_or(Rgb::splat(0.8), |m| m.colour);
            let material_colour = encode_colour(material_colour);
            let start = out.stream.len() as u32;
            // Each point's records made in input order (sequential reads), then sorted with
            // them: gathering the records in Morton order afterwards read the cloud's arrays at
            // random, a cache miss per array per point (0.5-0.9 s of a 5 M-point layout).
            let mut keyed = morton_keys(&cloud.positions, |i| Records {
                stream: StreamPoint {
                    position: cloud.positions[i],
                    normal: cloud.normals.as_ref().map_or(0, |n| encode_octahedral(n[i])),
                },
                attributes: PointAttributes {
                    radius: cloud.radii.as_ref().map_or(fallback_radius, |r| r[i]),
                    colour: cloud.colours.as_ref().map_or(material_colour, |c| encode_colour(c[i])),
                },
            });
            keyed.par_sort_unstable_by_key(|k| (k.key, k.index));
            out.stream.par_extend(keyed.par_iter().map(|k| k.records.stream));
            out.attributes.par_extend(keyed.par_iter().map(|k| k.records.attributes));
            drop(keyed);
            let m = object.world_from_object.matrix3;
            let det = m.determinant();
            out.clouds.push(CloudRange {
                start,
                end: out.stream.len() as u32,
                world_from_object: object.world_from_object,
                world_normal_from_object: Mat3::from(m).inverse().transpose(),
                radius_scale: det.abs().cbrt(),
                material: object.material as u32,
                oriented: cloud.normals.is_some() && cloud.orientation == Orientation::Oriented,
                has_normals: cloud.normals.is_some(),
            });
        }
        Ok(out)
    }

    #[allow(clippy::len_without_is_empty)] // internal: only the count is asked for
    pub fn len(&self) -> usize {
        self.stream.len()
    }
}

/// Radius for a cloud that has none (and was not prepared): the spacing of `n` points spread
/// evenly over a surface of about the bounding box's diagonal squared.
fn fallback_radius(diagonal: f32, n: usize) -> f32 {
    let r = diagonal / (n.max(1) as f32).sqrt();
    if r.is_finite() && r > 0.0 { r } else { 1.0 }
}

/// What the layout keeps of one point.
#[derive(Clone, Copy, Debug)]
struct Records {
    stream: StreamPoint,
    attributes: PointAttributes,
}

/// A point's records with its sort key: the Morton code of its position, ties broken by its
/// index in the cloud, so the order is deterministic.
#[derive(Clone, Copy, Debug)]
struct Keyed {
    key: u64,
    index: u32,
    records: Records,
}

/// Every point's Morton code in the cloud's bounds (21 bits per axis) beside `records(i)`,
/// made in parallel in input order.
fn morton_keys(positions: &[Vec3], records: impl Fn(usize) -> Records + Sync) -> Vec<Keyed> {
    let bounds = glint_core::Bounds3::from_points(positions.iter().copied());
    let lo = bounds.min;
    let extent = bounds.extent().max_element();
    let scale = if extent > 0.0 { ((1u32 << 21) - 1) as f32 / extent } else { 0.0 };
    positions
        .par_iter()
        .enumerate()
        .map(|(i, &p)| {
            let q = ((p - lo) * scale).max(Vec3::ZERO);
            Keyed { key: morton3(q.x as u32, q.y as u32, q.z as u32), index: i as u32, records: records(i) }
        })
        .collect()
}

/// Point indices sorted by Morton code, ties in index order (what the layout's sort gives).
#[cfg(test)]
fn morton_order(positions: &[Vec3]) -> Vec<u32> {
    let none = Records {
        stream: StreamPoint { position: Vec3::ZERO, normal: 0 },
        attributes: PointAttributes { radius: 0.0, colour: 0 },
    };
    let mut keyed = morton_keys(positions, |_| none);
    keyed.par_sort_unstable_by_key(|k| (k.key, k.index));
    keyed.into_iter().map(|k| k.index).collect()
}

/// Interleave the low 21 bits of x, y and z.
fn morton3(x: u32, y: u32, z: u32) -> u64 {
    fn spread(v: u32) -> u64 {
        let mut v = u64::from(v) & 0x1f_ffff;
        v = (v | v << 32) & 0x1f_0000_0000_ffff;
        v = (v | v << 16) & 0x1f_0000_ff00_00ff;
        v = (v | v << 8) & 0x100f_00f0_0f00_f00f;
        v = (v | v << 4) & 0x10c3_0c30_c30c_30c3;
        v = (v | v << 2) & 0x1249_2492_4924_9249;
        v
    }
    spread(x) | spread(y) << 1 | spread(z) << 2
}

/// Octahedral encoding of a unit vector (Cigolle et al. 2014), 16 bits per coordinate. Never 0
/// for a unit vector (0 decodes to "no normal").
pub fn encode_octahedral(n: Vec3) -> u32 {
    let l1 = n.x.abs() + n.y.abs() + n.z.abs();
    if l1.is_nan() || l1 <= 0.0 {
        return 0;
    }
    let mut p = Vec2::new(n.x, n.y) / l1;
    if n.z < 0.0 {
        p = (Vec2::ONE - Vec2::new(p.y.abs(), p.x.abs())) * Vec2::new(sign(p.x), sign(p.y));
    }
    let q = |v: f32| ((v.clamp(-1.0, 1.0) * 0.5 + 0.5) * 65534.0).round() as u32 + 1;
    q(p.x) | q(p.y) << 16
}

/// The (not normalised) direction an octahedral code stands for; zero for code 0.
#[inline]
pub fn decode_octahedral_direction(code: u32) -> Vec3 {
    if code == 0 {
        return Vec3::ZERO;
    }
    decode_octahedral_unchecked(code)
}

/// [`decode_octahedral_direction`] without the test for code 0 (which decodes to some
/// direction), branch-free: the lower hemisphere folded back by `t = max(−z, 0)` (Stubbe's
/// form), so a loop over codes can run in SIMD lanes.
#[inline(always)]
pub fn decode_octahedral_unchecked(code: u32) -> Vec3 {
    const SCALE: f32 = 2.0 / 65534.0;
    let x = (code & 0xffff) as f32 * SCALE - (1.0 + SCALE);
    let y = (code >> 16) as f32 * SCALE - (1.0 + SCALE);
    let z = 1.0 - x.abs() - y.abs();
    let t = (-z).max(0.0);
    Vec3::new(x - t.copysign(x), y - t.copysign(y), z)
}

#[inline]
fn sign(v: f32) -> f32 {
    if v >= 0.0 { 1.0 } else { -1.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::random::SampleStream;
    use glint_core::sampling::sample_uniform_sphere as uniform_sphere;

    #[test]
    fn octahedral_round_trip_is_close_and_never_zero() {
        for i in 0..20_000u64 {
            let mut s = SampleStream::new(i, 0, 7);
            let n = uniform_sphere(s.next_2d());
            let code = encode_octahedral(n);
            assert_ne!(code, 0);
            let back = decode_octahedral_direction(code).normalize();
            assert!((back - n).length() < 1e-4, "{n} -> {back}");
        }
        for n in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            assert!(decode_octahedral_direction(encode_octahedral(n)).normalize().dot(n) > 0.999_999);
        }
        assert_eq!(encode_octahedral(Vec3::ZERO), 0);
        assert_eq!(decode_octahedral_direction(0), Vec3::ZERO);
    }

    #[test]
    fn colours_round_trip_through_8_bit_srgb() {
        for i in 0..=255u32 {
            let v = glint_core::colour::srgb_to_linear(i as f32 / 255.0);
            let c = encode_colour(Rgb::new(v, 0.0, 1.0));
            assert_eq!(c & 0xff, i);
            assert_eq!(decode_colour(c), Rgb::new(v, 0.0, 1.0));
        }
        assert_eq!(encode_colour(Rgb::new(-1.0, 2.0, f32::NAN)) & 0xffff, 0xff00);
    }

    #[test]
    fn morton_order_is_a_permutation_that_groups_neighbours() {
        let pts: Vec<Vec3> = (0..4096).map(|i| Vec3::new((i % 64) as f32, (i / 64) as f32, 0.0)).collect();
        let order = morton_order(&pts);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert!(seen.iter().enumerate().all(|(i, &v)| i as u32 == v));
        // Consecutive points in Morton order are close: the mean step is a few grid cells.
        let steps: f32 =
            order.windows(2).map(|w| pts[w[0] as usize].distance(pts[w[1] as usize])).sum::<f32>() / 4095.0;
        assert!(steps < 2.0, "mean step {steps}");
        assert_eq!(morton3(1, 0, 0), 1);
        assert_eq!(morton3(0, 1, 0), 2);
        assert_eq!(morton3(0, 0, 1), 4);
        assert_eq!(morton3(3, 0, 0), 0b1001);
    }
}
