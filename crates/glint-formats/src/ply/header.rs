//! The PLY header: format line, elements with their properties, `end_header`.
//!
//! Counts are checked against the size of the body before anything is allocated: every row of
//! an element needs a known minimum of bytes, so a header that promises more rows than the file
//! could hold (`element vertex 1000000000000`) is rejected at once.

use crate::error::FormatError;
use std::path::Path;

/// Longest header accepted; real headers are a few hundred bytes.
const MAX_HEADER_BYTES: usize = 1 << 20;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlyFormat {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

/// The scalar types of PLY, under both their old and their sized names.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ScalarType {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl ScalarType {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    /// Size in bytes in a binary body.
    pub fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    pub fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PropertyKind {
    Scalar(ScalarType),
    /// A count of type `count`, then that many items of type `item`.
    List {
        count: ScalarType,
        item: ScalarType,
    },
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Property {
    pub name: String,
    pub kind: PropertyKind,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Element {
    pub name: String,
    pub count: usize,
    pub properties: Vec<Property>,
}

impl Element {
    /// Bytes every row needs at least: binary sizes (lists may be empty), or for ASCII one
    /// character and one separator per value.
    pub(crate) fn min_row_bytes(&self, format: PlyFormat) -> usize {
        self.properties
            .iter()
            .map(|p| match (format, p.kind) {
                (PlyFormat::Ascii, _) => 2,
                (_, PropertyKind::Scalar(t)) => t.size(),
                (_, PropertyKind::List { count, .. }) => count.size(),
            })
            .sum()
    }

    /// Row size when every property is a scalar (binary fast path).
    pub(crate) fn fixed_stride(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                PropertyKind::Scalar(t) => Some(t.size()),
                PropertyKind::List { .. } => None,
            })
            .sum()
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Header {
    pub format: PlyFormat,
    pub elements: Vec<Element>,
    pub comments: Vec<String>,
    /// Byte offset of the body (just after the `end_header` line).
    pub body_offset: usize,
}

fn err(path: &Path, line: usize, message: impl Into<String>) -> FormatError {
    FormatError::malformed(path, format!("header line {line}"), message)
}

/// Parses the header at the start of `data` and checks its counts against the body size.
pub(crate) fn parse_header(path: &Path, data: &[u8]) -> Result<Header, FormatError> {
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut comments = Vec::new();
    loop {
        if pos >= data.len() {
            return Err(FormatError::malformed(path, "header", "the file ends before `end_header`"));
        }
        if pos > MAX_HEADER_BYTES {
            return Err(FormatError::malformed(path, "header", "no `end_header` in the first megabyte"));
        }
        let end = data[pos..].iter().position(|&b| b == b'\n').map_or(data.len(), |i| pos + i);
        let raw = &data[pos..end];
        pos = (end + 1).min(data.len());
        line_no += 1;
        let Ok(line) = std::str::from_utf8(raw) else {
            return Err(err(path, line_no, "the header is not text"));
        };
        let line = line.trim_end_matches('\r');
        if line_no == 1 {
            if line.trim() != "ply" {
                return Err(FormatError::malformed(path, "header", "not a PLY file (the first line is not `ply`)"));
            }
            continue;
        }
        let mut words = line.split_ascii_whitespace();
        let Some(keyword) = words.next() else { continue };
        match keyword {
            "format" => {
                let (Some(kind), Some(version), None) = (words.next(), words.next(), words.next()) else {
                    return Err(err(path, line_no, format!("bad format line `{line}`")));
                };
                format = Some(match kind {
                    "ascii" => PlyFormat::Ascii,
                    "binary_little_endian" => PlyFormat::BinaryLittleEndian,
                    "binary_big_endian" => PlyFormat::BinaryBigEndian,
                    _ => return Err(err(path, line_no, format!("unknown format `{kind}`"))),
                });
                if !version.starts_with('1') {
                    return Err(err(path, line_no, format!("unsupported PLY version `{version}`")));
                }
            }
            "comment" | "obj_info" => comments.push(line[keyword.len()..].trim().to_string()),
            "element" => {
                let (Some(name), Some(count), None) = (words.next(), words.next(), words.next()) else {
                    return Err(err(
                        path,
                        line_no,
                        format!("bad element line `{line}` (want `element <name> <count>`)"),
                    ));
                };
                let count: u64 = count.parse().map_err(|_| {
                    err(path, line_no, format!("element count `{count}` is not a non-negative integer"))
                })?;
                let count = usize::try_from(count)
                    .map_err(|_| FormatError::limits(path, format!("element '{name}' count {count} is absurd")))?;
                elements.push(Element { name: name.to_string(), count, properties: Vec::new() });
            }
            "property" => {
                let Some(element) = elements.last_mut() else {
                    return Err(err(path, line_no, "`property` before any `element`"));
                };
                let parts: Vec<&str> = words.collect();
                let bad_type = |t: &str| err(path, line_no, format!("unknown property type `{t}`"));
                let property = match parts.as_slice() {
                    ["list", count, item, name] => {
                        let count = ScalarType::parse(count).ok_or_else(|| bad_type(count))?;
                        let item = ScalarType::parse(item).ok_or_else(|| bad_type(item))?;
                        if !count.is_integer() {
                            return Err(err(path, line_no, "a list count must have an integer type"));
                        }
                        Property { name: name.to_string(), kind: PropertyKind::List { count, item } }
                    }
                    [ty, name] => Property {
                        name: name.to_string(),
                        kind: PropertyKind::Scalar(ScalarType::parse(ty).ok_or_else(|| bad_type(ty))?),
                    },
                    _ => return Err(err(path, line_no, format!("bad property line `{line}`"))),
                };
                if element.properties.iter().any(|p| p.name == property.name) {
                    return Err(err(path, line_no, format!("property '{}' appears twice", property.name)));
                }
                element.properties.push(property);
            }
            "end_header" => break,
            _ => return Err(err(path, line_no, format!("unknown header keyword `{keyword}`"))),
        }
    }
    let Some(format) = format else {
        return Err(FormatError::malformed(path, "header", "no `format` line"));
    };
    let header = Header { format, elements, comments, body_offset: pos };
    check_counts(path, &header, data.len() - pos)?;
    Ok(header)
}

/// Rejects element counts the body cannot possibly hold, before anything is allocated.
///
/// A count a little beyond the body is a truncated file: it passes here, and the body reader
/// reports the exact row and byte where the data stops (its reservations are capped by the
/// bytes left). A count far beyond it (`element vertex 1000000000000` in a small file) is an
/// absurd header, rejected at once.
fn check_counts(path: &Path, header: &Header, body_len: usize) -> Result<(), FormatError> {
    let mut needed: u128 = 0;
    for e in &header.elements {
        let row = e.min_row_bytes(header.format) as u128;
        if row == 0 && e.count > u32::MAX as usize {
            return Err(FormatError::limits(path, format!("element '{}' count {} is absurd", e.name, e.count)));
        }
        needed += row * e.count as u128;
        if needed > 2 * body_len as u128 + 4096 {
            return Err(FormatError::limits(
                path,
                format!(
                    "header: element '{}' claims {} rows, which need at least {needed} bytes, but the body has only \
                     {body_len}: the count is absurd",
                    e.name, e.count
                ),
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<Header, FormatError> {
        parse_header(Path::new("t.ply"), text.as_bytes())
    }

    #[test]
    fn header_with_lists_and_comments_parses() {
        let h = parse(
            "ply\r\nformat binary_little_endian 1.0\r\ncomment hi\r\nelement vertex 1\r\nproperty float32 x\r\n\
             element face 0\r\nproperty list uint8 int32 vertex_indices\r\nend_header\r\n1234",
        )
        .expect("valid");
        assert_eq!(h.format, PlyFormat::BinaryLittleEndian);
        assert_eq!(h.elements.len(), 2);
        assert_eq!(
            h.elements[1].properties[0].kind,
            PropertyKind::List { count: ScalarType::U8, item: ScalarType::I32 }
        );
        assert_eq!(h.comments, vec!["hi".to_string()]);
        assert_eq!(h.body_offset, h.body_offset.min(1000));
    }

    #[test]
    fn bad_format_line_is_an_error() {
        let e = parse("ply\nformat binary_middle_endian 1.0\nend_header\n").expect_err("bad format");
        assert!(e.to_string().starts_with("t.ply: header line 2"), "{e}");
    }

    #[test]
    fn absurd_count_is_rejected_before_allocation() {
        let e = parse("ply\nformat ascii 1.0\nelement vertex 1000000000000\nproperty float x\nend_header\n1\n")
            .expect_err("absurd");
        assert!(matches!(e, FormatError::Limits { .. }), "{e}");
        let e =
            parse("ply\nformat ascii 1.0\nelement vertex 100000000000000000000\nend_header\n").expect_err("overflow");
        assert!(e.to_string().contains("100000000000000000000"), "{e}");
    }

    #[test]
    fn missing_end_header_and_stray_property_are_errors() {
        assert!(parse("ply\nformat ascii 1.0\nelement vertex 0\n").is_err());
        assert!(parse("ply\nformat ascii 1.0\nproperty float x\nend_header\n").is_err());
        assert!(parse("ply\nformat ascii 1.0\nelement v 1\nproperty quad x\nend_header\n1\n").is_err());
        assert!(parse("PLY?\n").is_err());
    }
}
