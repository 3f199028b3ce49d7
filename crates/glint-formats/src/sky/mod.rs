//! Sky images → [`Sky`]: six face files, crosses, strips and lat-long maps (docs/skies.md).
//!
//! [`load_sky`] reads what users have — a folder of six faces named by one of the common
//! schemes (`names`), six files listed explicitly, or one image whose aspect says its layout
//! (`layout`) — as linear RGB through glint-image (PNG/JPEG sRGB-decoded, HDR/EXR as stored),
//! applies the per-face flips and turns a set may need (`transform`), checks that the faces
//! meet at their edges and suggests a fix when they clearly do not (`seam`), and builds the
//! glint-scene map. [`write_sky`] goes the other way for `glint sky convert` (`write`).
//!
//! Sits between glint-image (pixels) and glint-scene (the map and its lookups); it never
//! renders. Errors name the file or folder and what is wrong with it ([`FormatError::Sky`] for
//! layouts and faces); problems glint recovered from are [`LoadedSky::warnings`].

mod layout;
mod names;
mod seam;
mod transform;
mod write;

pub use seam::seam_mismatch;
pub use transform::FaceTransform;
pub use write::{SkyMapRef, SkyWriteOptions, WrittenSky, write_sky};

use crate::error::FormatError;
use glint_core::Rgb;
use glint_image::Image;
use glint_scene::{CubeFace, CubeMap, LatLongMap, Sky, SkyTransform, TextureImage};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Largest face edge or lat-long height glint reads (a 16384² face is already 3 GiB of f32).
pub const MAX_SKY_SIDE: u32 = 16_384;

/// Where a sky comes from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum SkySource {
    /// One image (a cross, a strip or a lat-long map, told apart by its aspect) or a folder of
    /// six faces named by a common scheme.
    Path(PathBuf),
    /// Six face images, in [`CubeFace::ALL`] order (+X, −X, +Y, −Y, +Z, −Z).
    Faces([PathBuf; 6]),
}

/// How to read a sky: face transforms for sets stored in another convention, and where the
/// map sits in the world.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SkyLoadOptions {
    /// Applied to every face of a cube map.
    pub all_faces: FaceTransform,
    /// Applied to single faces ([`CubeFace::ALL`] order), after `all_faces`.
    pub per_face: [FaceTransform; 6],
    /// Turn of the whole sky about +Y, degrees (see [`SkyTransform`]).
    pub rotation_degrees: f32,
    /// Scale of the radiance.
    pub intensity: f32,
    /// Apply the fix the seam check finds (a flip of every face, or a flip or turn of single
    /// faces) instead of only suggesting it (`--sky-fix auto`).
    pub auto_fix: bool,
}

impl Default for SkyLoadOptions {
    fn default() -> Self {
        SkyLoadOptions {
            all_faces: FaceTransform::IDENTITY,
            per_face: [FaceTransform::IDENTITY; 6],
            rotation_degrees: 0.0,
            intensity: 1.0,
            auto_fix: false,
        }
    }
}

impl SkyLoadOptions {
    fn has_face_transforms(&self) -> bool {
        !self.all_faces.is_identity() || self.per_face.iter().any(|t| !t.is_identity())
    }
}

/// How the images of a sky are laid out.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SkyLayout {
    /// Six square images, one per face.
    Faces,
    /// One 4:3 image: +Y above +Z, then −X +Z +X −Z, −Y below +Z.
    HorizontalCross,
    /// One 3:4 image: +Y, then −X +Z +X, −Y, and −Z (turned 180°) below it.
    VerticalCross,
    /// One 6:1 image, faces left to right in [`CubeFace::ALL`] order.
    HorizontalStrip,
    /// One 1:6 image, faces top to bottom in [`CubeFace::ALL`] order.
    VerticalStrip,
    /// One 2:1 equirectangular image.
    LatLong,
}

/// A sky read from files.
#[derive(Clone, Debug)]
pub struct LoadedSky {
    /// [`Sky::CubeMap`] or [`Sky::LatLong`], with the rotation and intensity asked for.
    pub sky: Sky,
    /// The layout the images were in.
    pub layout: SkyLayout,
    /// The image files read (one, or six in [`CubeFace::ALL`] order).
    pub files: Vec<PathBuf>,
    /// What glint worked around or suspects, each starting with the file or folder it is
    /// about (e.g. faces that do not meet at their edges, with the fix that would make them).
    pub warnings: Vec<String>,
}

