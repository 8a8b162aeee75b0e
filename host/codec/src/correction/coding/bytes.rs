//! Plain byte-level framing: fixed-width integers and LEB128 varints, read with bounds checks.

use super::integer::{unzigzag, zigzag};
use crate::quantize::{Grid, Spacing};

/// The data ended early, a varint was longer than its type, or a grid was invalid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FramingError {
    Truncated,
    BadVarint,
    BadGrid,
}

pub(crate) fn put_varint(out: &mut Vec<u8>, mut value: u64) {
    while value >= 0x80 {
        out.push((value as u8) | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
}

/// An optional grid: a varint 0 (none), 1 (binary: then the zigzagged step exponent of each
/// axis) or 2 (decimal: then the digit count of each axis).
pub(crate) fn put_grid(out: &mut Vec<u8>, grid: Option<Grid>) {
    match grid.map(|g| g.spacing()) {
        None => put_varint(out, 0),
        Some(Spacing::Binary(exponents)) => {
            put_varint(out, 1);
            exponents.iter().for_each(|&e| put_varint(out, u64::from(zigzag(e))));
        }
        Some(Spacing::Decimal(digits)) => {
            put_varint(out, 2);
            digits.iter().for_each(|&d| put_varint(out, u64::from(d)));
        }
    }
}

/// A cursor over untrusted bytes: every read checks what is left first.
pub(crate) struct ByteReader<'a> {
    bytes: &'a [u8],
}

impl<'a> ByteReader<'a> {
    pub(crate) fn new(bytes: &'a [u8]) -> Self {
        Self { bytes }
    }

    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len()
    }

    pub(crate) fn take(&mut self, n: usize) -> Result<&'a [u8], FramingError> {
        if n > self.bytes.len() {
            return Err(FramingError::Truncated);
        }
        let (head, rest) = self.bytes.split_at(n);
        self.bytes = rest;
        Ok(head)
    }

    pub(crate) fn array<const N: usize>(&mut self) -> Result<[u8; N], FramingError> {
        Ok(self.take(N)?.try_into().expect("took exactly N bytes"))
    }

    pub(crate) fn u16(&mut self) -> Result<u16, FramingError> {
        Ok(u16::from_le_bytes(self.array()?))
    }

    /// A LEB128 value of at most 64 bits; longer or overflowing encodings are refused.
    pub(crate) fn varint(&mut self) -> Result<u64, FramingError> {
        let mut value = 0u64;
        for shift in (0..64).step_by(7) {
            let [byte] = self.array()?;
            let part = u64::from(byte & 0x7f);
            if shift == 63 && part > 1 {
                return Err(FramingError::BadVarint);
            }
            value |= part << shift;
            if byte & 0x80 == 0 {
                return Ok(value);
            }
        }
        Err(FramingError::BadVarint)
    }

    /// What [`put_grid`] wrote.
    pub(crate) fn grid(&mut self) -> Result<Option<Grid>, FramingError> {
        let flag = self.varint()?;
        let mut axes = [0u32; 3];
        if flag == 1 || flag == 2 {
            for axis in &mut axes {
                *axis = u32::try_from(self.varint()?).map_err(|_| FramingError::BadGrid)?;
            }
        }
        let grid = match flag {
            0 => return Ok(None),
            1 => Grid::from_exponents(axes.map(unzigzag)),
            2 => axes
                .iter()
                .all(|&d| d <= 255)
                .then(|| axes.map(|d| d as u8))
                .and_then(Grid::from_digits),
            _ => None,
        };
        grid.map(Some).ok_or(FramingError::BadGrid)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn varints_round_trip_and_refuse_overflow_and_truncation() {
        let mut out = Vec::new();
        for v in [0, 1, 127, 128, 300, u32::MAX as u64, u64::MAX] {
            out.clear();
            put_varint(&mut out, v);
            assert_eq!(ByteReader::new(&out).varint(), Ok(v));
            assert_eq!(
                ByteReader::new(&out[..out.len() - 1]).varint(),
                Err(FramingError::Truncated)
            );
        }
        assert_eq!(ByteReader::new(&[0xff; 11]).varint(), Err(FramingError::BadVarint));
        let mut r = ByteReader::new(&[1, 2, 3]);
        assert_eq!(r.u16(), Ok(0x0201));
        assert_eq!(r.take(2), Err(FramingError::Truncated));
    }

    #[test]
    fn grids_round_trip_and_refuse_bad_flags_and_steps() {
        for grid in [None, Grid::from_exponents([-149, 0, 127]), Grid::from_digits([0, 6, 12])] {
            let mut out = Vec::new();
            put_grid(&mut out, grid);
            assert_eq!(ByteReader::new(&out).grid(), Ok(grid));
        }
        assert_eq!(ByteReader::new(&[3]).grid(), Err(FramingError::BadGrid));
        assert_eq!(ByteReader::new(&[2, 6, 6, 13]).grid(), Err(FramingError::BadGrid));
        assert_eq!(ByteReader::new(&[1, 0, 0, 0xfe, 3]).grid(), Err(FramingError::BadGrid));
    }
}

