//! Deferred shading of the reconstructed surface (Marroquim et al. 2007, §3.4; Botsch et al.
//! 2004): Phong on the G-buffer's normals and colours with the scene's lights (no shadows: the
//! points mode traces no rays) and the sky's irradiance as ambient light; the sky behind.
//! Eye-dome lighting (Boucheny 2009) shades clouds without normals from the depth alone.

use super::view::View;
use super::{PointFrame, PointShading};
use crate::lights8::LightLanes;
use glint_accel::lanes::{F8, Isa, LANES, LaneKernel, M8, U8x, V8, dispatch, pow_unit};
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::Scene;
use glint_scene::sky::IrradianceSh;
use rayon::prelude::*;

/// Eye-dome lighting: `exp(−k · strength · Σ max(0, ln z − ln z_neighbour))` over the 8
/// neighbours. Potree's constant (300 × the mean log2 step) in natural logs: 300 / (8 ln 2). A
/// plane seen so that its depth grows 0.5 % per pixel shades to about 0.45; a pixel 10 % behind
/// its neighbours (a silhouette's far side) to black.
const EDL_SCALE: f32 = 300.0 / (8.0 * std::f32::consts::LN_2);

/// How Phong is computed: eight pixels at a time in the best lanes this CPU has, in the SSE
/// lanes, or pixel by pixel (the oracle the tests hold the lanes to).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kernel {
    Best,
    Baseline,
    Scalar,
}

/// What a frame is shaded with.
pub(super) struct ShadeParams<'a> {
    pub(super) scene: &'a Scene,
    pub(super) view: &'a View,
    pub(super) sky_irradiance: Option<&'a IrradianceSh>,
    pub(super) shading: PointShading,
    pub(super) edl_strength: f32,
    pub(super) kernel: Kernel,
}

/// What shading a pixel needs, made once per frame.
pub(super) struct Shader<'a> {
    p: ShadeParams<'a>,
    /// The angle one pixel subtends at the centre: the sky's filter footprint.
    cone: f32,
    constant_sky: Option<Rgb>,
    /// Phong in lanes, unless a light projects a texture (only `Light::sample_in` applies it).
    lanes: Option<PhongLanes<'a>>,
}

impl<'a> Shader<'a> {
    pub(super) fn new(p: ShadeParams<'a>) -> Self {
        let constant_sky = match &p.scene.sky {
            glint_scene::Sky::Colour(c) => Some(*c),
            _ => None,
        };
        let lanes = (matches!(p.shading, PointShading::Phong | PointShading::Auto)
            && p.kernel != Kernel::Scalar
            && !p.scene.lights.iter().any(glint_scene::Light::is_textured))
        .then(|| PhongLanes::new(p.scene, p.sky_irradiance));
        Self { cone: 1.0 / p.view.focal, constant_sky, lanes, p }
    }

    /// Shade the G-buffer of `frame` into its colour plane: the pass on its own (`mod.rs`
    /// fuses [`Shader::row`] with the final push when [`Shader::per_pixel`]).
    pub(super) fn frame(&self, frame: &mut PointFrame) {
        let width = frame.width as usize;
        let PointFrame { depth, normal, albedo, material, colour, .. } = frame;
        let (depth, normal, albedo, material) = (&*depth, &*normal, &*albedo, &*material);
        colour.par_chunks_mut(width).enumerate().with_min_len(4).for_each(|(y, row)| {
            let g = GBufferRow {
                depth: &depth[y * width..(y + 1) * width],
                normal: &normal[y * width..(y + 1) * width],
                albedo: &albedo[y * width..(y + 1) * width],
                material: &material[y * width..(y + 1) * width],
            };
            self.row(y, &g, depth, row);
        });
    }

    /// Whether a pixel's colour depends on its own G-buffer texel only (all but eye-dome
    /// lighting, which compares each depth with its neighbours'): then a row can be shaded as
    /// soon as its G-buffer row is made.
    pub(super) fn per_pixel(&self) -> bool {
        self.p.shading != PointShading::EyeDome
    }

