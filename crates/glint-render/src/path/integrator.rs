//! One camera sample of the path tracer, split the way DESIGN.md §2 asks.
//!
//! The camera ray follows mirrors and glass (delta-dominant vertices: a delta lobe is chosen
//! with its probability) to the first non-delta vertex, the *guide vertex*. There:
//! - **direct** light: one light sample (next-event estimation from the lights alone, the same
//!   way for every sample, no MIS);
//! - **diffuse indirect**: one ray from the non-delta BSDF; the incident light it brings,
//!   demodulated (`L · (cos/π) / pdf`, so that `ρd ×` it is the diffuse part), goes to the
//!   indirect buffer that the filter smooths; in lookup mode it is not traced here at all;
//! - **glossy indirect** (the Phong lobe's share of that same ray, or a glossy-only ray in
//!   lookup mode) and the **delta lobes** of a mostly-diffuse surface (traced
//!   deterministically) are added unfiltered.
//!
//! Deeper vertices are plain path tracing: one light sample with multiple importance sampling
//! (power heuristic) against BSDF sampling, Russian roulette after `rr_start` bounces. The
//! first vertex after the guide vertex adds no emission that next-event estimation could have
//! sampled (no double counting); emitters NEE cannot aim at (spheres, planes) count in full.

use super::bsdf::{Bsdf, PhongParts};
use super::lights::{LightSet, power_heuristic};
use super::shading::{Physical, lambertian_at};
use crate::stats::RayCounts;
use crate::whitted::optics::reflect;
use crate::world::{SurfaceHit, World};
use glint_core::colour::luminance;
use glint_core::random::SampleStream;
use glint_core::{Ray, Rgb, Vec3};

#[derive(Clone, Copy, Debug)]
pub struct PathParams {
    /// Indirect bounces after the guide vertex (0 = direct light only).
    pub max_bounces: u32,
    /// Longest chain of mirror/glass vertices the camera ray follows.
    pub max_chain: u32,
    /// Russian roulette from this bounce on.
    pub rr_start: u32,
    /// Largest component of the indirect radiance a sample may bring to its guide vertex
    /// (firefly clamp; biased, darkens caustics); infinite = off.
    pub clamp_indirect: f32,
    /// Route the diffuse part of the sampled (area and sky) direct light through the filter
    /// too (an extension of the paper: its direct light came from point lights).
    pub filter_area_direct: bool,
    /// Mitsuba's total vertex budget ([`super::PathSettings::max_depth`]).
    pub max_depth: Option<u32>,
    /// The frame is filtered (guides and lookups): the guide vertex keeps glint's split
    /// (light sampling alone for its direct light) even under Mitsuba's budget.
    pub filtered: bool,
    /// Emitters and the sky seen directly from the camera add nothing (Mitsuba's `hide_emitters`).
    pub hide_emitters: bool,
}

/// Scale `c` down so that its largest component is at most `limit`.
#[inline]
pub(super) fn clamp_radiance(c: Rgb, limit: f32) -> Rgb {
    let m = c.max_element();
    if m > limit { c * (limit / m) } else { c }
}

/// Whether the guide vertex traces its diffuse indirect light or takes it from the filtered map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IndirectMode {
    Trace,
    Lookup,
}

/// Geometry of a guide vertex (the filter's guide and the lookup's similarity).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GuideGeometry {
    /// Shading normal on the viewer's side.
    pub normal: Vec3,
    /// Camera depth of the first hit plus the lengths of the delta chain after it.
    pub depth: f32,
}

/// What one camera sample found.
#[derive(Clone, Copy, Debug, Default)]
pub struct CameraSample {
    /// Everything except the diffuse indirect light at the guide vertex: emission and sky
    /// seen along the camera chain, direct light, glossy indirect, delta lobes.
    pub rest: Rgb,
    pub direct: Rgb,
    /// Chain throughput × ρd at the guide vertex (zero without one).
    pub albedo: Rgb,
    /// Demodulated diffuse indirect light (traced mode only).
    pub indirect: Rgb,
    pub guide: Option<GuideGeometry>,
    /// The primary ray hit a surface.
    pub covered: bool,
}