/// The sealed front all three file formats share: magic, version (u16 LE), then a 16-byte
/// BLAKE3 checksum of every byte after it.
const CHECKSUM_LEN: usize = 16;
const CHECKSUM_AT: usize = 6;
/// The bytes of the sealed front: what follows it is the format's own.
pub(crate) const SEALED_FRONT: usize = CHECKSUM_AT + CHECKSUM_LEN;

/// Why a sealed file's front was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum SealError {
    BadMagic,
    UnsupportedVersion(u16),
    Truncated,
    ChecksumMismatch,
}

/// Starts a sealed file: magic, version and room for the checksum [`seal`] fills in.
pub(crate) fn sealed_front(magic: [u8; 4], version: u16, capacity: usize) -> Vec<u8> {
    let mut out = Vec::with_capacity(CHECKSUM_AT + CHECKSUM_LEN + capacity);
    out.extend_from_slice(&magic);
    out.extend_from_slice(&version.to_le_bytes());
    out.extend_from_slice(&[0; CHECKSUM_LEN]);
    out
}

/// Fills in the checksum of a file begun with [`sealed_front`].
pub(crate) fn seal(out: &mut [u8]) {
    let checksum = blake3::hash(&out[SEALED_FRONT..]);
    out[CHECKSUM_AT..CHECKSUM_AT + CHECKSUM_LEN]
        .copy_from_slice(&checksum.as_bytes()[..CHECKSUM_LEN]);
}

/// Checks magic, version and checksum; a reader over what follows them.
pub(crate) fn open_sealed(
    bytes: &[u8],
    magic: [u8; 4],
    version: u16,
) -> Result<ByteReader<'_>, SealError> {
    Ok(open_sealed_versions(bytes, magic, version..=version)?.0)
}

/// [`open_sealed`] for a format read in several versions; which one it is.
pub(crate) fn open_sealed_versions(
    bytes: &[u8],
    magic: [u8; 4],
    versions: std::ops::RangeInclusive<u16>,
) -> Result<(ByteReader<'_>, u16), SealError> {
    let mut r = ByteReader::new(bytes);
    if r.take(4).map_err(|_| SealError::BadMagic)? != magic {
        return Err(SealError::BadMagic);
    }
    let found = r.u16().map_err(|_| SealError::Truncated)?;
    if !versions.contains(&found) {
        return Err(SealError::UnsupportedVersion(found));
    }
    let checksum = r.take(CHECKSUM_LEN).map_err(|_| SealError::Truncated)?;
    if blake3::hash(&bytes[SEALED_FRONT..]).as_bytes()[..CHECKSUM_LEN] != *checksum {
        return Err(SealError::ChecksumMismatch);
    }
    Ok((r, found))
}
