//! Laplacian smoothing: every free vertex moves to the weighted average of its neighbours.

use meshflow_plugin_sdk::geometry::{cotangent_weights, larger};
use meshflow_plugin_sdk::topology::adjacency::VertexNeighbours;
use meshflow_plugin_sdk::topology::boundary::boundary_vertices;
use meshflow_plugin_sdk::topology::halfedge::HalfEdges;
use meshflow_plugin_sdk::topology::visit_weighted_mean;

/// Which vertices stay where they are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pinning {
    /// Boundary vertices keep their position, so holes and borders do not shrink.
    Boundary,
    /// Every vertex with neighbours moves.
    None,
}

/// How much each neighbour pulls.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Weights {
    /// Every neighbour equally (the umbrella operator): fast, but it also evens out the
    /// sampling, sliding vertices along the surface.
    Uniform,
    /// The cotangent weights of the edges (`(cot α + cot β) / 2`), recomputed from the current
    /// positions at every iteration: moves vertices mostly along the normal, so the sampling
    /// is kept. Negative weights (across obtuse angle pairs) are clamped to 0, which keeps
    /// every new position inside the hull of its neighbours; a vertex whose weights are all
    /// zero stays.
    Cotangent,
}

/// `iterations` Jacobi steps of Laplacian smoothing over `positions` (x y z per vertex).
/// Vertices without neighbours (unreferenced) never move. Sums are taken in f64 over the
/// neighbours in ascending order, so the result is the same on every machine.
pub fn smooth(
    positions: &[f32],
    triangles: &[u32],
    iterations: u32,
    pinning: Pinning,
    weights: Weights,
) -> Vec<f32> {
    smooth_owned(positions.to_vec(), triangles.to_vec(), iterations, pinning, weights)
}

/// [`smooth`] of arrays it may keep or drop: the positions become the first buffer, and
/// uniform weights drop the triangles once the neighbours are known, so the guest holds
/// the mesh once. The half-edges (for the boundary) come and go before the neighbours are
/// built, so the two never take memory at once.
pub fn smooth_owned(
    positions: Vec<f32>,
    triangles: Vec<u32>,
    iterations: u32,
    pinning: Pinning,
    weights: Weights,
) -> Vec<f32> {
    let vertex_count = positions.len() / 3;
    let pinned = match pinning {
        Pinning::Boundary => {
            boundary_vertices(vertex_count, &triangles, &HalfEdges::new(vertex_count, &triangles))
        }
        Pinning::None => vec![false; vertex_count],
    };
    let neighbours = VertexNeighbours::new(vertex_count, &triangles);
    let triangles = match weights {
        Weights::Uniform => Vec::new(),
        Weights::Cotangent => triangles,
    };
    let mut current = positions;
    let mut next = current.clone();
    for _ in 0..iterations {
        match weights {
            Weights::Uniform => step(&current, &mut next, &neighbours, &pinned, |_| 1.0),
            Weights::Cotangent => {
                let cot = cotangent_weights(&current, &triangles, &neighbours);
                step(&current, &mut next, &neighbours, &pinned, |i| larger(f64::from(cot[i]), 0.0));
            }
        }
        std::mem::swap(&mut current, &mut next);
    }
    current
}