/// What [`CameraSample::bound`] did to a sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleBound {
    /// Every value was finite and within [`MAX_SAMPLE_RADIANCE`].
    Within,
    /// Some radiance was finite but above the bound, and was clamped to it.
    Clamped,
    /// Some value was NaN or infinite: the sample must be dropped.
    NonFinite,
}

use crate::film::MAX_SAMPLE_RADIANCE;

impl CameraSample {
    pub fn is_finite(&self) -> bool {
        self.rest.is_finite() && self.direct.is_finite() && self.albedo.is_finite() && self.indirect.is_finite()
    }

    /// Check the sample and clamp its radiance (and the albedo weight that multiplies it) to
    /// [`MAX_SAMPLE_RADIANCE`] per channel, so that `rest + albedo · indirect` and every sum of
    /// samples stay finite.
    pub fn bound(&mut self) -> SampleBound {
        if !self.is_finite() {
            return SampleBound::NonFinite;
        }
        let mut clamped = false;
        for v in [&mut self.rest, &mut self.direct, &mut self.indirect] {
            if v.max_element() > MAX_SAMPLE_RADIANCE {
                *v = v.min(Rgb::splat(MAX_SAMPLE_RADIANCE));
                clamped = true;
            }
        }
        // A throughput weight above 1e3 times a clamped radiance could still pass the bound.
        let product = self.albedo * self.indirect;
        if product.max_element() > MAX_SAMPLE_RADIANCE {
            let scale = MAX_SAMPLE_RADIANCE / product.max_element();
            self.indirect *= scale;
            clamped = true;
        }
        if clamped { SampleBound::Clamped } else { SampleBound::Within }
    }

    /// This sample [bounded](CameraSample::bound), counted in `clamped` when it was clamped;
    /// None, counted in `rejected`, when it must be dropped.
    pub fn admitted(mut self, rejected: &mut u64, clamped: &mut u64) -> Option<CameraSample> {
        match self.bound() {
            SampleBound::NonFinite => {
                *rejected += 1;
                return None;
            }
            SampleBound::Clamped => *clamped += 1,
            SampleBound::Within => {}
        }
        Some(self)
    }
}

/// How the previous vertex sampled the ray that arrives at the current one (for MIS).
#[derive(Clone, Copy)]
pub(super) struct Arrival {
    pub(super) pdf: f32,
    pub(super) delta: bool,
    /// Right after the guide vertex: emitters that NEE samples add nothing.
    pub(super) after_guide: bool,
    pub(super) from: Vec3,
}

impl Arrival {
    /// The MIS weight of emission found along the arriving ray, whose light-sampling pdf is
    /// `p_light` (None: next-event estimation cannot sample that emitter). Right after the
    /// guide vertex, sampled emitters add nothing (the guide vertex's light sample has them).
    #[inline]
    pub(super) fn emission_weight(&self, p_light: Option<f32>) -> f32 {
        match (self.delta, p_light) {
            (true, _) | (false, None) => 1.0,
            (false, Some(_)) if self.after_guide => 0.0,
            (false, Some(p_light)) => power_heuristic(self.pdf, p_light),
        }
    }
}

pub struct Integrator<'a> {
    pub world: &'a World,
    pub lights: &'a LightSet,
    pub params: PathParams,
    pub counts: RayCounts,
}

/// Orient a hit toward the ray it was found by; returns (entering, ng, ns, wo).
#[inline]
fn orient(hit: &SurfaceHit, dir: Vec3) -> (bool, Vec3, Vec3, Vec3) {
    let wo = -dir;
    let entering = hit.geometric_normal.dot(wo) >= 0.0;
    if entering {
        (true, hit.geometric_normal, hit.shading_normal, wo)
    } else {
        (false, -hit.geometric_normal, -hit.shading_normal, wo)
    }
}

