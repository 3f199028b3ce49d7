//! A physically based material at one hit (pipeline: scene → acceleration structure →
//! **integrators** → film): the material's BSDF tree ([`glint_scene::bsdf`]) read where the ray
//! landed — textures evaluated at the hit's uv, the shading frame built (Mitsuba 3's: the
//! shading normal with the uv tangent `∂p/∂u` made orthogonal to it; perturbed by a normal or
//! bump map; mirrored when a two-sided model is seen from behind), blends and masks flattened
//! into one [`Mixture`] of [`models`](super::models) with plain parameters.
//!
//! Sidedness and frames follow Mitsuba's plugins (`twosided.cpp`, `normalmap.cpp`,
//! `bumpmap.cpp`): one-sided models are black from behind; a perturbed frame only passes
//! directions on the same side of both frames, and is weighted by the shadow-terminator term
//! of Estevez et al. 2019 (`normalmap_helpers.h`). One frame serves the whole tree: a normal
//! map, bump map or two-sided model anywhere in it applies to every branch (blends of
//! differently mapped models are rare; docs/scene-format.md says so).

use super::models::{MIXTURE_DELTA_LOBES, Microfacet, Mixture, Model, PrincipledParams};
use crate::world::{SurfaceHit, World};
use glint_core::colour::luminance;
use glint_core::{Frame, Rgb, Vec2, Vec3};
use glint_scene::Scene;
use glint_scene::bsdf::{BsdfKind, Roughness, Tex};

/// The deepest BSDF tree read (validation already refuses cycles; this bounds the walk).
const MAX_NESTING: u32 = 16;

/// A physically based BSDF at a hit, seen from one direction.
#[derive(Clone, Copy, Debug)]
pub struct Physical {
    /// The shading frame the models work in (x = tangent, y = bitangent, z = normal; z may
    /// point away from the viewer: one-sided models are then black).
    frame: Frame,
    /// The unperturbed shading frame, when a normal or bump map perturbed `frame`.
    base: Option<Frame>,
    pub mixture: Mixture,
    /// The direction toward the viewer, in `frame`.
    wo: Vec3,
}

/// A material tree that is Mitsuba's `diffuse` alone (or `twosided` over two of them), with no
/// normal or bump map, read without the general model's machinery (shading frame from the
/// uv derivatives, mixture, ~400 bytes of state): its reflectance toward the viewer — zero
/// from behind a one-sided `diffuse`, as Mitsuba's — and the shading normal on the viewer's
/// side (the frame's `z` as [`Physical::normal`] gives it). `None` for any other tree.
///
/// The Lambertian lobe it stands for is the general model's `Model::Diffuse` value for value:
/// `ρ/π` for `wi` above the shading frame, cosine-weighted sampling (around another tangent
/// frame: the same density, other directions for the same random numbers).
pub fn lambertian_at(world: &World, hit: &SurfaceHit, dir: Vec3, root: usize) -> Option<(Rgb, Vec3)> {
    let bsdfs = &world.scene().bsdfs;
    let n = hit.shading_normal;
    let cos_o = -n.dot(dir);
    let reflectance = |t: &Tex<Rgb>| match *t {
        Tex::Value(v) => v,
        Tex::Texture(i) => world.texture_at(i, hit),
    };
    let toward = if cos_o < 0.0 { -n } else { n };
    match bsdfs.get(root)? {
        BsdfKind::Diffuse { reflectance: r } => Some((if cos_o > 0.0 { reflectance(r) } else { Rgb::ZERO }, toward)),
        BsdfKind::TwoSided { front, back } => {
            // Seen from behind: the back's model in the mirrored frame (as `Reader::read`).
            let (side, cos) = if cos_o < 0.0 { (*back, -cos_o) } else { (*front, cos_o) };
            match bsdfs.get(side)? {
                BsdfKind::Diffuse { reflectance: r } => {
                    Some((if cos > 0.0 { reflectance(r) } else { Rgb::ZERO }, toward))
                }
                _ => None,
            }
        }
        _ => None,
    }
}

