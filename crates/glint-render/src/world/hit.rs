//! Shading at a hit (pipeline: World → **surface data** → integrators): the closest hit
//! turned into everything shading needs — position with its floating-point error bound (pbrt
//! §3.9), geometric and shading normals, uv, material — and the material queries integrators
//! make (albedo with textures, ambient light).

use super::World;
use super::instances::{Found, Instance, InstanceShape, Plane, transform_ray};
use glint_core::float::{gamma, offset_ray_origin};
use glint_core::{Mat3, Ray, Rgb, Vec2, Vec3};
use glint_scene::Texture;

/// Everything shading needs about a ray's closest hit.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub t: f32,
    pub position: Vec3,
    /// Conservative absolute error bound of `position`, per axis.
    pub p_error: Vec3,
    /// Unit geometric normal as the geometry orients it (outward for spheres; by winding for
    /// triangles), not flipped toward the ray.
    pub geometric_normal: Vec3,
    /// Unit shading normal (interpolated vertex normals), in the hemisphere of `geometric_normal`.
    pub shading_normal: Vec3,
    pub uv: Vec2,
    pub material: u32,
    pub object: u32,
    /// Triangle index within the object's mesh; [`NO_PRIM`] for spheres and planes.
    pub prim: u32,
}

/// `SurfaceHit::prim` of surfaces that are not triangles.
pub const NO_PRIM: u32 = u32::MAX;

impl SurfaceHit {
    /// A ray leaving the surface in direction `dir`, starting outside the error bound on the
    /// side `dir` points to.
    #[inline]
    #[must_use]
    pub fn spawn_ray(&self, dir: Vec3) -> Ray {
        Ray::new(offset_ray_origin(self.position, self.p_error, self.geometric_normal, dir), dir)
    }

    /// A shadow ray toward the point `target` (a point light: no surface there, so the segment
    /// runs all the way to it): unit direction, `tmax` = the distance to the target.
    #[inline]
    #[must_use]
    pub fn spawn_ray_to(&self, target: Vec3) -> Ray {
        let dir0 = target - self.position;
        let origin = offset_ray_origin(self.position, self.p_error, self.geometric_normal, dir0);
        let d = target - origin;
        let dist = d.length();
        Ray::segment(origin, d / dist, 0.0, dist)
    }
}

impl World {
    /// I_a for a surface with unit normal `n`: the scene's ambient colour, or with
    /// `sky_ambient` that colour times the sky's irradiance over π (a uniform sky of radiance L
    /// gives L).
    #[inline]
    #[must_use]
    pub fn ambient(&self, n: Vec3) -> Rgb {
        match &self.sky_irradiance {
            Some(sh) => self.scene.ambient * sh.irradiance(n) * std::f32::consts::FRAC_1_PI,
            None => self.scene.ambient,
        }
    }

    /// The ambient colour when it is the same for every normal (no sky irradiance).
    #[inline]
    #[must_use]
    pub fn ambient_is_constant(&self) -> Option<Rgb> {
        self.sky_irradiance.is_none().then_some(self.scene.ambient)
    }

    /// The radiance a hit's surface emits toward `wo` (away from the surface): the material's
    /// emission from the faces it emits from, times its emission texture (glTF's
    /// emissiveTexture) at the hit's uv.
    #[inline]
    #[must_use]
    pub fn emitted(&self, hit: &SurfaceHit, wo: Vec3) -> Rgb {
        let m = self.material(hit.material);
        let e = m.emitted(hit.geometric_normal, wo);
        match m.emission_texture {
            Some(t) if e != Rgb::ZERO => e * self.texture_at(t, hit),
            _ => e,
        }
    }

    /// Texture `t` of the scene at a hit: at its uv, or, for a mesh attribute, the hit
    /// mesh's value there (the texture's scale alone where the surface has no such attribute).
    #[inline]
    #[must_use]
    pub fn texture_at(&self, t: usize, hit: &SurfaceHit) -> Rgb {
        match &self.scene.textures[t] {
            Texture::MeshAttribute { name, scale } => {
                self.mesh_attribute(hit, name).map_or(Rgb::splat(*scale), |v| v * *scale)
            }
            texture => texture.evaluate(hit.uv),
        }
    }

    /// The hit mesh's attribute `name` at the hit ([`glint_scene::Mesh::attribute_at`]), the
    /// barycentrics recovered from the hit's position in the triangle (in object space).
    /// `None` for spheres and planes and for meshes without it.
    #[must_use]
    pub fn mesh_attribute(&self, hit: &SurfaceHit, name: &str) -> Option<Rgb> {
        let Some(Some(index)) = self.instance_of_object.get(hit.object as usize) else { return None };
        let inst = &self.instances[*index];
        let InstanceShape::Mesh(m) = inst.shape else { return None };
        let mesh = &self.meshes[m];
        let prim = hit.prim as usize;
        if hit.prim == NO_PRIM || prim >= mesh.triangles.len() {
            return None;
        }
        let p = if inst.identity { hit.position } else { inst.object_from_world.transform_point3(hit.position) };
        let [a, b, c] = mesh.triangle(prim);
        let (b1, b2) = barycentrics(p - a, b - a, c - a);
        mesh.attribute_at(name, prim, b1, b2)
    }

