//! Wavefront OBJ (+ MTL, see [`mtl`]): glint's own parser.
//!
//! Written here rather than taken from `tobj` for two reasons: every error names its line
//! (`line 12: vertex index 40 is out of range`), and it is fast (one pass over the bytes, no
//! intermediate strings; the Sponza atrium reads in tens of milliseconds).
//!
//! The whole file becomes one mesh, with per-triangle materials when the file uses any (one
//! BVH per file; groups and objects are not kept apart). Corners are welded on their
//! (position, uv, normal) triple. Polygons are split into fans. Without `vn` the mesh is shaded
//! flat (the file's author gave no normals); corners lacking a normal in a file that has some
//! get smooth normals from the faces around them. A missing .mtl is a warning (the faces get the
//! default material), an unknown statement or a malformed number is an error.

mod mtl;

use crate::error::FormatError;
use crate::model::{self, Model, file_name};
use glint_core::{Vec2, Vec3};
use glint_scene::{Material, Mesh};
use mtl::MaterialLibrary;
use std::collections::{BTreeSet, HashMap};
use std::hash::{BuildHasherDefault, Hasher};
use std::path::Path;

/// Statements of the OBJ specification that glint reads past (free-form geometry, display
/// attributes, lines, points, smoothing groups).
const SKIPPED: [&str; 30] = [
    "s",
    "l",
    "p",
    "vp",
    "mg",
    "cstype",
    "deg",
    "bmat",
    "step",
    "curv",
    "curv2",
    "surf",
    "parm",
    "trim",
    "hole",
    "scrv",
    "sp",
    "end",
    "con",
    "bevel",
    "c_interp",
    "d_interp",
    "lod",
    "usemap",
    "maplib",
    "shadow_obj",
    "trace_obj",
    "ctech",
    "stech",
    "call",
];

const NONE: u32 = u32::MAX;

/// Reads an OBJ file and the MTL files it names.
pub(crate) fn load(path: &Path) -> Result<Model, FormatError> {
    let data = crate::files::read_sniffed(path, None, crate::files::text("an OBJ file"))?;
    let mut model = parse(path, &data)?;
    model::finish_meshes(path, &mut model.meshes, &mut model.warnings)?;
    Ok(model)
}

/// A multiplicative hash for the (position, uv, normal) index triples that weld corners.
#[derive(Default)]
struct TripleHasher(u64);

