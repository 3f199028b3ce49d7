//! Whitted shading of eight hits at once (pipeline: batched tracer → **shade8** → sample sums
//! and the next depth's rays): materials gathered into lanes, Phong with one shadow packet per
//! light, Schlick or exact dielectric Fresnel, the reflected and refracted rays spawned.
//!
//! Every formula is the scalar tracer's (`tracer.rs`), lane by lane and in the same order,
//! with masks where the scalar code branches: misses, material classes (Schlick, transparent,
//! Fresnel), total internal reflection, the contribution threshold. Two things differ by a
//! rounding: the Phong power is [`pow_unit`] (relative error < 3e-5) instead of `powf`, and
//! contributions reach a sample in depth order instead of the scalar stack's order.

use super::batch::{Lanes, Stream, TileSums};
use crate::lights8::LightLanes;
use crate::world::{PointCones, World};
use glint_accel::batch::RayOrigins8;
use glint_accel::batch::Rays8;
use glint_accel::lanes::{F8, Isa, LANES, M8, U8x, V8, pow_unit};
use glint_core::{Rgb, Vec3};
use glint_scene::{Light, Material, Sky, Texture};

use crate::world::Surfaces8;

/// The scene's materials as arrays a lane can gather from.
pub(super) struct MaterialTable {
    colour: Vec<Vec3>,
    texture: Vec<Option<usize>>,
    ambient: Vec<f32>,
    diffuse: Vec<f32>,
    specular: Vec<f32>,
    shininess: Vec<f32>,
    reflectivity: Vec<f32>,
    transparency: Vec<f32>,
    ior: Vec<f32>,
    fresnel: Vec<bool>,
    emission: Vec<Vec3>,
    /// Emission from both faces (else the front only).
    two_sided: Vec<bool>,
    /// Schlick's f0 (zero where the material has none) and whether it has one.
    f0: Vec<Vec3>,
    schlick: Vec<bool>,
    textured: Vec<bool>,
}

impl MaterialTable {
    pub(super) fn new(materials: &[Material]) -> Self {
        let col = |f: fn(&Material) -> f32| materials.iter().map(f).collect::<Vec<f32>>();
        Self {
            colour: materials.iter().map(|m| m.colour).collect(),
            texture: materials.iter().map(|m| m.texture).collect(),
            ambient: col(|m| m.ambient),
            diffuse: col(|m| m.diffuse),
            specular: col(|m| m.specular),
            shininess: col(|m| m.shininess),
            reflectivity: col(|m| m.reflectivity),
            transparency: col(|m| m.transparency),
            ior: col(|m| m.ior),
            fresnel: materials.iter().map(|m| m.fresnel).collect(),
            emission: materials.iter().map(|m| m.emission).collect(),
            f0: materials.iter().map(|m| m.reflection_f0.unwrap_or(Vec3::ZERO)).collect(),
            schlick: materials.iter().map(|m| m.reflection_f0.is_some()).collect(),
            two_sided: materials.iter().map(|m| m.two_sided).collect(),
            textured: materials.iter().map(|m| m.texture.is_some()).collect(),
        }
    }
}

/// One material per lane.
struct Materials8<I: Isa> {
    colour: V8<I>,
    ambient: F8<I>,
    diffuse: F8<I>,
    specular: F8<I>,
    shininess: F8<I>,
    reflectivity: F8<I>,
    transparency: F8<I>,
    ior: F8<I>,
    fresnel: M8<I>,
    emission: V8<I>,
    f0: V8<I>,
    /// Lanes whose material reflects by Schlick's Fresnel (`reflection_f0`).
    schlick: M8<I>,
    /// Lanes whose material has a texture.
    textured: M8<I>,
    /// Lanes whose material emits from both faces.
    two_sided: M8<I>,
}

