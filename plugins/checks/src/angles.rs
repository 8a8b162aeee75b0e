//! The smallest and largest interior angle over the non-degenerate triangles.
//!
//! A triangle is degenerate when it has a repeated vertex id or exactly zero area (see
//! [`geometry::is_degenerate`]); its angles (0° and 180°) say nothing about the shape of the
//! surface, so it is skipped, as are triangles with out-of-range ids. **A mesh without any
//! non-degenerate triangle has no angles to measure: both checks then read 0.**
//!
//! Speed: no per-corner trigonometry, and no square root per triangle. In a triangle with
//! (unnormalised) normal `n`, the angle at a corner has cotangent `dot / |n|` (`dot` of the two
//! edge vectors leaving the corner), and the cotangent decreases strictly over `(0°, 180°)`,
//! as does the signed square `cot |cot| = dot |dot| / |n|²`. So the smallest angle of the mesh
//! belongs to the largest such ratio and the largest angle to the smallest; one pass finds
//! both triangles, and only their two angles are then computed exactly. The pass serves
//! both checks (see [`MeshArrays::angle_extremes`](crate::MeshArrays::angle_extremes)).

use meshflow_plugin_sdk::geometry::{self, cross, dot, sub};
use meshflow_plugin_sdk::topology::is_proper_triangle;

/// The smallest and the largest angle in degrees over the non-degenerate triangles, both 0
/// if there is none: one pass finds both corners. O(T).
pub fn angle_extremes(positions: &[f32], triangles: &[u32]) -> (f64, f64) {
    let (smallest, largest) = extreme_corners(positions, triangles);
    let degrees = |corner: Option<Corner>| corner.map_or(0.0, |c| angle(positions, triangles, c));
    (degrees(smallest), degrees(largest))
}

/// A corner: triangle id and corner (0, 1, 2).
type Corner = (u32, usize);

/// The corner of the smallest angle (the largest cotangent) and that of the largest (the
/// smallest cotangent) over the non-degenerate triangles, the first one on ties; `None`
/// without such a triangle.
fn extreme_corners(positions: &[f32], triangles: &[u32]) -> (Option<Corner>, Option<Corner>) {
    let vertex_count = positions.len() / 3;
    // Largest `cot |cot|` and largest `-cot |cot|` seen so far, with their corners.
    let (mut smallest, mut largest) = (None, None);
    for t in 0..triangles.len() as u32 / 3 {
        if !is_proper_triangle(triangles, vertex_count, t) {
            continue;
        }
        let p = geometry::triangle_points(positions, triangles, t);
        // Edge vectors e[k] = p[k + 1] - p[k], shared by the normal and the corner dots
        // (fewer float operations: each one costs a NaN check in the sandbox).
        let e = [sub(p[1], p[0]), sub(p[2], p[1]), sub(p[0], p[2])];
        let n = cross(e[2], e[0]);
        let area2_squared = dot(n, n);
        // Zero area is degenerate; non-finite coordinates give no comparable angles.
        if area2_squared == 0.0 || !area2_squared.is_finite() {
            continue;
        }
        // Corner k lies between e[k] and -e[k - 1]: its cotangent has the sign of -dots[k].
        let dots = [dot(e[0], e[2]), dot(e[1], e[0]), dot(e[2], e[1])];
        let (low, high) = (argmin(&dots), argmax(&dots));
        keep_larger(&mut smallest, -dots[low], (t, low), area2_squared);
        keep_larger(&mut largest, dots[high], (t, high), area2_squared);
    }
    (smallest.map(|(_, c)| c), largest.map(|(_, c)| c))
}

/// Keeps `corner` if its `d |d| / |n|²` is larger than the best so far, comparing against
/// `key × |n|²` (|n|² > 0) rather than dividing per triangle.
#[inline]
fn keep_larger(best: &mut Option<(f64, Corner)>, d: f64, corner: Corner, area2_squared: f64) {
    let signed_square = d * d.abs();
    if best.is_none_or(|(key, _)| signed_square > key * area2_squared) {
        *best = Some((signed_square / area2_squared, corner));
    }
}

