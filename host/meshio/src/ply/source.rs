//! Where PLY body values come from: ascii tokens or binary bytes in either byte order.
//!
//! The element readers are generic over [`Source`], so ascii, little and big endian share one
//! reading logic and each is compiled into a loop without dynamic dispatch.

use std::marker::PhantomData;

use super::super::error::{Invalid, Position, ReadResult};
use super::super::text::{parse_f32, parse_i64, shown};
use super::header::{Kind, Scalar};

/// A cursor over the body.
pub(super) trait Source {
    /// Where the last value read started: errors about a value point at it.
    fn last_at(&self) -> Position;
    /// Bytes not read yet.
    fn remaining(&self) -> usize;
    /// Reads a scalar of type `ty` as an `f32` (nearest value).
    fn coordinate(&mut self, ty: Scalar) -> ReadResult<f32>;
    /// Reads a `double` coordinate: its exact value and the `f32` [`Source::coordinate`]
    /// gives for it.
    fn double_coordinate(&mut self) -> ReadResult<(f64, f32)>;
    /// Reads a scalar of integer type `ty`.
    fn integer(&mut self, ty: Scalar) -> ReadResult<i64>;
    /// Reads a scalar of any type `ty` exactly (`f64` holds every PLY number).
    fn value(&mut self, ty: Scalar) -> ReadResult<f64>;
    /// Skips one property value (a scalar or a whole list).
    fn skip(&mut self, kind: Kind) -> ReadResult<()>;
    /// Skips `n` values of type `item` (a list's items, its length already read).
    fn skip_items(&mut self, item: Scalar, n: usize) -> ReadResult<()>;
    /// Binary only: the unread bytes and the file offset of their start, so the common
    /// layouts can be decoded in bulk instead of value by value. `None` for ascii.
    fn unread(&self) -> Option<(&[u8], usize)>;
    /// Marks `len` bytes of [`Source::unread`] as read.
    fn consume(&mut self, len: usize);
    /// Binary only: decodes a scalar at the start of `bytes` as an `f32`.
    fn decode_f32(ty: Scalar, bytes: &[u8]) -> f32;
    /// Binary only: decodes a `double` at the start of `bytes`.
    fn decode_f64(bytes: &[u8]) -> f64;
    /// Binary only: decodes an integer scalar at the start of `bytes`.
    fn decode_int(ty: Scalar, bytes: &[u8]) -> i64;
    /// Binary only: decodes a scalar of any type at the start of `bytes`, exactly.
    fn decode_value(ty: Scalar, bytes: &[u8]) -> f64;
}

/// The error for a binary body that ends before `needed` bytes at file offset `at`.
pub(super) fn truncated(at: usize, needed: usize, left: usize) -> Invalid {
    Invalid::byte(at, format!("the file is truncated: {needed} more bytes needed, {left} left"))
}

/// Byte order of a binary body.
pub(super) trait Order {
    fn u16(bytes: [u8; 2]) -> u16;
    fn u32(bytes: [u8; 4]) -> u32;
    fn u64(bytes: [u8; 8]) -> u64;
}

pub(super) struct LittleEndian;
pub(super) struct BigEndian;

impl Order for LittleEndian {
    fn u16(bytes: [u8; 2]) -> u16 {
        u16::from_le_bytes(bytes)
    }
    fn u32(bytes: [u8; 4]) -> u32 {
        u32::from_le_bytes(bytes)
    }
    fn u64(bytes: [u8; 8]) -> u64 {
        u64::from_le_bytes(bytes)
    }
}

impl Order for BigEndian {
    fn u16(bytes: [u8; 2]) -> u16 {
        u16::from_be_bytes(bytes)
    }
    fn u32(bytes: [u8; 4]) -> u32 {
        u32::from_be_bytes(bytes)
    }
    fn u64(bytes: [u8; 8]) -> u64 {
        u64::from_be_bytes(bytes)
    }
}

/// A binary body in byte order `O`.
pub(super) struct Binary<'a, O> {
    bytes: &'a [u8],
    pos: usize,
    /// File offset of `bytes[0]`, so errors give offsets in the file.
    base: usize,
    last: usize,
    order: PhantomData<O>,
}

