//! Packet traversal of the 8-wide BVH for up to 8 coherent rays (AVX2 + FMA, entered only
//! after runtime detection): Wald, Slusallek, Benthin, Wagner, "Interactive Rendering with
//! Coherent Ray Tracing", EG 2001, in the 8-wide form of Embree's packet kernels (Wald et al.,
//! "Embree: A Kernel Framework for Efficient CPU Ray Tracing", SIGGRAPH 2014, section 4): the
//! packet walks the tree once with a mask of active rays, and each child box is tested against
//! all 8 rays with one SIMD operation per slab (the rays, not the children, fill the lanes).
//!
//! Exactness: per lane the box test is the single-ray test (`traverse::node_test`) operation
//! for operation, the leaves run the single-ray leaf test (`avx2::leaf_closest` /
//! `leaf_any`) per active ray, or, when the rays outnumber the leaf's triangles ([`lane_leaf`]),
//! each triangle against the rays in lanes with the same operations (`frustum::LeafLanes`),
//! children are culled per ray against that ray's own `tmax`,
//! and equally near hits are resolved by the lowest primitive index ([`super::walk::closer`]), so
//! the result does not depend on the visiting order: `out[i]` equals the single-ray kernel's
//! answer for `rays[i]`. Rays are grouped by direction octant (the near/far planes are picked
//! per octant, as in the single-ray kernel); a group of one ray, and a group whose directions
//! spread wider than a cone ([`coherent`]), takes the single-ray kernel ray by ray, except in
//! a tree of one node ([`WideBvh::packs_any_rays`]): there every packet walks the same root and
//! then the leaves its rays' boxes meet, so incoherent rays lose nothing by walking together,
//! and a leaf met by enough of them tests its triangles against the rays in lanes (diffuse
//! bounce rays of Mitsuba's Cornell box, 38 triangles, binned by octant and dominant axis as
//! the path tracer's wavefront bins them: 16.9 → 20.7 M rays/s on one thread).

use super::dispatch::{Any, Closest};
use super::frustum::{Best8, Frustum, LeafLanes, closest_frustum};
use super::sse::TriRay4;
use super::walk::order_children;
use super::{EMPTY_SLOT, LEAF, Stack, WideBvh, avx2, leaf_packets};
use crate::Hit;
use crate::bvh2::FAR_SCALE;
use glint_core::Ray;
use std::arch::x86_64::*;

// SAFETY (every `unsafe` block in this file): the `#[target_feature(enable = "avx2,fma")]`
// functions are only called from `intersect8` / `occluded8` after `Isa::detect()` found AVX2
// and FMA; unaligned loads and stores touch `[f32; 8]` arrays, exactly 32 bytes.

/// The 8 rays in lanes: `f[k]` holds field `k` of every ray (origin x, y, z, direction x, y,
/// z, tmin, tmax): one 8 × 8 transpose of the rays as stored (`Ray` is `#[repr(C)]`, 8 floats).
struct RayLanes {
    f: [__m256; 8],
}

const _: () = assert!(size_of::<Ray>() == 32 && align_of::<Ray>() == 4);

impl RayLanes {
    #[inline(always)]
    fn new(rays: &[Ray; 8]) -> Self {
        // SAFETY: AVX only; inlined into the `avx2,fma` entry points below (see the top of the
        // file). Each load reads one `Ray`: 32 bytes of 8 f32 fields (`#[repr(C)]`, asserted
        // above); `loadu` needs no alignment.
        unsafe {
            // (Loops and arrays, no closures: a closure here would not inherit the AVX features.)
            let mut r = [_mm256_setzero_ps(); 8];
            for (v, ray) in r.iter_mut().zip(rays) {
                *v = _mm256_loadu_ps((&raw const *ray).cast::<f32>());
            }
            let t = [
                _mm256_unpacklo_ps(r[0], r[1]),
                _mm256_unpackhi_ps(r[0], r[1]),
                _mm256_unpacklo_ps(r[2], r[3]),
                _mm256_unpackhi_ps(r[2], r[3]),
                _mm256_unpacklo_ps(r[4], r[5]),
                _mm256_unpackhi_ps(r[4], r[5]),
                _mm256_unpacklo_ps(r[6], r[7]),
                _mm256_unpackhi_ps(r[6], r[7]),
            ];
            let u = [
                _mm256_shuffle_ps::<0x44>(t[0], t[2]),
                _mm256_shuffle_ps::<0xee>(t[0], t[2]),
                _mm256_shuffle_ps::<0x44>(t[1], t[3]),
                _mm256_shuffle_ps::<0xee>(t[1], t[3]),
                _mm256_shuffle_ps::<0x44>(t[4], t[6]),
                _mm256_shuffle_ps::<0xee>(t[4], t[6]),
                _mm256_shuffle_ps::<0x44>(t[5], t[7]),
                _mm256_shuffle_ps::<0xee>(t[5], t[7]),
            ];
            Self {
                f: [
                    _mm256_permute2f128_ps::<0x20>(u[0], u[4]),
                    _mm256_permute2f128_ps::<0x20>(u[1], u[5]),
                    _mm256_permute2f128_ps::<0x20>(u[2], u[6]),
                    _mm256_permute2f128_ps::<0x20>(u[3], u[7]),
                    _mm256_permute2f128_ps::<0x31>(u[0], u[4]),
                    _mm256_permute2f128_ps::<0x31>(u[1], u[5]),
                    _mm256_permute2f128_ps::<0x31>(u[2], u[6]),
                    _mm256_permute2f128_ps::<0x31>(u[3], u[7]),
                ],
            }
        }
    }