impl Hasher for TripleHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u32(b as u32);
        }
    }

    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.0 = (self.0.rotate_left(26) ^ i as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// The mesh being assembled.
#[derive(Default)]
struct Builder {
    positions: Vec<Vec3>,
    texcoords: Vec<Vec2>,
    normals: Vec<Vec3>,
    /// Output vertex of each position index, for corners with neither uv nor normal.
    by_position: Vec<u32>,
    by_triple: HashMap<(u32, u32, u32), u32, BuildHasherDefault<TripleHasher>>,
    out_positions: Vec<Vec3>,
    out_uvs: Vec<Vec2>,
    out_normals: Vec<Vec3>,
    any_uv: bool,
    any_normal: bool,
    /// Some corner lacks a uv / a normal.
    missing_uv: bool,
    missing_normal: bool,
    triangles: Vec<[u32; 3]>,
    triangle_materials: Vec<u32>,
}

impl Builder {
    fn vertex(&mut self, v: u32, vt: u32, vn: u32) -> u32 {
        if vt == NONE && vn == NONE {
            let slot = self.by_position[v as usize];
            if slot != NONE {
                return slot;
            }
        } else if let Some(&i) = self.by_triple.get(&(v, vt, vn)) {
            return i;
        }
        let index = self.out_positions.len() as u32;
        self.out_positions.push(self.positions[v as usize]);
        self.out_uvs.push(if vt == NONE { Vec2::ZERO } else { self.texcoords[vt as usize] });
        self.out_normals.push(if vn == NONE { Vec3::ZERO } else { self.normals[vn as usize] });
        self.any_uv |= vt != NONE;
        self.any_normal |= vn != NONE;
        self.missing_uv |= vt == NONE;
        self.missing_normal |= vn == NONE;
        if vt == NONE && vn == NONE {
            self.by_position[v as usize] = index;
        } else {
            self.by_triple.insert((v, vt, vn), index);
        }
        index
    }
}

/// Resolves a 1-based (or negative, relative) OBJ index against `count` elements so far.
fn resolve(text: &[u8], count: usize) -> Option<u32> {
    let s = std::str::from_utf8(text).ok()?;
    let i: i64 = s.parse().ok()?;
    let r = if i > 0 { i - 1 } else { count as i64 + i };
    if i == 0 || r < 0 || r >= count as i64 { None } else { Some(r as u32) }
}

fn parse_f32(w: &[u8]) -> Option<f32> {
    std::str::from_utf8(w).ok()?.parse().ok()
}

/// Parses OBJ bytes (`path` names them in messages and locates the MTL files).
fn parse(path: &Path, data: &[u8]) -> Result<Model, FormatError> {
    let mut parser = Parser::new(path);
    let mut joined = Vec::new();
    let mut lines = data.split(|&c| c == b'\n').enumerate();
    while let Some((i, raw)) = lines.next() {
        let line = logical_line(raw, &mut lines, &mut joined);
        parser.statement(&At { path, line: i + 1 }, line)?;
    }
    parser.finish()
}

/// `raw` without its `\r`, joined with the lines that follow while it ends in a backslash (a
/// trailing backslash continues the statement on the next line).
fn logical_line<'a, 'b>(
    raw: &'a [u8],
    rest: &mut impl Iterator<Item = (usize, &'a [u8])>,
    joined: &'b mut Vec<u8>,
) -> &'b [u8]
where
    'a: 'b,
{
    let line = raw.strip_suffix(b"\r").unwrap_or(raw);
    if !line.ends_with(b"\\") {
        return line;
    }
    joined.clear();
    joined.extend_from_slice(&line[..line.len() - 1]);
    for (_, next) in rest {
        let next = next.strip_suffix(b"\r").unwrap_or(next);
        joined.push(b' ');
        match next.strip_suffix(b"\\") {
            Some(more) => joined.extend_from_slice(more),
            None => {
                joined.extend_from_slice(next);
                break;
            }
        }
    }
    joined
}

/// Where a statement starts, for its error messages.
struct At<'a> {
    path: &'a Path,
    line: usize,
}

impl At<'_> {
    fn err(&self, message: String) -> FormatError {
        FormatError::malformed(self.path, format!("line {}", self.line), message)
    }

    fn not_a_number(&self, w: &[u8]) -> FormatError {
        self.err(format!("`{}` is not a number", String::from_utf8_lossy(w)))
    }
}

/// One pass over an OBJ file: the mesh so far, the materials, and what to warn about.
struct Parser<'a> {
    path: &'a Path,
    b: Builder,
    warnings: Vec<String>,
    library: MaterialLibrary,
    /// A `usemtl` was met: every triangle gets a material from then on.
    uses_materials: bool,
    current_material: u32,
    /// The default material's index in `library`, once some face needs it.
    default_index: u32,
    /// Materials named by `usemtl` but defined in no library.
    undefined: BTreeSet<String>,
    /// Statements of the specification that glint reads past.
    skipped: BTreeSet<String>,
    /// The current face's output vertices (kept to reuse its allocation).
    corners: Vec<u32>,
}

impl<'a> Parser<'a> {
    fn new(path: &'a Path) -> Self {
        Self {
            path,
            b: Builder::default(),
            warnings: Vec::new(),
            library: MaterialLibrary::default(),
            uses_materials: false,
            current_material: NONE,
            default_index: NONE,
            undefined: BTreeSet::new(),
            skipped: BTreeSet::new(),
            corners: Vec::with_capacity(8),
        }
    }

    /// One logical line of the file.
    fn statement(&mut self, at: &At, line: &[u8]) -> Result<(), FormatError> {
        let mut words = line.split(|c| c.is_ascii_whitespace()).filter(|w| !w.is_empty());
        let Some(keyword) = words.next() else { return Ok(()) };
        if keyword[0] == b'#' {
            return Ok(());
        }
        match keyword {
            b"v" | b"vn" => self.vector(at, keyword, words),
            b"vt" => self.texcoord(at, words),
            b"f" | b"fo" => self.face(at, words),
            b"mtllib" => self.mtllib(at, &rest_after(line, keyword)),
            b"usemtl" => {
                self.usemtl(rest_after(line, keyword).trim());
                Ok(())
            }
            b"o" | b"g" => Ok(()),
            other => {
                let k = String::from_utf8_lossy(other).into_owned();
                if !SKIPPED.contains(&k.as_str()) {
                    return Err(at.err(format!("unknown statement `{k}`")));
                }
                self.skipped.insert(k);
                Ok(())
            }
        }
    }

