//! The bytes behind a glTF file: its buffers (the .glb BIN chunk, base64 `data:` URIs or files
//! beside the .gltf) and its images, decoded to linear RGB texels.
//!
//! Read here rather than by the `gltf` crate's importer, so that a missing file is reported by
//! name (a missing buffer is an error, a missing image a warning) and a bad URI cannot panic.
//! [`super::read`] calls [`read_buffers`] and [`check_views`] first; accessors are checked
//! ([`check_accessor`]) before they are read, images decoded ([`read_image`]) when a material
//! first uses them.

use crate::error::FormatError;
use crate::model::file_name;
use crate::texture_file;
use std::path::{Path, PathBuf};

pub(super) fn read_buffers(
    path: &Path,
    base: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
) -> Result<Vec<Vec<u8>>, FormatError> {
    let mut out = Vec::new();
    for buffer in document.buffers() {
        let place = format!("buffers[{}]", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                FormatError::malformed(path, place.clone(), "refers to the BIN chunk, which the file does not have")
            })?,
            gltf::buffer::Source::Uri(uri) => match read_uri(path, base, uri, &place)? {
                UriData::Bytes(b) => b,
                UriData::Missing(file) => {
                    return Err(FormatError::MissingFile {
                        file,
                        referenced_from: format!("{} ({place})", path.display()),
                    });
                }
            },
        };
        if data.len() < buffer.length() {
            return Err(FormatError::malformed(
                path,
                place,
                format!("holds {} bytes, but the file says {}", data.len(), buffer.length()),
            ));
        }
        out.push(data);
    }
    Ok(out)
}

enum UriData {
    Bytes(Vec<u8>),
    Missing(PathBuf),
}

/// The bytes a URI names: a base64 `data:` URI or a file relative to the glTF file.
fn read_uri(path: &Path, base: &Path, uri: &str, place: &str) -> Result<UriData, FormatError> {
    if let Some(rest) = uri.strip_prefix("data:") {
        let Some((_, payload)) = rest.split_once(";base64,") else {
            return Err(FormatError::malformed(path, place, "only base64 data URIs are supported"));
        };
        return decode_base64(payload)
            .map(UriData::Bytes)
            .ok_or_else(|| FormatError::malformed(path, place, "invalid base64 in data URI"));
    }
    let relative = uri.strip_prefix("file://").or_else(|| uri.strip_prefix("file:")).unwrap_or(uri);
    if relative.contains("://") {
        return Err(FormatError::malformed(path, place, format!("unsupported URI scheme in `{uri}`")));
    }
    let file = base.join(percent_decode(relative));
    let field = format!("{place}.uri");
    match crate::files::read(&file, Some(crate::files::Referrer::new(path, &field))) {
        Ok(bytes) => Ok(UriData::Bytes(bytes)),
        Err(FormatError::MissingFile { .. }) => Ok(UriData::Missing(file)),
        Err(e) => Err(e),
    }
}

fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && let Some(v) = bytes
                .get(i + 1..i + 3)
                .and_then(|h| std::str::from_utf8(h).ok())
                .and_then(|h| u8::from_str_radix(h, 16).ok())
        {
            out.push(v);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (RFC 4648), padding optional, whitespace not allowed.
pub(super) fn decode_base64(s: &str) -> Option<Vec<u8>> {
    let value = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            _ => return None,
        } as u32)
    };
    let s = s.trim_end_matches('=').as_bytes();
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    for chunk in s.chunks(4) {
        let mut acc = 0u32;
        for &c in chunk {
            acc = (acc << 6) | value(c)?;
        }
        match chunk.len() {
            4 => out.extend_from_slice(&acc.to_be_bytes()[1..]),
            3 => out.extend_from_slice(&(acc << 6).to_be_bytes()[1..3]),
            2 => out.push((acc >> 4) as u8),
            _ => return None,
        }
    }
    Some(out)
}

/// An image's texels as stored (not yet linearised), RGBA in [0, 1], rows top to bottom.
pub(super) struct RawImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<[f32; 4]>,
}