impl<I: Isa> Materials8<I> {
    /// The materials of the `lanes` (one load per field when they share one).
    #[inline(always)]
    fn gather(t: &MaterialTable, index: U8x<I>, lanes: M8<I>) -> Materials8<I> {
        let first = index[lanes.bits().trailing_zeros() as usize % LANES] as usize;
        let shared = (index.eq(U8x::splat(first as u32)) | !lanes) == M8::all();
        Materials8 {
            colour: gather3(&t.colour, index, first, shared),
            ambient: gather(&t.ambient, index, first, shared),
            diffuse: gather(&t.diffuse, index, first, shared),
            specular: gather(&t.specular, index, first, shared),
            shininess: gather(&t.shininess, index, first, shared),
            reflectivity: gather(&t.reflectivity, index, first, shared),
            transparency: gather(&t.transparency, index, first, shared),
            ior: gather(&t.ior, index, first, shared),
            fresnel: gather_flag(&t.fresnel, index, first, shared),
            emission: gather3(&t.emission, index, first, shared),
            f0: gather3(&t.f0, index, first, shared),
            schlick: gather_flag(&t.schlick, index, first, shared),
            textured: gather_flag(&t.textured, index, first, shared) & lanes,
            two_sided: gather_flag(&t.two_sided, index, first, shared),
        }
    }
}

/// `v[index[i]]` per lane (one load when every lane reads `v[first]`).
#[inline(always)]
fn gather<I: Isa>(v: &[f32], index: U8x<I>, first: usize, shared: bool) -> F8<I> {
    if shared { F8::splat(v[first]) } else { F8::from_fn(|i| v[index[i] as usize]) }
}

/// [`gather`] of flags, as a mask.
#[inline(always)]
fn gather_flag<I: Isa>(v: &[bool], index: U8x<I>, first: usize, shared: bool) -> M8<I> {
    if shared { M8::from_bits(if v[first] { 0xff } else { 0 }) } else { M8::from_fn(|i| v[index[i] as usize]) }
}

/// [`gather`] of 3-vectors.
#[inline(always)]
fn gather3<I: Isa>(v: &[Vec3], index: U8x<I>, first: usize, shared: bool) -> V8<I> {
    if shared { V8::splat(v[first]) } else { V8::from_fn(|i| v[index[i] as usize]) }
}

/// A light as the batched tracer reads it: its lanes, and the spheres its shadow rays can meet.
pub(super) struct ShadowLight {
    lanes: LightLanes,
    /// The sphere set seen from the light's position (point and spot lights): shadow
    /// packets skip the spheres none of their rays can cross.
    cones: Option<PointCones>,
}

impl ShadowLight {
    pub(super) fn new(light: &Light, world: &World) -> Self {
        Self { lanes: LightLanes::new(light), cones: light.position().map(|p| world.point_cones(p)) }
    }
}

/// What every batch of a frame shares.
pub(super) struct Shading<'a> {
    pub world: &'a World,
    pub materials: MaterialTable,
    pub lights: Vec<ShadowLight>,
    pub max_depth: u32,
    pub min_contribution: f32,
    /// The camera, for the depth AOV.
    pub eye: Vec3,
    pub forward: Vec3,
}

/// `i − 2 n (n·i)`.
#[inline(always)]
fn reflect<I: Isa>(i: V8<I>, n: V8<I>) -> V8<I> {
    i - n.scale(F8::splat(2.0) * n.dot(i))
}

/// `x.clamp(0, 1)` as `f32::clamp` gives it for finite x.
#[inline(always)]
fn unit<I: Isa>(x: F8<I>) -> F8<I> {
    x.max(F8::zero()).min(F8::one())
}