    /// The surface colour at a hit: material colour × texture.
    #[inline]
    #[must_use]
    pub fn albedo(&self, hit: &SurfaceHit) -> Rgb {
        let m = self.material(hit.material);
        match m.texture {
            Some(t) => m.colour * self.texture_at(t, hit),
            None => m.colour,
        }
    }

    /// The surface's partial derivatives `(∂p/∂u, ∂p/∂v)` at a hit, in world space: what
    /// orients an anisotropic BSDF, a normal map's tangent space and a bump map's gradient
    /// (Mitsuba's `dp_du`, `dp_dv`). Triangles: from their positions and uvs (solving
    /// `Δp = ∂p/∂u Δu + ∂p/∂v Δv` over two edges); spheres: of their longitude/latitude uv;
    /// planes: their uv axes. Where the uvs are missing or degenerate, an arbitrary
    /// orthonormal pair around the geometric normal (Mitsuba's `coordinate_system`). Computed
    /// on demand: only the physically based models ask.
    #[must_use]
    pub fn uv_derivatives(&self, hit: &SurfaceHit) -> (Vec3, Vec3) {
        let fallback = || {
            let f = glint_core::Frame::from_z(hit.geometric_normal);
            (f.x, f.y)
        };
        let Some(Some(index)) = self.instance_of_object.get(hit.object as usize) else {
            return match self.planes.iter().find(|p| p.object == hit.object) {
                Some(p) => (p.u_axis, p.v_axis),
                None => fallback(),
            };
        };
        let inst = &self.instances[*index];
        let (du, dv) = match inst.shape {
            InstanceShape::Sphere { centre, radius } => {
                // uv = (0.5 + atan2(x, −z)/2π, 1 − acos(y)/π) of the local unit direction.
                let local = inst.object_from_world.transform_point3(hit.position) - centre;
                let (x, z) = (local.x, local.z);
                let r_xz = (x * x + z * z).sqrt();
                if r_xz <= 1e-7 * radius {
                    return fallback();
                }
                let tau = std::f32::consts::TAU;
                let du = Vec3::new(-z, 0.0, -x) * tau;
                let y = local.y / radius;
                let sin_theta = (1.0 - y * y).max(0.0).sqrt();
                // ∂p/∂v with v = 1 − θ/π: p moves toward +y as v grows.
                let dv = Vec3::new(x / r_xz * -y, sin_theta, z / r_xz * -y) * (std::f32::consts::PI * radius);
                (du, dv)
            }
            InstanceShape::Mesh(m) if hit.prim != NO_PRIM => {
                let mesh = &self.meshes[m];
                let Some(uvs) = &mesh.uvs else { return fallback() };
                let [i0, i1, i2] = mesh.triangles[hit.prim as usize].map(|i| i as usize);
                let (dp0, dp1) = (mesh.positions[i1] - mesh.positions[i0], mesh.positions[i2] - mesh.positions[i0]);
                let (duv0, duv1) = (uvs[i1] - uvs[i0], uvs[i2] - uvs[i0]);
                let det = duv0.x * duv1.y - duv0.y * duv1.x;
                if det == 0.0 || !det.is_finite() {
                    return fallback();
                }
                let inv = 1.0 / det;
                ((dp0 * duv1.y - dp1 * duv0.y) * inv, (dp1 * duv0.x - dp0 * duv1.x) * inv)
            }
            InstanceShape::Mesh(_) => return fallback(),
        };
        let m = &inst.world_from_object;
        let (du, dv) = if inst.identity { (du, dv) } else { (m.transform_vector3(du), m.transform_vector3(dv)) };
        if du.is_finite() && dv.is_finite() && du.length_squared() > 0.0 { (du, dv) } else { fallback() }
    }

    pub(super) fn surface_hit(&self, ray: &Ray, found: Found, t: f32) -> Option<SurfaceHit> {
        match found {
            Found::None => None,
            Found::Plane(pi) => Some(self.plane_hit(&self.planes[pi], ray, t)),
            Found::Instance { inst, prim, u, v } => {
                Some(self.instance_hit(&self.instances[inst as usize], ray, t, prim, u, v))
            }
        }
    }

    pub(super) fn plane_hit(&self, p: &Plane, ray: &Ray, t: f32) -> SurfaceHit {
        let raw = ray.at(t);
        // Project onto the plane: what remains is error along the normal only.
        let position = raw - p.normal * (raw.dot(p.normal) + p.offset);
        let p_error = Vec3::splat(gamma(6) * (position.abs().max_element() + p.offset.abs()));
        SurfaceHit {
            t,
            position,
            p_error,
            geometric_normal: p.normal,
            shading_normal: p.normal,
            uv: Vec2::new(position.dot(p.u_axis), position.dot(p.v_axis)),
            material: p.material,
            object: p.object,
            prim: NO_PRIM,
        }
    }

