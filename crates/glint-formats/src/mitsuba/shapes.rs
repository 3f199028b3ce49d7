//! Shapes → objects: OBJ and PLY files (this crate's readers), `.serialized` meshes,
//! Mitsuba's rectangle, cube, disk and cylinder as triangle meshes with its uv
//! parameterisations and normals (src/shapes/*.cpp), spheres as glint's analytic sphere, and
//! shape groups placed by instances. Mitsuba's uv has v = 0 at an image's top; glint's at its
//! bottom, so generated and `.serialized`/PLY uvs are stored as (u, 1 − v) (Mitsuba's OBJ
//! reader already flips v, as glint's keeps it).

use super::Builder;
use super::props::{Props, any_perpendicular, is_affine};
use super::xml::Element;
use crate::error::FormatError;
use glint_core::glam::{DMat4, DVec3};
use glint_core::{Affine3A, Rgb, Vec2, Vec3};
use glint_scene::{BsdfKind, Mesh, Object, Shape, Tex};
use std::f32::consts::TAU;
use std::sync::Arc;

/// One object a shape element makes (before an instance places it).
#[derive(Clone, Debug)]
pub(super) struct Part {
    pub name: String,
    pub shape: Shape,
    pub material: usize,
    pub world_from_object: DMat4,
}

/// Segments around generated disks and cylinders.
const SEGMENTS: u32 = 64;

impl<'a> Builder<'a> {
    pub(super) fn shape(&mut self, el: &'a Element) -> Result<(), FormatError> {
        if el.attr("type") == Some("shapegroup") {
            // Placed only by instances.
            return self.group(el).map(|_| ());
        }
        for part in self.shape_parts(el)? {
            self.place(part, DMat4::IDENTITY, el)?;
        }
        Ok(())
    }

    fn place(&mut self, part: Part, world_from_group: DMat4, at: &Element) -> Result<(), FormatError> {
        let m = world_from_group * part.world_from_object;
        if !is_affine(&m) {
            return Err(at.loc.error("to_world is projective (its last row is not 0 0 0 1)"));
        }
        let m = Affine3A::from_mat4(m.as_mat4());
        if m.matrix3.determinant() == 0.0 || !m.is_finite() {
            return Err(at.loc.error(format!("{}: to_world is not invertible", at.describe())));
        }
        self.scene.objects.push(Object {
            name: part.name,
            shape: part.shape,
            material: part.material,
            world_from_object: m,
        });
        Ok(())
    }

    fn group(&mut self, el: &'a Element) -> Result<Vec<Part>, FormatError> {
        if let Some(parts) = self.group_cache.get(&super::key(el)) {
            return Ok(parts.clone());
        }
        let p = self.props(el)?;
        let mut parts = Vec::new();
        for (_, s) in p.objects("shape") {
            if s.attr("type") == Some("shapegroup") || s.attr("type") == Some("instance") {
                return Err(s.loc.error("a shapegroup may not hold another group or an instance"));
            }
            parts.extend(self.shape_parts(s)?);
        }
        self.finish(&p)?;
        self.group_cache.insert(super::key(el), parts.clone());
        Ok(parts)
    }

