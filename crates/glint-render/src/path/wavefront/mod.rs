//! Wavefront path tracing: the camera samples of a band traced breadth first, one bounce of
//! every live path at a time (Laine, Karras and Aila, "Megakernels Considered Harmful:
//! Wavefront Path Tracing on GPUs", HPG 2013, as CPU renderers such as Mitsuba 3's LLVM
//! variants and Embree's stream mode run it).
//!
//! Each round:
//! 1. **trace**: the live paths, binned by direction octant (a counting sort: a packet of one
//!    octant walks the tree with one near/far plane choice), eight rays per packet query; in
//!    a scene of one small tree, whose packets take incoherent rays too
//!    (`World::packs_any_rays`), binned by octant and dominant axis, so that a packet's rays
//!    share the watertight test's axis order and its leaves test them in lanes;
//! 2. **shade**: every hit at once — emission with its MIS weight, the BSDF, the light samples
//!    of next-event estimation (queued as shadow rays with what each adds when unblocked), the
//!    next direction, Russian roulette; survivors are compacted into the next round's paths
//!    (the vertices on surfaces without delta lobes, in a scene whose lights the lanes take,
//!    are queued and shaded eight at a time in lanes: [`phong8`]);
//! 3. **shadows**: the round's shadow rays binned as the paths are and asked as any-hit
//!    packets;
//! 4. the paths that ended this round hand their radiance to their camera sample.
//!
//! The estimator is the recursive integrator's ([`super::integrator`]), vertex for vertex: the
//! camera chain to the guide vertex, the direct/indirect split there, plain path tracing with
//! MIS behind it. What changes is only the order of the work, and therefore which random
//! numbers a sub-path reads: a camera sample's stream is read by its camera chain, its guide
//! vertex and then its indirect path, as the recursive tracer reads it; the delta lobes a
//! guide vertex also follows (its mirror and its glass) run beside the indirect path and read
//! their own dimensions of the same stream (from [`LOBE_DIMENSIONS`] on). So on surfaces
//! without delta lobes both tracers draw the same numbers and agree up to the order of float
//! additions; elsewhere they agree in distribution (tests/path.rs compares them per pixel).
//! Every number is still `hash(pixel, sample, dimension, seed)`: no thread count or schedule
//! changes a bit.

mod phong8;

use super::Frame;
use super::bsdf::Bsdf;
use super::integrator::{
    Arrival, CameraSample, GuideGeometry, IndirectMode, bsdf_at, clamp_radiance, light_samples, phong_parts_at,
};
use crate::stats::RayCounts;
use crate::world::{SurfaceHit, World};
use glint_core::random::SampleStream;
use glint_core::{Ray, Rgb, Vec2, Vec3};
use phong8::{Budget, Guide, Kind, PhongResult, PhongVertex, SunShadow};

/// The stream dimensions of delta lobe `k` of a guide vertex start at `(k + 1) ·` this, far
/// beyond what any path reads (a few dimensions per bounce, bounces capped by
/// `glint_scene::limits`).
pub(super) const LOBE_DIMENSIONS: u64 = 1 << 32;

/// No tail: a shadow ray whose light goes straight to its camera sample.
const NO_TAIL: u32 = u32::MAX;

/// One camera sample to trace: pixel, sample index, whether it goes through the pixel centre,
/// and how its guide vertex treats the diffuse indirect light.
#[derive(Clone, Copy, Debug)]
pub(super) struct Request {
    pub x: usize,
    pub y: usize,
    pub index: u64,
    pub centre: bool,
    pub mode: IndirectMode,
}

/// A camera path on its way to its guide vertex (through mirrors and glass).
#[derive(Clone, Copy, Debug)]
struct CameraLeg {
    chain: u32,
    throughput: Rgb,
    /// Camera depth of the first hit plus the lengths of the chain after it.
    depth: f32,
    /// The primary ray's footprint, for sky filtering.
    cone: f32,
    mode: IndirectMode,
}

/// A path behind a guide vertex: the recursive tracer's `trace_path` loop state.
#[derive(Clone, Copy)]
struct TailLeg {
    tail: u32,
    beta: Rgb,
    /// Vertex number (after the guide vertex) of the ray's next hit.
    bounce: u32,
    /// The last vertex that samples light (the recursive tracer's `max_bounces` argument:
    /// under Mitsuba's budget it depends on the camera chain's length).
    max_bounces: u32,
    arrival: Arrival,
}

