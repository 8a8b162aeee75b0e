//! The smooth closed base surface: a cube's faces gridded, projected to a sphere, and
//! deformed by a few seeded low-frequency bumps, like a scanned organic object.

use std::collections::HashMap;

use super::rng::SplitMix64;

/// A closed, manifold, consistently oriented surface with about `target_vertices` vertices.
pub(crate) fn bumpy_sphere(target_vertices: usize, rng: &mut SplitMix64) -> (Vec<f64>, Vec<u32>) {
    // A cube grid of n cells per edge has 6n² + 2 vertices.
    let n = (((target_vertices.max(8) - 2) as f64 / 6.0).sqrt().round() as i64).max(1);
    let bumps: Vec<([f64; 3], f64, f64)> =
        (0..6).map(|i| (rng.direction(), rng.range(1.5, 4.0), 0.12 / (1.0 + i as f64))).collect();

    let mut ids: HashMap<[i64; 3], u32> = HashMap::with_capacity(6 * (n * n) as usize + 2);
    let mut positions = Vec::with_capacity(3 * (6 * n * n + 2) as usize);
    let mut vertex = |lattice: [i64; 3], positions: &mut Vec<f64>| -> u32 {
        *ids.entry(lattice).or_insert_with(|| {
            let cube = lattice.map(|c| 2.0 * c as f64 / n as f64 - 1.0);
            let len = (cube[0] * cube[0] + cube[1] * cube[1] + cube[2] * cube[2]).sqrt();
            let dir = cube.map(|c| c / len);
            let radius = 1.0
                + bumps
                    .iter()
                    .map(|(axis, freq, amp)| {
                        let along = dir[0] * axis[0] + dir[1] * axis[1] + dir[2] * axis[2];
                        amp * (freq * along * std::f64::consts::PI).sin()
                    })
                    .sum::<f64>();
            positions.extend(dir.map(|d| d * radius));
            (positions.len() / 3 - 1) as u32
        })
    };

    let mut triangles = Vec::with_capacity(12 * (n * n) as usize * 3);
    // Each face: a fixed axis at 0 or n, and two running axes chosen so (u × v) points out.
    for (axis, side) in [(0, 0), (0, 1), (1, 0), (1, 1), (2, 0), (2, 1)] {
        let (mut u, mut v) = ((axis + 1) % 3, (axis + 2) % 3);
        if side == 0 {
            std::mem::swap(&mut u, &mut v);
        }
        let at = |i: i64, j: i64| {
            let mut p = [0i64; 3];
            p[axis] = side * n;
            p[u] = i;
            p[v] = j;
            p
        };
        for i in 0..n {
            for j in 0..n {
                let a = vertex(at(i, j), &mut positions);
                let b = vertex(at(i + 1, j), &mut positions);
                let c = vertex(at(i + 1, j + 1), &mut positions);
                let d = vertex(at(i, j + 1), &mut positions);
                // Alternate the diagonal so the mesh has no preferred direction.
                if (i + j) % 2 == 0 {
                    triangles.extend([a, b, c, a, c, d]);
                } else {
                    triangles.extend([a, b, d, b, c, d]);
                }
            }
        }
    }
    (positions, triangles)
}