    pub(super) fn instance_hit(&self, inst: &Instance, ray: &Ray, t: f32, prim: u32, u: f32, v: f32) -> SurfaceHit {
        let (p_obj, err_obj, ng_obj, ns_obj, uv, material) = match inst.shape {
            InstanceShape::Sphere { centre, radius } => {
                // The ray is read here only: a mesh hit needs none of it. (Copied up front for
                // every hit, the ray the batched callers had just written lane by lane was read
                // back in 8-byte loads the store buffer cannot forward: 14 % of this function
                // on Sponza's Whitted frame.)
                let r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
                let local = r.at(t) - centre;
                let n = local.normalize_or(Vec3::Y);
                let local = n * radius; // reproject onto the surface
                let p = centre + local;
                let err = gamma(5) * local.abs() + gamma(1) * p.abs();
                // Spherical uv only when a texture will read it (atan2 and acos are not free).
                let uv = if self.scene.materials[inst.material as usize].texture.is_some() {
                    Vec2::new(
                        0.5 + n.x.atan2(-n.z) / std::f32::consts::TAU,
                        1.0 - n.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI,
                    )
                } else {
                    Vec2::ZERO
                };
                (p, err, n, n, uv, inst.material)
            }
            InstanceShape::Mesh(m) => {
                let mesh = &self.meshes[m];
                let tri = mesh.triangles[prim as usize];
                let [i0, i1, i2] = tri.map(|i| i as usize);
                let (p0, p1, p2) = (mesh.positions[i0], mesh.positions[i1], mesh.positions[i2]);
                let w = 1.0 - u - v;
                let p = p0 * w + p1 * u + p2 * v;
                let err = gamma(7) * ((p0 * w).abs() + (p1 * u).abs() + (p2 * v).abs());
                let ng = (p1 - p0).cross(p2 - p0).normalize_or(Vec3::Y);
                let ns = match &mesh.normals {
                    Some(n) => {
                        let s = (n[i0] * w + n[i1] * u + n[i2] * v).normalize_or(ng);
                        if s.dot(ng) < 0.0 { -s } else { s }
                    }
                    None => ng,
                };
                let uv = match &mesh.uvs {
                    Some(t) => t[i0] * w + t[i1] * u + t[i2] * v,
                    None => Vec2::ZERO,
                };
                let material = match &mesh.triangle_materials {
                    Some(ms) => ms[prim as usize],
                    None => inst.material,
                };
                (p, err, ng, ns, uv, material)
            }
        };
        let (position, p_error, ng, ns) = if inst.identity {
            (p_obj, err_obj, ng_obj, ns_obj)
        } else {
            let m = &inst.world_from_object;
            let abs_m = Mat3::from_cols(
                Vec3::from(m.matrix3.x_axis).abs(),
                Vec3::from(m.matrix3.y_axis).abs(),
                Vec3::from(m.matrix3.z_axis).abs(),
            );
            let position = m.transform_point3(p_obj);
            // pbrt's bound for transforming a point that already carries an error.
            let p_error = (1.0 + gamma(3)) * (abs_m * err_obj)
                + gamma(3) * (abs_m * p_obj.abs() + Vec3::from(m.translation).abs());
            let ng = (inst.normal_from_object * ng_obj).normalize_or(Vec3::Y);
            let ns = (inst.normal_from_object * ns_obj).normalize_or(ng);
            (position, p_error, ng, ns)
        };
        let ns = if ns.dot(ng) < 0.0 { -ns } else { ns };
        let prim = if matches!(inst.shape, InstanceShape::Mesh(_)) { prim } else { NO_PRIM };
        SurfaceHit {
            t,
            position,
            p_error,
            geometric_normal: ng,
            shading_normal: ns,
            uv,
            material,
            object: inst.object,
            prim,
        }
    }
}

/// The barycentric weights (of the second and third corners) of the point `d` (relative to the
/// first corner) in the triangle spanned by the edges `e1`, `e2`: the least-squares solution
/// of `d = b1·e1 + b2·e2`, clamped into the triangle (a hit lies on it up to rounding).
fn barycentrics(d: Vec3, e1: Vec3, e2: Vec3) -> (f32, f32) {
    let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d1, d2) = (d.dot(e1), d.dot(e2));
    let den = d11 * d22 - d12 * d12;
    if !(den > 0.0 && den.is_finite()) {
        return (1.0 / 3.0, 1.0 / 3.0);
    }
    let b1 = ((d22 * d1 - d12 * d2) / den).clamp(0.0, 1.0);
    let b2 = ((d11 * d2 - d12 * d1) / den).clamp(0.0, 1.0 - b1);
    (b1, b2)
}