/// The texels of a sky as read from its files, before a map is built from them (the map
/// stores RGB9E5; these keep the files' f32 values, for exact layout conversions).
#[derive(Clone, Debug)]
pub enum SkyTexels {
    /// Six faces in [`CubeFace::ALL`] order, transforms applied.
    Faces([TextureImage; 6]),
    /// An equirectangular image.
    LatLong(TextureImage),
}

/// [`SkyTexels`] read from files, and where they came from.
#[derive(Clone, Debug)]
pub struct LoadedTexels {
    pub texels: SkyTexels,
    pub layout: SkyLayout,
    pub files: Vec<PathBuf>,
    /// The file or folder errors and warnings name.
    pub about: PathBuf,
    pub warnings: Vec<String>,
}

/// Reads a sky: a folder of six faces, six listed faces, or one image (cross, strip or
/// lat-long, by aspect). Face transforms are applied after slicing, before the cube map is
/// built; they are an error with a lat-long map. Cube maps get a seam check (see
/// [`seam_mismatch`]) whose findings are warnings.
pub fn load_sky(source: &SkySource, options: &SkyLoadOptions) -> Result<LoadedSky, FormatError> {
    let loaded = load_sky_texels(source, options)?;
    let transform = SkyTransform::new(options.rotation_degrees, options.intensity);
    let LoadedTexels { texels, layout, files, about, warnings } = loaded;
    let sky = match texels {
        SkyTexels::LatLong(texture) => {
            let map = LatLongMap::from_image(texture).map_err(|source| FormatError::Invalid { file: about, source })?;
            Sky::LatLong { map: Arc::new(map), transform }
        }
        SkyTexels::Faces(faces) => {
            let map = CubeMap::from_faces(faces).map_err(|source| FormatError::Invalid { file: about, source })?;
            Sky::CubeMap { map: Arc::new(map), transform }
        }
    };
    Ok(LoadedSky { sky, layout, files, warnings })
}

/// As [`load_sky`], stopping before the map is built (rotation and intensity are not applied).
pub fn load_sky_texels(source: &SkySource, options: &SkyLoadOptions) -> Result<LoadedTexels, FormatError> {
    let named = match source {
        SkySource::Path(path) => path.clone(),
        SkySource::Faces(paths) => paths[0].clone(),
    };
    check_options(&named, options)?;
    let mut warnings = Vec::new();
    let (faces, layout, files, about) = match source {
        SkySource::Path(path) if path.is_dir() => {
            let files = names::find_faces(path)?;
            (read_faces(&files, &mut warnings)?, SkyLayout::Faces, files.to_vec(), path.clone())
        }
        SkySource::Path(path) => {
            if let Some(pixels) = claimed_pixels(path) {
                // Decoded planes, then the texels sliced from them, then the map.
                let needed = pixels.saturating_mul(DECODE_BYTES_PER_TEXEL + KEPT_BYTES_PER_TEXEL);
                glint_core::memory::check(|| format!("a sky image of {pixels} pixels"), needed)
                    .map_err(|e| FormatError::limits(path, e.to_string()))?;
            }
            let image = read_image(path)?;
            let (layout, n) = SkyLayout::from_image_size(image.width, image.height)
                .ok_or_else(|| bad_aspect(path, image.width, image.height))?;
            if layout == SkyLayout::LatLong {
                if options.has_face_transforms() {
                    return Err(FormatError::sky(
                        path,
                        "is a lat-long map: face flips and turns apply to cube maps only (use rotation to turn it)",
                    ));
                }
                check_side(path, n)?;
                let texture = texture_from_image(path, &image, &mut warnings)?;
                LatLongMap::check_image(&texture)
                    .map_err(|source| FormatError::Invalid { file: path.clone(), source })?;
                return Ok(LoadedTexels {
                    texels: SkyTexels::LatLong(texture),
                    layout,
                    files: vec![path.clone()],
                    about: path.clone(),
                    warnings,
                });
            }
            check_side(path, n)?;
            let faces = layout::slice_faces(&image, layout, n).ok_or_else(|| no_rgb(path, &image))?;
            let faces = sanitise_faces(path, faces, &mut warnings);
            (faces, layout, vec![path.clone()], path.clone())
        }
        SkySource::Faces(paths) => (read_faces(paths, &mut warnings)?, SkyLayout::Faces, paths.to_vec(), named),
    };
    let mut index = 0;
    let faces = faces.map(|face| {
        let transforms = [options.all_faces, options.per_face[index]];
        index += 1;
        transforms.iter().filter(|t| !t.is_identity()).fold(face, |face, t| t.apply(&face))
    });
    CubeMap::check_faces(&faces).map_err(|source| FormatError::Invalid { file: about.clone(), source })?;
    let (warning, fix) = seam_warning(&faces, options);
    if let Some(warning) = warning {
        warnings.push(format!("{}: {warning}", about.display()));
    }
    let faces = match fix {
        Some(fix) if options.auto_fix => {
            let mut index = 0;
            faces.map(|face| {
                let transforms = [fix.all_faces, fix.per_face[index]];
                index += 1;
                transforms.iter().filter(|t| !t.is_identity()).fold(face, |face, t| t.apply(&face))
            })
        }
        _ => faces,
    };
    Ok(LoadedTexels { texels: SkyTexels::Faces(faces), layout, files, about, warnings })
}