    /// `v x y z` (a position) or `vn x y z` (a normal, normalised; zero if it has no length).
    fn vector<'w>(
        &mut self,
        at: &At,
        keyword: &[u8],
        mut words: impl Iterator<Item = &'w [u8]>,
    ) -> Result<(), FormatError> {
        let mut xyz = [0.0f32; 3];
        for (k, c) in xyz.iter_mut().enumerate() {
            let Some(w) = words.next() else {
                return Err(at.err(format!("`{}` needs 3 coordinates, found {k}", String::from_utf8_lossy(keyword))));
            };
            *c = parse_f32(w).ok_or_else(|| at.not_a_number(w))?;
            if !c.is_finite() {
                return Err(at.err(format!("coordinate `{}` is not finite", String::from_utf8_lossy(w))));
            }
        }
        // `v x y z w` and `v x y z r g b` carry extra numbers glint does not use; they
        // must still be numbers.
        for w in words {
            parse_f32(w).ok_or_else(|| at.not_a_number(w))?;
        }
        if keyword == b"v" {
            self.b.positions.push(Vec3::from_array(xyz));
            self.b.by_position.push(NONE);
        } else {
            let n = Vec3::from_array(xyz);
            self.b.normals.push(n.try_normalize().unwrap_or(Vec3::ZERO));
        }
        Ok(())
    }

    /// `vt u [v [w]]`: glint keeps u and v.
    fn texcoord<'w>(&mut self, at: &At, words: impl Iterator<Item = &'w [u8]>) -> Result<(), FormatError> {
        let mut uv = [0.0f32; 2];
        let mut count = 0;
        for w in words {
            let v = parse_f32(w).ok_or_else(|| at.not_a_number(w))?;
            if !v.is_finite() {
                return Err(at.err(format!("texture coordinate `{v}` is not finite")));
            }
            if count < 2 {
                uv[count] = v;
            }
            count += 1;
        }
        if count == 0 || count > 3 {
            return Err(at.err(format!("`vt` needs 1 to 3 numbers, found {count}")));
        }
        self.b.texcoords.push(Vec2::from_array(uv));
        Ok(())
    }

    /// `f v/vt/vn …`: a polygon, split into a fan of triangles.
    fn face<'w>(&mut self, at: &At, words: impl Iterator<Item = &'w [u8]>) -> Result<(), FormatError> {
        self.corners.clear();
        for w in words {
            let corner = self.corner(at, w)?;
            self.corners.push(corner);
        }
        let corners = &self.corners;
        if corners.len() < 3 {
            return Err(at.err(format!("a face needs at least 3 corners, found {}", corners.len())));
        }
        let before = self.b.triangles.len();
        model::split_polygon(corners, &mut self.b.triangles);
        if self.uses_materials {
            let added = self.b.triangles.len() - before;
            self.b.triangle_materials.extend(std::iter::repeat_n(self.current_material, added));
        }
        Ok(())
    }

    /// One face corner `v`, `v/vt`, `v//vn` or `v/vt/vn`, as an output vertex.
    fn corner(&mut self, at: &At, w: &[u8]) -> Result<u32, FormatError> {
        let b = &mut self.b;
        let mut parts = w.split(|&c| c == b'/');
        let bad = |what: &str, count: usize| {
            at.err(format!(
                "`{}`: {what} index is not a number in 1..={count} (or a negative relative index)",
                String::from_utf8_lossy(w)
            ))
        };
        let v = parts.next().unwrap_or(b"");
        let v = resolve(v, b.positions.len()).ok_or_else(|| bad("vertex", b.positions.len()))?;
        let vt = match parts.next() {
            None | Some(b"") => NONE,
            Some(t) => resolve(t, b.texcoords.len()).ok_or_else(|| bad("texture", b.texcoords.len()))?,
        };
        let vn = match parts.next() {
            None | Some(b"") => NONE,
            Some(n) => resolve(n, b.normals.len()).ok_or_else(|| bad("normal", b.normals.len()))?,
        };
        if parts.next().is_some() {
            return Err(
                at.err(format!("`{}` is not a face corner (v, v/vt, v//vn or v/vt/vn)", String::from_utf8_lossy(w)))
            );
        }
        Ok(b.vertex(v, vt, vn))
    }

    /// `mtllib a.mtl [b.mtl …]`, read now; a missing file is a warning.
    fn mtllib(&mut self, at: &At, rest: &str) -> Result<(), FormatError> {
        let files: Vec<&str> = rest.split_ascii_whitespace().collect();
        if files.is_empty() {
            return Err(at.err("`mtllib` names no file".into()));
        }
        let dir = self.path.parent().unwrap_or(Path::new(""));
        // File names with spaces: try the whole rest of the line first.
        let whole = rest.trim();
        let names: Vec<&str> = if files.len() > 1 && dir.join(whole).exists() { vec![whole] } else { files };
        for f in names {
            let mtl_path = dir.join(f);
            let field = format!("line {} mtllib", at.line);
            let by = Some(crate::files::Referrer::new(self.path, &field));
            match crate::files::read_sniffed(&mtl_path, by, crate::files::text("an MTL file")) {
                Ok(text) => self.library.read(&mtl_path, &text, &mut self.warnings)?,
                Err(FormatError::MissingFile { .. }) => self.warnings.push(format!(
                    "{}:{}: material library {} not found; its materials are replaced by the default material",
                    file_name(self.path),
                    at.line,
                    mtl_path.display()
                )),
                Err(e) => return Err(e),
            }
        }
        Ok(())
    }

    /// `usemtl name`: the material of the faces that follow (the default one if no library
    /// defines `name`).
    fn usemtl(&mut self, m: &str) {
        if !self.uses_materials {
            // Faces before the first `usemtl` get the default material.
            self.uses_materials = true;
            let d = self.default_material();
            self.b.triangle_materials = vec![d; self.b.triangles.len()];
        }
        self.current_material = match self.library.by_name.get(m) {
            Some(&i) => i as u32,
            None => {
                self.undefined.insert(m.to_string());
                self.default_material()
            }
        };
    }

    fn default_material(&mut self) -> u32 {
        if self.default_index == NONE {
            self.default_index = self.library.materials.len() as u32;
            self.library.materials.push(Material::default());
        }
        self.default_index
    }

    /// The model, after warning once about what was skipped or left undefined.
    fn finish(mut self) -> Result<Model, FormatError> {
        let name = file_name(self.path);
        self.skipped.remove("s");
        if !self.skipped.is_empty() {
            let list: Vec<String> = self.skipped.into_iter().collect();
            self.warnings.push(format!("{name}: ignored statements glint does not render: {}", list.join(", ")));
        }
        if !self.undefined.is_empty() {
            let list: Vec<String> = self.undefined.into_iter().collect();
            self.warnings.push(format!(
                "{name}: materials not defined in any material library (the default is used): {}",
                list.join(", ")
            ));
        }
        if self.b.out_positions.len() > NONE as usize {
            return Err(FormatError::limits(self.path, "more vertices than glint can index"));
        }
        let mesh = assemble(self.path, self.b);
        let meshes = if mesh.triangles.is_empty() { Vec::new() } else { vec![mesh] };
        Ok(Model {
            meshes,
            materials: self.library.materials,
            bsdfs: Vec::new(),
            textures: self.library.textures,
            warnings: self.warnings,
        })
    }
}

