//! The PLY body: rows of every element, read into named columns.
//!
//! General on purpose: meshes select `x y z nx ny nz u v` and `vertex_indices`, point clouds
//! select whatever scalar properties they carry; unselected properties and elements are
//! skipped according to their types (lists included). Binary elements made only of scalars are
//! read with a fixed stride in one pass per column; elements with lists are walked row by row.

use super::header::{Element, Header, PlyFormat, Property, PropertyKind, ScalarType};
use crate::error::FormatError;
use std::path::Path;

/// The values of one property over all rows of an element.
#[derive(Clone, Debug, PartialEq)]
pub enum Column {
    /// Any scalar type but `double`, widened or narrowed to `f32` (integers up to 2^24 exactly).
    Float(Vec<f32>),
    /// `double` properties keep their precision (large LiDAR coordinates).
    Double(Vec<f64>),
    /// An integer list per row: `counts[row]` items, concatenated in `values`.
    IndexList { counts: Vec<u32>, values: Vec<u32> },
}

impl Column {
    /// The column as `f32` values (`None` for a list).
    pub fn to_f32(&self) -> Option<Vec<f32>> {
        match self {
            Column::Float(v) => Some(v.clone()),
            Column::Double(v) => Some(v.iter().map(|&x| x as f32).collect()),
            Column::IndexList { .. } => None,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct ElementData {
    pub name: String,
    pub count: usize,
    /// The selected properties, in header order.
    pub columns: Vec<(String, Column)>,
}

impl ElementData {
    pub fn column(&self, name: &str) -> Option<&Column> {
        self.columns.iter().find(|(n, _)| n == name).map(|(_, c)| c)
    }
}

/// A PLY file read into columns.
#[derive(Clone, Debug, PartialEq)]
pub struct PlyData {
    pub header: Header,
    /// One per header element, in order (with no columns when nothing was selected).
    pub elements: Vec<ElementData>,
}

impl PlyData {
    pub fn element(&self, name: &str) -> Option<&ElementData> {
        self.elements.iter().find(|e| e.name == name)
    }
}

/// Reads the body of `data` (whose header is `header`), keeping the properties `select` picks.
pub(crate) fn read_body(
    path: &Path,
    data: &[u8],
    header: Header,
    select: &dyn Fn(&Element, &Property) -> bool,
) -> Result<PlyData, FormatError> {
    for e in &header.elements {
        for p in &e.properties {
            if let PropertyKind::List { item, .. } = p.kind
                && !item.is_integer()
                && select(e, p)
            {
                return Err(FormatError::malformed(
                    path,
                    "header",
                    format!("list property '{}' of element '{}' has non-integer items", p.name, e.name),
                ));
            }
        }
    }
    let elements = match header.format {
        PlyFormat::Ascii => read_ascii(path, data, &header, select)?,
        PlyFormat::BinaryLittleEndian => read_binary(path, data, &header, false, select)?,
        PlyFormat::BinaryBigEndian => read_binary(path, data, &header, true, select)?,
    };
    Ok(PlyData { header, elements })
}

/// A column being filled.
enum Sink {
    Skip,
    Float(Vec<f32>),
    Double(Vec<f64>),
    List(Vec<u32>, Vec<u32>),
}

impl Sink {
    /// Reservations are capped by the rows the remaining bytes can hold, so a truncated file
    /// with a large count allocates no more than its size warrants.
    fn new(e: &Element, p: &Property, selected: bool, remaining_bytes: usize, min_row: usize) -> Sink {
        if !selected {
            return Sink::Skip;
        }
        let rows = e.count.min(remaining_bytes / min_row.max(1) + 1);
        match p.kind {
            PropertyKind::Scalar(ScalarType::F64) => Sink::Double(Vec::with_capacity(rows)),
            PropertyKind::Scalar(_) => Sink::Float(Vec::with_capacity(rows)),
            PropertyKind::List { item, .. } => {
                let values = rows.saturating_mul(3).min(remaining_bytes / item.size());
                Sink::List(Vec::with_capacity(rows), Vec::with_capacity(values))
            }
        }
    }

    fn finish(self) -> Option<Column> {
        match self {
            Sink::Skip => None,
            Sink::Float(v) => Some(Column::Float(v)),
            Sink::Double(v) => Some(Column::Double(v)),
            Sink::List(counts, values) => Some(Column::IndexList { counts, values }),
        }
    }
}

fn collect(e: &Element, sinks: Vec<Sink>) -> ElementData {
    let columns = e.properties.iter().zip(sinks).filter_map(|(p, s)| s.finish().map(|c| (p.name.clone(), c))).collect();
    ElementData { name: e.name.clone(), count: e.count, columns }
}

#[inline]
fn bytes<const N: usize>(b: &[u8]) -> [u8; N] {
    let mut out = [0; N];
    out.copy_from_slice(&b[..N]);
    out
}

/// Decodes one scalar from the front of `b` (which holds at least `ty.size()` bytes).
#[inline]
fn decode(ty: ScalarType, big: bool, b: &[u8]) -> f64 {
    macro_rules! num {
        ($t:ty, $n:literal) => {
            if big { <$t>::from_be_bytes(bytes::<$n>(b)) as f64 } else { <$t>::from_le_bytes(bytes::<$n>(b)) as f64 }
        };
    }
    match ty {
        ScalarType::I8 => b[0] as i8 as f64,
        ScalarType::U8 => b[0] as f64,
        ScalarType::I16 => num!(i16, 2),
        ScalarType::U16 => num!(u16, 2),
        ScalarType::I32 => num!(i32, 4),
        ScalarType::U32 => num!(u32, 4),
        ScalarType::F32 => num!(f32, 4),
        ScalarType::F64 => num!(f64, 8),
    }
}

/// One fixed-stride column: `count` values of type `ty` at `start + row * stride`.
fn strided_f32(data: &[u8], start: usize, stride: usize, count: usize, ty: ScalarType, big: bool) -> Vec<f32> {
    let rows = data[start..].chunks(stride).take(count);
    match (ty, big) {
        (ScalarType::F32, false) => rows.map(|r| f32::from_le_bytes(bytes::<4>(r))).collect(),
        (ScalarType::F32, true) => rows.map(|r| f32::from_be_bytes(bytes::<4>(r))).collect(),
        _ => rows.map(|r| decode(ty, big, r) as f32).collect(),
    }
}

fn read_binary(
    path: &Path,
    data: &[u8],
    header: &Header,
    big: bool,
    select: &dyn Fn(&Element, &Property) -> bool,
) -> Result<Vec<ElementData>, FormatError> {
    let mut pos = header.body_offset;
    let mut out = Vec::with_capacity(header.elements.len());
    let truncated = |e: &Element, row: usize, at: usize| {
        FormatError::malformed(
            path,
            format!("{} {row} (byte {at})", e.name),
            format!("the file ends inside element '{}' ({} rows expected): truncated?", e.name, e.count),
        )
    };
    for e in &header.elements {
        if let Some(stride) = e.fixed_stride() {
            let need = stride * e.count;
            if data.len() - pos < need {
                let row = (data.len() - pos) / stride.max(1);
                return Err(truncated(e, row, pos + row * stride));
            }
            let mut offset = 0;
            let mut columns = Vec::new();
            for p in &e.properties {
                let PropertyKind::Scalar(ty) = p.kind else { continue };
                if select(e, p) {
                    let column = if ty == ScalarType::F64 {
                        let rows = data[pos + offset..].chunks(stride).take(e.count);
                        Column::Double(rows.map(|r| decode(ty, big, r)).collect())
                    } else {
                        Column::Float(strided_f32(data, pos + offset, stride, e.count, ty, big))
                    };
                    columns.push((p.name.clone(), column));
                }
                offset += ty.size();
            }
            out.push(ElementData { name: e.name.clone(), count: e.count, columns });
            pos += need;
            continue;
        }
        // Rows with lists: walk them.
        let mut sinks: Vec<Sink> = e
            .properties
            .iter()
            .map(|p| Sink::new(e, p, select(e, p), data.len() - pos, e.min_row_bytes(header.format)))
            .collect();
        for row in 0..e.count {
            for (p, sink) in e.properties.iter().zip(sinks.iter_mut()) {
                match p.kind {
                    PropertyKind::Scalar(ty) => {
                        let size = ty.size();
                        if data.len() - pos < size {
                            return Err(truncated(e, row, pos));
                        }
                        match sink {
                            Sink::Float(v) => v.push(decode(ty, big, &data[pos..]) as f32),
                            Sink::Double(v) => v.push(decode(ty, big, &data[pos..])),
                            _ => {}
                        }
                        pos += size;
                    }
                    PropertyKind::List { count, item } => {
                        if data.len() - pos < count.size() {
                            return Err(truncated(e, row, pos));
                        }
                        let n = decode(count, big, &data[pos..]);
                        let list_at = pos;
                        pos += count.size();
                        let bytes_needed = n * item.size() as f64;
                        if n < 0.0 || bytes_needed > (data.len() - pos) as f64 {
                            return Err(FormatError::malformed(
                                path,
                                format!("{} {row} (byte {list_at})", e.name),
                                format!(
                                    "list '{}' claims {n} items, more than the {} bytes left in the file",
                                    p.name,
                                    data.len() - pos
                                ),
                            ));
                        }
                        let n = n as usize;
                        if let Sink::List(counts, values) = sink {
                            counts.push(n as u32);
                            for k in 0..n {
                                let v = decode(item, big, &data[pos + k * item.size()..]);
                                if v < 0.0 || v > u32::MAX as f64 {
                                    return Err(FormatError::malformed(
                                        path,
                                        format!("{} {row} (byte {})", e.name, pos + k * item.size()),
                                        format!("list '{}' holds {v}, which is not an index", p.name),
                                    ));
                                }
                                values.push(v as u32);
                            }
                        }
                        pos += n * item.size();
                    }
                }
            }
        }
        out.push(collect(e, sinks));
    }
    Ok(out)
}

/// Whitespace-separated words of an ASCII body, with line numbers for messages.
struct Words<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Words<'a> {
    #[inline]
    fn next(&mut self) -> Option<&'a [u8]> {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            if self.data[self.pos] == b'\n' {
                self.line += 1;
            }
            self.pos += 1;
        }
        if self.pos >= self.data.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        Some(&self.data[start..self.pos])
    }
}

