//! Integers as an adaptive bucket symbol plus raw low bits (an Elias-gamma-like split).
//!
//! Values below 16 are their own symbol; larger ones are coded by bit length and the bit
//! after the leading one (so the model sees the magnitude to within a factor of 1.5), then
//! the remaining bits raw. Small values dominate every stream this codec writes.

use super::model::AdaptiveModel;

/// Values `0..LITERALS` are coded as one symbol each.
const LITERALS: u32 = 16;
/// 16 literals + 2 buckets per bit length 5..=32.
pub(crate) const BUCKETS: usize = LITERALS as usize + 2 * 28;

/// A fresh adaptive model over integer buckets.
pub(crate) fn int_model() -> AdaptiveModel {
    AdaptiveModel::new(BUCKETS)
}

/// `(bucket, raw bit count, raw bits)` for `z`.
pub(crate) fn split(z: u32) -> (usize, u32, u32) {
    if z < LITERALS {
        return (z as usize, 0, 0);
    }
    let length = 32 - z.leading_zeros(); // 5..=32
    let raw = length - 2;
    let second = (z >> raw) & 1;
    let bucket = LITERALS + 2 * (length - 5) + second;
    (bucket as usize, raw, z & low_mask(raw))
}

/// The raw bit count of `bucket`.
pub(crate) fn raw_bits(bucket: usize) -> u32 {
    if bucket < LITERALS as usize { 0 } else { (bucket as u32 - LITERALS) / 2 + 3 }
}

/// The value of `bucket` with raw bits `raw`.
pub(crate) fn join(bucket: usize, raw: u32) -> u32 {
    let bucket = bucket as u32;
    if bucket < LITERALS {
        return bucket;
    }
    let length = (bucket - LITERALS) / 2 + 5;
    let second = (bucket - LITERALS) % 2;
    let shift = length - 2;
    (1 << (length - 1)) | (second << shift) | (raw & low_mask(shift))
}

fn low_mask(bits: u32) -> u32 {
    if bits >= 32 { u32::MAX } else { (1 << bits) - 1 }
}

/// Signed to unsigned, small magnitudes to small values: 0, -1, 1, -2, 2 -> 0, 1, 2, 3, 4.
pub(crate) fn zigzag(v: i32) -> u32 {
    ((v << 1) ^ (v >> 31)) as u32
}

pub(crate) fn unzigzag(z: u32) -> i32 {
    ((z >> 1) as i32) ^ -((z & 1) as i32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn split_and_join_are_inverse_at_every_bucket_edge() {
        let mut samples: Vec<u32> = (0..300).collect();
        for b in 4..32 {
            for d in [0u32, 1, 2] {
                samples.extend([(1u32 << b) - d, (1u32 << b) + d, (3u32 << (b - 1)) - d]);
            }
        }
        samples.extend([u32::MAX, u32::MAX - 1, 1 << 31]);
        for z in samples {
            let (bucket, bits, raw) = split(z);
            assert!(bucket < BUCKETS, "{z}");
            assert_eq!(bits, raw_bits(bucket), "{z}");
            assert_eq!(join(bucket, raw), z, "{z}");
        }
    }

    #[test]
    fn zigzag_round_trips_the_extremes() {
        for v in [0, 1, -1, 2, -2, i32::MAX, i32::MIN] {
            assert_eq!(unzigzag(zigzag(v)), v);
        }
        assert_eq!(zigzag(-1), 1);
        assert_eq!(zigzag(1), 2);
    }
}