impl Physical {
    /// The material tree `root` of `world`'s scene at `hit`, seen along `dir` (the ray's
    /// direction). `None` when the tree has more terms than a [`Mixture`] holds.
    pub fn at(world: &World, hit: &SurfaceHit, dir: Vec3, root: usize) -> Option<Physical> {
        let scene = world.scene();
        let wo_world = -dir;
        let n = hit.shading_normal;
        let (dp_du, dp_dv) = world.uv_derivatives(hit);
        let base = gram_schmidt(n, dp_du);
        let mut reader = Reader {
            scene,
            world,
            hit,
            uv: hit.uv,
            frame: base,
            perturbed: false,
            wo: wo_world,
            dp_du,
            dp_dv,
            geometric: hit.geometric_normal,
            mixture: Mixture::default(),
        };
        reader.read(root, 1.0, 0)?;
        let frame = reader.frame;
        let perturbed = reader.perturbed;
        Some(Physical {
            frame,
            base: perturbed.then_some(base),
            mixture: reader.mixture,
            wo: to_local(&frame, wo_world),
        })
    }

    #[inline]
    fn local(&self, v: Vec3) -> Vec3 {
        to_local(&self.frame, v)
    }

    #[inline]
    fn world(&self, v: Vec3) -> Vec3 {
        self.frame.x * v.x + self.frame.y * v.y + self.frame.z * v.z
    }

    /// Mitsuba's rule for perturbed frames: `wi` counts only on the same side of both, and is
    /// weighted by the shadow-terminator term. 1 without a perturbation.
    #[inline]
    fn perturbation_weight(&self, wi_world: Vec3, wi_local: Vec3) -> f32 {
        let Some(base) = &self.base else { return 1.0 };
        let cos_base = base.z.dot(wi_world);
        if cos_base * wi_local.z <= 0.0 {
            return 0.0;
        }
        // The perturbed normal and wi in the unperturbed frame.
        let n = to_local(base, self.frame.z);
        let wi = to_local(base, wi_world);
        shadow_terminator(n, wi)
    }

    /// `f · |cos|` toward `wi` (world), non-delta lobes.
    #[inline]
    pub fn eval(&self, wi: Vec3) -> Rgb {
        let l = self.local(wi);
        let w = self.perturbation_weight(wi, l);
        if w == 0.0 { Rgb::ZERO } else { self.mixture.eval(self.wo, l) * w }
    }

