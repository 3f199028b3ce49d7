//! Eight path vertices on surfaces without delta lobes shaded at once, structure of arrays
//! (the wavefront's "shade in SIMD batches" for the commonest vertices: a diffuse or glossy
//! wall, under area lights, suns and a sky).
//!
//! A round's guide vertices and the vertices behind them whose BSDF is the Phong reading's
//! diffuse and glossy lobes or Mitsuba's `diffuse` ([`PhongParts`], found by
//! `integrator::phong_parts_at`), in a scene whose lights the lanes take
//! ([`LightSet::suns`]: up to [`SUNS`] directional lights sampled at every vertex, the rest
//! emissive triangles and the sky), are queued while the round is shaded ([`PhongVertex`]:
//! their random numbers drawn in the scalar code's order), then shaded eight to a kernel call
//! ([`shade`]), in three steps:
//! 1. **gather**: each lane's hit, BSDF, path state and light choice (the triangle and point,
//!    or the sky's direction, that `LightSet::sample` would pick) into lanes;
//! 2. **lanes**: each sun's shadow ray and what it brings; the chosen light's point,
//!    direction, pdf and shadow ray ([`crate::path::lights::AreaChoice::sample_from`], or the
//!    sky's direction), the BSDF's value and pdf there, the power heuristic; the bounce (the
//!    lobe chosen by its probability; the cosine-weighted direction from the concentric disc
//!    with [`glint_core::sampling::sin_cos_quarter`]'s polynomials, or the Phong lobe's
//!    direction about the mirror direction), its frame (Duff et al. 2017), weight and Russian
//!    roulette; every ray's origin ([`RayOrigins8`]);
//! 3. **scatter**: lane by lane, the shadow rays queued and the path continued or ended, in
//!    the order the scalar code would have queued them.
//!
//! Every lane performs the scalar code's float operations in its order (no fused
//! multiply-add; `glint_accel::lanes` guarantees each operation's bits on both instruction
//! sets); the glossy lobe's power is `path::pow`'s lane code (the scalar code calls one lane
//! of it), and the Phong direction's sine and cosine are libm's, lane by lane, as the scalar
//! code calls them. So a lane gives the bits of
//! `Wavefront::continue_tail` (or `guide_vertex`) on the same vertex: the `WavefrontScalar`
//! kernel, which sends the same queue through that scalar code, is the oracle (tests/path.rs
//! compares the two pictures bit for bit).

use super::{Path, TailLeg};
use crate::path::bsdf::{Bsdf, PhongParts};
use crate::path::lights::{LightSet, Pick, SHADOW_SHORT, SUNS};
use crate::path::pow::pow8;
use crate::world::{SurfaceHit, World};
use glint_accel::batch::RayOrigins8;
use glint_accel::lanes::{F8, Isa, LANES, LaneKernel, M8, U8x, V8, dispatch};
use glint_core::random::{SOBOL_DIMENSIONS, SampleStream, sobol_seeds};
use glint_core::sampling::{COS_QUARTER, SIN_QUARTER};
use glint_core::{Ray, Rgb, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4, TAU};

/// A vertex on a surface without delta lobes, its random numbers drawn: one lane's input.
#[derive(Clone, Copy, Debug)]
pub(super) struct PhongVertex {
    /// Its path's and hit's index in the round.
    pub index: u32,
    pub kind: Kind,
    pub parts: PhongParts,
    /// Which random numbers it reads, from which dimension of its path's stream (drawn
    /// eight vertices at a time, in lanes: [`draw8`]).
    pub draws: Draws,
    /// The chosen light's sample is weighed against BSDF sampling (power heuristic) with
    /// the BSDF's pdf times this.
    pub mis: Option<f32>,
    /// The dimension of the path's stream after these draws (a queued vertex with a whole
    /// stream and a light choice stalled on store forwarding when gathered).
    pub dimension: u64,
}

/// The random numbers of a vertex, in the order the scalar code draws them from dimension
/// `first` of its path's stream: the light choice (1-D) and point (2-D) where it samples
/// light; the lobe choice (1-D, stepped over for a lone Lambertian lobe: [`lobe_number`]) and
/// the direction (2-D) where it bounces; Russian roulette's (1-D) where the next vertex is past
/// `rr_start`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Draws {
    pub first: u64,
    pub light: bool,
    pub bounce: bool,
    /// The lobe choice is drawn (else 0 stands in).
    pub lobe: bool,
    pub rr: bool,
}

/// Which vertex of its camera sample.
#[derive(Clone, Copy, Debug)]
pub(super) enum Kind {
    /// Behind the guide vertex (its path's leg is a tail).
    Tail,
    /// The guide vertex itself.
    Guide(Guide),
}

/// A guide vertex's state: its camera chain's throughput, the albedo it showed, its tail's
/// last light-sampling vertex, whether it traces its indirect light, and the dimension its
/// stream is at when `guide_vertex` receives it (the oracle's).
#[derive(Clone, Copy, Debug)]
pub(super) struct Guide {
    pub throughput: Rgb,
    pub albedo: Rgb,
    pub bounces: u32,
    pub trace: bool,
    pub entry: u64,
}

/// How the path budget treats a vertex (the scalar `continue_tail`'s reading of its
/// parameters).
#[derive(Clone, Copy, Debug)]
pub(super) struct Budget {
    /// Mitsuba's `max_depth` (its last light-sampling vertex follows its BSDF once more).
    pub mitsuba: bool,
    pub rr_start: u32,
}

