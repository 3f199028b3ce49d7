//! LAS 1.0–1.4 and LAZ (LASzip-compressed LAS) airborne and terrestrial LiDAR through the `las`
//! crate, into glint's frame.
//!
//! - **Recentring, always.** LAS coordinates are geo-referenced (UTM: 500 000 m east, 5 000 000 m
//!   north), far beyond f32's centimetre range. Points are read as f64, the centre of the
//!   header's bounds becomes [`PointCloud::origin`] and positions are `p - origin` as f32. A
//!   header whose bounds are not finite, or do not hold the first point, is not trusted: the
//!   first point is the origin then.
//! - **Axes.** LAS is Z-up (x east, y north); glint's world is Y-up, right-handed. A LAS point
//!   `(x, y, z)` becomes `(x, z, -y)` ([`glint_from_las`], which also turns a scene's `sensor`
//!   given in the file's axes). The origin is stored in glint's axes too, so the file's
//!   point is recovered as `(o.x + p.x, -(o.z + p.z), o.y + p.y)` with `o = origin`,
//!   `p = position`.
//! - **Orientation** is [`Orientation::Up`] (+Y): airborne scans see surfaces from above, so
//!   estimated normals should point up.
//! - **Colour** by [`ColourBy`](super::ColourBy); Auto is RGB, else intensity, else elevation.
//!   RGB is 16-bit, but some writers store 8-bit values: when no component exceeds 255 the
//!   values are taken as 8-bit.
//!
//! The counts in the header are checked against the file's size before the `las` crate sees
//! them (it allocates and multiplies with them unchecked), and points are read in chunks, so a
//! lying header costs no more memory than the file holds.

use super::colour::{ColourBy, ColourSources, PointReadOptions, colours};
use crate::FormatError;
use ::las::{PointDataBuilder, Reader};
use glint_core::glam::DVec3;
use glint_core::{Rgb, Vec3};
use glint_scene::{Orientation, PointCloud};
use std::fs::File;
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::Path;

/// Points decoded per call into the `las` crate.
const CHUNK: u64 = 1 << 16;
/// A LAZ file holding more points than this many per byte is not believed.
const MAX_LAZ_POINTS_PER_BYTE: u64 = 1000;

/// A point in a LAS file's axes (Z-up: x east, y north) in glint's (Y-up, right-handed):
/// `(x, y, z)` → `(x, z, −y)`.
#[inline]
pub(crate) fn glint_from_las(p: DVec3) -> DVec3 {
    DVec3::new(p.x, p.z, -p.y)
}

fn malformed(path: &Path, place: impl Into<String>, message: impl Into<String>) -> FormatError {
    FormatError::malformed(path, place, message)
}

/// A `las` crate error as a [`FormatError`] at `place`.
fn las_error(path: &Path, place: impl Into<String>, e: ::las::Error) -> FormatError {
    match e {
        ::las::Error::Io(e) if e.kind() == std::io::ErrorKind::UnexpectedEof => {
            malformed(path, place, "the file ends early: truncated?")
        }
        ::las::Error::Io(e) => FormatError::io(path, e),
        other => malformed(path, place, other.to_string()),
    }
}

