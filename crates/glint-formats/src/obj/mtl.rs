//! MTL material libraries (the companions of OBJ files) → [`Material`]s and image textures.
//!
//! Mapping to glint's Phong parameters:
//! - `Kd` → colour (diffuse weight 1: the file's Kd is the albedo); `map_Kd` → image texture
//!   multiplying it (`-s u v` → texture scale; other options are read and ignored);
//! - `Ks` → specular weight (its luminance); `Ns` → shininess;
//! - `Ka` → ambient weight 0.2 × luminance(Ka): exporters write `Ka 1 1 1` routinely, meant for
//!   OpenGL's fixed-function model whose global ambient light is 0.2;
//! - `d` (opacity) or else `Tr` (transparency) → transparency; `Ni` → ior (clamped to [1, 10]);
//! - `Ke` → emission; when there is no `Ke` but `Ka` exceeds 1 (the classic Cornell box stores
//!   its light's radiance that way), Ka is taken as the emission, with a warning;
//! - `illum` 3, 5, 6, 7 (ray-traced reflection) → reflectivity = luminance(Ks).
//!
//! Statements glint does not use (other maps, PBR extensions) are ignored with one warning
//! each; a malformed number is an error with its line. A missing texture file is a warning
//! (the material keeps its Kd), because downloaded models often come without their images.