#[derive(Clone, Copy)]
enum Leg {
    Camera(CameraLeg),
    Tail(TailLeg),
}

/// A live path: its camera sample, the ray it traces next, its random stream.
#[derive(Clone, Copy)]
struct Path {
    slot: u32,
    ray: Ray,
    stream: SampleStream,
    leg: Leg,
}

/// The radiance a path behind a guide vertex gathers, and how it reaches its camera sample
/// when the path ends: `rest += to_rest · L`, `indirect += to_indirect · L`, with `L`
/// clamped first where `clamp` says (the recursive tracer's firefly clamp).
#[derive(Clone, Copy)]
struct Tail {
    slot: u32,
    li: Rgb,
    clamp: bool,
    to_rest: Rgb,
    to_indirect: f32,
}

/// A queued shadow ray and what it adds when nothing blocks it: to its camera sample's rest,
/// direct and indirect parts, or (with a tail) to that tail's radiance (`rest`).
#[derive(Clone, Copy)]
struct Shadow {
    ray: Ray,
    slot: u32,
    tail: u32,
    rest: Rgb,
    direct: Rgb,
    indirect: Rgb,
}

/// A vertex's answer from the lanes: its result, the scene's suns and its rays toward them.
type Answer<'r> = (&'r PhongResult, (&'r [(Vec3, Rgb)], &'r [SunShadow]));

/// Where the light samples of a vertex go.
#[derive(Clone, Copy)]
enum Dest {
    /// A guide vertex: its camera sample's direct light (`throughput`, and `albedo` to take
    /// the filtered part out when area light is filtered; `trace`: that part goes to the
    /// traced indirect buffer).
    Guide { slot: u32, throughput: Rgb, albedo: Rgb, trace: bool },
    /// A vertex behind it: its tail's radiance, times `beta`.
    Tail { tail: u32, beta: Rgb },
}

/// The wavefront tracer of one band: its queues ([`Queues`]) come from its worker thread and go
/// back to it when the tracer is dropped.
pub(super) struct Wavefront<'a> {
    world: &'a World,
    frame: &'a Frame,
    pub counts: RayCounts,
    q: Queues,
    batch: Batch,
    /// The suns the lanes take (`LightSet::suns`; empty when the batch is off).
    suns: Vec<(Vec3, Rgb)>,
    /// How rays are binned before they are traced.
    bins: Bins,
}

/// How a round's vertices on surfaces without delta lobes are shaded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Batch {
    /// Each where it comes (a scene with lights the lanes do not take: points, spots, more
    /// than `lights::SUNS` suns).
    Off,
    /// Queued, then eight at a time in lanes ([`phong8`]).
    Lanes,
    /// Queued, then one at a time by the scalar code (the lanes' oracle: the same order).
    Scalar,
}

/// A worker thread's queues between the wavefront tracers it makes (one per band): a fresh
/// tracer's empty vectors grew by doubling in every band (copies and fresh pages, ~3 % of a
/// Sponza path frame). Every queue is cleared before use, so what a band left in them never
/// reaches the next.
#[derive(Default)]
struct Queues {
    paths: Vec<Path>,
    next: Vec<Path>,
    hits: Vec<Option<SurfaceHit>>,
    tails: Vec<Tail>,
    ended: Vec<u32>,
    shadows: Vec<Shadow>,
    order: Vec<u32>,
    phong: Vec<PhongVertex>,
    sun_out: Vec<SunShadow>,
}

thread_local! {
    static QUEUES: std::cell::RefCell<Queues> = std::cell::RefCell::new(Queues::default());
}

impl<'a> Wavefront<'a> {
    /// A tracer of `frame`; `lanes`: its vertices without delta lobes shaded eight at a time
    /// (else one at a time, in the same order).
    pub(super) fn new(world: &'a World, frame: &'a Frame, lanes: bool) -> Self {
        let q = QUEUES.try_with(|q| q.take()).unwrap_or_default();
        let suns = frame.lights.suns();
        let batch = match (&suns, lanes) {
            (None, _) => Batch::Off,
            (Some(_), true) => Batch::Lanes,
            (Some(_), false) => Batch::Scalar,
        };
        let bins = if world.packs_any_rays() { Bins::OctantAndAxis } else { Bins::Octant };
        Self { world, frame, counts: RayCounts::default(), q, batch, suns: suns.unwrap_or_default(), bins }
    }

