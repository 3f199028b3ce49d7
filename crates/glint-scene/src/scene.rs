//! The scene: everything a render needs, validated once.

use crate::{Animation, Camera, CloudObject, Light, Material, Mesh, Object, SceneError, Shape, Sky, Texture};
use glint_core::{Bounds3, Rgb, Vec3};
use std::sync::Arc;

pub use crate::limits::{MAX_IMAGE_PIXELS, MAX_IMAGE_SIDE, image_size_ok};

/// Render settings a scene file may give; the CLI overrides them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderDefaults {
    pub width: u32,
    pub height: u32,
    /// N for N×N stratified supersampling (1 = one ray through each pixel centre).
    pub samples_per_side: u32,
    /// Maximum ray depth (primary ray = depth 0).
    pub max_depth: u32,
    /// A reflection/refraction branch whose accumulated weight falls below this is not traced.
    pub min_contribution: f32,
    /// The mode a scene is meant for (the command line may choose another).
    pub mode: RenderMode,
    /// Path mode: indirect bounces.
    pub max_bounces: u32,
    /// Path mode: samples per pixel the scene asks for (Mitsuba's sampler `sample_count`);
    /// `--spp` overrides it; None: 1.
    pub spp: Option<u32>,
    /// Path mode: a total vertex budget with Mitsuba's meaning (its `max_depth`; see
    /// `PathSettings::max_depth` in glint-render); None: glint's budgets above.
    pub path_depth: Option<u32>,
    /// Path mode: Russian roulette from this bounce on (None: the renderer's default).
    pub rr_depth: Option<u32>,
    /// Path mode: filter the indirect light in image space unless told otherwise (the
    /// `--filter` default: guided). Mitsuba scenes say no: their integrators have no filter,
    /// and a researcher comparing against Mitsuba expects its plain estimator.
    pub image_filter: bool,
    /// Path mode: the film's pixel filter (Mitsuba's `rfilter`; glint's own scenes: box).
    pub pixel_filter: glint_core::PixelFilter,
    /// Path mode: emitters and the sky seen directly by the camera are left out (Mitsuba's
    /// `hide_emitters`); seen in mirrors and glass, and as light, they stay.
    pub hide_emitters: bool,
    /// Path mode: how camera samples draw their random numbers (`[render] sampler`; Mitsuba's
    /// `independent` sampler stays independent, its stratified ones become Sobol).
    pub sampler: glint_core::random::Sampler,
    /// Render only this window of the `width × height` film: x0, y0, width, height in pixels
    /// (Mitsuba's film crop; `glint render --crop` overrides it). None: the whole film.
    pub crop: Option<[u32; 4]>,
}

/// Rendering modes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum RenderMode {
    #[default]
    Whitted,
    Path,
    /// Point clouds by pull-push reconstruction (meshes, if any, traced Whitted-style beside).
    Points,
}

impl RenderMode {
    /// The mode's name as summaries and the viewer show it.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            RenderMode::Whitted => "Whitted",
            RenderMode::Path => "path",
            RenderMode::Points => "points",
        }
    }
}

impl Default for RenderDefaults {
    fn default() -> Self {
        Self {
            width: 1280,
            height: 720,
            samples_per_side: 1,
            max_depth: 8,
            min_contribution: 1e-3,
            mode: RenderMode::Whitted,
            max_bounces: 3,
            spp: None,
            path_depth: None,
            rr_depth: None,
            image_filter: true,
            pixel_filter: glint_core::PixelFilter::Box,
            hide_emitters: false,
            sampler: glint_core::random::Sampler::Sobol,
            crop: None,
        }
    }
}

#[derive(Clone, Debug, Default)]
pub struct Scene {
    pub camera: Camera,
    pub render: RenderDefaults,
    pub sky: Sky,
    /// I_a: ambient light colour, multiplied by each material's K_a. With `sky_ambient`, a tint
    /// on the sky's light instead.
    pub ambient: Rgb,
    /// The ambient light is the sky's: for a surface with normal n, I_a = `ambient` · E(n)/π,
    /// E the sky's irradiance (so a uniform sky of radiance L gives I_a = `ambient` · L).
    pub sky_ambient: bool,
    pub materials: Vec<Material>,
    /// Physically based models that materials may name ([`crate::bsdf`]).
    pub bsdfs: Vec<crate::BsdfKind>,
    pub textures: Vec<Texture>,
    pub meshes: Vec<Arc<Mesh>>,
    pub objects: Vec<Object>,
    /// Point clouds (drawn by the points mode only).
    pub clouds: Vec<CloudObject>,
    pub lights: Vec<Light>,
    /// Objects and lights that move ([`Scene::set_time`] places them; at most one each).
    pub animations: Vec<Animation>,
}

