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

/// A token that is not the number it should be; the token as [`shown`].
#[derive(Debug, thiserror::Error)]
pub(crate) enum NumberError {
    #[error("'{0}' is not a number")]
    NotANumber(String),
    #[error("'{0}' is not an integer")]
    NotAnInteger(String),
}

/// Parses a decimal number straight to the nearest `f32` (going through `f64` could round
/// twice). NaN and infinities parse; the caller rejects them with a vertex-level message.
#[inline]
pub(crate) fn parse_f32(token: &[u8]) -> Result<f32, NumberError> {
    std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| NumberError::NotANumber(shown(token)))
}

/// Parses a decimal integer.
#[inline]
pub(crate) fn parse_i64(token: &[u8]) -> Result<i64, NumberError> {
    std::str::from_utf8(token)
        .ok()
        .and_then(|s| s.parse().ok())
        .ok_or_else(|| NumberError::NotAnInteger(shown(token)))
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

/// Writes an `f64` as the shortest decimal that parses back to the same bits.
pub(crate) fn write_f64(out: &mut dyn Write, value: f64) -> io::Result<()> {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_floats_parse_back_to_the_same_bits() {
        // A spread of bit patterns over every exponent, both signs, subnormals included.
        let samples =
            (0..=u32::MAX).step_by(65_521).chain([0, 1, 0x8000_0000, 0x7f7f_ffff, 0x0080_0000]);
        for bits in samples {
            let value = f32::from_bits(bits);
            if !value.is_finite() {
                continue;
            }
            let mut out = Vec::new();
            write_f32(&mut out, value).unwrap();
            let back = parse_f32(&out).unwrap();
            assert_eq!(
                back.to_bits(),
                bits,
                "{value:e} written as {}",
                String::from_utf8_lossy(&out)
            );
        }
    }

    #[test]
    fn lines_and_tokens_handle_crlf_and_any_whitespace() {
        let text = b"a b\r\n\tc\x0b d \n\nlast";
        let lines: Vec<(usize, &[u8])> = lines(text).collect();
        assert_eq!(lines, [(1, &b"a b"[..]), (2, b"\tc\x0b d "), (3, b""), (4, b"last")]);
        assert_eq!(tokens(b"  x\t y  ").collect::<Vec<_>>(), [b"x", b"y"]);
    }

    #[test]
    fn long_tokens_are_shortened_in_messages() {
        assert_eq!(shown(b"abc"), "abc");
        assert_eq!(shown(&[b'7'; 100]).chars().count(), 41);
    }
}