fn check_options(path: &Path, options: &SkyLoadOptions) -> Result<(), FormatError> {
    for (what, t) in std::iter::once(("all faces", &options.all_faces))
        .chain(CubeFace::ALL.iter().map(|f| (f.short_name(), &options.per_face[f.index()])))
    {
        t.check().map_err(|m| FormatError::sky(path, format!("face transform of {what}: {m}")))?;
    }
    if !options.rotation_degrees.is_finite() {
        return Err(FormatError::sky(path, format!("sky rotation {} is not a finite angle", options.rotation_degrees)));
    }
    if !(options.intensity.is_finite() && options.intensity >= 0.0) {
        return Err(FormatError::sky(path, format!("sky intensity {} must be finite and ≥ 0", options.intensity)));
    }
    Ok(())
}

/// The warning for faces that do not meet, with the fix when a simple one exists (applied by
/// the caller when `options.auto_fix`).
fn seam_warning(faces: &[TextureImage; 6], options: &SkyLoadOptions) -> (Option<String>, Option<seam::SeamFix>) {
    let Some((score, fix)) = seam::diagnose(faces) else { return (None, None) };
    if score <= seam::MISMATCHED {
        return (None, None);
    }
    let given = if options.has_face_transforms() { " with the flips and turns given" } else { "" };
    let warning = match &fix {
        Some(fix) if options.auto_fix => format!(
            "faces do not meet at their edges{given} (seam score {score:.1}); applied the fix (--sky-fix auto): {} \
             ({:.1}); to keep it in a scene: {}",
            fix.describe(),
            fix.score,
            fix.toml()
        ),
        Some(fix) => format!(
            "faces do not meet at their edges{given} (seam score {score:.1}); {} they would ({:.1}): {}; or \
             render with --sky-fix auto",
            fix.describe(),
            fix.score,
            fix.toml()
        ),
        None => format!(
            "faces do not meet at their edges{given} (seam score {score:.1}, about 1 is expected) and no flip \
             or quarter turn fixes it: check which file is which face (docs/skies.md)"
        ),
    };
    (Some(warning), fix)
}

fn bad_aspect(path: &Path, width: u32, height: u32) -> FormatError {
    let hint = match SkyLayout::nearest(width, height) {
        Some(l) => format!("; it is close to a {}, whose cells must be whole squares", l.describe()),
        None => String::new(),
    };
    FormatError::sky(
        path,
        format!(
            "a {width}x{height} image is no sky layout glint knows (accepted aspects: {}){hint}; six faces go in a \
             folder",
            SkyLayout::ACCEPTED
        ),
    )
}

fn check_side(path: &Path, side: u32) -> Result<(), FormatError> {
    if side > MAX_SKY_SIDE {
        return Err(FormatError::limits(
            path,
            format!("sky faces (or lat-long height) of {side} texels; glint reads at most {MAX_SKY_SIDE}"),
        ));
    }
    Ok(())
}