    /// Trace the camera samples `requests`; `out[i]` is request `i`'s offset in its pixel
    /// ([`super::Frame::sample`]) and sample.
    pub(super) fn run(&mut self, requests: &[Request], out: &mut Vec<(Vec2, CameraSample)>) {
        out.clear();
        self.q.paths.clear();
        self.q.tails.clear();
        for (slot, r) in requests.iter().enumerate() {
            let (offset, ray, stream) = self.frame.camera_ray(r.x, r.y, r.index, r.centre);
            let cos = ray.dir.dot(self.frame.forward);
            let cone = self.frame.centre_cone * cos * cos.sqrt();
            out.push((offset, CameraSample::default()));
            let leg = CameraLeg { chain: 0, throughput: Rgb::ONE, depth: 0.0, cone, mode: r.mode };
            self.q.paths.push(Path { slot: slot as u32, ray, stream, leg: Leg::Camera(leg) });
        }
        // Camera rays come in pixel order, already coherent: traced as they are.
        let mut binned = true;
        while !self.q.paths.is_empty() {
            if !binned {
                bin_paths(&self.q.paths, &mut self.q.next, self.bins);
                std::mem::swap(&mut self.q.paths, &mut self.q.next);
            }
            binned = false;
            self.trace();
            self.q.next.clear();
            self.q.shadows.clear();
            self.q.ended.clear();
            // The round's paths and hits are read in place (taken out of the queues while the
            // shading pushes onto the others): copying each ~100-byte path and hit out first
            // was a tenth of a Cornell box frame.
            let (paths, hits) = (std::mem::take(&mut self.q.paths), std::mem::take(&mut self.q.hits));
            for (i, (path, hit)) in paths.iter().zip(&hits).enumerate() {
                match &path.leg {
                    Leg::Camera(leg) => self.shade_camera(i as u32, path, *leg, hit.as_ref(), out),
                    Leg::Tail(leg) => self.shade_tail(i as u32, path, *leg, hit.as_ref()),
                }
            }
            self.shade_phong(&paths, &hits, out);
            (self.q.paths, self.q.hits) = (paths, hits);
            self.trace_shadows(out);
            for &t in &self.q.ended {
                let tail = &self.q.tails[t as usize];
                let li = if tail.clamp { clamp_radiance(tail.li, self.frame.params.clamp_indirect) } else { tail.li };
                let s = &mut out[tail.slot as usize].1;
                s.rest += tail.to_rest * li;
                s.indirect += li * tail.to_indirect;
            }
            std::mem::swap(&mut self.q.paths, &mut self.q.next);
        }
    }

    /// Closest hits of every live path, eight rays per packet query.
    fn trace(&mut self) {
        let n = self.q.paths.len();
        self.q.hits.clear();
        self.q.hits.resize(n, None);
        let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
        let mut found = [None; 8];
        for start in (0..n).step_by(8) {
            let len = (n - start).min(8);
            for (j, r) in rays.iter_mut().enumerate() {
                // A short last packet repeats its last ray (the same answer, ignored).
                *r = self.q.paths[start + j.min(len - 1)].ray;
            }
            self.world.intersect8(&rays, &mut found);
            self.q.hits[start..start + len].copy_from_slice(&found[..len]);
        }
    }