/// The BSDF at `hit` seen along `dir`, and the radiance the surface emits back along it.
#[inline]
pub(super) fn bsdf_at(world: &World, hit: &SurfaceHit, dir: Vec3) -> (Bsdf, Rgb) {
    let m = world.material(hit.material);
    let (entering, ng, ns, wo) = orient(hit, dir);
    let emitted = world.emitted(hit, wo);
    // A physically based model when the material names one (Scene validation bounds its tree
    // to what a Mixture holds; should one not fit, the Phong reading stands in).
    if let Some(root) = m.bsdf {
        // Mitsuba's `diffuse` alone (most of a Mitsuba scene's surfaces) skips the general
        // model's frame and mixture (a quarter of a Cornell box frame from its XML).
        if let Some((rho, normal)) = lambertian_at(world, hit, dir, root) {
            return (Bsdf::lambertian(rho, normal), emitted);
        }
        if let Some(physical) = Physical::at(world, hit, dir, root) {
            return (Bsdf::physical(physical, ng), emitted);
        }
    }
    (Bsdf::new(m, world.albedo(hit), wo, ns, ng, entering), emitted)
}

/// The [`PhongParts`] of the BSDF [`bsdf_at`] builds at `hit` (seen along `dir`) where that
/// BSDF has no delta lobe and no physically based model, without building it: Mitsuba's
/// `diffuse` read by `lambertian_at`, and the Phong reading of a material with no mirror, no
/// glass and no Fresnel term (its diffuse and glossy lobes). `Some` only where
/// `bsdf_at(..).0.phong_parts()` is `Some`, with its values (the wavefront queues these
/// vertices for shading in lanes; building the ~500-byte BSDF and reading its fields back
/// stalled on store forwarding). `None` is also allowed where it would be `Some`.
#[inline]
pub(super) fn phong_parts_at(world: &World, hit: &SurfaceHit, dir: Vec3) -> Option<PhongParts> {
    let m = world.material(hit.material);
    if let Some(root) = m.bsdf {
        let (rho, normal) = lambertian_at(world, hit, dir, root)?;
        // `Bsdf::lambertian` chooses its lobe with probability 1 where it reflects anything.
        return (rho.max_element() > 0.0).then_some(PhongParts {
            diffuse: rho,
            normal,
            geometric: normal,
            glossy: 0.0,
            exponent: 0.0,
            mirror_dir: Vec3::ZERO,
            p_diffuse: 1.0,
            p_glossy: 0.0,
        });
    }
    if m.reflection_f0.is_some() || m.reflectivity != 0.0 || m.is_transparent() {
        return None;
    }
    let (_, ng, ns, wo) = orient(hit, dir);
    // `Bsdf::new` without mirror or glass, operation for operation: the Phong weight, the
    // pair scaled down where it would reflect more than it receives, the lobes' albedos and
    // choice probabilities (the mirror's and the glass's luminance are 0).
    let phong = Rgb::splat((1.0 - m.reflectivity - m.transparency).clamp(0.0, 1.0));
    let albedo = world.albedo(hit);
    let (mut kd, mut ks) = (m.diffuse.max(0.0), m.specular.max(0.0));
    let total = kd * albedo.max_element() + ks;
    if total > 1.0 {
        kd /= total;
        ks /= total;
    }
    let diffuse = phong * albedo * kd;
    if ks == 0.0 {
        // No glossy lobe (a matte material): the probabilities below without their divisions,
        // whose latency was most of this function on diffuse walls. Bit for bit: the glossy
        // weight `ks · sum / 3` is `ks` itself (a zero of its sign, the sum being finite and
        // not negative), the sum of the weights is `wd`, and `wd / wd` is 1 where `wd` is
        // positive and finite (elsewhere the quotients fail the tests below: no parts).
        let wd = luminance(diffuse);
        return (wd > 0.0 && wd.is_finite()).then_some(PhongParts {
            diffuse,
            normal: ns,
            geometric: ng,
            glossy: ks,
            exponent: m.shininess.max(0.0),
            mirror_dir: reflect(-wo, ns),
            p_diffuse: 1.0,
            p_glossy: ks,
        });
    }
    let glossy = ks * phong.element_sum() / 3.0;
    let (wd, wg) = (luminance(diffuse), glossy);
    let sum = wd + wg + luminance(Rgb::ZERO) + luminance(Rgb::ZERO);
    if sum.is_nan() || sum <= 0.0 {
        return None;
    }
    let (p_diffuse, p_glossy) = (wd / sum, wg / sum);
    let parts = PhongParts {
        diffuse,
        normal: ns,
        geometric: ng,
        glossy,
        exponent: m.shininess.max(0.0),
        mirror_dir: reflect(-wo, ns),
        p_diffuse,
        p_glossy,
    };
    (p_diffuse + p_glossy > 0.0).then_some(parts)
}

