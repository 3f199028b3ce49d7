//! Everything next-event estimation can aim at: the scene's point, spot and directional lights,
//! emissive triangles (area lights) and the sky, with one discrete choice among them.
//!
//! **Units.** Point, spot and directional lights keep the Whitted mode's meaning: a light of
//! intensity `I` gives a white Lambertian surface facing it the brightness `I` (Phong's
//! `K_d I cos`), i.e. it delivers irradiance `π I`. So the same scene looks alike in both modes.
//! Emissive surfaces emit radiance `emission` from their front face (two-sided materials from
//! both); the sky is radiance.
//!
//! **Choice.** Up to [`EACH_DELTA_LIMIT`] point, spot and directional lights are each given a
//! shadow ray at every shading point (they cost one ray and have no variance: choosing among
//! them, or between the sun and the sky, would speckle every sunlit pixel that lost the draw).
//! One sample then goes to the rest: each light gets a probability in proportion to a rough
//! estimate of the irradiance it delivers at the scene's scale `R` (its bounding radius):
//! `π I lum` for delta lights beyond the limit (over `R²` with inverse-square falloff),
//! `lum(L) · area / R²` for a triangle, `∫ lum(L) dω / 4` for the sky (`π L` for a uniform sky).

use crate::world::{EmissiveTriangle, SurfaceHit, World};
use glint_core::colour::luminance;
use glint_core::{Ray, Rgb, Vec2, Vec3};
use glint_scene::light::Attenuation;
use glint_scene::{Light, SkySampler};
use std::collections::HashMap;
use std::f32::consts::PI;

/// Scenes with at most this many point, spot and directional lights sample each of them at
/// every shading point; more go into the random choice.
pub const EACH_DELTA_LIMIT: usize = 8;

#[derive(Clone, Copy, Debug)]
enum Entry {
    Delta(usize),
    Triangle(usize),
    Sky,
}

/// One light sample seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub wi: Vec3,
    /// The shadow ray (origin offset from the surface, tmax short of the light).
    pub shadow: Ray,
    /// Incident radiance over the pdf, i.e. what multiplies `f · cos` (choice included).
    pub weight: Rgb,
    /// Solid-angle pdf including the choice probability; 0 for delta lights.
    pub pdf: f32,
}

/// A point chosen on an emissive triangle (barycentric `b0`, `b1` of `vertices`), with what
/// the sample seen from a shading point needs: [`AreaChoice::sample_from`], and the batched
/// path vertices' eight-lane copy of it.
#[derive(Clone, Copy, Debug)]
pub struct AreaChoice {
    /// Wound so that `(v1 − v0) × (v2 − v0)` is the front face's normal.
    pub vertices: [Vec3; 3],
    pub two_sided: bool,
    pub area: f32,
    /// Probability of choosing this triangle.
    pub p_choice: f32,
    pub b0: f32,
    pub b1: f32,
    /// Radiance emitted there.
    pub emission: Rgb,
}

impl AreaChoice {
    /// The light sample of this point seen from `hit` (`None` where the point is on the
    /// hit, or the light turns its back).
    #[inline]
    pub fn sample_from(&self, hit: &SurfaceHit) -> Option<LightSample> {
        let [a, b, c] = self.vertices;
        let (b0, b1) = (self.b0, self.b1);
        let target = a * b0 + b * b1 + c * (1.0 - b0 - b1);
        let to = target - hit.position;
        let dist2 = to.length_squared();
        if dist2.is_nan() || dist2 <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let wi = to / dist;
        let n = (b - a).cross(c - a);
        // One-sided lights shine from their front face only: toward −n·wi > 0.
        let facing = -n.dot(wi);
        let cos_l = if self.two_sided { facing.abs() } else { facing } / n.length();
        if cos_l.is_nan() || cos_l <= 1e-7 {
            return None;
        }
        let pdf = self.p_choice * dist2 / (self.area * cos_l);
        let mut shadow = hit.spawn_ray_to(target);
        // Stop short of the light's own surface.
        shadow.tmax *= SHADOW_SHORT;
        Some(LightSample { wi, shadow, weight: self.emission / pdf, pdf })
    }
}

/// Which light [`LightSet::pick`] picks.
#[derive(Clone, Copy, Debug)]
pub enum Pick {
    /// Delta light `i`.
    Delta(usize),
    /// Emissive triangle `i` (of the set's).
    Triangle(usize),
    Sky,
}