    /// One vertex of a camera chain: the recursive tracer's `camera_sample_from` loop body.
    fn shade_camera(
        &mut self,
        index: u32,
        path: &Path,
        mut leg: CameraLeg,
        hit: Option<&SurfaceHit>,
        out: &mut [(Vec2, CameraSample)],
    ) {
        let slot = path.slot;
        if leg.chain == 0 {
            self.counts.primary += 1;
        } else {
            self.counts.secondary += 1;
        }
        let params = &self.frame.params;
        let sample = &mut out[slot as usize].1;
        let Some(hit) = hit else {
            // Mitsuba's budget comes with Mitsuba's point lookups of the sky.
            let sky = if leg.chain == 0 && params.max_depth.is_none() {
                self.world.sky().radiance_filtered(path.ray.dir, leg.cone)
            } else {
                self.world.sky().radiance(path.ray.dir)
            };
            if leg.chain > 0 || !params.hide_emitters {
                sample.rest += leg.throughput * sky;
            }
            return;
        };
        sample.covered = true;
        leg.depth = if leg.chain == 0 { self.frame.camera.depth(hit.position) } else { leg.depth + hit.t };
        // A guide vertex without delta lobes needs only the BSDF's parts: it is not built. (The
        // lanes trace no glossy-only tail: a lookup guide vertex with a glossy lobe is shaded
        // here.)
        let phong = if self.batch == Batch::Off { None } else { phong_parts_at(self.world, hit, path.ray.dir) };
        let phong = phong.filter(|p| leg.mode == IndirectMode::Trace || p.glossy <= 0.0);
        // Read in place: moving the BSDF out of the pair copied its 488 bytes (a Mitsuba
        // scene's Cornell box, whose BSDFs are the physically based model: 2–3 % faster).
        let shaded = phong.is_none().then(|| bsdf_at(self.world, hit, path.ray.dir));
        let emission = shaded.as_ref().map_or_else(|| self.world.emitted(hit, -path.ray.dir), |s| s.1);
        if leg.chain > 0 || !params.hide_emitters {
            sample.rest += leg.throughput * emission;
        }
        // Mitsuba's budget: vertex `chain` samples light and continues only while vertex
        // `chain + 1` is within `max_depth`; what follows the guide vertex gets the rest.
        let bounces = match params.max_depth {
            Some(l) if leg.chain + 1 >= l => return,
            Some(l) => l - 2 - leg.chain,
            None => params.max_bounces,
        };
        let last_chain = params.max_depth.map_or(params.max_chain, |l| l.saturating_sub(1));
        // The chain's lobe choice and direction: drawn only where a BSDF with delta lobes reads
        // them (a vertex without them steps over their dimensions: two Sobol draws a path).
        let mut stream = path.stream;
        stream.skip(3);
        if let Some(parts) = phong {
            // Without delta lobes a BSDF is never delta-dominant.
            let albedo = leg.throughput * parts.diffuse;
            out[slot as usize].1.albedo = albedo;
            let (throughput, trace) = (leg.throughput, leg.mode == IndirectMode::Trace);
            let guide = Guide { throughput, albedo, bounces, trace, entry: stream.dimension() };
            let budget = Budget { mitsuba: params.max_depth.is_some(), rr_start: params.rr_start };
            self.q.phong.push(PhongVertex::guide(index, guide, parts, stream, budget, params.filtered));
            out[slot as usize].1.guide = Some(GuideGeometry { normal: parts.normal, depth: leg.depth });
            return;
        }
        let Some((bsdf, _)) = shaded.as_ref() else { return };
        let (u_lobe, u) = {
            let mut s = path.stream;
            (s.next_1d(), s.next_2d())
        };
        let with_delta = if bsdf.is_delta_dominant() {
            if u_lobe >= bsdf.p_non_delta() {
                // Through the mirror or the glass, while the chain may grow.
                let Some(s) = bsdf.sample_delta(u_lobe, u) else { return };
                leg.throughput *= s.weight;
                if leg.chain < last_chain {
                    leg.chain += 1;
                    let ray = hit.spawn_ray(s.wi);
                    self.q.next.push(Path { slot, ray, stream, leg: Leg::Camera(leg) });
                }
                return;
            }
            // The non-delta part was chosen: the guide vertex, its delta lobes accounted.
            leg.throughput /= bsdf.p_non_delta();
            false
        } else {
            true
        };
        self.guide_vertex(slot, hit, bsdf, &leg, with_delta, bounces, stream, out);
        out[slot as usize].1.guide = Some(GuideGeometry { normal: bsdf.normal, depth: leg.depth });
    }

