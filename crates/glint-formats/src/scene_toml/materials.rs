//! `[[texture]]` and `[[material]]` → the scene's textures and materials, by name.
//!
//! Read after the sky and before the lights and objects, which name materials; a material
//! names a texture, so textures come first (their tables may stand anywhere in the file: serde
//! gathers each array of tables before the builder runs). Image textures are read once per
//! file, however many textures use them.

use super::Builder;
use super::defs::{MaterialDef, TextureDef, TextureKind};
use super::values::V3;
use crate::error::FormatError;
use crate::texture_file;
use glint_core::Vec2;
use glint_scene::{Material, Sampler, Texture};
use std::sync::Arc;
use toml::Spanned;

impl Builder<'_> {
    pub(super) fn texture(&mut self, t: &Spanned<TextureDef>) -> Result<(), FormatError> {
        let def = t.get_ref();
        let name = def.name.get_ref();
        if self.texture_names.contains_key(name) {
            return Err(self.err(&def.name.span(), format!("a texture named '{name}' is already defined")));
        }
        let keys = def.keys();
        let texture = match def.kind.get_ref() {
            TextureKind::Checker => {
                self.disallow(&keys, &["size", "even", "odd"], "a checker texture")?;
                let size = match &def.size {
                    Some(s) => {
                        let v = s.get_ref().0;
                        if v <= 0.0 {
                            return Err(self.err(&s.span(), format!("checker `size` = {v} must be > 0")));
                        }
                        v
                    }
                    None => 1.0,
                };
                let colour = |c: &Option<Spanned<V3>>, key: &str| match c {
                    Some(c) => self.colour(c, key),
                    None => Err(self.missing(&t.span(), format!("a checker texture needs `{key}`"))),
                };
                Texture::Checker { size, even: colour(&def.even, "even")?, odd: colour(&def.odd, "odd")? }
            }
            TextureKind::Image => {
                self.disallow(&keys, &["path", "scale"], "an image texture")?;
                let Some(path) = &def.path else {
                    return Err(self.missing(&t.span(), "an image texture needs `path`"));
                };
                let file = self.resolve(path, "path")?;
                let image = match self.images.get(&file) {
                    Some(i) => i.clone(),
                    None => {
                        let i = Arc::new(texture_file::read_texture_image(&file)?);
                        self.images.insert(file, i.clone());
                        i
                    }
                };
                let scale = match &def.scale {
                    Some(s) => {
                        let v = s.get_ref().0;
                        if v.x == 0.0 || v.y == 0.0 {
                            return Err(self.err(&s.span(), "texture `scale` must not be 0"));
                        }
                        v
                    }
                    None => Vec2::ONE,
                };
                Texture::Image { image, scale, sampler: Sampler::default() }
            }
        };
        self.texture_names.insert(name.clone(), self.scene.textures.len());
        self.scene.textures.push(texture);
        Ok(())
    }

    pub(super) fn material(&mut self, m: &Spanned<MaterialDef>) -> Result<(), FormatError> {
        let def = m.get_ref();
        let name = def.name.get_ref();
        if self.material_names.contains_key(name) {
            return Err(self.err(&def.name.span(), format!("a material named '{name}' is already defined")));
        }
        let mut mat = Material { name: name.clone(), ..Material::default() };
        if let Some(c) = &def.colour {
            mat.colour = self.colour(c, "colour")?;
        }
        if let Some(t) = &def.texture {
            let Some(&i) = self.texture_names.get(t.get_ref()) else {
                return Err(
                    self.err(&t.span(), format!("no texture named '{}' (define it with [[texture]])", t.get_ref()))
                );
            };
            mat.texture = Some(i);
        }
        for (v, slot, key) in [
            (&def.ambient, &mut mat.ambient, "ambient"),
            (&def.diffuse, &mut mat.diffuse, "diffuse"),
            (&def.specular, &mut mat.specular, "specular"),
            (&def.shininess, &mut mat.shininess, "shininess"),
        ] {
            if let Some(v) = v {
                *slot = self.non_negative(v, key)?;
            }
        }
        for (v, slot, key) in [
            (&def.reflectivity, &mut mat.reflectivity, "reflectivity"),
            (&def.transparency, &mut mat.transparency, "transparency"),
        ] {
            if let Some(v) = v {
                *slot = self.unit_interval(v, key)?;
            }
        }
        if let Some(ior) = &def.ior {
            let v = ior.get_ref().0;
            if !(1.0..=10.0).contains(&v) {
                return Err(self.err(&ior.span(), format!("`ior` = {v} must be in [1, 10]")));
            }
            mat.ior = v;
        }
        if let Some(f) = def.fresnel {
            mat.fresnel = f;
        }
        if let Some(f0) = &def.f0 {
            let v = f0.get_ref().0;
            if v.min_element() < 0.0 || v.max_element() > 1.0 {
                return Err(
                    self.err(&f0.span(), "`f0` must be in [0, 1] (0.04 for dielectrics, a metal's reflectance)")
                );
            }
            if mat.reflectivity > 0.0 || mat.transparency > 0.0 {
                return Err(self.err(
                    &f0.span(),
                    "`f0` (Fresnel reflection) excludes `reflectivity` and `transparency`: give one or the other",
                ));
            }
            mat.reflection_f0 = Some(v);
        }
        if let Some(e) = &def.emission {
            mat.emission = self.colour(e, "emission")?;
        }
        mat.two_sided = def.two_sided.unwrap_or(false);
        self.material_names.insert(name.clone(), self.scene.materials.len());
        self.scene.materials.push(mat);
        Ok(())
    }
}