/// The text of `line` after its first word `keyword`.
fn rest_after<'a>(line: &'a [u8], keyword: &[u8]) -> std::borrow::Cow<'a, str> {
    let start = line.windows(keyword.len()).position(|w| w == keyword).map_or(line.len(), |p| p + keyword.len());
    String::from_utf8_lossy(&line[start..])
}

/// The final mesh: attributes only where the file gave them; normals missing at some corners
/// are filled with the area-weighted normals of the faces around them.
fn assemble(path: &Path, b: Builder) -> Mesh {
    let uvs = b.any_uv.then_some(b.out_uvs);
    let normals = b.any_normal.then(|| {
        let mut normals = b.out_normals;
        if b.missing_normal || normals.contains(&Vec3::ZERO) {
            let mut sum = vec![Vec3::ZERO; normals.len()];
            for t in &b.triangles {
                let [p0, p1, p2] = t.map(|i| b.out_positions[i as usize]);
                let face = (p1 - p0).cross(p2 - p0);
                for &i in t {
                    sum[i as usize] += face;
                }
            }
            for (n, s) in normals.iter_mut().zip(sum) {
                if *n == Vec3::ZERO {
                    *n = s.normalize_or(Vec3::Y);
                }
            }
        }
        normals
    });
    let triangle_materials = (!b.triangle_materials.is_empty()).then_some(b.triangle_materials);
    Mesh {
        name: path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned()),
        positions: b.out_positions,
        normals,
        uvs,
        triangles: b.triangles,
        triangle_materials,
        attributes: Vec::new(),
    }
}

#[cfg(test)]
mod tests;