impl PhongVertex {
    /// The vertex of `path` (its leg `leg`) at a surface of BSDF `parts`: its numbers drawn
    /// from the path's stream in the order `continue_tail` draws them (light choice and point,
    /// then lobe and direction, then the roulette's), so the stream it carries on is the
    /// scalar code's.
    #[inline]
    pub fn tail(index: u32, path: &Path, leg: &TailLeg, parts: PhongParts, budget: Budget) -> PhongVertex {
        let first = path.stream.dimension();
        let mut draws = Draws { first, light: false, bounce: false, lobe: !is_lambertian(&parts), rr: false };
        let mut mis = None;
        if leg.bounce <= leg.max_bounces {
            // MIS against BSDF sampling, except at the last vertex (its BSDF ray is not traced).
            mis = (leg.bounce < leg.max_bounces || budget.mitsuba).then_some(1.0);
            draws.light = true;
        }
        if leg.bounce < leg.max_bounces + u32::from(budget.mitsuba) {
            draws.bounce = true;
            draws.rr = leg.bounce + 1 > budget.rr_start;
        }
        let dimension = first + draws.count();
        PhongVertex { index, kind: Kind::Tail, parts, draws, mis, dimension }
    }

    /// The guide vertex of path `index` (`filtered`: the frame is filtered), its numbers
    /// drawn from `stream` (the path's at `guide.entry`) in `guide_vertex`'s order: the light
    /// samples', then, where it starts a traced tail, the bounce's.
    #[inline]
    pub fn guide(
        index: u32,
        guide: Guide,
        parts: PhongParts,
        stream: SampleStream,
        budget: Budget,
        filtered: bool,
    ) -> PhongVertex {
        // Mitsuba's budget weighs the direct light against the BSDF sample (whose density is
        // the non-delta part's alone).
        let mitsuba = budget.mitsuba && !filtered;
        let mis = mitsuba.then(|| 1.0 / (parts.p_diffuse + parts.p_glossy).max(1e-12));
        let bounce = guide.trace && (guide.bounces > 0 || mitsuba);
        let first = stream.dimension();
        let draws = Draws { first, light: true, bounce, lobe: !is_lambertian(&parts), rr: false };
        let (kind, dimension) = (Kind::Guide(guide), first + draws.count());
        PhongVertex { index, kind, parts, draws, mis, dimension }
    }

    /// Its path's stream after its draws.
    pub fn stream(&self, path: &Path) -> SampleStream {
        path.stream.at_dimension(self.dimension)
    }

    /// The BSDF the scalar code shades this vertex with.
    pub fn bsdf(&self) -> Bsdf {
        Bsdf::from_phong(&self.parts)
    }
}

/// Whether the lobe choice of a vertex of BSDF `parts` needs no number: a lone Lambertian lobe
/// is chosen with probability 1 (every number in [0, 1) picks it, in the lanes as in
/// `Bsdf::sample` and `Bsdf::sample_non_delta`), so its dimension is stepped over and 0 stands
/// in (a Sobol draw saved at most vertices of an area-lit scene of diffuse walls).
#[inline]
fn is_lambertian(parts: &PhongParts) -> bool {
    parts.p_diffuse == 1.0 && parts.p_glossy == 0.0
}

impl Draws {
    /// The dimensions they take.
    #[inline]
    fn count(&self) -> u64 {
        3 * u64::from(self.light) + 3 * u64::from(self.bounce) + u64::from(self.rr)
    }
}

/// A chunk's random numbers in lanes (a lane's unused numbers are zero).
struct Numbers<I: Isa> {
    choice: F8<I>,
    point: [F8<I>; 2],
    lobe: F8<I>,
    dir: [F8<I>; 2],
    rr: F8<I>,
}

/// The numbers of up to eight vertices' draws ([`Draws`]), lane `i` from the stream of
/// `paths[chunk[i].index]` (the identity of a guide vertex's stream is its path's; only the
/// dimension differs), bit for bit what `SampleStream::next_1d` / `next_2d` return there.
/// Low-discrepancy draws (a Sobol stream below `SOBOL_DIMENSIONS`) are made in lanes: their
/// seeds per lane (two 64-bit multiplies), then `random::sobol_draw`'s permutations and bit
/// reversals for eight streams at once (about a hundred integer operations a 2-D draw, a
/// few percent of a Cornell box frame when drawn one at a time); the others are hashed lane
/// by lane.
#[inline(always)]
fn draw8<I: Isa>(chunk: &[PhongVertex], paths: &[Path]) -> Numbers<I> {
    // References, not copies: the streams and draws copied into an array of pairs were read
    // back across two of their stores (a stalled store forward, 4 % of a Cornell box frame).
    let mut lanes = [None; LANES];
    for (lane, v) in lanes.iter_mut().zip(chunk) {
        *lane = Some((&paths[v.index as usize].stream, &v.draws));
    }
    draw_streams(&lanes)
}

/// [`draw8`] of lane by lane a stream and its draws (`None`: an unused lane, all zeros).
#[inline(always)]
fn draw_streams<I: Isa>(lanes: &[Option<(&SampleStream, &Draws)>; LANES]) -> Numbers<I> {
    let zero = F8::zero();
    let mut n = Numbers { choice: zero, point: [zero; 2], lobe: zero, dir: [zero; 2], rr: zero };
    // Per lane: the stream, and each draw's dimension (`None`: not drawn).
    let mut streams = [None; LANES];
    let mut index_reversed = [0u32; LANES];
    let mut dims = [[None; 5]; LANES];
    for i in 0..LANES {
        let Some((stream, d)) = lanes[i] else { continue };
        let mut at = d.first;
        let mut next = |used: bool, take: u64| {
            let here = at;
            if used {
                at += take;
            }
            used.then_some(here)
        };
        let choice = next(d.light, 1);
        let point = next(d.light, 2);
        let lobe = next(d.bounce, 1).filter(|_| d.lobe);
        let dir = next(d.bounce, 2);
        let rr = next(d.rr, 1);
        dims[i] = [choice, point, lobe, dir, rr];
        if let Some((_, reversed)) = stream.sobol_state() {
            index_reversed[i] = reversed;
        }
        streams[i] = Some(stream);
    }
    let lanes = ChunkStreams { streams, dims, index_reversed: U8x::<I>::from_array(index_reversed) };
    [n.choice, _] = draw_lanes(&lanes, 0, false);
    n.point = draw_lanes(&lanes, 1, true);
    [n.lobe, _] = draw_lanes(&lanes, 2, false);
    n.dir = draw_lanes(&lanes, 3, true);
    [n.rr, _] = draw_lanes(&lanes, 4, false);
    n
}