/// The light samples of next-event estimation at `hit`: every delta light of
/// [`LightSet::each_delta`] plus one sample among the other lights (`mis`: weighted against
/// BSDF sampling). For each that the BSDF does not turn away, `visit(shadow ray, f·cos·L/pdf ×
/// MIS weight, its diffuse part demodulated)` — the last nonzero only for the sampled light —
/// to be added where the shadow ray finds nothing in the way. Counts the shadow rays.
#[allow(clippy::too_many_arguments)]
#[inline]
pub(super) fn light_samples(
    lights: &LightSet,
    world: &World,
    hit: &SurfaceHit,
    bsdf: &Bsdf,
    stream: &mut SampleStream,
    mis: Option<f32>,
    counts: &mut RayCounts,
    mut visit: impl FnMut(&Ray, Rgb, Rgb),
) {
    for light in lights.each_delta() {
        let Some(ls) = lights.delta_sample(light, hit) else { continue };
        let f = bsdf.eval_cos(ls.wi);
        if f.max_element() > 0.0 {
            counts.shadow += 1;
            visit(&ls.shadow, f * ls.weight, Rgb::ZERO);
        }
    }
    let u_choice = stream.next_1d();
    let u = stream.next_2d();
    if let Some(ls) = lights.sample(world, hit, u_choice, u) {
        let weighed = mis.filter(|_| ls.pdf > 0.0);
        let (f, pdf) = match weighed {
            Some(_) => bsdf.eval_cos_and_pdf(ls.wi),
            None => (bsdf.eval_cos(ls.wi), 0.0),
        };
        if f.max_element() > 0.0 {
            counts.shadow += 1;
            let w = match weighed {
                Some(scale) => power_heuristic(ls.pdf, pdf * scale),
                None => 1.0,
            };
            let diffuse = if ls.pdf > 0.0 { ls.weight * (w * bsdf.diffuse_shape(ls.wi)) } else { Rgb::ZERO };
            visit(&ls.shadow, f * ls.weight * w, diffuse);
        }
    }
}

impl<'a> Integrator<'a> {
    pub fn new(world: &'a World, lights: &'a LightSet, params: PathParams) -> Self {
        Self { world, lights, params, counts: RayCounts::default() }
    }

    fn bsdf_at(&self, hit: &SurfaceHit, dir: Vec3) -> (Bsdf, Rgb) {
        bsdf_at(self.world, hit, dir)
    }