    /// The guide vertex: its direct light (queued), its indirect path and, when it follows
    /// them, its delta lobes (new tails, whose last light-sampling vertex is `bounces`).
    #[allow(clippy::too_many_arguments)]
    fn guide_vertex(
        &mut self,
        slot: u32,
        hit: &SurfaceHit,
        bsdf: &Bsdf,
        leg: &CameraLeg,
        with_delta: bool,
        bounces: u32,
        mut stream: SampleStream,
        out: &mut [(Vec2, CameraSample)],
    ) {
        let albedo = leg.throughput * bsdf.diffuse;
        out[slot as usize].1.albedo = albedo;
        let throughput = leg.throughput;
        let base = stream;
        let params = &self.frame.params;
        if bsdf.has_non_delta() {
            let trace = leg.mode == IndirectMode::Trace;
            // Mitsuba's budget: the direct light weighed against the BSDF sample below (whose
            // density is the non-delta part's alone), as its path integrator weighs them.
            let mitsuba = params.max_depth.is_some() && !params.filtered;
            let mis = mitsuba.then(|| 1.0 / bsdf.p_non_delta().max(1e-12));
            self.light_samples(hit, bsdf, &mut stream, mis, Dest::Guide { slot, throughput, albedo, trace });
            if bounces > 0 || mitsuba && trace {
                let u_lobe = stream.next_1d();
                let u = stream.next_2d();
                match leg.mode {
                    IndirectMode::Trace => {
                        if let Some(s) = bsdf.sample_non_delta(u_lobe, u) {
                            let arrival =
                                Arrival { pdf: s.pdf, delta: false, after_guide: !mitsuba, from: hit.position };
                            let tail = Tail {
                                slot,
                                li: Rgb::ZERO,
                                clamp: true,
                                to_rest: throughput * (bsdf.eval_glossy_cos(s.wi) / s.pdf),
                                to_indirect: bsdf.diffuse_shape(s.wi) / s.pdf,
                            };
                            self.start_tail(tail, hit.spawn_ray(s.wi), stream, (1, bounces), arrival);
                        }
                    }
                    IndirectMode::Lookup => {
                        if let Some((wi, w)) = bsdf.sample_glossy_only(u_lobe, u) {
                            let arrival =
                                Arrival { pdf: bsdf.pdf(wi), delta: false, after_guide: true, from: hit.position };
                            let tail =
                                Tail { slot, li: Rgb::ZERO, clamp: true, to_rest: throughput * w, to_indirect: 0.0 };
                            self.start_tail(tail, hit.spawn_ray(wi), stream, (1, bounces), arrival);
                        }
                    }
                }
            }
        }
        if with_delta {
            // glint's budget does not count delta bounces; Mitsuba's does.
            let first = u32::from(params.max_depth.is_some());
            for (k, lobe) in bsdf.delta_lobes().into_iter().enumerate() {
                let Some((dir, weight)) = lobe else { continue };
                let arrival = Arrival { pdf: 0.0, delta: true, after_guide: false, from: hit.position };
                let tail = Tail { slot, li: Rgb::ZERO, clamp: false, to_rest: throughput * weight, to_indirect: 0.0 };
                let lobe_stream = base.at_dimension(LOBE_DIMENSIONS * (k as u64 + 1));
                self.start_tail(tail, hit.spawn_ray(dir), lobe_stream, (first, bounces), arrival);
            }
        }
    }

    /// A new path behind a guide vertex; `bounces`: the vertex number of its first hit and its
    /// last light-sampling vertex.
    fn start_tail(&mut self, tail: Tail, ray: Ray, stream: SampleStream, bounces: (u32, u32), arrival: Arrival) {
        let id = self.q.tails.len() as u32;
        self.q.tails.push(tail);
        let (bounce, max_bounces) = bounces;
        let leg = TailLeg { tail: id, beta: Rgb::ONE, bounce, max_bounces, arrival };
        self.q.next.push(Path { slot: tail.slot, ray, stream, leg: Leg::Tail(leg) });
    }

    /// One vertex behind a guide vertex (path `index` of the round): the recursive tracer's
    /// `trace_path` loop body. One without delta lobes, in a scene whose lights the lanes
    /// take, is queued for [`Wavefront::shade_phong`] after its emission is taken.
    fn shade_tail(&mut self, index: u32, path: &Path, leg: TailLeg, hit: Option<&SurfaceHit>) {
        self.counts.secondary += 1;
        let frame = self.frame;
        let (params, lights) = (frame.params, &frame.lights);
        let Some(hit) = hit else {
            let weight = leg.arrival.emission_weight(lights.pdf_sky(self.world, path.ray.dir));
            if weight > 0.0 {
                self.q.tails[leg.tail as usize].li += leg.beta * self.world.sky().radiance(path.ray.dir) * weight;
            }
            self.q.ended.push(leg.tail);
            return;
        };
        let phong = if self.batch == Batch::Off { None } else { phong_parts_at(self.world, hit, path.ray.dir) };
        // A vertex without delta lobes needs only the BSDF's parts: it is not built.
        let shaded = phong.is_none().then(|| bsdf_at(self.world, hit, path.ray.dir));
        let emission = shaded.as_ref().map_or_else(|| self.world.emitted(hit, -path.ray.dir), |s| s.1);
        if emission.max_element() > 0.0 {
            let weight = leg.arrival.emission_weight(lights.pdf_surface(leg.arrival.from, path.ray.dir, hit));
            self.q.tails[leg.tail as usize].li += leg.beta * emission * weight;
        }
        match (phong, shaded.as_ref()) {
            (Some(parts), _) => {
                let budget = Budget { mitsuba: params.max_depth.is_some(), rr_start: params.rr_start };
                self.q.phong.push(PhongVertex::tail(index, path, &leg, parts, budget));
            }
            (None, Some((bsdf, _))) => self.continue_tail(path, leg, hit, bsdf),
            (None, None) => {}
        }
    }

