//! The traceable world: a scene's geometry in a two-level BVH.
//!
//! Every bounded object is an *instance*: a shape in object space (a sphere, or a mesh with its
//! own BVH) and an affine placement. A top-level BVH over the instances' world boxes is rebuilt
//! when an object moves (cheap: one box per object); a mesh whose vertices move is refitted.
//! Nothing else is rebuilt (the two-level scheme of Wald et al. 2003 that the path-tracing paper
//! uses). Infinite planes cannot live in a BVH and are tested beside it.
//!
//! Hit points carry a conservative bound on their floating-point error (pbrt §3.9) so that
//! spawned rays start just outside it: no fixed epsilon, correct at every scale.

use glint_accel::{BuildOptions, MeshBvh, SphereSet, Tlas, primitives};
use glint_core::float::gamma;
use glint_core::float::offset_ray_origin;
use glint_core::{Affine3A, Bounds3, Mat3, Ray, Rgb, Vec2, Vec3};
use glint_scene::{AnimationTarget, IrradianceSh, Light, Material, Mesh, Object, Scene, Shape, Sky, Texture};
use rayon::prelude::*;
use std::sync::Arc;

#[derive(Clone, Copy, Debug)]
enum InstanceShape {
    Sphere { centre: Vec3, radius: f32 },
    Mesh(usize),
}

#[derive(Clone, Debug)]
struct Instance {
    shape: InstanceShape,
    object: u32,
    material: u32,
    world_from_object: Affine3A,
    object_from_world: Affine3A,
    /// Inverse transpose of the linear part, for normals.
    normal_from_object: Mat3,
    identity: bool,
    /// Every surface of this instance is opaque (shadow rays may stop at its first hit).
    opaque: bool,
}