    /// Trace one camera sample whose primary ray's closest hit is `first` (found by a single
    /// or a packet query: the same hit bit for bit). `cone` is the primary ray's footprint for
    /// sky filtering; `depth_of` gives the camera depth of a world point.
    pub fn camera_sample_from(
        &mut self,
        primary: Ray,
        first: Option<SurfaceHit>,
        cone: f32,
        depth_of: impl Fn(Vec3) -> f32,
        stream: &mut SampleStream,
        mode: IndirectMode,
    ) -> CameraSample {
        let mut out = CameraSample::default();
        let mut ray = primary;
        let mut throughput = Rgb::ONE;
        let mut depth = 0.0;
        // Mitsuba's budget: vertex `chain` exists; it samples light and continues only while
        // vertex `chain + 1` is within `max_depth`.
        let last_chain = self.params.max_depth.map_or(self.params.max_chain, |l| l.saturating_sub(1));
        for chain in 0..=last_chain {
            let found = if chain == 0 {
                self.counts.primary += 1;
                first
            } else {
                self.counts.secondary += 1;
                self.world.intersect(&ray)
            };
            let Some(hit) = found else {
                // Mitsuba's budget comes with Mitsuba's point lookups of the sky (its pixels
                // average their samples' lookups; a prefiltered footprint would blur more).
                let sky = if chain == 0 && self.params.max_depth.is_none() {
                    self.world.sky().radiance_filtered(ray.dir, cone)
                } else {
                    self.world.sky().radiance(ray.dir)
                };
                if chain > 0 || !self.params.hide_emitters {
                    out.rest += throughput * sky;
                }
                return out;
            };
            out.covered = true;
            depth = if chain == 0 { depth_of(hit.position) } else { depth + hit.t };
            let (bsdf, emission) = self.bsdf_at(&hit, ray.dir);
            if chain > 0 || !self.params.hide_emitters {
                out.rest += throughput * emission;
            }
            let bounces = match self.params.max_depth {
                Some(l) if chain + 1 >= l => return out,
                Some(l) => l - 2 - chain,
                None => self.params.max_bounces,
            };
            let u_lobe = stream.next_1d();
            let u = stream.next_2d();
            if bsdf.is_delta_dominant() {
                if u_lobe >= bsdf.p_non_delta() {
                    let Some(s) = bsdf.sample_delta(u_lobe, u) else { return out };
                    throughput *= s.weight;
                    ray = hit.spawn_ray(s.wi);
                    continue;
                }
                // The non-delta part was chosen: the guide vertex, its delta lobes accounted.
                throughput /= bsdf.p_non_delta();
                self.guide_vertex(&hit, &bsdf, throughput, false, bounces, stream, mode, &mut out);
            } else {
                self.guide_vertex(&hit, &bsdf, throughput, true, bounces, stream, mode, &mut out);
            }
            out.guide = Some(GuideGeometry { normal: bsdf.normal, depth });
            return out;
        }
        out
    }

    #[allow(clippy::too_many_arguments)]
    fn guide_vertex(
        &mut self,
        hit: &SurfaceHit,
        bsdf: &Bsdf,
        throughput: Rgb,
        with_delta: bool,
        bounces: u32,
        stream: &mut SampleStream,
        mode: IndirectMode,
        out: &mut CameraSample,
    ) {
        out.albedo = throughput * bsdf.diffuse;
        if bsdf.has_non_delta() {
            // Direct light: the lights alone.
            // Mitsuba's budget: light sampling weighted against the BSDF sample below (whose
            // density is the non-delta part's alone), as its path integrator weighs them.
            let mitsuba = self.params.max_depth.is_some() && !self.params.filtered;
            let mis = mitsuba.then(|| 1.0 / bsdf.p_non_delta().max(1e-12));
            let (direct, sampled_diffuse) = self.direct_light_split(hit, bsdf, stream, mis);
            out.direct = throughput * direct;
            // Optionally the diffuse light of area lights and the sky goes through the filter
            // with the indirect light (traced: into the buffer; lookup: read from the map).
            let filtered_direct = if self.params.filter_area_direct { sampled_diffuse } else { Rgb::ZERO };
            out.direct -= out.albedo * filtered_direct;
            out.rest += out.direct;
            if mode == IndirectMode::Trace {
                out.indirect = filtered_direct;
            }
            if bounces > 0 || mitsuba && mode == IndirectMode::Trace {
                let u_lobe = stream.next_1d();
                let u = stream.next_2d();
                match mode {
                    IndirectMode::Trace => {
                        if let Some(s) = bsdf.sample_non_delta(u_lobe, u) {
                            let arrival =
                                Arrival { pdf: s.pdf, delta: false, after_guide: !mitsuba, from: hit.position };
                            let li = self.trace_path(hit.spawn_ray(s.wi), 1, bounces, arrival, stream);
                            let li = clamp_radiance(li, self.params.clamp_indirect);
                            out.indirect += li * (bsdf.diffuse_shape(s.wi) / s.pdf);
                            out.rest += throughput * li * (bsdf.eval_glossy_cos(s.wi) / s.pdf);
                        }
                    }
                    IndirectMode::Lookup => {
                        if let Some((wi, w)) = bsdf.sample_glossy_only(u_lobe, u) {
                            let arrival =
                                Arrival { pdf: bsdf.pdf(wi), delta: false, after_guide: true, from: hit.position };
                            let li = self.trace_path(hit.spawn_ray(wi), 1, bounces, arrival, stream);
                            out.rest += throughput * clamp_radiance(li, self.params.clamp_indirect) * w;
                        }
                    }
                }
            }
        }
        if with_delta {
            for (dir, weight) in bsdf.delta_lobes().into_iter().flatten() {
                let arrival = Arrival { pdf: 0.0, delta: true, after_guide: false, from: hit.position };
                // glint's budget does not count delta bounces; Mitsuba's does.
                let first = u32::from(self.params.max_depth.is_some());
                let li = self.trace_path(hit.spawn_ray(dir), first, bounces, arrival, stream);
                out.rest += throughput * weight * li;
            }
        }
    }

