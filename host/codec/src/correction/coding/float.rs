//! Lossless f32 residuals: differences of order-preserving integer images of the bits.
//!
//! `ordered` maps floats to `i32` monotonically (`-0.0` and `0.0` are neighbours), so the
//! difference between a value and a close prediction is a small integer counting the
//! representable floats between them, and adding it back restores the exact bits.

/// The order-preserving integer image of `f`'s bit pattern (an involution on the bits).
pub(crate) fn ordered(f: f32) -> i32 {
    let b = f.to_bits() as i32;
    b ^ ((((b >> 31) as u32) >> 1) as i32)
}

fn from_ordered(i: i32) -> f32 {
    f32::from_bits((i ^ ((((i >> 31) as u32) >> 1) as i32)) as u32)
}

/// How many representable steps `actual` lies above `predicted` (wrapping, so any pair works).
pub(crate) fn residual(actual: f32, predicted: f32) -> i32 {
    ordered(actual).wrapping_sub(ordered(predicted))
}

/// The inverse of [`residual`]: exact bits, whatever the prediction was.
pub(crate) fn restore(predicted: f32, residual: i32) -> f32 {
    from_ordered(ordered(predicted).wrapping_add(residual))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn residuals_restore_exact_bits_and_respect_order() {
        let values = [0.0f32, -0.0, 1.0, -1.0, 1e-38, -1e-38, f32::MAX, f32::MIN, 0.1, 3.5e7];
        for &a in &values {
            for &p in &values {
                assert_eq!(restore(p, residual(a, p)).to_bits(), a.to_bits(), "{a} from {p}");
            }
        }
        assert_eq!(residual(-0.0, 0.0), -1);
        assert_eq!(residual(f32::from_bits(1.0f32.to_bits() + 3), 1.0), 3);
        assert!(ordered(-2.0) < ordered(-1.0) && ordered(-1.0) < ordered(0.5));
    }
}
