//! Normal instability: how much the surface turns from triangle to triangle.

use meshflow_plugin_sdk::geometry::{Vec3, angle_between, dot, normalize, sub, triangle_normal};
use meshflow_plugin_sdk::topology::{NONE, is_proper_triangle};

use crate::arrays::MeshArrays;

/// The mean angle in degrees between the normals of the two triangles of each interior
/// manifold edge (an edge with exactly two triangles), or 0 if there is no such edge.
///
/// Normals are taken as the triangles are stored, so the check sees orientation defects: a
/// flipped triangle contributes about 180° on its edges to consistently oriented neighbours,
/// and the seam of a non-orientable strip does too. Edges next to a zero-area triangle are
/// skipped (it has no normal). Each triangle's unit normal is computed once in `f64` (rather
/// than for each of its three edges: the 24 bytes per triangle cost less), and each angle
/// without `atan2` where possible, to about 1e-15 relative (see [`small_angles_sum`]). The
/// sum is `f64` in a fixed order (the host's edge list, ascending by vertex ids; small
/// angles in batches), so the result is deterministic. O(V + T).
pub fn normal_instability(mesh: &MeshArrays) -> f64 {
    let normals = unit_normals(mesh.positions(), mesh.triangles());
    let opposites = mesh.opposites();
    let mut angles = AngleSum::default();
    // An edge's smallest half-edge comes first, so `(x, y)` is in ascending id order.
    for &x in mesh.edges() {
        let y = opposites[x as usize];
        if y != NONE {
            angles.add(normals[x as usize / 3], normals[y as usize / 3]);
        }
    }
    angles.mean_degrees()
}

/// Small angles summed per batch.
const BATCH: usize = 1024;

/// The angles between pairs of unit normals, in the order they are added (pairs with a NaN
/// normal skipped): deterministic for a given order.
#[derive(Default)]
pub(crate) struct AngleSum {
    sum: f64,
    edges: u64,
    /// Small angles wait in a batch and are summed by a loop the compiler vectorises.
    small: Vec<f64>,
}

impl AngleSum {
    pub(crate) fn add(&mut self, u: Vec3, v: Vec3) {
        if u[0].is_nan() || v[0].is_nan() {
            return;
        }
        let d = sub(u, v);
        let half_chord_squared = 0.25 * dot(d, d);
        if half_chord_squared <= SERIES_LIMIT {
            self.small.push(half_chord_squared);
            if self.small.len() == BATCH {
                self.sum += small_angles_sum(&self.small);
                self.small.clear();
            }
        } else {
            self.sum += angle_between(u, v);
        }
        self.edges += 1;
    }

    /// The mean angle in degrees, 0 without any pair.
    pub(crate) fn mean_degrees(mut self) -> f64 {
        self.sum += small_angles_sum(&self.small);
        if self.edges == 0 { 0.0 } else { (self.sum / self.edges as f64).to_degrees() }
    }
}

/// The unit normal of every triangle, or NaNs where it has none: an improper triangle (never
/// on an edge of the connectivity), zero area, or a non-finite corner.
pub(crate) fn unit_normals(positions: &[f32], triangles: &[u32]) -> Vec<Vec3> {
    let vertex_count = positions.len() / 3;
    (0..triangles.len() as u32 / 3)
        .map(|t| {
            is_proper_triangle(triangles, vertex_count, t)
                .then(|| normalize(triangle_normal(positions, triangles, t)))
                .flatten()
                .unwrap_or([f64::NAN; 3])
        })
        .collect()
}

/// `asin(s) / s` as a polynomial in `s²`: the Taylor coefficients
/// `(2k)! / (4^k (k!)² (2k + 1))`, enough of them for a truncation error below 1e-16
/// relative when `s ≤ 1/8`.
const ASIN_SERIES: [f64; 8] = [
    1.0,
    1.0 / 6.0,
    3.0 / 40.0,
    5.0 / 112.0,
    35.0 / 1152.0,
    63.0 / 2816.0,
    231.0 / 13312.0,
    143.0 / 10240.0,
];

/// Half chords `s` up to this squared (`s ≤ 1/8`, angles up to about 14°) take the series.
const SERIES_LIMIT: f64 = 1.0 / 64.0;

/// The sum of the angles whose squared half chords are `half_chords_squared` (each at most
/// [`SERIES_LIMIT`]), in two lanes so it vectorises; deterministic for a given order.
///
/// Neighbouring normals of a scan mostly differ by a few degrees, where `atan2` (software in
/// wasm) dominated the check. Half the chord `s = |u - v| / 2` between unit normals is
/// `sin(θ / 2)`, and for `s ≤ 1/8` the `asin` series gives `θ` from it with only
/// multiplications (accurate also for tiny angles, unlike `acos` of the dot product).
fn small_angles_sum(half_chords_squared: &[f64]) -> f64 {
    let angle = |x: f64| {
        // Estrin's scheme: short dependency chains, the terms evaluate in parallel.
        let c = ASIN_SERIES;
        let x2 = x * x;
        let low = (c[0] + c[1] * x) + x2 * (c[2] + c[3] * x);
        let high = (c[4] + c[5] * x) + x2 * (c[6] + c[7] * x);
        2.0 * x.sqrt() * (low + x2 * x2 * high)
    };
    let mut lanes = [0.0f64; 2];
    let pairs = half_chords_squared.chunks_exact(2);
    let rest = pairs.remainder();
    for pair in pairs {
        lanes[0] += angle(pair[0]);
        lanes[1] += angle(pair[1]);
    }
    lanes[0] + lanes[1] + rest.iter().map(|&x| angle(x)).sum::<f64>()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::*;

    fn instability(mesh: &Fixture) -> f64 {
        normal_instability(&MeshArrays::native(&mesh.positions, &mesh.triangles))
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
    fn series_angles_match_atan2_up_to_the_series_limit() {
        let (mut fast_sum, mut exact_sum) = (Vec::new(), 0.0);
        for i in 0..=2000 {
            let theta = std::f64::consts::PI * (i as f64 / 2000.0).powi(3);
            let v = [theta.cos(), theta.sin(), 0.0];
            let d = sub([1.0, 0.0, 0.0], v);
            let half_chord_squared = 0.25 * dot(d, d);
            if half_chord_squared > SERIES_LIMIT {
                assert!(theta > 0.24, "the series covers angles up to about 14°: {theta}");
                continue;
            }
            let (fast, exact) =
                (small_angles_sum(&[half_chord_squared]), angle_between([1.0, 0.0, 0.0], v));
            assert!((fast - exact).abs() <= 4e-15 * exact.max(1e-3), "{theta}: {fast} vs {exact}");
            fast_sum.push(half_chord_squared);
            exact_sum += exact;
        }
        // Summed in lanes, odd lengths included.
        let fast = small_angles_sum(&fast_sum);
        assert!((fast - exact_sum).abs() <= 1e-12 * exact_sum, "{fast} vs {exact_sum}");
    }

    #[test]
    fn zero_area_neighbours_are_skipped() {
        assert_eq!(instability(&degenerate_only()), 0.0);
        // A flat square whose second half is collapsed onto the diagonal: no normal there.
        let positions = vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0.5, 0.5, 0.];
        let collapsed = MeshArrays::native(&positions, &[0, 1, 2, 2, 1, 3]);
        assert_eq!(normal_instability(&collapsed), 0.0);
        assert_eq!(instability(&Fixture { positions: vec![], triangles: vec![] }), 0.0);
    }
}
