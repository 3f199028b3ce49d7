//! Hash-derived random streams: every random number in glint is a pure function of
//! `(pixel, sample, dimension, seed)` — `hash(pixel, sample, dimension, seed)`, or, for the
//! path mode's low-discrepancy streams, point `sample` of a sequence scrambled by hashes of
//! `(pixel, dimension, seed)` — so a render depends only on its seed, never on the thread that
//! computed a pixel or the order in which pixels were visited.

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

/// The random stream of one sample of one pixel. Consecutive calls take consecutive
/// dimensions (a 2-D draw takes two).
///
/// Two kinds:
/// - [`SampleStream::new`], independent: dimension `d` is `unit_float(hash4(pixel, sample, d,
///   seed))`;
/// - [`SampleStream::sobol`], low discrepancy: the first [`SOBOL_DIMENSIONS`] dimensions of a
///   pixel's samples are a padded, shuffled, Owen-scrambled Sobol sequence (Burley, "Practical
///   Hash-based Owen Scrambling", JCGT 2020), the rest independent as above. Every draw (a 1-D
///   or a 2-D one) starting at dimension `d` takes the `sample`-th point of its own
///   scrambled (0,2)-sequence: the first two Sobol dimensions, the sample index shuffled and
///   the coordinates scrambled by seeds hashed from `(pixel, d, seed)`. So the samples of one
///   pixel are stratified in every draw (each prefix of 2^m samples is a (0,m,2)-net: one
///   point in each of 2^m elementary intervals), draws are decorrelated from one another,
///   and pixels are independent of each other. Still a pure function of (pixel, sample,
///   dimension, seed): no thread count or visiting order changes a number.
#[derive(Clone, Copy, Debug)]
pub struct SampleStream {
    base: u64,
    dimension: u64,
    /// Per-pixel seed of the scrambles (0 for an independent stream, see `sobol`).
    scramble: u64,
    /// The sample index, bits reversed (the shuffle scrambles it in that order).
    index_reversed: u32,
    sobol: bool,
}

/// How a render draws its camera samples' random numbers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sampler {
    /// Low discrepancy ([`SampleStream::sobol`]): a pixel's samples are stratified, which lowers
    /// the error of a mean of N samples well below the independent `variance / N`.
    #[default]
    Sobol,
    /// Independent numbers ([`SampleStream::new`]): Mitsuba's `independent` sampler, and what
    /// a per-sample variance estimate of the error of a pixel's mean assumes.
    Independent,
}

impl Sampler {
    /// The stream of sample `sample` of pixel `pixel`.
    #[inline]
    #[must_use]
    pub fn stream(self, pixel: u64, sample: u64, seed: u64) -> SampleStream {
        match self {
            Sampler::Sobol => SampleStream::sobol(pixel, sample, seed),
            Sampler::Independent => SampleStream::new(pixel, sample, seed),
        }
    }

    /// The name the scene format and the command line use.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Sobol => "sobol",
            Sampler::Independent => "independent",
        }
    }
}

/// Dimensions of a [`SampleStream::sobol`] stream that are low discrepancy: the camera's
/// pixel and lens samples and the first few vertices' light, lobe and direction choices (a
/// few dimensions per vertex). Later ones are independent: past a few bounces stratification
/// gains little and the scrambles cost a few nanoseconds a draw.
pub const SOBOL_DIMENSIONS: u64 = 16;

impl SampleStream {
    pub fn new(pixel: u64, sample: u64, seed: u64) -> Self {
        let h = mix64(seed ^ 0x9e37_79b9_7f4a_7c15);
        let h = mix64(h ^ pixel);
        let base = mix64(h ^ sample.wrapping_mul(0x2545_f491_4f6c_dd1d));
        Self { base, dimension: 0, scramble: 0, index_reversed: 0, sobol: false }
    }

    /// A low-discrepancy stream (see the type's documentation); dimensions from
    /// [`SOBOL_DIMENSIONS`] on are those of [`SampleStream::new`]`(pixel, sample, seed)`.
    pub fn sobol(pixel: u64, sample: u64, seed: u64) -> Self {
        let scramble = mix64(mix64(seed ^ 0x5851_f42d_4c95_7f2d) ^ pixel);
        Self { scramble, index_reversed: (sample as u32).reverse_bits(), sobol: true, ..Self::new(pixel, sample, seed) }
    }

