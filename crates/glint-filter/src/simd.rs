//! The crate's only `unsafe`: AVX2 + FMA builds of the kernels, entered after runtime
//! detection, the AVX2 horizontal box sum, and the prefetch hint A-Trous gives.
//!
//! A kernel is written once, generic over [`Kernels`], as an `#[inline(always)]` function in
//! its module. [`Portable`] runs it as compiled for the baseline; an [`Avx2`] value — which only
//! [`Avx2::detect`] creates, after `is_x86_feature_detected!("avx2")` — runs it inside a
//! `#[target_feature(enable = "avx2")]` wrapper here, so the same source is compiled a second
//! time with 8-wide registers. Holding an `Avx2` is the proof every `unsafe` block below relies
//! on. The guided filter is bit-identical between the two (it never calls [`Kernels::mul_add`],
//! and the AVX2 box sum performs the portable one's additions in the same order); the weighted
//! filters fuse multiply-adds with FMA and agree with the portable build to float rounding
//! (both tested). An [`Avx512`] value (AVX-512 F and VL on top of AVX2 and FMA) runs A-Trous
//! with 16 lanes (`Wide<16>`) in an `avx512f,avx512vl` wrapper: the same operations lane for
//! lane, so the AVX2 build's bits (tested); its other kernels are the AVX2 ones.
#![allow(unsafe_code)]

use crate::Isa;
use crate::lanes::{Chunk, LANES, Wide};

/// The operations whose implementation differs per instruction set.
pub(crate) trait Kernels: Copy + Send + Sync {
    /// `a · b + c`: two roundings portably, one (a fused multiply-add) with AVX2 + FMA.
    fn mul_add<const N: usize>(self, a: Wide<N>, b: Wide<N>, c: Wide<N>) -> Wide<N>;

    /// `2^−s` for `s >= 0`, see [`Wide::exp2_neg`]; its polynomial uses [`Kernels::mul_add`].
    #[inline(always)]
    fn exp2_neg<const N: usize>(self, s: Wide<N>) -> Wide<N> {
        s.exp2_neg(|a, b, c| self.mul_add(a, b, c))
    }

    /// `2^−s`, 0 from s = 40 on: see [`Wide::exp2_neg_or_zero`].
    #[inline(always)]
    fn exp2_neg_or_zero<const N: usize>(self, s: Wide<N>) -> Wide<N> {
        s.exp2_neg_or_zero(|a, b, c| self.mul_add(a, b, c))
    }

    /// A hint to bring the cache line holding `p` into L1; `p` may point anywhere.
    #[inline(always)]
    fn prefetch<T>(self, _p: *const T) {}
}

/// The guided filter's horizontal box sum, per instruction set (the weighted filters do not
/// use it, so a proof type without its own, like [`Avx512`], need not have one).
pub(crate) trait BoxSum: Kernels {
    /// See [`crate::boxsum::hbox_portable`].
    #[allow(clippy::too_many_arguments)]
    fn hbox(
        self,
        src: &[Chunk],
        s8: usize,
        n: usize,
        dst: &mut [Chunk],
        stride: usize,
        range: (usize, usize),
        r: usize,
    );
}

/// Baseline code.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Portable;

impl BoxSum for Portable {
    #[inline(always)]
    fn hbox(
        self,
        src: &[Chunk],
        s8: usize,
        n: usize,
        dst: &mut [Chunk],
        stride: usize,
        range: (usize, usize),
        r: usize,
    ) {
        crate::boxsum::hbox_portable(src, s8, n, dst, stride, range, r);
    }
}

impl Kernels for Portable {
    #[inline(always)]
    fn mul_add<const N: usize>(self, a: Wide<N>, b: Wide<N>, c: Wide<N>) -> Wide<N> {
        a * b + c
    }
}

/// Proof that this CPU runs AVX2 and FMA (only [`Avx2::detect`] makes one).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx2 {
    _proof: (),
}

impl Avx2 {
    /// `Some` when the CPU has AVX2.
    pub(crate) fn detect() -> Option<Avx2> {
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma") {
            return Some(Avx2 { _proof: () });
        }
        None
    }

    /// `Some` when `isa` asks for AVX2 (or AVX-512, whose kernels without a 16-lane form run
    /// their AVX2 build) and the CPU has it.
    pub(crate) fn wanted(isa: Isa) -> Option<Avx2> {
        if matches!(isa, Isa::Avx2 | Isa::Avx512) { Avx2::detect() } else { None }
    }
}

