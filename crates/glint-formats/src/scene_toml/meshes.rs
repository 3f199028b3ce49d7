//! Mesh objects' geometry: inline `vertices` and `triangles` → a [`Mesh`], or a model file
//! (OBJ, PLY, glTF; see [`crate::model`]) → its meshes, with their materials and textures added
//! to the scene.
//!
//! Called by [`super::objects`] for `type = "mesh"`. A model file is read once per scene and
//! `shading`; its meshes (and, unless the object names its own material, its materials,
//! renamed `file/material`) enter the scene once and are shared by every object that uses the
//! file the same way.

use super::Builder;
use super::defs::{ObjectDef, Shading};
use crate::error::FormatError;
use crate::model;
use glint_core::Vec3;
use glint_scene::{Material, Mesh};
use std::rc::Rc;
use std::sync::Arc;
use toml::Spanned;

impl Builder<'_> {
    pub(super) fn inline_mesh(
        &mut self,
        o: &Spanned<ObjectDef>,
        name: &str,
        shading: Option<Shading>,
    ) -> Result<Mesh, FormatError> {
        let def = o.get_ref();
        let (Some(vertices), Some(triangles)) = (&def.vertices, &def.triangles) else {
            return Err(self.missing(
                &o.span(),
                format!("mesh '{name}' needs `path` (a model file) or `vertices` and `triangles`"),
            ));
        };
        let positions: Vec<Vec3> = vertices.get_ref().iter().map(|v| v.0).collect();
        let n = positions.len();
        let mut tris = Vec::with_capacity(triangles.get_ref().len());
        for t in triangles.get_ref() {
            let tri = *t.get_ref();
            if let Some(&bad) = tri.iter().find(|&&i| i as usize >= n) {
                return Err(
                    self.err(&t.span(), format!("vertex index {bad} is out of range (the mesh has {n} vertices)"))
                );
            }
            tris.push(tri);
        }
        let normals = match &def.normals {
            Some(ns) => {
                if ns.get_ref().len() != n {
                    return Err(self.err(&ns.span(), format!("{} normals for {n} vertices", ns.get_ref().len())));
                }
                let mut out = Vec::with_capacity(n);
                for (i, v) in ns.get_ref().iter().enumerate() {
                    match v.0.try_normalize() {
                        Some(u) => out.push(u),
                        None => return Err(self.err(&ns.span(), format!("normal {i} has zero length"))),
                    }
                }
                Some(out)
            }
            None => None,
        };
        let uvs = match &def.uvs {
            Some(us) => {
                if us.get_ref().len() != n {
                    return Err(self.err(&us.span(), format!("{} uvs for {n} vertices", us.get_ref().len())));
                }
                Some(us.get_ref().iter().map(|v| v.0).collect())
            }
            None => None,
        };
        let mut mesh = Mesh {
            name: name.to_string(),
            positions,
            normals,
            uvs,
            triangles: tris,
            triangle_materials: None,
            attributes: Vec::new(),
        };
        if let Some(message) = mesh.out_of_range_message() {
            return Err(self.err(&triangles.span(), format!("mesh '{name}': {message}")));
        }
        let copies = mesh.remove_duplicate_triangles();
        if copies > 0 {
            let place = self.place(&triangles.span());
            self.warnings.push(format!("{place}: mesh '{name}': dropped {copies} duplicate triangles"));
        }
        let dropped = mesh.remove_degenerate_triangles();
        if mesh.triangles.is_empty() {
            return Err(self.err(&triangles.span(), format!("mesh '{name}': every triangle has zero area")));
        }
        if dropped > 0 {
            let place = self.place(&triangles.span());
            self.warnings.push(format!("{place}: mesh '{name}': dropped {dropped} zero-area triangles"));
        }
        model::apply_shading(&mut mesh, shading);
        Ok(mesh)
    }

    /// The scene meshes of a model file, loading it (and its materials and textures) once.
    pub(super) fn file_meshes(
        &mut self,
        path: &Spanned<String>,
        shading: Option<Shading>,
        overridden: bool,
    ) -> Result<Vec<usize>, FormatError> {
        let file = self.resolve(path, "path")?;
        if model::ModelFormat::from_extension(&model::extension(&file)).is_none() {
            return Err(self.err(
                &path.span(),
                format!("`{}`: glint reads meshes from .obj, .ply, .gltf and .glb files", path.get_ref()),
            ));
        }
        let key = std::fs::canonicalize(&file).unwrap_or_else(|_| file.clone());
        if let Some(ids) = self.meshes.get(&(key.clone(), shading, overridden)) {
            return Ok(ids.clone());
        }
        let model = match self.models.get(&(key.clone(), shading)) {
            Some(m) => m.clone(),
            None => {
                let mut m = model::load_model(&file)?;
                self.warnings.append(&mut m.warnings);
                for mesh in &mut m.meshes {
                    model::apply_shading(mesh, shading);
                }
                let m = Rc::new(m);
                self.models.insert((key.clone(), shading), m.clone());
                m
            }
        };
        let (material_base, texture_base) = (self.scene.materials.len() as u32, self.scene.textures.len());
        if !overridden && model.meshes.iter().any(|m| m.triangle_materials.is_some()) {
            let bsdf_base = self.scene.bsdfs.len();
            self.scene.textures.extend(model.textures.iter().cloned());
            self.scene.bsdfs.extend(model.bsdfs.iter().map(|b| b.remapped(|i| i + bsdf_base, |t| t + texture_base)));
            let stem = file.file_name().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
            self.scene.materials.extend(model.materials.iter().map(|m| Material {
                name: format!("{stem}/{}", m.name),
                texture: m.texture.map(|t| t + texture_base),
                emission_texture: m.emission_texture.map(|t| t + texture_base),
                bsdf: m.bsdf.map(|b| b + bsdf_base),
                ..m.clone()
            }));
        }
        let mut ids = Vec::with_capacity(model.meshes.len());
        for mesh in &model.meshes {
            let mut mesh = mesh.clone();
            mesh.triangle_materials = match (overridden, mesh.triangle_materials.take()) {
                (false, Some(tm)) => Some(tm.into_iter().map(|m| m + material_base).collect()),
                _ => None,
            };
            self.scene.meshes.push(Arc::new(mesh));
            ids.push(self.scene.meshes.len() - 1);
        }
        self.meshes.insert((key, shading, overridden), ids.clone());
        Ok(ids)
    }
}