fn read_ascii(
    path: &Path,
    data: &[u8],
    header: &Header,
    select: &dyn Fn(&Element, &Property) -> bool,
) -> Result<Vec<ElementData>, FormatError> {
    let header_lines = data[..header.body_offset].iter().filter(|&&b| b == b'\n').count();
    let mut words = Words { data, pos: header.body_offset, line: header_lines + 1 };
    let mut out = Vec::with_capacity(header.elements.len());
    for e in &header.elements {
        let mut sinks: Vec<Sink> = e
            .properties
            .iter()
            .map(|p| Sink::new(e, p, select(e, p), data.len() - words.pos, e.min_row_bytes(header.format)))
            .collect();
        for row in 0..e.count {
            let place = |line: usize| format!("line {line} ({} {row})", e.name);
            let truncated = |line: usize| {
                FormatError::malformed(
                    path,
                    place(line),
                    format!("the file ends inside element '{}' ({} rows expected): truncated?", e.name, e.count),
                )
            };
            let bad = |w: &[u8], line: usize, what: &str, p: &Property| {
                FormatError::malformed(
                    path,
                    place(line),
                    format!("`{}` is not {what} (property '{}')", String::from_utf8_lossy(w), p.name),
                )
            };
            for (p, sink) in e.properties.iter().zip(sinks.iter_mut()) {
                let w = words.next().ok_or_else(|| truncated(words.line))?;
                match p.kind {
                    PropertyKind::Scalar(ty) => match sink {
                        Sink::Float(v) => v.push(parse_number(w, ty).ok_or_else(|| bad(w, words.line, "a number", p))?),
                        Sink::Double(v) => v.push(parse_f64(w).ok_or_else(|| bad(w, words.line, "a number", p))?),
                        Sink::Skip | Sink::List(..) => {}
                    },
                    PropertyKind::List { .. } => {
                        let n = parse_index(w).ok_or_else(|| bad(w, words.line, "a list count", p))? as usize;
                        if n > (data.len() - words.pos) / 2 + 1 {
                            return Err(FormatError::malformed(
                                path,
                                place(words.line),
                                format!("list '{}' claims {n} items, more than the rest of the file holds", p.name),
                            ));
                        }
                        if let Sink::List(counts, values) = sink {
                            counts.push(n as u32);
                            for _ in 0..n {
                                let w = words.next().ok_or_else(|| truncated(words.line))?;
                                values.push(parse_index(w).ok_or_else(|| bad(w, words.line, "an index", p))?);
                            }
                        } else {
                            for _ in 0..n {
                                words.next().ok_or_else(|| truncated(words.line))?;
                            }
                        }
                    }
                }
            }
        }
        out.push(collect(e, sinks));
    }
    Ok(out)
}

fn parse_index(w: &[u8]) -> Option<u32> {
    std::str::from_utf8(w).ok()?.parse().ok()
}

fn parse_f64(w: &[u8]) -> Option<f64> {
    std::str::from_utf8(w).ok()?.parse().ok()
}

/// An ASCII value as `f32`; integer types must be written as integers.
fn parse_number(w: &[u8], ty: ScalarType) -> Option<f32> {
    let text = std::str::from_utf8(w).ok()?;
    if ty.is_integer() { text.parse::<i64>().ok().map(|v| v as f32) } else { text.parse::<f32>().ok() }
}