    /// The lanes whose ray can be traced (`bvh2::ray_is_traceable`, lane by lane): finite
    /// origin and direction, a non-zero direction, `tmin <= tmax` (false for NaN).
    #[inline(always)]
    fn traceable(&self) -> u32 {
        // SAFETY: AVX only; inlined into the `avx2,fma` entry points (see the top of the file).
        unsafe {
            let inf = _mm256_set1_ps(f32::INFINITY);
            let sign = _mm256_set1_ps(-0.0);
            let mut ok = _mm256_cmp_ps::<_CMP_LE_OQ>(self.f[6], self.f[7]);
            for k in 0..6 {
                ok = _mm256_and_ps(ok, _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_andnot_ps(sign, self.f[k]), inf));
            }
            let zero = _mm256_setzero_ps();
            let nonzero = _mm256_or_ps(
                _mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_NEQ_OQ>(self.f[3], zero),
                    _mm256_cmp_ps::<_CMP_NEQ_OQ>(self.f[4], zero),
                ),
                _mm256_cmp_ps::<_CMP_NEQ_OQ>(self.f[5], zero),
            );
            _mm256_movemask_ps(_mm256_and_ps(ok, nonzero)) as u32
        }
    }

    /// Sign bits of the direction's axes, lane by lane.
    #[inline(always)]
    fn signs(&self) -> [u32; 3] {
        // SAFETY: AVX only; inlined into the `avx2,fma` entry points (see the top of the file).
        unsafe {
            [
                _mm256_movemask_ps(self.f[3]) as u32,
                _mm256_movemask_ps(self.f[4]) as u32,
                _mm256_movemask_ps(self.f[5]) as u32,
            ]
        }
    }

    /// Whether every direction of `group` is within `acos(COHERENT_COS)` of its first ray's
    /// (no square root: compared squared, with the sign of the dot product checked first).
    #[inline(always)]
    fn coherent(&self, group: u32) -> bool {
        // SAFETY: AVX2 only; inlined into the `avx2,fma` entry points (see the top of the file).
        unsafe {
            let first = _mm256_set1_epi32(group.trailing_zeros() as i32);
            let (dx, dy, dz) = (self.f[3], self.f[4], self.f[5]);
            let d0 = [
                _mm256_permutevar8x32_ps(dx, first),
                _mm256_permutevar8x32_ps(dy, first),
                _mm256_permutevar8x32_ps(dz, first),
            ];
            let dot = _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(dx, d0[0]), _mm256_mul_ps(dy, d0[1])),
                _mm256_mul_ps(dz, d0[2]),
            );
            let len = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz));
            let len0 = _mm256_permutevar8x32_ps(len, first);
            let bound = _mm256_mul_ps(_mm256_mul_ps(len0, _mm256_set1_ps(COHERENT_COS * COHERENT_COS)), len);
            let ok = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_GE_OQ>(dot, _mm256_setzero_ps()),
                _mm256_cmp_ps::<_CMP_GE_OQ>(_mm256_mul_ps(dot, dot), bound),
            );
            _mm256_movemask_ps(ok) as u32 & group == group
        }
    }
}

/// Splits the traceable rays into groups of one direction octant (bit `a` of the octant set
/// where axis `a` of the direction has its sign bit set); calls `f(group mask, octant)`.
#[inline(always)]
fn for_each_octant(lanes: &RayLanes, mut f: impl FnMut(u32, u32)) {
    let mut todo = lanes.traceable();
    let signs = lanes.signs();
    while todo != 0 {
        let i = todo.trailing_zeros();
        let mut group = todo;
        let mut oct = 0;
        for (a, &s) in signs.iter().enumerate() {
            let neg = s >> i & 1;
            group &= if neg == 1 { s } else { !s };
            oct |= neg << a;
        }
        todo &= !group;
        f(group, oct);
    }
}

