//! Hash-derived random streams: every random number in glint is
//! `hash(pixel, sample, dimension, seed)`, so a render depends only on its seed, never on the
//! thread that computed a pixel or the order in which pixels were visited.

/// A 64-bit finaliser with full avalanche (the `splitmix64` mix; Steele et al. 2014).
#[inline]
pub const fn mix64(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Hash of the four coordinates of a random number.
#[inline]
pub const fn hash4(pixel: u64, sample: u64, dimension: u64, seed: u64) -> u64 {
    let h = mix64(seed ^ 0x9e37_79b9_7f4a_7c15);
    let h = mix64(h ^ pixel);
    let h = mix64(h ^ sample.wrapping_mul(0x2545_f491_4f6c_dd1d));
    mix64(h ^ dimension.wrapping_mul(0x9e37_79b9_7f4a_7c15))
}

/// A uniform float in [0, 1) from the top 24 bits of a hash.
#[inline]
pub fn unit_float(h: u64) -> f32 {
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// The random stream of one sample of one pixel: dimension `d` of it is
/// `unit_float(hash4(pixel, sample, d, seed))`. Consecutive calls take consecutive dimensions.
#[derive(Clone, Copy, Debug)]
pub struct SampleStream {
    base: u64,
    dimension: u64,
}

impl SampleStream {
    pub fn new(pixel: u64, sample: u64, seed: u64) -> Self {
        let h = mix64(seed ^ 0x9e37_79b9_7f4a_7c15);
        let h = mix64(h ^ pixel);
        let base = mix64(h ^ sample.wrapping_mul(0x2545_f491_4f6c_dd1d));
        Self { base, dimension: 0 }
    }

    /// The next uniform float in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        let h = mix64(self.base ^ self.dimension.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        self.dimension += 1;
        unit_float(h)
    }

    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        let a = self.next_1d();
        glam::Vec2::new(a, self.next_1d())
    }

    /// Jump to dimension `d` (so each use of randomness can own fixed dimensions).
    pub fn at_dimension(mut self, d: u64) -> Self {
        self.dimension = d;
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stream_matches_hash4() {
        let mut s = SampleStream::new(17, 3, 42);
        for d in 0..8 {
            assert_eq!(s.next_1d(), unit_float(hash4(17, 3, d, 42)));
        }
    }

    #[test]
    fn unit_floats_are_in_range_and_roughly_uniform() {
        let n = 100_000;
        let mut buckets = [0u32; 10];
        for i in 0..n {
            let u = unit_float(hash4(i, 0, 0, 7));
            assert!((0.0..1.0).contains(&u));
            buckets[(u * 10.0) as usize] += 1;
        }
        for b in buckets {
            assert!((b as f64 - 10_000.0).abs() < 500.0, "{buckets:?}");
        }
    }
}