/// A chunk's streams for [`draw_lanes`]: lane by lane the stream, its draws' dimensions
/// (choice, point, lobe, direction, roulette; `None`: not drawn), its reversed sample index.
struct ChunkStreams<'a, I: Isa> {
    streams: [Option<&'a SampleStream>; LANES],
    dims: [[Option<u64>; 5]; LANES],
    index_reversed: U8x<I>,
}

/// Draw `k` (1-D, or 2-D where `two`) of every lane of [`draw8`]. (A function, not a closure:
/// a closure is compiled without the kernel's instruction set, and its lane operations would
/// become calls.)
#[inline(always)]
fn draw_lanes<I: Isa>(c: &ChunkStreams<'_, I>, k: usize, two: bool) -> [F8<I>; 2] {
    let (streams, dims, index_reversed) = (&c.streams, &c.dims, c.index_reversed);
    let (mut shuffle, mut sx, mut sy) = ([0u32; LANES], [0u32; LANES], [0u32; LANES]);
    let mut ld = 0u32;
    let (mut x, mut y) = ([0.0f32; LANES], [0.0f32; LANES]);
    for i in 0..LANES {
        let (Some(stream), Some(d)) = (streams[i], dims[i][k]) else { continue };
        match stream.sobol_state() {
            Some((scramble, _)) if d < SOBOL_DIMENSIONS => {
                (shuffle[i], sx[i], sy[i]) = sobol_seeds(scramble, d);
                ld |= 1 << i;
            }
            _ => {
                x[i] = stream.independent_at(d);
                if two {
                    y[i] = stream.independent_at(d + 1);
                }
            }
        }
    }
    let (mut u, mut v) = (F8::from_array(x), F8::from_array(y));
    if ld != 0 {
        let i = lk_permutation8(index_reversed, U8x::from_array(shuffle)).reverse_bits();
        let m = M8::from_bits(ld);
        u = F8::select(m, unit_float8(lk_permutation8(i, U8x::from_array(sx)).reverse_bits()), u);
        if two {
            let w = lk_permutation8(sobol_second_of_reversed8(i), U8x::from_array(sy)).reverse_bits();
            v = F8::select(m, unit_float8(w), v);
        }
    }
    [u, v]
}

/// `random::lk_permutation` in lanes.
#[inline(always)]
fn lk_permutation8<I: Isa>(x: U8x<I>, seed: U8x<I>) -> U8x<I> {
    let x = x.xor(x.wrapping_mul(U8x::splat(0x3d20_adea)));
    let x = x.wrapping_add(seed);
    let x = x.wrapping_mul(seed.shift_right(16).or(1));
    let x = x.xor(x.wrapping_mul(U8x::splat(0x0552_6c56)));
    x.xor(x.wrapping_mul(U8x::splat(0x53a2_2864)))
}

/// `random::sobol_second_of_reversed` in lanes.
#[inline(always)]
fn sobol_second_of_reversed8<I: Isa>(i: U8x<I>) -> U8x<I> {
    let f = i.xor(i.shift_right(1).and(0x5555_5555));
    let f = f.xor(f.shift_right(2).and(0x3333_3333));
    let f = f.xor(f.shift_right(4).and(0x0f0f_0f0f));
    let f = f.xor(f.shift_right(8).and(0x00ff_00ff));
    f.xor(f.shift_right(16))
}

/// `random::unit_float32` in lanes: the top 24 bits over 2^24 (exact).
#[inline(always)]
fn unit_float8<I: Isa>(x: U8x<I>) -> F8<I> {
    x.shift_right(8).to_f32() * F8::splat(1.0 / (1u32 << 24) as f32)
}

/// A vertex's bounce: its ray, the path's β after it (tails: roulette included), its pdf,
/// and the lobes' parts there over nothing: the diffuse shape `max(n·wi, 0)/π` and the
/// glossy lobe's `f·cos` (what a guide vertex's tail hands to its camera sample).
#[derive(Clone, Copy, Debug)]
pub(super) struct Next {
    pub ray: Ray,
    pub beta: Rgb,
    pub pdf: f32,
    pub shape: f32,
    pub glossy: f32,
}

/// What a vertex gives back (besides its suns' shadow rays).
#[derive(Clone, Copy, Debug)]
pub(super) struct PhongResult {
    /// The chosen light's shadow ray, what it brings (`f·cos·L/pdf` × the MIS weight) and
    /// that light's diffuse part demodulated (`light_samples`' two colours).
    pub shadow: Option<(Ray, Rgb, Rgb)>,
    pub next: Option<Next>,
}

/// A sun's shadow ray from a vertex (sun `sun` of [`LightSet::suns`], from `origin`) and what
/// it brings when nothing blocks it (`f·cos·L·π`). Kept apart from [`PhongResult`]: a scene
/// without suns writes none.
#[derive(Clone, Copy, Debug)]
pub(super) struct SunShadow {
    pub sun: u8,
    pub origin: Vec3,
    pub brings: Rgb,
}