impl BoxSum for Avx2 {
    #[inline(always)]
    fn hbox(
        self,
        src: &[Chunk],
        s8: usize,
        n: usize,
        dst: &mut [Chunk],
        stride: usize,
        range: (usize, usize),
        r: usize,
    ) {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `self` exists only if the CPU reported AVX2 (and FMA).
        unsafe {
            x86::hbox(src, s8, n, dst, stride, range, r)
        }
        #[cfg(not(target_arch = "x86_64"))]
        crate::boxsum::hbox_portable(src, s8, n, dst, stride, range, r);
    }
}

impl Kernels for Avx2 {
    #[inline(always)]
    fn mul_add<const N: usize>(self, a: Wide<N>, b: Wide<N>, c: Wide<N>) -> Wide<N> {
        fused(a, b, c)
    }

    #[inline(always)]
    fn prefetch<T>(self, p: *const T) {
        prefetch_t0(p);
    }
}

/// `prefetcht0` of the line holding `p` (what [`Kernels::prefetch`] does where the CPU was
/// detected: SSE has it, so any x86-64).
#[inline(always)]
fn prefetch_t0<T>(p: *const T) {
    #[cfg(target_arch = "x86_64")]
    // SAFETY: a prefetch is a hint: it reads no memory the program sees and never faults,
    // whatever the address.
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.cast())
    };
    #[cfg(not(target_arch = "x86_64"))]
    let _ = p;
}

/// `a · b + c` rounded once, lane by lane: inside the `fma` wrappers one vfmadd per register,
/// no libm call.
#[inline(always)]
fn fused<const N: usize>(a: Wide<N>, b: Wide<N>, c: Wide<N>) -> Wide<N> {
    let mut r = c.0;
    for i in 0..N {
        r[i] = a.0[i].mul_add(b.0[i], c.0[i]);
    }
    Wide(r)
}

/// Proof that this CPU runs AVX-512 (F and VL) besides AVX2 and FMA (only
/// [`Avx512::detect`] makes one). Kernels with a 16-lane form (A-Trous) run it in an
/// `avx512f` wrapper; the operations are the AVX2 build's, lane for lane, so the results are
/// the same bits.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Avx512 {
    _proof: (),
}

impl Avx512 {
    /// `Some` when the CPU has AVX-512 F and VL, AVX2 and FMA.
    pub(crate) fn detect() -> Option<Avx512> {
        #[cfg(target_arch = "x86_64")]
        if Avx2::detect().is_some()
            && std::arch::is_x86_feature_detected!("avx512f")
            && std::arch::is_x86_feature_detected!("avx512vl")
        {
            return Some(Avx512 { _proof: () });
        }
        None
    }

    /// `Some` when `isa` asks for AVX-512 and the CPU has it.
    pub(crate) fn wanted(isa: Isa) -> Option<Avx512> {
        if isa == Isa::Avx512 { Avx512::detect() } else { None }
    }
}

impl Kernels for Avx512 {
    #[inline(always)]
    fn mul_add<const N: usize>(self, a: Wide<N>, b: Wide<N>, c: Wide<N>) -> Wide<N> {
        fused(a, b, c)
    }

    #[inline(always)]
    fn prefetch<T>(self, p: *const T) {
        prefetch_t0(p);
    }
}

