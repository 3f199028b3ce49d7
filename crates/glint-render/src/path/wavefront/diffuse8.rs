//! Eight path vertices on Lambertian surfaces shaded at once, structure of arrays (the
//! wavefront's "shade in SIMD batches" for the commonest vertex of a scene lit by area
//! lights: a diffuse wall behind the guide vertex).
//!
//! A round's guide vertices and the vertices behind them whose BSDF is a Lambertian lobe alone
//! (`integrator::lambertian_parts_at`) in a scene whose lights are all emissive triangles
//! ([`LightSet::area_only`]) are queued while the round is shaded ([`DiffuseVertex`]: their
//! random numbers drawn in the scalar code's order), then shaded eight to a kernel call
//! ([`shade`]), in three steps:
//! 1. **gather**: each lane's hit, BSDF, path state and light choice (the triangle and point
//!    `LightSet::choose_area` picks) into lanes;
//! 2. **lanes**: the light sample's point, direction, pdf and shadow ray
//!    ([`crate::path::lights::AreaChoice::sample_from`]), the BSDF's value and pdf there, the
//!    power heuristic, the cosine-weighted bounce (the concentric disc with
//!    [`glint_core::sampling::sin_cos_quarter`]'s polynomials), its frame (Duff et al.
//!    2017), weight and Russian roulette, and both rays' origins ([`RayOrigins8`]);
//! 3. **scatter**: lane by lane, the shadow ray queued and the path continued or ended, in
//!    the order the scalar code would have queued them.
//!
//! Every lane performs the scalar code's float operations in its order (no fused
//! multiply-add; `glint_accel::lanes` guarantees each operation's bits on both instruction
//! sets), so a lane gives the bits of `Wavefront::continue_tail` (or `guide_vertex`) on the
//! same vertex: the `WavefrontScalar` kernel, which sends the same queue through that scalar
//! code, is the oracle (tests/path.rs compares the two pictures bit for bit).

use super::{Path, TailLeg};
use crate::path::bsdf::Bsdf;
use crate::path::lights::{LightSet, SHADOW_SHORT};
use crate::world::{SurfaceHit, World};
use glint_accel::batch::RayOrigins8;
use glint_accel::lanes::{F8, Isa, LANES, LaneKernel, M8, V8, dispatch};
use glint_core::random::SampleStream;
use glint_core::sampling::{COS_QUARTER, SIN_QUARTER};
use glint_core::{Ray, Rgb, Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, FRAC_PI_4};

/// A vertex on a Lambertian surface, its random numbers drawn: one lane's input.
#[derive(Clone, Copy, Debug)]
pub(super) struct DiffuseVertex {
    /// Its path's and hit's index in the round.
    pub index: u32,
    pub kind: Kind,
    /// ρd, and the shading and geometric normals on the viewer's side.
    pub diffuse: Rgb,
    pub normal: Vec3,
    pub geometric: Vec3,
    /// The light sample's numbers (choice, point); `None` where the vertex samples no light.
    pub light: Option<(f32, Vec2)>,
    /// The light sample is weighed against BSDF sampling (power heuristic).
    pub mis: bool,
    /// The bounce's number (the cosine-weighted direction's); `None` where the path ends
    /// after its light sample.
    pub bounce: Option<Vec2>,
    /// Russian roulette's number, where the next vertex is past `rr_start`.
    pub rr: Option<f32>,
    /// The dimension of the path's stream after these draws (the vertex is ~120 bytes, not
    /// ~250 with a whole stream and a light choice: queued and gathered, the larger one's
    /// copies stalled on store forwarding).
    pub dimension: u64,
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

impl DiffuseVertex {
    /// The vertex of `path` (its leg `leg`) at a surface whose BSDF has the Lambertian
    /// `parts`: its numbers drawn from the path's stream in the order `continue_tail` draws them
    /// (light choice and point, then lobe and direction, then the roulette's), so the stream
    /// it carries on is the scalar code's.
    #[inline]
    pub fn tail(index: u32, path: &Path, leg: &TailLeg, parts: (Rgb, Vec3, Vec3), budget: Budget) -> DiffuseVertex {
        let (diffuse, normal, geometric) = parts;
        let mut stream = path.stream;
        let (mut light, mut mis) = (None, false);
        if leg.bounce <= leg.max_bounces {
            // MIS against BSDF sampling, except at the last vertex (its BSDF ray is not traced).
            mis = leg.bounce < leg.max_bounces || budget.mitsuba;
            let u_choice = stream.next_1d();
            light = Some((u_choice, stream.next_2d()));
        }
        let (mut bounce, mut rr) = (None, None);
        if leg.bounce < leg.max_bounces + u32::from(budget.mitsuba) {
            // The lobe's number: a lone Lambertian lobe is chosen whatever it is.
            let _ = stream.next_1d();
            bounce = Some(stream.next_2d());
            if leg.bounce + 1 > budget.rr_start {
                rr = Some(stream.next_1d());
            }
        }
        let dimension = stream.dimension();
        DiffuseVertex { index, kind: Kind::Tail, diffuse, normal, geometric, light, mis, bounce, rr, dimension }
    }