impl<'a, O: Order> Binary<'a, O> {
    pub fn new(bytes: &'a [u8], base: usize) -> Self {
        Self { bytes, pos: 0, base, last: 0, order: PhantomData }
    }

    #[inline]
    fn take(&mut self, len: usize) -> ReadResult<&'a [u8]> {
        let remaining = self.bytes.len() - self.pos;
        if len > remaining {
            return Err(truncated(self.base + self.pos, len, remaining));
        }
        self.last = self.pos;
        self.pos += len;
        Ok(&self.bytes[self.last..self.pos])
    }
}

#[inline]
fn array<const N: usize>(bytes: &[u8]) -> [u8; N] {
    bytes[..N].try_into().expect("caller took enough bytes")
}

impl<O: Order> Source for Binary<'_, O> {
    fn last_at(&self) -> Position {
        Position::Byte((self.base + self.last) as u64)
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    #[inline]
    fn coordinate(&mut self, ty: Scalar) -> ReadResult<f32> {
        Ok(Self::decode_f32(ty, self.take(ty.size())?))
    }

    fn double_coordinate(&mut self) -> ReadResult<(f64, f32)> {
        let exact = Self::decode_f64(self.take(8)?);
        Ok((exact, exact as f32))
    }

    #[inline]
    fn integer(&mut self, ty: Scalar) -> ReadResult<i64> {
        Ok(Self::decode_int(ty, self.take(ty.size())?))
    }

    #[inline]
    fn value(&mut self, ty: Scalar) -> ReadResult<f64> {
        Ok(Self::decode_value(ty, self.take(ty.size())?))
    }

    fn skip(&mut self, kind: Kind) -> ReadResult<()> {
        match kind {
            Kind::Scalar(ty) => self.take(ty.size()).map(drop),
            Kind::List { count, item } => {
                let n = self.integer(count)?;
                let n = usize::try_from(n).map_err(|_| {
                    Invalid::at(self.last_at(), format!("negative list length {n}"))
                })?;
                self.take(n.saturating_mul(item.size())).map(drop)
            }
        }
    }

    fn skip_items(&mut self, item: Scalar, n: usize) -> ReadResult<()> {
        self.take(n.saturating_mul(item.size())).map(drop)
    }

    fn unread(&self) -> Option<(&[u8], usize)> {
        Some((&self.bytes[self.pos..], self.base + self.pos))
    }

    fn consume(&mut self, len: usize) {
        self.last = self.pos;
        self.pos += len;
    }

    #[inline]
    fn decode_f32(ty: Scalar, b: &[u8]) -> f32 {
        match ty {
            Scalar::F32 => f32::from_bits(O::u32(array(b))),
            Scalar::F64 => f64::from_bits(O::u64(array(b))) as f32,
            _ => Self::decode_int(ty, b) as f32,
        }
    }

    fn decode_f64(b: &[u8]) -> f64 {
        f64::from_bits(O::u64(array(b)))
    }

    #[inline]
    fn decode_int(ty: Scalar, b: &[u8]) -> i64 {
        match ty {
            Scalar::I8 => i64::from(b[0] as i8),
            Scalar::U8 => i64::from(b[0]),
            Scalar::I16 => i64::from(O::u16(array(b)) as i16),
            Scalar::U16 => i64::from(O::u16(array(b))),
            Scalar::I32 => i64::from(O::u32(array(b)) as i32),
            Scalar::U32 => i64::from(O::u32(array(b))),
            // Headers with float lists are rejected before reading; truncate if one slips by.
            Scalar::F32 => f32::from_bits(O::u32(array(b))) as i64,
            Scalar::F64 => f64::from_bits(O::u64(array(b))) as i64,
        }
    }

    #[inline]
    fn decode_value(ty: Scalar, b: &[u8]) -> f64 {
        match ty {
            Scalar::F32 => f64::from(f32::from_bits(O::u32(array(b)))),
            Scalar::F64 => f64::from_bits(O::u64(array(b))),
            _ => Self::decode_int(ty, b) as f64,
        }
    }
}

/// An ascii body: whitespace-separated tokens; line numbers for errors.
pub(super) struct Ascii<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Line of the current position.
    line: usize,
    /// Line of the last token read.
    last_line: usize,
}

