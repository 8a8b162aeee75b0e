//! A small deterministic random number generator: the sandbox has no randomness source, and
//! a service must be a function of its parameters, so randomness comes from a `seed`.

/// SplitMix64 (Steele, Lea, Flood 2014): a 64-bit state advanced by a constant and mixed;
/// every seed, 0 included, gives a full-period, well-mixed stream. Same bits on every machine.
#[derive(Clone, Debug)]
pub struct SplitMix64 {
    state: u64,
}

impl SplitMix64 {
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`, from the top 53 bits (every value a multiple of 2⁻⁵³).
    pub fn next_unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in `[-1, 1)`: exactly `2 * next_unit() - 1`, with one float operation
    /// instead of three (each costs a NaN check in the sandbox).
    pub fn next_signed_unit(&mut self) -> f64 {
        ((self.next_u64() >> 11) as i64 - (1 << 52)) as f64 * (1.0 / (1u64 << 52) as f64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_reference_sequence() {
        // The published first outputs of Vigna's splitmix64.c for seed 0.
        let mut rng = SplitMix64::new(0);
        let expected = [0xE220_A839_7B1D_CDAF, 0x6E78_9E6A_A1B9_65F4, 0x06C4_5D18_8009_454F];
        for e in expected {
            assert_eq!(rng.next_u64(), e);
        }
    }

    #[test]
    fn signed_units_are_exactly_twice_the_unit_minus_one() {
        let (mut a, mut b) = (SplitMix64::new(9), SplitMix64::new(9));
        for _ in 0..100_000 {
            let s = a.next_signed_unit();
            assert_eq!(s.to_bits(), (2.0 * b.next_unit() - 1.0).to_bits());
        }
    }

    #[test]
    fn units_stay_in_range() {
        let mut rng = SplitMix64::new(0);
        for _ in 0..10_000 {
            let u = rng.next_unit();
            assert!((0.0..1.0).contains(&u));
            let s = rng.next_signed_unit();
            assert!((-1.0..1.0).contains(&s));
        }
    }
}
