//! The geometry-aware lookup (DESIGN.md §2): a sample after the guide ray takes its indirect
//! light from the filtered map at the guide pixel, among the 2×2 whose centres enclose it, that
//! looks most like its own hit.
//!
//! `S_i = S_N,i · S_D,i`, `S_N,i = 1 − |N_a − N_i| / max_j |N_a − N_j|` (likewise for depth;
//! a factor whose maximum is 0 is 1). The highest `S_i` wins; ties go to the guide nearest the
//! sample, then to the lowest index (order: top-left, top-right, bottom-left, bottom-right).
//! Guides that hit nothing never win; when none of the four hit, there is no value.

use glint_core::{Vec2, Vec3};

/// The guide rays of a frame: one per pixel, through its centre.
pub struct GuideMap<'a> {
    pub width: usize,
    pub height: usize,
    pub normal: &'a [Vec3],
    /// +inf where the guide ray found no non-delta vertex.
    pub depth: &'a [f32],
}

impl GuideMap<'_> {
    /// The pixel index of the guide to read for a sample at image position `pos` (pixels)
    /// whose own guide vertex has normal `n` and depth `d`.
    pub fn choose(&self, pos: Vec2, n: Vec3, d: f32) -> Option<usize> {
        let clamp_x = |x: f32| (x.max(0.0) as usize).min(self.width - 1);
        let clamp_y = |y: f32| (y.max(0.0) as usize).min(self.height - 1);
        let fx = (pos.x - 0.5).floor();
        let fy = (pos.y - 0.5).floor();
        let (x0, x1) = (clamp_x(fx), clamp_x(fx + 1.0));
        let (y0, y1) = (clamp_y(fy), clamp_y(fy + 1.0));
        let candidates = [y0 * self.width + x0, y0 * self.width + x1, y1 * self.width + x0, y1 * self.width + x1];
        let mut dn = [0.0f32; 4];
        let mut dd = [0.0f32; 4];
        let (mut max_n, mut max_d) = (0.0f32, 0.0f32);
        let mut any = false;
        for (k, &i) in candidates.iter().enumerate() {
            if !self.depth[i].is_finite() {
                continue;
            }
            any = true;
            dn[k] = (n - self.normal[i]).length();
            dd[k] = (d - self.depth[i]).abs();
            max_n = max_n.max(dn[k]);
            max_d = max_d.max(dd[k]);
        }
        if !any {
            return None;
        }
        let mut best: Option<(f32, f32, usize)> = None;
        for (k, &i) in candidates.iter().enumerate() {
            if !self.depth[i].is_finite() {
                continue;
            }
            let s_n = if max_n > 0.0 { 1.0 - dn[k] / max_n } else { 1.0 };
            let s_d = if max_d > 0.0 { 1.0 - dd[k] / max_d } else { 1.0 };
            let s = s_n * s_d;
            let centre = Vec2::new((i % self.width) as f32 + 0.5, (i / self.width) as f32 + 0.5);
            let dist = centre.distance_squared(pos);
            let better = match best {
                None => true,
                Some((bs, bd, _)) => s > bs || (s == bs && dist < bd),
            };
            if better {
                best = Some((s, dist, i));
            }
        }
        best.map(|(_, _, i)| i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 4×4 map: left half a floor (normal +Y, depth 2), right half a wall (normal +X,
    /// depth 5), pixel (1,1) hit nothing.
    fn map() -> (Vec<Vec3>, Vec<f32>) {
        let mut n = Vec::new();
        let mut d = Vec::new();
        for y in 0..4 {
            for x in 0..4 {
                if x < 2 {
                    n.push(Vec3::Y);
                    d.push(2.0 + 0.01 * y as f32);
                } else {
                    n.push(Vec3::X);
                    d.push(5.0);
                }
            }
        }
        d[5] = f32::INFINITY;
        n[5] = Vec3::ZERO;
        (n, d)
    }

    #[test]
    fn picks_the_guide_on_the_same_surface() {
        let (n, d) = map();
        let m = GuideMap { width: 4, height: 4, normal: &n, depth: &d };
        // Between columns 1 and 2 (floor | wall), rows 2 and 3: a wall sample must read the
        // wall even though it sits nearer the floor's centres.
        let pos = Vec2::new(1.6, 2.9);
        let i = m.choose(pos, Vec3::X, 5.0).expect("some guide");
        assert_eq!(i % 4, 2);
        let i = m.choose(Vec2::new(1.9, 2.9), Vec3::Y, 2.02).expect("some guide");
        assert_eq!(i % 4, 1);
    }

    #[test]
    fn ties_go_to_the_nearest_guide_and_misses_never_win() {
        let (n, d) = map();
        let m = GuideMap { width: 4, height: 4, normal: &n, depth: &d };
        // All four guides identical (floor, equal depth is not quite: rows differ by 0.01):
        // a floor sample at row 0-1 near (0.7, 0.7) must pick (0,0).
        let i = m.choose(Vec2::new(0.7, 0.6), Vec3::Y, 2.0).expect("some guide");
        assert_eq!(i, 0);
        // Around the missing guide (1,1): never chosen.
        for pos in [Vec2::new(1.4, 1.4), Vec2::new(1.6, 1.6), Vec2::new(0.9, 1.9)] {
            let i = m.choose(pos, Vec3::Y, 2.01).expect("some guide");
            assert_ne!(i, 5);
        }
        // Clamped at the border.
        let i = m.choose(Vec2::new(0.1, 0.1), Vec3::Y, 2.0).expect("some guide");
        assert_eq!(i, 0);
    }

    #[test]
    fn no_hit_anywhere_gives_nothing() {
        let n = vec![Vec3::ZERO; 4];
        let d = vec![f32::INFINITY; 4];
        let m = GuideMap { width: 2, height: 2, normal: &n, depth: &d };
        assert_eq!(m.choose(Vec2::new(1.0, 1.0), Vec3::Y, 1.0), None);
    }
}
