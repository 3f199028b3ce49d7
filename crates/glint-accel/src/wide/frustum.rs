//! Frustum traversal of packets from one point (AVX2 + FMA, entered only after runtime
//! detection): the rays of one direction octant that leave the same origin (a pinhole camera's
//! primary rays) walk the 8-wide tree as one beam. An inner node tests its 8 children against
//! the whole packet at once with the interval bounds of the packet's slab distances (the
//! frusta of Reshetov, Soupikov and Hurley, "Multi-Level Ray Tracing Algorithm", SIGGRAPH 2005,
//! and of Embree's coherent mode): one SIMD operation per slab serves every ray, where
//! `packet.rs` spends one per slab per child. A leaf tests its rays against the leaf's own box,
//! then against its triangles: each triangle against all of them in lanes ([`LeafLanes`]) when
//! they share the test's axis permutation, else ray by ray.
//!
//! Exactness. A ray's slab distance is `fl(fl(b - o) · inv)`. With one origin, `x = b - o` is
//! the same for every ray, and `fl(x · inv)` is monotone in `inv` (rounding is monotone), so
//! over the packet's reciprocals `[imin, imax]` (one sign per axis within an octant) it lies
//! between `fl(x · imin)` and `fl(x · imax)`. The frustum's entry distance is therefore at most
//! every ray's and its exit at least every ray's (a ray's exit is `fl(fl(b - o) · inv_far)`,
//! bounded the same way by the packet's far reciprocals `[fmin, fmax]`; `tmax` is monotone too): a
//! child any ray's own test accepts, the frustum accepts. Leaves run the single-ray box and
//! triangle tests per ray, and equally near hits resolve by primitive index, so each ray's
//! answer is the single-ray kernel's bit for bit; visiting more inner nodes than a ray would
//! costs time, never a different hit. Packets whose origins differ (shadow rays from spread
//! hit points: a frustum over their origin box is loose, and measured 25 % slower on a Sponza
//! path frame) or whose reciprocals are not finite and non-zero take `packet.rs`'s kernel.
//!
//! Measured (BENCHMARKS §1.1, one thread): Sponza's primary rays 7.5 → 10.0 Mrays/s with the
//! frustum walk, 13.5 with the 8-ray leaves below; the dragon's 17.9 → 19.6 → 24.6.

use super::packet::{Lanes, LeafRays, PacketRay, box8, lane_mask, lane_max, lane_min, load, store};
use super::walk::{closer, order_children};
use super::{LEAF, PACKET, Stack, TriPacket, WideBvh, avx2, leaf_packets};
use crate::Hit;
use crate::primitives::{WoopRay, woop};
use glint_core::Ray;
use std::arch::x86_64::*;

// SAFETY (every `unsafe` block in this file): the `#[target_feature(enable = "avx2,fma")]`
// function is only called from `packet::closest_packet`, itself only reached after
// `Isa::detect()` found AVX2 and FMA; the intrinsics touch registers and 32-byte arrays only.

/// The interval bounds of a packet's slab distances, splatted across the 8 children.
pub(super) struct Frustum {
    /// The rays' common origin.
    org: [__m256; 3],
    /// Per axis: the smallest and largest reciprocal direction, and of the far planes'
    /// reciprocals (`PacketRay::inv_far`).
    imin: [__m256; 3],
    imax: [__m256; 3],
    fmin: [__m256; 3],
    fmax: [__m256; 3],
    tmin: __m256,
}