/// The most directional lights the wavefront's vertices in lanes take ([`LightSet::suns`]).
pub const SUNS: usize = 2;

/// A shadow ray toward a point on a light stops this fraction of the way, short of the
/// light's own surface.
pub const SHADOW_SHORT: f32 = 1.0 - 1e-4;

pub struct LightSet {
    entries: Vec<Entry>,
    /// Cumulative choice probabilities (last = 1).
    cdf: Vec<f32>,
    triangles: Vec<EmissiveTriangle>,
    /// Area of each triangle.
    areas: Vec<f32>,
    /// (object, prim) → entry index of emissive triangles.
    triangle_entry: HashMap<(u32, u32), u32>,
    sky: Option<SkySampler>,
    sky_entry: Option<u32>,
    delta_lights: Vec<Light>,
    /// The scene's textures when a delta light projects one (else empty).
    projected: Vec<glint_scene::Texture>,
    /// Every delta light is sampled at every shading point (not in `entries`).
    each_delta: bool,
}

impl LightSet {
    pub fn new(world: &World) -> LightSet {
        let bounds = world.bounds();
        let radius = if bounds.is_empty() { 1.0 } else { (bounds.diagonal_length() * 0.5).max(1e-6) };
        let r2 = radius * radius;
        let mut entries = Vec::new();
        let mut weights = Vec::new();
        let delta_lights = world.scene().lights.clone();
        let each_delta = delta_lights.len() <= EACH_DELTA_LIMIT;
        for (i, l) in delta_lights.iter().enumerate().filter(|_| !each_delta) {
            let (colour, intensity, atten) = match *l {
                Light::Point { colour, intensity, attenuation, .. } => (colour, intensity, attenuation),
                Light::Spot { colour, intensity, attenuation, .. } => (colour, intensity, attenuation),
                Light::Directional { colour, intensity, .. } => (colour, intensity, Attenuation::None),
            };
            let fall = if atten == Attenuation::InverseSquare { 1.0 / r2 } else { 1.0 };
            let w = PI * intensity * luminance(colour) * fall;
            if w > 0.0 && w.is_finite() {
                entries.push(Entry::Delta(i));
                weights.push(w);
            }
        }
        let triangles = world.emissive_triangles();
        let mut areas = Vec::with_capacity(triangles.len());
        let mut triangle_entry = HashMap::new();
        for (i, t) in triangles.iter().enumerate() {
            let [a, b, c] = t.vertices;
            let area = 0.5 * (b - a).cross(c - a).length();
            areas.push(area);
            let w = luminance(t.emission) * area / r2;
            if w > 0.0 && w.is_finite() {
                triangle_entry.insert((t.object, t.prim), entries.len() as u32);
                entries.push(Entry::Triangle(i));
                weights.push(w);
            }
        }
        let sampler = SkySampler::new(world.sky());
        let sky_weight = sampler.integral() / 4.0;
        let (sky, sky_entry) = if sky_weight > 0.0 && sky_weight.is_finite() {
            entries.push(Entry::Sky);
            weights.push(sky_weight);
            (Some(sampler), Some(entries.len() as u32 - 1))
        } else {
            (None, None)
        };
        let total: f32 = weights.iter().sum();
        let mut acc = 0.0;
        let cdf = weights
            .iter()
            .map(|w| {
                acc += w / total;
                acc
            })
            .collect::<Vec<_>>();
        let mut cdf = cdf;
        if let Some(last) = cdf.last_mut() {
            *last = 1.0;
        }
        let projected =
            if delta_lights.iter().any(Light::is_textured) { world.scene().textures.clone() } else { Vec::new() };
        LightSet { entries, cdf, triangles, areas, triangle_entry, sky, sky_entry, delta_lights, projected, each_delta }
    }

    /// The delta lights sampled at every shading point (empty when they are in the choice).
    pub fn each_delta(&self) -> &[Light] {
        if self.each_delta { &self.delta_lights } else { &[] }
    }

    /// The sample of a delta light seen from `hit` (weight = incident radiance, pdf 0).
    pub fn delta_sample(&self, light: &Light, hit: &SurfaceHit) -> Option<LightSample> {
        let ls = light.sample_in(hit.position, &self.projected)?;
        let shadow = if ls.distance.is_finite() {
            hit.spawn_ray_to(hit.position + ls.wi * ls.distance)
        } else {
            hit.spawn_ray(ls.wi)
        };
        Some(LightSample { wi: ls.wi, shadow, weight: ls.radiance * PI, pdf: 0.0 })
    }