/// One Jacobi step from `current` into `next`; `weight(i)` is the weight of entry `i` of
/// the neighbour CSR. Pinned vertices, and those whose weights sum to zero or less, stay.
fn step(
    current: &[f32],
    next: &mut [f32],
    neighbours: &VertexNeighbours,
    pinned: &[bool],
    weight: impl Fn(usize) -> f64,
) {
    next.copy_from_slice(current);
    visit_weighted_mean(current, neighbours, weight, |v, mean| {
        if !pinned[v] {
            for (k, m) in mean.into_iter().enumerate() {
                next[3 * v + k] = m as f32;
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use meshflow_plugin_sdk::topology::shapes::{square_grid, triangular_sheet};

    /// A 3x3 grid of vertices (one interior vertex, 4), 8 triangles.
    fn grid() -> (Vec<f32>, Vec<u32>) {
        let (mut positions, triangles) = square_grid(2);
        positions[3 * 4 + 2] = 3.0; // lift the centre
        (positions, triangles)
    }

    #[test]
    fn the_interior_vertex_moves_to_its_neighbours_average_and_the_boundary_stays() {
        let (positions, triangles) = grid();
        let smoothed = smooth(&positions, &triangles, 1, Pinning::Boundary, Weights::Uniform);
        assert_eq!(&smoothed[12..15], &[1.0, 1.0, 0.0]);
        for v in (0..9).filter(|&v| v != 4) {
            assert_eq!(&smoothed[3 * v..3 * v + 3], &positions[3 * v..3 * v + 3], "vertex {v}");
        }
    }

    #[test]
    fn unpinned_boundary_vertices_move_too() {
        let (positions, triangles) = grid();
        let smoothed = smooth(&positions, &triangles, 1, Pinning::None, Weights::Uniform);
        assert_ne!(&smoothed[0..3], &positions[0..3]);
    }

    #[test]
    fn zero_iterations_change_nothing_and_unreferenced_vertices_never_move() {
        let (mut positions, triangles) = grid();
        positions.extend([7.0, 7.0, 7.0]);
        assert_eq!(smooth(&positions, &triangles, 0, Pinning::None, Weights::Cotangent), positions);
        let smoothed = smooth(&positions, &triangles, 5, Pinning::None, Weights::Cotangent);
        assert_eq!(&smoothed[27..30], &[7.0, 7.0, 7.0]);
    }

    /// A flat, nearly equilateral triangulation (`n x n` vertices, rows shifted by half a
    /// step) with a deterministic jitter of the interior vertices in the plane; `lift` gives
    /// each vertex a height from its (x, y).
    pub(crate) fn jittered_sheet(n: u32, lift: impl Fn(f32, f32) -> f32) -> (Vec<f32>, Vec<u32>) {
        let (mut positions, triangles) = triangular_sheet(n);
        for (v, p) in (0..).zip(positions.chunks_exact_mut(3)) {
            let (i, j) = (v % n, v / n);
            let interior = i > 0 && j > 0 && i + 1 < n && j + 1 < n;
            let jitter = if interior { 0.08 * ((17 * i + 31 * j) as f32).sin() } else { 0.0 };
            let (x, y) = (p[0] + jitter, p[1] - jitter);
            p.copy_from_slice(&[x, y, lift(x, y)]);
        }
        (positions, triangles)
    }

    /// The largest distance any vertex moved.
    fn largest_move(a: &[f32], b: &[f32]) -> f32 {
        a.chunks_exact(3)
            .zip(b.chunks_exact(3))
            .map(|(p, q)| (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f32>().sqrt())
            .fold(0.0, f32::max)
    }

    #[test]
    fn cotangent_weights_leave_a_flat_sheet_in_place_where_uniform_ones_slide_it() {
        let (positions, triangles) = jittered_sheet(12, |_, _| 0.0);
        let cot = smooth(&positions, &triangles, 1, Pinning::Boundary, Weights::Cotangent);
        let uniform = smooth(&positions, &triangles, 1, Pinning::Boundary, Weights::Uniform);
        // The cotangent Laplacian of a flat mesh is zero: only rounding moves a vertex.
        assert!(largest_move(&positions, &cot) < 1e-5, "{}", largest_move(&positions, &cot));
        assert!(largest_move(&positions, &uniform) > 0.05);
    }

    #[test]
    fn cotangent_smoothing_flattens_a_noisy_bump() {
        let noisy = |x: f32, y: f32| {
            let bump = (-((x - 6.0).powi(2) + (y - 5.0).powi(2)) / 8.0).exp();
            bump + 0.05 * ((13.0 * x).sin() * (7.0 * y).cos())
        };
        let (positions, triangles) = jittered_sheet(12, noisy);
        // The largest height difference between a vertex and its neighbours' mean.
        let roughness = |p: &[f32]| {
            let flat = smooth(p, &triangles, 1, Pinning::Boundary, Weights::Uniform);
            p.iter().zip(&flat).skip(2).step_by(3).map(|(a, b)| (a - b).abs()).fold(0.0, f32::max)
        };
        let smoothed = smooth(&positions, &triangles, 10, Pinning::Boundary, Weights::Cotangent);
        assert!(roughness(&smoothed) < 0.5 * roughness(&positions));
    }
}