/// Shade `vertices` (whose paths and hits are `paths[v.index]`, `hits[v.index]`, each with
/// a hit) eight at a time with the best instruction set this CPU has, under the suns
/// `suns` ([`LightSet::suns`]), handing each vertex's answer to `apply` in their order:
/// the vertex, its result and its suns' shadow rays (`sun_rays` holds a lane's). Each answer
/// is taken from the lanes and applied at once: written out for the whole round and read
/// back, the answers' loads waited on memory or stalled on store forwarding (a few percent
/// of a Cornell box frame).
pub(super) fn shade(
    (world, lights, suns): (&World, &LightSet, &[(Vec3, Rgb)]),
    (paths, hits): (&[Path], &[Option<SurfaceHit>]),
    vertices: &[PhongVertex],
    sun_rays: &mut Vec<SunShadow>,
    apply: impl FnMut(&PhongVertex, PhongResult, &[SunShadow]),
) {
    let kernel = Kernel { world, lights, suns, paths, hits, vertices, sun_rays, apply };
    dispatch(kernel, crate::lanes_baseline());
}

struct Kernel<'a, F> {
    world: &'a World,
    lights: &'a LightSet,
    suns: &'a [(Vec3, Rgb)],
    paths: &'a [Path],
    hits: &'a [Option<SurfaceHit>],
    vertices: &'a [PhongVertex],
    sun_rays: &'a mut Vec<SunShadow>,
    apply: F,
}

impl<F: FnMut(&PhongVertex, PhongResult, &[SunShadow])> LaneKernel for Kernel<'_, F> {
    type Output = ();

    #[inline(always)]
    fn run<I: Isa>(mut self) {
        for chunk in self.vertices.chunks(LANES) {
            let numbers = draw8::<I>(chunk, self.paths);
            let lanes = gather::<I>(chunk, &numbers, self.paths, self.hits, (self.world, self.lights));
            let shaded = shade8(&lanes, self.suns);
            scatter(&shaded, chunk, self.suns.len(), &mut *self.sun_rays, &mut self.apply);
        }
    }
}

/// A BSDF without delta lobes in lanes ([`PhongParts`]).
struct Lobes<I: Isa> {
    normal: V8<I>,
    geometric: V8<I>,
    diffuse: V8<I>,
    glossy: F8<I>,
    exponent: F8<I>,
    mirror_dir: V8<I>,
    p_diffuse: F8<I>,
    p_glossy: F8<I>,
    /// Lanes with a glossy lobe (`glossy` > 0), and lanes whose pdf has one (`p_glossy` > 0).
    has_glossy: M8<I>,
    pdf_glossy: M8<I>,
}

/// Eight vertices' inputs in lanes (a short chunk repeats its last vertex; the copies'
/// answers are dropped).
struct Lanes<I: Isa> {
    position: V8<I>,
    p_error: V8<I>,
    /// The hit's geometric normal as the geometry orients it (ray origins' side test).
    hit_normal: V8<I>,
    bsdf: Lobes<I>,
    /// Every lane a lone Lambertian lobe (chosen with probability 1).
    lambertian: bool,
    beta: V8<I>,
    tail: M8<I>,
    /// Lanes that sample light (the suns, and the choice unless it found nothing).
    lit: M8<I>,
    area: M8<I>,
    vertices: [V8<I>; 3],
    two_sided: M8<I>,
    tri_area: F8<I>,
    p_choice: F8<I>,
    b0: F8<I>,
    b1: F8<I>,
    emission: V8<I>,
    sky: M8<I>,
    sky_dir: V8<I>,
    sky_weight: V8<I>,
    sky_pdf: F8<I>,
    mis: M8<I>,
    mis_scale: F8<I>,
    bounce: M8<I>,
    u_lobe: F8<I>,
    u_bounce: [F8<I>; 2],
    rr: M8<I>,
    u_rr: F8<I>,
}