    /// A vertex behind a guide vertex after its emission: its light samples, its bounce.
    fn continue_tail(&mut self, path: &Path, mut leg: TailLeg, hit: &SurfaceHit, bsdf: &Bsdf) {
        let params = self.frame.params;
        let mut stream = path.stream;
        // Mitsuba's budget follows the last light-sampling vertex's BSDF one more segment, for
        // the emission it finds (MIS-weighted); glint's does not trace it.
        let mitsuba = params.max_depth.is_some();
        if bsdf.has_non_delta() && leg.bounce <= leg.max_bounces {
            // MIS against BSDF sampling, except at the last vertex (its BSDF ray is not traced).
            let mis = leg.bounce < leg.max_bounces || mitsuba;
            self.light_samples(
                hit,
                bsdf,
                &mut stream,
                mis.then_some(1.0),
                Dest::Tail { tail: leg.tail, beta: leg.beta },
            );
        }
        if leg.bounce >= leg.max_bounces + u32::from(mitsuba) {
            self.q.ended.push(leg.tail);
            return;
        }
        let u_lobe = stream.next_1d();
        let u = stream.next_2d();
        let Some(s) = bsdf.sample(u_lobe, u) else {
            self.q.ended.push(leg.tail);
            return;
        };
        leg.beta *= s.weight;
        leg.bounce += 1;
        if leg.bounce > params.rr_start {
            let q = leg.beta.max_element().min(0.95);
            if stream.next_1d() >= q || q.is_nan() {
                self.q.ended.push(leg.tail);
                return;
            }
            leg.beta /= q;
        }
        leg.arrival = Arrival { pdf: s.pdf, delta: s.delta, after_guide: false, from: hit.position };
        self.q.next.push(Path { slot: path.slot, ray: hit.spawn_ray(s.wi), stream, leg: Leg::Tail(leg) });
    }

    /// The round's queued vertices without delta lobes (`paths[v.index]`, `hits[v.index]`):
    /// their shadow rays, next paths and new tails queued in their order, as `continue_tail`
    /// and `guide_vertex` would have. `out`: the camera samples (the scalar oracle's guide
    /// vertices write their albedo again, the same value).
    fn shade_phong(&mut self, paths: &[Path], hits: &[Option<SurfaceHit>], out: &mut [(Vec2, CameraSample)]) {
        if self.q.phong.is_empty() {
            return;
        }
        let mut vertices = std::mem::take(&mut self.q.phong);
        if self.batch == Batch::Scalar {
            for v in &vertices {
                let path = &paths[v.index as usize];
                let Some(hit) = &hits[v.index as usize] else { continue };
                match (&v.kind, path.leg) {
                    (Kind::Tail, Leg::Tail(leg)) => self.continue_tail(path, leg, hit, &v.bsdf()),
                    (Kind::Guide(g), Leg::Camera(leg)) => {
                        // `guide_vertex` reads the leg's throughput and mode, as queued.
                        let stream = path.stream.at_dimension(g.entry);
                        self.guide_vertex(path.slot, hit, &v.bsdf(), &leg, true, g.bounces, stream, out);
                    }
                    _ => {}
                }
            }
        } else {
            let mut sun_rays = std::mem::take(&mut self.q.sun_out);
            let suns = std::mem::take(&mut self.suns);
            let lights = (self.world, &self.frame.lights, &suns[..]);
            phong8::shade(lights, (paths, hits), &vertices, &mut sun_rays, |v, r, sun| {
                let path = &paths[v.index as usize];
                let Some(hit) = &hits[v.index as usize] else { return };
                let sun = (&suns[..], sun);
                match (&v.kind, &path.leg) {
                    (Kind::Tail, Leg::Tail(leg)) => self.tail_result(path, *leg, hit, v, (&r, sun)),
                    (Kind::Guide(g), _) => self.guide_result(path, hit, g, v, (&r, sun)),
                    _ => {}
                }
            });
            self.suns = suns;
            self.q.sun_out = sun_rays;
        }
        vertices.clear();
        self.q.phong = vertices;
    }