/// Runs `$kernel(k, $args...)` with `k` = the AVX2 proof inside an AVX2-compiled wrapper, or with
/// `Portable` as compiled for the baseline.
macro_rules! avx2_entry {
    ($(#[$doc:meta])* $name:ident $(<$(const $c:ident: $ct:ty),*>)? => $kernel:path, ($($arg:ident: $ty:ty),*)) => {
        $(#[$doc])*
        pub(crate) fn $name$(<$(const $c: $ct),*>)?(isa: Isa, $($arg: $ty),*) {
            #[cfg(target_arch = "x86_64")]
            if let Some(k) = Avx2::wanted(isa) {
                #[target_feature(enable = "avx2,fma")]
                fn avx2$(<$(const $c: $ct),*>)?(k: Avx2, $($arg: $ty),*) {
                    $kernel(k, $($arg),*)
                }
                // SAFETY: `k` exists only if the CPU reported AVX2 and FMA.
                return unsafe { avx2$(::<$($c),*>)?(k, $($arg),*) };
            }
            $kernel(Portable, $($arg),*)
        }
    };
}

avx2_entry!(
    /// One strip of the guided filter ([`crate::guided::strip`]).
    guided_strip<const D: usize> => crate::guided::strip::<D, _>, (job: crate::guided::StripJob<'_>)
);
avx2_entry!(
    /// A band of rows of the cross-bilateral filter ([`crate::bilateral::band`]).
    bilateral_band => crate::bilateral::band, (job: crate::bilateral::BandJob<'_>)
);
/// The lanes per vector that [`atrous_band`] runs with for `isa` on this CPU: the width its
/// planes must be laid out for ([`crate::padded::Padded::zeros_for`]).
pub(crate) fn atrous_lanes(isa: Isa) -> usize {
    if Avx512::wanted(isa).is_some() { 16 } else { LANES }
}

/// A band of rows of one À-Trous iteration ([`crate::atrous::band`]): 16 lanes with AVX-512,
/// else 8 with AVX2 or portably (planes laid out for [`atrous_lanes`]).
pub(crate) fn atrous_band(isa: Isa, job: crate::atrous::BandJob<'_>) {
    #[cfg(target_arch = "x86_64")]
    if let Some(k) = Avx512::wanted(isa) {
        #[target_feature(enable = "avx2,fma,avx512f,avx512vl")]
        fn avx512(k: Avx512, job: crate::atrous::BandJob<'_>) {
            crate::atrous::band::<_, 16>(k, job)
        }
        // SAFETY: `k` exists only if the CPU reported AVX-512 F and VL, AVX2 and FMA.
        return unsafe { avx512(k, job) };
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(k) = Avx2::wanted(isa) {
        #[target_feature(enable = "avx2,fma")]
        fn avx2(k: Avx2, job: crate::atrous::BandJob<'_>) {
            crate::atrous::band::<_, LANES>(k, job)
        }
        // SAFETY: `k` exists only if the CPU reported AVX2 and FMA.
        return unsafe { avx2(k, job) };
    }
    crate::atrous::band::<_, LANES>(Portable, job)
}

#[cfg(target_arch = "x86_64")]
mod x86 {
    use std::arch::x86_64::*;

    use crate::boxsum::{BLOCK, check_hbox, pad};
    use crate::lanes::{Chunk, LANES};

    /// [`window_sum`] with AVX2 loads (same additions, same order).
    #[target_feature(enable = "avx2")]
    fn window_sum_avx2(s: &[f32]) -> f32 {
        let (whole, tail) = s.as_chunks::<LANES>();
        let mut acc = _mm256_setzero_ps();
        for c in whole {
            // SAFETY: `c` is 8 readable floats.
            acc = _mm256_add_ps(acc, unsafe { _mm256_loadu_ps(c.as_ptr()) });
        }
        let mut t = 0.0;
        for v in tail {
            t += v;
        }
        let mut a = [0.0f32; LANES];
        // SAFETY: `a` is 8 writable floats.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), acc) };
        (((a[0] + a[1]) + (a[2] + a[3])) + ((a[4] + a[5]) + (a[6] + a[7]))) + t
    }

    /// AVX2 twin of [`crate::boxsum::hbox_portable`] (same contract, same bits): the first row
    /// of each pair in the low 128-bit half of each register, the second in the high half.
    #[target_feature(enable = "avx2")]
    pub(super) fn hbox(
        src: &[Chunk],
        s8: usize,
        n: usize,
        dst: &mut [Chunk],
        stride: usize,
        (i0, i1): (usize, usize),
        r: usize,
    ) {
        let (lo, hi) = (pad(r) - r - 1, pad(r) + r);
        check_hbox(src.len(), s8, n, dst.len(), stride, (i0, i1), r);
        for q in (0..n).step_by(2) {
            let pair = [q, (q + 1).min(n - 1)];
            let rows = [
                src[pair[0] * s8..(pair[0] + 1) * s8].as_flattened(),
                src[pair[1] * s8..(pair[1] + 1) * s8].as_flattened(),
            ];
            let [a, b] = [rows[0].as_ptr(), rows[1].as_ptr()];
            for start in (i0..i1).step_by(BLOCK) {
                let window = lo + start * LANES..hi + start * LANES;
                let c = [window_sum_avx2(&rows[0][window.clone()]), window_sum_avx2(&rows[1][window])];
                let mut carry = _mm256_setr_ps(c[0], c[0], c[0], c[0], c[1], c[1], c[1], c[1]);
                for i in start..i1.min(start + BLOCK) {
                    let base = (i - i0) * stride;
                    // pair[k] < n <= stride and (i − i0 + 1)·stride <= dst.len() (check_hbox).
                    let out = [dst[base + pair[0]].as_mut_ptr(), dst[base + pair[1]].as_mut_ptr()];
                    for half in 0..2 {
                        let x = i * LANES + half * 4;
                        // SAFETY: x + 4 <= 8·i1 and lo < hi, so hi + x + 4 <= pad(r) + r + 8·i1 <=
                        // 8·s8 = rows[k].len() (check_hbox): all four loads stay inside the rows.
                        let (up, down) = unsafe {
                            let up = _mm256_set_m128(_mm_loadu_ps(b.add(hi + x)), _mm_loadu_ps(a.add(hi + x)));
                            let down = _mm256_set_m128(_mm_loadu_ps(b.add(lo + x)), _mm_loadu_ps(a.add(lo + x)));
                            (up, down)
                        };
                        let d = _mm256_sub_ps(up, down);
                        let s = _mm256_add_ps(d, _mm256_castsi256_ps(_mm256_slli_si256::<4>(_mm256_castps_si256(d))));
                        let s = _mm256_add_ps(s, _mm256_castsi256_ps(_mm256_slli_si256::<8>(_mm256_castps_si256(s))));
                        let h = _mm256_add_ps(s, carry);
                        // SAFETY: out[k] points at a whole chunk of dst; half·4 + 4 <= 8.
                        unsafe {
                            _mm_storeu_ps(out[0].add(half * 4), _mm256_castps256_ps128(h));
                            _mm_storeu_ps(out[1].add(half * 4), _mm256_extractf128_ps::<1>(h));
                        }
                        carry = _mm256_add_ps(carry, _mm256_shuffle_ps::<0xFF>(s, s));
                    }
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_prefetch_of_any_address_reads_and_faults_nothing() {
        // The A-Trous band prefetches past its rows' ends; no address may fault or change
        // what memory holds.
        let v = [1.0f32, 2.0, 3.0];
        let addresses = [std::ptr::null(), v.as_ptr().wrapping_add(1 << 40), usize::MAX as *const f32, v.as_ptr()];
        for p in addresses {
            Portable.prefetch(p);
            if let Some(k) = Avx2::detect() {
                k.prefetch(p);
            }
            if let Some(k) = Avx512::detect() {
                k.prefetch(p);
            }
        }
        assert_eq!(v, [1.0, 2.0, 3.0]);
    }

    #[test]
    fn avx2_box_sum_is_bit_identical_to_portable() {
        let Some(k) = Avx2::detect() else { return };
        let bits = |v: &[[f32; 8]]| v.as_flattened().iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        let mut seed = 12345u32;
        let mut random = move || {
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (seed >> 8) as f32 / (1 << 24) as f32 * 10.0 - 2.0
        };
        for r in [1, 3, 28, 64, 700] {
            let n8 = 125;
            let s8 = (crate::boxsum::pad(r) + crate::boxsum::tail_pad(r)) / 8 + n8;
            let p8 = crate::boxsum::pad(r) / 8;
            // Three padded rows of random values.
            let mut src = vec![[0.0f32; 8]; 3 * s8];
            for q in 0..3 {
                for i in 0..n8 {
                    src[q * s8 + p8 + i] = std::array::from_fn(|_| random());
                }
            }
            let mut a = vec![[0.0; 8]; n8 * 4];
            let mut b = a.clone();
            Portable.hbox(&src, s8, 3, &mut a, 4, (0, n8), r);
            k.hbox(&src, s8, 3, &mut b, 4, (0, n8), r);
            assert_eq!(bits(&a), bits(&b), "r = {r}");
            // A block range writes relative to its first vector.
            let mut d = vec![[0.0; 8]; 20 * 4];
            k.hbox(&src, s8, 3, &mut d, 4, (16, 36), r);
            assert_eq!(bits(&d), bits(&b[16 * 4..36 * 4]), "r = {r}");
        }
    }
}