    #[inline]
    fn ld(&self) -> bool {
        self.sobol && self.dimension < SOBOL_DIMENSIONS
    }

    /// The next uniform float in [0, 1).
    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        if self.ld() {
            let seeds = sobol_seeds(self.scramble, self.dimension);
            self.dimension += 1;
            return unit_float32(sobol_draw(self.index_reversed, seeds).0);
        }
        let u = self.independent_at(self.dimension);
        self.dimension += 1;
        u
    }

    #[inline]
    pub fn next_2d(&mut self) -> glam::Vec2 {
        if self.ld() {
            let seeds = sobol_seeds(self.scramble, self.dimension);
            self.dimension += 2;
            let (x, y) = sobol_draw(self.index_reversed, seeds);
            return glam::Vec2::new(unit_float32(x), unit_float32(y));
        }
        let a = self.next_1d();
        glam::Vec2::new(a, self.next_1d())
    }

    /// Dimension `d` of the independent stream (what [`SampleStream::next_1d`] reads there
    /// when it is not low discrepancy).
    #[inline]
    #[must_use]
    pub fn independent_at(&self, d: u64) -> f32 {
        unit_float(mix64(self.base ^ d.wrapping_mul(0x9e37_79b9_7f4a_7c15)))
    }

    /// A low-discrepancy stream's per-pixel scramble seed and bit-reversed sample index, for
    /// a caller that draws many streams' numbers at once ([`sobol_seeds`], [`sobol_draw`]);
    /// `None` for an independent stream. A draw at dimension `d` is low discrepancy where
    /// `d < SOBOL_DIMENSIONS`.
    #[must_use]
    pub fn sobol_state(&self) -> Option<(u64, u32)> {
        self.sobol.then_some((self.scramble, self.index_reversed))
    }

    /// Steps over the next `n` dimensions without computing them: the stream then reads
    /// what it would after `n` one-dimensional draws (or `n / 2` two-dimensional ones), for a
    /// caller that knows it will not use those numbers (a Sobol draw costs a few dozen
    /// integer operations).
    #[inline]
    pub fn skip(&mut self, n: u64) {
        self.dimension += n;
    }

    /// Jump to dimension `d` (so each use of randomness can own fixed dimensions).
    pub fn at_dimension(mut self, d: u64) -> Self {
        self.dimension = d;
        self
    }

    /// The dimension the next draw reads (a stream is its first dimension's stream
    /// `at_dimension` this).
    #[must_use]
    pub fn dimension(&self) -> u64 {
        self.dimension
    }
}

/// The seeds of a low-discrepancy draw at dimension `dimension` of a pixel whose scramble
/// seed is `scramble`: the index shuffle's, then one per coordinate (the third a
/// multiplicative hash of the 64-bit one: no second mix).
#[inline]
#[must_use]
pub fn sobol_seeds(scramble: u64, dimension: u64) -> (u32, u32, u32) {
    // The per-pixel seed is mixed already: one multiply spreads the dimension over it.
    let h = (scramble ^ dimension).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    (h as u32 ^ (h >> 29) as u32, (h >> 32) as u32, (h.wrapping_mul(0xd1b5_4a32_d192_ed03) >> 32) as u32)
}

/// The two coordinates (32-bit fractions) of the point of sample `index_reversed.reverse_bits()`
/// of the draw whose seeds are `(shuffle, sx, sy)` ([`sobol_seeds`]): the index shuffled by
/// Owen's scramble (`j` is the shuffled index reversed: `nested_uniform_scramble(index,
/// shuffle)` is `j.reverse_bits()`), then the first two Sobol dimensions at it, each
/// Owen-scrambled. The scrambles work in the reversed domain (`nested_uniform_scramble(v, s)`
/// is `lk_permutation(v.reverse_bits(), s).reverse_bits()`): Sobol's first coordinate reversed
/// is `j`, its second reversed is [`sobol_second_of_reversed`] of `j`'s reversal. A 1-D draw
/// is the first coordinate. The lanes of `path::wavefront` compute the same operations.
#[inline]
#[must_use]
pub fn sobol_draw(index_reversed: u32, (shuffle, sx, sy): (u32, u32, u32)) -> (u32, u32) {
    let j = lk_permutation(index_reversed, shuffle);
    let i = j.reverse_bits();
    (lk_permutation(i, sx).reverse_bits(), lk_permutation(sobol_second_of_reversed(i), sy).reverse_bits())
}