    /// The guide vertex of path `index` (`filtered`: the frame is filtered), its numbers
    /// drawn from `stream` (the path's at `guide.entry`) in `guide_vertex`'s order: the light
    /// sample's, then, where it starts a traced tail, the bounce's.
    #[inline]
    pub fn guide(
        index: u32,
        guide: Guide,
        parts: (Rgb, Vec3, Vec3),
        mut stream: SampleStream,
        budget: Budget,
        filtered: bool,
    ) -> DiffuseVertex {
        let (diffuse, normal, geometric) = parts;
        // Mitsuba's budget weighs the direct light against the BSDF sample.
        let mitsuba = budget.mitsuba && !filtered;
        let u_choice = stream.next_1d();
        let light = Some((u_choice, stream.next_2d()));
        let mut bounce = None;
        if guide.trace && (guide.bounces > 0 || mitsuba) {
            let _ = stream.next_1d();
            bounce = Some(stream.next_2d());
        }
        let (kind, dimension) = (Kind::Guide(guide), stream.dimension());
        DiffuseVertex { index, kind, diffuse, normal, geometric, light, mis: mitsuba, bounce, rr: None, dimension }
    }

    /// Its path's stream after its draws.
    pub fn stream(&self, path: &Path) -> SampleStream {
        path.stream.at_dimension(self.dimension)
    }

    /// The BSDF the scalar code shades this vertex with.
    pub fn bsdf(&self) -> Bsdf {
        Bsdf::diffuse_with_geometric(self.diffuse, self.normal, self.geometric)
    }
}

/// What a vertex gives back.
#[derive(Clone, Copy, Debug)]
pub(super) struct DiffuseResult {
    /// Its shadow ray, what that brings when nothing blocks it (`f·cos·L/pdf` × the MIS
    /// weight) and that light's diffuse part demodulated (`light_samples`' two colours).
    pub shadow: Option<(Ray, Rgb, Rgb)>,
    /// The bounce's ray, the path's β after it (tails: roulette included), its pdf and the
    /// diffuse lobe's shape `max(n·wi, 0)/π` there; `None`: no bounce.
    pub next: Option<(Ray, Rgb, f32, f32)>,
}

/// Shade `vertices` (whose paths and hits are `paths[v.index]`, `hits[v.index]`, each with
/// a hit) eight at a time with the best instruction set this CPU has;
/// `out[i]` is vertex `i`'s result.
pub(super) fn shade(
    (world, lights): (&World, &LightSet),
    paths: &[Path],
    hits: &[Option<SurfaceHit>],
    vertices: &[DiffuseVertex],
    out: &mut Vec<DiffuseResult>,
) {
    out.clear();
    dispatch(Kernel { world, lights, paths, hits, vertices, out }, crate::lanes_baseline());
}

struct Kernel<'a> {
    world: &'a World,
    lights: &'a LightSet,
    paths: &'a [Path],
    hits: &'a [Option<SurfaceHit>],
    vertices: &'a [DiffuseVertex],
    out: &'a mut Vec<DiffuseResult>,
}

impl LaneKernel for Kernel<'_> {
    type Output = ();

    #[inline(always)]
    fn run<I: Isa>(self) {
        for chunk in self.vertices.chunks(LANES) {
            let lanes = gather::<I>(chunk, self.paths, self.hits, (self.world, self.lights));
            let shaded = shade8(&lanes);
            scatter(&shaded, chunk.len(), self.out);
        }
    }
}

