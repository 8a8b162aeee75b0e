//! Laplacian smoothing: every free vertex moves to the average of its neighbours.

use meshflow_sdk::topology::adjacency::VertexNeighbours;
use meshflow_sdk::topology::boundary::boundary_vertices;
use meshflow_sdk::topology::halfedge::HalfEdges;

/// Which vertices stay where they are.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pinning {
    /// Boundary vertices keep their position, so holes and borders do not shrink.
    Boundary,
    /// Every vertex with neighbours moves.
    None,
}

/// `iterations` Jacobi steps of uniform Laplacian smoothing over `positions` (x y z per
/// vertex). Vertices without neighbours (unreferenced) never move. Sums are taken in f64
/// over the neighbours in ascending order, so the result is the same on every machine.
pub fn smooth_uniform(
    positions: &[f32],
    triangles: &[u32],
    iterations: u32,
    pinning: Pinning,
) -> Vec<f32> {
    let vertex_count = positions.len() / 3;
    let neighbours = VertexNeighbours::new(vertex_count, triangles);
    let pinned = match pinning {
        Pinning::Boundary => {
            boundary_vertices(vertex_count, triangles, &HalfEdges::new(vertex_count, triangles))
        }
        Pinning::None => vec![false; vertex_count],
    };
    let mut current = positions.to_vec();
    let mut next = positions.to_vec();
    for _ in 0..iterations {
        for v in 0..vertex_count {
            let around = neighbours.of(v as u32);
            if pinned[v] || around.is_empty() {
                next[3 * v..3 * v + 3].copy_from_slice(&current[3 * v..3 * v + 3]);
                continue;
            }
            let mut sum = [0.0f64; 3];
            for &n in around {
                let p = &current[3 * n as usize..3 * n as usize + 3];
                sum[0] += p[0] as f64;
                sum[1] += p[1] as f64;
                sum[2] += p[2] as f64;
            }
            let inv = 1.0 / around.len() as f64;
            for k in 0..3 {
                next[3 * v + k] = (sum[k] * inv) as f32;
            }
        }
        std::mem::swap(&mut current, &mut next);
    }
    current
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 3x3 grid of vertices (one interior vertex, 4), 8 triangles.
    fn grid() -> (Vec<f32>, Vec<u32>) {
        let mut positions = Vec::new();
        for y in 0..3 {
            for x in 0..3 {
                positions.extend([x as f32, y as f32, 0.0]);
            }
        }
        positions[3 * 4 + 2] = 3.0; // lift the centre
        let mut triangles = Vec::new();
        for y in 0..2 {
            for x in 0..2 {
                let v = y * 3 + x;
                triangles.extend([v, v + 1, v + 4, v, v + 4, v + 3]);
            }
        }
        (positions, triangles)
    }

    #[test]
    fn the_interior_vertex_moves_to_its_neighbours_average_and_the_boundary_stays() {
        let (positions, triangles) = grid();
        let smoothed = smooth_uniform(&positions, &triangles, 1, Pinning::Boundary);
        assert_eq!(&smoothed[12..15], &[1.0, 1.0, 0.0]);
        for v in (0..9).filter(|&v| v != 4) {
            assert_eq!(&smoothed[3 * v..3 * v + 3], &positions[3 * v..3 * v + 3], "vertex {v}");
        }
    }

    #[test]
    fn unpinned_boundary_vertices_move_too() {
        let (positions, triangles) = grid();
        let smoothed = smooth_uniform(&positions, &triangles, 1, Pinning::None);
        assert_ne!(&smoothed[0..3], &positions[0..3]);
    }

    #[test]
    fn zero_iterations_change_nothing_and_unreferenced_vertices_never_move() {
        let (mut positions, triangles) = grid();
        positions.extend([7.0, 7.0, 7.0]);
        assert_eq!(smooth_uniform(&positions, &triangles, 0, Pinning::None), positions);
        let smoothed = smooth_uniform(&positions, &triangles, 5, Pinning::None);
        assert_eq!(&smoothed[27..30], &[7.0, 7.0, 7.0]);
    }
}
