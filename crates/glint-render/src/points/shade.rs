//! Deferred shading of the reconstructed surface (Marroquim et al. 2007, §3.4; Botsch et al.
//! 2004): Phong on the G-buffer's normals and colours with the scene's lights (no shadows: the
//! points mode traces no rays) and the sky's irradiance as ambient light; the sky behind.
//! Eye-dome lighting (Boucheny 2009) shades clouds without normals from the depth alone.

use super::view::View;
use super::{PointFrame, PointShading};
use glint_core::{Rgb, Vec2, Vec3};
use glint_scene::Scene;
use glint_scene::sky::IrradianceSh;
use rayon::prelude::*;

/// Eye-dome lighting: `exp(−k · strength · Σ max(0, ln z − ln z_neighbour))` over the 8
/// neighbours. Potree's constant (300 × the mean log2 step) in natural logs: 300 / (8 ln 2). A
/// plane seen so that its depth grows 0.5 % per pixel shades to about 0.45; a pixel 10 % behind
/// its neighbours (a silhouette's far side) to black.
const EDL_SCALE: f32 = 300.0 / (8.0 * std::f32::consts::LN_2);

pub fn shade(
    scene: &Scene,
    view: &View,
    sky_irradiance: Option<&IrradianceSh>,
    shading: PointShading,
    edl_strength: f32,
    frame: &mut PointFrame,
) {
    let width = frame.width as usize;
    let height = frame.height as usize;
    // The angle one pixel subtends at the centre: the sky's filter footprint.
    let cone = 1.0 / view.focal;
    let constant_sky = match &scene.sky {
        glint_scene::Sky::Colour(c) => Some(*c),
        _ => None,
    };
    let PointFrame { depth, normal, albedo, material, colour, .. } = frame;
    let (depth, normal, albedo, material) = (&*depth, &*normal, &*albedo, &*material);
    colour.par_chunks_mut(width).enumerate().with_min_len(4).for_each(|(y, row)| {
        // The sky behind, eight pixels at a time (a map's lookups run across lanes).
        let mut sky = [Rgb::ZERO; 8];
        for (x, out) in row.iter_mut().enumerate() {
            let i = y * width + x;
            if constant_sky.is_none() && x % 8 == 0 {
                let mut background = 0u8;
                let mut dirs = [Vec3::ZERO; 8];
                for k in 0..8.min(width - x) {
                    if !depth[i + k].is_finite() {
                        background |= 1 << k;
                        let p = Vec2::new((x + k) as f32 + 0.5, y as f32 + 0.5);
                        dirs[k] = view.ray_at_depth_one(p).normalize();
                    }
                }
                if background != 0 {
                    sky = scene.sky.radiance_filtered8(&dirs, &[cone; 8], background);
                }
            }
            let z = depth[i];
            if !z.is_finite() {
                *out = constant_sky.unwrap_or(sky[x % 8]);
                continue;
            }
            let dir = view.ray_at_depth_one(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
            *out = match shading {
                PointShading::Flat => albedo[i],
                PointShading::EyeDome => albedo[i] * eye_dome(depth, width, height, x, y, edl_strength),
                PointShading::Phong | PointShading::Auto => {
                    let position = view.eye + dir * z;
                    phong(scene, sky_irradiance, material[i], albedo[i], normal[i], position, -dir.normalize())
                }
            };
        }
    });
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