    /// A vertex's shadow rays from the lanes, queued as `light_samples` queues them: its
    /// suns' (`suns`: the scene's suns, then the vertex's rays toward them), then the chosen
    /// light's.
    #[inline(always)]
    fn queue_shadows(&mut self, (r, suns): Answer, dest: Dest) {
        let filter_direct = self.frame.params.filter_area_direct;
        for s in suns.1 {
            self.counts.shadow += 1;
            let ray = Ray::new(s.origin, suns.0[s.sun as usize].0);
            self.q.shadows.push(shadow_to(dest, filter_direct, ray, s.brings, Rgb::ZERO));
        }
        if let Some((ray, c, diffuse)) = r.shadow {
            self.counts.shadow += 1;
            self.q.shadows.push(shadow_to(dest, filter_direct, ray, c, diffuse));
        }
    }

    /// A tail vertex's lanes answer queued as `continue_tail` queues it.
    #[inline(always)]
    fn tail_result(&mut self, path: &Path, leg: TailLeg, hit: &SurfaceHit, v: &PhongVertex, answer: Answer) {
        self.queue_shadows(answer, Dest::Tail { tail: leg.tail, beta: leg.beta });
        let r = answer.0;
        let Some(next) = r.next else {
            self.q.ended.push(leg.tail);
            return;
        };
        let arrival = Arrival { pdf: next.pdf, delta: false, after_guide: false, from: hit.position };
        let leg = TailLeg { beta: next.beta, bounce: leg.bounce + 1, arrival, ..leg };
        self.q.next.push(Path { slot: path.slot, ray: next.ray, stream: v.stream(path), leg: Leg::Tail(leg) });
    }

    /// A guide vertex's lanes answer queued as `guide_vertex` queues it.
    #[inline(always)]
    fn guide_result(&mut self, path: &Path, hit: &SurfaceHit, g: &Guide, v: &PhongVertex, answer: Answer) {
        let params = self.frame.params;
        let (slot, throughput, trace) = (path.slot, g.throughput, g.trace);
        self.queue_shadows(answer, Dest::Guide { slot, throughput, albedo: g.albedo, trace });
        let r = answer.0;
        if let Some(next) = r.next {
            let mitsuba = params.max_depth.is_some() && !params.filtered;
            let arrival = Arrival { pdf: next.pdf, delta: false, after_guide: !mitsuba, from: hit.position };
            let to_rest = throughput * (Rgb::splat(next.glossy) / next.pdf);
            let tail = Tail { slot, li: Rgb::ZERO, clamp: true, to_rest, to_indirect: next.shape / next.pdf };
            self.start_tail(tail, next.ray, v.stream(path), (1, g.bounces), arrival);
        }
    }

    /// Next-event estimation at a vertex: its shadow rays queued with what each adds.
    fn light_samples(
        &mut self,
        hit: &SurfaceHit,
        bsdf: &Bsdf,
        stream: &mut SampleStream,
        mis: Option<f32>,
        dest: Dest,
    ) {
        let frame = self.frame;
        let filter_direct = frame.params.filter_area_direct;
        let shadows = &mut self.q.shadows;
        light_samples(&frame.lights, self.world, hit, bsdf, stream, mis, &mut self.counts, |ray, c, diffuse| {
            shadows.push(shadow_to(dest, filter_direct, *ray, c, diffuse));
        });
    }

