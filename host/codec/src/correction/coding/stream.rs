//! One coded stream: symbols under adaptive models, integers, raw bits and floats.
//!
//! Symbols are range coded; raw bits (the low bits of large integers, float bit patterns)
//! gain nothing from a model, so they go to a plain bit stream beside it, which is much
//! cheaper to read. Layout: varint byte length of the range-coded words, the words (u32
//! LE), then the raw bits packed in u32 LE words, least significant bit first.
//!
//! [`SymbolWriter`] and [`SymbolReader`] are mirror images; every `write_*` has a `read_*`
//! that consumes exactly what it wrote. A reader never panics on corrupt data: it returns
//! [`CorruptStream`], and stops at the first symbol the data cannot hold.

use constriction::stream::queue::{DefaultRangeDecoder, DefaultRangeEncoder};
use constriction::stream::{Decode, Encode};

use super::bytes::{ByteReader, put_varint};
use super::integer::{join, raw_bits, split, unzigzag, zigzag};
use super::model::AdaptiveModel;

/// The stream ended or held data no model can produce.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct CorruptStream;

pub(crate) struct SymbolWriter {
    coder: DefaultRangeEncoder,
    raw: Vec<u32>,
    /// Bits not yet in `raw`, the oldest lowest.
    pending: u64,
    pending_bits: u32,
}

impl SymbolWriter {
    pub(crate) fn new() -> Self {
        Self { coder: DefaultRangeEncoder::new(), raw: Vec::new(), pending: 0, pending_bits: 0 }
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

    /// The low `bits` bits (0..=32) of `value`, raw.
    pub(crate) fn raw(&mut self, bits: u32, value: u32) {
        let value = u64::from(value) & ((1u64 << bits) - 1);
        self.pending |= value << self.pending_bits;
        self.pending_bits += bits;
        if self.pending_bits >= 32 {
            self.raw.push(self.pending as u32);
            self.pending >>= 32;
            self.pending_bits -= 32;
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

    /// The compressed stream, as bytes.
    pub(crate) fn finish(mut self) -> Vec<u8> {
        if self.pending_bits > 0 {
            self.raw.push(self.pending as u32);
        }
        let words = self.coder.into_compressed().expect("a Vec backend cannot fail");
        let mut out = Vec::with_capacity(10 + 4 * (words.len() + self.raw.len()));
        put_varint(&mut out, 4 * words.len() as u64);
        out.extend(words.iter().chain(&self.raw).flat_map(|w| w.to_le_bytes()));
        out
    }
}

pub(crate) struct SymbolReader {
    coder: DefaultRangeDecoder,
    raw: Vec<u32>,
    /// The next raw word to load into `pending`.
    next_raw: usize,
    pending: u64,
    pending_bits: u32,
}

impl SymbolReader {
    /// A reader over a stream written by [`SymbolWriter::finish`].
    pub(crate) fn new(bytes: &[u8]) -> Result<Self, CorruptStream> {
        let mut r = ByteReader::new(bytes);
        let coded =
            usize::try_from(r.varint().map_err(|_| CorruptStream)?).map_err(|_| CorruptStream)?;
        let coded = r.take(coded).map_err(|_| CorruptStream)?;
        let raw = r.take(r.remaining()).map_err(|_| CorruptStream)?;
        let coder =
            DefaultRangeDecoder::from_compressed(words(coded)?).map_err(|_| CorruptStream)?;
        Ok(Self { coder, raw: words(raw)?, next_raw: 0, pending: 0, pending_bits: 0 })
    }

    pub(crate) fn symbol(&mut self, model: &mut AdaptiveModel) -> Result<usize, CorruptStream> {
        let symbol = self.coder.decode_symbol(&*model).map_err(|_| CorruptStream)?;
        model.update(symbol);
        Ok(symbol)
    }

    pub(crate) fn bit(&mut self, model: &mut AdaptiveModel) -> Result<bool, CorruptStream> {
        Ok(self.symbol(model)? == 1)
    }

    /// `bits` (0..=32) raw bits.
    pub(crate) fn raw(&mut self, bits: u32) -> Result<u32, CorruptStream> {
        if self.pending_bits < bits {
            let word = *self.raw.get(self.next_raw).ok_or(CorruptStream)?;
            self.next_raw += 1;
            self.pending |= u64::from(word) << self.pending_bits;
            self.pending_bits += 32;
        }
        let value = (self.pending & ((1u64 << bits) - 1)) as u32;
        self.pending >>= bits;
        self.pending_bits -= bits;
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

/// Little-endian u32 words; a length that is not a multiple of 4 is corrupt.
fn words(bytes: &[u8]) -> Result<Vec<u32>, CorruptStream> {
    if !bytes.len().is_multiple_of(4) {
        return Err(CorruptStream);
    }
    Ok(bytes.chunks_exact(4).map(|w| u32::from_le_bytes([w[0], w[1], w[2], w[3]])).collect())
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

        // 32 bytes of range-coded words, 32 of raw bits, all noise.
        let mut garbage = vec![32];
        garbage.extend((0..64u32).map(|i| (i.wrapping_mul(2654435761) >> 13) as u8));
        let mut r = SymbolReader::new(&garbage).unwrap();
        let mut model = int_model();
        for _ in 0..10_000 {
            if r.int(&mut model).is_err() || r.f32_bits().is_err() {
                break;
            }
        }
        assert!(SymbolReader::new(&garbage[..3]).is_err());
    }
}
