//! Small closed shapes as flat arrays, for tests and examples.
//!
//! ```
//! use meshflow_topology::shapes::{unit_cube, uv_sphere};
//! use meshflow_topology::measure::closed_component_volumes;
//! let (positions, triangles) = unit_cube();
//! let volumes = closed_component_volumes(&positions, &triangles);
//! assert!((volumes[0].volume - 1.0).abs() < 1e-12);
//! let (positions, triangles) = uv_sphere(8, 16);
//! assert_eq!((positions.len() / 3, triangles.len() / 3), (2 + 7 * 16, 2 * 7 * 16));
//! ```

use std::f64::consts::{PI, TAU};

/// The unit cube `[0, 1]³`: vertex `x + 2y + 4z`, two triangles per face (faces in the order
/// −z, +z, −y, +y, −x, +x), wound outward.
pub fn unit_cube() -> (Vec<f32>, Vec<u32>) {
    let positions = (0..8u32).flat_map(|v| [v & 1, v >> 1 & 1, v >> 2 & 1].map(|c| c as f32));
    #[rustfmt::skip]
    let triangles = vec![
        0, 2, 3, 0, 3, 1, // z = 0
        4, 5, 7, 4, 7, 6, // z = 1
        0, 1, 5, 0, 5, 4, // y = 0
        2, 6, 7, 2, 7, 3, // y = 1
        0, 4, 6, 0, 6, 2, // x = 0
        1, 3, 7, 1, 7, 5, // x = 1
    ];
    (positions.collect(), triangles)
}

/// A closed UV sphere of radius 1 around the origin, wound outward: vertex 0 at the north
/// pole, `rings − 1` latitude rings of `segments` vertices each, the south pole last.
/// Needs `rings ≥ 2` and `segments ≥ 3`.
pub fn uv_sphere(rings: u32, segments: u32) -> (Vec<f32>, Vec<u32>) {
    assert!(rings >= 2 && segments >= 3, "a UV sphere needs 2 rings and 3 segments");
    let mut positions = vec![0.0, 0.0, 1.0];
    for r in 1..rings {
        let polar = PI * r as f64 / rings as f64;
        for s in 0..segments {
            let azimuth = TAU * s as f64 / segments as f64;
            let p = [polar.sin() * azimuth.cos(), polar.sin() * azimuth.sin(), polar.cos()];
            positions.extend(p.map(|x| x as f32));
        }
    }
    positions.extend([0.0, 0.0, -1.0]);
    let ring = |r: u32, s: u32| 1 + (r - 1) * segments + s % segments;
    let south = 1 + (rings - 1) * segments;
    let mut triangles = Vec::new();
    for s in 0..segments {
        triangles.extend([0, ring(1, s), ring(1, s + 1)]);
        triangles.extend([south, ring(rings - 1, s + 1), ring(rings - 1, s)]);
        for r in 1..rings - 1 {
            let (a, b, c, d) = (ring(r, s), ring(r + 1, s), ring(r + 1, s + 1), ring(r, s + 1));
            triangles.extend([a, b, c, a, c, d]);
        }
    }
    (positions, triangles)
}

/// A flat grid of `squares × squares` unit squares in the plane z = 0: vertex `w·y + x` at
/// `(x, y)` with `w = squares + 1`; the square whose lower-left corner is `v` is split into
/// `(v, v+1, v+w+1)` and `(v, v+w+1, v+w)`, wound toward +z.
pub fn square_grid(squares: u32) -> (Vec<f32>, Vec<u32>) {
    let w = squares + 1;
    let positions = (0..w * w).flat_map(|v| [(v % w) as f32, (v / w) as f32, 0.0]).collect();
    let mut triangles = Vec::new();
    for y in 0..squares {
        for x in 0..squares {
            let v = y * w + x;
            triangles.extend([v, v + 1, v + w + 1, v, v + w + 1, v + w]);
        }
    }
    (positions, triangles)
}

/// A flat, nearly equilateral triangulation of `n × n` vertices in the plane z = 0: vertex
/// `n·j + i` at `(i + ½·(j odd), j·√3/2)`, rows shifted by half a step, wound toward +z.
pub fn triangular_sheet(n: u32) -> (Vec<f32>, Vec<u32>) {
    let row = 3f32.sqrt() / 2.0;
    let positions = (0..n * n)
        .flat_map(|v| {
            let (i, j) = (v % n, v / n);
            [i as f32 + 0.5 * (j % 2) as f32, j as f32 * row, 0.0]
        })
        .collect();
    let v = |i: u32, j: u32| j * n + i;
    let mut triangles = Vec::new();
    for j in 0..n.saturating_sub(1) {
        for i in 0..n - 1 {
            if j % 2 == 0 {
                triangles.extend([v(i, j), v(i + 1, j), v(i, j + 1)]);
                triangles.extend([v(i + 1, j), v(i + 1, j + 1), v(i, j + 1)]);
            } else {
                triangles.extend([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
                triangles.extend([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            }
        }
    }
    (positions, triangles)
}
