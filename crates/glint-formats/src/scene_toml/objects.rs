//! `[[object]]` → the scene's objects: spheres, planes, meshes (inline or read from a model
//! file, see [`super::meshes`]) and point clouds, each placed by its transform keys.
//!
//! The last tables the builder reads, since objects name materials. One object is built in
//! named steps: its material name is resolved and its animation read, its type builds the
//! shapes ([`Made`]), and only then does an object without a material get the scene's default
//! material (so the default is added once, and only when some object uses it).

use super::Builder;
use super::defs::{ObjectDef, ObjectKind};
use super::values::V3;
use crate::error::FormatError;
use crate::points::{self, ColourBy, PointReadOptions};
use glint_core::{Affine3A, Mat3, Vec3};
use glint_scene::{AnimationTarget, CloudObject, Material, Motion, Object, Orientation, PointCloud, Shape};
use std::path::Path;
use std::sync::Arc;
use toml::Spanned;

/// Keys that place an object in the world (every type but the plane, whose equation is
/// written in world space).
const TRANSFORM: [&str; 5] = ["translate", "rotate", "rotate_axis", "rotate_angle", "scale"];

/// What one `[[object]]` table makes, before its material is chosen.
enum Made {
    /// Scene objects sharing one placement, a name and a shape each (a model file gives one
    /// per mesh).
    Objects { shapes: Vec<(String, Shape)>, world_from_object: Affine3A },
    /// A point cloud (drawn by the points mode).
    Cloud { name: String, cloud: PointCloud, world_from_object: Affine3A },
}

fn kind_name(kind: ObjectKind) -> &'static str {
    match kind {
        ObjectKind::Sphere => "sphere",
        ObjectKind::Plane => "plane",
        ObjectKind::Mesh => "mesh",
        ObjectKind::Points => "points",
    }
}

