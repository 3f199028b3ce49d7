//! Synthetic inputs for the tests: random and piecewise-flat scenes.

use crate::Guide;

/// A tiny deterministic generator (PCG-style LCG with an output shift).
pub(crate) struct Rng(u64);

impl Rng {
    pub(crate) fn new(seed: u64) -> Self {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15).wrapping_add(1))
    }

    /// Uniform in [0, 1).
    pub(crate) fn next_f32(&mut self) -> f32 {
        self.0 = self.0.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }
}

/// Input planes and a guide, owned.
#[derive(Clone, Debug)]
pub(crate) struct Scene {
    pub w: usize,
    pub h: usize,
    pub input: [Vec<f32>; 3],
    pub normal: [Vec<f32>; 3],
    pub depth: Vec<f32>,
}

impl Scene {
    pub(crate) fn input(&self) -> [&[f32]; 3] {
        [&self.input[0], &self.input[1], &self.input[2]]
    }

    pub(crate) fn guide(&self) -> Guide<'_> {
        Guide {
            width: self.w,
            height: self.h,
            normal: [&self.normal[0], &self.normal[1], &self.normal[2]],
            depth: &self.depth,
        }
    }
}

/// Random unit normals (every 13th pixel "missed": zero normal, depth 1.5), depth in [0, 1.2),
/// input in [0, 1).
pub(crate) fn random_scene(w: usize, h: usize, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let n = w * h;
    let mut normal: [Vec<f32>; 3] = std::array::from_fn(|_| Vec::with_capacity(n));
    let mut depth = Vec::with_capacity(n);
    for i in 0..n {
        let v = loop {
            let v = [0; 3].map(|_| rng.next_f32() * 2.0 - 1.0);
            let len2: f32 = v.iter().map(|c| c * c).sum();
            if len2 > 0.01 && len2 <= 1.0 {
                break v.map(|c| c / len2.sqrt());
            }
        };
        let missed = i % 13 == 5;
        for k in 0..3 {
            normal[k].push(if missed { 0.0 } else { v[k] });
        }
        depth.push(if missed { 1.5 } else { rng.next_f32() * 1.2 });
    }
    let input = std::array::from_fn(|_| (0..n).map(|_| rng.next_f32()).collect());
    Scene { w, h, input, normal, depth }
}

/// Two flat halves split at column `split`: the left one has normal `normals[0]`, depth `z[0]`
/// and input `left`; the right one `normals[1]`, `z[1]` and `right`.
pub(crate) fn two_halves(
    w: usize,
    h: usize,
    split: usize,
    [left, right]: [f32; 2],
    z: [f32; 2],
    normals: [[f32; 3]; 2],
) -> Scene {
    let n = w * h;
    let side = |i: usize| usize::from(i % w >= split);
    let normal = std::array::from_fn(|k| (0..n).map(|i| normals[side(i)][k]).collect());
    let depth = (0..n).map(|i| z[side(i)]).collect();
    let input = std::array::from_fn(|_| (0..n).map(|i| [left, right][side(i)]).collect());
    Scene { w, h, input, normal, depth }
}

/// Unit normals along +X, +Y, −Y, +Z.
pub(crate) const PLUS_X: [f32; 3] = [1.0, 0.0, 0.0];
pub(crate) const PLUS_Y: [f32; 3] = [0.0, 1.0, 0.0];
pub(crate) const MINUS_Y: [f32; 3] = [0.0, -1.0, 0.0];
pub(crate) const PLUS_Z: [f32; 3] = [0.0, 0.0, 1.0];