impl Frustum {
    /// The frustum of `group`'s rays (one octant), or `None` when their origins differ (bit
    /// for bit) or a ray's reciprocal direction is not finite and non-zero; lane operations
    /// on the packet's constants.
    #[inline(always)]
    pub(super) fn new(pr: &PacketRay, group: u32) -> Option<Self> {
        // SAFETY: AVX2 only; inlined into the `avx2,fma` kernel (see the top of the file).
        unsafe {
            let on = lane_mask(group);
            let first = _mm256_set1_epi32(group.trailing_zeros() as i32);
            let inf = _mm256_set1_ps(f32::INFINITY);
            let mut same = 0xff;
            let mut usable = 0xff;
            let mut org = [inf; 3];
            let (mut imin, mut imax) = ([inf; 3], [inf; 3]);
            let (mut fmin, mut fmax) = ([inf; 3], [inf; 3]);
            for a in 0..3 {
                // One origin: every lane's bits equal the first ray's.
                let o = _mm256_permutevar8x32_ps(pr.org[a], first);
                let eq = _mm256_cmpeq_epi32(_mm256_castps_si256(pr.org[a]), _mm256_castps_si256(o));
                same &= _mm256_movemask_ps(_mm256_castsi256_ps(eq)) as u32;
                org[a] = o;
                // Reciprocals finite and non-zero (|inv| < inf, inv ≠ 0; NaN fails both), the
                // far ones too (finite far implies finite near; non-zero alike).
                let (v, vf) = (pr.inv[a], pr.inv_far[a]);
                let finite = _mm256_cmp_ps::<_CMP_LT_OQ>(_mm256_andnot_ps(_mm256_set1_ps(-0.0), vf), inf);
                let nonzero = _mm256_cmp_ps::<_CMP_NEQ_OQ>(vf, _mm256_setzero_ps());
                usable &= _mm256_movemask_ps(_mm256_and_ps(finite, nonzero)) as u32;
                let ninf = _mm256_set1_ps(f32::NEG_INFINITY);
                imin[a] = _mm256_set1_ps(lane_min(_mm256_blendv_ps(inf, v, on)));
                imax[a] = _mm256_set1_ps(lane_max(_mm256_blendv_ps(ninf, v, on)));
                fmin[a] = _mm256_set1_ps(lane_min(_mm256_blendv_ps(inf, vf, on)));
                fmax[a] = _mm256_set1_ps(lane_max(_mm256_blendv_ps(ninf, vf, on)));
            }
            if same & group != group || usable & group != group {
                return None;
            }
            let tmin = _mm256_set1_ps(lane_min(_mm256_blendv_ps(inf, pr.tmin, on)));
            Some(Self { org, imin, imax, fmin, fmax, tmin })
        }
    }

    /// The 8 children of a node against the frustum: the mask of those some ray may meet
    /// before `tmax` (the largest `tmax` of the packet's rays), and entry distances no larger
    /// than any ray's.
    #[inline(always)]
    fn test(&self, pr: &PacketRay, bounds: &[[f32; 8]; 6], tmax: __m256) -> (u32, __m256) {
        let (mut tn, mut tf) = (self.tmin, tmax);
        for a in 0..3 {
            let near = interval(load(&bounds[pr.near[a]]), self.org[a], self.imin[a], self.imax[a]);
            let far = interval(load(&bounds[pr.far[a]]), self.org[a], self.fmin[a], self.fmax[a]);
            // SAFETY: AVX only; inlined into the `avx2,fma` kernel below (see the top of the file).
            unsafe {
                tn = _mm256_max_ps(tn, _mm256_min_ps(near.0, near.1));
                tf = _mm256_min_ps(tf, _mm256_max_ps(far.0, far.1));
            }
        }
        // SAFETY: as above.
        unsafe { (_mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32, tn) }
    }
}

/// `(b - o) · lo` and `(b - o) · hi`: a slab distance at both ends of the reciprocal interval.
/// (A function, not a closure: a closure is compiled without the caller's AVX features and its
/// intrinsics would become calls.)
#[inline(always)]
fn interval(b: __m256, o: __m256, lo: __m256, hi: __m256) -> (__m256, __m256) {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels below (see the top of the file).
    unsafe {
        let x = _mm256_sub_ps(b, o);
        (_mm256_mul_ps(x, lo), _mm256_mul_ps(x, hi))
    }
}

#[inline(always)]
fn splat(x: f32) -> __m256 {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernels below (see the top of the file).
    unsafe { _mm256_set1_ps(x) }
}

/// A node to visit: the child reference, where its box is stored (parent node and slot: a
/// leaf tests its rays against it) and the frustum's entry distance.
#[derive(Clone, Copy, Default)]
struct Entry {
    child: u32,
    parent: u32,
    slot: u32,
    tn: f32,
}

