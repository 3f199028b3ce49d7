//! Axis-aligned bounding boxes.

use glam::{Affine3A, Vec3};

/// An axis-aligned box. The empty box has `min = +inf`, `max = -inf`, so that growing it by any
/// point or box gives that point or box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds3 {
    pub min: Vec3,
    pub max: Vec3,
}

impl Default for Bounds3 {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Bounds3 {
    pub const EMPTY: Bounds3 = Bounds3 { min: Vec3::INFINITY, max: Vec3::NEG_INFINITY };

    pub fn new(min: Vec3, max: Vec3) -> Self {
        Self { min, max }
    }

    pub fn from_point(p: Vec3) -> Self {
        Self { min: p, max: p }
    }

    pub fn from_points(points: impl IntoIterator<Item = Vec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    #[inline]
    pub fn grow(self, p: Vec3) -> Self {
        Self { min: self.min.min(p), max: self.max.max(p) }
    }

    #[inline]
    pub fn union(self, other: Bounds3) -> Self {
        Self { min: self.min.min(other.min), max: self.max.max(other.max) }
    }

    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    #[inline]
    pub fn extent(&self) -> Vec3 {
        (self.max - self.min).max(Vec3::ZERO)
    }

    #[inline]
    pub fn centre(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Half the surface area (the SAH only needs ratios); 0 for an empty box.
    #[inline]
    pub fn half_area(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    pub fn surface_area(&self) -> f32 {
        2.0 * self.half_area()
    }

    /// Index of the longest axis (0, 1 or 2).
    pub fn largest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// The box around the eight transformed corners.
    pub fn transformed(&self, m: &Affine3A) -> Bounds3 {
        if self.is_empty() {
            return *self;
        }
        let mut b = Bounds3::EMPTY;
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            b = b.grow(m.transform_point3(c));
        }
        b
    }

    /// Length of the diagonal, 0 for an empty box.
    pub fn diagonal_length(&self) -> f32 {
        self.extent().length()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn empty_box_is_identity_of_union() {
        let b = Bounds3::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(Bounds3::EMPTY.union(b), b);
        assert!(Bounds3::EMPTY.is_empty());
        assert_eq!(Bounds3::EMPTY.half_area(), 0.0);
    }

    #[test]
    fn half_area_of_unit_cube_is_three() {
        let b = Bounds3::new(Vec3::ZERO, Vec3::ONE);
        assert_eq!(b.half_area(), 3.0);
        assert_eq!(b.surface_area(), 6.0);
        assert_eq!(Bounds3::new(Vec3::ZERO, Vec3::new(1.0, 5.0, 2.0)).largest_axis(), 1);
    }
}