/// Eight vertices' inputs in lanes (a short chunk repeats its last vertex; the copies'
/// answers are dropped).
struct Lanes<I: Isa> {
    position: V8<I>,
    p_error: V8<I>,
    /// The hit's geometric normal as the geometry orients it (ray origins' side test).
    hit_normal: V8<I>,
    normal: V8<I>,
    geometric: V8<I>,
    diffuse: V8<I>,
    beta: V8<I>,
    light: M8<I>,
    vertices: [V8<I>; 3],
    two_sided: M8<I>,
    area: F8<I>,
    p_choice: F8<I>,
    b0: F8<I>,
    b1: F8<I>,
    emission: V8<I>,
    mis: M8<I>,
    bounce: M8<I>,
    u_bounce: [F8<I>; 2],
    rr: M8<I>,
    u_rr: F8<I>,
}

#[inline(always)]
fn gather<I: Isa>(
    chunk: &[DiffuseVertex],
    paths: &[Path],
    hits: &[Option<SurfaceHit>],
    (world, lights): (&World, &LightSet),
) -> Lanes<I> {
    let (zero, zero3) = (F8::zero(), V8::zero());
    let mut l = Lanes {
        position: zero3,
        p_error: zero3,
        hit_normal: zero3,
        normal: zero3,
        geometric: zero3,
        diffuse: zero3,
        beta: zero3,
        light: M8::none_set(),
        vertices: [zero3; 3],
        two_sided: M8::none_set(),
        area: zero,
        p_choice: zero,
        b0: zero,
        b1: zero,
        emission: zero3,
        mis: M8::none_set(),
        bounce: M8::none_set(),
        u_bounce: [zero; 2],
        rr: M8::none_set(),
        u_rr: zero,
    };
    let (mut light, mut two_sided, mut mis, mut bounce, mut rr) = (0u32, 0u32, 0u32, 0u32, 0u32);
    for i in 0..LANES {
        let v = &chunk[i.min(chunk.len() - 1)];
        let bit = 1 << i;
        let index = v.index as usize;
        // Queued from a tail leg with a hit (`Wavefront::shade_tail`).
        if let Some(hit) = &hits[index] {
            l.position.set(i, hit.position);
            l.p_error.set(i, hit.p_error);
            l.hit_normal.set(i, hit.geometric_normal);
        }
        // A guide vertex's β is 1 (its tail starts afresh).
        let beta = if let super::Leg::Tail(leg) = &paths[index].leg { leg.beta } else { Rgb::ONE };
        l.beta.set(i, beta);
        l.normal.set(i, v.normal);
        l.geometric.set(i, v.geometric);
        l.diffuse.set(i, v.diffuse);
        // The light's triangle and point, as `LightSet::sample` chooses them.
        if let Some(c) = v.light.and_then(|(u_choice, u)| lights.choose_area(world, u_choice, u)) {
            light |= bit;
            if c.two_sided {
                two_sided |= bit;
            }
            for (k, p) in c.vertices.iter().enumerate() {
                l.vertices[k].set(i, *p);
            }
            l.area[i] = c.area;
            l.p_choice[i] = c.p_choice;
            l.b0[i] = c.b0;
            l.b1[i] = c.b1;
            l.emission.set(i, c.emission);
        }
        if v.mis {
            mis |= bit;
        }
        if let Some(u) = v.bounce {
            bounce |= bit;
            l.u_bounce[0][i] = u.x;
            l.u_bounce[1][i] = u.y;
        }
        if let Some(u) = v.rr {
            rr |= bit;
            l.u_rr[i] = u;
        }
    }
    (l.light, l.two_sided, l.mis, l.bounce, l.rr) =
        (M8::from_bits(light), M8::from_bits(two_sided), M8::from_bits(mis), M8::from_bits(bounce), M8::from_bits(rr));
    l
}

