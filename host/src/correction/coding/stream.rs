//! One range-coded stream: symbols under adaptive models, integers, raw bits and floats.
//!
//! [`SymbolWriter`] and [`SymbolReader`] are mirror images; every `write_*` has a `read_*`
//! that consumes exactly what it wrote. A reader never panics on corrupt data: it returns
//! [`CorruptStream`], and stops at the first symbol the data cannot hold.

use constriction::stream::queue::{DefaultRangeDecoder, DefaultRangeEncoder};
use constriction::stream::{Decode, Encode};

use super::integer::{join, raw_bits, split, unzigzag, zigzag};
use super::model::{AdaptiveModel, UniformBits};

/// Raw bits are coded at most this many at a time (the model precision bounds it).
const RAW_CHUNK: u32 = 16;

/// The stream ended or held data no model can produce.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct CorruptStream;

pub(crate) struct SymbolWriter {
    coder: DefaultRangeEncoder,
}

impl SymbolWriter {
    pub(crate) fn new() -> Self {
        Self { coder: DefaultRangeEncoder::new() }
    }

    pub(crate) fn symbol(&mut self, model: &mut AdaptiveModel, symbol: usize) {
        debug_assert!(symbol < model.symbols());
        self.coder
            .encode_symbol(symbol, &*model)
            .expect("symbols in range always encode into a growable buffer");
        model.update(symbol);
    }

    pub(crate) fn bit(&mut self, model: &mut AdaptiveModel, bit: bool) {
        self.symbol(model, usize::from(bit));
    }

    /// The low `bits` bits of `value`, raw.
    pub(crate) fn raw(&mut self, mut bits: u32, mut value: u32) {
        while bits > 0 {
            let chunk = bits.min(RAW_CHUNK);
            let part = value & ((1 << chunk) - 1);
            self.coder
                .encode_symbol(part, UniformBits { bits: chunk })
                .expect("chunk-sized values always encode");
            value = value.checked_shr(chunk).unwrap_or(0);
            bits -= chunk;
        }
    }

    pub(crate) fn uint(&mut self, model: &mut AdaptiveModel, value: u32) {
        let (bucket, bits, raw) = split(value);
        self.symbol(model, bucket);
        self.raw(bits, raw);
    }

    pub(crate) fn int(&mut self, model: &mut AdaptiveModel, value: i32) {
        self.uint(model, zigzag(value));
    }

    /// A float's exact bits, with no model: for rare values without a prediction.
    pub(crate) fn f32_bits(&mut self, value: f32) {
        self.raw(32, value.to_bits());
    }

    /// The compressed stream, as little-endian bytes.
    pub(crate) fn finish(self) -> Vec<u8> {
        let words = self.coder.into_compressed().expect("a Vec backend cannot fail");
        words.iter().flat_map(|w| w.to_le_bytes()).collect()
    }
}

pub(crate) struct SymbolReader {
    coder: DefaultRangeDecoder,
}

impl SymbolReader {
    /// A reader over a stream written by [`SymbolWriter::finish`].
    pub(crate) fn new(bytes: &[u8]) -> Result<Self, CorruptStream> {
        if !bytes.len().is_multiple_of(4) {
            return Err(CorruptStream);
        }
        let words: Vec<u32> =
            bytes.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect();
        let coder = DefaultRangeDecoder::from_compressed(words).map_err(|_| CorruptStream)?;
        Ok(Self { coder })
    }

    pub(crate) fn symbol(&mut self, model: &mut AdaptiveModel) -> Result<usize, CorruptStream> {
        let symbol = self.coder.decode_symbol(&*model).map_err(|_| CorruptStream)?;
        model.update(symbol);
        Ok(symbol)
    }

    pub(crate) fn bit(&mut self, model: &mut AdaptiveModel) -> Result<bool, CorruptStream> {
        Ok(self.symbol(model)? == 1)
    }

    pub(crate) fn raw(&mut self, bits: u32) -> Result<u32, CorruptStream> {
        let (mut value, mut shift, mut left) = (0u32, 0u32, bits);
        while left > 0 {
            let chunk = left.min(RAW_CHUNK);
            let part =
                self.coder.decode_symbol(UniformBits { bits: chunk }).map_err(|_| CorruptStream)?;
            value |= part << shift;
            shift += chunk;
            left -= chunk;
        }
        Ok(value)
    }

    pub(crate) fn uint(&mut self, model: &mut AdaptiveModel) -> Result<u32, CorruptStream> {
        let bucket = self.symbol(model)?;
        let raw = self.raw(raw_bits(bucket))?;
        Ok(join(bucket, raw))
    }

    pub(crate) fn int(&mut self, model: &mut AdaptiveModel) -> Result<i32, CorruptStream> {
        Ok(unzigzag(self.uint(model)?))
    }

    pub(crate) fn f32_bits(&mut self) -> Result<f32, CorruptStream> {
        Ok(f32::from_bits(self.raw(32)?))
    }
}

#[cfg(test)]
mod tests {
    use super::super::integer::int_model;
    use super::*;

    #[test]
    fn everything_written_reads_back_and_garbage_never_panics() {
        let values: Vec<i32> = (-500..500).chain([i32::MIN, i32::MAX, 1 << 20]).collect();
        let mut w = SymbolWriter::new();
        let mut model = int_model();
        let mut flag = AdaptiveModel::new(2);
        for &v in &values {
            w.int(&mut model, v);
            w.bit(&mut flag, v % 3 == 0);
            w.f32_bits(v as f32 * 0.25);
        }
        let bytes = w.finish();
        let mut r = SymbolReader::new(&bytes).unwrap();
        let (mut model, mut flag) = (int_model(), AdaptiveModel::new(2));
        for &v in &values {
            assert_eq!(r.int(&mut model), Ok(v));
            assert_eq!(r.bit(&mut flag), Ok(v % 3 == 0));
            assert_eq!(r.f32_bits().map(f32::to_bits), Ok((v as f32 * 0.25).to_bits()));
        }

        let garbage: Vec<u8> =
            (0..64u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8).collect();
        let mut r = SymbolReader::new(&garbage).unwrap();
        let mut model = int_model();
        for _ in 0..10_000 {
            if r.int(&mut model).is_err() {
                break;
            }
        }
        assert!(SymbolReader::new(&garbage[..3]).is_err());
    }
}
