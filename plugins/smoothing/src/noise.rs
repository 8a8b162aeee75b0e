//! Random displacement of every vertex, reproducible from a seed.

use crate::random::SplitMix64;

/// The vertices' streams start this (odd) constant times their id apart: unrelated to
/// SplitMix64's own increment, so no stream runs into another's within the few draws a
/// vertex takes.
const STREAM_STRIDE: u64 = 0xD1B5_4A32_D192_ED03;

/// Moves every vertex (`x y z` per vertex in `positions`) by a random vector drawn uniformly
/// from the ball of radius `radius`. Vertex `i` draws from a [`SplitMix64`] stream of its
/// own, keyed by `seed` and `ids[i]` (its id in the whole mesh): the same input, radius and
/// seed give the same bits everywhere, on the whole mesh or cut into partitions.
///
/// The displacement is added in `f64` and the result rounded to `f32`, so a vertex may land
/// up to half an `f32` ulp of its coordinates (per axis) beyond `radius`; nothing else
/// exceeds it.
pub fn add_noise(positions: &[f32], ids: &[u32], radius: f64, seed: u64) -> Vec<f32> {
    let base = SplitMix64::new(seed).next_u64();
    let mut noisy = Vec::with_capacity(positions.len());
    for (p, &id) in positions.chunks_exact(3).zip(ids) {
        let mut rng = SplitMix64::new(base.wrapping_add(u64::from(id).wrapping_mul(STREAM_STRIDE)));
        let d = random_in_unit_ball(&mut rng);
        for k in 0..3 {
            noisy.push((p[k] as f64 + radius * d[k]) as f32);
        }
    }
    noisy
}

/// A point uniform in the closed unit ball, by rejection from the cube `[-1, 1)³` (on
/// average 1.9 draws of three numbers).
fn random_in_unit_ball(rng: &mut SplitMix64) -> [f64; 3] {
    loop {
        let d = [rng.next_signed_unit(), rng.next_signed_unit(), rng.next_signed_unit()];
        if d[0] * d[0] + d[1] * d[1] + d[2] * d[2] <= 1.0 {
            return d;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cloud() -> Vec<f32> {
        (0..3000).map(|i| (i % 97) as f32 * 0.25 - 7.0).collect()
    }

    fn ids(positions: &[f32]) -> Vec<u32> {
        (0..positions.len() as u32 / 3).collect()
    }

    fn displacement(a: &[f32], b: &[f32]) -> Vec<f64> {
        a.chunks_exact(3)
            .zip(b.chunks_exact(3))
            .map(|(p, q)| (0..3).map(|k| (q[k] as f64 - p[k] as f64).powi(2)).sum::<f64>().sqrt())
            .collect()
    }

    #[test]
    fn the_same_seed_gives_the_same_bits_and_another_seed_other_ones() {
        let positions = cloud();
        let a = add_noise(&positions, &ids(&positions), 0.1, 42);
        assert_eq!(a, add_noise(&positions, &ids(&positions), 0.1, 42));
        let b = add_noise(&positions, &ids(&positions), 0.1, 43);
        assert!(a.iter().zip(&b).filter(|(x, y)| x != y).count() > positions.len() / 2);
    }

    #[test]
    fn every_vertex_moves_within_the_radius_and_the_ball_is_filled() {
        let positions = cloud();
        let moved = displacement(&positions, &add_noise(&positions, &ids(&positions), 0.5, 7));
        // Coordinates are below 32 in magnitude: half an ulp is at most 2^-19.
        assert!(moved.iter().all(|&d| d <= 0.5 + 3f64.sqrt() * 2f64.powi(-19)));
        assert!(moved.iter().all(|&d| d > 0.0));
        // Uniform in the ball: the median distance is 0.5 * 2^(-1/3) ≈ 0.397.
        let mut sorted = moved.clone();
        sorted.sort_by(f64::total_cmp);
        let median = sorted[sorted.len() / 2];
        assert!((median - 0.397).abs() < 0.03, "median {median}");
    }

    #[test]
    fn zero_radius_and_no_vertices_change_nothing() {
        let positions = cloud();
        assert_eq!(add_noise(&positions, &ids(&positions), 0.0, 3), positions);
        assert!(add_noise(&[], &[], 1.0, 3).is_empty());
    }

    #[test]
    fn a_vertex_draws_by_its_id_not_its_place() {
        let positions = cloud();
        let ids = ids(&positions);
        let whole = add_noise(&positions, &ids, 0.1, 5);
        // Every third vertex alone, as a partition holding them would run it.
        let picked: Vec<usize> = (0..ids.len()).step_by(3).collect();
        let part: Vec<f32> =
            picked.iter().flat_map(|&v| positions[3 * v..3 * v + 3].to_vec()).collect();
        let part_ids: Vec<u32> = picked.iter().map(|&v| ids[v]).collect();
        let moved = add_noise(&part, &part_ids, 0.1, 5);
        for (i, &v) in picked.iter().enumerate() {
            assert_eq!(moved[3 * i..3 * i + 3], whole[3 * v..3 * v + 3], "vertex {v}");
        }
        // Neighbouring ids do not draw the same displacement, nor a shifted one.
        let d = |v: usize| [0, 1, 2].map(|k| whole[3 * v + k] - positions[3 * v + k]);
        assert!((1..ids.len()).all(|v| d(v) != d(v - 1)));
    }
}
