//! Hand-built meshes with known answers, shared by the unit tests of every check family.

use std::f64::consts::PI;

/// A mesh as the checks see it: `x y z` per vertex, three vertex ids per triangle.
pub struct Fixture {
    pub positions: Vec<f32>,
    pub triangles: Vec<u32>,
}

impl Fixture {
    pub fn vertex_count(&self) -> usize {
        self.positions.len() / 3
    }
}

/// The unit cube, 8 vertices (`x + 2y + 4z`), two right isosceles triangles per face,
/// oriented outwards.
pub fn cube() -> Fixture {
    let (positions, triangles) = meshflow_plugin_sdk::topology::shapes::unit_cube();
    Fixture { positions, triangles }
}

/// The cube without its top face (triangles 2 and 3): one square hole, and the top face's
/// diagonal is gone with it.
pub fn open_cube() -> Fixture {
    let mut mesh = cube();
    mesh.triangles.drain(6..12);
    mesh
}

/// The cube with triangle 0 stored the other way round.
pub fn flipped_cube() -> Fixture {
    let mut mesh = cube();
    mesh.triangles.swap(1, 2);
    mesh
}

/// A regular tetrahedron, oriented outwards.
pub fn tetrahedron() -> Fixture {
    Fixture {
        positions: vec![1., 1., 1., 1., -1., -1., -1., 1., -1., -1., -1., 1.],
        triangles: vec![0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2],
    }
}

/// A Möbius strip of `quads` quads (≥ 3) around a circle of radius 2, width 1: vertex `2i`
/// on the top edge, `2i + 1` on the bottom edge, and the last quad joins top to bottom.
pub fn mobius_strip(quads: u32) -> Fixture {
    let mut positions = Vec::new();
    for i in 0..quads {
        let phi = 2.0 * PI * i as f64 / quads as f64;
        for s in [0.5, -0.5] {
            let r = 2.0 + s * (phi / 2.0).cos();
            positions
                .extend([r * phi.cos(), r * phi.sin(), s * (phi / 2.0).sin()].map(|c| c as f32));
        }
    }
    let (top, bottom) = (|i: u32| 2 * i, |i: u32| 2 * i + 1);
    let mut triangles = Vec::new();
    for i in 0..quads {
        // Half a turn later the top edge has become the bottom edge.
        let (next_top, next_bottom) =
            if i + 1 < quads { (top(i + 1), bottom(i + 1)) } else { (bottom(0), top(0)) };
        triangles.extend([top(i), bottom(i), next_bottom, top(i), next_bottom, next_top]);
    }
    Fixture { positions, triangles }
}

/// Two flat sheets of two right isosceles triangles each, crossing at right angles along
/// their common middle edge 0–1, which therefore has four triangles.
pub fn two_sheets() -> Fixture {
    Fixture {
        positions: vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 0., -1., 0., 0., 0., 1., 0., 0., -1.],
        triangles: vec![0, 1, 2, 1, 0, 3, 0, 1, 4, 1, 0, 5],
    }
}

/// Two right isosceles triangles touching only at vertex 0 (a bow-tie).
pub fn bow_tie() -> Fixture {
    Fixture {
        positions: vec![0., 0., 0., 1., 0., 0., 0., 1., 0., -1., 0., 0., 0., -1., 0.],
        triangles: vec![0, 1, 2, 0, 3, 4],
    }
}

/// Nothing but degenerate triangles: collinear corners, a repeated id, and a triangle with an
/// out-of-range id; plus an unreferenced vertex.
pub fn degenerate_only() -> Fixture {
    Fixture {
        positions: vec![0., 0., 0., 1., 1., 1., 2., 2., 2., 5., 0., 0.],
        triangles: vec![0, 1, 2, 0, 0, 1, 0, 1, 9],
    }
}

/// The unit sphere as a subdivided octahedron: each face split into `n²` triangles, every
/// lattice point projected onto the sphere, shared between faces, wound outward.
pub fn sphere(n: i32) -> Fixture {
    let mut ids = std::collections::HashMap::new();
    let mut positions = Vec::new();
    let mut id = |p: [i32; 3]| {
        *ids.entry(p).or_insert_with(|| {
            let len = p.iter().map(|&c| (c * c) as f64).sum::<f64>().sqrt();
            positions.extend(p.map(|c| (c as f64 / len) as f32));
            positions.len() as u32 / 3 - 1
        })
    };
    let mut triangles = Vec::new();
    for signs in 0..8 {
        let s = [0, 1, 2].map(|axis| if signs >> axis & 1 == 0 { 1 } else { -1 });
        let at = |i: i32, j: i32| [s[0] * (n - i - j), s[1] * i, s[2] * j];
        let mut push = |a, b, c| {
            let t = [id(a), id(b), id(c)];
            // Mirroring an odd number of axes turns the winding inward: undo it.
            triangles.extend(if s[0] * s[1] * s[2] > 0 { t } else { [t[0], t[2], t[1]] });
        };
        for i in 0..n {
            for j in 0..n - i {
                push(at(i, j), at(i + 1, j), at(i, j + 1));
                if i + j + 1 < n {
                    push(at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                }
            }
        }
    }
    Fixture { positions, triangles }
}