/// A uniform float in [0, 1) from the top 24 bits of a 32-bit value.
#[inline]
#[must_use]
pub fn unit_float32(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// A random permutation of 32-bit values in which a bit depends only on the bits below it
/// (Laine and Karras's observation, "Stratified sampling for stochastic transparency", 2011;
/// the constants of Vegdahl's improved hash, 2021, after Burley 2020). Applied to reversed
/// bits it is an Owen scramble: each bit of the result is flipped by a hash of the bits above
/// it.
#[inline]
#[must_use]
pub fn lk_permutation(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

/// Sobol's second dimension at index `i`, bits reversed: `sobol_second(i).reverse_bits()`,
/// where `sobol_second` is the sequence's second dimension (primitive polynomial `x + 1`:
/// direction numbers `v_0 = 2^31`, `v_k = v_{k-1} ^ (v_{k-1} >> 1)`, so `v_k` reversed holds
/// the binomial coefficients `C(k, t) mod 2` at bits `t`, the coefficients of `(1 + x)^k`).
/// Read as a polynomial over GF(2) (bit `k` the coefficient of `x^k`), the result is `i(x +
/// 1)`: the Taylor shift, made by one masked shift and xor per level of halves (`f(x + 1) =
/// f_0(x + 1) + f_1(x + 1) + x^s f_1(x + 1)` for `f = f_0 + x^s f_1`, the halves first).
#[inline]
#[must_use]
pub fn sobol_second_of_reversed(i: u32) -> u32 {
    let mut f = i;
    f ^= (f >> 1) & 0x5555_5555;
    f ^= (f >> 2) & 0x3333_3333;
    f ^= (f >> 4) & 0x0f0f_0f0f;
    f ^= (f >> 8) & 0x00ff_00ff;
    f ^ (f >> 16)
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
    fn skipping_dimensions_reads_what_the_draws_would_have_left() {
        for sampler in [Sampler::Sobol, Sampler::Independent] {
            for n in 0..6u64 {
                let (mut drawn, mut skipped) = (sampler.stream(9, 5, 1), sampler.stream(9, 5, 1));
                for _ in 0..n {
                    drawn.next_1d();
                }
                skipped.skip(n);
                assert_eq!(skipped.dimension(), drawn.dimension());
                // Across the low-discrepancy dimensions' end, 1-D and 2-D draws alike.
                for _ in 0..12 {
                    assert_eq!(skipped.next_1d().to_bits(), drawn.next_1d().to_bits(), "{sampler:?}, n {n}");
                    assert_eq!(skipped.next_2d(), drawn.next_2d(), "{sampler:?}, n {n}");
                }
            }
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

    /// Sobol's second dimension by its definition: the xor of the direction numbers of the
    /// index's set bits.
    fn sobol_second_by_bits(index: u32) -> u32 {
        let (mut x, mut v) = (0u32, 1u32 << 31);
        for bit in 0..32 {
            if index >> bit & 1 == 1 {
                x ^= v;
            }
            v ^= v >> 1;
        }
        x
    }

    #[test]
    fn the_taylor_shift_is_sobols_second_dimension_reversed() {
        let mut h = 1u64;
        for k in 0..20_000u32 {
            h = mix64(h);
            let i = if k < 4096 { k } else { h as u32 };
            assert_eq!(sobol_second_of_reversed(i), sobol_second_by_bits(i).reverse_bits(), "i = {i:#x}");
        }
        // Both maps are linear over GF(2): equal on every basis vector, equal everywhere.
        for b in 0..32 {
            assert_eq!(sobol_second_of_reversed(1 << b), sobol_second_by_bits(1 << b).reverse_bits());
        }
        // The unscrambled sequence's first points (index order): 0, 1/2, 3/4, 1/4, 5/8.
        let first: Vec<u32> = (0..5).map(|i| sobol_second_by_bits(i) >> 29).collect();
        assert_eq!(first, [0, 4, 6, 2, 5]);
    }

    /// Cells of the `2^a × 2^b` grid each point of `points` falls in, as counts.
    fn cell_counts(points: &[(f32, f32)], a: u32, b: u32) -> Vec<u32> {
        let (nx, ny) = (1usize << a, 1usize << b);
        let mut cells = vec![0u32; nx * ny];
        for &(x, y) in points {
            assert!((0.0..1.0).contains(&x) && (0.0..1.0).contains(&y), "({x}, {y})");
            cells[(y * ny as f32) as usize * nx + (x * nx as f32) as usize] += 1;
        }
        cells
    }

    #[test]
    fn a_pixels_first_2_to_the_m_samples_are_a_02_net_in_every_low_dimension() {
        for (pixel, seed) in [(0u64, 0u64), (17, 3), (123_456, 99)] {
            for d in [0u64, 2, 5, 9, 14] {
                let draw = |s: u64| {
                    let v = SampleStream::sobol(pixel, s, seed).at_dimension(d).next_2d();
                    (v.x, v.y)
                };
                for m in 1..=8u32 {
                    let points: Vec<(f32, f32)> = (0..1u64 << m).map(draw).collect();
                    // Every elementary interval of area 2^-m holds exactly one point.
                    for a in 0..=m {
                        let cells = cell_counts(&points, a, m - a);
                        assert!(cells.iter().all(|&c| c == 1), "pixel {pixel} dim {d} m {m} grid 2^{a}x2^{}", m - a);
                    }
                    // And in 1-D draws, one point in each interval of length 2^-m.
                    let mut seen = vec![false; 1 << m];
                    for s in 0..1u64 << m {
                        let u = SampleStream::sobol(pixel, s, seed).at_dimension(d).next_1d();
                        let cell = (u * (1u32 << m) as f32) as usize;
                        assert!(!seen[cell], "pixel {pixel} dim {d} m {m}: two 1-D points in interval {cell}");
                        seen[cell] = true;
                    }
                }
            }
        }
    }

    #[test]
    fn different_draws_of_a_pixel_are_not_correlated() {
        // Padded Sobol without the index shuffle would give every draw the same points in the
        // same order (a correlation of 1 between draws after a scramble's monotone parts).
        let n = 1024u64;
        for (d1, d2) in [(0u64, 2u64), (2, 3), (5, 11), (0, 14)] {
            let pairs: Vec<(f32, f32)> = (0..n)
                .map(|s| {
                    let mut st = SampleStream::sobol(7, s, 1).at_dimension(d1);
                    let a = st.next_1d();
                    (a, SampleStream::sobol(7, s, 1).at_dimension(d2).next_1d())
                })
                .collect();
            let mean = |f: &dyn Fn(&(f32, f32)) -> f64| pairs.iter().map(f).sum::<f64>() / n as f64;
            let (mx, my) = (mean(&|p| f64::from(p.0)), mean(&|p| f64::from(p.1)));
            let cov = mean(&|p| (f64::from(p.0) - mx) * (f64::from(p.1) - my));
            let r = cov / (1.0 / 12.0);
            assert!(r.abs() < 0.12, "dims {d1} and {d2}: correlation {r}");
            // The pairs spread over the square: most of a 16 × 16 grid's cells are met (a
            // random pairing of two stratified sets meets ~98 %).
            let met = cell_counts(&pairs, 4, 4).iter().filter(|&&c| c > 0).count();
            assert!(met > 230, "dims {d1} and {d2}: {met} of 256 cells");
        }
    }

    #[test]
    fn pixels_are_independent_and_later_dimensions_are_the_independent_streams() {
        // Sample 0 of many pixels: uniform, as independent draws are.
        let mut buckets = [0u32; 10];
        for pixel in 0..50_000u64 {
            let u = SampleStream::sobol(pixel, 0, 5).at_dimension(3).next_1d();
            buckets[(u * 10.0) as usize] += 1;
        }
        for b in buckets {
            assert!((f64::from(b) - 5_000.0).abs() < 350.0, "{buckets:?}");
        }
        for d in SOBOL_DIMENSIONS..SOBOL_DIMENSIONS + 8 {
            let a = SampleStream::sobol(11, 6, 2).at_dimension(d).next_2d();
            let b = SampleStream::new(11, 6, 2).at_dimension(d).next_2d();
            assert_eq!(a, b, "dimension {d}");
        }
        // The seed changes the scrambles.
        let a = SampleStream::sobol(11, 6, 2).next_2d();
        let b = SampleStream::sobol(11, 6, 3).next_2d();
        assert_ne!(a, b);
        assert_eq!(Sampler::Independent.stream(4, 5, 6).next_1d(), SampleStream::new(4, 5, 6).next_1d());
        assert_eq!(Sampler::Sobol.stream(4, 5, 6).next_1d(), SampleStream::sobol(4, 5, 6).next_1d());
    }
}
