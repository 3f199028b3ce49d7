//! The Whitted tracer of one primary ray (DESIGN.md §1; the thesis's backward ray tracer).
//!
//! At the nearest hit: Phong local shading with one shadow ray per light (attenuated through
//! transparent occluders), plus a reflected and a refracted ray, combined as
//! `I = I_local + K_refl I_refl + K_refr I_refr`. The tree of rays is walked with an explicit
//! stack, never by recursion; a branch stops at the maximum depth or when its accumulated weight
//! falls under the contribution threshold. Rays that leave the scene return the sky.

use super::optics::{fresnel_dielectric, reflect, refract};
use crate::settings::WhittedSettings;
use crate::stats::RayCounts;
use crate::world::{SurfaceHit, World};
use glint_core::{Ray, Rgb, Vec3};

/// What the primary ray saw first (for the AOVs).
#[derive(Clone, Copy, Debug)]
pub struct FirstHit {
    pub normal: Vec3,
    pub albedo: Rgb,
    pub position: Vec3,
}

/// One ray of the tree, with its ray cone (Akenine-Möller et al. 2021): the footprint's width
/// at the ray origin and its spread angle, both in world units/radians. Sky lookups filter over
/// the spread; curved mirrors widen it.
#[derive(Clone, Copy)]
struct Branch {
    ray: Ray,
    weight: Rgb,
    depth: u32,
    width: f32,
    spread: f32,
}

/// Reusable per-thread state (the branch stack).
#[derive(Default)]
pub struct Tracer {
    stack: Vec<Branch>,
    pub counts: RayCounts,
}

impl Tracer {
    /// Radiance along a primary ray, and its first hit.
    /// `cone` is the primary ray's footprint (angular width in radians) for sky filtering.
    pub fn trace(&mut self, world: &World, ray: Ray, cone: f32, params: &WhittedSettings) -> (Rgb, Option<FirstHit>) {
        let mut colour = Rgb::ZERO;
        let mut first = None;
        self.stack.clear();
        self.stack.push(Branch { ray, weight: Rgb::ONE, depth: 0, width: 0.0, spread: cone });
        while let Some(b) = self.stack.pop() {
            if b.depth == 0 {
                self.counts.primary += 1;
            } else {
                self.counts.secondary += 1;
            }
            let Some(hit) = world.intersect(&b.ray) else {
                colour += b.weight * world.sky().radiance_filtered(b.ray.dir, b.spread);
                continue;
            };
            let m = world.material(hit.material);
            let albedo = world.albedo(&hit);
            // Every ray direction here is unit length (camera rays are normalised, reflection
            // preserves length, refraction renormalises).
            let wo = -b.ray.dir;
            // Orient the normals toward the side the ray came from.
            let entering = hit.geometric_normal.dot(wo) >= 0.0;
            let (ng, ns) = if entering {
                (hit.geometric_normal, hit.shading_normal)
            } else {
                (-hit.geometric_normal, -hit.shading_normal)
            };
            if b.depth == 0 {
                first = Some(FirstHit { normal: ns, albedo, position: hit.position });
            }
            let local = self.local(world, &hit, m, albedo, wo, ng, ns);
            let cos_o = ns.dot(wo).clamp(0.0, 1.0);
            // The cone at the hit and after it (ray cones): a mirror of curvature κ turns the
            // edges of a footprint of width w apart by 2κw on its convex side (together on its
            // concave side); a refracting surface bends the spread like a thin lens of power
            // (η_t − η_i)κ / η_t, converging where the surface bulges toward the ray. Past a
            // focus the cone widens again, hence the absolute values.
            let width = b.width + b.spread * hit.t;
            let curvature = if entering { world.curvature(hit.object) } else { -world.curvature(hit.object) };
            let reflected_spread = (b.spread + 2.0 * curvature * width).abs();
            // Fresnel reflection (DESIGN.md §4): lerp(shaded, reflected, F), F by Schlick.
            if let Some(f) = m.schlick(cos_o) {
                colour += b.weight * local * (Rgb::ONE - f);
                if b.depth < params.max_depth {
                    let weight = b.weight * f;
                    if weight.max_element() > params.min_contribution {
                        let ray = hit.spawn_ray(reflect(-wo, ns));
                        self.stack.push(Branch { ray, weight, depth: b.depth + 1, width, spread: reflected_spread });
                    }
                }
                continue;
            }
            colour += b.weight * local * (1.0 - m.transparency);

            if b.depth >= params.max_depth {
                continue;
            }
            // Reflection and refraction weights.
            let (mut k_refl, mut k_refr) = (m.reflectivity, m.transparency);
            let (eta_i, eta_t) = if entering { (1.0, m.ior) } else { (m.ior, 1.0) };
            let refracted = if m.is_transparent() { refract(-wo, ns, eta_i / eta_t) } else { None };
            if m.is_transparent() && m.fresnel {
                let f = match refracted {
                    Some(_) => fresnel_dielectric(cos_o, eta_i, eta_t),
                    None => 1.0, // total internal reflection
                };
                k_refl = (m.reflectivity + m.transparency * f).min(1.0);
                k_refr = m.transparency * (1.0 - f);
            } else if m.is_transparent() && refracted.is_none() {
                k_refl = (k_refl + k_refr).min(1.0);
                k_refr = 0.0;
            }
            let push = |stack: &mut Vec<Branch>, dir: Vec3, k: f32, spread: f32| {
                let weight = b.weight * k;
                if k > 0.0 && weight.max_element() > params.min_contribution {
                    stack.push(Branch { ray: hit.spawn_ray(dir), weight, depth: b.depth + 1, width, spread });
                }
            };
            push(&mut self.stack, reflect(-wo, ns), k_refl, reflected_spread);
            if let Some(t) = refracted {
                let spread = (b.spread * eta_i / eta_t - (eta_t - eta_i) / eta_t * curvature * width).abs();
                push(&mut self.stack, t, k_refr, spread);
            }
        }
        (colour, first)
    }

