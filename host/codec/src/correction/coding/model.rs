//! The entropy model for constriction's range coder: an adaptive categorical distribution.
//!
//! Encoder and decoder update an [`AdaptiveModel`] identically after every symbol, with
//! integer arithmetic only, so both sides always hold the same distribution and no table is
//! ever transmitted.

use std::num::NonZeroU32;

use constriction::stream::model::{DecoderModel, EncoderModel, EntropyModel};

/// Fixed-point precision of every model: probabilities are multiples of `2^-24`.
pub(crate) const PRECISION: usize = 24;
const ONE: u32 = 1 << PRECISION;
/// Count added per observed symbol; larger adapts faster relative to the initial counts.
const INCREMENT: u32 = 32;
/// Counts are halved when their sum passes this, so the model tracks drifting statistics and
/// no symbol's probability ever falls below about `2^-16`.
const MAX_TOTAL: u32 = 1 << 16;
/// The CDF is rebuilt after this many updates at most; early on it is rebuilt more often.
const MAX_REBUILD_INTERVAL: u32 = 256;
/// Decoding starts its search for a quantile's symbol at `lookup[quantile >> LOOKUP_SHIFT]`:
/// a binary search over the CDF is a chain of dependent loads, and was most of the decode
/// time; from the table, the symbol is usually found at once or one step on.
const LOOKUP_SHIFT: usize = PRECISION - 8;

/// A categorical distribution over `0..n` learnt from the symbols coded so far.
#[derive(Clone, Debug)]
pub(crate) struct AdaptiveModel {
    counts: Vec<u32>,
    total: u32,
    /// `cdf[s]` is the left cumulative of symbol `s`; `cdf[n] == 2^PRECISION`.
    cdf: Vec<u32>,
    /// `lookup[j]` is the symbol whose interval holds quantile `j << LOOKUP_SHIFT`.
    lookup: [u8; 1 << (PRECISION - LOOKUP_SHIFT)],
    until_rebuild: u32,
    interval: u32,
}

impl AdaptiveModel {
    /// A uniform start over `symbols` symbols (2 ..= 256).
    pub(crate) fn new(symbols: usize) -> Self {
        debug_assert!((2..=256).contains(&symbols));
        let mut model = Self {
            counts: vec![1; symbols],
            total: symbols as u32,
            cdf: vec![0; symbols + 1],
            lookup: [0; 1 << (PRECISION - LOOKUP_SHIFT)],
            until_rebuild: 1,
            interval: 1,
        };
        model.rebuild();
        model
    }

    pub(crate) fn symbols(&self) -> usize {
        self.counts.len()
    }

    /// Learns from one coded symbol.
    pub(crate) fn update(&mut self, symbol: usize) {
        self.counts[symbol] += INCREMENT;
        self.total += INCREMENT;
        if self.total > MAX_TOTAL {
            self.total = 0;
            for c in &mut self.counts {
                *c = c.div_ceil(2);
                self.total += *c;
            }
        }
        self.until_rebuild -= 1;
        if self.until_rebuild == 0 {
            self.rebuild();
            self.interval = (self.interval * 2).min(MAX_REBUILD_INTERVAL);
            self.until_rebuild = self.interval;
        }
    }

    /// Every symbol keeps at least one unit; the rounding remainder goes to the first most
    /// frequent symbol. Integer-only, so every host builds the same table.
    fn rebuild(&mut self) {
        let n = self.counts.len() as u64;
        let free = u64::from(ONE) - n;
        let total = u64::from(self.total);
        let mut sum = 0u32;
        let mut best = 0;
        for (s, &c) in self.counts.iter().enumerate() {
            self.cdf[s] = sum;
            sum += 1 + (u64::from(c) * free / total) as u32;
            if c > self.counts[best] {
                best = s;
            }
        }
        let remainder = ONE - sum;
        for cdf in &mut self.cdf[best + 1..] {
            *cdf += remainder;
        }
        *self.cdf.last_mut().expect("n + 1 entries") = ONE;
        let mut s = 0;
        for (j, entry) in self.lookup.iter_mut().enumerate() {
            while self.cdf[s + 1] <= (j << LOOKUP_SHIFT) as u32 {
                s += 1;
            }
            *entry = s as u8;
        }
    }
}

impl EntropyModel<PRECISION> for AdaptiveModel {
    type Symbol = usize;
    type Probability = u32;
}

impl EncoderModel<PRECISION> for AdaptiveModel {
    fn left_cumulative_and_probability(
        &self,
        symbol: impl std::borrow::Borrow<usize>,
    ) -> Option<(u32, NonZeroU32)> {
        let s = *symbol.borrow();
        let left = *self.cdf.get(s)?;
        let right = *self.cdf.get(s + 1)?;
        Some((left, NonZeroU32::new(right - left)?))
    }
}

impl DecoderModel<PRECISION> for AdaptiveModel {
    fn quantile_function(&self, quantile: u32) -> (usize, u32, NonZeroU32) {
        // `cdf[s] <= quantile` holds from the table on; the last entry, 2^PRECISION, does
        // not, so the scan stops at a symbol.
        let mut s = usize::from(self.lookup[(quantile >> LOOKUP_SHIFT) as usize]);
        while self.cdf[s + 1] <= quantile {
            s += 1;
        }
        let (left, right) = (self.cdf[s], self.cdf[s + 1]);
        (s, left, NonZeroU32::new(right - left).expect("every symbol has probability >= 1"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_stays_a_distribution_with_every_symbol_possible() {
        let mut m = AdaptiveModel::new(5);
        for i in 0..100_000 {
            m.update(if i % 97 == 0 { 4 } else { 1 });
            assert_eq!(m.cdf[5], ONE);
            assert!(m.cdf.windows(2).all(|w| w[0] < w[1]));
        }
        // Symbol 1 dominates, symbol 0 was never seen but can still be coded.
        let p1 = m.cdf[2] - m.cdf[1];
        assert!(p1 > ONE / 10 * 9, "{p1}");
        assert!(m.left_cumulative_and_probability(0).is_some());
        assert!(m.left_cumulative_and_probability(5).is_none());
        // The lookup table finds the same symbol a search of the CDF would.
        for q in (0..ONE).step_by(997) {
            let (s, left, p) = m.quantile_function(q);
            assert!(m.cdf[s] == left && left <= q && q < left + p.get(), "{q}");
        }
    }
}
