//! Affine maps in `f64`: build, compose and apply them in double precision, and round once
//! to the row-major `f32` 3x4 matrix the host's `transform` edits take.

use crate::geometry::{Vec3, norm};

/// A row-major 3x4 affine map: `p' = M[..][..3] p + M[..][3]`.
pub type Affine = [[f64; 4]; 3];

/// The map that changes nothing.
pub const IDENTITY: Affine = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0]];

/// Moves every point by `t`.
pub fn translation(t: Vec3) -> Affine {
    let mut m = IDENTITY;
    for r in 0..3 {
        m[r][3] = t[r];
    }
    m
}

/// Scales each axis about the origin.
pub fn scaling(s: Vec3) -> Affine {
    let mut m = IDENTITY;
    for r in 0..3 {
        m[r][r] = s[r];
    }
    m
}

/// Rotates by `angle` radians about `axis` through the origin (right-hand rule, Rodrigues);
/// `None` for a zero or non-finite axis.
pub fn rotation(axis: Vec3, angle: f64) -> Option<Affine> {
    let n = norm(axis);
    if !(n.is_finite() && n > 0.0) {
        return None;
    }
    let [x, y, z] = axis.map(|a| a / n);
    let (s, c) = angle.sin_cos();
    let k = 1.0 - c;
    Some([
        [c + x * x * k, x * y * k - z * s, x * z * k + y * s, 0.0],
        [y * x * k + z * s, c + y * y * k, y * z * k - x * s, 0.0],
        [z * x * k - y * s, z * y * k + x * s, c + z * z * k, 0.0],
    ])
}

/// `outer ∘ inner`: applies `inner` first.
pub fn compose(outer: &Affine, inner: &Affine) -> Affine {
    let mut m = [[0.0; 4]; 3];
    for r in 0..3 {
        for c in 0..4 {
            let mut v = if c == 3 { outer[r][3] } else { 0.0 };
            for k in 0..3 {
                v += outer[r][k] * inner[k][c];
            }
            m[r][c] = v;
        }
    }
    m
}

/// `m` applied to `p`.
#[inline]
pub fn transform_point(m: &Affine, p: Vec3) -> Vec3 {
    [0, 1, 2].map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
}

/// Every position (x y z per vertex) mapped in `f64` and rounded once to `f32`; for a
/// `set-positions` edit when the host's `f32` matrix would lose precision.
pub fn transform_positions(m: &Affine, positions: &[f32]) -> Vec<f32> {
    let mut out = Vec::with_capacity(positions.len());
    for p in positions.chunks_exact(3) {
        let q = transform_point(m, [p[0] as f64, p[1] as f64, p[2] as f64]);
        out.extend(q.map(|x| x as f32));
    }
    out
}

/// The `f32` row-major 3x4 matrix the host's `transform` and `transform-component` edits
/// take.
pub fn to_f32_matrix(m: &Affine) -> [f32; 12] {
    std::array::from_fn(|i| m[i / 4][i % 4] as f32)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::FRAC_PI_2;

    fn close(a: Vec3, b: Vec3) -> bool {
        (0..3).all(|i| (a[i] - b[i]).abs() < 1e-12)
    }

    #[test]
    fn a_quarter_turn_about_z_then_a_shift() {
        let turn = rotation([0.0, 0.0, 2.0], FRAC_PI_2).unwrap();
        let m = compose(&translation([1.0, 0.0, 0.0]), &turn);
        assert!(close(transform_point(&m, [1.0, 0.0, 5.0]), [1.0, 1.0, 5.0]));
        assert!(rotation([0.0; 3], 1.0).is_none());
    }

    #[test]
    fn positions_are_mapped_in_f64_and_the_matrix_rounds_once() {
        let m = compose(&scaling([2.0, 3.0, 4.0]), &translation([0.5, 0.5, 0.5]));
        assert_eq!(
            transform_positions(&m, &[1.0, 1.0, 1.0, 0.0, 0.0, 0.0]),
            [3., 4.5, 6., 1., 1.5, 2.]
        );
        assert_eq!(to_f32_matrix(&m), [2., 0., 0., 1., 0., 3., 0., 1.5, 0., 0., 4., 2.]);
        assert_eq!(compose(&IDENTITY, &m), m);
    }
}