/// Closest hits of `group` (one octant, one origin) by frustum traversal.
#[target_feature(enable = "avx2,fma")]
pub(super) fn closest_frustum(
    bvh: &WideBvh<8>,
    pr: &mut PacketRay,
    f: &Frustum,
    rays: &[Ray; 8],
    group: u32,
    out: &mut [Option<Hit>; 8],
) {
    let mut leaf_rays = LeafRays::new(rays);
    // Made on the first leaf (most packets that miss never reach one).
    let mut lanes = None;
    let mut best = Best8::new();
    let mut tmax = load(&pr.tmax);
    let mut far = lane_max(tmax);
    let mut stack = Stack::<Entry>::new();
    let mut cur = Entry { child: 0, parent: 0, slot: 0, tn: 0.0 };
    'walk: loop {
        if cur.child & LEAF == 0 {
            let node = &bvh.nodes[cur.child as usize];
            let (mask, tn) = f.test(pr, &node.bounds, splat(far));
            if mask != 0 {
                let d = store(tn);
                let entry = |c: usize| Entry { child: node.child[c], parent: cur.child, slot: c as u32, tn: d[c] };
                let near = order_children(mask, &d, |c| stack.push(entry(c)));
                cur = entry(near);
                continue;
            }
        } else {
            let (m, _) = box8(&bvh.nodes[cur.parent as usize].bounds, cur.slot as usize, pr, tmax);
            let m = m & group;
            if m != 0 {
                match lanes.get_or_insert_with(|| LeafLanes::new(rays, group)) {
                    Some(l) if m.count_ones() >= MIN_LEAF_LANES => {
                        for p in &bvh.packets[leaf_packets(cur.child)] {
                            l.closest(p, rays, m, &mut pr.tmax, (&mut best, out));
                        }
                    }
                    _ => {
                        for i in Lanes(m) {
                            let tr = leaf_rays.get(i);
                            let packets = &bvh.packets[leaf_packets(cur.child)];
                            pr.tmax[i] = avx2::leaf_closest(tr, packets, pr.tmax[i], &mut out[i]);
                        }
                    }
                }
                tmax = load(&pr.tmax);
                far = lane_max(tmax);
            }
        }
        loop {
            let Some(e) = stack.pop() else { break 'walk };
            if e.tn <= far {
                cur = e;
                break;
            }
        }
    }
    best.finish(out);
}

/// Fewest rays in a leaf for which testing each triangle against all of them at once
/// ([`LeafLanes::closest`]: 8 rays a vector) beats each ray against 4 triangles at once
/// (measured on Sponza's and the dragon's primary rays: 1 and 2 equal, 3–6 within noise,
/// 9, i.e. never, 30 % slower).
pub(super) const MIN_LEAF_LANES: u32 = 2;

/// The per-ray constants of the watertight triangle test (Woop, Benthin, Wald, JCGT 2013) for
/// the rays of a packet in lanes, when they share its axis permutation (the dominant axis of
/// their directions; within one octant that fixes the swap of the other two as well).
pub(super) struct LeafLanes {
    k: [usize; 3],
    /// Origins, permuted: `org[0]` holds axis `kx` of every ray.
    org: [__m256; 3],
    s: [__m256; 3],
    tmin: __m256,
}

impl LeafLanes {
    /// `None` when two rays of `group` have different permutations (lanes outside `group`
    /// repeat the first ray's constants; the callers mask them out).
    #[inline(always)]
    pub(super) fn new(rays: &[Ray; 8], group: u32) -> Option<Self> {
        let first = WoopRay::new(&rays[group.trailing_zeros() as usize % 8]);
        let k = [first.kx, first.ky, first.kz];
        let mut org = [[0.0f32; 8]; 3];
        let mut sh = [[first.sx; 8], [first.sy; 8], [first.sz; 8]];
        let mut tmin = [0.0f32; 8];
        for i in 0..8 {
            let (r, w) = if group >> i & 1 == 1 {
                let w = WoopRay::new(&rays[i]);
                // Field by field: as arrays, LLVM stored the three indices and loaded them
                // back as one vector, a load the store buffer cannot forward (5 % of a packet
                // walk of primary rays stalled there).
                if w.kx != k[0] || w.ky != k[1] || w.kz != k[2] {
                    return None;
                }
                (&rays[i], w)
            } else {
                (&rays[group.trailing_zeros() as usize % 8], first)
            };
            for a in 0..3 {
                org[a][i] = w.org[k[a]];
            }
            (sh[0][i], sh[1][i], sh[2][i]) = (w.sx, w.sy, w.sz);
            tmin[i] = r.tmin;
        }
        Some(Self { k, org: org.map(|v| load(&v)), s: sh.map(|v| load(&v)), tmin: load(&tmin) })
    }