impl Instance {
    fn new(shape: InstanceShape, object: u32, material: u32, world_from_object: Affine3A, opaque: bool) -> Self {
        let identity = world_from_object == Affine3A::IDENTITY;
        Self {
            shape,
            object,
            material,
            opaque,
            world_from_object,
            object_from_world: world_from_object.inverse(),
            normal_from_object: Mat3::from(world_from_object.matrix3).inverse().transpose(),
            identity,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Plane {
    normal: Vec3,
    offset: f32,
    /// `Frame::from_z(normal)`'s tangents (the uv axes), kept so no hit recomputes them.
    u_axis: Vec3,
    v_axis: Vec3,
    object: u32,
    material: u32,
    opaque: bool,
}

impl Plane {
    fn new(normal: Vec3, offset: f32, object: u32, material: u32, opaque: bool) -> Self {
        let frame = glint_core::Frame::from_z(normal);
        Self { normal, offset, u_axis: frame.x, v_axis: frame.y, object, material, opaque }
    }
}

#[derive(Clone, Copy)]
enum Found {
    None,
    Instance { inst: u32, prim: u32, u: f32, v: f32 },
    Plane(usize),
}

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
    pub fn spawn_ray(&self, dir: Vec3) -> Ray {
        Ray::new(offset_ray_origin(self.position, self.p_error, self.geometric_normal, dir), dir)
    }

    /// A shadow ray toward the point `target` (a point light: no surface there, so the segment
    /// runs all the way to it): unit direction, `tmax` = the distance to the target.
    #[inline]
    pub fn spawn_ray_to(&self, target: Vec3) -> Ray {
        let dir0 = target - self.position;
        let origin = offset_ray_origin(self.position, self.p_error, self.geometric_normal, dir0);
        let d = target - origin;
        let dist = d.length();
        Ray::segment(origin, d / dist, 0.0, dist)
    }
}

/// A light-emitting triangle in world space.
#[derive(Clone, Copy, Debug)]
pub struct EmissiveTriangle {
    pub object: u32,
    pub prim: u32,
    pub vertices: [Vec3; 3],
    pub emission: Rgb,
}

/// Statistics of the acceleration structures (reported by the CLI and benchmarks).
#[derive(Clone, Copy, Debug, Default)]
pub struct WorldStats {
    pub triangles: usize,
    pub instances: usize,
    pub spheres: usize,
    pub planes: usize,
    pub node_bytes: usize,
    pub build_ms: f64,
}

/// A scene made traceable.
pub struct World {
    pub scene: Scene,
    /// `scene.bounds()`, updated with the top level.
    bounds: Bounds3,
    meshes: Vec<Arc<Mesh>>,
    blas: Vec<MeshBvh>,
    instances: Vec<Instance>,
    tlas: Tlas,
    /// Whether the TLAS holds any instance (not when every instance is in the sphere set):
    /// an empty one is not visited at all.
    tlas_used: bool,
    /// Untransformed spheres, tested four at a time beside the TLAS (which then skips them).
    spheres: SphereSet,
    /// Instance index of each member of `spheres`.
    sphere_instances: Vec<u32>,
    planes: Vec<Plane>,
    /// Instance index of each object (None for planes).
    instance_of_object: Vec<Option<usize>>,
    any_transparent: bool,
    /// The sky's irradiance, when the scene takes its ambient light from the sky.
    sky_irradiance: Option<IrradianceSh>,
    /// Curvature (1 / radius in world units) of each object, for ray cones: spheres by their
    /// smallest scaled radius, planes 0, meshes 0 (treated as locally flat).
    curvature: Vec<f32>,
    pub stats: WorldStats,
}

/// An animated object's placement or light, before [`World::set_time`] moves it.
enum Placement {
    Object(usize, Affine3A, Shape),
    Light(usize, Light),
}

/// Up to this many untransformed spheres are tested as a vector set; more go into the TLAS.
const SPHERE_SET_LIMIT: usize = 16;

/// 1 / radius for spheres (their smallest scaled radius), 0 for planes and meshes.
fn object_curvature(o: &Object) -> f32 {
    match o.shape {
        Shape::Sphere { radius, .. } => {
            let m = o.world_from_object.matrix3;
            let scale = m.x_axis.length().min(m.y_axis.length()).min(m.z_axis.length());
            1.0 / (radius * scale).max(f32::MIN_POSITIVE)
        }
        Shape::Plane { .. } | Shape::Mesh(_) => 0.0,
    }
}

/// Split the instances between the sphere set and the top-level BVH.
fn top_level(instances: &[Instance], blas: &[MeshBvh]) -> (Tlas, bool, SphereSet, Vec<u32>) {
    let in_set = |inst: &Instance| inst.identity && matches!(inst.shape, InstanceShape::Sphere { .. });
    let count = instances.iter().filter(|i| in_set(i)).count();
    let use_set = count <= SPHERE_SET_LIMIT;
    let mut spheres = Vec::new();
    let mut ids = Vec::new();
    let boxes: Vec<Bounds3> = instances
        .iter()
        .enumerate()
        .map(|(i, inst)| match inst.shape {
            InstanceShape::Sphere { centre, radius } if use_set && in_set(inst) => {
                spheres.push((centre, radius));
                ids.push(i as u32);
                Bounds3::EMPTY // never visited by the TLAS
            }
            _ => instance_bounds(inst, blas),
        })
        .collect();
    let used = boxes.iter().any(|b| !b.is_empty());
    (Tlas::build(&boxes), used, SphereSet::new(&spheres), ids)
}

fn instance_bounds(inst: &Instance, blas: &[MeshBvh]) -> Bounds3 {
    let local = match inst.shape {
        InstanceShape::Sphere { centre, radius } => {
            Bounds3::new(centre - Vec3::splat(radius), centre + Vec3::splat(radius))
        }
        InstanceShape::Mesh(m) => blas[m].bounds(),
    };
    if inst.identity { local } else { local.transformed(&inst.world_from_object) }
}

impl World {
    /// Build the acceleration structures of a validated scene (meshes in parallel).
    pub fn new(scene: Scene) -> Self {
        let start = std::time::Instant::now();
        let options = BuildOptions::default();
        let meshes = scene.meshes.clone();
        let blas: Vec<MeshBvh> =
            meshes.par_iter().map(|m| MeshBvh::build(&m.positions, &m.triangles, &options)).collect();
        let transparent = |m: usize| scene.materials[m].is_transparent();
        let mesh_opaque = |mesh: usize, object_material: usize| match &meshes[mesh].triangle_materials {
            Some(ms) => ms.iter().all(|&m| !transparent(m as usize)),
            None => !transparent(object_material),
        };
        let mut instances = Vec::new();
        let mut planes = Vec::new();
        let mut instance_of_object = Vec::with_capacity(scene.objects.len());
        for (i, o) in scene.objects.iter().enumerate() {
            let (object, material) = (i as u32, o.material as u32);
            match o.shape {
                Shape::Plane { normal, offset } => {
                    planes.push(Plane::new(normal, offset, object, material, !transparent(o.material)));
                    instance_of_object.push(None);
                }
                Shape::Sphere { centre, radius } => {
                    instance_of_object.push(Some(instances.len()));
                    instances.push(Instance::new(
                        InstanceShape::Sphere { centre, radius },
                        object,
                        material,
                        o.world_from_object,
                        !transparent(o.material),
                    ));
                }
                Shape::Mesh(m) => {
                    instance_of_object.push(Some(instances.len()));
                    let opaque = mesh_opaque(m, o.material);
                    instances.push(Instance::new(
                        InstanceShape::Mesh(m),
                        object,
                        material,
                        o.world_from_object,
                        opaque,
                    ));
                }
            }
        }
        let (tlas, tlas_used, spheres, sphere_instances) = top_level(&instances, &blas);
        let any_transparent = scene.materials.iter().any(Material::is_transparent);
        let sky_irradiance = scene.sky_ambient.then(|| scene.sky.irradiance_sh());
        let curvature = scene.objects.iter().map(object_curvature).collect();
        let stats = WorldStats {
            triangles: meshes.iter().map(|m| m.triangles.len()).sum(),
            instances: instances.len(),
            spheres: instances.iter().filter(|i| matches!(i.shape, InstanceShape::Sphere { .. })).count(),
            planes: planes.len(),
            node_bytes: blas.iter().map(|b| b.stats().node_bytes).sum(),
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        };
        Self {
            bounds: scene.bounds(),
            scene,
            meshes,
            blas,
            instances,
            tlas,
            tlas_used,
            spheres,
            sphere_instances,
            planes,
            instance_of_object,
            any_transparent,
            sky_irradiance,
            curvature,
            stats,
        }
    }

    /// Move object `object` (not a plane): only the top level is rebuilt.
    pub fn set_transform(&mut self, object: usize, world_from_object: Affine3A) -> bool {
        if !matches!(self.instance_of_object.get(object), Some(Some(_))) {
            return false;
        }
        self.scene.objects[object].world_from_object = world_from_object;
        self.place_object(object);
        self.rebuild_top_level();
        true
    }

    /// Put the scene's animated objects and lights where they are at time `t` (seconds; see
    /// [`Scene::set_time`]): the moved instances get their new transforms, moved planes their
    /// new equations, and the top level is rebuilt once; no mesh BVH is touched. Lights are
    /// read from the scene by every render, so a moved light needs nothing more. Returns whether
    /// anything moved. The result is the world [`World::new`] builds from the scene at `t`.
    pub fn set_time(&mut self, t: f32) -> bool {
        if !self.scene.is_animated() {
            return false;
        }
        // The animated targets as they are now, to tell what moved.
        let before: Vec<Placement> = self
            .scene
            .animations
            .iter()
            .filter_map(|a| match a.target {
                AnimationTarget::Object(i) => {
                    self.scene.objects.get(i).map(|o| Placement::Object(i, o.world_from_object, o.shape))
                }
                AnimationTarget::Light(i) => self.scene.lights.get(i).map(|l| Placement::Light(i, *l)),
            })
            .collect();
        self.scene.set_time(t);
        let mut changed = false;
        let mut moved_instance = false;
        for was in before {
            match was {
                Placement::Object(i, w, shape) => {
                    let o = &self.scene.objects[i];
                    if o.world_from_object != w || o.shape != shape {
                        changed = true;
                        moved_instance |= self.place_object(i);
                    }
                }
                Placement::Light(i, l) => changed |= self.scene.lights[i] != l,
            }
        }
        if moved_instance {
            self.rebuild_top_level();
        }
        changed
    }

    /// Bring the instance (or plane) of object `object` in line with its placement in the
    /// scene, without rebuilding the top level. Returns whether an instance (a TLAS member)
    /// changed.
    fn place_object(&mut self, object: usize) -> bool {
        let o = &self.scene.objects[object];
        self.curvature[object] = object_curvature(o);
        match (o.shape, self.instance_of_object.get(object).copied().flatten()) {
            (Shape::Plane { normal, offset }, _) => {
                if let Some(p) = self.planes.iter_mut().find(|p| p.object as usize == object) {
                    *p = Plane::new(normal, offset, p.object, p.material, p.opaque);
                }
                false
            }
            (_, Some(i)) => {
                let inst = &self.instances[i];
                self.instances[i] =
                    Instance::new(inst.shape, inst.object, inst.material, o.world_from_object, inst.opaque);
                true
            }
            (_, None) => false,
        }
    }

    /// New vertex positions for mesh `mesh` (same triangles): its BVH is refitted, not rebuilt.
    pub fn update_mesh_positions(&mut self, mesh: usize, positions: Vec<Vec3>) -> bool {
        let Some(m) = self.meshes.get(mesh) else { return false };
        if positions.len() != m.positions.len() || positions.iter().any(|p| !p.is_finite()) {
            return false;
        }
        let mut new_mesh = (**m).clone();
        new_mesh.positions = positions;
        self.blas[mesh].refit(&new_mesh.positions);
        let new_mesh = Arc::new(new_mesh);
        self.meshes[mesh] = new_mesh.clone();
        self.scene.meshes[mesh] = new_mesh;
        self.rebuild_top_level();
        true
    }

    fn rebuild_top_level(&mut self) {
        (self.tlas, self.tlas_used, self.spheres, self.sphere_instances) = top_level(&self.instances, &self.blas);
        self.bounds = self.scene.bounds();
    }

    /// `scene.bounds()` as of the last change through this world's methods, kept so that a
    /// frame does not walk every mesh vertex (the path mode reads it per frame).
    pub fn bounds(&self) -> Bounds3 {
        self.bounds
    }

    pub fn sky(&self) -> &Sky {
        &self.scene.sky
    }

    /// Curvature of object `object` (see the field); 0 for unknown objects.
    #[inline]
    pub fn curvature(&self, object: u32) -> f32 {
        self.curvature.get(object as usize).copied().unwrap_or(0.0)
    }

    /// I_a for a surface with unit normal `n`: the scene's ambient colour, or with
    /// `sky_ambient` that colour times the sky's irradiance over π (a uniform sky of radiance L
    /// gives L).
    #[inline]
    pub fn ambient(&self, n: Vec3) -> Rgb {
        match &self.sky_irradiance {
            Some(sh) => self.scene.ambient * sh.irradiance(n) * std::f32::consts::FRAC_1_PI,
            None => self.scene.ambient,
        }
    }

    pub fn material(&self, index: u32) -> &Material {
        &self.scene.materials[index as usize]
    }

    /// The surface colour at a hit: material colour × texture.
    #[inline]
    pub fn albedo(&self, hit: &SurfaceHit) -> Rgb {
        let m = self.material(hit.material);
        match m.texture {
            Some(t) => m.colour * evaluate_texture(&self.scene.textures[t], hit.uv),
            None => m.colour,
        }
    }

    /// Closest hit along `ray` within `[ray.tmin, ray.tmax]`.
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceHit> {
        let (found, t) = self.closest(ray, false);
        self.surface_hit(ray, found, t)
    }

    /// [`World::intersect`] of 8 rays: one packet query where [`World::traces_packets`] (the
    /// same hits bit for bit; coherent rays, e.g. neighbouring pixels, gain), else ray by ray.
    pub fn intersect8(&self, rays: &[Ray; 8], out: &mut [Option<SurfaceHit>; 8]) {
        match self.lone_mesh() {
            Some(bvh) => {
                let mut hits = [None; 8];
                bvh.intersect8(rays, &mut hits);
                for ((o, h), r) in out.iter_mut().zip(hits).zip(rays) {
                    *o = h.and_then(|h| {
                        self.surface_hit(r, Found::Instance { inst: 0, prim: h.prim, u: h.u, v: h.v }, h.t)
                    });
                }
            }
            None => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.intersect(r);
                }
            }
        }
    }