fn finite3(v: Vec3) -> bool {
    v.is_finite()
}

impl Scene {
    /// World-space bounds of every bounded object (planes excluded).
    pub fn bounds(&self) -> Bounds3 {
        let mut b = Bounds3::EMPTY;
        for o in &self.objects {
            b = b.union(self.object_bounds(o));
        }
        for c in &self.clouds {
            b = b.union(c.cloud.bounds().transformed(&c.world_from_object));
        }
        b
    }

    /// World-space bounds of one object (empty for planes and dangling meshes).
    pub fn object_bounds(&self, o: &Object) -> Bounds3 {
        let local = match o.shape {
            Shape::Sphere { centre, radius } => {
                Bounds3::new(centre - Vec3::splat(radius), centre + Vec3::splat(radius))
            }
            Shape::Plane { .. } => return Bounds3::EMPTY,
            Shape::Mesh(i) => match self.meshes.get(i) {
                Some(m) => m.bounds(),
                None => return Bounds3::EMPTY,
            },
        };
        local.transformed(&o.world_from_object)
    }

    /// Check every value an integrator relies on. After `Ok`, rendering cannot meet a NaN
    /// coordinate, a dangling index or an impossible size.
    pub fn validate(&self) -> Result<(), SceneError> {
        let r = &self.render;
        if !image_size_ok(r.width, r.height) {
            return Err(SceneError::ImageSize { width: r.width, height: r.height, max: MAX_IMAGE_SIDE });
        }
        if r.samples_per_side == 0 || r.samples_per_side > 64 {
            return Err(SceneError::invalid(
                "render",
                format!("samples per side {} is outside 1..=64", r.samples_per_side),
            ));
        }
        if !(r.min_contribution.is_finite() && r.min_contribution >= 0.0) {
            return Err(SceneError::invalid("render", "min_contribution must be a finite number >= 0"));
        }
        let c = &self.camera;
        if !finite3(c.position) || !finite3(c.forward) || !finite3(c.up) {
            return Err(SceneError::invalid("camera", "position, direction and up must be finite numbers"));
        }
        if c.forward.length_squared() == 0.0 {
            return Err(SceneError::invalid("camera", "the view direction has zero length (look_at equals position?)"));
        }
        if c.forward.normalize().cross(c.up).length_squared() < 1e-12 {
            return Err(SceneError::invalid("camera", "up is parallel to the view direction"));
        }
        let fov = c.fov.degrees();
        if !(fov > 0.0 && fov < 180.0) {
            return Err(SceneError::invalid("camera", format!("field of view {fov}° must be in (0, 180)")));
        }
        match c.lens {
            crate::Lens::Pinhole => {}
            crate::Lens::ThinLens { aperture_radius: r, focus_distance: f } => {
                if !(r.is_finite() && r >= 0.0 && f.is_finite() && f > 0.0) {
                    return Err(SceneError::invalid(
                        "camera",
                        format!("thin lens: aperture radius {r} must be >= 0 and focus distance {f} > 0, both finite"),
                    ));
                }
            }
            crate::Lens::Orthographic(crate::ViewSize::HalfWidth(h) | crate::ViewSize::HalfHeight(h)) => {
                if !(h.is_finite() && h > 0.0) {
                    return Err(SceneError::invalid(
                        "camera",
                        format!("orthographic view size {h} must be finite and > 0"),
                    ));
                }
            }
        }
        if !finite3(self.ambient) || self.ambient.min_element() < 0.0 {
            return Err(SceneError::invalid("ambient", "must be a finite, non-negative colour"));
        }
        for (i, t) in self.textures.iter().enumerate() {
            if let Texture::Checker { size, .. } = t
                && !(size.is_finite() && *size > 0.0)
            {
                return Err(SceneError::invalid(format!("texture #{i}"), "checker size must be > 0"));
            }
        }
        self.validate_bsdfs()?;
        for m in &self.materials {
            self.validate_material(m)?;
        }
        for (i, l) in self.lights.iter().enumerate() {
            validate_light(i, l)?;
        }
        for (i, mesh) in self.meshes.iter().enumerate() {
            self.validate_mesh(i, mesh)?;
        }
        if self.objects.is_empty() && self.clouds.is_empty() {
            return Err(SceneError::Empty);
        }
        for o in &self.objects {
            self.validate_object(o)?;
        }
        for c in &self.clouds {
            self.validate_cloud(c)?;
        }
        for (i, a) in self.animations.iter().enumerate() {
            self.validate_animation(i, a)?;
        }
        Ok(())
    }