/// Eight vertices' answers in lanes.
struct Shaded<I: Isa> {
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

/// The Lambertian lobe toward `wi`: `(f·cos, pdf)` where it reflects (cos above 0 by both
/// normals), zero elsewhere ([`Bsdf::eval_cos_and_pdf`] of a lone diffuse lobe).
#[inline(always)]
fn lambert<I: Isa>(l: &Lanes<I>, wi: V8<I>) -> (M8<I>, V8<I>, F8<I>) {
    let zero = F8::zero();
    let cos = l.normal.dot(wi);
    let reflects = cos.gt(zero) & l.geometric.dot(wi).gt(zero);
    let f = l.diffuse.scale(F8::splat(FRAC_1_PI)).scale(cos);
    let f = V8::select(reflects, f, V8::zero());
    let pdf = F8::select(reflects, cos * F8::splat(FRAC_1_PI), zero);
    (reflects, f, pdf)
}

#[inline(always)]
fn shade8<I: Isa>(l: &Lanes<I>) -> Shaded<I> {
    let (zero, one) = (F8::zero(), F8::one());
    let origins = RayOrigins8::new(l.position, l.p_error, l.hit_normal);

    // The light sample: `AreaChoice::sample_from`, operation for operation.
    let [a, b, c] = l.vertices;
    let target = a.scale(l.b0) + b.scale(l.b1) + c.scale(one - l.b0 - l.b1);
    let to = target - l.position;
    let dist2 = to.dot(to);
    let mut found = l.light & dist2.gt(zero);
    let wi = over(to, dist2.sqrt());
    let n = (b - a).cross(c - a);
    let facing = -n.dot(wi);
    let cos_l = F8::select(l.two_sided, facing.abs(), facing) / n.dot(n).sqrt();
    found = found & cos_l.gt(F8::splat(1e-7));
    let pdf_light = l.p_choice * dist2 / (l.area * cos_l);
    // `SurfaceHit::spawn_ray_to(target)`, stopped short of the light.
    let origin = origins.toward(to);
    let d = target - origin;
    let length = d.dot(d).sqrt();
    let shadow_dir = over(d, length);
    let shadow_tmax = length * F8::splat(SHADOW_SHORT);
    let radiance = over(l.emission, pdf_light);
    // `light_samples`: the BSDF there, weighed against its own sampling.
    let (_, f, pdf_bsdf) = lambert(l, wi);
    let weighed = l.mis & pdf_light.gt(zero);
    let (a2, b2) = (pdf_light * pdf_light, pdf_bsdf * pdf_bsdf);
    let heuristic = F8::select((a2 + b2).le(zero), zero, a2 / (a2 + b2));
    let w = F8::select(weighed, heuristic, one);
    let shadow = found & any_positive(f);
    let shadow_brings = (f * radiance).scale(w);
    let shape = l.normal.dot(wi).max(zero) * F8::splat(FRAC_1_PI);
    let shadow_diffuse = V8::select(pdf_light.gt(zero), radiance.scale(w * shape), V8::zero());

    // The bounce: `sample_cosine_hemisphere` in `Frame::from_z(normal)`.
    let [dx, dy] = disc8(l.u_bounce);
    let dz = (one - (dx * dx + dy * dy)).max(zero).sqrt();
    let ns = l.normal;
    let sign = one.copysign(ns.z);
    let k = F8::splat(-1.0) / (sign + ns.z);
    let m = ns.x * ns.y * k;
    let fx = V8::new(one + sign * ns.x * ns.x * k, sign * m, -sign * ns.x);
    let fy = V8::new(m, sign + ns.y * ns.y * k, -ns.y);
    let dir = fx.scale(dx) + fy.scale(dy) + ns.scale(dz);
    let (reflects, f, pdf) = lambert(l, dir);
    let mut next = l.bounce & reflects & pdf.gt(zero) & pdf.lt(F8::splat(f32::INFINITY));
    let beta = l.beta * over(f, pdf);
    // Russian roulette.
    let q = max_element(beta).min(F8::splat(0.95));
    let killed = l.rr & (l.u_rr.ge(q) | q.is_nan());
    next = next.and_not(killed);
    let beta = V8::select(l.rr, over(beta, q), beta);

    Shaded {
        shadow,
        shadow_origin: origin,
        shadow_dir,
        shadow_tmax,
        shadow_brings,
        shadow_diffuse,
        next,
        next_origin: origins.toward(dir),
        next_dir: dir,
        next_beta: beta,
        next_pdf: pdf,
        next_shape: l.normal.dot(dir).max(zero) * F8::splat(FRAC_1_PI),
    }
}

/// The first `len` lanes' answers onto `out`, lane by lane.
#[inline(always)]
fn scatter<I: Isa>(s: &Shaded<I>, len: usize, out: &mut Vec<DiffuseResult>) {
    for i in 0..len {
        let shadow = s.shadow.lane(i).then(|| {
            let ray = Ray::segment(s.shadow_origin.lane(i), s.shadow_dir.lane(i), 0.0, s.shadow_tmax[i]);
            (ray, s.shadow_brings.lane(i), s.shadow_diffuse.lane(i))
        });
        let next = s.next.lane(i).then(|| {
            let ray = Ray::new(s.next_origin.lane(i), s.next_dir.lane(i));
            (ray, s.next_beta.lane(i), s.next_pdf[i], s.next_shape[i])
        });
        out.push(DiffuseResult { shadow, next });
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
