//! Taubin smoothing (λ|μ): every iteration moves each free vertex by `λ` times its uniform
//! Laplacian, then by `μ` times the Laplacian of the result. With `μ < -λ < 0` the second,
//! inflating step cancels the shrinkage of the first at low frequencies, so noise goes and
//! the volume stays (G. Taubin, "A signal processing approach to fair surface design", 1995).

use meshflow_plugin_sdk::topology::boundary::boundary_vertices;
use meshflow_plugin_sdk::topology::halfedge::HalfEdges;
use meshflow_plugin_sdk::topology::{VertexNeighbours, visit_uniform_laplacian};

/// `iterations` λ|μ steps over `positions` (x y z per vertex). Boundary vertices stay, so
/// borders and holes keep their shape; vertices without neighbours never move. The Laplacian
/// is summed in `f64` over the neighbours in ascending order and each half-step is rounded to
/// `f32` once, so the result is the same on every machine (the C++ template repeats exactly
/// these operations).
pub fn smooth(
    positions: &[f32],
    triangles: &[u32],
    lambda: f64,
    mu: f64,
    iterations: u32,
) -> Vec<f32> {
    smooth_owned(positions.to_vec(), triangles.to_vec(), lambda, mu, iterations)
}

/// [`smooth`] of arrays it may keep or drop: the positions become the first buffer and the
/// triangles go once the neighbours are known, so the guest holds the mesh once; the
/// half-edges (for the boundary) go before the neighbours are built.
pub fn smooth_owned(
    positions: Vec<f32>,
    triangles: Vec<u32>,
    lambda: f64,
    mu: f64,
    iterations: u32,
) -> Vec<f32> {
    let vertex_count = positions.len() / 3;
    let pinned =
        boundary_vertices(vertex_count, &triangles, &HalfEdges::new(vertex_count, &triangles));
    let neighbours = VertexNeighbours::new(vertex_count, &triangles);
    drop(triangles);
    // Two buffers, each half-step writing one from the other: pinned vertices and those
    // without neighbours are never written, so they stay the same in both.
    let mut current = positions;
    let mut next = current.clone();
    for _ in 0..iterations {
        for factor in [lambda, mu] {
            visit_uniform_laplacian(&current, &neighbours, |v, laplacian| {
                if !pinned[v] {
                    for (k, step) in laplacian.iter().enumerate() {
                        let i = 3 * v + k;
                        next[i] = (current[i] as f64 + factor * step) as f32;
                    }
                }
            });
            std::mem::swap(&mut current, &mut next);
        }
    }
    current
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::laplacian::{self, Pinning, Weights};
    use crate::noise::add_noise;
    use meshflow_plugin_sdk::topology::measure::closed_component_volumes;
    use meshflow_plugin_sdk::topology::shapes::uv_sphere;

    fn volume(positions: &[f32], triangles: &[u32]) -> f64 {
        closed_component_volumes(positions, triangles).iter().map(|c| c.volume).sum()
    }

    #[test]
    fn taubin_keeps_the_volume_of_a_noised_sphere_where_laplacian_shrinks_it() {
        let (clean, triangles) = uv_sphere(40, 80);
        let ids: Vec<u32> = (0..clean.len() as u32 / 3).collect();
        let noised = add_noise(&clean, &ids, 0.02, 7);
        let before = volume(&noised, &triangles);
        assert!((before - 4.0 / 3.0 * std::f64::consts::PI).abs() < 0.05, "{before}");
        let taubin = smooth(&noised, &triangles, 0.5, -0.53, 10);
        let uniform =
            laplacian::smooth(&noised, &triangles, 10, Pinning::Boundary, Weights::Uniform);
        let kept = volume(&taubin, &triangles) / before;
        let shrunk = volume(&uniform, &triangles) / before;
        assert!(
            (kept - 1.0).abs() < 0.01,
            "Taubin changed the volume by {:.3}%",
            100.0 * (kept - 1.0)
        );
        assert!(shrunk < 0.99, "Laplacian kept {:.3}% of the volume", 100.0 * shrunk);
        // And the noise went: vertices are closer to the unit sphere than before.
        let spread = |p: &[f32]| {
            p.chunks_exact(3)
                .map(|q| ((q[0] * q[0] + q[1] * q[1] + q[2] * q[2]).sqrt() - 1.0).abs() as f64)
                .sum::<f64>()
        };
        assert!(spread(&taubin) < 0.5 * spread(&noised));
    }

    #[test]
    fn boundary_and_isolated_vertices_stay_and_zero_iterations_change_nothing() {
        // A fan of four triangles around vertex 4, lifted, plus an unreferenced vertex 5.
        let positions = [0., 0., 0., 2., 0., 0., 2., 2., 0., 0., 2., 0., 1., 1., 1., 5., 5., 5.];
        let triangles = [0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4];
        assert_eq!(smooth(&positions, &triangles, 0.5, -0.53, 0), positions);
        let smoothed = smooth(&positions, &triangles, 0.5, -0.53, 3);
        assert_eq!(&smoothed[..12], &positions[..12]);
        assert_eq!(&smoothed[15..], &positions[15..]);
        // λ then μ on the centre: 1 -> 0.5 -> 0.5 - 0.53 * (0 - 0.5) = 0.765, and so on.
        assert_eq!(&smoothed[12..14], &[1.0, 1.0]);
        let mut z = 1.0f64;
        for _ in 0..3 {
            z = (z + 0.5 * -z) as f32 as f64;
            z = (z + -0.53 * -z) as f32 as f64;
        }
        assert_eq!(smoothed[14] as f64, z);
    }
}