    fn validate_cloud(&self, c: &CloudObject) -> Result<(), SceneError> {
        if c.material >= self.materials.len() {
            return Err(SceneError::invalid(format!("point cloud '{}'", c.name), "material index out of range"));
        }
        if !c.world_from_object.is_finite() || c.world_from_object.matrix3.determinant() == 0.0 {
            return Err(SceneError::invalid(
                format!("point cloud '{}'", c.name),
                "transform is not finite and invertible",
            ));
        }
        c.cloud.validate()
    }

    /// Every BSDF's references (BSDFs, textures) in range and acyclic, its numbers in range.
    fn validate_bsdfs(&self) -> Result<(), SceneError> {
        use crate::bsdf::{BsdfKind, Tex};
        let n = self.bsdfs.len();
        for (i, b) in self.bsdfs.iter().enumerate() {
            let what = || format!("bsdf #{i}");
            if let Some(c) = b.children().into_iter().find(|&c| c >= n) {
                return Err(SceneError::invalid(what(), format!("refers to bsdf #{c}, there are {n}")));
            }
            if let Some(t) = b.textures().into_iter().find(|&t| t >= self.textures.len()) {
                return Err(SceneError::invalid(
                    what(),
                    format!("refers to texture #{t}, there are {}", self.textures.len()),
                ));
            }
            let eta_ok = |e: f32| e.is_finite() && e > 0.0;
            let alpha_ok = |a: &Tex<f32>| !matches!(*a, Tex::Value(v) if !(v.is_finite() && v >= 0.0));
            let ok = match b {
                BsdfKind::Conductor { eta, k, .. } | BsdfKind::RoughConductor { eta, k, .. } => {
                    eta.is_finite() && k.is_finite() && eta.min_element() >= 0.0 && k.min_element() >= 0.0
                }
                BsdfKind::Dielectric { eta, .. }
                | BsdfKind::ThinDielectric { eta, .. }
                | BsdfKind::RoughDielectric { eta, .. }
                | BsdfKind::Plastic { eta, .. }
                | BsdfKind::RoughPlastic { eta, .. } => eta_ok(*eta),
                BsdfKind::BumpMap { scale, .. } => scale.is_finite(),
                BsdfKind::Mask { cutoff, .. } => cutoff.is_none_or(|c| (0.0..=1.0).contains(&c)),
                BsdfKind::Principled(p) => p.eta.is_none_or(eta_ok) && p.specular.is_finite(),
                _ => true,
            } && match b {
                BsdfKind::RoughConductor { roughness, .. }
                | BsdfKind::RoughDielectric { roughness, .. }
                | BsdfKind::RoughPlastic { roughness, .. } => {
                    alpha_ok(&roughness.alpha_u) && alpha_ok(&roughness.alpha_v)
                }
                _ => true,
            };
            if !ok {
                return Err(SceneError::invalid(what(), format!("parameters out of range: {b:?}")));
            }
        }
        // Acyclic: a depth-first walk that never meets a BSDF it is still inside (each BSDF
        // finished once, so shared children cost nothing more).
        let mut state = vec![0u8; n]; // 0 unseen, 1 on the walk, 2 done
        for root in 0..n {
            if state[root] != 0 {
                continue;
            }
            let mut stack = vec![(root, false)];
            while let Some((j, leaving)) = stack.pop() {
                if leaving {
                    state[j] = 2;
                    continue;
                }
                match state[j] {
                    1 => {
                        return Err(SceneError::invalid(
                            format!("bsdf #{j}"),
                            "nested BSDFs refer to each other in a cycle",
                        ));
                    }
                    2 => continue,
                    _ => {}
                }
                state[j] = 1;
                stack.push((j, true));
                stack.extend(self.bsdfs[j].children().into_iter().map(|c| (c, false)));
            }
        }
        Ok(())
    }