fn argmax(x: &[f64; 3]) -> usize {
    if x[0] >= x[1] && x[0] >= x[2] {
        0
    } else if x[1] >= x[2] {
        1
    } else {
        2
    }
}

fn argmin(x: &[f64; 3]) -> usize {
    if x[0] <= x[1] && x[0] <= x[2] {
        0
    } else if x[1] <= x[2] {
        1
    } else {
        2
    }
}

/// The angle at a corner in degrees, computed as the SDK computes every angle.
fn angle(positions: &[f32], triangles: &[u32], (t, k): Corner) -> f64 {
    geometry::corner_angles_degrees(positions, triangles, t)[k]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::*;

    fn extremes(mesh: &Fixture) -> (f64, f64) {
        angle_extremes(&mesh.positions, &mesh.triangles)
    }

    fn assert_close(actual: (f64, f64), expected: (f64, f64)) {
        let ok = (actual.0 - expected.0).abs() < 1e-9 && (actual.1 - expected.1).abs() < 1e-9;
        assert!(ok, "got {actual:?}, expected {expected:?}");
    }

    #[test]
    fn right_isosceles_triangles_span_45_to_90() {
        for mesh in [cube(), open_cube(), flipped_cube(), two_sheets(), bow_tie()] {
            assert_close(extremes(&mesh), (45.0, 90.0));
        }
    }

    #[test]
    fn a_regular_tetrahedron_has_only_60_degrees() {
        assert_close(extremes(&tetrahedron()), (60.0, 60.0));
    }

    #[test]
    fn mobius_strip_matches_a_direct_scan_of_all_corners() {
        let mesh = mobius_strip(7);
        let all: Vec<f64> = (0..mesh.triangles.len() as u32 / 3)
            .flat_map(|t| geometry::corner_angles_degrees(&mesh.positions, &mesh.triangles, t))
            .collect();
        let expected = all.iter().fold((180.0f64, 0.0f64), |(lo, hi), &a| (lo.min(a), hi.max(a)));
        assert_close(extremes(&mesh), expected);
        assert!(expected.0 > 10.0 && expected.1 < 170.0, "a sane strip: {expected:?}");
    }

    #[test]
    fn degenerate_triangles_are_skipped() {
        // A collinear triangle (0° and 180°) and a repeated-id one next to the tetrahedron.
        let mut mesh = tetrahedron();
        mesh.positions.extend([2., 2., 2., 3., 3., 3.]);
        mesh.triangles.extend([0, 4, 5, 1, 1, 2]);
        assert_close(extremes(&mesh), (60.0, 60.0));
    }

    #[test]
    fn without_a_non_degenerate_triangle_both_read_zero() {
        assert_eq!(extremes(&degenerate_only()), (0.0, 0.0));
        assert_eq!(extremes(&Fixture { positions: vec![], triangles: vec![] }), (0.0, 0.0));
        let positions = vec![f32::NAN, 0., 0., 1., 0., 0., 0., 1., 0.];
        assert_eq!(extremes(&Fixture { positions, triangles: vec![0, 1, 2] }), (0.0, 0.0));
    }

    #[test]
    fn a_needle_is_found_in_any_corner() {
        // The same thin triangle with its sharp corner rotated through positions 0, 1, 2.
        let positions = vec![0., 0., 0., 10., 0., 0., 10., 1., 0.];
        let sharp = 1f64.atan2(10.0).to_degrees();
        for triangles in [vec![0, 1, 2], vec![2, 0, 1], vec![1, 2, 0]] {
            let mesh = Fixture { positions: positions.clone(), triangles };
            assert_close(extremes(&mesh), (sharp, 90.0));
        }
    }
}