impl Builder<'_> {
    /// Object `index` (1-based, for its default name) of the file.
    pub(super) fn object(&mut self, index: usize, o: &Spanned<ObjectDef>) -> Result<(), FormatError> {
        let def = o.get_ref();
        let kind = *def.kind.get_ref();
        let name = def.name.clone().unwrap_or_else(|| format!("object {index} ({})", kind_name(kind)));
        let material = self.named_material(def)?;
        let motion = self.object_motion(def, kind)?;
        let first = self.scene.objects.len();
        let made = match kind {
            ObjectKind::Sphere => self.sphere(o, name)?,
            ObjectKind::Plane => self.plane(o, name)?,
            ObjectKind::Mesh => self.mesh_object(o, name, material.is_some())?,
            ObjectKind::Points => self.point_cloud(o, name)?,
        };
        let material = self.material_or_default(material);
        self.add(made, material);
        if let Some(motion) = motion {
            let targets: Vec<AnimationTarget> =
                (first..self.scene.objects.len()).map(AnimationTarget::Object).collect();
            self.animate(&targets, motion)?;
        }
        Ok(())
    }

    /// The index of the `material` the object names, if it names one.
    fn named_material(&self, def: &ObjectDef) -> Result<Option<usize>, FormatError> {
        let Some(m) = &def.material else { return Ok(None) };
        match self.material_names.get(m.get_ref()) {
            Some(&i) => Ok(Some(i)),
            None => {
                Err(self.err(&m.span(), format!("no material named '{}' (define it with [[material]])", m.get_ref())))
            }
        }
    }

    /// `[object.animation]`: spheres, planes and meshes move; point clouds do not.
    fn object_motion(&self, def: &ObjectDef, kind: ObjectKind) -> Result<Option<Motion>, FormatError> {
        match &def.animation {
            Some(a) if kind == ObjectKind::Points => {
                Err(self.err(&a.span(), "point clouds cannot be animated (only spheres, planes and meshes)"))
            }
            Some(a) => Ok(Some(self.animation(a, false)?)),
            None => Ok(None),
        }
    }

    /// The material an object uses: the one it names, or else the scene's default material
    /// (added to the scene the first time an object needs it).
    fn material_or_default(&mut self, named: Option<usize>) -> usize {
        match named {
            Some(m) => m,
            None => *self.default_material.get_or_insert_with(|| {
                self.scene.materials.push(Material::default());
                self.scene.materials.len() - 1
            }),
        }
    }

    fn add(&mut self, made: Made, material: usize) {
        match made {
            Made::Objects { shapes, world_from_object } => {
                for (name, shape) in shapes {
                    self.scene.objects.push(Object { name, shape, material, world_from_object });
                }
            }
            Made::Cloud { name, cloud, world_from_object } => {
                self.scene.clouds.push(CloudObject { name, cloud: Arc::new(cloud), material, world_from_object });
            }
        }
    }

    /// Rejects a key of `def` that its type does not take: the type's `own` keys, and the
    /// placement keys when the type is `placed`.
    fn allow_keys(&self, def: &ObjectDef, own: &[&str], placed: bool, what: &str) -> Result<(), FormatError> {
        let transform: &[&str] = if placed { &TRANSFORM } else { &[] };
        let allowed: Vec<&str> = own.iter().chain(transform).copied().collect();
        self.disallow(&def.shape_keys(), &allowed, what)
    }

    fn sphere(&self, o: &Spanned<ObjectDef>, name: String) -> Result<Made, FormatError> {
        let def = o.get_ref();
        self.allow_keys(def, &["centre", "radius"], true, "a sphere")?;
        let centre = def.centre.as_ref().map_or(Vec3::ZERO, |c| c.get_ref().0);
        let Some(r) = &def.radius else {
            return Err(self.missing(&o.span(), format!("sphere '{name}' needs `radius`")));
        };
        let radius = r.get_ref().0;
        if radius <= 0.0 {
            return Err(self.err(&r.span(), format!("sphere radius {radius} must be > 0")));
        }
        let world_from_object = self.transform(def)?;
        Ok(Made::Objects { shapes: vec![(name, Shape::Sphere { centre, radius })], world_from_object })
    }

    fn plane(&self, o: &Spanned<ObjectDef>, name: String) -> Result<Made, FormatError> {
        let def = o.get_ref();
        self.allow_keys(def, &["normal", "offset", "point"], false, "a plane (its equation is in world space)")?;
        let Some(n) = &def.normal else {
            return Err(self.missing(&o.span(), format!("plane '{name}' needs `normal`")));
        };
        let normal = self.direction(n, "normal")?;
        let offset = match (&def.offset, &def.point) {
            (Some(_), Some(p)) => return Err(self.err(&p.span(), "give either `offset` or `point`, not both")),
            (Some(d), None) => d.get_ref().0,
            (None, Some(p)) => -p.get_ref().0.dot(normal),
            (None, None) => 0.0,
        };
        Ok(Made::Objects {
            shapes: vec![(name, Shape::Plane { normal, offset })],
            world_from_object: Affine3A::IDENTITY,
        })
    }

    /// A mesh object: inline `vertices` and `triangles`, or every mesh of a model file (then
    /// named `name/mesh`). `overridden`: the object names a material, which replaces the
    /// file's own.
    fn mesh_object(&mut self, o: &Spanned<ObjectDef>, name: String, overridden: bool) -> Result<Made, FormatError> {
        let def = o.get_ref();
        let world_from_object = self.transform(def)?;
        let shading = def.shading.as_ref().map(|s| *s.get_ref());
        let mesh_indices = match &def.path {
            Some(path) => {
                self.allow_keys(def, &["path", "shading"], true, "a mesh read from a file")?;
                self.file_meshes(path, shading, overridden)?
            }
            None => {
                self.allow_keys(def, &["vertices", "triangles", "normals", "uvs", "shading"], true, "an inline mesh")?;
                let mesh = self.inline_mesh(o, &name, shading)?;
                self.scene.meshes.push(Arc::new(mesh));
                vec![self.scene.meshes.len() - 1]
            }
        };
        let single = mesh_indices.len() == 1;
        let shapes = mesh_indices
            .into_iter()
            .map(|i| {
                let object_name = if single { name.clone() } else { format!("{name}/{}", self.scene.meshes[i].name) };
                (object_name, Shape::Mesh(i))
            })
            .collect();
        Ok(Made::Objects { shapes, world_from_object })
    }

    fn point_cloud(&mut self, o: &Spanned<ObjectDef>, name: String) -> Result<Made, FormatError> {
        let def = o.get_ref();
        self.allow_keys(def, &["path", "colour_by", "sensor"], true, "a point cloud")?;
        let Some(path) = &def.path else {
            return Err(self.missing(
                &o.span(),
                format!("point cloud '{name}' needs `path` (a .ply, .las, .laz, .xyz or .pts file)"),
            ));
        };
        let colour_by = match &def.colour_by {
            Some(c) => ColourBy::from_name(c.get_ref()).ok_or_else(|| {
                self.err(
                    &c.span(),
                    format!("colour_by {:?}: use auto, rgb, intensity, classification or elevation", c.get_ref()),
                )
            })?,
            None => ColourBy::Auto,
        };
        let file = self.resolve(path, "path")?;
        let mut cloud = points::read_point_cloud(&file, &PointReadOptions { colour_by })?;
        self.warnings.extend(points::coincident_warning(&file, &cloud));
        if let Some(s) = &def.sensor {
            self.orient_toward_sensor(&mut cloud, &file, s)?;
        }
        let world_from_object = self.transform(def)?;
        Ok(Made::Cloud { name, cloud, world_from_object })
    }

    /// `sensor`: the scanner's position, given in the cloud file's own axes, toward which
    /// estimated normals are turned.
    fn orient_toward_sensor(&self, cloud: &mut PointCloud, file: &Path, s: &Spanned<V3>) -> Result<(), FormatError> {
        if cloud.normals.is_some() {
            return Err(self.err(&s.span(), "`sensor` orients estimated normals, but this cloud has its own"));
        }
        let sensor = points::glint_from_file_axes(file, s.get_ref().0.as_dvec3());
        cloud.orientation = Orientation::TowardSensor((sensor - cloud.origin).as_vec3());
        Ok(())
    }

    /// `world_from_object` of `translate`, `rotate` (or `rotate_axis` + `rotate_angle`) and
    /// `scale`: scale first, then rotate, then translate.
    fn transform(&self, def: &ObjectDef) -> Result<Affine3A, FormatError> {
        let translate = def.translate.as_ref().map_or(Vec3::ZERO, |t| t.get_ref().0);
        let rotation = match (&def.rotate, &def.rotate_axis, &def.rotate_angle) {
            (Some(_), Some(a), _) => {
                return Err(self.err(&a.span(), "give either `rotate` or `rotate_axis` + `rotate_angle`, not both"));
            }
            (Some(_), None, Some(a)) => {
                return Err(self.err(&a.span(), "`rotate_angle` goes with `rotate_axis`, not with `rotate`"));
            }
            (Some(r), None, None) => {
                let [x, y, z] = r.get_ref().0.to_array().map(f32::to_radians);
                // X first, then Y, then Z (about the fixed world axes).
                Mat3::from_rotation_z(z) * Mat3::from_rotation_y(y) * Mat3::from_rotation_x(x)
            }
            (None, Some(axis), Some(angle)) => {
                let axis = self.direction(axis, "rotate_axis")?;
                Mat3::from_axis_angle(axis, angle.get_ref().0.to_radians())
            }
            (None, Some(a), None) => return Err(self.err(&a.span(), "`rotate_axis` needs `rotate_angle` (degrees)")),
            (None, None, Some(a)) => return Err(self.err(&a.span(), "`rotate_angle` needs `rotate_axis`")),
            (None, None, None) => Mat3::IDENTITY,
        };
        let scale = match &def.scale {
            Some(s) => {
                let v = s.get_ref().0;
                if v.abs().min_element() < 1e-12 {
                    return Err(self.err(&s.span(), "`scale` must not be 0 (the object would vanish)"));
                }
                v
            }
            None => Vec3::ONE,
        };
        Ok(Affine3A::from_mat3_translation(rotation * Mat3::from_diagonal(scale), translate))
    }
}