use crate::error::FormatError;
use crate::model::file_name;
use crate::texture_file;
use glint_core::colour::luminance;
use glint_core::{Rgb, Vec2};
use glint_scene::{Material, Sampler, Texture};
use std::collections::{BTreeSet, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Materials of one or more MTL files, and the textures they reference.
#[derive(Debug, Default)]
pub(crate) struct MaterialLibrary {
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub by_name: HashMap<String, usize>,
    /// Texture files already read (several materials often share one).
    texture_files: HashMap<PathBuf, usize>,
}

/// An MTL material as written, before it becomes a glint material.
#[derive(Default)]
struct MtlEntry {
    name: String,
    kd: Option<Rgb>,
    ka: Option<Rgb>,
    ks: Option<Rgb>,
    ke: Option<Rgb>,
    ns: Option<f32>,
    ni: Option<f32>,
    d: Option<f32>,
    tr: Option<f32>,
    illum: Option<u32>,
    map_kd: Option<(String, Vec2, usize)>,
}

/// MTL statements that are valid but that glint does not use.
const IGNORED: [&str; 24] = [
    "Tf",
    "map_Ka",
    "map_Ks",
    "map_Ns",
    "map_d",
    "map_Tr",
    "map_bump",
    "bump",
    "map_Bump",
    "disp",
    "decal",
    "refl",
    "sharpness",
    "map_Ke",
    "Pr",
    "Pm",
    "Ps",
    "Pc",
    "Pcr",
    "aniso",
    "anisor",
    "norm",
    "map_Pr",
    "map_Pm",
];

impl MaterialLibrary {
    /// Reads an MTL file into the library. `text` is its content.
    pub(crate) fn read(&mut self, path: &Path, text: &[u8], warnings: &mut Vec<String>) -> Result<(), FormatError> {
        let mut entries: Vec<MtlEntry> = Vec::new();
        let mut ignored = BTreeSet::new();
        let name = file_name(path);
        for (i, raw) in text.split(|&b| b == b'\n').enumerate() {
            let line_no = i + 1;
            let line = String::from_utf8_lossy(raw);
            let line = line.trim();
            if line.is_empty() || line.starts_with('#') {
                continue;
            }
            let err = |message: String| FormatError::malformed(path, format!("line {line_no}"), message);
            let mut words = line.split_ascii_whitespace();
            let Some(keyword) = words.next() else { continue };
            let args: Vec<&str> = words.collect();
            if keyword == "newmtl" {
                let name = line["newmtl".len()..].trim();
                if name.is_empty() {
                    return Err(err("`newmtl` needs a name".into()));
                }
                entries.push(MtlEntry { name: name.to_string(), ..MtlEntry::default() });
                continue;
            }
            let Some(entry) = entries.last_mut() else {
                return Err(err(format!("`{keyword}` before any `newmtl`")));
            };
            let number = |s: &str| -> Result<f32, FormatError> {
                match s.parse::<f32>() {
                    Ok(v) if v.is_finite() => Ok(v),
                    _ => Err(err(format!("`{s}` is not a finite number (in `{keyword}`)"))),
                }
            };
            let colour = |args: &[&str]| -> Result<Rgb, FormatError> {
                if args.first() == Some(&"spectral") || args.first() == Some(&"xyz") {
                    return Err(err(format!("`{keyword} {}` colours are not supported (use r g b)", args[0])));
                }
                match args {
                    [r] => Ok(Rgb::splat(number(r)?)),
                    [r, g, b] => Ok(Rgb::new(number(r)?, number(g)?, number(b)?)),
                    _ => Err(err(format!("`{keyword}` needs 1 or 3 numbers"))),
                }
            };
            let scalar = |args: &[&str]| -> Result<f32, FormatError> {
                match args {
                    // `d -halo 0.5`: the halo form keeps the factor.
                    [v] | ["-halo", v] => number(v),
                    _ => Err(err(format!("`{keyword}` needs one number"))),
                }
            };
            match keyword {
                "Kd" => entry.kd = Some(colour(&args)?),
                "Ka" => entry.ka = Some(colour(&args)?),
                "Ks" => entry.ks = Some(colour(&args)?),
                "Ke" => entry.ke = Some(colour(&args)?),
                "Ns" => entry.ns = Some(scalar(&args)?),
                "Ni" => entry.ni = Some(scalar(&args)?),
                "d" => entry.d = Some(scalar(&args)?),
                "Tr" => entry.tr = Some(scalar(&args)?),
                "illum" => {
                    let [v] = args.as_slice() else { return Err(err("`illum` needs one integer".into())) };
                    entry.illum = Some(v.parse().map_err(|_| err(format!("`{v}` is not an illumination model")))?);
                }
                "map_Kd" => {
                    let (file, scale) = texture_statement(&args).map_err(err)?;
                    entry.map_kd = Some((file, scale, line_no));
                }
                _ => {
                    ignored.insert(keyword.to_string());
                }
            }
        }
        if !ignored.is_empty() {
            let known: Vec<&str> = ignored.iter().map(String::as_str).filter(|k| IGNORED.contains(k)).collect();
            let unknown: Vec<&str> = ignored.iter().map(String::as_str).filter(|k| !IGNORED.contains(k)).collect();
            if !known.is_empty() {
                warnings.push(format!("{name}: ignored statements glint does not use: {}", known.join(", ")));
            }
            if !unknown.is_empty() {
                warnings.push(format!("{name}: ignored unknown statements: {}", unknown.join(", ")));
            }
        }
        let dir = path.parent().unwrap_or(Path::new(""));
        for e in entries {
            let material = self.material(path, dir, e, warnings)?;
            self.by_name.insert(material.name.clone(), self.materials.len());
            self.materials.push(material);
        }
        Ok(())
    }

    fn material(
        &mut self,
        path: &Path,
        dir: &Path,
        e: MtlEntry,
        warnings: &mut Vec<String>,
    ) -> Result<Material, FormatError> {
        let file = file_name(path);
        let clamp01 = |v: f32| v.clamp(0.0, 1.0);
        let non_negative = |c: Rgb| c.max(Rgb::ZERO);
        let ks = e.ks.map(non_negative);
        let mut m = Material { name: e.name.clone(), diffuse: 1.0, ..Material::default() };
        if let Some(kd) = e.kd {
            m.colour = non_negative(kd);
        }
        if let Some(ka) = e.ka {
            m.ambient = 0.2 * clamp01(luminance(non_negative(ka)));
        }
        if let Some(ks) = ks {
            m.specular = clamp01(luminance(ks));
        }
        if let Some(ns) = e.ns {
            m.shininess = ns.max(0.0);
        }
        if let Some(ni) = e.ni {
            m.ior = ni.clamp(1.0, 10.0);
        }
        m.transparency = match (e.d, e.tr) {
            (Some(d), _) => clamp01(1.0 - d),
            (None, Some(tr)) => clamp01(tr),
            (None, None) => 0.0,
        };
        if matches!(e.illum, Some(3 | 5 | 6 | 7)) {
            m.reflectivity = ks.map_or(0.0, |ks| clamp01(luminance(ks)));
        }
        match (e.ke, e.ka) {
            (Some(ke), _) => m.emission = non_negative(ke),
            (None, Some(ka)) if ka.max_element() > 1.0 => {
                m.emission = non_negative(ka);
                m.ambient = 0.0;
                warnings.push(format!(
                    "{file}: material '{}' has Ka above 1 and no Ke: Ka is read as its emission",
                    e.name
                ));
            }
            _ => {}
        }
        if let Some((name, scale, line)) = e.map_kd {
            let image_path = dir.join(&name);
            m.texture = match self.texture_files.get(&image_path) {
                Some(&t) => Some(t),
                None if !image_path.exists() => {
                    warnings.push(format!(
                        "{file}:{line}: texture {} not found; material '{}' uses its Kd colour",
                        image_path.display(),
                        e.name
                    ));
                    None
                }
                None => {
                    let field = format!("line {line} map_Kd");
                    crate::files::check(&image_path, Some(crate::files::Referrer::new(path, &field)))?;
                    let image = Arc::new(texture_file::read_texture_image(&image_path)?);
                    self.textures.push(Texture::Image { image, scale, sampler: Sampler::default() });
                    self.texture_files.insert(image_path, self.textures.len() - 1);
                    Some(self.textures.len() - 1)
                }
            };
        }
        Ok(m)
    }
}

/// Splits `map_Kd [-option args...] file name` into the file and its `-s` scale.
fn texture_statement(args: &[&str]) -> Result<(String, Vec2), String> {
    let mut scale = Vec2::ONE;
    let mut i = 0;
    while i < args.len() && args[i].starts_with('-') {
        let option = args[i];
        i += 1;
        let fixed = match option {
            "-blendu" | "-blendv" | "-cc" | "-clamp" | "-imfchan" | "-bm" | "-boost" | "-texres" | "-type" => 1,
            "-mm" => 2,
            "-o" | "-s" | "-t" => 0,
            _ => return Err(format!("unknown texture option `{option}`")),
        };
        if fixed > 0 {
            i += fixed;
            continue;
        }
        // -o/-s/-t take one to three numbers.
        let mut values = Vec::new();
        while values.len() < 3 && i < args.len() && i + 1 < args.len() {
            match args[i].parse::<f32>() {
                Ok(v) if v.is_finite() => values.push(v),
                _ => break,
            }
            i += 1;
        }
        if values.is_empty() {
            return Err(format!("`{option}` needs numbers"));
        }
        if option == "-s" {
            let u = values[0];
            let v = values.get(1).copied().unwrap_or(u);
            if u == 0.0 || v == 0.0 {
                return Err("texture scale `-s` must not be 0".into());
            }
            scale = Vec2::new(u, v);
        }
    }
    if i >= args.len() {
        return Err("the texture statement names no file".into());
    }
    Ok((args[i..].join(" "), scale))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<(MaterialLibrary, Vec<String>), FormatError> {
        let mut lib = MaterialLibrary::default();
        let mut warnings = Vec::new();
        lib.read(Path::new("m.mtl"), text.as_bytes(), &mut warnings)?;
        Ok((lib, warnings))
    }

    #[test]
    fn phong_parameters_are_mapped() {
        let (lib, warnings) = read(
            "newmtl glass\nKd 0.5 0.6 0.7\nKs 1 1 1\nNs 200\nNi 1.5\nd 0.1\nillum 7\nmap_Bump n.png\n\
             newmtl lamp\nKa 20 20 20\nKd 1 1 1\n",
        )
        .expect("valid");
        let glass = &lib.materials[lib.by_name["glass"]];
        assert_eq!(glass.colour, Rgb::new(0.5, 0.6, 0.7));
        assert_eq!((glass.specular, glass.shininess, glass.ior), (1.0, 200.0, 1.5));
        assert!((glass.transparency - 0.9).abs() < 1e-6);
        assert_eq!(glass.reflectivity, 1.0);
        let lamp = &lib.materials[lib.by_name["lamp"]];
        assert_eq!(lamp.emission, Rgb::splat(20.0));
        assert_eq!(warnings.len(), 2, "{warnings:?}");
    }

    #[test]
    fn bad_number_is_an_error_with_its_line() {
        let e = read("newmtl a\nKd 1 x 1\n").expect_err("bad number");
        assert!(e.to_string().starts_with("m.mtl: line 2:"), "{e}");
        assert!(read("Kd 1 1 1\n").is_err());
        assert!(read("newmtl a\nNs nan\n").is_err());
    }

    #[test]
    fn texture_options_are_skipped_and_scale_kept() {
        assert_eq!(
            texture_statement(&["-s", "2", "3", "-bm", "1", "my", "tex.png"]),
            Ok(("my tex.png".into(), Vec2::new(2.0, 3.0)))
        );
        assert_eq!(texture_statement(&["tex.png"]), Ok(("tex.png".into(), Vec2::ONE)));
        assert!(texture_statement(&["-s", "2"]).is_err());
        assert!(texture_statement(&["-zz", "a.png"]).is_err());
    }

    #[test]
    fn missing_texture_is_a_warning() {
        let (lib, warnings) = read("newmtl a\nKd 1 0 0\nmap_Kd nothing-here.png\n").expect("valid");
        assert_eq!(lib.materials[0].texture, None);
        assert!(warnings[0].contains("nothing-here.png"), "{warnings:?}");
    }
}
