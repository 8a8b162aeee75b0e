//! Laplacian operators over flat arrays: for every vertex, the vector from its position to
//! the weighted mean of its neighbours, `Σ w_ij (p_j - p_i) / Σ w_ij`. Smoothing filters
//! (Laplacian, Taubin) move vertices along it; fairing and curvature estimates start from it.
//!
//! Results are `f64`, three per vertex (the layout of `positions`). A vertex without
//! neighbours, or whose weights sum to zero or less, gets `[0, 0, 0]`. Sums run over the
//! neighbours in ascending order, so the result is the same on every machine.

use crate::VertexNeighbours;
use crate::geometry::{cotangent_weights, larger};

/// The umbrella operator: every neighbour weighs 1. `neighbours` must cover the vertices
/// of `positions` (built with `positions.len() / 3`). O(V + E).
pub fn uniform_laplacian(positions: &[f32], neighbours: &VertexNeighbours) -> Vec<f64> {
    weighted_laplacian(positions, neighbours, |_| 1.0)
}

/// The cotangent Laplacian: edge `{i, j}` weighs `(cot α + cot β) / 2`
/// ([`cotangent_weights`]), clamped at 0 so every target stays in the hull of the
/// neighbours. `neighbours` must have been built from the same `triangles`. O(V + T log d).
pub fn cotangent_laplacian(
    positions: &[f32],
    triangles: &[u32],
    neighbours: &VertexNeighbours,
) -> Vec<f64> {
    let weights = cotangent_weights(positions, triangles, neighbours);
    weighted_laplacian(positions, neighbours, |i| larger(f64::from(weights[i]), 0.0))
}

/// `Σ w(i) (p_j - p_v) / Σ w(i)` per vertex `v`, with `i` the entry of neighbour `j` in the
/// neighbour CSR.
fn weighted_laplacian(
    positions: &[f32],
    neighbours: &VertexNeighbours,
    weight: impl Fn(usize) -> f64,
) -> Vec<f64> {
    let (offsets, items) = (neighbours.offsets(), neighbours.neighbours());
    let vertex_count = neighbours.vertex_count().min(positions.len() / 3);
    let mut out = vec![0.0f64; 3 * vertex_count];
    for v in 0..vertex_count {
        let mut sum = [0.0f64; 3];
        let mut total = 0.0f64;
        let ring = offsets[v] as usize..offsets[v + 1] as usize;
        for (i, &item) in ring.clone().zip(&items[ring]) {
            let w = weight(i);
            let j = 3 * item as usize;
            sum[0] += w * positions[j] as f64;
            sum[1] += w * positions[j + 1] as f64;
            sum[2] += w * positions[j + 2] as f64;
            total += w;
        }
        if total > 0.0 {
            for k in 0..3 {
                out[3 * v + k] = sum[k] / total - positions[3 * v + k] as f64;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square of four vertices around a lifted centre vertex 4.
    fn pyramid() -> (Vec<f32>, Vec<u32>) {
        let positions = vec![0., 0., 0., 2., 0., 0., 2., 2., 0., 0., 2., 0., 1., 1., 3.];
        (positions, vec![0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4])
    }

    #[test]
    fn uniform_points_to_the_mean_of_the_neighbours() {
        let (positions, triangles) = pyramid();
        let neighbours = VertexNeighbours::new(5, &triangles);
        let l = uniform_laplacian(&positions, &neighbours);
        assert_eq!(&l[12..15], &[0.0, 0.0, -3.0]);
        // Vertex 0's neighbours are 1, 3 and 4: mean (1, 1, 1).
        assert_eq!(&l[0..3], &[1.0, 1.0, 1.0]);
    }

    #[test]
    fn cotangent_is_zero_on_a_flat_mesh_and_isolated_vertices_stay() {
        let (mut positions, triangles) = pyramid();
        positions[14] = 0.0; // flatten the centre
        positions.extend([9.0, 9.0, 9.0]); // an unreferenced vertex
        let neighbours = VertexNeighbours::new(6, &triangles);
        let l = cotangent_laplacian(&positions, &triangles, &neighbours);
        assert!(l[12..15].iter().all(|x| x.abs() < 1e-12), "{:?}", &l[12..15]);
        assert_eq!(&l[15..18], &[0.0; 3]);
        assert_eq!(&uniform_laplacian(&positions, &neighbours)[15..18], &[0.0; 3]);
    }

    #[test]
    fn cotangent_pulls_a_lifted_centre_straight_down() {
        let (positions, triangles) = pyramid();
        let neighbours = VertexNeighbours::new(5, &triangles);
        let l = cotangent_laplacian(&positions, &triangles, &neighbours);
        assert!(l[12].abs() < 1e-12 && l[13].abs() < 1e-12 && l[14] < -1.0, "{:?}", &l[12..15]);
    }
}
