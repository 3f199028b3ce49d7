//! Orthonormal frames (local shading coordinates).

use glam::Vec3;

/// An orthonormal basis with `z` as the "up" (normal) axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub x: Vec3,
    pub y: Vec3,
    pub z: Vec3,
}

impl Frame {
    /// A frame around the unit vector `n`, built without branches on a threshold
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    pub fn from_z(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let x = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let y = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Self { x, y, z: n }
    }

    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal() {
        for n in [Vec3::Z, -Vec3::Z, Vec3::X, Vec3::new(0.3, -0.4, 0.5).normalize()] {
            let f = Frame::from_z(n);
            assert!(f.x.dot(f.y).abs() < 1e-6);
            assert!(f.x.dot(f.z).abs() < 1e-6);
            assert!((f.x.length() - 1.0).abs() < 1e-5);
            assert!((f.x.cross(f.y) - f.z).length() < 1e-5);
            let v = Vec3::new(0.1, 0.2, 0.3);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
        }
    }
}