    fn surface_hit(&self, ray: &Ray, found: Found, t: f32) -> Option<SurfaceHit> {
        match found {
            Found::None => None,
            Found::Plane(pi) => Some(self.plane_hit(&self.planes[pi], ray, t)),
            Found::Instance { inst, prim, u, v } => {
                Some(self.instance_hit(&self.instances[inst as usize], ray, t, prim, u, v))
            }
        }
    }

    /// Distance to the closest hit, without computing shading data (traversal only: what the
    /// ray benchmarks time).
    pub fn hit_distance(&self, ray: &Ray) -> Option<f32> {
        match self.closest(ray, false) {
            (Found::None, _) => None,
            (_, t) => Some(t),
        }
    }

    /// The mesh BVH of a scene that is exactly one untransformed mesh instance (no planes, no
    /// spheres): there the 8-ray queries take the packet path of [`MeshBvh::intersect8`].
    fn lone_mesh(&self) -> Option<&MeshBvh> {
        match self.instances.as_slice() {
            [inst] if inst.identity && self.planes.is_empty() => match inst.shape {
                InstanceShape::Mesh(m) => self.blas.get(m),
                InstanceShape::Sphere { .. } => None,
            },
            _ => None,
        }
    }

    /// Whether [`World::hit_distance8`] and [`World::occluded8`] trace packets (true) or loop
    /// over single rays.
    pub fn traces_packets(&self) -> bool {
        self.lone_mesh().is_some()
    }