    /// Shade row `y` of the G-buffer (`g`) into `row`. `depth` is the whole depth plane, read
    /// only by eye-dome lighting (a per-pixel shader may be given `g.depth`).
    pub(super) fn row(&self, y: usize, g: &GBufferRow<'_>, depth: &[f32], row: &mut [Rgb]) {
        let (scene, view, width) = (self.p.scene, self.p.view, g.depth.len());
        let height = depth.len() / width.max(1);
        for (x0, row) in row.chunks_mut(LANES).enumerate().map(|(k, r)| (k * LANES, r)) {
            let n = row.len();
            let mut out = [Rgb::ZERO; LANES];
            // The sky behind, eight pixels at a time (a map's lookups run across lanes).
            let mut background = 0u8;
            let mut dirs = [Vec3::ZERO; LANES];
            for (k, (dir, z)) in dirs.iter_mut().zip(&g.depth[x0..x0 + n]).enumerate() {
                if !z.is_finite() {
                    background |= 1 << k;
                    if self.constant_sky.is_none() {
                        let p = Vec2::new((x0 + k) as f32 + 0.5, y as f32 + 0.5);
                        *dir = view.ray_at_depth_one(p).normalize();
                    }
                }
            }
            if background != 0 {
                out = match self.constant_sky {
                    Some(c) => [c; LANES],
                    None => scene.sky.radiance_filtered8(&dirs, &[self.cone; LANES], background),
                };
            }
            let surface = (((1u32 << n) - 1) as u8) & !background;
            if surface != 0 {
                if let Some(lanes) = &self.lanes {
                    let run = PhongRun { lanes, view, g, x0, y, surface, out: &mut out };
                    dispatch(run, self.p.kernel == Kernel::Baseline);
                } else {
                    for k in (0..n).filter(|k| surface >> k & 1 == 1) {
                        let x = x0 + k;
                        out[k] = match self.p.shading {
                            PointShading::Flat => g.albedo[x],
                            PointShading::EyeDome => {
                                g.albedo[x] * eye_dome(depth, width, height, x, y, self.p.edl_strength)
                            }
                            PointShading::Phong | PointShading::Auto => {
                                let dir = view.ray_at_depth_one(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                                let position = view.eye + dir * g.depth[x];
                                let wo = -dir.normalize();
                                phong(
                                    scene,
                                    self.p.sky_irradiance,
                                    g.material[x],
                                    g.albedo[x],
                                    g.normal[x],
                                    position,
                                    wo,
                                )
                            }
                        };
                    }
                }
            }
            row.copy_from_slice(&out[..n]);
        }
    }
}

/// One row's G-buffer.
pub(super) struct GBufferRow<'a> {
    pub(super) depth: &'a [f32],
    pub(super) normal: &'a [Vec3],
    pub(super) albedo: &'a [Rgb],
    pub(super) material: &'a [u32],
}

/// What Phong in lanes reads of the scene: the lights, the materials as arrays a lane can
/// gather from, and the ambient light.
struct PhongLanes<'a> {
    lights: Vec<LightLanes>,
    emission: Vec<Vec3>,
    ambient: Vec<f32>,
    diffuse: Vec<f32>,
    specular: Vec<f32>,
    shininess: Vec<f32>,
    scene_ambient: Rgb,
    sky_irradiance: Option<&'a IrradianceSh>,
}

impl<'a> PhongLanes<'a> {
    fn new(scene: &Scene, sky_irradiance: Option<&'a IrradianceSh>) -> Self {
        let m = &scene.materials;
        Self {
            lights: scene.lights.iter().map(LightLanes::new).collect(),
            emission: m.iter().map(|m| m.emission).collect(),
            ambient: m.iter().map(|m| m.ambient).collect(),
            diffuse: m.iter().map(|m| m.diffuse).collect(),
            specular: m.iter().map(|m| m.specular).collect(),
            shininess: m.iter().map(|m| m.shininess).collect(),
            scene_ambient: scene.ambient,
            sky_irradiance,
        }
    }
}

/// Phong of the surface lanes of eight pixels of a row, into `out`.
struct PhongRun<'a, 'b> {
    lanes: &'a PhongLanes<'a>,
    view: &'a View,
    g: &'a GBufferRow<'b>,
    x0: usize,
    y: usize,
    /// Lanes with a surface (the others keep what `out` holds).
    surface: u8,
    out: &'a mut [Rgb; LANES],
}

impl LaneKernel for PhongRun<'_, '_> {
    type Output = ();

    #[inline(always)]
    fn run<I: Isa>(self) {
        phong8::<I>(self);
    }
}

