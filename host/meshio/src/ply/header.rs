//! The PLY header: format, elements and their properties, up to `end_header`.
//!
//! Parsed here rather than with `ply-rs-bw`: its header keeps elements and properties in maps
//! keyed by name, so a file with a repeated name would be mis-sized silently, and its errors
//! are multi-line debug dumps rather than one line with a line number.

use std::collections::HashSet;

use super::super::error::{Invalid, ReadResult};
use super::super::text::{self, shown};

/// A PLY scalar type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn from_name(name: &[u8]) -> Option<Scalar> {
        Some(match name {
            b"char" | b"int8" => Scalar::I8,
            b"uchar" | b"uint8" => Scalar::U8,
            b"short" | b"int16" => Scalar::I16,
            b"ushort" | b"uint16" => Scalar::U16,
            b"int" | b"int32" => Scalar::I32,
            b"uint" | b"uint32" => Scalar::U32,
            b"float" | b"float32" => Scalar::F32,
            b"double" | b"float64" => Scalar::F64,
            _ => return None,
        })
    }

    /// Size in binary encodings.
    pub fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }

    pub fn is_integer(self) -> bool {
        !matches!(self, Scalar::F32 | Scalar::F64)
    }
}

/// A property's type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Kind {
    Scalar(Scalar),
    /// A count of type `count`, then that many values of type `item`.
    List {
        count: Scalar,
        item: Scalar,
    },
}

#[derive(Clone, Debug)]
pub(super) struct Property {
    pub name: String,
    pub kind: Kind,
}

#[derive(Clone, Debug)]
pub(super) struct Element {
    pub name: String,
    pub count: u64,
    pub properties: Vec<Property>,
    /// Header line declaring the element, for errors about the declaration.
    pub line: usize,
}

impl Element {
    /// The record size when every property is a scalar, i.e. records are fixed-size.
    pub fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                Kind::Scalar(s) => Some(s.size()),
                Kind::List { .. } => None,
            })
            .sum()
    }

    /// The fewest body bytes one record can take: lists may be empty; in ascii every value
    /// is at least one digit and one separator.
    pub fn min_size(&self, encoding: Encoding) -> usize {
        self.properties
            .iter()
            .map(|p| match (encoding, p.kind) {
                (Encoding::Ascii, _) => 2,
                (_, Kind::Scalar(s)) => s.size(),
                (_, Kind::List { count, .. }) => count.size(),
            })
            .sum()
    }

    pub fn property(&self, name: &str) -> Option<usize> {
        self.properties.iter().position(|p| p.name == name)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Encoding {
    Ascii,
    BinaryLittleEndian,
    BinaryBigEndian,
}

#[derive(Clone, Debug)]
pub(super) struct Header {
    pub encoding: Encoding,
    pub elements: Vec<Element>,
    /// Byte offset where the body starts.
    pub body_offset: usize,
    /// Line number of the body's first line (for ascii errors).
    pub body_line: usize,
    /// The text of each `comment` line after the keyword, trimmed (`TextureFile skin.png`).
    pub comments: Vec<String>,
}

/// Parses the header at the start of `bytes`.
pub(super) fn parse(bytes: &[u8]) -> ReadResult<Header> {
    let mut encoding = None;
    let mut elements: Vec<Element> = Vec::new();
    // Names seen so far, so that a header of many properties is read in linear time.
    let mut element_names = HashSet::new();
    let mut property_names = HashSet::new();
    let mut comments = Vec::new();
    let mut offset = 0;
    for (number, line) in text::lines(bytes) {
        offset += line.len() + 1;
        // `text::lines` strips a '\r'; count it back for the body offset.
        if bytes.get(offset - 1) == Some(&b'\r') {
            offset += 1;
        }
        let error = |reason: String| Invalid::line(number, reason);
        let mut tokens = text::tokens(line);
        let keyword = tokens.next();
        if number == 1 {
            if keyword != Some(b"ply") {
                return Err(error("not a PLY file: it does not start with 'ply'".into()));
            }
            continue;
        }
        match keyword {
            Some(b"format") => {
                encoding = Some(match tokens.next() {
                    Some(b"ascii") => Encoding::Ascii,
                    Some(b"binary_little_endian") => Encoding::BinaryLittleEndian,
                    Some(b"binary_big_endian") => Encoding::BinaryBigEndian,
                    other => {
                        return Err(error(format!(
                            "unknown PLY format '{}'",
                            shown(other.unwrap_or(b""))
                        )));
                    }
                });
            }
            Some(b"element") => {
                let (Some(name), Some(count)) = (tokens.next(), tokens.next()) else {
                    return Err(error("expected 'element <name> <count>'".into()));
                };
                let count = std::str::from_utf8(count)
                    .ok()
                    .and_then(|c| c.parse::<u64>().ok())
                    .ok_or_else(|| {
                        error(format!("element count '{}' is not a count", shown(count)))
                    })?;
                let name = String::from_utf8_lossy(name).into_owned();
                if !element_names.insert(name.clone()) {
                    return Err(error(format!("element '{name}' is declared twice")));
                }
                property_names.clear();
                elements.push(Element { name, count, properties: Vec::new(), line: number });
            }
            Some(b"property") => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| error("property before any element".into()))?;
                let property = parse_property(tokens).map_err(|e| error(e.to_string()))?;
                if !property_names.insert(property.name.clone()) {
                    return Err(error(format!("property '{}' is declared twice", property.name)));
                }
                element.properties.push(property);
            }
            Some(b"end_header") => {
                let encoding =
                    encoding.ok_or_else(|| error("no 'format' line before 'end_header'".into()))?;
                let body_offset = offset.min(bytes.len());
                return Ok(Header {
                    encoding,
                    elements,
                    body_offset,
                    body_line: number + 1,
                    comments,
                });
            }
            Some(b"comment") => {
                let start = line.windows(7).position(|w| w == b"comment").unwrap_or(0) + 7;
                comments.push(String::from_utf8_lossy(line[start..].trim_ascii()).into_owned());
            }
            Some(b"obj_info") | None => {}
            Some(other) => {
                return Err(error(format!("unexpected '{}' in the PLY header", shown(other))));
            }
        }
    }
    Err(Invalid::whole("the PLY header has no 'end_header' line"))
}

/// Why a `property` line of the header was refused.
#[derive(Debug, thiserror::Error)]
enum PropertyError {
    #[error("unknown property type '{0}'")]
    UnknownType(String),
    #[error("a list count must have an integer type")]
    ListCountNotInteger,
    #[error("a property needs a name")]
    NoName,
}

fn parse_property<'a>(
    mut tokens: impl Iterator<Item = &'a [u8]>,
) -> Result<Property, PropertyError> {
    let scalar = |token: Option<&[u8]>| {
        let token = token.unwrap_or(b"");
        Scalar::from_name(token).ok_or_else(|| PropertyError::UnknownType(shown(token)))
    };
    let first = tokens.next();
    let kind = if first == Some(b"list") {
        let count = scalar(tokens.next())?;
        let item = scalar(tokens.next())?;
        if !count.is_integer() {
            return Err(PropertyError::ListCountNotInteger);
        }
        Kind::List { count, item }
    } else {
        Kind::Scalar(scalar(first)?)
    };
    let name = tokens.next().ok_or(PropertyError::NoName)?;
    Ok(Property { name: String::from_utf8_lossy(name).into_owned(), kind })
}
