//! Mitsuba's `.serialized` meshes (src/shapes/serialized.cpp): a sequence of zlib-compressed
//! meshes, each after a 4-byte header (format id 0x041C, version 3 or 4), and at the end of the
//! file a table of their byte offsets (u64 in version 4, u32 in version 3) and their count
//! (u32). A mesh's stream: u32 flags, (v4) a NUL-terminated name, u64 vertex and triangle
//! counts, positions, then normals, uvs and colours as the flags say (f32 or f64), then u32
//! indices (u64 when there are more than 2³² vertices). Little endian throughout.

use crate::error::FormatError;
use flate2::read::ZlibDecoder;
use glint_core::{Vec2, Vec3};
use glint_scene::Mesh;
use std::io::Read;
use std::path::Path;

const FORMAT_ID: u16 = 0x041C;
const HAS_NORMALS: u32 = 0x0001;
const HAS_TEXCOORDS: u32 = 0x0002;
const HAS_COLORS: u32 = 0x0008;
const FACE_NORMALS: u32 = 0x0010;
const SINGLE_PRECISION: u32 = 0x1000;
const DOUBLE_PRECISION: u32 = 0x2000;
/// Largest uncompressed mesh body read (4 GiB).
const MAX_BODY_BYTES: u64 = 4 << 30;

/// One mesh of a `.serialized` file, as stored (uvs as Mitsuba's, v = 0 at the image's top),
/// and whether the file asks for face normals.
pub(super) struct SerializedMesh {
    pub mesh: Mesh,
    pub face_normals: bool,
}

/// Reads mesh `shape_index` of a `.serialized` file as a glint mesh (uvs turned to glint's
/// convention, v = 0 at the image's bottom; face-normal meshes without vertex normals).
pub fn read_serialized(path: &Path, shape_index: u32) -> Result<Mesh, FormatError> {
    let data = crate::files::read_sniffed(path, None, |head| {
        if head.len() >= 2 && head[..2] != [0x1c, 0x04] {
            Err("not a Mitsuba .serialized file (it does not start with 1C 04)".to_string())
        } else {
            Ok(())
        }
    })?;
    let mut m = parse(path, &data, shape_index)?;
    if let Some(uvs) = &mut m.mesh.uvs {
        for uv in uvs {
            uv.y = 1.0 - uv.y;
        }
    }
    if m.face_normals {
        m.mesh.normals = None;
    }
    Ok(m.mesh)
}

fn u16_at(data: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(data.get(at..at + 2)?.try_into().ok()?))
}

fn u32_at(data: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(data.get(at..at + 4)?.try_into().ok()?))
}

fn u64_at(data: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(data.get(at..at + 8)?.try_into().ok()?))
}

/// The number of meshes in a `.serialized` file's data.
pub(super) fn mesh_count(path: &Path, data: &[u8]) -> Result<u32, FormatError> {
    let bad = |m: &str| FormatError::malformed(path, "table of contents", m);
    if data.len() < 8 {
        return Err(bad("the file is too short to be a Mitsuba .serialized mesh"));
    }
    u32_at(data, data.len() - 4).ok_or_else(|| bad("truncated"))
}