    fn choice_probability(&self, entry: usize) -> f32 {
        let lo = if entry == 0 { 0.0 } else { self.cdf[entry - 1] };
        self.cdf[entry] - lo
    }

    /// The lights as the wavefront's vertices in lanes take them, where they can: the
    /// directional lights of [`LightSet::each_delta`] (at most [`SUNS`], as incident
    /// direction and `L·π`, what [`LightSet::delta_sample`] gives at every point), the other
    /// lights all in the one choice among triangles and the sky ([`LightSet::pick`]). `None` for
    /// point and spot lights, more suns, or delta lights in the choice.
    pub fn suns(&self) -> Option<Vec<(Vec3, Rgb)>> {
        if !self.each_delta || self.delta_lights.len() > SUNS {
            return None;
        }
        let point = Vec3::ZERO;
        let suns = self.delta_lights.iter().map(|l| match l {
            Light::Directional { .. } => {
                let s = l.sample_in(point, &self.projected)?;
                Some((s.wi, s.radiance * PI))
            }
            _ => None,
        });
        suns.collect()
    }

    /// The light `u_choice` picks and the probability of picking it (`None`: no light, or
    /// one of no probability). [`LightSet::sample`] and the lanes' gather go on from here
    /// with [`LightSet::area_choice`] or [`LightSet::sky_choice`] (an enum of their answers,
    /// returned to the gather, went through memory: 2 % of a Cornell box frame).
    #[inline(always)]
    pub fn pick(&self, u_choice: f32) -> Option<(Pick, f32)> {
        let entry = self.cdf.partition_point(|&c| c <= u_choice).min(self.entries.len().checked_sub(1)?);
        let p_choice = self.choice_probability(entry);
        if p_choice <= 0.0 {
            return None;
        }
        Some(match self.entries[entry] {
            Entry::Delta(i) => (Pick::Delta(i), p_choice),
            Entry::Triangle(i) => (Pick::Triangle(i), p_choice),
            Entry::Sky => (Pick::Sky, p_choice),
        })
    }

    /// The sky picked with probability `p_choice`: the direction `u` warps to, its radiance
    /// over its pdf, and that pdf (choice included); `None` where the sky gives no direction.
    #[inline]
    pub fn sky_choice(&self, world: &World, p_choice: f32, u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        let s = self.sky.as_ref()?.sample(world.sky(), u)?;
        if s.pdf.is_nan() || s.pdf <= 0.0 {
            return None;
        }
        let pdf = s.pdf * p_choice;
        Some((s.dir, s.radiance / pdf, pdf))
    }

    /// Triangle `i` chosen with probability `p_choice`, at the point `u` warps to (uniform in
    /// area: Turk's square-root parametrisation).
    #[inline(always)]
    pub fn area_choice(&self, world: &World, i: usize, p_choice: f32, u: Vec2) -> AreaChoice {
        let t = &self.triangles[i];
        let su = u.x.sqrt();
        let (b0, b1) = (1.0 - su, u.y * su);
        AreaChoice {
            vertices: t.vertices,
            two_sided: t.two_sided,
            area: self.areas[i],
            p_choice,
            b0,
            b1,
            emission: t.emission_at(world, b0, b1),
        }
    }

    /// One light sample for the shading point `hit`, from `u_choice` and `u`, among the lights
    /// not in [`LightSet::each_delta`].
    pub fn sample(&self, world: &World, hit: &SurfaceHit, u_choice: f32, u: Vec2) -> Option<LightSample> {
        match self.pick(u_choice)? {
            (Pick::Delta(i), p_choice) => {
                let mut s = self.delta_sample(&self.delta_lights[i], hit)?;
                s.weight /= p_choice;
                Some(s)
            }
            (Pick::Triangle(i), p_choice) => self.area_choice(world, i, p_choice, u).sample_from(hit),
            (Pick::Sky, p_choice) => {
                let (dir, weight, pdf) = self.sky_choice(world, p_choice, u)?;
                Some(LightSample { wi: dir, shadow: hit.spawn_ray(dir), weight, pdf })
            }
        }
    }

