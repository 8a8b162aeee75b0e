//! Normal instability: how much the surface turns from triangle to triangle.

use meshflow_sdk::geometry::{angle_between, dot, triangle_normal};

use crate::edges::EdgeBuckets;

/// The mean angle in degrees between the normals of the two triangles of each interior
/// manifold edge (an edge with exactly two triangles), or 0 if there is no such edge.
///
/// Normals are taken as the triangles are stored, so the check sees orientation defects: a
/// flipped triangle contributes about 180° on its edges to consistently oriented neighbours,
/// and the seam of a non-orientable strip does too. Edges next to a zero-area triangle are
/// skipped (it has no normal). The angle is measured between the unnormalised normals
/// (`atan2` is scale-free), recomputed per edge rather than stored: cheaper than 24 bytes per
/// triangle of fresh memory. The sum is `f64` in ascending edge order, so the result is
/// deterministic. O(V + T).
pub fn normal_instability(positions: &[f32], triangles: &[u32]) -> f64 {
    let normal = |t: u32| {
        let n = triangle_normal(positions, triangles, t);
        // Zero area, or a non-finite corner: no direction.
        (n != [0.0; 3] && dot(n, n).is_finite()).then_some(n)
    };
    let (mut sum, mut edges) = (0.0f64, 0u64);
    EdgeBuckets::new(positions.len() / 3, triangles).for_each_edge(|_, sides| {
        if let [x, y] = sides
            && let (Some(n0), Some(n1)) = (normal(x.triangle()), normal(y.triangle()))
        {
            sum += angle_between(n0, n1);
            edges += 1;
        }
    });
    if edges == 0 { 0.0 } else { (sum / edges as f64).to_degrees() }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::*;

    fn instability(mesh: &Fixture) -> f64 {
        normal_instability(&mesh.positions, &mesh.triangles)
    }

    fn assert_close(actual: f64, expected: f64) {
        assert!((actual - expected).abs() < 1e-9, "got {actual}, expected {expected}");
    }

    #[test]
    fn cube_edges_turn_90_and_diagonals_0() {
        assert_close(instability(&cube()), 12.0 * 90.0 / 18.0);
        // Four cube edges became border edges, one diagonal went with the face.
        assert_close(instability(&open_cube()), 8.0 * 90.0 / 13.0);
    }

    #[test]
    fn a_flipped_triangle_turns_its_diagonal_to_180() {
        // Its two cube edges still meet at 90° (normal reversed: 180° - 90°).
        assert_close(instability(&flipped_cube()), (12.0 * 90.0 + 180.0) / 18.0);
    }

    #[test]
    fn tetrahedron_normals_meet_at_the_supplement_of_the_dihedral_angle() {
        assert_close(instability(&tetrahedron()), (-1.0f64 / 3.0).acos().to_degrees());
    }

    #[test]
    fn only_two_triangle_edges_count() {
        // Four triangles on the shared edge, none elsewhere; one vertex in the bow-tie.
        assert_eq!(instability(&two_sheets()), 0.0);
        assert_eq!(instability(&bow_tie()), 0.0);
    }

    #[test]
    fn the_mobius_seam_shows() {
        // 12 quads: the strip bends gently, but across the seam the stored normals oppose.
        let strip = mobius_strip(12);
        let without_seam_quad = Fixture {
            positions: strip.positions.clone(),
            triangles: strip.triangles[..3 * 22].to_vec(),
        };
        let open = instability(&without_seam_quad);
        assert!(open > 0.0 && open < 30.0, "{open}");
        // 21 interior edges without the last quad, 24 with it: the three it adds (a
        // diagonal and two rungs) sum to the 180° seam plus gentle bends.
        let added = 24.0 * instability(&strip) - 21.0 * open;
        assert!(added > 170.0 && added < 180.0 + 2.0 * 30.0, "{added}");
    }

    #[test]
    fn zero_area_neighbours_are_skipped() {
        assert_eq!(instability(&degenerate_only()), 0.0);
        // A flat square whose second half is collapsed onto the diagonal: no normal there.
        let positions = vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0.5, 0.5, 0.];
        assert_eq!(normal_instability(&positions, &[0, 1, 2, 2, 1, 3]), 0.0);
        assert_eq!(instability(&Fixture { positions: vec![], triangles: vec![] }), 0.0);
    }
}