/// The surface colour (material colour × texture) of the hit lanes.
#[inline(always)]
fn albedo<I: Isa>(s: &Shading, m: &Materials8<I>, surf: &Surfaces8<I>) -> V8<I> {
    let textured = m.textured;
    if textured.none() {
        return m.colour;
    }
    let mut tex = V8::splat(Vec3::ONE);
    let textures = &s.world.scene().textures;
    let mut todo = textured;
    while todo.any() {
        let lane = todo.bits().trailing_zeros() as usize;
        let Some(ti) = s.materials.texture[surf.material[lane] as usize] else { break };
        // Every lane with this texture at once.
        let same = M8::from_fn(|i| todo.lane(i) && s.materials.texture[surf.material[i] as usize] == Some(ti));
        match &textures[ti] {
            Texture::Checker { size, even, odd } => {
                // Texture::evaluate: floor(uv / size), parity of the sum (exact below 2^24).
                let cx = (surf.uv[0] / F8::splat(*size)).floor();
                let cy = (surf.uv[1] / F8::splat(*size)).floor();
                let sum = cx + cy;
                let parity = sum - F8::splat(2.0) * (sum * F8::splat(0.5)).floor();
                let colour = V8::select(parity.eq(F8::zero()), V8::splat(*even), V8::splat(*odd));
                tex = V8::select(same, colour, tex);
            }
            t @ Texture::Image { .. } => {
                for i in 0..LANES {
                    if same.lane(i) {
                        tex.set(i, t.evaluate(glint_core::Vec2::new(surf.uv[0][i], surf.uv[1][i])));
                    }
                }
            }
            Texture::MeshAttribute { .. } => {
                for i in 0..LANES {
                    if let Some(hit) = same.lane(i).then(|| surf.lane(i)).flatten() {
                        tex.set(i, s.world.texture_at(ti, &hit));
                    }
                }
            }
        }
        todo = todo.and_not(same);
    }
    V8::select(textured, m.colour * tex, m.colour)
}

/// The sky seen by the missing lanes, each over its ray cone.
#[inline(always)]
pub(super) fn sky8<I: Isa>(sky: &Sky, dir: V8<I>, spread: F8<I>, lanes: M8<I>) -> V8<I> {
    match sky {
        Sky::Colour(c) => V8::splat(*c),
        _ => {
            // Eight lookups across lanes (a cube map's; others lane by lane): the same values.
            let dirs = std::array::from_fn(|i| dir.lane(i));
            let seen = sky.radiance_filtered8(&dirs, &spread.to_array(), lanes.bits() as u8);
            V8::from_fn(|i| seen[i])
        }
    }
}