#[inline(always)]
fn gather<I: Isa>(
    chunk: &[PhongVertex],
    numbers: &Numbers<I>,
    paths: &[Path],
    hits: &[Option<SurfaceHit>],
    (world, lights): (&World, &LightSet),
) -> Lanes<I> {
    let (zero, zero3, none) = (F8::zero(), V8::zero(), M8::none_set());
    let bsdf = Lobes {
        normal: zero3,
        geometric: zero3,
        diffuse: zero3,
        glossy: zero,
        exponent: zero,
        mirror_dir: zero3,
        p_diffuse: zero,
        p_glossy: zero,
        has_glossy: none,
        pdf_glossy: none,
    };
    let mut l = Lanes {
        position: zero3,
        p_error: zero3,
        hit_normal: zero3,
        bsdf,
        lambertian: false,
        beta: zero3,
        tail: none,
        lit: none,
        area: none,
        vertices: [zero3; 3],
        two_sided: none,
        tri_area: zero,
        p_choice: zero,
        b0: zero,
        b1: zero,
        emission: zero3,
        sky: none,
        sky_dir: zero3,
        sky_weight: zero3,
        sky_pdf: zero,
        mis: none,
        mis_scale: zero,
        bounce: none,
        u_lobe: zero,
        u_bounce: [zero; 2],
        rr: none,
        u_rr: zero,
    };
    let (mut tail, mut lit, mut area, mut two_sided, mut sky) = (0u32, 0u32, 0u32, 0u32, 0u32);
    let (mut mis, mut bounce, mut rr) = (0u32, 0u32, 0u32);
    // Eight lone Lambertian lobes (most chunks of an area-lit scene) need only ρ and the
    // normals: their other parts are the lanes' constants (lanes gathered one float at a time
    // and read as vectors stall on store forwarding, a few percent of a Cornell box frame).
    let lambertian = chunk.iter().all(|v| {
        let p = &v.parts;
        p.glossy == 0.0 && p.p_glossy == 0.0 && p.p_diffuse == 1.0
    });
    if lambertian {
        l.bsdf.p_diffuse = F8::one();
        l.lambertian = true;
    }
    for i in 0..LANES {
        let v = &chunk[i.min(chunk.len() - 1)];
        let bit = 1 << i;
        let index = v.index as usize;
        // Queued from a leg with a hit (`Wavefront::shade_tail`, `shade_camera`).
        if let Some(hit) = &hits[index] {
            l.position.set(i, hit.position);
            l.p_error.set(i, hit.p_error);
            l.hit_normal.set(i, hit.geometric_normal);
        }
        // A guide vertex's β is 1 (its tail starts afresh).
        let beta = if let super::Leg::Tail(leg) = &paths[index].leg { leg.beta } else { Rgb::ONE };
        l.beta.set(i, beta);
        if matches!(v.kind, Kind::Tail) {
            tail |= bit;
        }
        let p = &v.parts;
        let b = &mut l.bsdf;
        b.normal.set(i, p.normal);
        b.geometric.set(i, p.geometric);
        b.diffuse.set(i, p.diffuse);
        if !lambertian {
            b.glossy[i] = p.glossy;
            b.exponent[i] = p.exponent;
            b.mirror_dir.set(i, p.mirror_dir);
            b.p_diffuse[i] = p.p_diffuse;
            b.p_glossy[i] = p.p_glossy;
        }
        // A short chunk's repeated last vertex takes the last lane's numbers.
        let j = i.min(chunk.len() - 1);
        if v.draws.light {
            let (u_choice, u) = (numbers.choice[j], Vec2::new(numbers.point[0][j], numbers.point[1][j]));
            lit |= bit;
            // The light's triangle and point, or the sky's direction, as `LightSet::sample`
            // chooses them.
            match lights.pick(u_choice) {
                Some((Pick::Triangle(t), p_choice)) => {
                    let c = lights.area_choice(world, t, p_choice, u);
                    area |= bit;
                    if c.two_sided {
                        two_sided |= bit;
                    }
                    for (k, p) in c.vertices.iter().enumerate() {
                        l.vertices[k].set(i, *p);
                    }
                    l.tri_area[i] = c.area;
                    l.p_choice[i] = c.p_choice;
                    l.b0[i] = c.b0;
                    l.b1[i] = c.b1;
                    l.emission.set(i, c.emission);
                }
                Some((Pick::Sky, p_choice)) => {
                    if let Some((dir, weight, pdf)) = lights.sky_choice(world, p_choice, u) {
                        sky |= bit;
                        l.sky_dir.set(i, dir);
                        l.sky_weight.set(i, weight);
                        l.sky_pdf[i] = pdf;
                    }
                }
                // `LightSet::suns` admits no delta light into the choice.
                Some((Pick::Delta(_), _)) | None => {}
            }
        }
        if let Some(scale) = v.mis {
            mis |= bit;
            l.mis_scale[i] = scale;
        }
        if v.draws.bounce {
            bounce |= bit;
            l.u_lobe[i] = numbers.lobe[j];
            l.u_bounce[0][i] = numbers.dir[0][j];
            l.u_bounce[1][i] = numbers.dir[1][j];
        }
        if v.draws.rr {
            rr |= bit;
            l.u_rr[i] = numbers.rr[j];
        }
    }
    let bits = M8::from_bits;
    (l.tail, l.lit, l.area, l.two_sided, l.sky) = (bits(tail), bits(lit), bits(area), bits(two_sided), bits(sky));
    (l.mis, l.bounce, l.rr) = (bits(mis), bits(bounce), bits(rr));
    l.bsdf.has_glossy = l.bsdf.glossy.gt(zero);
    l.bsdf.pdf_glossy = l.bsdf.p_glossy.gt(zero);
    l
}

/// Eight vertices' answers in lanes.
struct Shaded<I: Isa> {
    /// Each sun's: lanes that queue its shadow ray, their origins and what each brings.
    sun: [(M8<I>, V8<I>, V8<I>); SUNS],
    shadow: M8<I>,
    shadow_origin: V8<I>,
    shadow_dir: V8<I>,
    shadow_tmax: F8<I>,
    shadow_brings: V8<I>,
    shadow_diffuse: V8<I>,
    next: M8<I>,
    next_origin: V8<I>,
    next_dir: V8<I>,
    next_beta: V8<I>,
    next_pdf: F8<I>,
    next_shape: F8<I>,
    next_glossy: F8<I>,
}

/// [`glint_core::sampling::sin_cos_quarter`] in lanes, operation for operation.
#[inline(always)]
fn sin_cos_quarter8<I: Isa>(x: F8<I>) -> (F8<I>, F8<I>) {
    let z = x * x;
    let [s1, s2, s3, s4] = SIN_QUARTER.map(F8::splat);
    let [c1, c2, c3, c4, c5] = COS_QUARTER.map(F8::splat);
    let sin = x + x * z * (s1 + z * (s2 + z * (s3 + z * s4)));
    let cos = F8::one() + z * (c1 + z * (c2 + z * (c3 + z * (c4 + z * c5))));
    (sin, cos)
}