    /// The objects of one shape element, placed by its own `to_world`.
    fn shape_parts(&mut self, el: &'a Element) -> Result<Vec<Part>, FormatError> {
        let p = self.props(el)?;
        if p.plugin == "instance" {
            let groups = p.objects("shape");
            let [(_, group)] = groups.as_slice() else {
                return Err(el.loc.error("an instance needs exactly one <ref> to a shapegroup"));
            };
            if group.attr("type") != Some("shapegroup") {
                return Err(el.loc.error(format!("an instance refers to {}, not a shapegroup", group.describe())));
            }
            let to_world = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
            self.finish(&p)?;
            let parts = self.group(group)?;
            for part in parts {
                self.place(part, to_world, el)?;
            }
            return Ok(Vec::new());
        }
        let name = el.attr("id").map(str::to_string);
        let to_world = p.transform("to_world")?.unwrap_or(DMat4::IDENTITY);
        let flip = p.boolean("flip_normals", false)?;
        let face_normals = p.boolean("face_normals", false)?;
        let (bsdf, emission) = self.shape_appearance(&p)?;
        p.ignore(&["id"]);
        let mut meshes: Vec<Mesh> = Vec::new();
        let mut world = to_world;
        let mut sphere = None;
        match p.plugin {
            "obj" | "ply" => {
                let file = self
                    .resolve(p.string("filename")?.ok_or_else(|| el.loc.error("a mesh shape needs a filename"))?, el)?;
                let mut model =
                    if p.plugin == "obj" { crate::obj::load(&file)? } else { crate::ply::load_with_attributes(&file)? };
                let flip_uv = if p.plugin == "obj" { !p.boolean("flip_tex_coords", true)? } else { true };
                p.ignore(&["max_smooth_angle"]);
                self.warnings.append(&mut model.warnings);
                for mut m in model.meshes {
                    m.triangle_materials = None;
                    if flip_uv && let Some(uvs) = &mut m.uvs {
                        uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
                    }
                    meshes.push(m);
                }
            }
            "serialized" => {
                let file = self.resolve(
                    p.string("filename")?.ok_or_else(|| el.loc.error("a serialized shape needs a filename"))?,
                    el,
                )?;
                let index = p.count("shape_index", 0)?;
                let mut mesh = super::read_serialized(&file, index)?;
                let dropped = mesh.remove_degenerate_triangles();
                if dropped > 0 {
                    self.warnings
                        .push(format!("{}: mesh {index}: dropped {dropped} zero-area triangles", file.display()));
                }
                if mesh.triangles.is_empty() {
                    return Err(FormatError::malformed(&file, format!("mesh {index}"), "has no triangles"));
                }
                p.ignore(&["max_smooth_angle"]);
                meshes.push(mesh);
            }
            "rectangle" => meshes.push(rectangle()),
            "cube" => meshes.push(cube()),
            "disk" => meshes.push(disk()),
            "cylinder" => {
                let radius = p.float("radius", 1.0)?;
                let p0 = p.vector("p0")?.unwrap_or(DVec3::ZERO);
                let p1 = p.vector("p1")?.unwrap_or(DVec3::Z);
                let d = p1 - p0;
                let length = d.length();
                if !(length > 0.0 && radius > 0.0) {
                    return Err(el.loc.error("cylinder: p0 equals p1 or radius <= 0"));
                }
                let n = d / length;
                let s = any_perpendicular(n);
                let t = n.cross(s);
                let frame = DMat4::from_cols(s.extend(0.0), t.extend(0.0), n.extend(0.0), p0.extend(1.0));
                world = to_world * frame * DMat4::from_scale(DVec3::new(radius, radius, length));
                meshes.push(cylinder());
            }
            "sphere" => {
                let centre = p.vector("center")?.unwrap_or(DVec3::ZERO);
                let radius = p.float("radius", 1.0)?;
                if radius <= 0.0 {
                    return Err(el.loc.error(format!("sphere radius {radius} must be > 0")));
                }
                if flip {
                    self.unsupported(&el.loc, "flip_normals on a sphere: glint's spheres face outward")?;
                }
                sphere = Some(Shape::Sphere { centre: centre.as_vec3(), radius: radius as f32 });
            }
            other => {
                self.unsupported(&el.loc, format!("shape '{other}' is not supported by glint"))?;
                return Ok(Vec::new());
            }
        }
        self.finish(&p)?;
        let label = name.clone().unwrap_or_else(|| format!("{} {}", p.plugin, self.scene.objects.len()));
        let material = self.material(label.clone(), bsdf, emission);
        if let Some(shape) = sphere {
            return Ok(vec![Part { name: label, shape, material, world_from_object: world }]);
        }
        let mut parts = Vec::new();
        for mut m in meshes {
            if face_normals {
                m.normals = None;
            }
            if flip {
                for t in &mut m.triangles {
                    t.swap(1, 2);
                }
                if let Some(n) = &mut m.normals {
                    n.iter_mut().for_each(|v| *v = -*v);
                }
            }
            if m.name.is_empty() {
                m.name.clone_from(&label);
            }
            self.scene.meshes.push(Arc::new(m));
            let shape = Shape::Mesh(self.scene.meshes.len() - 1);
            parts.push(Part { name: label.clone(), shape, material, world_from_object: world });
        }
        Ok(parts)
    }

    /// A shape's BSDF (Mitsuba's default: diffuse 0.5) and its area emitter's radiance.
    fn shape_appearance(&mut self, p: &Props<'a>) -> Result<(usize, Option<Tex<Rgb>>), FormatError> {
        let bsdfs = p.objects("bsdf");
        if bsdfs.len() > 1 {
            return Err(p.loc().error("a shape has one BSDF"));
        }
        let bsdf = match bsdfs.first() {
            Some((_, b)) => self.bsdf(b)?,
            None => self.default_bsdf(),
        };
        let mut emission = None;
        for (_, e) in p.objects("emitter") {
            emission = Some(self.area_emitter(e)?);
        }
        Ok((bsdf, emission))
    }