fn read_image(path: &Path) -> Result<Image, FormatError> {
    let image = crate::texture_file::read_image_file(path)?;
    if image.rgb_planes().is_some() {
        return Ok(image);
    }
    // A grey EXR: one Y channel, used for all three.
    match image.channel("Y") {
        Some(y) => {
            let y = y.to_vec();
            Ok(layout::planar_rgb(image.width, image.height, [y.clone(), y.clone(), y]))
        }
        None => Err(no_rgb(path, &image)),
    }
}

fn no_rgb(path: &Path, image: &Image) -> FormatError {
    let names: Vec<&str> = image.channels.iter().map(|c| c.name.as_str()).collect();
    FormatError::malformed(
        path,
        "image data",
        format!("a sky needs R, G, B (or Y) channels, the file has: {}", names.join(", ")),
    )
}

/// The `R`, `G`, `B` planes of `image` as texels, with values a map cannot hold replaced.
fn texture_from_image(path: &Path, image: &Image, warnings: &mut Vec<String>) -> Result<TextureImage, FormatError> {
    let (r, g, b) = image.rgb_planes().ok_or_else(|| no_rgb(path, image))?;
    let mut bad = 0usize;
    let texels = r.iter().zip(g).zip(b).map(|((&r, &g), &b)| sanitise(Rgb::new(r, g, b), &mut bad)).collect();
    warn_sanitised(path, bad, warnings);
    Ok(TextureImage { width: image.width, height: image.height, texels })
}

/// NaN, ±∞ and negative values (which an EXR may hold) become 0; counted in `bad`.
fn sanitise(c: Rgb, bad: &mut usize) -> Rgb {
    if c.is_finite() && c.min_element() >= 0.0 {
        return c;
    }
    *bad += 1;
    Rgb::from_array(c.to_array().map(|v| if v.is_finite() { v.max(0.0) } else { 0.0 }))
}

fn warn_sanitised(path: &Path, bad: usize, warnings: &mut Vec<String>) {
    if bad > 0 {
        warnings.push(format!("{}: {bad} texels were NaN, infinite or negative; read as 0", path.display()));
    }
}

fn sanitise_faces(path: &Path, faces: [TextureImage; 6], warnings: &mut Vec<String>) -> [TextureImage; 6] {
    let mut bad = 0;
    let faces = faces.map(|mut f| {
        for t in &mut f.texels {
            *t = sanitise(*t, &mut bad);
        }
        f
    });
    warn_sanitised(path, bad, warnings);
    faces
}

/// Bytes a sky texel holds once read: linear RGB (12) until the map is built, and the map's
/// shared-exponent texel with its mips and borders (about 6).
const KEPT_BYTES_PER_TEXEL: u64 = 18;
/// Bytes a texel takes while its file is decoded: the decoder's pixels (at most 8, RGBA16) and
/// the f32 planes (12).
const DECODE_BYTES_PER_TEXEL: u64 = 20;

/// The pixel count a file's header claims, without decoding it (`None` when the header cannot
/// be read: decoding will then say why).
fn claimed_pixels(path: &Path) -> Option<u64> {
    let (w, h) = image::ImageReader::open(path).ok()?.with_guessed_format().ok()?.into_dimensions().ok()?;
    Some(u64::from(w) * u64::from(h))
}

/// Whether six faces of these pixel counts can be decoded at once within the memory budget;
/// when even one at a time would not fit, the error saying what they need.
fn decode_in_parallel(paths: &[PathBuf; 6]) -> Result<bool, FormatError> {
    let pixels: Vec<u64> = paths.iter().map(|p| claimed_pixels(p).unwrap_or(0)).collect();
    let total: u64 = pixels.iter().sum();
    let largest = pixels.iter().copied().max().unwrap_or(0);
    let kept = total.saturating_mul(KEPT_BYTES_PER_TEXEL);
    let what = || format!("six sky faces of {largest} texels each ({total} texels in all)");
    glint_core::memory::check(what, kept.saturating_add(largest.saturating_mul(DECODE_BYTES_PER_TEXEL)))
        .map_err(|e| FormatError::limits(&paths[0], e.to_string()))?;
    let parallel = kept.saturating_add(total.saturating_mul(DECODE_BYTES_PER_TEXEL));
    Ok(glint_core::memory::check(String::new, parallel).is_ok())
}

