//! Writing a sky map in any layout, for `glint sky convert`.
//!
//! Resampling evaluates the source at each destination texel centre through its trilinear
//! lookup, with the destination texel's angular width as the footprint, so shrinking a map
//! filters rather than aliases and a same-size conversion between kinds stays sharp. Same kind
//! and same size copies texels exactly. Output never replaces a file half-written: single
//! images go through glint-image's atomic writes; six faces are written into a fresh folder
//! beside OUT first and then renamed into place.

use super::layout::{assemble_faces, texture_to_image};
use super::names::{face_from_stem, has_image_extension};
use super::{MAX_SKY_SIDE, SkyLayout};
use crate::error::FormatError;
use glint_core::{Rgb, Vec3};
use glint_image::{ImageError, MAX_PIXELS, PngOptions};
use glint_scene::{CubeFace, CubeMap, LatLongMap, Sky, TextureImage, cube_direction, latlong_direction};
use std::f32::consts::PI;
use std::path::{Path, PathBuf};

/// A sky map to write: a cube map or a lat-long map, in its own (map) space.
#[derive(Clone, Copy, Debug)]
pub enum SkyMapRef<'a> {
    Cube(&'a CubeMap),
    LatLong(&'a LatLongMap),
    /// Texels as read from files ([`crate::sky::load_sky_texels`]): copied exactly when the
    /// layout changes but the size does not; a map is built from them to resample.
    Texels(&'a crate::sky::SkyTexels),
}

impl<'a> SkyMapRef<'a> {
    /// The map of a [`Sky::CubeMap`] or [`Sky::LatLong`] (its rotation and intensity are not
    /// part of the map); `None` for colours and gradients.
    pub fn from_sky(sky: &'a Sky) -> Option<SkyMapRef<'a>> {
        match sky {
            Sky::CubeMap { map, .. } => Some(SkyMapRef::Cube(map)),
            Sky::LatLong { map, .. } => Some(SkyMapRef::LatLong(map)),
            _ => None,
        }
    }

    /// Trilinear lookup for a footprint of `cone_angle` radians (`Texels` build their map
    /// first: see [`SkyMapRef::with_map`]).
    pub fn lookup_filtered(self, dir: Vec3, cone_angle: f32) -> Rgb {
        match self {
            SkyMapRef::Cube(m) => m.lookup_filtered(dir, cone_angle),
            SkyMapRef::LatLong(m) => m.lookup_filtered(dir, cone_angle),
            SkyMapRef::Texels(_) => self.with_map(|m| m.lookup_filtered(dir, cone_angle)),
        }
    }

    /// Calls `f` with a map (built from texels when needed; texels from
    /// [`crate::sky::load_sky_texels`] are already checked, so the fallback, an empty black
    /// map, is never reached with them).
    fn with_map<R>(self, f: impl FnOnce(SkyMapRef<'_>) -> R) -> R {
        match self {
            SkyMapRef::Texels(crate::sky::SkyTexels::Faces(faces)) => match CubeMap::from_faces(faces.clone()) {
                Ok(m) => f(SkyMapRef::Cube(&m)),
                Err(_) => f(SkyMapRef::LatLong(&LatLongMap::from_fn(1, |_| Rgb::ZERO))),
            },
            SkyMapRef::Texels(crate::sky::SkyTexels::LatLong(image)) => match LatLongMap::from_image(image.clone()) {
                Ok(m) => f(SkyMapRef::LatLong(&m)),
                Err(_) => f(SkyMapRef::LatLong(&LatLongMap::from_fn(1, |_| Rgb::ZERO))),
            },
            map => f(map),
        }
    }

    /// The size written when none is asked for: a cube's face edge, a lat-long map's height.
    /// Used as the face edge of cube layouts and the height of a lat-long map, so a lat-long
    /// W × W/2 becomes faces of W/2 and back without loss of size.
    pub fn default_size(self) -> u32 {
        match self {
            SkyMapRef::Cube(m) => m.face_size(),
            SkyMapRef::LatLong(m) => m.height(),
            SkyMapRef::Texels(crate::sky::SkyTexels::Faces(f)) => f[0].width,
            SkyMapRef::Texels(crate::sky::SkyTexels::LatLong(i)) => i.height,
        }
    }
}

/// How to write a sky.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SkyWriteOptions {
    /// Face edge of cube layouts, height of a lat-long map (its width is twice that); `None`
    /// keeps [`SkyMapRef::default_size`].
    pub size: Option<u32>,
    /// File type of the six faces of [`SkyLayout::Faces`]: `png`, `jpg`, `hdr` or `exr`
    /// (single images take theirs from OUT's extension).
    pub face_extension: String,
}

impl Default for SkyWriteOptions {
    fn default() -> Self {
        SkyWriteOptions { size: None, face_extension: "png".to_string() }
    }
}

/// What [`write_sky`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct WrittenSky {
    /// The files, six faces in [`CubeFace::ALL`] order or the one image.
    pub files: Vec<PathBuf>,
    /// Face edge, or lat-long height.
    pub size: u32,
    /// E.g. values above 1 clipped by an 8-bit format, each starting with the file.
    pub warnings: Vec<String>,
}

/// Writes `map` in `layout` to `out`: [`SkyLayout::Faces`] makes (or fills) the folder `out`
/// with `px`, `nx`, `py`, `ny`, `pz`, `nz` plus `options.face_extension`; every other layout
/// is one image whose extension (`.png`, `.jpg`, `.hdr`, `.exr`) picks the format. 8-bit
/// formats clip values above 1 (reported in [`WrittenSky::warnings`]). On error nothing is
/// left under `out`'s name that was not there before (a folder of faces is replaced file by
/// file only after all six are written).
pub fn write_sky(
    map: SkyMapRef<'_>,
    layout: SkyLayout,
    out: &Path,
    options: &SkyWriteOptions,
) -> Result<WrittenSky, FormatError> {
    let size = options.size.unwrap_or_else(|| map.default_size());
    check_size(out, layout, size)?;
    match layout {
        SkyLayout::Faces => {
            let extension = checked_extension(out, &options.face_extension)?;
            let names: Vec<String> = CubeFace::ALL.iter().map(|f| format!("{}.{extension}", f.short_name())).collect();
            check_face_folder(out, &names)?;
            let faces = cube_faces(map, size);
            let mut warnings = Vec::new();
            let images: Vec<_> = faces.iter().map(texture_to_image).collect();
            if is_ldr(&extension) {
                let clipped = faces.iter().map(count_clipped).sum();
                warn_clipped(out, clipped, 6 * 3 * (size as usize).pow(2), &mut warnings);
            }
            let files = write_folder(out, &names, &images)?;
            Ok(WrittenSky { files, size, warnings })
        }
        _ => {
            let extension = out.extension().and_then(|e| e.to_str()).unwrap_or("");
            let extension = checked_extension(out, extension)?;
            if out.is_dir() {
                return Err(FormatError::write(out, "is a folder; a cross, strip or lat-long map is one image file"));
            }
            let texture = if layout == SkyLayout::LatLong { Some(latlong(map, size)) } else { None };
            let image = match &texture {
                Some(t) => texture_to_image(t),
                None => assemble_faces(&cube_faces(map, size), layout)
                    .ok_or_else(|| FormatError::write(out, "not a single-image layout"))?,
            };
            let mut warnings = Vec::new();
            if is_ldr(&extension) {
                let clipped = image.channels.iter().map(|c| c.data.iter().filter(|&&v| v > 1.0).count()).sum();
                warn_clipped(out, clipped, 3 * image.pixel_count(), &mut warnings);
            }
            glint_image::write_image(out, &image, &PngOptions::default()).map_err(|e| write_error(out, e))?;
            Ok(WrittenSky { files: vec![out.to_path_buf()], size, warnings })
        }
    }
}

const EXTENSIONS: [&str; 5] = ["png", "jpg", "jpeg", "hdr", "exr"];

fn checked_extension(out: &Path, extension: &str) -> Result<String, FormatError> {
    let lower = extension.trim_start_matches('.').to_ascii_lowercase();
    if EXTENSIONS.contains(&lower.as_str()) {
        return Ok(lower);
    }
    let shown = if lower.is_empty() { "none".to_string() } else { format!("'.{lower}'") };
    Err(FormatError::write(out, format!("unsupported image type {shown} (use .png, .jpg, .hdr or .exr)")))
}

fn is_ldr(extension: &str) -> bool {
    matches!(extension, "png" | "jpg" | "jpeg")
}

/// Refuses sizes glint could not read back.
fn check_size(out: &Path, layout: SkyLayout, size: u32) -> Result<(), FormatError> {
    let (cols, rows) = match layout {
        SkyLayout::Faces => (1, 1),
        SkyLayout::LatLong => (2, 1),
        other => other.grid().unwrap_or((1, 1)),
    };
    let pixels = u64::from(cols) * u64::from(rows) * u64::from(size).pow(2);
    let longest = u64::from(cols.max(rows)) * u64::from(size);
    if size == 0 || size > MAX_SKY_SIDE || pixels > MAX_PIXELS || longest > glint_image::MAX_SIDE {
        let what = if layout == SkyLayout::LatLong { "a lat-long height" } else { "a face edge" };
        return Err(FormatError::write(
            out,
            format!(
                "{what} of {size} is out of range (layout: {}): 1..={MAX_SKY_SIDE}, at most {MAX_PIXELS} pixels per image",
                layout.describe()
            ),
        ));
    }
    Ok(())
}

fn write_error(out: &Path, e: ImageError) -> FormatError {
    match e {
        ImageError::Io { source, .. } => FormatError::write(out, source.to_string()),
        ImageError::Encode { message, .. } | ImageError::Decode { message, .. } | ImageError::Mismatch { message } => {
            FormatError::write(out, message)
        }
        other => FormatError::write(out, other.to_string()),
    }
}

fn count_clipped(t: &TextureImage) -> usize {
    t.texels.iter().map(|c| c.to_array().iter().filter(|&&v| v > 1.0).count()).sum()
}

fn warn_clipped(out: &Path, clipped: usize, total: usize, warnings: &mut Vec<String>) {
    if clipped > 0 {
        warnings.push(format!(
            "{}: {clipped} of {total} values ({:.2} %) were above 1 and are clipped by an 8-bit format; write .hdr \
             or .exr to keep them",
            out.display(),
            100.0 * clipped as f64 / total as f64
        ));
    }
}

/// The six faces of edge `n`: copied when the source is a cube map of that size, else
/// resampled with each texel's angular width ((2/n)·m^1.5, m the major component of the unit
/// direction) as the footprint.
fn cube_faces(map: SkyMapRef<'_>, n: u32) -> [TextureImage; 6] {
    match map {
        SkyMapRef::Cube(cube) if cube.face_size() == n => return CubeFace::ALL.map(|f| cube.face_image(f)),
        SkyMapRef::Texels(crate::sky::SkyTexels::Faces(faces)) if faces[0].width == n => return faces.clone(),
        SkyMapRef::Texels(_) => return map.with_map(|m| cube_faces(m, n)),
        _ => {}
    }
    let nf = n as f32;
    CubeFace::ALL.map(|face| {
        let texels = par_texels(n, n, |x, y| {
            let d = cube_direction(face, (x as f32 + 0.5) / nf, (y as f32 + 0.5) / nf).normalize();
            let m = d.abs().max_element();
            map.lookup_filtered(d, 2.0 / nf * m * m.sqrt())
        });
        TextureImage { width: n, height: n, texels }
    })
}

/// A lat-long map of height `h` (width 2h): copied when the source is one of that size, else
/// resampled with the texel height π/h as the footprint (the texel's longer side everywhere).
fn latlong(map: SkyMapRef<'_>, h: u32) -> TextureImage {
    match map {
        SkyMapRef::LatLong(source) if source.height() == h => return source.image(),
        SkyMapRef::Texels(crate::sky::SkyTexels::LatLong(image)) if image.height == h => return image.clone(),
        SkyMapRef::Texels(_) => return map.with_map(|m| latlong(m, h)),
        _ => {}
    }
    let (w, hf) = (2 * h, h as f32);
    let cone = PI / hf;
    let texels = par_texels(w, h, |x, y| {
        let d = latlong_direction((x as f32 + 0.5) / (2.0 * hf), (y as f32 + 0.5) / hf);
        map.lookup_filtered(d, cone)
    });
    TextureImage { width: w, height: h, texels }
}

/// `f(x, y)` for every texel of a `width × height` image, rows split over the cores. Each
/// texel depends on its position only, so the result does not depend on the thread count.
fn par_texels(width: u32, height: u32, f: impl Fn(u32, u32) -> Rgb + Sync) -> Vec<Rgb> {
    let mut texels = vec![Rgb::ZERO; width as usize * height as usize];
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let rows_per_chunk = (height as usize).div_ceil(threads * 4).max(1);
    let chunks: Vec<(usize, &mut [Rgb])> = texels.chunks_mut(rows_per_chunk * width as usize).enumerate().collect();
    let next = std::sync::Mutex::new(chunks.into_iter());
    std::thread::scope(|scope| {
        for _ in 0..threads {
            scope.spawn(|| {
                // The guard is consumed inside `and_then`, so the lock is not held while a
                // chunk is computed.
                while let Some((index, chunk)) = next.lock().ok().and_then(|mut it| it.next()) {
                    let y0 = index * rows_per_chunk;
                    for (i, texel) in chunk.iter_mut().enumerate() {
                        let (x, y) = (i % width as usize, y0 + i / width as usize);
                        *texel = f(x as u32, y as u32);
                    }
                }
            });
        }
    });
    texels
}

/// Refuses an OUT that is a file, or a folder holding face images of other names (which
/// would make the folder ambiguous once ours are added).
fn check_face_folder(out: &Path, names: &[String]) -> Result<(), FormatError> {
    if !out.exists() {
        return Ok(());
    }
    if !out.is_dir() {
        return Err(FormatError::write(out, "exists and is not a folder; --to faces writes a folder of six images"));
    }
    let entries = std::fs::read_dir(out).map_err(|e| FormatError::write(out, e.to_string()))?;
    let mut clashing = Vec::new();
    for entry in entries.flatten() {
        let path = entry.path();
        let name = entry.file_name().to_string_lossy().into_owned();
        let stem = path.file_stem().and_then(|s| s.to_str()).unwrap_or("");
        if has_image_extension(&path) && face_from_stem(stem).is_some() && !names.contains(&name) {
            clashing.push(name);
        }
    }
    clashing.sort();
    if !clashing.is_empty() {
        return Err(FormatError::write(
            out,
            format!(
                "the folder already holds face images that would not be replaced ({}): the set would be ambiguous; \
                 choose a new or empty folder",
                clashing.join(", ")
            ),
        ));
    }
    Ok(())
}

/// Writes `images` as `names` into a fresh folder beside `out`, then moves them into place:
/// the whole folder if `out` does not exist, else file by file (each rename atomic).
fn write_folder(out: &Path, names: &[String], images: &[glint_image::Image]) -> Result<Vec<PathBuf>, FormatError> {
    use std::sync::atomic::{AtomicU32, Ordering};
    static COUNTER: AtomicU32 = AtomicU32::new(0);
    let parent = match out.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let leaf = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "sky".to_string());
    let temp = parent.join(format!(".{leaf}.tmp-{}-{}", std::process::id(), COUNTER.fetch_add(1, Ordering::Relaxed)));
    std::fs::create_dir(&temp).map_err(|e| FormatError::write(out, e.to_string()))?;
    let result = (|| {
        for (name, image) in names.iter().zip(images) {
            glint_image::write_image(&temp.join(name), image, &PngOptions::default())
                .map_err(|e| write_error(&out.join(name), e))?;
        }
        if out.exists() {
            for name in names {
                std::fs::rename(temp.join(name), out.join(name))
                    .map_err(|e| FormatError::write(out.join(name), e.to_string()))?;
            }
            let _ = std::fs::remove_dir(&temp);
        } else {
            std::fs::rename(&temp, out).map_err(|e| FormatError::write(out, e.to_string()))?;
        }
        Ok(names.iter().map(|n| out.join(n)).collect())
    })();
    if result.is_err() {
        let _ = std::fs::remove_dir_all(&temp);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sky::test_util::{painted_faces, smooth, smooth_faces};
    use crate::sky::{SkyLoadOptions, SkySource, load_sky};
    use crate::test_util::TempDir;

    fn load(path: &Path) -> crate::sky::LoadedSky {
        load_sky(&SkySource::Path(path.to_path_buf()), &SkyLoadOptions::default()).expect("load")
    }

    fn cube_of(loaded: &crate::sky::LoadedSky) -> &CubeMap {
        match &loaded.sky {
            Sky::CubeMap { map, .. } => map,
            other => panic!("not a cube map: {other:?}"),
        }
    }

    #[test]
    fn every_layout_written_reads_back_as_the_same_faces() {
        let dir = TempDir::new("sky-write-layouts");
        let cube = CubeMap::from_faces(painted_faces(4)).expect("cube");
        let layouts = [
            (SkyLayout::HorizontalCross, "cross.exr"),
            (SkyLayout::VerticalCross, "vcross.hdr"),
            (SkyLayout::HorizontalStrip, "strip.exr"),
            (SkyLayout::VerticalStrip, "vstrip.png"),
            (SkyLayout::Faces, "faces"),
        ];
        for (layout, name) in layouts {
            let out = dir.join(name);
            let options = SkyWriteOptions { size: None, face_extension: "exr".into() };
            let written = write_sky(SkyMapRef::Cube(&cube), layout, &out, &options).expect("write");
            assert_eq!(written.size, 4);
            assert_eq!(written.files.len(), if layout == SkyLayout::Faces { 6 } else { 1 });
            let loaded = load(&out);
            assert_eq!(loaded.layout, layout);
            let back = cube_of(&loaded);
            for face in CubeFace::ALL {
                let (a, b) = (cube.face_image(face), back.face_image(face));
                for (x, y) in a.texels.iter().zip(&b.texels) {
                    // Exact for EXR; within RGBE / 8-bit sRGB steps otherwise.
                    assert!((*x - *y).abs().max_element() < 0.01, "{layout:?} {face:?}: {x} vs {y}");
                }
            }
        }
    }

    #[test]
    fn latlong_to_faces_and_back_keeps_the_picture() {
        let h = 64;
        let source = LatLongMap::from_fn(h, smooth);
        let faces = cube_faces(SkyMapRef::LatLong(&source), h);
        let cube = CubeMap::from_faces(faces).expect("cube");
        let back = latlong(SkyMapRef::Cube(&cube), h);
        let original = source.image();
        let mse: f64 = original
            .texels
            .iter()
            .zip(&back.texels)
            .map(|(a, b)| f64::from((*a - *b).length_squared()) / 3.0)
            .sum::<f64>()
            / original.texels.len() as f64;
        let psnr = 10.0 * (1.0 / mse).log10();
        assert!(psnr > 35.0, "{psnr} dB");
        // Same kind, same size: texels copied exactly.
        assert_eq!(latlong(SkyMapRef::LatLong(&source), h), original);
        let cube = CubeMap::from_faces(smooth_faces(8)).expect("cube");
        assert_eq!(cube_faces(SkyMapRef::Cube(&cube), 8), smooth_faces(8));
    }

    #[test]
    fn shrinking_filters_instead_of_aliasing() {
        // A checkerboard of single texels averages to grey when shrunk 8×.
        let n = 256;
        let faces: [TextureImage; 6] = std::array::from_fn(|_| TextureImage {
            width: n,
            height: n,
            texels: (0..n * n).map(|i| if (i % n + i / n) % 2 == 0 { Rgb::ONE } else { Rgb::ZERO }).collect(),
        });
        let cube = CubeMap::from_faces(faces).expect("cube");
        let small = cube_faces(SkyMapRef::Cube(&cube), n / 8);
        for face in &small {
            for t in &face.texels {
                assert!((t.x - 0.5).abs() < 0.1, "{t}");
            }
        }
    }

    #[test]
    fn par_texels_visits_every_texel_once_in_place() {
        let t = par_texels(7, 5, |x, y| Rgb::new(x as f32, y as f32, 0.0));
        for (i, c) in t.iter().enumerate() {
            assert_eq!((c.x as usize, c.y as usize), (i % 7, i / 7));
        }
    }

    #[test]
    fn bad_outputs_are_errors_and_leave_nothing_behind() {
        let dir = TempDir::new("sky-write-bad");
        let cube = CubeMap::from_faces(painted_faces(2)).expect("cube");
        let map = SkyMapRef::Cube(&cube);
        let o = SkyWriteOptions::default();
        let err = write_sky(map, SkyLayout::HorizontalCross, &dir.join("x.tga"), &o).expect_err("tga");
        assert!(err.to_string().contains("x.tga") && err.to_string().contains("unsupported"), "{err}");
        let err = write_sky(map, SkyLayout::LatLong, &dir.join("noext"), &o).expect_err("no extension");
        assert!(err.to_string().contains("noext"), "{err}");
        let big = SkyWriteOptions { size: Some(20_000), ..o.clone() };
        assert!(write_sky(map, SkyLayout::Faces, &dir.join("big"), &big).is_err());
        let zero = SkyWriteOptions { size: Some(0), ..o.clone() };
        assert!(write_sky(map, SkyLayout::LatLong, &dir.join("z.png"), &zero).is_err());
        let bad_ext = SkyWriteOptions { face_extension: "bmp".into(), ..o.clone() };
        assert!(write_sky(map, SkyLayout::Faces, &dir.join("f"), &bad_ext).is_err());
        // A folder OUT for a single image, a file OUT for faces.
        std::fs::create_dir(dir.join("taken.png")).expect("mkdir");
        assert!(write_sky(map, SkyLayout::HorizontalCross, &dir.join("taken.png"), &o).is_err());
        std::fs::write(dir.join("file"), b"keep").expect("write");
        assert!(write_sky(map, SkyLayout::Faces, &dir.join("file"), &o).is_err());
        assert_eq!(std::fs::read(dir.join("file")).expect("read"), b"keep");
        // A missing parent folder.
        let err = write_sky(map, SkyLayout::Faces, &dir.join("no/such/faces"), &o).expect_err("no parent");
        assert!(err.to_string().contains("no/such/faces"), "{err}");
        // A folder that already holds faces named otherwise.
        let set = dir.join("set");
        std::fs::create_dir(&set).expect("mkdir");
        std::fs::write(set.join("right.png"), b"old").expect("write");
        let err = write_sky(map, SkyLayout::Faces, &set, &o).expect_err("clash");
        assert!(err.to_string().contains("right.png"), "{err}");
        let mut left: Vec<String> = std::fs::read_dir(dir.path())
            .expect("ls")
            .map(|e| e.expect("e").file_name().to_string_lossy().into())
            .collect();
        left.sort();
        assert_eq!(left, ["file", "set", "taken.png"]);
        // Filling an existing folder that holds only our names works and replaces them.
        std::fs::remove_file(set.join("right.png")).expect("rm");
        std::fs::write(set.join("px.png"), b"old").expect("write");
        std::fs::write(set.join("notes.txt"), b"mine").expect("write");
        let written = write_sky(map, SkyLayout::Faces, &set, &o).expect("fill");
        assert_eq!(written.files.len(), 6);
        assert_eq!(std::fs::read(set.join("notes.txt")).expect("read"), b"mine");
        assert!(glint_image::read_image(&set.join("px.png")).is_ok());
    }

    #[test]
    fn ldr_output_reports_clipping() {
        let dir = TempDir::new("sky-write-clip");
        let mut faces = painted_faces(2);
        faces[0].texels[3] = Rgb::new(4.0, 0.5, 0.5);
        let cube = CubeMap::from_faces(faces).expect("cube");
        let o = SkyWriteOptions::default();
        let written =
            write_sky(SkyMapRef::Cube(&cube), SkyLayout::HorizontalCross, &dir.join("c.png"), &o).expect("png");
        assert_eq!(written.warnings.len(), 1, "{:?}", written.warnings);
        assert!(written.warnings[0].contains("clipped"), "{:?}", written.warnings);
        let written =
            write_sky(SkyMapRef::Cube(&cube), SkyLayout::HorizontalCross, &dir.join("c.hdr"), &o).expect("hdr");
        assert!(written.warnings.is_empty());
    }
}