/// Cosine of the widest angle between the directions of a packet worth walking together (the
/// first ray's and any other's). Incoherent packets (diffuse bounces, rays toward random points
/// of an area light or the sky) share few nodes: walking them as a packet costs more than one
/// single-ray walk each (Sponza path frame: 938 → 839 ms with 0.9, 900 with 0.5; BENCHMARKS
/// §1.1), while primary rays of a pixel tile, shadow rays toward one point or parallel light and
/// mirror reflections of those stay packets.
const COHERENT_COS: f32 = 0.9;

/// Closest hits; `bvh` is non-empty and AVX2 + FMA were detected.
pub(super) fn intersect8(bvh: &WideBvh<8>, rays: &[Ray; 8], out: &mut [Option<Hit>; 8]) {
    // SAFETY: AVX2 and FMA detected by the caller (see the top of the file).
    unsafe { intersect8_avx(bvh, rays, out) }
}

#[target_feature(enable = "avx2,fma")]
fn intersect8_avx(bvh: &WideBvh<8>, rays: &[Ray; 8], out: &mut [Option<Hit>; 8]) {
    *out = [None; 8];
    let lanes = RayLanes::new(rays);
    let any = bvh.packs_any_rays();
    for_each_octant(&lanes, |group, oct| {
        if group & (group - 1) == 0 || !(any || lanes.coherent(group)) {
            for i in Lanes(group) {
                out[i] = avx2::run8::<Closest>(bvh, &rays[i]);
            }
        } else {
            closest_packet(bvh, rays, group, oct, out);
        }
    });
}

/// Any hits; `bvh` is non-empty and AVX2 + FMA were detected.
pub(super) fn occluded8(bvh: &WideBvh<8>, rays: &[Ray; 8], out: &mut [bool; 8]) {
    // SAFETY: AVX2 and FMA detected by the caller (see the top of the file).
    unsafe { occluded8_avx(bvh, rays, out) }
}

#[target_feature(enable = "avx2,fma")]
fn occluded8_avx(bvh: &WideBvh<8>, rays: &[Ray; 8], out: &mut [bool; 8]) {
    *out = [false; 8];
    let lanes = RayLanes::new(rays);
    let any = bvh.packs_any_rays();
    for_each_octant(&lanes, |group, oct| {
        if group & (group - 1) == 0 || !(any || lanes.coherent(group)) {
            for i in Lanes(group) {
                out[i] = avx2::run8::<Any>(bvh, &rays[i]);
            }
        } else {
            let done = any_packet(bvh, rays, group, oct);
            for (i, o) in out.iter_mut().enumerate() {
                *o |= done >> i & 1 != 0;
            }
        }
    });
}

/// The packet's per-lane box-test constants; lanes outside the group get `tmax = -inf`, which
/// fails every box test.
pub(super) struct PacketRay {
    pub(super) org: [__m256; 3],
    pub(super) inv: [__m256; 3],
    /// `inv · FAR_SCALE`, the far planes' reciprocals (`bvh2::BoxRay::inv_far`).
    pub(super) inv_far: [__m256; 3],
    pub(super) tmin: __m256,
    /// Per axis: index into `WideNode::bounds` of the near and the far plane.
    pub(super) near: [usize; 3],
    pub(super) far: [usize; 3],
    pub(super) tmax: [f32; 8],
}

impl PacketRay {
    #[inline(always)]
    fn new(rays: &[Ray; 8], group: u32, oct: u32) -> Self {
        let mut org = [[0.0f32; 8]; 3];
        let mut dir = [[1.0f32; 8]; 3];
        let mut tmin = [0.0f32; 8];
        let mut tmax = [f32::NEG_INFINITY; 8];
        for (i, r) in rays.iter().enumerate() {
            if group >> i & 1 == 0 {
                continue;
            }
            for a in 0..3 {
                org[a][i] = r.origin[a];
                dir[a][i] = r.dir[a];
            }
            tmin[i] = r.tmin;
            tmax[i] = r.tmax;
        }
        let neg = |a: usize| (oct >> a & 1) as usize;
        // Exact (IEEE, correctly rounded) reciprocal, as in the single-ray kernel (Ize 2013):
        // bit-identical to its scalar `1 / d`.
        // SAFETY: AVX only; inlined into the `avx2,fma` kernels (see the top of the file).
        let inv = dir.map(|d| unsafe { _mm256_div_ps(_mm256_set1_ps(1.0), load(&d)) });
        // SAFETY: as above.
        let inv_far = inv.map(|i| unsafe { _mm256_mul_ps(i, _mm256_set1_ps(FAR_SCALE)) });
        Self {
            org: org.map(|v| load(&v)),
            inv,
            inv_far,
            tmin: load(&tmin),
            near: [neg(0), 2 + neg(1), 4 + neg(2)],
            far: [1 - neg(0), 3 - neg(1), 5 - neg(2)],
            tmax,
        }
    }
}