/// An image of the file, decoded. A missing image file is a warning (`None`): the materials
/// that use it fall back to their factors.
pub(super) fn read_image(
    path: &Path,
    base: &Path,
    image: &gltf::Image,
    buffers: &[Vec<u8>],
    warnings: &mut Vec<String>,
) -> Result<Option<RawImage>, FormatError> {
    let place = format!("images[{}]", image.index());
    let bytes = match image.source() {
        gltf::image::Source::View { view, .. } => {
            let start = view.offset();
            let slice =
                buffers.get(view.buffer().index()).and_then(|b| b.get(start..start.checked_add(view.length())?));
            match slice {
                Some(s) => s.to_vec(),
                None => {
                    return Err(FormatError::malformed(
                        path,
                        place,
                        format!("bufferViews[{}] lies outside its buffer", view.index()),
                    ));
                }
            }
        }
        gltf::image::Source::Uri { uri, .. } => match read_uri(path, base, uri, &place)? {
            UriData::Bytes(b) => b,
            UriData::Missing(file) => {
                warnings.push(format!(
                    "{}: texture {} ({place}) not found; its materials use their factors alone",
                    file_name(path),
                    file.display()
                ));
                return Ok(None);
            }
        },
    };
    if image::guess_format(&bytes).is_ok_and(|f| f == image::ImageFormat::Jpeg)
        && !glint_image::jpeg_is_complete(&bytes)
    {
        return Err(FormatError::malformed(
            path,
            place,
            "the JPEG is truncated: its image data ends without the end-of-image marker",
        ));
    }
    texture_file::check_budget(path, &place, &bytes)?;
    let decoded = image::load_from_memory(&bytes)
        .map_err(|e| FormatError::malformed(path, place, format!("cannot decode image: {e}")))?;
    texture_file::check_size(path, decoded.width(), decoded.height())?;
    let rgba = decoded.into_rgba32f();
    let texels = rgba.pixels().map(|p| p.0).collect();
    Ok(Some(RawImage { width: rgba.width(), height: rgba.height(), texels }))
}

/// Every buffer view inside its buffer: checked once, so that accessors only need to fit
/// their view.
pub(super) fn check_views(path: &Path, document: &gltf::Document, buffers: &[Vec<u8>]) -> Result<(), FormatError> {
    for view in document.views() {
        let buffer = view.buffer().index();
        let len = buffers.get(buffer).map_or(0, Vec::len);
        let end = view.offset().checked_add(view.length());
        if end.is_none_or(|end| end > len) {
            return Err(FormatError::malformed(
                path,
                format!("bufferViews[{}]", view.index()),
                format!(
                    "bytes {}..{} lie outside buffers[{buffer}] ({len} bytes)",
                    view.offset(),
                    view.offset().saturating_add(view.length())
                ),
            ));
        }
    }
    Ok(())
}

/// An accessor's elements inside its buffer view (and sparse parts inside theirs), before it
/// is read: the `gltf` crate's reader would otherwise stop early or panic.
pub(super) fn check_accessor(path: &Path, accessor: &gltf::Accessor) -> Result<(), FormatError> {
    let place = || format!("accessors[{}]", accessor.index());
    let count = accessor.count();
    let element = accessor.size();
    if let Some(view) = accessor.view() {
        let stride = view.stride().unwrap_or(element);
        let needed = match count {
            0 => Some(0),
            n => (n - 1)
                .checked_mul(stride)
                .and_then(|b| b.checked_add(element))
                .and_then(|b| b.checked_add(accessor.offset())),
        };
        if needed.is_none_or(|n| n > view.length()) {
            return Err(FormatError::malformed(
                path,
                place(),
                format!(
                    "{count} elements of {element} bytes (stride {stride}) from byte {} do not fit bufferViews[{}] ({} bytes)",
                    accessor.offset(),
                    view.index(),
                    view.length()
                ),
            ));
        }
    }
    if let Some(sparse) = accessor.sparse() {
        let n = sparse.count();
        let index_size = sparse.indices().index_type().size();
        for (what, view, offset, size) in [
            ("sparse indices", sparse.indices().view(), sparse.indices().offset(), index_size),
            ("sparse values", sparse.values().view(), sparse.values().offset(), element),
        ] {
            if n.checked_mul(size).and_then(|b| b.checked_add(offset)).is_none_or(|b| b > view.length()) {
                return Err(FormatError::malformed(
                    path,
                    place(),
                    format!("{what}: {n} elements do not fit bufferViews[{}]", view.index()),
                ));
            }
        }
    }
    Ok(())
}