    /// The round's shadow rays, binned as the paths are, as any-hit packets; the unblocked
    /// ones add their light.
    fn trace_shadows(&mut self, out: &mut [(Vec2, CameraSample)]) {
        let n = self.q.shadows.len();
        if n == 0 {
            return;
        }
        bin_order(self.q.shadows.iter().map(|s| s.ray.dir), &mut self.q.order, self.bins);
        let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
        let mut blocked = [false; 8];
        for start in (0..n).step_by(8) {
            let len = (n - start).min(8);
            for (j, r) in rays.iter_mut().enumerate() {
                *r = self.q.shadows[self.q.order[start + j.min(len - 1)] as usize].ray;
            }
            self.world.occluded8(&rays, &mut blocked);
            for (j, &b) in blocked[..len].iter().enumerate() {
                if b {
                    continue;
                }
                let s = &self.q.shadows[self.q.order[start + j] as usize];
                if s.tail == NO_TAIL {
                    let sample = &mut out[s.slot as usize].1;
                    sample.rest += s.rest;
                    sample.direct += s.direct;
                    sample.indirect += s.indirect;
                } else {
                    self.q.tails[s.tail as usize].li += s.rest;
                }
            }
        }
    }
}

/// The queued shadow ray of a light sample that brings `c` (its diffuse part demodulated:
/// `diffuse`) to `dest`; `filter_direct`: a guide vertex's filtered part of the direct light
/// leaves the unfiltered sum for the traced indirect buffer.
#[inline]
fn shadow_to(dest: Dest, filter_direct: bool, ray: Ray, c: Rgb, diffuse: Rgb) -> Shadow {
    match dest {
        Dest::Guide { slot, throughput, albedo, trace } => {
            let filtered = if filter_direct { diffuse } else { Rgb::ZERO };
            let direct = throughput * c - albedo * filtered;
            let indirect = if trace { filtered } else { Rgb::ZERO };
            Shadow { ray, slot, tail: NO_TAIL, rest: direct, direct, indirect }
        }
        Dest::Tail { tail, beta } => {
            Shadow { ray, slot: 0, tail, rest: beta * c, direct: Rgb::ZERO, indirect: Rgb::ZERO }
        }
    }
}

/// How a round's rays are binned before they are traced: a stable counting sort by a key of
/// their direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Bins {
    /// By direction octant (8 bins): a packet of one octant walks the tree with one near/far
    /// plane choice. Finer bins made Sponza's frame slower (its packets are coherent rays, in
    /// pixel order within a bin).
    Octant,
    /// By octant and dominant axis (24 bins): for a tree whose packets take incoherent rays,
    /// whose leaves test rays in lanes only when they share the watertight test's axis order
    /// (Mitsuba's Cornell box: BENCHMARKS.md §13.11).
    OctantAndAxis,
}

impl Bins {
    const MAX: usize = 24;

    #[inline]
    fn of(self, d: Vec3) -> usize {
        let octant = d.x.is_sign_negative() as usize
            | (d.y.is_sign_negative() as usize) << 1
            | (d.z.is_sign_negative() as usize) << 2;
        match self {
            Bins::Octant => octant,
            Bins::OctantAndAxis => octant * 3 + glint_accel::primitives::dominant_axis(d),
        }
    }
}

impl Drop for Wavefront<'_> {
    /// The queues go back to the thread for its next tracer.
    fn drop(&mut self) {
        let queues = std::mem::take(&mut self.q);
        // During the thread's teardown there is nowhere to keep them: they are freed.
        let _ = QUEUES.try_with(|q| q.replace(queues));
    }
}

/// `out` = `paths` stably binned by their rays' directions.
fn bin_paths(paths: &[Path], out: &mut Vec<Path>, bins: Bins) {
    let mut start = [0usize; Bins::MAX + 1];
    for p in paths {
        start[bins.of(p.ray.dir) + 1] += 1;
    }
    for o in 1..=Bins::MAX {
        start[o] += start[o - 1];
    }
    out.clear();
    let Some(&first) = paths.first() else { return };
    out.resize(paths.len(), first);
    for p in paths {
        let o = bins.of(p.ray.dir);
        out[start[o]] = *p;
        start[o] += 1;
    }
}

/// `order` = the indices of `dirs` stably binned by direction.
fn bin_order(dirs: impl Iterator<Item = Vec3> + Clone, order: &mut Vec<u32>, bins: Bins) {
    let mut start = [0usize; Bins::MAX + 1];
    let mut n = 0;
    for d in dirs.clone() {
        start[bins.of(d) + 1] += 1;
        n += 1;
    }
    for o in 1..=Bins::MAX {
        start[o] += start[o - 1];
    }
    order.clear();
    order.resize(n, 0);
    for (i, d) in dirs.enumerate() {
        let o = bins.of(d);
        order[start[o]] = i as u32;
        start[o] += 1;
    }
}