    fn validate_material(&self, m: &Material) -> Result<(), SceneError> {
        let what = || format!("material '{}'", m.name);
        let scalars = [
            ("ambient", m.ambient),
            ("diffuse", m.diffuse),
            ("specular", m.specular),
            ("shininess", m.shininess),
            ("reflectivity", m.reflectivity),
            ("transparency", m.transparency),
        ];
        for (name, v) in scalars {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SceneError::invalid(what(), format!("{name} = {v} must be a finite number >= 0")));
            }
        }
        if m.transparency > 1.0 || m.reflectivity > 1.0 {
            return Err(SceneError::invalid(what(), "reflectivity and transparency must be at most 1"));
        }
        if !(m.ior.is_finite() && m.ior >= 1.0 && m.ior <= 10.0) {
            return Err(SceneError::invalid(what(), format!("ior = {} must be in [1, 10]", m.ior)));
        }
        if let Some(f0) = m.reflection_f0 {
            if !f0.is_finite() || f0.min_element() < 0.0 || f0.max_element() > 1.0 {
                return Err(SceneError::invalid(what(), format!("f0 = {f0} must be in [0, 1]")));
            }
            if m.reflectivity > 0.0 || m.transparency > 0.0 {
                return Err(SceneError::invalid(
                    what(),
                    "Fresnel reflection (f0) and a constant reflectivity or transparency exclude each other",
                ));
            }
        }
        if !m.colour.is_finite()
            || m.colour.min_element() < 0.0
            || !m.emission.is_finite()
            || m.emission.min_element() < 0.0
        {
            return Err(SceneError::invalid(what(), "colour and emission must be finite and non-negative"));
        }
        if let Some(b) = m.bsdf
            && b >= self.bsdfs.len()
        {
            return Err(SceneError::invalid(what(), format!("refers to bsdf #{b}, there are {}", self.bsdfs.len())));
        }
        if let Some(t) = m.texture.into_iter().chain(m.emission_texture).find(|&t| t >= self.textures.len()) {
            return Err(SceneError::BadReference {
                what: what(),
                kind: "texture",
                index: t,
                count: self.textures.len(),
            });
        }
        Ok(())
    }

    fn validate_mesh(&self, i: usize, mesh: &Mesh) -> Result<(), SceneError> {
        let what = || format!("mesh '{}' (#{i})", mesh.name);
        if mesh.triangles.is_empty() {
            return Err(SceneError::invalid(what(), "has no triangles"));
        }
        if let Some(p) = mesh.positions.iter().position(|p| !p.is_finite()) {
            return Err(SceneError::invalid(what(), format!("vertex {p} has a NaN or infinite coordinate")));
        }
        let n = mesh.positions.len();
        if let Some((t, _)) = mesh.triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&v| v as usize >= n)) {
            return Err(SceneError::invalid(what(), format!("triangle {t} refers to a vertex beyond the {n} it has")));
        }
        if let Some(normals) = &mesh.normals {
            if normals.len() != n {
                return Err(SceneError::invalid(what(), format!("{} normals for {n} vertices", normals.len())));
            }
            if normals.iter().any(|v| !v.is_finite()) {
                return Err(SceneError::invalid(what(), "a vertex normal is NaN or infinite"));
            }
        }
        if let Some(uvs) = &mesh.uvs {
            if uvs.len() != n {
                return Err(SceneError::invalid(what(), format!("{} texture coordinates for {n} vertices", uvs.len())));
            }
            if uvs.iter().any(|v| !v.is_finite()) {
                return Err(SceneError::invalid(what(), "a texture coordinate is NaN or infinite"));
            }
        }
        if let Some(tm) = &mesh.triangle_materials {
            if tm.len() != mesh.triangles.len() {
                return Err(SceneError::invalid(what(), "per-triangle materials do not match the triangle count"));
            }
            if let Some(&bad) = tm.iter().find(|&&m| m as usize >= self.materials.len()) {
                return Err(SceneError::BadReference {
                    what: what(),
                    kind: "material",
                    index: bad as usize,
                    count: self.materials.len(),
                });
            }
        }
        Ok(())
    }

    fn validate_object(&self, o: &Object) -> Result<(), SceneError> {
        let what = || format!("object '{}'", o.name);
        if o.material >= self.materials.len() {
            return Err(SceneError::BadReference {
                what: what(),
                kind: "material",
                index: o.material,
                count: self.materials.len(),
            });
        }
        let m = o.world_from_object;
        if !(m.matrix3.x_axis.is_finite()
            && m.matrix3.y_axis.is_finite()
            && m.matrix3.z_axis.is_finite()
            && m.translation.is_finite())
        {
            return Err(SceneError::invalid(what(), "transform has a NaN or infinite entry"));
        }
        if m.matrix3.determinant().abs() < 1e-12 {
            return Err(SceneError::invalid(what(), "transform is singular (a scale of 0?)"));
        }
        match o.shape {
            Shape::Sphere { centre, radius } => {
                if !(centre.is_finite() && radius.is_finite() && radius > 0.0) {
                    return Err(SceneError::invalid(
                        what(),
                        format!("sphere needs a finite centre and radius > 0 (radius = {radius})"),
                    ));
                }
            }
            Shape::Plane { normal, offset } => {
                if !normal.is_finite() || !offset.is_finite() || (normal.length() - 1.0).abs() > 1e-3 {
                    return Err(SceneError::invalid(what(), "plane needs a finite unit normal and offset"));
                }
            }
            Shape::Mesh(i) => {
                if i >= self.meshes.len() {
                    return Err(SceneError::BadReference {
                        what: what(),
                        kind: "mesh",
                        index: i,
                        count: self.meshes.len(),
                    });
                }
            }
        }
        Ok(())
    }
}