/// Reads six face files and checks they are square and equal: in parallel, or one after the
/// other when only that fits the memory budget (the texels are the same either way).
fn read_faces(paths: &[PathBuf; 6], warnings: &mut Vec<String>) -> Result<[TextureImage; 6], FormatError> {
    if !decode_in_parallel(paths)? {
        let mut faces = Vec::with_capacity(6);
        for path in paths {
            let image = read_image(path)?;
            check_side(path, image.width.max(image.height))?;
            faces.push(texture_from_image(path, &image, warnings)?);
        }
        return check_face_sizes(paths, faces);
    }
    let results: Vec<Result<(TextureImage, Vec<String>), FormatError>> = std::thread::scope(|scope| {
        let handles: Vec<_> = paths
            .iter()
            .map(|path| {
                scope.spawn(move || {
                    let image = read_image(path)?;
                    check_side(path, image.width.max(image.height))?;
                    let mut w = Vec::new();
                    let texture = texture_from_image(path, &image, &mut w)?;
                    Ok((texture, w))
                })
            })
            .collect();
        handles
            .into_iter()
            .zip(paths)
            .map(|(h, path)| {
                h.join().unwrap_or_else(|_| {
                    Err(FormatError::malformed(path.as_path(), "image data", "the decoder crashed on this file"))
                })
            })
            .collect()
    });
    let mut faces = Vec::with_capacity(6);
    for result in results {
        let (face, w) = result?;
        warnings.extend(w);
        faces.push(face);
    }
    check_face_sizes(paths, faces)
}

fn check_face_sizes(paths: &[PathBuf; 6], faces: Vec<TextureImage>) -> Result<[TextureImage; 6], FormatError> {
    for (path, face) in paths.iter().zip(&faces) {
        if face.width != face.height {
            return Err(FormatError::sky(
                path,
                format!("a cube face must be square, this one is {}x{}", face.width, face.height),
            ));
        }
    }
    let n = faces[0].width;
    if let Some(i) = faces.iter().position(|f| f.width != n) {
        return Err(FormatError::sky(
            &paths[i],
            format!(
                "this face is {0}x{0}, but {1} is {2}x{2}: all six faces must be the same size",
                faces[i].width,
                paths[0].display(),
                n
            ),
        ));
    }
    faces.try_into().map_err(|_| FormatError::sky(&paths[0], "expected six faces"))
}

#[cfg(test)]
pub(crate) mod test_util {
    //! Synthetic skies for the tests of this module and its children.
    use super::*;

    /// A smooth sky with no symmetry (every face differs, a flip shows), in [0, 1].
    pub fn smooth(d: glint_core::Vec3) -> Rgb {
        Rgb::new(
            0.5 + 0.4 * (3.0 * d.x + 1.0 * d.y).sin(),
            0.5 + 0.4 * (2.0 * d.y - 2.5 * d.z).cos(),
            0.5 + 0.3 * (4.0 * d.z + d.x * d.y).sin(),
        )
    }

    /// The faces of [`smooth`] at edge `n`.
    pub fn smooth_faces(n: u32) -> [TextureImage; 6] {
        let map = CubeMap::from_fn(n, smooth);
        CubeFace::ALL.map(|f| map.face_image(f))
    }

    /// Face `i` painted a flat colour of its own (red = i/8), with a yellow top-left texel and
    /// a cyan one right of it, so that flips and turns show.
    pub fn painted_faces(n: u32) -> [TextureImage; 6] {
        std::array::from_fn(|i| {
            let base = Rgb::new(i as f32 / 8.0, 0.5, 1.0 - i as f32 / 8.0);
            let mut texels = vec![base; (n * n) as usize];
            texels[0] = Rgb::new(1.0, 1.0, 0.0);
            texels[1] = Rgb::new(0.0, 1.0, 1.0);
            TextureImage { width: n, height: n, texels }
        })
    }

    /// Writes a texture image to `path` (format by extension).
    pub fn write_texture(path: &Path, texture: &TextureImage) {
        let image = layout::texture_to_image(texture);
        glint_image::write_image(path, &image, &glint_image::PngOptions::default()).expect("write test image");
    }
}

#[cfg(test)]
mod tests;