/// The header's point count and record length, checked against the file: uncompressed points
/// must fit in it, compressed ones within [`MAX_LAZ_POINTS_PER_BYTE`]; extended records and
/// the LAZ chunk table must lie inside it.
fn check_header(path: &Path, file: &mut File, file_len: u64) -> Result<(), FormatError> {
    let io = |e| FormatError::io(path, e);
    let raw = ::las::raw::Header::read_from(BufReader::new(&mut *file)).map_err(|e| las_error(path, "header", e))?;
    let legacy = u64::from(raw.number_of_point_records);
    let count = match raw.large_file {
        Some(lf) if legacy == 0 => lf.number_of_point_records,
        _ => legacy,
    };
    let record_len = u64::from(raw.point_data_record_length);
    let compressed = raw.point_data_record_format & 0x80 != 0;
    let start = u64::from(raw.offset_to_point_data);
    // Coordinates are `offset + scale * integer`: a zero scale puts every point at the
    // offset (a cloud of one point, however many records), a NaN one nowhere.
    for (axis, scale, offset) in [
        ("x", raw.x_scale_factor, raw.x_offset),
        ("y", raw.y_scale_factor, raw.y_offset),
        ("z", raw.z_scale_factor, raw.z_offset),
    ] {
        if scale == 0.0 || !scale.is_finite() || !offset.is_finite() {
            return Err(malformed(
                path,
                "header",
                format!(
                    "{axis} scale factor {scale} and offset {offset}: the scale must be a finite non-zero number and the offset finite"
                ),
            ));
        }
    }
    if record_len < 20 {
        return Err(malformed(path, "header", format!("point record length {record_len} is below the minimum of 20")));
    }
    if start > file_len {
        return Err(FormatError::limits(
            path,
            format!("the points start at byte {start}, beyond the end of the {file_len}-byte file"),
        ));
    }
    if count > u64::from(u32::MAX) {
        return Err(FormatError::limits(path, format!("{count} points are more than glint can index")));
    }
    let body = file_len - start;
    if !compressed && count * record_len > body {
        return Err(FormatError::limits(
            path,
            format!(
                "the header promises {count} points of {record_len} bytes ({} bytes), but only {body} \
                 bytes follow the header: truncated or corrupt",
                count * record_len
            ),
        ));
    }
    if compressed && count > body.saturating_mul(MAX_LAZ_POINTS_PER_BYTE) {
        return Err(FormatError::limits(
            path,
            format!("the header promises {count} compressed points in {body} bytes: corrupt"),
        ));
    }
    let mut read_u64_at = |at: u64| -> Result<Option<u64>, FormatError> {
        if at.checked_add(8).is_none_or(|end| end > file_len) {
            return Ok(None);
        }
        let mut b = [0u8; 8];
        file.seek(SeekFrom::Start(at)).map_err(io)?;
        file.read_exact(&mut b).map_err(io)?;
        Ok(Some(u64::from_le_bytes(b)))
    };
    if let Some(evlr) = raw.evlr {
        // The first extended VLR: 60 bytes of header, its length at byte 20 of them.
        let at = evlr.start_of_first_evlr;
        let fits = match read_u64_at(at.saturating_add(20))? {
            Some(len) => at.checked_add(60).and_then(|e| e.checked_add(len)).is_some_and(|e| e <= file_len),
            None => false,
        };
        if !fits {
            return Err(FormatError::limits(path, format!("the extended VLR at byte {at} does not fit in the file")));
        }
    }
    if compressed {
        // LASzip: an i64 offset to the chunk table (or, if unset, the file's last 8 bytes),
        // where a u32 version and a u32 chunk count start it.
        let offset = match read_u64_at(start)? {
            Some(o) if o > start + 8 => Some(o),
            _ => read_u64_at(file_len.saturating_sub(8))?.filter(|&o| o > start + 8),
        };
        if let Some(table) = offset
            && let Some(head) = read_u64_at(table)?
        {
            let chunks = head >> 32;
            if chunks > body {
                return Err(FormatError::limits(
                    path,
                    format!("the LAZ chunk table lists {chunks} chunks, more than the file's {body} bytes of points"),
                ));
            }
        }
    }
    file.seek(SeekFrom::Start(0)).map_err(io)?;
    Ok(())
}