fn validate_light(i: usize, l: &Light) -> Result<(), SceneError> {
    let what = || format!("light #{i}");
    let (colour, intensity) = match *l {
        Light::Point { position, colour, intensity, .. } => {
            if !position.is_finite() {
                return Err(SceneError::invalid(what(), "position must be finite"));
            }
            (colour, intensity)
        }
        Light::Directional { direction, colour, intensity } => {
            if !direction.is_finite() || (direction.length() - 1.0).abs() > 1e-3 {
                return Err(SceneError::invalid(what(), "direction must be a finite unit vector"));
            }
            (colour, intensity)
        }
        Light::Spot { position, direction, inner_deg, outer_deg, colour, intensity, .. } => {
            if !position.is_finite() || !direction.is_finite() || (direction.length() - 1.0).abs() > 1e-3 {
                return Err(SceneError::invalid(
                    what(),
                    "position and direction must be finite (direction unit length)",
                ));
            }
            if !(inner_deg >= 0.0 && inner_deg <= outer_deg && outer_deg > 0.0 && outer_deg <= 180.0) {
                return Err(SceneError::invalid(
                    what(),
                    format!("cone angles need 0 <= inner ({inner_deg}) <= outer ({outer_deg}) <= 180"),
                ));
            }
            (colour, intensity)
        }
    };
    if !colour.is_finite() || colour.min_element() < 0.0 || !(intensity.is_finite() && intensity >= 0.0) {
        return Err(SceneError::invalid(what(), "colour and intensity must be finite and non-negative"));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use glint_core::Affine3A;

    fn one_sphere() -> Scene {
        Scene {
            materials: vec![Material::default()],
            objects: vec![Object {
                name: "s".into(),
                shape: Shape::Sphere { centre: Vec3::ZERO, radius: 1.0 },
                material: 0,
                world_from_object: Affine3A::IDENTITY,
            }],
            ..Default::default()
        }
    }

    #[test]
    fn a_sphere_scene_is_valid() {
        assert_eq!(one_sphere().validate(), Ok(()));
    }

    #[test]
    fn empty_scene_is_rejected() {
        let s = Scene { materials: vec![Material::default()], ..Default::default() };
        assert_eq!(s.validate(), Err(SceneError::Empty));
    }

    #[test]
    fn nan_radius_and_bad_material_are_rejected() {
        let mut s = one_sphere();
        s.objects[0].shape = Shape::Sphere { centre: Vec3::ZERO, radius: f32::NAN };
        assert!(matches!(s.validate(), Err(SceneError::InvalidValue { .. })));
        let mut s = one_sphere();
        s.objects[0].material = 3;
        assert!(matches!(s.validate(), Err(SceneError::BadReference { .. })));
    }

    #[test]
    fn fresnel_reflection_excludes_constant_reflectivity_and_stays_in_range() {
        let mut s = one_sphere();
        s.materials[0].reflection_f0 = Some(Rgb::splat(0.04));
        assert!(s.validate().is_ok());
        s.materials[0].reflectivity = 0.5;
        let e = s.validate().expect_err("both");
        assert!(e.to_string().contains("exclude each other"), "{e}");
        s.materials[0].reflectivity = 0.0;
        s.materials[0].reflection_f0 = Some(Rgb::new(1.2, 0.5, 0.5));
        assert!(s.validate().is_err());
        s.materials[0].reflection_f0 = Some(Rgb::new(f32::NAN, 0.5, 0.5));
        assert!(s.validate().is_err());
    }

    #[test]
    fn schlick_goes_from_f0_to_one() {
        let m = Material { reflection_f0: Some(Rgb::splat(0.04)), ..Material::default() };
        assert_eq!(m.schlick(1.0), Some(Rgb::splat(0.04)));
        assert_eq!(m.schlick(0.0), Some(Rgb::ONE));
        let mid = m.schlick(0.5).expect("opted in").x;
        assert!((mid - (0.04 + 0.96 * 0.5f32.powi(5))).abs() < 1e-6);
        assert_eq!(Material::default().schlick(0.5), None);
    }

    #[test]
    fn impossible_image_size_is_rejected() {
        let mut s = one_sphere();
        s.render.width = 0;
        assert!(matches!(s.validate(), Err(SceneError::ImageSize { .. })));
        s.render.width = 1_000_000;
        assert!(matches!(s.validate(), Err(SceneError::ImageSize { .. })));
    }

    #[test]
    fn mesh_with_out_of_range_index_is_rejected() {
        let mut s = one_sphere();
        s.meshes.push(Arc::new(Mesh {
            name: "m".into(),
            positions: vec![Vec3::ZERO; 2],
            triangles: vec![[0, 1, 2]],
            ..Default::default()
        }));
        let err = s.validate().expect_err("index 2 of 2 vertices");
        assert!(err.to_string().contains("triangle 0"), "{err}");
    }

    #[test]
    fn bsdf_references_are_checked_and_cycles_refused() {
        use crate::bsdf::{BsdfKind, Tex};
        let diffuse = BsdfKind::Diffuse { reflectance: Tex::Value(Rgb::splat(0.5)) };
        let mut s = one_sphere();
        // A diamond (both halves of a blend wrap the same model) is fine.
        s.bsdfs = vec![
            diffuse.clone(),
            BsdfKind::Mask { opacity: Tex::Value(0.5), inner: 0, cutoff: None },
            BsdfKind::Blend { weight: Tex::Value(0.5), a: 1, b: 0 },
        ];
        s.materials[0].bsdf = Some(2);
        assert!(s.validate().is_ok());
        s.bsdfs[0] = BsdfKind::TwoSided { front: 2, back: 2 };
        let err = s.validate().unwrap_err().to_string();
        assert!(err.contains("cycle"), "{err}");
        s.bsdfs[0] = diffuse;
        s.materials[0].bsdf = Some(3);
        assert!(s.validate().is_err());
        s.materials[0].bsdf = Some(0);
        s.bsdfs[1] = BsdfKind::Dielectric {
            eta: -1.0,
            specular_reflectance: Tex::Value(Rgb::ONE),
            specular_transmittance: Tex::Texture(9),
        };
        assert!(s.validate().is_err());
    }
}