    fn default_bsdf(&mut self) -> usize {
        *self.bsdf_cache.entry(0).or_insert_with(|| {
            self.scene.bsdfs.push(BsdfKind::Diffuse { reflectance: Tex::Value(Rgb::splat(0.5)) });
            self.scene.bsdfs.len() - 1
        })
    }
}

/// A mesh from Mitsuba-uv vertices.
fn mesh(name: &str, vertices: &[(Vec3, Vec3, Vec2)], triangles: Vec<[u32; 3]>) -> Mesh {
    Mesh {
        name: name.into(),
        positions: vertices.iter().map(|v| v.0).collect(),
        normals: Some(vertices.iter().map(|v| v.1).collect()),
        uvs: Some(vertices.iter().map(|v| Vec2::new(v.2.x, 1.0 - v.2.y)).collect()),
        triangles,
        triangle_materials: None,
        attributes: Vec::new(),
    }
}

/// Mitsuba's rectangle: [−1, 1]² in z = 0, normal +z, uv = (x + 1, y + 1)/2.
pub(super) fn rectangle() -> Mesh {
    let v = |x: f32, y: f32| (Vec3::new(x, y, 0.0), Vec3::Z, Vec2::new((x + 1.0) * 0.5, (y + 1.0) * 0.5));
    mesh("rectangle", &[v(-1.0, -1.0), v(1.0, -1.0), v(1.0, 1.0), v(-1.0, 1.0)], vec![[0, 1, 2], [2, 3, 0]])
}

/// Mitsuba's cube (src/shapes/cube.cpp): [−1, 1]³, four vertices per face with the face's
/// normal and uvs (0,1) (1,1) (1,0) (0,0).
pub(super) fn cube() -> Mesh {
    const NORMALS: [[f32; 3]; 6] =
        [[0.0, -1.0, 0.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]];
    const CORNER: [u32; 24] = [1, 5, 4, 0, 3, 2, 6, 7, 1, 3, 7, 5, 5, 7, 6, 4, 4, 6, 2, 0, 3, 1, 0, 2];
    const UV: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
    let corner = |c: u32| {
        Vec3::new(
            if c & 1 != 0 { 1.0 } else { -1.0 },
            if c & 2 != 0 { 1.0 } else { -1.0 },
            if c & 4 != 0 { 1.0 } else { -1.0 },
        )
    };
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for s in 0..6u32 {
        for k in 0..4 {
            vertices.push((
                corner(CORNER[(4 * s + k) as usize]),
                Vec3::from_array(NORMALS[s as usize]),
                Vec2::from_array(UV[k as usize]),
            ));
        }
        let v = 4 * s;
        triangles.push([v, v + 1, v + 2]);
        triangles.push([v + 3, v, v + 2]);
    }
    mesh("cube", &vertices, triangles)
}

/// Mitsuba's disk: radius 1 in z = 0, normal +z, uv = (r, φ/2π); a ring of wedges whose
/// centre vertex is repeated per wedge (its v differs) and whose seam is doubled.
pub(super) fn disk() -> Mesh {
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for i in 0..SEGMENTS {
        let (v0, v1) = (i as f32 / SEGMENTS as f32, (i + 1) as f32 / SEGMENTS as f32);
        let rim = |v: f32| {
            let (s, c) = (v * TAU).sin_cos();
            (Vec3::new(c, s, 0.0), Vec3::Z, Vec2::new(1.0, v))
        };
        let base = vertices.len() as u32;
        vertices.push((Vec3::ZERO, Vec3::Z, Vec2::new(0.0, 0.5 * (v0 + v1))));
        vertices.push(rim(v0));
        vertices.push(rim(v1));
        triangles.push([base, base + 1, base + 2]);
    }
    mesh("disk", &vertices, triangles)
}

/// Mitsuba's cylinder: radius 1 around z from 0 to 1, open, normals outward, uv = (φ/2π, z).
pub(super) fn cylinder() -> Mesh {
    let mut vertices = Vec::new();
    for i in 0..=SEGMENTS {
        let u = i as f32 / SEGMENTS as f32;
        let (s, c) = (u * TAU).sin_cos();
        let n = Vec3::new(c, s, 0.0);
        vertices.push((n, n, Vec2::new(u, 0.0)));
        vertices.push((n + Vec3::Z, n, Vec2::new(u, 1.0)));
    }
    let triangles = (0..SEGMENTS)
        .flat_map(|i| {
            let (a, b) = (2 * i, 2 * i + 2);
            [[a, b, b + 1], [a, b + 1, a + 1]]
        })
        .collect();
    mesh("cylinder", &vertices, triangles)
}