    /// Solid-angle pdf (choice included) with which [`LightSet::sample`] would have picked the
    /// emitting surface `hit` seen from `from` along unit `dir`; `None` when that surface is not
    /// sampled by next-event estimation (emissive spheres and planes: BSDF sampling alone finds
    /// them).
    pub fn pdf_surface(&self, from: Vec3, dir: Vec3, hit: &SurfaceHit) -> Option<f32> {
        let &entry = self.triangle_entry.get(&(hit.object, hit.prim))?;
        let Entry::Triangle(i) = self.entries[entry as usize] else { return None };
        let facing = -hit.geometric_normal.dot(dir);
        let cos_l = if self.triangles[i].two_sided { facing.abs() } else { facing };
        if cos_l.is_nan() || cos_l <= 0.0 {
            return Some(0.0);
        }
        let dist2 = (hit.position - from).length_squared();
        Some(self.choice_probability(entry as usize) * dist2 / (self.areas[i] * cos_l))
    }

    /// Solid-angle pdf (choice included) of sampling the sky toward `dir`; `None` when the sky
    /// is not sampled.
    pub fn pdf_sky(&self, world: &World, dir: Vec3) -> Option<f32> {
        let sky = self.sky.as_ref()?;
        let entry = self.sky_entry? as usize;
        Some(sky.pdf(world.sky(), dir) * self.choice_probability(entry))
    }
}

/// The power heuristic (β = 2) weight of a strategy with pdf `a` against one with pdf `b`.
#[inline]
pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 <= 0.0 { 0.0 } else { a2 / (a2 + b2) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::chi2::chi2_sphere;
    use glint_core::random::SampleStream;
    use glint_core::{Affine3A, Rgb, Vec3};
    use glint_scene::{Material, Object, Scene, Shape, Sky};
    use std::sync::Arc;

    fn object(shape: Shape, material: usize) -> Object {
        Object { name: "o".into(), shape, material, world_from_object: Affine3A::IDENTITY }
    }

    /// Light sampling draws directions with the density it reports: an emissive quad above a
    /// point, under a non-uniform sky.
    #[test]
    fn light_sampling_matches_its_pdf() {
        let gradient = Sky::Gradient { zenith: Rgb::new(0.2, 0.3, 0.9), horizon: Rgb::ONE, ground: Rgb::splat(0.1) };
        check_light_sampling(Sky::Colour(Rgb::ZERO), 4.0);
        check_light_sampling(gradient.clone(), 0.0);
        check_light_sampling(gradient, 4.0);
    }

    fn check_light_sampling(sky: Sky, emission: f32) {
        let quad = glint_scene::Mesh {
            name: "light".into(),
            positions: vec![
                Vec3::new(-0.5, 1.0, -0.3),
                Vec3::new(0.6, 1.0, -0.4),
                Vec3::new(0.5, 1.2, 0.5),
                Vec3::new(-0.4, 0.9, 0.4),
            ],
            normals: None,
            uvs: None,
            triangles: vec![[0, 1, 2], [0, 2, 3]],
            triangle_materials: None,
            attributes: Vec::new(),
        };
        let scene = Scene {
            sky,
            materials: vec![
                Material { emission: Rgb::new(1.0, 0.75, 0.5) * emission, ..Material::default() },
                Material::default(),
            ],
            meshes: vec![Arc::new(quad)],
            objects: vec![
                object(Shape::Mesh(0), 0),
                // A tiny sphere to shade at.
                object(Shape::Sphere { centre: Vec3::ZERO, radius: 1e-3 }, 1),
            ],
            ..Scene::default()
        };
        let world = World::new(scene);
        let lights = LightSet::new(&world);
        let probe = glint_core::Ray::new(Vec3::new(0.0, 0.0, 5.0), Vec3::new(0.0, 0.0, -1.0));
        let hit = world.intersect(&probe).expect("the probe sphere");
        let n = 400_000;
        let mut dirs = Vec::new();
        for i in 0..n {
            let mut s = SampleStream::new(i, 0, 1);
            if let Some(ls) = lights.sample(&world, &hit, s.next_1d(), s.next_2d()) {
                dirs.push(ls.wi);
            }
        }
        let from = hit.position;
        let pdf = |d: Vec3| -> f64 {
            let ray = glint_core::Ray::new(from + d * 1e-2, d);
            // The sky is sampled whatever lies in front of it, so both densities add up where
            // the quad hides the sky.
            let surface = world.intersect(&ray).and_then(|h| lights.pdf_surface(from, d, &h)).unwrap_or(0.0);
            (surface + lights.pdf_sky(&world, d).unwrap_or(0.0)) as f64
        };
        let out = chi2_sphere(&dirs, n as usize, pdf, 24, 48);
        assert!(out.p_value > 0.01 / 3.0, "emission {emission}: {out:?}");
    }
}