    /// Solid-angle pdf of [`Physical::sample`] returning `wi` through a non-delta lobe.
    #[inline]
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let l = self.local(wi);
        if self.base.is_some() && self.perturbation_weight(wi, l) == 0.0 {
            return 0.0;
        }
        self.mixture.pdf(self.wo, l)
    }

    /// The diffuse lobe's colour (demodulation factor) and its shape toward `wi` (with cosine).
    #[inline]
    pub fn diffuse_albedo(&self) -> Rgb {
        self.mixture.diffuse_albedo(self.wo)
    }

    #[inline]
    pub fn eval_diffuse(&self, wi: Vec3) -> f32 {
        let l = self.local(wi);
        let w = self.perturbation_weight(wi, l);
        if w == 0.0 { 0.0 } else { self.mixture.eval_diffuse(self.wo, l) * w }
    }

    #[inline]
    pub fn p_delta(&self) -> f32 {
        self.mixture.p_delta(self.wo)
    }

    /// A sampled direction (world), weight `f·cos/pdf` (delta: the lobe over its probability).
    #[inline]
    pub fn sample(&self, u_lobe: f32, u: Vec2) -> Option<(Vec3, Rgb, f32, bool)> {
        let s = self.mixture.sample(self.wo, u_lobe, u)?;
        let wi = self.world(s.wi);
        if s.delta {
            return Some((wi, s.weight, 0.0, true));
        }
        let w = self.perturbation_weight(wi, s.wi);
        if w == 0.0 || s.pdf.is_nan() || s.pdf <= 0.0 {
            return None;
        }
        Some((wi, s.weight * w, s.pdf, false))
    }

    /// A direction from the non-delta lobes only: (world direction, `f·cos/pdf`, pdf), the
    /// pdf that of the non-delta lobes alone (normalised over them). A term is chosen in
    /// proportion to its weight times its non-delta probability; within it the delta lobes
    /// are skipped (every model picks them first, for `u_lobe` below its `p_delta`), so the
    /// density is the mixture's over `1 − p_delta`.
    pub fn sample_non_delta(&self, u_lobe: f32, u: Vec2) -> Option<(Vec3, Rgb, f32)> {
        let terms = self.mixture.terms();
        let mut q = [0.0f32; super::models::MIXTURE_TERMS];
        let mut total_q = 0.0;
        for (k, (w, m)) in terms.iter().enumerate() {
            q[k] = if *w > 0.0 { w * (1.0 - m.p_delta(self.wo)).max(0.0) } else { 0.0 };
            total_q += q[k];
        }
        if total_q.is_nan() || total_q <= 0.0 {
            return None;
        }
        let mut x = u_lobe * total_q;
        let mut chosen = None;
        for (k, (_, m)) in terms.iter().enumerate() {
            if q[k] <= 0.0 {
                continue;
            }
            if x < q[k] || chosen.is_none() && k + 1 == terms.len() {
                let p_delta = m.p_delta(self.wo);
                let rest = (x / q[k]).clamp(0.0, 1.0 - f32::EPSILON / 2.0);
                chosen = Some((m, (p_delta + rest * (1.0 - p_delta)).min(1.0 - f32::EPSILON / 2.0)));
                break;
            }
            x -= q[k];
        }
        let (model, u_model) = chosen?;
        let s = model.sample(self.wo, u_model, u)?;
        if s.delta {
            return None;
        }
        let wi = self.world(s.wi);
        let w = self.perturbation_weight(wi, s.wi);
        let p_non_delta = 1.0 - self.mixture.p_delta(self.wo);
        let pdf = self.mixture.pdf(self.wo, s.wi) / p_non_delta;
        if w == 0.0 || !(pdf > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some((wi, self.mixture.eval(self.wo, s.wi) * (w / pdf), pdf))
    }

    /// The delta lobes (world direction, full weight).
    #[inline]
    pub fn delta_lobes(&self) -> [Option<(Vec3, Rgb)>; MIXTURE_DELTA_LOBES] {
        self.mixture.delta_lobes(self.wo).map(|l| l.map(|(d, w)| (self.world(d), w)))
    }

    /// The shading normal on the viewer's side (the guide's normal).
    #[inline]
    pub fn normal(&self) -> Vec3 {
        if self.wo.z < 0.0 { -self.frame.z } else { self.frame.z }
    }
}

#[inline]
fn to_local(f: &Frame, v: Vec3) -> Vec3 {
    Vec3::new(f.x.dot(v), f.y.dot(v), f.z.dot(v))
}

/// The frame of normal `n` whose tangent is `dp_du` made orthogonal to it (Mitsuba's
/// `initialize_sh_frame`); any tangent when `dp_du` is parallel to `n`.
fn gram_schmidt(n: Vec3, dp_du: Vec3) -> Frame {
    let s = dp_du - n * n.dot(dp_du);
    let len = s.length();
    if len.is_nan() || len <= 1e-12 || !len.is_finite() {
        return Frame::from_z(n);
    }
    let s = s / len;
    Frame { x: s, y: n.cross(s), z: n }
}

/// Estevez et al. 2019's shadowing of a perturbed normal `n` (in the unperturbed frame) for the
/// direction `w` (same frame): `2 / (1 + sqrt(1 + α² tan²θ_w))` with `α² = min(tan²θ_n / 8, 1)`.
fn shadow_terminator(n: Vec3, w: Vec3) -> f32 {
    let tan2 = |v: Vec3| {
        let c2 = v.z * v.z;
        if c2 <= 0.0 { f32::INFINITY } else { ((1.0 - c2).max(0.0) / c2).min(f32::MAX) }
    };
    let alpha2 = (0.125 * tan2(n)).min(1.0);
    2.0 / (1.0 + (1.0 + alpha2 * tan2(w)).sqrt())
}

/// Walks a material's BSDF tree at one hit.
struct Reader<'a> {
    scene: &'a Scene,
    world: &'a World,
    hit: &'a SurfaceHit,
    uv: Vec2,
    frame: Frame,
    perturbed: bool,
    /// Toward the viewer, world space.
    wo: Vec3,
    dp_du: Vec3,
    dp_dv: Vec3,
    geometric: Vec3,
    mixture: Mixture,
}