pub(super) fn parse(path: &Path, data: &[u8], shape_index: u32) -> Result<SerializedMesh, FormatError> {
    let bad = |place: &str, m: String| FormatError::malformed(path, place, m);
    let count = mesh_count(path, data)?;
    if shape_index >= count {
        return Err(bad(
            "table of contents",
            format!("shape_index {shape_index} is out of range: the file holds {count} meshes"),
        ));
    }
    let id = u16_at(data, 0).unwrap_or(0);
    let version = u16_at(data, 2).unwrap_or(0);
    if id != FORMAT_ID {
        return Err(bad(
            "header",
            format!("format id 0x{id:04X}, expected 0x{FORMAT_ID:04X} (not a Mitsuba .serialized file)"),
        ));
    }
    let end = data.len() - 4;
    let back =
        |n: usize| end.checked_sub(n).ok_or_else(|| bad("table of contents", "the offset table is cut off".into()));
    let offset = match version {
        4 => u64_at(data, back(8 * (count - shape_index) as usize)?),
        3 => u32_at(data, back(4 * (count - shape_index) as usize)?).map(u64::from),
        v => return Err(bad("header", format!("version {v} is not supported (3 or 4)"))),
    }
    .ok_or_else(|| bad("table of contents", "the offset table is cut off".into()))?;
    let offset =
        usize::try_from(offset).ok().filter(|&o| o.checked_add(4).is_some_and(|e| e <= end)).ok_or_else(|| {
            bad("table of contents", format!("mesh {shape_index} starts at byte {offset}, past the end of the file"))
        })?;
    let place = format!("mesh {shape_index} (byte {offset})");
    if u16_at(data, offset) != Some(FORMAT_ID) || u16_at(data, offset + 2) != Some(version) {
        return Err(bad(&place, "no mesh header at the offset the table gives".into()));
    }
    let mut z = ZlibDecoder::new(&data[offset + 4..end]);
    let mut read = |n: u64, what: &str| -> Result<Vec<u8>, FormatError> {
        let mut buf = Vec::new();
        (&mut z).take(n).read_to_end(&mut buf).map_err(|e| bad(&place, format!("{what}: {e}")))?;
        if buf.len() as u64 != n {
            return Err(bad(&place, format!("{what}: the compressed data ends early")));
        }
        Ok(buf)
    };
    let flags = u32::from_le_bytes(read(4, "flags")?.try_into().unwrap_or_default());
    let name = if version == 4 {
        let mut name = Vec::new();
        loop {
            let b = read(1, "name")?[0];
            if b == 0 {
                break;
            }
            if name.len() > 4096 {
                return Err(bad(&place, "the mesh name is not terminated".into()));
            }
            name.push(b);
        }
        String::from_utf8_lossy(&name).into_owned()
    } else {
        String::new()
    };
    let counts = read(16, "counts")?;
    let vertices = u64::from_le_bytes(counts[..8].try_into().unwrap_or_default());
    let triangles = u64::from_le_bytes(counts[8..].try_into().unwrap_or_default());
    let double = flags & DOUBLE_PRECISION != 0;
    if double && flags & SINGLE_PRECISION != 0 {
        return Err(bad(&place, "flags ask for both single and double precision".into()));
    }
    let real = if double { 8 } else { 4 };
    let index = if vertices > u64::from(u32::MAX) { 8 } else { 4 };
    let per_vertex = real
        * (3 + if flags & HAS_NORMALS != 0 { 3 } else { 0 }
            + if flags & HAS_TEXCOORDS != 0 { 2 } else { 0 }
            + if flags & HAS_COLORS != 0 { 3 } else { 0 });
    let body =
        vertices.checked_mul(per_vertex).zip(triangles.checked_mul(3 * index)).and_then(|(a, b)| a.checked_add(b));
    if body.is_none_or(|b| b > MAX_BODY_BYTES) || vertices > u64::from(u32::MAX) {
        return Err(FormatError::limits(
            path,
            format!("{place}: {vertices} vertices and {triangles} triangles are more than glint reads"),
        ));
    }
    let n = vertices as usize;
    let mut reals = |k: usize, what: &str| -> Result<Vec<f32>, FormatError> {
        let bytes = read((n * k * real as usize) as u64, what)?;
        let v: Vec<f32> = if double {
            bytes.chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().unwrap_or_default()) as f32).collect()
        } else {
            bytes.chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().unwrap_or_default())).collect()
        };
        if let Some(i) = v.iter().position(|x| !x.is_finite()) {
            return Err(bad(&place, format!("{what} of vertex {} is not a finite number", i / k)));
        }
        Ok(v)
    };
    let p = reals(3, "position")?;
    let positions: Vec<Vec3> = p.chunks_exact(3).map(Vec3::from_slice).collect();
    let normals = if flags & HAS_NORMALS != 0 {
        let v = reals(3, "normal")?;
        Some(v.chunks_exact(3).map(|c| Vec3::from_slice(c).normalize_or(Vec3::Z)).collect())
    } else {
        None
    };
    let uvs = if flags & HAS_TEXCOORDS != 0 {
        Some(reals(2, "uv")?.chunks_exact(2).map(Vec2::from_slice).collect::<Vec<_>>())
    } else {
        None
    };
    if flags & HAS_COLORS != 0 {
        let _ = reals(3, "colour")?;
    }
    let raw = read(triangles * 3 * index, "indices")?;
    let idx: Vec<u64> = if index == 8 {
        raw.chunks_exact(8).map(|c| u64::from_le_bytes(c.try_into().unwrap_or_default())).collect()
    } else {
        raw.chunks_exact(4).map(|c| u64::from(u32::from_le_bytes(c.try_into().unwrap_or_default()))).collect()
    };
    if let Some(i) = idx.iter().position(|&i| i >= vertices) {
        return Err(bad(&place, format!("triangle {} refers to vertex {}, there are {vertices}", i / 3, idx[i])));
    }
    let triangles = idx.chunks_exact(3).map(|t| [t[0] as u32, t[1] as u32, t[2] as u32]).collect();
    let name = if name.is_empty() { format!("shape {shape_index}") } else { name };
    Ok(SerializedMesh {
        mesh: Mesh { name, positions, normals, uvs, triangles, triangle_materials: None, attributes: Vec::new() },
        face_normals: flags & FACE_NORMALS != 0,
    })
}