    /// Each triangle of `p` against the rays of `active` (the operations of `sse::tri4`, lane
    /// for lane: the same bits); hits closer than a ray's best in lanes (`best`, by
    /// [`closer`]'s rule in lanes) replace it and lower its `tmax`. Lanes with a zero edge
    /// function take the exact test of `primitives::woop`, as there, against `out`; the caller
    /// merges `best` into `out` when its walk ends ([`Best8::finish`]).
    #[inline(always)]
    pub(super) fn closest(
        &self,
        p: &TriPacket,
        rays: &[Ray; 8],
        active: u32,
        tmax: &mut [f32; 8],
        (best, out): (&mut Best8, &mut [Option<Hit>; 8]),
    ) {
        let [kx, ky, kz] = self.k;
        for j in 0..PACKET {
            // Unused lanes of a leaf's last packet repeat its last triangle: same answer.
            if j > 0 && p.prim[j] == p.prim[j - 1] {
                continue;
            }
            let vert = |v: usize| [p.v[v][kx][j], p.v[v][ky][j], p.v[v][kz][j]];
            let t_max = load(tmax);
            let l = tri8(self, vert(0), vert(1), vert(2), t_max, active);
            let prim = p.prim[j];
            if l.hit & active != 0 {
                best.offer(&l, prim, l.hit & active, t_max, tmax);
            }
            for i in Lanes(l.zero & active) {
                let [a, b, c] = p.lane(j);
                if let Some(h) = woop(&WoopRay::new(&rays[i]), a, b, c, rays[i].tmin, tmax[i])
                    && closer(h.t, prim, &out[i])
                {
                    tmax[i] = h.t;
                    out[i] = Some(Hit { t: h.t, prim, u: h.u, v: h.v });
                }
            }
        }
    }

    /// Each triangle of `p` against the rays of `active`: the lanes with a hit in their
    /// `(tmin, tmax]`, the single-ray any-hit test's answer lane for lane (zero-edge lanes take
    /// the exact test of `primitives::woop`, as there).
    #[inline(always)]
    pub(super) fn any(&self, p: &TriPacket, rays: &[Ray; 8], active: u32, tmax: &[f32; 8]) -> u32 {
        let [kx, ky, kz] = self.k;
        let t = load(tmax);
        let mut found = 0;
        for j in 0..PACKET {
            let todo = active & !found;
            // Unused lanes of a leaf's last packet repeat its last triangle: same answer.
            if todo == 0 || (j > 0 && p.prim[j] == p.prim[j - 1]) {
                break;
            }
            let vert = |v: usize| [p.v[v][kx][j], p.v[v][ky][j], p.v[v][kz][j]];
            let l = tri8(self, vert(0), vert(1), vert(2), t, todo);
            found |= l.hit & todo;
            for i in Lanes(l.zero & todo) {
                let [a, b, c] = p.lane(j);
                if woop(&WoopRay::new(&rays[i]), a, b, c, rays[i].tmin, tmax[i]).is_some() {
                    found |= 1 << i;
                }
            }
        }
        found
    }
}

/// One triangle against 8 rays: hit lanes (zero-edge lanes excluded), zero-edge lanes, and
/// t, V, W, det per lane.
struct Lanes8 {
    hit: u32,
    zero: u32,
    t: __m256,
    v: __m256,
    w: __m256,
    det: __m256,
}

/// The nearest hits [`LeafLanes::closest`] found so far, per lane and in registers: distance,
/// primitive and the unnormalised barycentrics (`V`, `W`, `det`), in the lanes of `found`.
/// Made into [`Hit`]s once, when the walk ends ([`Best8::finish`]): per hit, a scalar loop with
/// two divisions cost a tenth of the Cornell box's packet walks.
pub(super) struct Best8 {
    t: __m256,
    prim: __m256i,
    v: __m256,
    w: __m256,
    det: __m256,
    found: u32,
}