    /// Next-event estimation at `hit`: every delta light of [`LightSet::each_delta`] plus one
    /// sample among the other lights; `mis` weights that sample against BSDF sampling.
    fn direct_light(&mut self, hit: &SurfaceHit, bsdf: &Bsdf, stream: &mut SampleStream, mis: Option<f32>) -> Rgb {
        self.direct_light_split(hit, bsdf, stream, mis).0
    }

    /// As [`Integrator::direct_light`], also returning the randomly chosen light's diffuse
    /// part demodulated (`L · (cos/π) / pdf`; `ρd ×` it is in the total).
    fn direct_light_split(
        &mut self,
        hit: &SurfaceHit,
        bsdf: &Bsdf,
        stream: &mut SampleStream,
        mis: Option<f32>,
    ) -> (Rgb, Rgb) {
        let mut sum = Rgb::ZERO;
        let mut sampled_diffuse = Rgb::ZERO;
        let world = self.world;
        light_samples(self.lights, world, hit, bsdf, stream, mis, &mut self.counts, |shadow, c, d| {
            if !world.occluded(shadow) {
                sum += c;
                sampled_diffuse += d;
            }
        });
        (sum, sampled_diffuse)
    }

    /// Radiance arriving along `ray`, whose first hit is vertex number `bounce` of the path
    /// after the guide vertex (0 for rays that continue a camera chain); vertices up to
    /// `max_bounces` sample light, those before it continue.
    fn trace_path(
        &mut self,
        mut ray: Ray,
        mut bounce: u32,
        max_bounces: u32,
        mut arrival: Arrival,
        stream: &mut SampleStream,
    ) -> Rgb {
        let mut radiance = Rgb::ZERO;
        let mut beta = Rgb::ONE;
        loop {
            self.counts.secondary += 1;
            let Some(hit) = self.world.intersect(&ray) else {
                let weight = arrival.emission_weight(self.lights.pdf_sky(self.world, ray.dir));
                if weight > 0.0 {
                    radiance += beta * self.world.sky().radiance(ray.dir) * weight;
                }
                break;
            };
            let (bsdf, emission) = self.bsdf_at(&hit, ray.dir);
            if emission.max_element() > 0.0 {
                let weight = arrival.emission_weight(self.lights.pdf_surface(arrival.from, ray.dir, &hit));
                radiance += beta * emission * weight;
            }
            // Mitsuba's budget follows the last light-sampling vertex's BSDF one more segment,
            // for the emission it finds (MIS-weighted); glint's does not trace it.
            let mitsuba = self.params.max_depth.is_some();
            if bsdf.has_non_delta() && bounce <= max_bounces {
                // MIS against BSDF sampling, except at the last vertex, whose BSDF ray is not
                // traced (then light sampling alone counts).
                let mis = (bounce < max_bounces || mitsuba).then_some(1.0);
                radiance += beta * self.direct_light(&hit, &bsdf, stream, mis);
            }
            if bounce >= max_bounces + u32::from(mitsuba) {
                break;
            }
            let u_lobe = stream.next_1d();
            let u = stream.next_2d();
            let Some(s) = bsdf.sample(u_lobe, u) else { break };
            beta *= s.weight;
            bounce += 1;
            if bounce > self.params.rr_start {
                let q = beta.max_element().min(0.95);
                if stream.next_1d() >= q || q.is_nan() {
                    break;
                }
                beta /= q;
            }
            arrival = Arrival { pdf: s.pdf, delta: s.delta, after_guide: false, from: hit.position };
            ray = hit.spawn_ray(s.wi);
        }
        radiance
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::random::SampleStream;
    use glint_core::{Affine3A, Vec2};
    use glint_scene::bsdf::{BsdfKind, Tex};
    use glint_scene::{Material, Object, Scene, Shape};

    /// A unit sphere at the origin made of `material` (its physically based models `bsdfs`).
    fn ball(material: Material, bsdfs: &[BsdfKind]) -> World {
        World::new(Scene {
            materials: vec![material],
            bsdfs: bsdfs.to_vec(),
            objects: vec![Object {
                name: "ball".into(),
                shape: Shape::Sphere { centre: Vec3::ZERO, radius: 1.0 },
                material: 0,
                world_from_object: Affine3A::IDENTITY,
            }],
            ..Scene::default()
        })
    }

    /// `phong_parts_at` finds a BSDF without delta lobes exactly where `bsdf_at` builds one,
    /// with its bits, and nowhere else: Phong materials with and without specular (glossy
    /// alone, exponents 0 to 500, a pair scaled down), mirror, glass, Fresnel and emission, an
    /// albedo that scales the diffuse coefficient down, Mitsuba's
    /// `diffuse` (black or not, one- and two-sided) and a model that is not diffuse; hit from
    /// outside and inside.
    #[test]
    fn phong_parts_are_those_of_the_built_bsdf() {
        let phong = |diffuse: f32, colour: f32| Material {
            diffuse,
            colour: Rgb::splat(colour),
            specular: 0.0,
            ..Material::default()
        };
        let materials = vec![
            phong(0.8, 0.6),
            phong(1.0, 1.0),
            phong(1.5, 0.9), // K_d · colour above 1: scaled down
            phong(0.0, 0.7), // black: no lobe
            Material { specular: 0.3, ..phong(0.6, 0.5) },
            Material { specular: 0.7, shininess: 500.0, ..phong(0.0, 0.5) },
            Material { specular: 0.9, shininess: 0.0, ..phong(0.8, 0.9) },
            Material { specular: 0.2, ..Material::default() },
            Material { specular: 0.0, shininess: 3.0, ..phong(0.0, 0.9) }, // black
            Material { reflectivity: 0.2, ..phong(0.6, 0.5) },
            Material { transparency: 0.5, ior: 1.5, ..phong(0.4, 0.5) },
            Material { reflection_f0: Some(Rgb::splat(0.04)), ..phong(0.6, 0.5) },
            Material { emission: Rgb::splat(2.0), ..phong(0.6, 0.5) },
            Material { bsdf: Some(0), ..Material::default() },
            Material { bsdf: Some(1), ..Material::default() },
            Material { bsdf: Some(2), ..Material::default() },
            Material { bsdf: Some(3), ..Material::default() },
        ];
        let bsdfs = vec![
            BsdfKind::Diffuse { reflectance: Tex::Value(Rgb::new(0.7, 0.4, 0.2)) },
            BsdfKind::Diffuse { reflectance: Tex::Value(Rgb::ZERO) },
            BsdfKind::TwoSided { front: 0, back: 0 },
            BsdfKind::Conductor {
                eta: Rgb::splat(0.2),
                k: Rgb::splat(3.0),
                specular_reflectance: Tex::Value(Rgb::ONE),
            },
        ];
        let mut seen = [0usize; 3];
        for (i, m) in materials.iter().enumerate() {
            let world = ball(m.clone(), &bsdfs);
            let mut stream = SampleStream::new(4, 5, 6);
            for k in 0..64 {
                let d = glint_core::sampling::sample_uniform_sphere(stream.next_2d());
                let ray = if k % 2 == 0 { Ray::new(d * 3.0, -d) } else { Ray::new(Vec3::ZERO, d) };
                let hit = world.intersect(&ray).expect("the sphere");
                let built = bsdf_at(&world, &hit, ray.dir).0.phong_parts();
                let found = phong_parts_at(&world, &hit, ray.dir);
                let bits = |p: Option<PhongParts>| {
                    p.map(|p| {
                        let v =
                            [p.diffuse, p.normal, p.geometric, p.mirror_dir].map(|v| v.to_array().map(f32::to_bits));
                        (v, [p.glossy, p.exponent, p.p_diffuse, p.p_glossy].map(f32::to_bits))
                    })
                };
                assert_eq!(bits(found), bits(built), "material {i}, ray {k}");
                seen[found.map_or(0, |p| 1 + usize::from(p.glossy > 0.0))] += 1;
            }
        }
        // Every answer occurs (none, Lambertian alone, with a glossy lobe): the test is not
        // vacuous.
        assert!(seen.iter().all(|&n| n > 100), "{seen:?}");
    }

    /// `lambertian_at`'s reading of Mitsuba's `diffuse` (alone, and `twosided` over two) gives
    /// the general model's answers: from in front and from behind a sphere, every query the
    /// integrators ask — value, density, demodulated shape, albedo, normal — and samples whose
    /// weight is the reflectance and whose density is the general model's.
    #[test]
    fn the_lambertian_reading_answers_as_the_general_model() {
        let front = Rgb::new(0.7, 0.4, 0.2);
        let bsdfs = vec![
            BsdfKind::Diffuse { reflectance: Tex::Value(front) },
            BsdfKind::Diffuse { reflectance: Tex::Value(Rgb::new(0.1, 0.5, 0.3)) },
            BsdfKind::TwoSided { front: 0, back: 1 },
        ];
        for root in [0, 2] {
            let world = ball(Material { bsdf: Some(root), ..Material::default() }, &bsdfs);
            let mut stream = SampleStream::new(1, 2, 3);
            let (mut lit_front, mut lit_back) = (0, 0);
            for k in 0..400 {
                let d = glint_core::sampling::sample_uniform_sphere(stream.next_2d());
                // Half the rays from outside (front faces), half from the centre (back faces).
                let ray = if k % 2 == 0 { Ray::new(d * 3.0, -d) } else { Ray::new(Vec3::ZERO, d) };
                let hit = world.intersect(&ray).expect("the sphere");
                let (fast, _) = bsdf_at(&world, &hit, ray.dir);
                let (_, ng, _, _) = orient(&hit, ray.dir);
                let general = Bsdf::physical(Physical::at(&world, &hit, ray.dir, root).expect("fits"), ng);
                assert!((fast.normal - general.normal).length() < 1e-6, "root {root}: normals");
                assert!((fast.diffuse - general.diffuse).abs().max_element() < 1e-6, "root {root}: albedo");
                if fast.diffuse.max_element() > 0.0 {
                    if k % 2 == 0 { lit_front += 1 } else { lit_back += 1 }
                }
                for _ in 0..8 {
                    let wi = glint_core::sampling::sample_uniform_sphere(stream.next_2d());
                    let (a, b) = (fast.eval_cos(wi), general.eval_cos(wi));
                    assert!((a - b).abs().max_element() < 1e-5, "root {root}: eval {a} vs {b}");
                    // Where the surface is black the fast reading samples nothing (no lobe).
                    if fast.has_non_delta() {
                        assert!((fast.pdf(wi) - general.pdf(wi)).abs() < 1e-5, "root {root}: pdf");
                        assert!((fast.diffuse_shape(wi) - general.diffuse_shape(wi)).abs() < 1e-5, "root {root}");
                        let u: Vec2 = stream.next_2d();
                        let s = fast.sample(0.5, u).expect("a direction above the surface");
                        assert!((s.weight - fast.diffuse).abs().max_element() < 1e-5, "root {root}: weight");
                        assert!((s.pdf - general.pdf(s.wi)).abs() < 1e-4 * s.pdf.max(1.0), "root {root}: density");
                    }
                }
            }
            // One-sided: lit from the front only; two-sided: from both.
            assert!(lit_front == 200 && (lit_back == 0) == (root == 0), "root {root}: {lit_front} / {lit_back}");
        }
    }
}