/// `glint_core::sampling::sample_disc_concentric` in lanes, operation for operation (both
/// quotients are formed; each lane keeps its branch's).
#[inline(always)]
fn disc8<I: Isa>(u: [F8<I>; 2]) -> [F8<I>; 2] {
    let (zero, one) = (F8::zero(), F8::one());
    let two = F8::splat(2.0);
    let (ox, oy) = (u[0] * two - one, u[1] * two - one);
    let centre = ox.eq(zero) & oy.eq(zero);
    let x_ring = ox.abs().gt(oy.abs());
    let (s, c) = sin_cos_quarter8(F8::splat(FRAC_PI_4) * F8::select(x_ring, oy / ox, ox / oy));
    let r = F8::select(x_ring, ox, oy);
    let dx = F8::select(x_ring, c, s) * r;
    let dy = F8::select(x_ring, s, c) * r;
    [F8::select(centre, zero, dx), F8::select(centre, zero, dy)]
}

/// `Frame::from_z(z).to_world(local)` (Duff et al.'s frame), operation for operation.
#[inline(always)]
fn to_world<I: Isa>(z: V8<I>, local: V8<I>) -> V8<I> {
    let one = F8::one();
    let sign = one.copysign(z.z);
    let k = F8::splat(-1.0) / (sign + z.z);
    let m = z.x * z.y * k;
    let fx = V8::new(one + sign * z.x * z.x * k, sign * m, -sign * z.x);
    let fy = V8::new(m, sign + z.y * z.y * k, -z.y);
    fx.scale(local.x) + fy.scale(local.y) + z.scale(local.z)
}

/// `v / s` per component (glam's `Vec3 / f32`).
#[inline(always)]
fn over<I: Isa>(v: V8<I>, s: F8<I>) -> V8<I> {
    V8::new(v.x / s, v.y / s, v.z / s)
}

/// Lanes where some component of `v` is above 0 (the scalar `max_element() > 0`).
#[inline(always)]
fn any_positive<I: Isa>(v: V8<I>) -> M8<I> {
    let zero = F8::zero();
    v.x.gt(zero) | v.y.gt(zero) | v.z.gt(zero)
}

/// glam's `max_element`, its comparisons in its order: `max(x, max(y, z))`.
#[inline(always)]
fn max_element<I: Isa>(v: V8<I>) -> F8<I> {
    let yz = F8::select(v.y.gt(v.z), v.y, v.z);
    F8::select(v.x.gt(yz), v.x, yz)
}

/// The glossy lobe's `cos^n α` toward `wi` in the lanes `need` (0 elsewhere): `Bsdf`'s
/// `glossy_lobe`, the power in lanes ([`pow8`]: the scalar `pow`'s bits).
#[inline(always)]
fn glossy_lobe<I: Isa>(b: &Lobes<I>, wi: V8<I>, need: M8<I>) -> F8<I> {
    let c = b.mirror_dir.dot(wi);
    F8::select(need & c.gt(F8::zero()), pow8(c, b.exponent), F8::zero())
}

/// The BSDF toward a direction ([`Bsdf::eval_cos_and_pdf`]).
struct Eval<I: Isa> {
    /// Lanes where it reflects (cos above 0 by both normals).
    reflects: M8<I>,
    /// `f·cos`.
    f: V8<I>,
    pdf: F8<I>,
    /// The glossy lobe's `cos^n α` (0 in lanes without a glossy lobe).
    lobe: F8<I>,
    /// The shading normal's cosine.
    cos: F8<I>,
}

#[inline(always)]
fn eval<I: Isa>(b: &Lobes<I>, wi: V8<I>) -> Eval<I> {
    let zero = F8::zero();
    let cos = b.normal.dot(wi);
    let reflects = cos.gt(zero) & b.geometric.dot(wi).gt(zero);
    let mut f = b.diffuse.scale(F8::splat(FRAC_1_PI));
    let pdf_diffuse = F8::select(reflects, cos * F8::splat(FRAC_1_PI), zero);
    let mut pdf = F8::select(b.p_diffuse.gt(zero), zero + b.p_diffuse * pdf_diffuse, zero);
    let mut lobe = zero;
    // Eight Lambertian lobes (most chunks of most scenes) skip the glossy lobe's arithmetic.
    let glossy_lanes = b.has_glossy | b.pdf_glossy;
    if glossy_lanes.any() {
        lobe = glossy_lobe(b, wi, glossy_lanes);
        let glossy = b.glossy * (b.exponent + F8::splat(2.0)) / F8::splat(TAU) * lobe;
        f = V8::select(b.has_glossy, f + V8::new(glossy, glossy, glossy), f);
        let pdf_g = b.p_glossy * ((b.exponent + F8::one()) / F8::splat(TAU) * lobe);
        pdf = F8::select(b.pdf_glossy, pdf + pdf_g, pdf);
    }
    let f = V8::select(reflects, f.scale(cos), V8::zero());
    Eval { reflects, f, pdf, lobe, cos }
}

/// The Phong lobe's direction about the mirror direction for the numbers `u` in the lanes
/// `need` (`Bsdf`'s `sample_glossy`: the power in lanes, libm's `cos` and `sin` lane by lane).
#[inline(always)]
#[allow(clippy::needless_range_loop)] // lane `i` of four lane arrays
fn glossy_direction<I: Isa>(b: &Lobes<I>, u: [F8<I>; 2], need: M8<I>) -> V8<I> {
    let mut local = V8::zero();
    if !need.any() {
        return local;
    }
    let cos_a = pow8(u[0], F8::one() / (b.exponent + F8::one()));
    for i in 0..LANES {
        if need.lane(i) {
            let cos_a = cos_a[i];
            let sin_a = (1.0 - cos_a * cos_a).max(0.0).sqrt();
            let phi = TAU * u[1][i];
            local.set(i, Vec3::new(sin_a * phi.cos(), sin_a * phi.sin(), cos_a));
        }
    }
    to_world(b.mirror_dir, local)
}