impl Best8 {
    #[inline(always)]
    pub(super) fn new() -> Self {
        // SAFETY: AVX only; inlined into the `avx2,fma` kernels (see the top of the file).
        unsafe {
            let zero = _mm256_setzero_ps();
            Self { t: splat(f32::INFINITY), prim: _mm256_set1_epi32(-1), v: zero, w: zero, det: zero, found: 0 }
        }
    }

    /// Triangle `prim`'s hits `l` in the lanes `lanes` (within `t_max`, the rays' `tmax`s as
    /// loaded from `tmax`): those nearer than the lane's best, or as near with a lower
    /// primitive ([`closer`]), replace it, and their distance becomes the ray's `tmax`.
    #[inline(always)]
    fn offer(&mut self, l: &Lanes8, prim: u32, lanes: u32, t_max: __m256, tmax: &mut [f32; 8]) {
        // SAFETY: AVX2 only; inlined into the `avx2,fma` kernels (see the top of the file).
        unsafe {
            let p = _mm256_set1_epi32(prim as i32);
            // Unsigned `prim < best`: both biased into the signed order.
            let bias = _mm256_set1_epi32(i32::MIN);
            let prim_lower = _mm256_cmpgt_epi32(_mm256_xor_si256(self.prim, bias), _mm256_xor_si256(p, bias));
            let nearer = _mm256_cmp_ps::<_CMP_LT_OQ>(l.t, self.t);
            let tie = _mm256_and_ps(_mm256_cmp_ps::<_CMP_EQ_OQ>(l.t, self.t), _mm256_castsi256_ps(prim_lower));
            let take = _mm256_movemask_ps(_mm256_or_ps(nearer, tie)) as u32 & lanes;
            if take == 0 {
                return;
            }
            let m = lane_mask(take);
            self.t = _mm256_blendv_ps(self.t, l.t, m);
            self.prim =
                _mm256_castps_si256(_mm256_blendv_ps(_mm256_castsi256_ps(self.prim), _mm256_castsi256_ps(p), m));
            self.v = _mm256_blendv_ps(self.v, l.v, m);
            self.w = _mm256_blendv_ps(self.w, l.w, m);
            self.det = _mm256_blendv_ps(self.det, l.det, m);
            self.found |= take;
            *tmax = store(_mm256_blendv_ps(t_max, l.t, m));
        }
    }

    /// The best hits into `out`, each where it is [`closer`] than what `out` holds (the hits
    /// the rays' scalar tests found), with its barycentrics `V / det`, `W / det` (the division
    /// the single-ray leaf makes): the nearest hit of all, lowest primitive among equals.
    #[inline(always)]
    pub(super) fn finish(&self, out: &mut [Option<Hit>; 8]) {
        if self.found == 0 {
            return;
        }
        let (t, v, w, det) = (store(self.t), store(self.v), store(self.w), store(self.det));
        let mut prim = [0u32; 8];
        // SAFETY: 32 writable bytes, `storeu` needs no alignment; AVX (top of the file).
        unsafe { _mm256_storeu_si256(prim.as_mut_ptr().cast(), self.prim) };
        for i in Lanes(self.found) {
            if closer(t[i], prim[i], &out[i]) {
                out[i] = Some(Hit { t: t[i], prim: prim[i], u: v[i] / det[i], v: w[i] / det[i] });
            }
        }
    }
}