#[inline(always)]
pub(super) fn load(a: &[f32; 8]) -> __m256 {
    // SAFETY: 32 readable bytes, `loadu` needs no alignment; AVX detected (top of the file).
    unsafe { _mm256_loadu_ps(a.as_ptr()) }
}

#[inline(always)]
pub(super) fn store(v: __m256) -> [f32; 8] {
    let mut a = [0.0f32; 8];
    // SAFETY: 32 writable bytes, `storeu` needs no alignment; AVX detected (top of the file).
    unsafe { _mm256_storeu_ps(a.as_mut_ptr(), v) };
    a
}

/// Slot `c` of `node` against every lane: hit mask (bit per ray) and entry distances. The same
/// operations, in the same order, as `traverse::node_test` on one lane.
#[inline(always)]
pub(super) fn box8(bounds: &[[f32; 8]; 6], c: usize, r: &PacketRay, tmax: __m256) -> (u32, __m256) {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels below (see the top of the file).
    unsafe {
        let slab =
            |k: usize, o: __m256, inv: __m256| _mm256_mul_ps(_mm256_sub_ps(_mm256_set1_ps(bounds[k][c]), o), inv);
        let near = |a: usize| slab(r.near[a], r.org[a], r.inv[a]);
        let far = |a: usize| slab(r.far[a], r.org[a], r.inv_far[a]);
        let tn = _mm256_max_ps(near(0), _mm256_max_ps(near(1), _mm256_max_ps(near(2), r.tmin)));
        let tf = _mm256_min_ps(far(0), _mm256_min_ps(far(1), _mm256_min_ps(far(2), tmax)));
        (_mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32, tn)
    }
}

/// Smallest entry distance over the lanes of `mask` (the packet's ordering key).
#[inline(always)]
fn masked_min(tn: __m256, mask: u32) -> f32 {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels below (see the top of the file).
    lane_min(unsafe { _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), tn, lane_mask(mask)) })
}

/// All ones in the lanes whose bit is set in `mask`, zeros elsewhere.
#[inline(always)]
pub(super) fn lane_mask(mask: u32) -> __m256 {
    // SAFETY: AVX2 only; inlined into the `avx2,fma` kernels (see the top of the file).
    unsafe {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32(mask as i32), bits), bits))
    }
}

/// The smallest lane.
#[inline(always)]
pub(super) fn lane_min(v: __m256) -> f32 {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels (see the top of the file).
    unsafe {
        let x = _mm256_min_ps(v, _mm256_permute2f128_ps::<1>(v, v));
        let x = _mm256_min_ps(x, _mm256_shuffle_ps::<0b0100_1110>(x, x));
        let x = _mm256_min_ps(x, _mm256_shuffle_ps::<0b1011_0001>(x, x));
        _mm256_cvtss_f32(x)
    }
}

/// The largest lane.
#[inline(always)]
pub(super) fn lane_max(v: __m256) -> f32 {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels (see the top of the file).
    unsafe {
        let x = _mm256_max_ps(v, _mm256_permute2f128_ps::<1>(v, v));
        let x = _mm256_max_ps(x, _mm256_shuffle_ps::<0b0100_1110>(x, x));
        let x = _mm256_max_ps(x, _mm256_shuffle_ps::<0b1011_0001>(x, x));
        _mm256_cvtss_f32(x)
    }
}

/// The indices of the set bits of a lane mask, lowest first: the rays it holds.
pub(super) struct Lanes(pub(super) u32);

impl Iterator for Lanes {
    type Item = usize;

    #[inline(always)]
    fn next(&mut self) -> Option<usize> {
        if self.0 == 0 {
            return None;
        }
        let i = self.0.trailing_zeros() as usize % 8;
        self.0 &= self.0 - 1;
        Some(i)
    }
}

/// The rays' constants of the triangle packet test, each made on its ray's first leaf: most
/// rays of a packet that misses never get there.
pub(super) struct LeafRays<'a> {
    rays: &'a [Ray; 8],
    tris: [Option<TriRay4>; 8],
}

impl<'a> LeafRays<'a> {
    #[inline(always)]
    pub(super) fn new(rays: &'a [Ray; 8]) -> Self {
        Self { rays, tris: std::array::from_fn(|_| None) }
    }