#[inline(always)]
fn shade8<I: Isa>(l: &Lanes<I>, suns: &[(Vec3, Rgb)]) -> Shaded<I> {
    let (zero, one) = (F8::zero(), F8::one());
    let b = &l.bsdf;
    let origins = RayOrigins8::new(l.position, l.p_error, l.hit_normal);

    // The suns: `LightSet::delta_sample` and `light_samples`' first loop.
    let none = (M8::none_set(), V8::zero(), V8::zero());
    let mut sun = [none; SUNS];
    for (s, &(wi, weight)) in sun.iter_mut().zip(suns) {
        let wi = V8::new(F8::splat(wi.x), F8::splat(wi.y), F8::splat(wi.z));
        let f = eval(b, wi).f;
        let weight = V8::new(F8::splat(weight.x), F8::splat(weight.y), F8::splat(weight.z));
        *s = (l.lit & any_positive(f), origins.toward(wi), f * weight);
    }

    // The chosen light: `AreaChoice::sample_from`, operation for operation ...
    let [va, vb, vc] = l.vertices;
    let target = va.scale(l.b0) + vb.scale(l.b1) + vc.scale(one - l.b0 - l.b1);
    let to = target - l.position;
    let dist2 = to.dot(to);
    let wi_area = over(to, dist2.sqrt());
    let n = (vb - va).cross(vc - va);
    let facing = -n.dot(wi_area);
    let cos_l = F8::select(l.two_sided, facing.abs(), facing) / n.dot(n).sqrt();
    let area = l.area & dist2.gt(zero) & cos_l.gt(F8::splat(1e-7));
    let pdf_area = l.p_choice * dist2 / (l.tri_area * cos_l);
    // `SurfaceHit::spawn_ray_to(target)`, stopped short of the light.
    let area_origin = origins.toward(to);
    let d = target - area_origin;
    let length = d.dot(d).sqrt();
    // ... or the sky's direction (`SurfaceHit::spawn_ray`).
    let (mut found, mut wi, mut pdf_light) = (area, wi_area, pdf_area);
    let mut weight = over(l.emission, pdf_area);
    let (mut shadow_origin, mut shadow_dir) = (area_origin, over(d, length));
    let mut shadow_tmax = length * F8::splat(SHADOW_SHORT);
    if l.sky.any() {
        found = found | l.sky;
        wi = V8::select(l.area, wi, l.sky_dir);
        pdf_light = F8::select(l.area, pdf_light, l.sky_pdf);
        weight = V8::select(l.area, weight, l.sky_weight);
        shadow_origin = V8::select(l.area, shadow_origin, origins.toward(l.sky_dir));
        shadow_dir = V8::select(l.area, shadow_dir, l.sky_dir);
        shadow_tmax = F8::select(l.area, shadow_tmax, F8::splat(f32::INFINITY));
    }
    // `light_samples`: the BSDF there, weighed against its own sampling.
    let Eval { f, pdf: pdf_bsdf, .. } = eval(b, wi);
    let weighed = l.mis & pdf_light.gt(zero);
    let pdf_bsdf = pdf_bsdf * l.mis_scale;
    let (a2, b2) = (pdf_light * pdf_light, pdf_bsdf * pdf_bsdf);
    let heuristic = F8::select((a2 + b2).le(zero), zero, a2 / (a2 + b2));
    let w = F8::select(weighed, heuristic, one);
    let shadow = found & any_positive(f);
    let shadow_brings = (f * weight).scale(w);
    let shape = b.normal.dot(wi).max(zero) * F8::splat(FRAC_1_PI);
    let shadow_diffuse = V8::select(pdf_light.gt(zero), weight.scale(w * shape), V8::zero());

    // The bounce: `Bsdf::sample` (tails: the non-delta part chosen by `u_lobe`, else the
    // delta part, which has no lobe) or `Bsdf::sample_non_delta` (guide vertices), then
    // `non_delta_direction`: the diffuse lobe's cosine-weighted direction or the glossy one's.
    let nd = b.p_diffuse + b.p_glossy;
    let non_delta = (l.tail & l.u_lobe.lt(nd)) | !l.tail;
    // Lambertian lanes: `nd` is 1, so the quotients are their dividends.
    let (u_lobe, ratio) = if l.lambertian {
        (l.u_lobe, b.p_diffuse)
    } else {
        (F8::select(l.tail, l.u_lobe / nd, l.u_lobe), b.p_diffuse / nd)
    };
    let diffuse = u_lobe.lt(ratio);
    let [dx, dy] = disc8(l.u_bounce);
    let dz = (one - (dx * dx + dy * dy)).max(zero).sqrt();
    let cosine = to_world(b.normal, V8::new(dx, dy, dz));
    let glossy_dir = glossy_direction(b, l.u_bounce, l.bounce.and_not(diffuse));
    let dir = V8::select(diffuse, cosine, glossy_dir);
    let Eval { reflects, f, pdf, lobe, cos } = eval(b, dir);
    let pdf = if l.lambertian { pdf } else { F8::select(l.tail, pdf, pdf / nd) };
    let mut next = l.bounce & non_delta & reflects & pdf.gt(zero) & pdf.lt(F8::splat(f32::INFINITY));
    let beta = l.beta * over(f, pdf);
    // Russian roulette.
    let q = max_element(beta).min(F8::splat(0.95));
    let killed = l.rr & (l.u_rr.ge(q) | q.is_nan());
    next = next.and_not(killed);
    let beta = V8::select(l.rr, over(beta, q), beta);
    // `Bsdf::eval_glossy_cos` there (a guide vertex's tail).
    let glossy = b.glossy * (b.exponent + F8::splat(2.0)) / F8::splat(TAU) * lobe * cos;
    let next_glossy = F8::select(b.has_glossy & reflects, glossy, zero);

    Shaded {
        sun,
        shadow,
        shadow_origin,
        shadow_dir,
        shadow_tmax,
        shadow_brings,
        shadow_diffuse,
        next,
        next_origin: origins.toward(dir),
        next_dir: dir,
        next_beta: beta,
        next_pdf: pdf,
        next_shape: b.normal.dot(dir).max(zero) * F8::splat(FRAC_1_PI),
        next_glossy,
    }
}