/// Shade the hit lanes of one batch: add `weight × (local light)` to each lane's sample, and
/// push the reflected and refracted rays that pass the depth limit and the contribution
/// threshold onto `next`. Returns the shadow rays traced.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(super) fn shade<I: Isa>(
    s: &Shading,
    rays: &Rays8<I>,
    b: &Lanes<I>,
    surf: &Surfaces8<I>,
    lanes: M8<I>,
    depth: u32,
    sums: &mut TileSums,
    next: &mut Stream,
) -> u64 {
    let m = Materials8::gather(&s.materials, surf.material, lanes);
    let albedo = albedo(s, &m, surf);
    let wo = -rays.dir;
    // Orient the normals toward the side the ray came from.
    let entering = surf.geometric_normal.dot(wo).ge(F8::zero());
    let ng = V8::select(entering, surf.geometric_normal, -surf.geometric_normal);
    let ns = V8::select(entering, surf.shading_normal, -surf.shading_normal);
    if depth == 0 {
        let d = (surf.position - V8::splat(s.eye)).dot(V8::splat(s.forward));
        for i in 0..LANES {
            if lanes.lane(i) {
                sums.first_hit(b.sample[i] as usize, ns.lane(i), albedo.lane(i), d[i]);
            }
        }
    }
    let origins = RayOrigins8::new(surf.position, surf.p_error, surf.geometric_normal);
    let (local, shadows) = local(s, surf, &origins, &m, albedo, [wo, ng, ns], lanes);
    let cos_o = unit(ns.dot(wo));
    // Ray cones at the hit and after it (see `tracer.rs`).
    let width = b.width + b.spread * surf.t;
    let first = surf.object[lanes.bits().trailing_zeros() as usize % LANES];
    let curvature = if (surf.object.eq(U8x::splat(first)) | !lanes) == M8::all() {
        F8::splat(s.world.curvature(first))
    } else {
        F8::from_fn(|i| s.world.curvature(surf.object[i]))
    };
    let curvature = F8::select(entering, curvature, -curvature);
    let reflected_spread = (b.spread + F8::splat(2.0) * curvature * width).abs();
    let deeper = depth < s.max_depth;
    let reflect_dir = reflect(-wo, ns);

    // Schlick lanes: lerp(shaded, reflected, F), F = f0 + (1 − f0)(1 − cos)^5.
    let schlick = lanes & m.schlick;
    let x = F8::one() - cos_o;
    let x2 = x * x;
    let fifth = x * (x2 * x2);
    let f = m.f0 + (V8::splat1(1.0) - m.f0).scale(fifth);
    // The others: local × (1 − transparency), then reflection and refraction weights.
    let plain = lanes.and_not(m.schlick);
    let weighted = b.weight * local;
    let contribution =
        V8::select(schlick, weighted * (V8::splat1(1.0) - f), weighted.scale(F8::one() - m.transparency));
    for i in 0..LANES {
        if lanes.lane(i) {
            sums.add(b.sample[i] as usize, contribution.lane(i));
        }
    }
    if !deeper {
        return shadows;
    }
    let min = F8::splat(s.min_contribution);
    // Schlick reflection.
    let w = b.weight * f;
    let push = schlick & w.max_element().gt(min);
    // Dielectric weights (transparent lanes), with total internal reflection; batches without
    // a transparent lane (most) skip the refraction arithmetic.
    let transparent = plain & m.transparency.gt(F8::zero());
    let (w_refl, push_refl, refracted);
    if transparent.any() {
        let eta_i = F8::select(entering, F8::one(), m.ior);
        let eta_t = F8::select(entering, m.ior, F8::one());
        let eta = eta_i / eta_t;
        let i_dir = -wo;
        let cos_i = -ns.dot(i_dir);
        let k = F8::one() - eta * eta * (F8::one() - cos_i * cos_i);
        let refracts = transparent & k.ge(F8::zero());
        let refract_dir = (i_dir.scale(eta) + ns.scale(eta * cos_i - k.max(F8::zero()).sqrt())).normalize();
        let fr = fresnel_dielectric(cos_o, eta_i, eta_t);
        let fr = F8::select(refracts, fr, F8::one());
        let fresnel = transparent & m.fresnel;
        let k_refl = F8::select(
            fresnel,
            (m.reflectivity + m.transparency * fr).min(F8::one()),
            F8::select(transparent.and_not(refracts), (m.reflectivity + m.transparency).min(F8::one()), m.reflectivity),
        );
        let k_refr =
            F8::select(fresnel, m.transparency * (F8::one() - fr), F8::select(refracts, m.transparency, F8::zero()));
        w_refl = b.weight.scale(k_refl);
        push_refl = plain & k_refl.gt(F8::zero()) & w_refl.max_element().gt(min);
        let w_refr = b.weight.scale(k_refr);
        let push_refr = refracts & k_refr.gt(F8::zero()) & w_refr.max_element().gt(min);
        let refr_spread = (b.spread * eta_i / eta_t - (eta_t - eta_i) / eta_t * curvature * width).abs();
        refracted = push_refr.any().then_some((push_refr, refract_dir, w_refr, refr_spread));
    } else {
        w_refl = b.weight.scale(m.reflectivity);
        push_refl = plain & m.reflectivity.gt(F8::zero()) & w_refl.max_element().gt(min);
        refracted = None;
    }

    let reflected = push | push_refl;
    if reflected.any() {
        let origin = origins.toward(reflect_dir);
        let weight = V8::select(push, w, w_refl);
        next.push_lanes(reflected, origin, reflect_dir, weight, width, reflected_spread, b.sample);
    }
    if let Some((lanes, dir, weight, spread)) = refracted {
        next.push_lanes(lanes, origins.toward(dir), dir, weight, width, spread, b.sample);
    }
    shadows
}

/// Exact unpolarised dielectric Fresnel reflectance per lane (`optics::fresnel_dielectric`).
#[inline(always)]
fn fresnel_dielectric<I: Isa>(cos_i: F8<I>, eta_i: F8<I>, eta_t: F8<I>) -> F8<I> {
    let cos_i = unit(cos_i);
    let sin_t = eta_i / eta_t * (F8::one() - cos_i * cos_i).max(F8::zero()).sqrt();
    let total = sin_t.ge(F8::one());
    let cos_t = (F8::one() - sin_t * sin_t).max(F8::zero()).sqrt();
    let r_par = (eta_t * cos_i - eta_i * cos_t) / (eta_t * cos_i + eta_i * cos_t);
    let r_perp = (eta_i * cos_i - eta_t * cos_t) / (eta_i * cos_i + eta_t * cos_t);
    F8::select(total, F8::one(), F8::splat(0.5) * (r_par * r_par + r_perp * r_perp))
}

