//! Laplacian operators over flat arrays: for every vertex, the vector from its position to
//! the weighted mean of its neighbours, `Σ w_ij (p_j - p_i) / Σ w_ij`. Smoothing filters
//! (Laplacian, Taubin) move vertices along it; fairing and curvature estimates start from it.
//!
//! Results are `f64`, three per vertex (the layout of `positions`). A vertex without
//! neighbours, or whose weights sum to zero or less, gets `[0, 0, 0]`. Sums run over the
//! neighbours in ascending order, so the result is the same on every machine.

use crate::VertexNeighbours;
use crate::csr::for_each_by_four;
use crate::geometry::{cotangent_weights, larger};

/// The umbrella operator: every neighbour weighs 1. `neighbours` must cover the vertices
/// of `positions` (built with `positions.len() / 3`). O(V + E).
pub fn uniform_laplacian(positions: &[f32], neighbours: &VertexNeighbours) -> Vec<f64> {
    collect(positions, neighbours, |visit| visit_uniform_laplacian(positions, neighbours, visit))
}

/// [`uniform_laplacian`] without storing it: `visit(v, laplacian)` for every vertex in
/// ascending order, so a smoothing step writes its next positions straight from it (no
/// `3 · V` f64 buffer per step, which was a third of Taubin's time in the sandbox).
pub fn visit_uniform_laplacian(
    positions: &[f32],
    neighbours: &VertexNeighbours,
    visit: impl FnMut(usize, [f64; 3]),
) {
    visit_weighted_laplacian(positions, neighbours, |_| 1.0, visit)
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
    let weight = |i: usize| larger(f64::from(weights[i]), 0.0);
    collect(positions, neighbours, |visit| {
        visit_weighted_laplacian(positions, neighbours, weight, visit)
    })
}

/// What a visiting operator gives, stored: three f64 per vertex, zero where not visited.
fn collect(
    positions: &[f32],
    neighbours: &VertexNeighbours,
    run: impl FnOnce(&mut dyn FnMut(usize, [f64; 3])),
) -> Vec<f64> {
    let mut out = vec![0.0f64; 3 * neighbours.vertex_count().min(positions.len() / 3)];
    run(&mut |v, l| out[3 * v..3 * v + 3].copy_from_slice(&l));
    out
}

/// `Σ w(i) (p_j - p_v) / Σ w(i)` for every vertex `v` whose weights sum above zero, with `i`
/// the entry of neighbour `j` in the neighbour CSR, handed to `visit` in ascending order.
fn visit_weighted_laplacian(
    positions: &[f32],
    neighbours: &VertexNeighbours,
    weight: impl Fn(usize) -> f64,
    mut visit: impl FnMut(usize, [f64; 3]),
) {
    let (points, _) = positions.as_chunks::<3>();
    visit_weighted_mean(positions, neighbours, weight, |v, mean| {
        let p = points[v];
        visit(v, [0, 1, 2].map(|k| mean[k] - p[k] as f64));
    });
}

/// The weighted mean of every vertex's neighbours, `Σ w(i) p_j / Σ w(i)`, for every vertex
/// whose weights sum above zero (`i` the entry of neighbour `j` in the neighbour CSR),
/// handed to `visit` in ascending vertex order; sums in `f64`, neighbours in ascending order.
/// Laplacian smoothing moves vertices to it; the Laplacian is it minus the vertex.
pub fn visit_weighted_mean(
    positions: &[f32],
    neighbours: &VertexNeighbours,
    weight: impl Fn(usize) -> f64,
    mut visit: impl FnMut(usize, [f64; 3]),
) {
    let (offsets, items) = (neighbours.offsets(), neighbours.neighbours());
    // One bounds check per neighbour, not three: this loop is most of a smoothing step.
    let (points, _) = positions.as_chunks::<3>();
    let vertex_count = neighbours.vertex_count().min(points.len());
    for v in 0..vertex_count {
        let mut sum = [0.0f64; 3];
        let mut total = 0.0f64;
        let mut add = |i: usize, item: u32| {
            let w = weight(i);
            let p = points[item as usize];
            sum[0] += w * p[0] as f64;
            sum[1] += w * p[1] as f64;
            sum[2] += w * p[2] as f64;
            total += w;
        };
        // Four neighbours per loop turn (see `for_each_by_four`); the order of the sums is
        // unchanged.
        let start = offsets[v] as usize;
        for_each_by_four(&items[start..offsets[v + 1] as usize], |k, item| add(start + k, item));
        if total > 0.0 {
            visit(v, sum.map(|s| s / total));
        }
    }
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