/// The chunk's answers, lane by lane, to `apply` (`sun_rays`: a lane's suns' shadow rays).
#[inline(always)]
fn scatter<I: Isa>(
    s: &Shaded<I>,
    chunk: &[PhongVertex],
    suns: usize,
    sun_rays: &mut Vec<SunShadow>,
    apply: &mut impl FnMut(&PhongVertex, PhongResult, &[SunShadow]),
) {
    for (i, v) in chunk.iter().enumerate() {
        sun_rays.clear();
        for (k, (lanes, origin, brings)) in s.sun[..suns].iter().enumerate() {
            if lanes.lane(i) {
                sun_rays.push(SunShadow { sun: k as u8, origin: origin.lane(i), brings: brings.lane(i) });
            }
        }
        let shadow = s.shadow.lane(i).then(|| {
            let ray = Ray::segment(s.shadow_origin.lane(i), s.shadow_dir.lane(i), 0.0, s.shadow_tmax[i]);
            (ray, s.shadow_brings.lane(i), s.shadow_diffuse.lane(i))
        });
        let next = s.next.lane(i).then(|| Next {
            ray: Ray::new(s.next_origin.lane(i), s.next_dir.lane(i)),
            beta: s.next_beta.lane(i),
            pdf: s.next_pdf[i],
            shape: s.next_shape[i],
            glossy: s.next_glossy[i],
        });
        apply(v, PhongResult { shadow, next }, sun_rays);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_accel::lanes::Sse;
    use glint_core::random::SampleStream;
    use glint_core::sampling::sample_disc_concentric;

    /// Eight disc points in lanes are the scalar mapping's bits, corners and centre included.
    #[test]
    fn eight_disc_points_are_the_scalar_points() {
        let special = [0.0, 0.5, 1.0 - f32::EPSILON / 2.0, 0.25, 0.75, 0.5 + f32::EPSILON, 0.125, 0.875];
        let mut s = SampleStream::new(1, 0, 9);
        for round in 0..4000 {
            let u: [Vec2; LANES] = std::array::from_fn(|i| {
                if round < 8 { Vec2::new(special[i], special[(i + round) % 8]) } else { s.next_2d() }
            });
            let got = disc8::<Sse>([F8::from_fn(|i| u[i].x), F8::from_fn(|i| u[i].y)]);
            for (i, u) in u.iter().enumerate() {
                let want = sample_disc_concentric(*u);
                assert_eq!((got[0][i].to_bits(), got[1][i].to_bits()), (want.x.to_bits(), want.y.to_bits()), "{u}");
            }
        }
    }
}

#[cfg(test)]
mod draw_tests {
    use super::*;
    use glint_accel::lanes::LaneKernel;
    use glint_core::random::{Sampler, mix64};

    /// Random streams (both samplers) and draws from dimensions around the end of the
    /// low-discrepancy ones, drawn in lanes and one at a time.
    struct Check(u64);

    impl LaneKernel for Check {
        type Output = ();
        #[inline(always)]
        fn run<I: Isa>(self) {
            let mut h = self.0;
            let mut rand = || {
                h = mix64(h.wrapping_add(1));
                h
            };
            for _ in 0..300 {
                let mut lanes = [None; LANES];
                let mut expected = [[0.0f32; 7]; LANES];
                for (i, lane) in lanes.iter_mut().enumerate() {
                    if rand() % 9 == 0 {
                        continue;
                    }
                    let sampler = if rand() % 3 == 0 { Sampler::Independent } else { Sampler::Sobol };
                    let first = rand() % (SOBOL_DIMENSIONS + 6);
                    let stream = sampler.stream(rand() % 100_000, rand() % 300, rand() % 4).at_dimension(first);
                    let r = rand();
                    let d = Draws { first, light: r & 1 == 1, bounce: r & 2 == 2, lobe: r & 4 == 4, rr: r & 8 == 8 };
                    // The scalar code's draws, in its order.
                    let mut s = stream;
                    let e = &mut expected[i];
                    if d.light {
                        e[0] = s.next_1d();
                        let p = s.next_2d();
                        (e[1], e[2]) = (p.x, p.y);
                    }
                    if d.bounce {
                        e[3] = if d.lobe {
                            s.next_1d()
                        } else {
                            s.skip(1);
                            0.0
                        };
                        let p = s.next_2d();
                        (e[4], e[5]) = (p.x, p.y);
                    }
                    if d.rr {
                        e[6] = s.next_1d();
                    }
                    assert_eq!(s.dimension(), first + d.count());
                    *lane = Some((stream, d));
                }
                let refs: [Option<(&SampleStream, &Draws)>; LANES] =
                    std::array::from_fn(|i| lanes[i].as_ref().map(|(s, d)| (s, d)));
                let n = draw_streams::<I>(&refs);
                for i in 0..LANES {
                    let got = [n.choice[i], n.point[0][i], n.point[1][i], n.lobe[i], n.dir[0][i], n.dir[1][i], n.rr[i]];
                    assert_eq!(got.map(f32::to_bits), expected[i].map(f32::to_bits), "lane {i}: {:?}", lanes[i]);
                }
            }
        }
    }

    #[test]
    fn lanes_draw_what_the_streams_draw_one_at_a_time() {
        dispatch(Check(1), true);
        dispatch(Check(2), false);
    }
}
