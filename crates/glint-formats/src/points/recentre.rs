//! When and how f64 file coordinates become f32 positions: the one recentring rule shared by
//! the PLY and text readers (LAS always recentres, see [`super::las`]).
//!
//! An f32 keeps about 7 significant digits. Geo-referenced scans (UTM coordinates of 500 000 m,
//! a tile a few hundred metres wide) lose centimetres when stored as f32, and renderers lose
//! more when rays are intersected far from the origin. So a cloud whose coordinates are large
//! compared to its own size, or simply large, is moved by its bounds' centre (in f64) and the
//! centre is kept as [`PointCloud::origin`](glint_scene::PointCloud). Small models keep their
//! coordinates exactly, so a scanned bunny lands where its author put it.

use glint_core::Vec3;
use glint_core::glam::DVec3;

/// Coordinates beyond this magnitude are always recentred.
const LARGE: f64 = 1e5;
/// ... as are coordinates this many times larger than the cloud's bounds diagonal.
const FAR_FOR_ITS_SIZE: f64 = 1000.0;

/// The origin to subtract from `coords`: the centre of their bounds when they are large for f32
/// (max |coordinate| > 1e5, or > 1000 × the bounds diagonal), else zero.
pub(crate) fn origin_for(coords: &[DVec3]) -> DVec3 {
    let Some(&first) = coords.first() else { return DVec3::ZERO };
    let (lo, hi) = coords.iter().fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
    let max_abs = lo.abs().max(hi.abs()).max_element();
    let diagonal = (hi - lo).length();
    if max_abs > LARGE || (diagonal > 0.0 && max_abs > FAR_FOR_ITS_SIZE * diagonal) {
        (lo + hi) * 0.5
    } else {
        DVec3::ZERO
    }
}

/// `p - origin`, subtracted in f64 and then rounded to f32. With a zero origin an f64 that
/// holds an f32 comes back bit-exact.
#[inline]
pub(crate) fn relative(p: DVec3, origin: DVec3) -> Vec3 {
    (p - origin).as_vec3()
}

/// Applies [`origin_for`]: the origin and the positions relative to it.
pub(crate) fn recentre(coords: &[DVec3]) -> (DVec3, Vec<Vec3>) {
    let origin = origin_for(coords);
    (origin, coords.iter().map(|&p| relative(p, origin)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn small_models_keep_their_coordinates() {
        let coords = [DVec3::new(-0.1, 0.03, 0.2), DVec3::new(0.05, 0.15, -0.04)];
        let (origin, p) = recentre(&coords);
        assert_eq!(origin, DVec3::ZERO);
        assert_eq!(p[0], Vec3::new(-0.1, 0.03, 0.2));
        // A building a kilometre from the origin is still "small": 2 km < 1000 × 20 m.
        let coords = [DVec3::new(1000.0, 0.0, 0.0), DVec3::new(1020.0, 5.0, 3.0)];
        assert_eq!(origin_for(&coords), DVec3::ZERO);
        assert_eq!(origin_for(&[DVec3::splat(3.0)]), DVec3::ZERO);
        assert_eq!(origin_for(&[]), DVec3::ZERO);
    }

    #[test]
    fn geo_referenced_coordinates_are_recentred_with_centimetre_precision() {
        let coords = [DVec3::new(500_000.01, 4_000_000.02, 100.0), DVec3::new(500_300.03, 4_000_200.04, 140.5)];
        let (origin, p) = recentre(&coords);
        assert!((origin - DVec3::new(500_150.02, 4_000_100.03, 120.25)).abs().max_element() < 1e-9);
        for (c, q) in coords.iter().zip(&p) {
            assert!((origin + q.as_dvec3() - *c).abs().max_element() < 1e-4, "{c} vs {q}");
        }
        // Far for its size, though not beyond 1e5: a 1 cm object at 50 m.
        let coords = [DVec3::new(50.0, 0.0, 0.0), DVec3::new(50.01, 0.0, 0.0)];
        assert!((origin_for(&coords).x - 50.005).abs() < 1e-12);
        // Beyond 1e5 even when degenerate.
        assert_eq!(origin_for(&[DVec3::splat(2e5)]), DVec3::splat(2e5));
    }
}
