//! Liepa's refinement: split patch triangles at their centroids until the patch's edge
//! density matches the surroundings (the √2 rule on the scale attributes `sigma`), relaxing
//! edges by swaps after every split so the triangles stay well shaped.

use meshflow_plugin_sdk::geometry::{add, distance, scale};

use crate::patch::Patch;

/// Liepa's density factor α: a triangle is split while its centroid is farther than σ/α
/// from every corner.
const DENSITY: f64 = std::f64::consts::SQRT_2;
/// Relaxation passes over all edges per round. Swapping by the circumcircle test converges
/// on planar patches; on curved ones it could in principle cycle, so the passes are bounded.
const MAX_RELAX_PASSES: usize = 32;

/// Refines `patch` in place; stops early rather than exceed `max_triangles` (a guard for
/// holes whose surroundings give a scale far below their size). `is_forbidden(a, b)` tells
/// which edges between loop vertices swaps must not create (the mesh already has them).
pub fn refine(patch: &mut Patch, max_triangles: usize, is_forbidden: impl Fn(u32, u32) -> bool) {
    loop {
        let mut split_any = false;
        for t in 0..patch.triangles.len() as u32 {
            if patch.triangles.len() + 2 > max_triangles {
                return;
            }
            let Some((centroid, sigma)) = split_point(patch, t) else { continue };
            split_any = true;
            for side in patch.split(t, centroid, sigma) {
                if patch.needs_swap(side) {
                    patch.swap(side, &is_forbidden);
                }
            }
        }
        if !split_any {
            return;
        }
        relax(patch, &is_forbidden);
    }
}

/// Swaps edges that fail the circumcircle test until none does (or the pass bound).
pub fn relax(patch: &mut Patch, is_forbidden: impl Fn(u32, u32) -> bool) {
    for _ in 0..MAX_RELAX_PASSES {
        let mut swapped = false;
        for h in 0..patch.half_edge_count() {
            // Each interior edge once: from its smaller half-edge.
            if h < patch.twin(h) && patch.needs_swap(h) && patch.swap(h, &is_forbidden) {
                swapped = true;
            }
        }
        if !swapped {
            return;
        }
    }
}

/// The centroid of triangle `t` and its interpolated scale, if the √2 rule says to split:
/// α·|c − v| exceeds both σ(c) and σ(v) for every corner `v`.
fn split_point(patch: &Patch, t: u32) -> Option<([f64; 3], f64)> {
    let corners = patch.triangles[t as usize];
    let points = corners.map(|v| patch.points[v as usize]);
    let centroid = scale(add(add(points[0], points[1]), points[2]), 1.0 / 3.0);
    let sigma = corners.iter().map(|&v| patch.sigma[v as usize]).sum::<f64>() / 3.0;
    let coarse = corners.iter().zip(points).all(|(&v, p)| {
        let reach = DENSITY * distance(centroid, p);
        reach > sigma && reach > patch.sigma[v as usize]
    });
    coarse.then_some((centroid, sigma))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::triangulate::{Polygon, triangulate};
    use meshflow_plugin_sdk::geometry::{Vec3, corner_angles_of};

    /// A flat round hole of radius 1 with `n` loop edges, triangulated, with scale `sigma`.
    fn round_hole(n: usize, sigma: f64) -> Patch {
        let points: Vec<Vec3> = (0..n)
            .map(|i| {
                let a = -(i as f64) * std::f64::consts::TAU / n as f64;
                [a.cos(), a.sin(), 0.0]
            })
            .collect();
        let rim = vec![[0.0, 0.0, 1.0]; n];
        let tris =
            triangulate(&Polygon { points: &points, rim_normals: &rim }, |_, _| false).unwrap();
        Patch::new(points, vec![sigma; n], tris)
    }

    #[test]
    fn a_large_flat_hole_gets_the_surrounding_density() {
        let n = 40;
        let edge = 2.0 * (std::f64::consts::PI / n as f64).sin();
        let mut patch = round_hole(n, edge);
        refine(&mut patch, usize::MAX, |_, _| false);
        patch.assert_valid();
        // Equilateral triangles of side `edge` tile the disk about π / (√3/4 · edge²) times.
        let expected = std::f64::consts::PI / (3f64.sqrt() / 4.0 * edge * edge);
        let count = patch.triangles.len() as f64;
        assert!(count > 0.5 * expected && count < 2.0 * expected, "{count} vs {expected}");
        assert!(patch.points.len() > n + n / 2, "only {} vertices", patch.points.len());
        // Relaxed: well-shaped triangles, all still facing up (no folds).
        let mut min_angles: Vec<f64> = patch
            .triangles
            .iter()
            .map(|t| {
                let p = t.map(|v| patch.points[v as usize]);
                let n = meshflow_plugin_sdk::geometry::normal_of(&p);
                assert!(n[2] > 0.0, "folded triangle {t:?}");
                corner_angles_of(&p).into_iter().fold(f64::MAX, f64::min).to_degrees()
            })
            .collect();
        min_angles.sort_by(f64::total_cmp);
        assert!(
            min_angles[min_angles.len() / 2] >= 30.0,
            "median {}",
            min_angles[count as usize / 2]
        );
    }

    #[test]
    fn a_hole_already_at_density_is_left_alone() {
        let mut patch = round_hole(6, 10.0);
        refine(&mut patch, usize::MAX, |_, _| false);
        assert_eq!((patch.points.len(), patch.triangles.len()), (6, 4));
    }

    #[test]
    fn the_triangle_bound_stops_refinement() {
        let mut patch = round_hole(12, 1e-6);
        refine(&mut patch, 100, |_, _| false);
        patch.assert_valid();
        assert!(patch.triangles.len() <= 100);
    }
}