/// The watertight test of one triangle (vertices given in the rays' permuted axes) against
/// every lane: `sse::tri4`'s operations in its order, multiplies and subtractions never fused.
/// (Plain functions for the vector operations, no closures: a closure is compiled without the
/// caller's AVX features and its intrinsics would become calls.)
#[inline(always)]
fn tri8(l: &LeafLanes, a: [f32; 3], b: [f32; 3], c: [f32; 3], tmax: __m256, active: u32) -> Lanes8 {
    let (ax, ay, az) = (sub(splat(a[0]), l.org[0]), sub(splat(a[1]), l.org[1]), sub(splat(a[2]), l.org[2]));
    let (bx, by, bz) = (sub(splat(b[0]), l.org[0]), sub(splat(b[1]), l.org[1]), sub(splat(b[2]), l.org[2]));
    let (cx, cy, cz) = (sub(splat(c[0]), l.org[0]), sub(splat(c[1]), l.org[1]), sub(splat(c[2]), l.org[2]));
    let [sx, sy, sz] = l.s;
    let ax = sub(ax, mul(sx, az));
    let ay = sub(ay, mul(sy, az));
    let bx = sub(bx, mul(sx, bz));
    let by = sub(by, mul(sy, bz));
    let cx = sub(cx, mul(sx, cz));
    let cy = sub(cy, mul(sy, cz));
    let u = sub(mul(cx, by), mul(cy, bx));
    let v = sub(mul(ax, cy), mul(ay, cx));
    let w = sub(mul(bx, ay), mul(by, ax));
    let zero = splat(0.0);
    let any_zero = or(or(cmp::<_CMP_EQ_OQ>(u, zero), cmp::<_CMP_EQ_OQ>(v, zero)), cmp::<_CMP_EQ_OQ>(w, zero));
    let any_neg = or(or(cmp::<_CMP_LT_OQ>(u, zero), cmp::<_CMP_LT_OQ>(v, zero)), cmp::<_CMP_LT_OQ>(w, zero));
    let any_pos = or(or(cmp::<_CMP_GT_OQ>(u, zero), cmp::<_CMP_GT_OQ>(v, zero)), cmp::<_CMP_GT_OQ>(w, zero));
    // SAFETY: AVX only; inlined into the `avx2,fma` kernel above (see the top of the file).
    let (outside, zero_bits) =
        unsafe { (_mm256_movemask_ps(and(any_neg, any_pos)) as u32, _mm256_movemask_ps(any_zero) as u32) };
    // Every active ray passes outside the triangle: no distance, no division. (The same
    // early exit in `sse::tri4`, one ray against 4 triangles, measured 3–5 % slower on
    // diffuse rays: its branch is less predictable there.)
    if (outside | !active) & 0xff == 0xff && zero_bits & active == 0 {
        return Lanes8 { hit: 0, zero: 0, t: zero, v: zero, w: zero, det: zero };
    }
    let det = add(add(u, v), w);
    let t = add(add(mul(u, mul(sz, az)), mul(v, mul(sz, bz))), mul(w, mul(sz, cz)));
    let t = div(t, det);
    let ok = and(and(cmp::<_CMP_GT_OQ>(t, l.tmin), cmp::<_CMP_LE_OQ>(t, tmax)), cmp::<_CMP_NEQ_UQ>(det, zero));
    // SAFETY: AVX only; inlined into the `avx2,fma` kernel above (see the top of the file).
    let ok = unsafe { _mm256_movemask_ps(_mm256_andnot_ps(and(any_neg, any_pos), ok)) as u32 };
    Lanes8 { hit: ok & !zero_bits, zero: zero_bits, t, v, w, det }
}

#[inline(always)]
fn sub(a: __m256, b: __m256) -> __m256 {
    // SAFETY: AVX only; inlined into the `avx2,fma` kernel above (see the top of the file).
    unsafe { _mm256_sub_ps(a, b) }
}

#[inline(always)]
fn add(a: __m256, b: __m256) -> __m256 {
    // SAFETY: as `sub`.
    unsafe { _mm256_add_ps(a, b) }
}

#[inline(always)]
fn mul(a: __m256, b: __m256) -> __m256 {
    // SAFETY: as `sub`.
    unsafe { _mm256_mul_ps(a, b) }
}

#[inline(always)]
fn div(a: __m256, b: __m256) -> __m256 {
    // SAFETY: as `sub`.
    unsafe { _mm256_div_ps(a, b) }
}

#[inline(always)]
fn or(a: __m256, b: __m256) -> __m256 {
    // SAFETY: as `sub`.
    unsafe { _mm256_or_ps(a, b) }
}

#[inline(always)]
fn and(a: __m256, b: __m256) -> __m256 {
    // SAFETY: as `sub`.
    unsafe { _mm256_and_ps(a, b) }
}

/// Lane mask of `a OP b` (the ordered/unordered forms of the SSE comparisons `tri4` uses).
#[inline(always)]
fn cmp<const OP: i32>(a: __m256, b: __m256) -> __m256 {
    // SAFETY: as `sub`.
    unsafe { _mm256_cmp_ps::<OP>(a, b) }
}