    /// [`World::hit_distance`] of up to 8 rays (coherent ones, e.g. a 4×2 pixel tile, gain):
    /// `out[i] == hit_distance(&rays[i])` bit for bit.
    pub fn hit_distance8(&self, rays: &[Ray; 8], out: &mut [Option<f32>; 8]) {
        match self.lone_mesh() {
            Some(bvh) => {
                let mut hits = [None; 8];
                bvh.intersect8(rays, &mut hits);
                for (o, h) in out.iter_mut().zip(hits) {
                    *o = h.map(|h| h.t);
                }
            }
            None => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.hit_distance(r);
                }
            }
        }
    }

    /// [`World::occluded`] of up to 8 rays: `out[i] == occluded(&rays[i])`.
    pub fn occluded8(&self, rays: &[Ray; 8], out: &mut [bool; 8]) {
        match self.lone_mesh() {
            Some(bvh) => bvh.occluded8(rays, out),
            None => {
                for (o, r) in out.iter_mut().zip(rays) {
                    *o = self.occluded(r);
                }
            }
        }
    }

    /// Closest hit; with `transparent_only`, instances and planes that are wholly opaque are
    /// skipped (used after an any-hit query has ruled them out).
    fn closest(&self, ray: &Ray, transparent_only: bool) -> (Found, f32) {
        let mut found = Found::None;
        let mut tmax = ray.tmax;
        if transparent_only {
            // The rare path (transparent meshes in the scene): one sphere at a time.
            for &i in &self.sphere_instances {
                let inst = &self.instances[i as usize];
                if let (false, InstanceShape::Sphere { centre, radius }) = (inst.opaque, inst.shape)
                    && let Some(t) = primitives::intersect_sphere(&Ray { tmax, ..*ray }, centre, radius)
                {
                    found = Found::Instance { inst: i, prim: 0, u: 0.0, v: 0.0 };
                    tmax = t;
                }
            }
        } else if let Some((t, k)) = self.spheres.closest(ray) {
            found = Found::Instance { inst: self.sphere_instances[k as usize], prim: 0, u: 0.0, v: 0.0 };
            tmax = t;
        }
        let ray = &Ray { tmax, ..*ray };
        let leaf = |i: u32, t_limit: f32| {
            let inst = &self.instances[i as usize];
            if transparent_only && inst.opaque {
                return None;
            }
            let mut r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
            r.tmax = t_limit;
            match inst.shape {
                InstanceShape::Sphere { centre, radius } => {
                    let t = primitives::intersect_sphere(&r, centre, radius)?;
                    found = Found::Instance { inst: i, prim: 0, u: 0.0, v: 0.0 };
                    tmax = t;
                    Some(t)
                }
                InstanceShape::Mesh(m) => {
                    let h = self.blas[m].intersect(&r)?;
                    found = Found::Instance { inst: i, prim: h.prim, u: h.u, v: h.v };
                    tmax = h.t;
                    Some(h.t)
                }
            }
        };
        if self.tlas_used {
            self.tlas.intersect(ray, leaf);
        }
        for (pi, p) in self.planes.iter().enumerate() {
            if transparent_only && p.opaque {
                continue;
            }
            let r = Ray { tmax, ..*ray };
            if let Some(t) = primitives::intersect_plane(&r, p.normal, p.offset) {
                tmax = t;
                found = Found::Plane(pi);
            }
        }
        (found, tmax)
    }

    /// True when anything blocks `ray` within its interval (opaque or not).
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.occluded_filtered(ray, false)
    }

    /// Any hit; with `opaque_only`, only surfaces that are wholly opaque count.
    fn occluded_filtered(&self, ray: &Ray, opaque_only: bool) -> bool {
        for p in &self.planes {
            if (!opaque_only || p.opaque) && primitives::intersect_plane(ray, p.normal, p.offset).is_some() {
                return true;
            }
        }
        if self
            .spheres
            .crossings(ray, |k, _| !opaque_only || self.instances[self.sphere_instances[k as usize] as usize].opaque)
        {
            return true;
        }
        self.tlas_used
            && self.tlas.occluded(ray, |i| {
                let inst = &self.instances[i as usize];
                if opaque_only && !inst.opaque {
                    return false;
                }
                let r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
                match inst.shape {
                    InstanceShape::Sphere { centre, radius } => {
                        primitives::intersect_sphere(&r, centre, radius).is_some()
                    }
                    InstanceShape::Mesh(m) => self.blas[m].occluded(&r),
                }
            })
    }

    /// Fraction of light that passes along a shadow ray: 0 behind an opaque object, reduced by
    /// each transparent surface it crosses ("reduced according to the degree of transparency").
    pub fn transmittance(&self, ray: &Ray) -> Rgb {
        if !self.any_transparent {
            return if self.occluded(ray) { Rgb::ZERO } else { Rgb::ONE };
        }
        // One pass: an opaque hit ends it; transparent planes and spheres multiply in the
        // transmittance of every surface the segment crosses (order does not matter for a
        // product). Only a transparent mesh needs its hits in order (its triangles may carry
        // different materials): then the ordered walk below.
        let mut t = 1.0f32;
        for p in &self.planes {
            if primitives::intersect_plane(ray, p.normal, p.offset).is_some() {
                if p.opaque {
                    return Rgb::ZERO;
                }
                t *= self.material(p.material).transparency;
            }
        }
        let blocked = self.spheres.crossings(ray, |k, n| {
            let inst = &self.instances[self.sphere_instances[k as usize] as usize];
            if !inst.opaque {
                t *= self.material(inst.material).transparency.powi(n as i32);
            }
            inst.opaque
        });
        if blocked {
            return Rgb::ZERO;
        }
        let mut walk = false;
        let blocked = self.tlas_used
            && self.tlas.occluded(ray, |i| {
                let inst = &self.instances[i as usize];
                let r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
                match inst.shape {
                    InstanceShape::Sphere { centre, radius } => {
                        let n = primitives::sphere_crossings(&r, centre, radius);
                        if n > 0 && !inst.opaque {
                            t *= self.material(inst.material).transparency.powi(n as i32);
                        }
                        n > 0 && inst.opaque
                    }
                    InstanceShape::Mesh(m) => {
                        if inst.opaque {
                            self.blas[m].occluded(&r)
                        } else {
                            walk |= self.blas[m].occluded(&r);
                            false
                        }
                    }
                }
            });
        if blocked || t < 1e-4 {
            return Rgb::ZERO;
        }
        if !walk {
            return Rgb::splat(t);
        }
        self.transmittance_ordered(ray)
    }

    /// The general case: walk the transparent surfaces along the ray in order.
    fn transmittance_ordered(&self, ray: &Ray) -> Rgb {
        if self.occluded_filtered(ray, true) {
            return Rgb::ZERO;
        }
        let mut t = Rgb::ONE;
        let mut r = *ray;
        let end = ray.at(ray.tmax);
        for _ in 0..64 {
            let (found, th) = self.closest(&r, true);
            let Some(hit) = self.surface_hit(&r, found, th) else { return t };
            let m = self.material(hit.material);
            if !m.is_transparent() {
                return Rgb::ZERO;
            }
            t *= m.transparency;
            if t.max_element() < 1e-4 {
                return Rgb::ZERO;
            }
            let origin = offset_ray_origin(hit.position, hit.p_error, hit.geometric_normal, r.dir);
            let remaining = (end - origin).dot(r.dir);
            if remaining <= 0.0 {
                return t;
            }
            r = Ray::segment(origin, r.dir, 0.0, remaining);
        }
        t
    }

    fn plane_hit(&self, p: &Plane, ray: &Ray, t: f32) -> SurfaceHit {
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

    fn instance_hit(&self, inst: &Instance, ray: &Ray, t: f32, prim: u32, u: f32, v: f32) -> SurfaceHit {
        let r = if inst.identity { *ray } else { transform_ray(&inst.object_from_world, ray) };
        let (p_obj, err_obj, ng_obj, ns_obj, uv, material) = match inst.shape {
            InstanceShape::Sphere { centre, radius } => {
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

    /// Every triangle whose material emits light, in world space, with its object and
    /// triangle index (the path tracer's area lights).
    pub fn emissive_triangles(&self) -> Vec<EmissiveTriangle> {
        let mut out = Vec::new();
        for inst in &self.instances {
            let InstanceShape::Mesh(m) = inst.shape else { continue };
            let mesh = &self.meshes[m];
            for (prim, t) in mesh.triangles.iter().enumerate() {
                let material = match &mesh.triangle_materials {
                    Some(ms) => ms[prim],
                    None => inst.material,
                };
                let emission = self.scene.materials[material as usize].emission;
                if emission.max_element() <= 0.0 {
                    continue;
                }
                let vertices = t.map(|i| inst.world_from_object.transform_point3(mesh.positions[i as usize]));
                out.push(EmissiveTriangle { object: inst.object, prim: prim as u32, vertices, emission });
            }
        }
        out
    }

    /// Every triangle of the world in world space (for the Embree comparison dumps).
    pub fn world_triangles(&self) -> Vec<[Vec3; 3]> {
        let mut out = Vec::new();
        for inst in &self.instances {
            if let InstanceShape::Mesh(m) = inst.shape {
                let mesh = &self.meshes[m];
                for t in &mesh.triangles {
                    out.push(t.map(|i| inst.world_from_object.transform_point3(mesh.positions[i as usize])));
                }
            }
        }
        out
    }
}

#[inline]
fn evaluate_texture(t: &Texture, uv: Vec2) -> Rgb {
    t.evaluate(uv)
}

/// The ray in object space. The direction is not renormalised, so `t` is the same in both spaces.
#[inline]
fn transform_ray(object_from_world: &Affine3A, ray: &Ray) -> Ray {
    Ray {
        origin: object_from_world.transform_point3(ray.origin),
        dir: object_from_world.transform_vector3(ray.dir),
        tmin: ray.tmin,
        tmax: ray.tmax,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_accel::procedural::displaced_sphere;
    use glint_scene::{Camera, Fov, Object};

    fn scene(extra: Option<Shape>, world_from_object: Affine3A) -> Scene {
        let m = displaced_sphere(5_000);
        let mesh = Mesh { name: "ball".into(), positions: m.positions, triangles: m.triangles, ..Mesh::default() };
        let mut objects = vec![Object { name: "ball".into(), shape: Shape::Mesh(0), material: 0, world_from_object }];
        if let Some(shape) = extra {
            objects.push(Object { name: "extra".into(), shape, material: 0, world_from_object: Affine3A::IDENTITY });
        }
        Scene {
            camera: Camera {
                position: Vec3::new(0.0, 0.3, 3.0),
                forward: -Vec3::Z,
                up: Vec3::Y,
                fov: Fov::Vertical(50.0),
            },
            materials: vec![Material::default()],
            meshes: vec![Arc::new(mesh)],
            objects,
            ..Scene::default()
        }
    }

    /// 8-ray queries equal the single-ray ones bit for bit, on the packet path (one mesh) and
    /// on the looping path (a plane or a transform in the scene), for primary tiles (distances
    /// and whole surface hits) and shadow rays.
    #[test]
    fn eight_ray_queries_equal_single_rays() {
        let cases = [
            (scene(None, Affine3A::IDENTITY), true),
            (scene(Some(Shape::Plane { normal: Vec3::Y, offset: -0.9 }), Affine3A::IDENTITY), false),
            (scene(None, Affine3A::from_translation(Vec3::new(0.1, 0.0, 0.0))), false),
        ];
        for (scene, packets) in cases {
            scene.validate().expect("valid scene");
            let world = World::new(scene);
            assert_eq!(world.traces_packets(), packets);
            let cam = world.scene.camera.rays(32, 16);
            let light = Vec3::new(3.0, 4.0, 5.0);
            for ty in (0..16).step_by(2) {
                for tx in (0..32).step_by(4) {
                    let tile: [Ray; 8] = std::array::from_fn(|i| {
                        cam.ray(Vec2::new((tx + i % 4) as f32 + 0.5, (ty + i / 4) as f32 + 0.5))
                    });
                    let mut dist = [None; 8];
                    world.hit_distance8(&tile, &mut dist);
                    let shadow: [Ray; 8] = std::array::from_fn(|i| match world.intersect(&tile[i]) {
                        Some(h) => h.spawn_ray_to(light),
                        None => Ray::new(Vec3::NAN, Vec3::Z),
                    });
                    let mut occ = [false; 8];
                    world.occluded8(&shadow, &mut occ);
                    let mut hits = [None; 8];
                    world.intersect8(&tile, &mut hits);
                    for i in 0..8 {
                        // Debug prints each float's shortest round trip: equal text, equal bits.
                        let hit = format!("{:?}", world.intersect(&tile[i]));
                        assert_eq!(format!("{:?}", hits[i]), hit, "hit ({tx}, {ty}) lane {i}");
                        let want = world.hit_distance(&tile[i]);
                        assert_eq!(dist[i].map(f32::to_bits), want.map(f32::to_bits), "tile ({tx}, {ty}) lane {i}");
                        assert_eq!(occ[i], world.occluded(&shadow[i]), "shadow ({tx}, {ty}) lane {i}");
                    }
                }
            }
        }
    }

    use crate::{RenderSettings, Schedule};
    use glint_scene::{AnimationBase, AnimationTarget, Attenuation, Keyframes, Light, Motion, Repeat, Rotation};

    fn small_settings() -> RenderSettings {
        RenderSettings {
            width: 48,
            height: 32,
            samples_per_side: 1,
            max_depth: 4,
            min_contribution: 1e-3,
            seed: 0,
            schedule: Schedule::WorkStealing,
        }
    }

    fn colours(world: &World) -> Vec<[u32; 3]> {
        let (film, _) = crate::render(world, &small_settings()).expect("valid settings");
        film.pixels.iter().map(|p| p.colour.to_array().map(f32::to_bits)).collect()
    }

    fn spin(axis: Vec3, degrees_per_second: f32) -> Option<Rotation> {
        Some(Rotation { axis, pivot: None, degrees_per_second, phase_deg: 0.0 })
    }

    fn keys(keys: Vec<(f32, Vec3)>, repeat: Repeat) -> Option<Keyframes> {
        Some(Keyframes { keys, repeat })
    }

    /// A mesh turning about the vertical, a sphere bouncing (it starts untransformed, in the
    /// sphere set, and leaves it when it moves), a light circling, over a floor.
    fn animated_scene() -> Scene {
        let mut s = scene(Some(Shape::Plane { normal: Vec3::Y, offset: 1.0 }), Affine3A::from_scale(Vec3::splat(0.6)));
        s.objects.push(Object {
            name: "ball".into(),
            shape: Shape::Sphere { centre: Vec3::new(1.0, -0.5, 0.0), radius: 0.4 },
            material: 0,
            world_from_object: Affine3A::IDENTITY,
        });
        s.lights.push(Light::Point {
            position: Vec3::new(2.0, 3.0, 2.0),
            colour: Rgb::ONE,
            intensity: 1.0,
            attenuation: Attenuation::None,
        });
        s.sky = Sky::Colour(Rgb::new(0.2, 0.3, 0.5));
        let turn = Motion { rotation: spin(Vec3::new(0.3, 1.0, 0.0), 40.0), translation: None };
        s.animate(&[AnimationTarget::Object(0)], turn).expect("in range");
        let bounce = keys(vec![(0.0, Vec3::ZERO), (1.0, Vec3::new(0.0, 1.2, 0.0))], Repeat::PingPong);
        s.animate(&[AnimationTarget::Object(2)], Motion { rotation: None, translation: bounce }).expect("in range");
        let circle = Rotation { pivot: Some(Vec3::ZERO), ..spin(Vec3::Y, 90.0).expect("some") };
        s.animate(&[AnimationTarget::Light(0)], Motion { rotation: Some(circle), translation: None })
            .expect("in range");
        s.set_time(0.0);
        s.validate().expect("valid animated scene");
        s
    }

    /// The scene at `t` placed by hand from the animations' rest states, not by `set_time`.
    fn placed_directly(mut s: Scene, t: f32) -> Scene {
        for a in s.animations.clone() {
            let m = a.motion.transform_at(t, a.pivot);
            match (a.target, a.base) {
                (AnimationTarget::Object(i), AnimationBase::Object { world_from_object, .. }) => {
                    s.objects[i].world_from_object = m * world_from_object;
                }
                (AnimationTarget::Light(i), AnimationBase::Light(Light::Point { position, .. })) => {
                    let Light::Point { position: p, .. } = &mut s.lights[i] else { panic!("a point light") };
                    *p = m.transform_point3(position);
                }
                _ => panic!("no other kinds here"),
            }
        }
        s
    }

    /// `set_time` moves instances and lights to exactly where a world built afresh at that time
    /// has them: the same hits and bit-identical renders; back at 0 the first image returns.
    #[test]
    fn set_time_equals_a_world_built_at_that_time() {
        let scene = animated_scene();
        let mut world = World::new(scene.clone());
        let first = colours(&world);
        let unanimated = World::new(Scene { animations: Vec::new(), ..scene.clone() });
        assert_eq!(colours(&unanimated), first, "animations at rest change nothing");
        let blas_before: Vec<usize> = world.blas.iter().map(|b| b.stats().node_bytes).collect();
        for t in [0.35, 1.3, 2.75] {
            assert!(world.set_time(t), "t = {t}: something moved");
            let fresh = World::new(placed_directly(scene.clone(), t));
            assert_eq!(world.scene.objects, fresh.scene.objects, "t = {t}");
            assert_eq!(world.scene.lights, fresh.scene.lights, "t = {t}");
            // The kept bounds follow the moves (the path mode's depth scale reads them).
            assert_eq!(world.bounds(), fresh.bounds(), "t = {t}");
            assert_eq!(world.bounds(), world.scene.bounds(), "t = {t}");
            let cam = world.scene.camera.rays(24, 16);
            for y in 0..16 {
                for x in 0..24 {
                    let ray = cam.ray(Vec2::new(x as f32 + 0.5, y as f32 + 0.5));
                    let (a, b) = (world.intersect(&ray), fresh.intersect(&ray));
                    let key =
                        |h: Option<SurfaceHit>| h.map(|h| (h.t.to_bits(), h.object, h.prim, h.position.to_array()));
                    assert_eq!(key(a), key(b), "t = {t}, pixel ({x}, {y})");
                }
            }
            let image = colours(&world);
            assert_eq!(image, colours(&fresh), "t = {t}");
            assert_ne!(image, first, "t = {t}: the picture changed");
        }
        assert_eq!(blas_before, world.blas.iter().map(|b| b.stats().node_bytes).collect::<Vec<_>>());
        assert!(world.set_time(0.0));
        assert_eq!(colours(&world), first, "back at t = 0");
        assert!(!world.set_time(0.0), "nothing moves from 0 to 0");
    }

    /// A light moving sideways moves the shadow of a ball on the floor (Whitted reads the
    /// scene's lights at every render).
    #[test]
    fn a_moving_light_moves_the_shadow() {
        let matte = Material { ambient: 0.0, diffuse: 1.0, specular: 0.0, ..Material::default() };
        let mut s = Scene {
            camera: Camera {
                position: Vec3::new(0.0, 3.0, 6.0),
                forward: Vec3::new(0.0, -3.0, -6.0),
                up: Vec3::Y,
                fov: Fov::Vertical(40.0),
            },
            sky: Sky::Colour(Rgb::ZERO),
            materials: vec![matte],
            objects: vec![
                Object {
                    name: "floor".into(),
                    shape: Shape::Plane { normal: Vec3::Y, offset: 0.0 },
                    material: 0,
                    world_from_object: Affine3A::IDENTITY,
                },
                Object {
                    name: "ball".into(),
                    shape: Shape::Sphere { centre: Vec3::Y, radius: 0.5 },
                    material: 0,
                    world_from_object: Affine3A::IDENTITY,
                },
            ],
            lights: vec![Light::Point {
                position: Vec3::new(0.0, 5.0, 0.0),
                colour: Rgb::ONE,
                intensity: 1.0,
                attenuation: Attenuation::None,
            }],
            ..Scene::default()
        };
        let slide = keys(vec![(0.0, Vec3::ZERO), (1.0, Vec3::new(4.0, 0.0, 0.0))], Repeat::Hold);
        s.animate(&[AnimationTarget::Light(0)], Motion { rotation: None, translation: slide }).expect("in range");
        s.validate().expect("valid");
        let mut world = World::new(s);
        let settings = RenderSettings { width: 33, height: 33, ..small_settings() };
        let centre = |w: &World| crate::render(w, &settings).expect("valid").0.pixel(16, 16).colour;
        let lit = |w: &World, p: Vec3| {
            let light = w.scene.lights[0].position().expect("a point light");
            let hit = w.intersect(&Ray::new(p + Vec3::Y, -Vec3::Y)).expect("the floor");
            w.transmittance(&hit.spawn_ray_to(light)).x > 0.0
        };
        let aside = Vec3::new(-1.25, 0.0, 0.0);
        assert_eq!(centre(&world), Rgb::ZERO, "under the ball: in its shadow");
        assert!(lit(&world, aside));
        assert!(world.set_time(1.0));
        assert_eq!(world.scene.lights[0].position(), Some(Vec3::new(4.0, 5.0, 0.0)));
        assert!(centre(&world).x > 0.1, "the shadow has moved away");
        assert!(!lit(&world, aside), "and fallen here");
        assert!(!world.set_time(2.0), "held at the last key");
    }

    /// An animated plane moves its equation: turned a quarter about Z it becomes x = 0, and
    /// keyframes lift it.
    #[test]
    fn an_animated_plane_turns_and_rises() {
        let mut s = scene(
            Some(Shape::Plane { normal: Vec3::Y, offset: 0.0 }),
            Affine3A::from_translation(Vec3::new(0.0, 0.0, -50.0)),
        );
        let rise = keys(vec![(0.0, Vec3::ZERO), (1.0, Vec3::new(0.0, 1.0, 0.0))], Repeat::Hold);
        s.animate(&[AnimationTarget::Object(1)], Motion { rotation: None, translation: rise }).expect("in range");
        let mut world = World::new(s.clone());
        let down = Ray::new(Vec3::new(0.0, 3.0, 0.0), -Vec3::Y);
        assert_eq!(world.intersect(&down).map(|h| h.t), Some(3.0));
        assert!(world.set_time(1.0));
        assert_eq!(world.intersect(&down).map(|h| h.t), Some(2.0));
        s.animations.clear();
        let quarter = Rotation { pivot: Some(Vec3::ZERO), ..spin(Vec3::Z, 90.0).expect("some") };
        s.animate(&[AnimationTarget::Object(1)], Motion { rotation: Some(quarter), translation: None })
            .expect("in range");
        let mut world = World::new(s);
        assert!(world.set_time(1.0));
        let hit = world.intersect(&Ray::new(Vec3::new(3.0, 0.5, 0.0), -Vec3::X)).expect("the plane x = 0");
        assert!((hit.t - 3.0).abs() < 1e-5 && (hit.geometric_normal - (-Vec3::X)).length() < 1e-6, "{hit:?}");
    }
}