    /// Phong: `K_a I_a + Σ visible lights (K_d I max(0, L·N) + K_s I max(0, R·V)^n)` plus emission.
    #[allow(clippy::too_many_arguments)]
    fn local(
        &mut self,
        world: &World,
        hit: &SurfaceHit,
        m: &glint_scene::Material,
        albedo: Rgb,
        wo: Vec3,
        ng: Vec3,
        ns: Vec3,
    ) -> Rgb {
        let mut c = world.emitted(hit, wo) + world.ambient(ns) * albedo * m.ambient;
        // Lights in groups: every shadow ray of a group is set up before any is traced, so the
        // (latency-bound) set-ups and traversals of different lights overlap; the group's
        // contributions are then added in light order, as one light at a time would.
        const GROUP: usize = 4;
        for lights in world.scene().lights.chunks(GROUP) {
            let mut rays = [None; GROUP];
            for (slot, light) in rays.iter_mut().zip(lights) {
                let Some(ls) = light.sample_in(hit.position, &world.scene().textures) else { continue };
                let cos_l = ns.dot(ls.wi);
                // Lights below the geometric surface are not seen, whatever the shading normal says.
                if cos_l <= 0.0 || ng.dot(ls.wi) <= 0.0 {
                    continue;
                }
                let shadow = if ls.distance.is_finite() {
                    hit.spawn_ray_to(hit.position + ls.wi * ls.distance)
                } else {
                    hit.spawn_ray(ls.wi)
                };
                *slot = Some((ls, cos_l, shadow));
            }
            for (ls, cos_l, shadow) in rays.into_iter().flatten() {
                self.counts.shadow += 1;
                let vis = world.transmittance(&shadow);
                if vis == Rgb::ZERO {
                    continue;
                }
                let r = reflect(-ls.wi, ns);
                // R·V ≤ 0 gives 0^n = 0 for n > 0: no powf needed (bit for bit the same).
                let r_dot_v = r.dot(wo);
                let spec = if m.specular > 0.0 && (r_dot_v > 0.0 || m.shininess <= 0.0) {
                    r_dot_v.max(0.0).powf(m.shininess) * m.specular
                } else {
                    0.0
                };
                c += vis * ls.radiance * (albedo * (m.diffuse * cos_l) + Rgb::splat(spec));
            }
        }
        c
    }
}