    #[inline(always)]
    pub(super) fn get(&mut self, i: usize) -> &TriRay4 {
        let ray = &self.rays[i];
        self.tris[i].get_or_insert_with(|| TriRay4::new(ray))
    }
}

/// A stack entry of the closest-hit packet kernel: a child, the rays whose box test passed,
/// and their entry distances (re-checked against each ray's `tmax` when popped).
#[derive(Clone, Copy, Default)]
struct Entry8 {
    child: u32,
    mask: u32,
    tn: [f32; 8],
}

#[target_feature(enable = "avx2,fma")]
fn closest_packet(bvh: &WideBvh<8>, rays: &[Ray; 8], group: u32, oct: u32, out: &mut [Option<Hit>; 8]) {
    let mut pr = PacketRay::new(rays, group, oct);
    if let Some(f) = Frustum::new(&pr, group) {
        return closest_frustum(bvh, &mut pr, &f, rays, group, out);
    }
    let mut leaf_rays = LeafRays::new(rays);
    let mut lanes = None;
    let mut best = Best8::new();
    let mut tmax = load(&pr.tmax);
    let mut stack = Stack::<Entry8>::new();
    let (mut cur, mut active) = (0u32, group);
    'walk: loop {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            let mut met = 0u32;
            let mut near = [0.0f32; 8];
            let mut masks = [0u32; 8];
            let mut tns = [_mm256_setzero_ps(); 8];
            for c in 0..8 {
                if node.child[c] == EMPTY_SLOT {
                    continue;
                }
                let (m, tn) = box8(&node.bounds, c, &pr, tmax);
                let m = m & active;
                if m != 0 {
                    near[c] = masked_min(tn, m);
                    masks[c] = m;
                    tns[c] = tn;
                    met |= 1 << c;
                }
            }
            if met != 0 {
                // The order first, then the pushes: no intrinsic inside the closure.
                let (mut farther, mut n) = ([0usize; 8], 0);
                let c = order_children(met, &near, |c| {
                    farther[n % 8] = c;
                    n += 1;
                });
                for &f in &farther[..n.min(8)] {
                    stack.push(Entry8 { child: node.child[f], mask: masks[f], tn: store(tns[f]) });
                }
                cur = node.child[c];
                active = masks[c];
                continue;
            }
        } else {
            let packets = &bvh.packets[leaf_packets(cur)];
            let in_lanes = lane_leaf(active, packets.len());
            if in_lanes && lanes.is_none() {
                lanes = Some(LeafLanes::new(rays, group));
            }
            match &lanes {
                Some(Some(l)) if in_lanes => {
                    for p in packets {
                        l.closest(p, rays, active, &mut pr.tmax, (&mut best, out));
                    }
                }
                _ => {
                    for i in Lanes(active) {
                        let tr = leaf_rays.get(i);
                        pr.tmax[i] = avx2::leaf_closest(tr, packets, pr.tmax[i], &mut out[i]);
                    }
                }
            }
            tmax = load(&pr.tmax);
        }
        loop {
            let Some(e) = stack.pop() else { break 'walk };
            let m = e.mask & _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(load(&e.tn), tmax)) as u32;
            if m != 0 {
                cur = e.child;
                active = m;
                break;
            }
        }
    }
    best.finish(out);
}

/// Returns the mask of occluded rays of `group`.
#[target_feature(enable = "avx2,fma")]
fn any_packet(bvh: &WideBvh<8>, rays: &[Ray; 8], group: u32, oct: u32) -> u32 {
    let mut pr = PacketRay::new(rays, group, oct);
    let mut leaf_rays = LeafRays::new(rays);
    let mut lanes = None;
    let ray_tmax = pr.tmax;
    let mut tmax = load(&pr.tmax);
    let mut done = 0u32;
    let mut stack = Stack::<(u32, u32)>::new();
    let (mut cur, mut active) = (0u32, group);
    loop {
        if cur & LEAF == 0 {
            let node = &bvh.nodes[cur as usize];
            // Slots from the last, so that the children met are visited in slot order (largest
            // box first, `WideBvh::from_bvh2`): the lowest goes on, the others pop after it in
            // their order.
            let mut first = None;
            for c in (0..8).rev() {
                if node.child[c] == EMPTY_SLOT {
                    continue;
                }
                let m = box8(&node.bounds, c, &pr, tmax).0 & active;
                if m != 0
                    && let Some(later) = first.replace((node.child[c], m))
                {
                    stack.push(later);
                }
            }
            if let Some((c, m)) = first {
                cur = c;
                active = m;
                continue;
            }
        } else {
            let packets = &bvh.packets[leaf_packets(cur)];
            let in_lanes = lane_leaf(active, packets.len());
            if in_lanes && lanes.is_none() {
                lanes = Some(LeafLanes::new(rays, group));
            }
            match &lanes {
                Some(Some(l)) if in_lanes => {
                    let mut hit = 0;
                    for p in packets {
                        hit |= l.any(p, rays, active & !hit, &ray_tmax);
                    }
                    for i in Lanes(hit) {
                        pr.tmax[i] = f32::NEG_INFINITY;
                    }
                    done |= hit;
                }
                _ => {
                    for i in Lanes(active) {
                        let tr = leaf_rays.get(i);
                        if avx2::leaf_any(tr, packets, ray_tmax[i]) {
                            done |= 1 << i;
                            pr.tmax[i] = f32::NEG_INFINITY;
                        }
                    }
                }
            }
            if done == group {
                return done;
            }
            tmax = load(&pr.tmax);
        }
        loop {
            let Some((c, m)) = stack.pop() else { return done };
            if m & !done != 0 {
                cur = c;
                active = m & !done;
                break;
            }
        }
    }
}