/// [`phong`] of eight pixels, with [`shade`]'s view ray and position, lane by lane in the
/// scalar code's order (no fused multiply-add), masks where it branches. One thing differs by
/// a rounding: the specular power is [`pow_unit`] (relative error < 3e-5), not `powf`.
#[inline(always)]
fn phong8<I: Isa>(PhongRun { lanes: t, view, g, x0, y, surface, out }: PhongRun<'_, '_>) {
    let n = LANES.min(g.depth.len() - x0);
    let lanes = M8::<I>::from_bits(u32::from(surface));
    let at = |k: usize| x0 + k.min(n - 1);
    let z = F8::<I>::from_fn(|k| g.depth[at(k)]);
    let normal = V8::<I>::from_fn(|k| g.normal[at(k)]);
    let albedo = V8::<I>::from_fn(|k| g.albedo[at(k)]);
    let material = U8x::<I>::from_array(std::array::from_fn(|k| g.material[at(k)]));
    // The view ray through each pixel centre, z = 1 (View::ray_at_depth_one), and its point.
    let px = F8::<I>::from_fn(|k| (x0 + k) as f32 + 0.5);
    let qx = (px - F8::splat(view.centre.x)) / F8::splat(view.focal);
    let qy = F8::<I>::splat(((y as f32 + 0.5) - view.centre.y) / view.focal);
    let dir = V8::splat(view.forward) + V8::splat(view.right).scale(qx) + V8::splat(view.down).scale(qy);
    let position = V8::splat(view.eye) + dir.scale(z);
    let wo = -dir.normalize();
    // The materials, gathered (one splat when the lanes share one, as they mostly do).
    let m0 = material[0] as usize;
    let shared = (0..LANES).all(|k| surface >> k & 1 == 0 || material[k] as usize == m0);
    let count = t.ambient.len();
    let known = M8::from_fn(|k| (material[k] as usize) < count);
    let index = |k: usize| if shared { m0 } else { material[k] as usize };
    let get = |v: &[f32], k: usize| v.get(index(k)).copied().unwrap_or(0.0);
    let (ka, kd) = (F8::<I>::from_fn(|k| get(&t.ambient, k)), F8::<I>::from_fn(|k| get(&t.diffuse, k)));
    let (ks, shininess) = (F8::<I>::from_fn(|k| get(&t.specular, k)), F8::<I>::from_fn(|k| get(&t.shininess, k)));
    let emission = V8::<I>::from_fn(|k| t.emission.get(index(k)).copied().unwrap_or(Vec3::ZERO));
    let ambient = match t.sky_irradiance {
        Some(sh) => V8::from_fn(|k| {
            if surface >> k & 1 == 1 {
                t.scene_ambient * sh.irradiance(normal.lane(k)) * std::f32::consts::FRAC_1_PI
            } else {
                Rgb::ZERO
            }
        }),
        None => V8::splat(t.scene_ambient),
    };
    let mut c = emission + (ambient * albedo).scale(ka);
    for light in &t.lights {
        let (wi, _, radiance, lit) = light.sample(position);
        let cos_l = normal.dot(wi);
        let seen = lanes & lit & cos_l.gt(F8::zero());
        if seen.none() {
            continue;
        }
        let r_dot_v = (normal.scale(F8::splat(2.0) * cos_l) - wi).dot(wo);
        let wants = seen & ks.gt(F8::zero()) & r_dot_v.gt(F8::zero());
        let mut spec = F8::zero();
        if wants.any() {
            let fast = wants & shininess.gt(F8::zero()) & r_dot_v.le(F8::one());
            spec = F8::select(fast, pow_unit(r_dot_v, shininess) * ks, F8::zero());
            for k in (0..LANES).filter(|&k| wants.and_not(fast).lane(k)) {
                spec[k] = r_dot_v[k].powf(shininess[k]) * ks[k];
            }
        }
        let term = radiance * (albedo.scale(kd * cos_l) + V8::new(spec, spec, spec));
        c = V8::select(seen, c + term, c);
    }
    // A material index the scene does not have shows the albedo (as `phong` does).
    let c = V8::select(known, c, albedo);
    for k in (0..n).filter(|k| surface >> k & 1 == 1) {
        out[k] = c.lane(k);
    }
}

/// Phong as the Whitted mode computes it, without shadow rays: `K_a I_a + Σ lights (K_d I
/// max(0, L·N) + K_s I max(0, R·V)^n)` plus emission.
#[inline]
fn phong(
    scene: &Scene,
    sky_irradiance: Option<&IrradianceSh>,
    material: u32,
    albedo: Rgb,
    n: Vec3,
    position: Vec3,
    wo: Vec3,
) -> Rgb {
    let Some(m) = scene.materials.get(material as usize) else { return albedo };
    let ambient = match sky_irradiance {
        Some(sh) => scene.ambient * sh.irradiance(n) * std::f32::consts::FRAC_1_PI,
        None => scene.ambient,
    };
    let mut c = m.emission + ambient * albedo * m.ambient;
    for light in &scene.lights {
        let Some(ls) = light.sample_in(position, &scene.textures) else { continue };
        let cos_l = n.dot(ls.wi);
        if cos_l <= 0.0 {
            continue;
        }
        let r_dot_v = (2.0 * cos_l * n - ls.wi).dot(wo);
        let spec = if m.specular > 0.0 && r_dot_v > 0.0 { r_dot_v.powf(m.shininess) * m.specular } else { 0.0 };
        c += ls.radiance * (albedo * (m.diffuse * cos_l) + Rgb::splat(spec));
    }
    c
}

/// The eye-dome factor of pixel (x, y); neighbours without a surface count as far away (they
/// never darken).
#[inline]
fn eye_dome(depth: &[f32], width: usize, height: usize, x: usize, y: usize, strength: f32) -> f32 {
    let ln_z = depth[y * width + x].ln();
    let mut response = 0.0f32;
    for (dx, dy) in [(-1i64, -1i64), (0, -1), (1, -1), (-1, 0), (1, 0), (-1, 1), (0, 1), (1, 1)] {
        let (nx, ny) = (x as i64 + dx, y as i64 + dy);
        if nx < 0 || ny < 0 || nx >= width as i64 || ny >= height as i64 {
            continue;
        }
        let zn = depth[ny as usize * width + nx as usize];
        if zn.is_finite() {
            response += (ln_z - zn.ln()).max(0.0);
        }
    }
    (-EDL_SCALE * strength * response).exp()
}