/// Reads a LAS or LAZ file.
pub(crate) fn read_las(path: &Path, options: &PointReadOptions) -> Result<PointCloud, FormatError> {
    let (mut file, file_len) = crate::files::open(path, None)?;
    check_header(path, &mut file, file_len)?;
    let mut reader = Reader::new(BufReader::new(file)).map_err(|e| las_error(path, "header", e))?;
    let header = reader.header();
    let count = header.number_of_points();
    let format = *header.point_format();
    let bounds = header.bounds();
    let (lo, hi) =
        (DVec3::new(bounds.min.x, bounds.min.y, bounds.min.z), DVec3::new(bounds.max.x, bounds.max.y, bounds.max.z));
    let header_bounds = (lo.is_finite() && hi.is_finite() && lo.cmple(hi).all()).then_some((lo, hi));

    let by = options.colour_by;
    let want_rgb = format.has_color && matches!(by, ColourBy::Auto | ColourBy::Rgb);
    let want_intensity = matches!(by, ColourBy::Auto | ColourBy::Intensity);
    let want_class = by == ColourBy::Classification;
    // Checked against the file size above; a LAZ file may still hold fewer points.
    let capacity = if format.is_compressed { count.min(file_len) } else { count } as usize;
    let mut positions = Vec::with_capacity(capacity);
    let mut rgb16: Vec<[u16; 3]> = Vec::with_capacity(if want_rgb { capacity } else { 0 });
    let mut intensity: Vec<f32> = Vec::with_capacity(if want_intensity { capacity } else { 0 });
    let mut classes: Vec<u8> = Vec::with_capacity(if want_class { capacity } else { 0 });
    let mut origin_las: Option<DVec3> = None;

    let mut points = PointDataBuilder::new().for_header(header).build();
    let mut done = 0u64;
    while done < count {
        let place = || format!("point {done}");
        let n = reader.fill_points(CHUNK, &mut points).map_err(|e| las_error(path, place(), e))?;
        if n == 0 {
            return Err(malformed(path, place(), format!("the file ends after {done} of {count} points: truncated?")));
        }
        for (k, ((x, y), z)) in points.x().zip(points.y()).zip(points.z()).enumerate() {
            let p = DVec3::new(x, y, z);
            if !p.is_finite() {
                let i = done + k as u64;
                return Err(malformed(path, format!("point {i}"), "a coordinate is NaN or infinite"));
            }
            let origin = *origin_las.get_or_insert_with(|| match header_bounds {
                Some((lo, hi)) if within(p, lo, hi) => (lo + hi) * 0.5,
                _ => p,
            });
            positions.push(glint_from_las(p - origin).as_vec3());
        }
        if want_rgb && let Some(rgb) = points.rgb() {
            rgb16.extend(rgb.map(|(r, g, b)| [r, g, b]));
        }
        if want_intensity {
            intensity.extend(points.intensity().map(f32::from));
        }
        if want_class {
            classes.extend(points.classification());
        }
        done += n;
    }
    let origin = glint_from_las(origin_las.unwrap_or(DVec3::ZERO));

    let rgb = want_rgb.then(|| {
        let max = rgb16.iter().flatten().copied().max().unwrap_or(0);
        let scale = if max <= 255 { 1.0 / 255.0 } else { 1.0 / 65535.0 };
        rgb16.iter().map(|c| Rgb::new(c[0] as f32, c[1] as f32, c[2] as f32) * scale).collect()
    });
    let sources = ColourSources {
        rgb,
        intensity: want_intensity.then_some(intensity),
        classification: want_class.then_some(classes),
        auto_elevation: true,
    };
    let place = format!("header (point format {})", format.to_u8().unwrap_or(0) & 0x3f);
    let colours = colours(path, &place, by, sources, &positions)?;
    let name = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "points".into());
    let orientation = Orientation::Up(Vec3::Y);
    let cloud = PointCloud { name, positions, normals: None, radii: None, colours, origin, orientation };
    cloud.validate().map_err(|source| FormatError::Invalid { file: path.to_path_buf(), source })?;
    Ok(cloud)
}

/// `p` inside the bounds, widened by their size plus a metre (bounds are often rounded).
fn within(p: DVec3, lo: DVec3, hi: DVec3) -> bool {
    let slack = (hi - lo).max_element() + 1.0;
    p.cmpge(lo - slack).all() && p.cmple(hi + slack).all()
}

#[cfg(test)]
mod tests;
