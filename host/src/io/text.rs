//! Helpers shared by the text formats: lines, tokens, numbers, and float output that reads
//! back bit-exactly.

use std::io::{self, Write};

/// Physical lines with their 1-based numbers, without the `\n` or `\r\n` terminator.
pub(crate) fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    bytes
        .split(|&b| b == b'\n')
        .enumerate()
        .map(|(i, line)| (i + 1, line.strip_suffix(b"\r").unwrap_or(line)))
}

/// Whitespace-separated tokens of a line. Works on bytes: comments and names in other
/// encodings than UTF-8 must not stop a load.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty())
}

/// A token as it may appear in an error message: lossy and short.
pub(crate) fn shown(token: &[u8]) -> String {
    const MAX: usize = 40;
    let text = String::from_utf8_lossy(&token[..token.len().min(MAX)]);
    if token.len() > MAX { format!("{text}…") } else { text.into_owned() }
}

/// Parses a decimal number straight to the nearest `f32` (going through `f64` could round
/// twice). NaN and infinities parse; the caller rejects them with a vertex-level message.
#[inline]
pub(crate) fn parse_f32(token: &[u8]) -> Result<f32, String> {
    std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("'{}' is not a number", shown(token)))
}

/// Parses a decimal integer.
#[inline]
pub(crate) fn parse_i64(token: &[u8]) -> Result<i64, String> {
    std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| format!("'{}' is not an integer", shown(token)))
}

/// Writes an `f32` as the shortest decimal that parses back to the same bits (Rust's float
/// formatting guarantees that). Exponent form only for very small or large magnitudes, which
/// positional notation would spell with dozens of zeros.
pub(crate) fn write_f32(out: &mut dyn Write, value: f32) -> io::Result<()> {
    let magnitude = value.abs();
    if magnitude == 0.0 || (1e-5..1e16).contains(&magnitude) {
        write!(out, "{value}")
    } else {
        write!(out, "{value:e}")
    }
}

/// Writes three coordinates separated by spaces.
pub(crate) fn write_xyz(out: &mut dyn Write, p: &[f32]) -> io::Result<()> {
    write_f32(out, p[0])?;
    out.write_all(b" ")?;
    write_f32(out, p[1])?;
    out.write_all(b" ")?;
    write_f32(out, p[2])
}
