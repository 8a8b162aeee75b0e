//! Plain byte-level framing: fixed-width integers and LEB128 varints, read with bounds checks.

/// The data ended early, or a varint was longer than its type.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum FramingError {
    Truncated,
    BadVarint,
}

pub(crate) fn put_varint(out: &mut Vec<u8>, mut value: u64) {
    while value >= 0x80 {
        out.push((value as u8) | 0x80);
        value >>= 7;
    }
    out.push(value as u8);
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
}