impl Reader<'_> {
    fn rgb(&self, t: &Tex<Rgb>) -> Rgb {
        match *t {
            Tex::Value(v) => v,
            Tex::Texture(i) => self.world.texture_at(i, self.hit),
        }
    }

    /// A scalar texture: an RGB texture's luminance (Mitsuba's `eval_1`).
    fn float(&self, t: &Tex<f32>) -> f32 {
        match *t {
            Tex::Value(v) => v,
            Tex::Texture(i) => luminance(self.world.texture_at(i, self.hit)),
        }
    }

    fn micro(&self, r: &Roughness) -> Microfacet {
        Microfacet::new(
            r.distribution,
            self.float(&r.alpha_u).max(1e-4),
            self.float(&r.alpha_v).max(1e-4),
            r.sample_visible,
        )
    }

    /// Mitsuba's `principled` / `principledthin` with every texture read.
    fn principled(&self, p: &glint_scene::bsdf::Principled) -> PrincipledParams {
        let has_spec_trans = !matches!(p.spec_trans, Tex::Value(v) if v == 0.0);
        PrincipledParams {
            thin: p.thin,
            base_color: self.rgb(&p.base_color),
            roughness: self.float(&p.roughness),
            anisotropic: self.float(&p.anisotropic),
            metallic: self.float(&p.metallic),
            spec_trans: self.float(&p.spec_trans),
            spec_tint: self.float(&p.spec_tint),
            sheen: self.float(&p.sheen),
            sheen_tint: self.float(&p.sheen_tint),
            flatness: self.float(&p.flatness),
            clearcoat: self.float(&p.clearcoat),
            clearcoat_gloss: self.float(&p.clearcoat_gloss),
            diff_trans: self.float(&p.diff_trans),
            eta: PrincipledParams::resolve_eta(p.thin, p.eta, p.specular, has_spec_trans),
        }
    }

    /// Adds tree `id` with weight `weight`; `None` when the mixture is full.
    fn read(&mut self, id: usize, weight: f32, depth: u32) -> Option<()> {
        if depth > MAX_NESTING || weight <= 0.0 {
            return Some(());
        }
        let model = match &self.scene.bsdfs[id] {
            BsdfKind::TwoSided { front, back } => {
                // Seen from behind: mirror the frame's normal (Mitsuba flips the local z).
                let back_side = self.frame.z.dot(self.wo) < 0.0;
                if back_side {
                    self.frame.z = -self.frame.z;
                }
                return self.read(if back_side { *back } else { *front }, weight, depth + 1);
            }
            BsdfKind::Mask { opacity, inner, cutoff } => {
                let a = self.float(opacity).clamp(0.0, 1.0);
                // glTF's alpha MASK: all or nothing at the cutoff.
                let a = match cutoff {
                    Some(c) => f32::from(u8::from(a >= *c)),
                    None => a,
                };
                if a < 1.0 {
                    self.mixture.set_pass_through(self.mixture.pass_through() + weight * (1.0 - a));
                }
                return self.read(*inner, weight * a, depth + 1);
            }
            BsdfKind::Blend { weight: w, a, b } => {
                let t = self.float(w).clamp(0.0, 1.0);
                self.read(*a, weight * (1.0 - t), depth + 1)?;
                return self.read(*b, weight * t, depth + 1);
            }
            BsdfKind::NormalMap { normals, inner } => {
                let c = self.scene.textures[*normals].evaluate(self.uv);
                self.perturb_normal(c * 2.0 - Rgb::ONE);
                return self.read(*inner, weight, depth + 1);
            }
            BsdfKind::BumpMap { height, scale, inner } => {
                self.bump(*height, *scale);
                return self.read(*inner, weight, depth + 1);
            }
            BsdfKind::Diffuse { reflectance } => Model::Diffuse { reflectance: self.rgb(reflectance) },
            BsdfKind::Conductor { eta, k, specular_reflectance } => {
                Model::Conductor { eta: *eta, k: *k, specular_reflectance: self.rgb(specular_reflectance) }
            }
            BsdfKind::RoughConductor { roughness, eta, k, specular_reflectance } => Model::RoughConductor {
                micro: self.micro(roughness),
                eta: *eta,
                k: *k,
                specular_reflectance: self.rgb(specular_reflectance),
            },
            BsdfKind::Dielectric { eta, specular_reflectance, specular_transmittance } => Model::Dielectric {
                eta: *eta,
                specular_reflectance: self.rgb(specular_reflectance),
                specular_transmittance: self.rgb(specular_transmittance),
            },
            BsdfKind::ThinDielectric { eta, specular_reflectance, specular_transmittance } => Model::ThinDielectric {
                eta: *eta,
                specular_reflectance: self.rgb(specular_reflectance),
                specular_transmittance: self.rgb(specular_transmittance),
            },
            BsdfKind::RoughDielectric { roughness, eta, specular_reflectance, specular_transmittance } => {
                Model::RoughDielectric {
                    micro: self.micro(roughness),
                    eta: *eta,
                    specular_reflectance: self.rgb(specular_reflectance),
                    specular_transmittance: self.rgb(specular_transmittance),
                }
            }
            BsdfKind::Plastic { diffuse_reflectance, specular_reflectance, eta, nonlinear } => Model::Plastic {
                diffuse_reflectance: self.rgb(diffuse_reflectance),
                specular_reflectance: self.rgb(specular_reflectance),
                eta: *eta,
                nonlinear: *nonlinear,
            },
            BsdfKind::RoughPlastic { roughness, diffuse_reflectance, specular_reflectance, eta, nonlinear } => {
                Model::RoughPlastic {
                    micro: self.micro(roughness),
                    diffuse_reflectance: self.rgb(diffuse_reflectance),
                    specular_reflectance: self.rgb(specular_reflectance),
                    eta: *eta,
                    nonlinear: *nonlinear,
                }
            }
            BsdfKind::Principled(p) => Model::Principled(self.principled(p)),
        };
        self.mixture.push(weight, model).ok()
    }

    /// A tangent-space normal `n` (in the current frame) becomes the frame's normal, the
    /// tangent `∂p/∂u` made orthogonal to it (Mitsuba's `normalmap`, flipping normals that
    /// face away from the viewer as its `flip_invalid_normals` does).
    fn perturb_normal(&mut self, n_local: Vec3) {
        let mut n = n_local.normalize_or(Vec3::Z);
        let wo = to_local(&self.frame, self.wo);
        if wo.z * wo.dot(n) <= 0.0 {
            n = Vec3::new(-n.x, -n.y, n.z);
        }
        let n_world = (self.frame.x * n.x + self.frame.y * n.y + self.frame.z * n.z).normalize_or(self.frame.z);
        // Mitsuba builds the perturbed frame's tangent from the local x axis made orthogonal
        // to the perturbed normal, then takes it to world space.
        let s_local = (Vec3::X - n * n.x).normalize_or(Vec3::X);
        let s_world = self.frame.x * s_local.x + self.frame.y * s_local.y + self.frame.z * s_local.z;
        self.frame = Frame { x: s_world, y: n_world.cross(s_world), z: n_world };
        self.perturbed = true;
    }

    /// Mitsuba's `bumpmap`: the height texture's uv gradient (central differences) times
    /// `scale` displaces `∂p/∂u` and `∂p/∂v` along the normal; their cross product is the new
    /// normal, turned to the geometric side.
    fn bump(&mut self, height: usize, scale: f32) {
        let tex = &self.scene.textures[height];
        let h = 1e-4;
        let at = |d: Vec2| luminance(tex.evaluate(self.uv + d));
        let gu = (at(Vec2::new(h, 0.0)) - at(Vec2::new(-h, 0.0))) / (2.0 * h) * scale;
        let gv = (at(Vec2::new(0.0, h)) - at(Vec2::new(0.0, -h))) / (2.0 * h) * scale;
        let n = self.frame.z;
        let du = self.dp_du + n * (gu - n.dot(self.dp_du));
        let dv = self.dp_dv + n * (gv - n.dot(self.dp_dv));
        let mut bumped = du.cross(dv).normalize_or(n);
        if self.geometric.dot(bumped) < 0.0 {
            bumped = -bumped;
        }
        let local = to_local(&self.frame, bumped);
        self.perturb_normal_keep_side(local);
    }

    fn perturb_normal_keep_side(&mut self, n_local: Vec3) {
        self.perturb_normal(n_local);
    }
}