impl<'a> Ascii<'a> {
    pub fn new(bytes: &'a [u8], first_line: usize) -> Self {
        Self { bytes, pos: 0, line: first_line, last_line: first_line }
    }

    fn token(&mut self) -> ReadResult<&'a [u8]> {
        let bytes = self.bytes;
        while let Some(&b) = bytes.get(self.pos).filter(|b| b.is_ascii_whitespace()) {
            self.line += usize::from(b == b'\n');
            self.pos += 1;
        }
        if self.pos == bytes.len() {
            return Err(Invalid::line(self.line, "the file is truncated: more values expected"));
        }
        let start = self.pos;
        while bytes.get(self.pos).is_some_and(|b| !b.is_ascii_whitespace()) {
            self.pos += 1;
        }
        self.last_line = self.line;
        Ok(&bytes[start..self.pos])
    }
}

impl Source for Ascii<'_> {
    fn last_at(&self) -> Position {
        Position::Line(self.last_line)
    }

    fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    fn coordinate(&mut self, _ty: Scalar) -> ReadResult<f32> {
        // Straight to f32 whatever the declared type: one rounding from the decimal text.
        let token = self.token()?;
        parse_f32(token).map_err(|reason| Invalid::line(self.last_line, reason.to_string()))
    }

    fn double_coordinate(&mut self) -> ReadResult<(f64, f32)> {
        let token = self.token()?;
        let invalid = |reason: String| Invalid::line(self.last_line, reason);
        // The f32 straight from the text, as `coordinate` reads it (not via the double).
        let rounded = parse_f32(token).map_err(|reason| invalid(reason.to_string()))?;
        let exact = std::str::from_utf8(token).ok().and_then(|t| t.parse::<f64>().ok());
        Ok((exact.unwrap_or(f64::from(rounded)), rounded))
    }

    fn integer(&mut self, _ty: Scalar) -> ReadResult<i64> {
        let token = self.token()?;
        parse_i64(token).map_err(|reason| Invalid::line(self.last_line, reason.to_string()))
    }

    fn value(&mut self, ty: Scalar) -> ReadResult<f64> {
        let token = self.token()?;
        let invalid = |reason: String| Invalid::line(self.last_line, reason);
        match ty {
            // Straight to f32, as coordinates are: one rounding from the decimal text.
            Scalar::F32 => parse_f32(token).map(f64::from).map_err(|r| invalid(r.to_string())),
            // Integers written as `255.0` by some writers are taken too.
            _ => std::str::from_utf8(token)
                .ok()
                .and_then(|t| t.parse::<i64>().map(|i| i as f64).ok().or_else(|| t.parse().ok()))
                .ok_or_else(|| invalid(format!("'{}' is not a number", shown(token)))),
        }
    }

    fn skip(&mut self, kind: Kind) -> ReadResult<()> {
        match kind {
            Kind::Scalar(_) => self.token().map(drop),
            Kind::List { count, .. } => {
                let n = self.integer(count)?;
                if n < 0 {
                    return Err(Invalid::line(self.last_line, format!("negative list length {n}")));
                }
                (0..n).try_for_each(|_| self.token().map(drop))
            }
        }
    }

    fn skip_items(&mut self, _item: Scalar, n: usize) -> ReadResult<()> {
        (0..n).try_for_each(|_| self.token().map(drop))
    }

    fn unread(&self) -> Option<(&[u8], usize)> {
        None
    }

    fn consume(&mut self, _len: usize) {
        unreachable!("ascii bodies are read token by token")
    }

    fn decode_f32(_ty: Scalar, _bytes: &[u8]) -> f32 {
        unreachable!("ascii bodies are read token by token")
    }

    fn decode_f64(_bytes: &[u8]) -> f64 {
        unreachable!("ascii bodies are read token by token")
    }

    fn decode_int(_ty: Scalar, _bytes: &[u8]) -> i64 {
        unreachable!("ascii bodies are read token by token")
    }

    fn decode_value(_ty: Scalar, _bytes: &[u8]) -> f64 {
        unreachable!("ascii bodies are read token by token")
    }
}