/// Whether a leaf of `packets` triangle packets is tested triangle by triangle against the
/// rays of `active` in lanes ([`LeafLanes`], one 8-ray vector per triangle) rather than ray by
/// ray (each ray against a leaf's 8 triangles per vector): when the rays outnumber the
/// triangles' packets twice. Measured (one thread): the Cornell box's shadow rays toward its
/// light 46.3 → 64.2 Mrays/s, Sponza's sun shadows 20.0 / 20.4 → 21.4 / 21.4, the dragon's
/// 12.4 / 12.3 → 12.5 / 12.6 (thresholds of 1 and 3 packets per ray within noise of 2).
#[inline(always)]
fn lane_leaf(active: u32, packets: usize) -> bool {
    active.count_ones() >= 2 * packets as u32
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::procedural::{Mesh, Rng, displaced_sphere, icosphere, triangle_soup};
    use crate::wide::{Bvh8, Isa};
    use crate::{BuildOptions, Bvh2};
    use glint_core::Vec3;
    use proptest::prelude::*;

    fn bits(h: Option<Hit>) -> Option<(u32, u32, u32, u32)> {
        h.map(|h| (h.t.to_bits(), h.prim, h.u.to_bits(), h.v.to_bits()))
    }

    fn bvh8(m: &Mesh, leaf: usize) -> Bvh8 {
        let opts = BuildOptions { max_leaf_size: leaf, ..BuildOptions::default() };
        Bvh8::from_bvh2(&Bvh2::build(&m.positions, &m.triangles, &opts), &m.positions, &m.triangles)
    }

    /// Primary rays of a tiny pinhole camera (16×8 pixels) looking from a random point at
    /// `target`, in 4×2 tiles (pixel order inside a tile), with a wide enough field of view
    /// that many tiles lie half on and half off the mesh. Every few tiles one lane is swapped
    /// for a NaN ray or a ray of another octant, and some tiles have finite `tmax` / `tmin`.
    fn camera_tiles(target: Vec3, dist: f32, seed: u64) -> Vec<[Ray; 8]> {
        let mut rng = Rng::new(seed);
        let origin = target + rng.next_dir() * dist;
        let fwd = (target - origin).normalize();
        let right = fwd.cross(Vec3::Y).try_normalize().unwrap_or(Vec3::X);
        let up = right.cross(fwd);
        let half = 0.2 + rng.next_f32() * 0.8;
        let (w, h) = (16u32, 8u32);
        let mut tiles = Vec::new();
        for ty in (0..h).step_by(2) {
            for tx in (0..w).step_by(4) {
                let k = tiles.len();
                let tile: [Ray; 8] = std::array::from_fn(|i| {
                    let (x, y) = (tx + i as u32 % 4, ty + i as u32 / 4);
                    let u = ((x as f32 + 0.5) / w as f32 * 2.0 - 1.0) * half * 2.0;
                    let v = (1.0 - (y as f32 + 0.5) / h as f32 * 2.0) * half;
                    let dir = fwd + right * u + up * v;
                    match k % 4 {
                        1 => Ray::segment(origin, dir, 0.0, dist * (0.5 + rng.next_f32())),
                        2 => Ray::segment(origin, dir * 3.0, rng.next_f32() * 0.2, f32::INFINITY),
                        _ => Ray::new(origin, dir),
                    }
                });
                let mut tile = tile;
                match k % 5 {
                    0 => tile[(k / 5) % 8] = Ray::new(Vec3::NAN, Vec3::Z),
                    1 => tile[(k / 5) % 8] = Ray::new(origin, rng.next_dir()),
                    2 => tile[(k / 5) % 8].dir = -tile[(k / 5) % 8].dir,
                    _ => {}
                }
                tiles.push(tile);
            }
        }
        tiles
    }

    fn check(bvh: &Bvh8, tiles: &[[Ray; 8]]) {
        let isa = Isa::detect();
        for (k, tile) in tiles.iter().enumerate() {
            let mut hits = [None; 8];
            let mut occ = [false; 8];
            bvh.intersect8_isa(isa, tile, &mut hits);
            bvh.occluded8_isa(isa, tile, &mut occ);
            for (i, r) in tile.iter().enumerate() {
                let want = bvh.intersect_isa(isa, r);
                assert_eq!(bits(hits[i]), bits(want), "tile {k} lane {i} {r:?}: packet {:?} single {want:?}", hits[i]);
                assert_eq!(occ[i], bvh.occluded_isa(isa, r), "tile {k} lane {i} {r:?}");
            }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn packets_equal_single_rays_on_soups(n in 1usize..400, size in 0.01f32..0.6, seed in any::<u64>(), leaf in 1usize..16, dist in 0.8f32..4.0) {
            let m = triangle_soup(n, size, seed);
            check(&bvh8(&m, leaf), &camera_tiles(Vec3::splat(0.5), dist, seed ^ 5));
        }

        #[test]
        fn packets_equal_single_rays_on_displaced_spheres(n in 200usize..20_000, seed in any::<u64>(), dist in 1.1f32..5.0) {
            let m = displaced_sphere(n);
            let mut rng = Rng::new(seed);
            let target = (rng.next_vec3() - 0.5) * 1.5;
            check(&bvh8(&m, 8), &camera_tiles(target, dist, seed));
        }
    }

    /// Incoherent rays (diffuse bounces inside the soup's box) through a tree of one node,
    /// whose packets take them whatever their spread: grouped by octant and dominant axis, as
    /// the path tracer bins them (their leaves test them in lanes), and in arbitrary order.
    #[test]
    fn one_node_trees_pack_incoherent_rays_as_single_rays_answer() {
        let mut packed = 0;
        for seed in 0..24u64 {
            let m = triangle_soup(6 + seed as usize * 2, 0.3, seed);
            let b = bvh8(&m, 4 + seed as usize % 5);
            if !b.packs_any_rays() {
                assert!(b.nodes.len() > 1);
                continue;
            }
            packed += 1;
            let mut rng = Rng::new(seed ^ 0x5eed);
            let mut rays: Vec<Ray> = (0..4096)
                .map(|k| {
                    let r = Ray::new(rng.next_vec3(), rng.next_dir());
                    if k % 7 == 0 { Ray::segment(r.origin, r.dir, 0.0, rng.next_f32()) } else { r }
                })
                .collect();
            let key = |r: &Ray| {
                let d = r.dir;
                let octant = usize::from(d.x < 0.0) | usize::from(d.y < 0.0) << 1 | usize::from(d.z < 0.0) << 2;
                octant * 3 + crate::primitives::dominant_axis(d)
            };
            let tiles = |rays: &[Ray]| -> Vec<[Ray; 8]> {
                rays.chunks_exact(8).map(|c| <[Ray; 8]>::try_from(c).expect("8 rays")).collect()
            };
            check(&b, &tiles(&rays));
            rays.sort_by_key(key);
            check(&b, &tiles(&rays));
        }
        assert!(packed >= 8, "only {packed} of the trees were of one node");
    }

    #[test]
    fn packets_equal_single_rays_inside_a_closed_mesh() {
        // Origins inside the sphere: every ray hits, many tiles span several octants.
        let m = displaced_sphere(30_000);
        let b = bvh8(&m, 8);
        for seed in 0..16 {
            check(&b, &camera_tiles(Vec3::ZERO, 0.3, seed));
        }
    }

    #[test]
    fn packets_are_watertight() {
        // Each edge- or vertex-aimed ray travels in a lane of a packet of 8 rays aimed at the
        // same target from nearby origins (a coherent packet), or (every other shot) from its
        // own origin toward nearby targets (the frustum walk of `frustum.rs`); its lane must hit.
        let ico = icosphere(4);
        let b = bvh8(&ico, 8);
        let isa = Isa::detect();
        let shot = std::cell::Cell::new(0usize);
        crate::test_util::shoot_at_edges(&ico, 100_000, 6, |r| {
            let k = shot.get();
            shot.set(k + 1);
            let lane = k % 8;
            let mut rng = Rng::new(k as u64);
            let target = r.origin + r.dir;
            let tile: [Ray; 8] = std::array::from_fn(|i| {
                if i == lane {
                    *r
                } else if k.is_multiple_of(2) {
                    let o = r.origin + (rng.next_vec3() - 0.5) * 0.05;
                    Ray::new(o, target - o)
                } else {
                    Ray::new(r.origin, target + (rng.next_vec3() - 0.5) * 0.05 - r.origin)
                }
            });
            let mut hits = [None; 8];
            let mut occ = [false; 8];
            b.intersect8_isa(isa, &tile, &mut hits);
            b.occluded8_isa(isa, &tile, &mut occ);
            (hits[lane].is_some(), occ[lane])
        });
    }

    #[test]
    fn packets_of_parallel_rays_from_spread_origins_equal_single_rays() {
        // Rays of one direction from origins far apart (shadow rays toward a directional
        // light): a coherent packet with different origins, which must not take the frustum
        // walk of one origin. Some tiles share one origin except for a single lane.
        let m = displaced_sphere(20_000);
        let b = bvh8(&m, 8);
        let mut rng = Rng::new(17);
        let tiles: Vec<[Ray; 8]> = (0..400)
            .map(|k| {
                let dir = rng.next_dir();
                let back = -dir * 3.0;
                let common = back + (rng.next_vec3() - 0.5) * 1.5;
                let odd = k % 8;
                std::array::from_fn(|i| {
                    let origin = if k % 2 == 0 || i == odd { back + (rng.next_vec3() - 0.5) * 2.0 } else { common };
                    Ray::new(origin, dir + (rng.next_vec3() - 0.5) * 0.01)
                })
            })
            .collect();
        check(&b, &tiles);
    }

    #[test]
    fn ray_lanes_hold_each_field_of_each_ray() {
        if Isa::detect() != Isa::Avx2 {
            return;
        }
        let mut rng = Rng::new(9);
        for k in 0..200 {
            let mut rays: [Ray; 8] = std::array::from_fn(|_| {
                Ray::segment(rng.next_vec3() - 0.5, rng.next_dir(), rng.next_f32(), 1.0 + rng.next_f32())
            });
            // Untraceable lanes: NaN, infinite, zero and negative-zero directions, tmin > tmax.
            match k % 6 {
                0 => rays[k % 8].origin.y = f32::NAN,
                1 => rays[k % 8].dir.z = f32::INFINITY,
                2 => rays[k % 8].dir = Vec3::ZERO,
                3 => rays[k % 8].dir = Vec3::new(-0.0, 0.0, -0.0),
                4 => rays[k % 8].tmin = 5.0,
                _ => {}
            }
            let lanes = RayLanes::new(&rays);
            let f: Vec<[f32; 8]> = lanes.f.iter().map(|&v| store(v)).collect();
            let mut traceable = 0;
            for (i, r) in rays.iter().enumerate() {
                let want = [r.origin.x, r.origin.y, r.origin.z, r.dir.x, r.dir.y, r.dir.z, r.tmin, r.tmax];
                for (field, &w) in want.iter().enumerate() {
                    assert_eq!(f[field][i].to_bits(), w.to_bits(), "ray {i} field {field}");
                }
                traceable |= (crate::bvh2::ray_is_traceable(r) as u32) << i;
            }
            assert_eq!(lanes.traceable(), traceable, "case {k}");
            let signs = lanes.signs();
            for (a, s) in signs.iter().enumerate() {
                for (i, r) in rays.iter().enumerate() {
                    assert_eq!(s >> i & 1 == 1, r.dir[a].is_sign_negative());
                }
            }
        }
    }

    #[test]
    fn empty_tree_and_all_nan_packets() {
        let b = bvh8(&Mesh::default(), 8);
        let tile = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
        let mut hits = [Some(Hit { t: 1.0, prim: 0, u: 0.0, v: 0.0 }); 8];
        let mut occ = [true; 8];
        b.intersect8_isa(Isa::detect(), &tile, &mut hits);
        b.occluded8_isa(Isa::detect(), &tile, &mut occ);
        assert_eq!(hits, [None; 8]);
        assert_eq!(occ, [false; 8]);
        let m = icosphere(2);
        let b = bvh8(&m, 8);
        let tile = [Ray::new(Vec3::NAN, Vec3::Z); 8];
        b.intersect8_isa(Isa::detect(), &tile, &mut hits);
        b.occluded8_isa(Isa::detect(), &tile, &mut occ);
        assert_eq!(hits, [None; 8]);
        assert_eq!(occ, [false; 8]);
    }
}