/// Phong of the hit lanes: `emission + K_a I_a + Σ visible lights (K_d I max(0, L·N) + K_s I
/// max(0, R·V)^n)`, one shadow packet per light. Returns the colour and the shadow rays traced.
/// `[wo, ng, ns]`: the outgoing direction and the normals turned toward it.
#[inline(always)]
fn local<I: Isa>(
    s: &Shading,
    surf: &Surfaces8<I>,
    origins: &RayOrigins8<I>,
    m: &Materials8<I>,
    albedo: V8<I>,
    [wo, ng, ns]: [V8<I>; 3],
    lanes: M8<I>,
) -> (V8<I>, u64) {
    let world = s.world;
    let ambient = match world.ambient_is_constant() {
        Some(c) => V8::splat(c),
        None => V8::from_fn(|i| if lanes.lane(i) { world.ambient(ns.lane(i)) } else { Rgb::ZERO }),
    };
    // Material::emitted: the front face (or both, two-sided) emits.
    let front = surf.geometric_normal.dot(wo).gt(F8::zero()) | m.two_sided;
    let mut c = V8::select(front, m.emission, V8::zero()) + (ambient * albedo).scale(m.ambient);
    let mut shadows = 0;
    for light in &s.lights {
        let (wi, distance, radiance, lit) = light.lanes.sample(surf.position);
        let cos_l = ns.dot(wi);
        // Lights below the geometric surface are not seen, whatever the shading normal says.
        let seen = lanes & lit & cos_l.gt(F8::zero()) & ng.dot(wi).gt(F8::zero());
        if seen.none() {
            continue;
        }
        shadows += u64::from(seen.bits().count_ones());
        let finite = distance.lt(F8::splat(f32::INFINITY));
        // SurfaceHit::spawn_ray_to (a point light's position) or spawn_ray (a direction).
        let target = surf.position + wi.scale(distance);
        let aim = V8::select(finite, target - surf.position, wi);
        let origin = origins.toward(aim);
        let to_target = target - origin;
        let dist = to_target.dot(to_target).sqrt();
        let dir = V8::select(finite, V8::new(to_target.x / dist, to_target.y / dist, to_target.z / dist), wi);
        let tmax = F8::select(finite, dist, F8::splat(f32::INFINITY));
        let shadow = Rays8 { origin, dir, tmin: F8::zero(), tmax };
        // Toward a point, every shadow segment lies on a ray leaving the light along −dir.
        let spheres = light.cones.as_ref().map_or(u64::MAX, |c| c.candidates(-dir, seen));
        let vis = world.transmittance_batch_among(&shadow, seen, spheres);
        let visible = seen & !(vis.x.eq(F8::zero()) & vis.y.eq(F8::zero()) & vis.z.eq(F8::zero()));
        if visible.none() {
            continue;
        }
        let r = reflect(-wi, ns);
        // R·V ≤ 0 gives 0^n = 0 for n > 0 (no power needed).
        let r_dot_v = r.dot(wo);
        let wants = m.specular.gt(F8::zero()) & (r_dot_v.gt(F8::zero()) | m.shininess.le(F8::zero())) & visible;
        let mut spec = F8::zero();
        if wants.any() {
            let base = r_dot_v.max(F8::zero());
            let fast = wants & m.shininess.gt(F8::zero()) & base.le(F8::one());
            spec = F8::select(fast, pow_unit(base, m.shininess) * m.specular, F8::zero());
            let slow = wants.and_not(fast);
            if slow.any() {
                for i in 0..LANES {
                    if slow.lane(i) {
                        spec[i] = base[i].powf(m.shininess[i]) * m.specular[i];
                    }
                }
            }
        }
        let term = vis * radiance * (albedo.scale(m.diffuse * cos_l) + V8::new(spec, spec, spec));
        c = V8::select(visible, c + term, c);
    }
    (c, shadows)
}
