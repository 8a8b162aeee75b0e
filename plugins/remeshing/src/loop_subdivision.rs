//! Loop subdivision (Loop 1987): every triangle becomes four; edge points are
//! `3/8 (a + b) + 1/8 (c + d)` inside and midpoints on the boundary; an interior vertex of
//! valence `n` moves to `(1 − nβ) v + β Σ neighbours` with Loop's
//! `β = (5/8 − (3/8 + 1/4 cos 2π/n)²) / n`; a boundary vertex with two boundary edges to
//! `3/4 v + 1/8 (b₀ + b₁)`; corners (more boundary edges, several fans) stay fixed.

use std::fmt;

use meshflow_plugin_sdk::geometry::{Vec3, add, point, scale};
use meshflow_plugin_sdk::topology::NONE;
use meshflow_plugin_sdk::topology::adjacency::{VertexNeighbours, VertexTriangles};
use meshflow_plugin_sdk::topology::halfedge::{HalfEdges, next, origin, prev, target};

use crate::input::{InputDefect, manifold_edges};

/// The most triangles subdivision may produce; four times as many per iteration.
pub const MAX_OUTPUT_TRIANGLES: usize = 8_000_000;

/// Why a mesh cannot be subdivided.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Refusal {
    Input(InputDefect),
    /// The result would exceed [`MAX_OUTPUT_TRIANGLES`].
    TooLarge {
        triangles: usize,
    },
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Input(defect) => defect.fmt(f),
            Refusal::TooLarge { triangles } => write!(
                f,
                "the result would have {triangles} triangles, above the limit of \
                 {MAX_OUTPUT_TRIANGLES}; use fewer iterations"
            ),
        }
    }
}

/// One level of subdivision: the old vertices' new positions, the edge points appended after
/// them, and the new triangles (four per old one, in order, orientation kept).
#[derive(Clone, Debug, PartialEq)]
pub struct Subdivided {
    pub positions: Vec<f32>,
    pub triangles: Vec<u32>,
    /// Per edge point, in id order: the ends of the edge it splits (ids of the vertices
    /// before its level, so an earlier level's edge points come first). Attributes blend
    /// them half and half.
    pub edge_ends: Vec<[u32; 2]>,
}

/// `iterations` levels of Loop subdivision of a mesh whose triangles are all proper and
/// whose edges have at most two triangles. Unreferenced vertices keep their positions.
pub fn loop_subdivision(
    positions: &[f32],
    triangles: &[u32],
    iterations: u32,
) -> Result<Subdivided, Refusal> {
    let output = (triangles.len() / 3).saturating_mul(4usize.saturating_pow(iterations));
    if output > MAX_OUTPUT_TRIANGLES {
        return Err(Refusal::TooLarge { triangles: output });
    }
    let mut mesh = Subdivided {
        positions: positions.to_vec(),
        triangles: triangles.to_vec(),
        edge_ends: Vec::new(),
    };
    for _ in 0..iterations {
        let level = subdivide_once(&mesh.positions, &mesh.triangles)?;
        let mut edge_ends = std::mem::take(&mut mesh.edge_ends);
        edge_ends.extend(level.edge_ends);
        mesh = Subdivided { edge_ends, ..level };
    }
    Ok(mesh)
}

fn subdivide_once(positions: &[f32], triangles: &[u32]) -> Result<Subdivided, Refusal> {
    let n = positions.len() / 3;
    let half_edges = manifold_edges(n, triangles).map_err(Refusal::Input)?;

    // Edge points, one per edge, numbered after the old vertices in half-edge order.
    let mut edge_vertex = vec![NONE; half_edges.len()];
    let mut new_positions = vertex_points(positions, triangles, &half_edges);
    let mut edge_ends = Vec::new();
    for h in 0..half_edges.len() as u32 {
        if edge_vertex[h as usize] != NONE {
            continue;
        }
        let id = (new_positions.len() / 3) as u32;
        let (a, b) =
            (point(positions, origin(triangles, h)), point(positions, target(triangles, h)));
        let twin = half_edges.opposite(h);
        let p = if twin == NONE {
            scale(add(a, b), 0.5)
        } else {
            edge_vertex[twin as usize] = id;
            let c = point(positions, origin(triangles, prev(h)));
            let d = point(positions, origin(triangles, prev(twin)));
            add(scale(add(a, b), 3.0 / 8.0), scale(add(c, d), 1.0 / 8.0))
        };
        edge_vertex[h as usize] = id;
        new_positions.extend(p.map(|x| x as f32));
        edge_ends.push([origin(triangles, h), target(triangles, h)]);
    }

    let mut new_triangles = Vec::with_capacity(4 * triangles.len());
    for t in 0..triangles.len() as u32 / 3 {
        let h = 3 * t;
        let [a, b, c] = [h, next(h), prev(h)].map(|e| origin(triangles, e));
        let [ab, bc, ca] = [h, next(h), prev(h)].map(|e| edge_vertex[e as usize]);
        new_triangles.extend([a, ab, ca, ab, b, bc, ca, bc, c, ab, bc, ca]);
    }
    Ok(Subdivided { positions: new_positions, triangles: new_triangles, edge_ends })
}

/// The old vertices' new positions (`x y z` per vertex).
fn vertex_points(positions: &[f32], triangles: &[u32], half_edges: &HalfEdges) -> Vec<f32> {
    let n = positions.len() / 3;
    let around = VertexTriangles::new(n, triangles);
    let neighbours = VertexNeighbours::from_vertex_triangles(&around, triangles);
    // Per vertex: boundary edges and the sum of their other ends.
    let mut boundary_count = vec![0u32; n];
    let mut boundary_sum = vec![[0.0f64; 3]; n];
    for h in half_edges.boundary_half_edges() {
        let (a, b) = (origin(triangles, h), target(triangles, h));
        for (v, w) in [(a, b), (b, a)] {
            boundary_count[v as usize] += 1;
            boundary_sum[v as usize] = add(boundary_sum[v as usize], point(positions, w));
        }
    }
    let mut out = Vec::with_capacity(positions.len() * 4);
    for v in 0..n as u32 {
        let p = point(positions, v);
        let ring = neighbours.of(v);
        let valence = ring.len();
        let moved: Vec3 = match boundary_count[v as usize] {
            0 if valence >= 3 && valence == around.of(v).len() => {
                let beta = loop_beta(valence);
                let sum = ring.iter().fold([0.0; 3], |s, &w| add(s, point(positions, w)));
                add(scale(p, 1.0 - valence as f64 * beta), scale(sum, beta))
            }
            2 => add(scale(p, 0.75), scale(boundary_sum[v as usize], 0.125)),
            // Unreferenced, a corner, or where fans meet: held.
            _ => p,
        };
        out.extend(moved.map(|x| x as f32));
    }
    out
}

/// Loop's weight of each neighbour of an interior vertex of valence `n`.
fn loop_beta(n: usize) -> f64 {
    let c = 0.375 + 0.25 * (std::f64::consts::TAU / n as f64).cos();
    (0.625 - c * c) / n as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use meshflow_plugin_sdk::topology::manifold::{is_manifold, is_oriented};

    fn close(a: &[f32], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] as f64 - b[k]).abs() < 1e-6)
    }

    #[test]
    fn a_tetrahedron_matches_the_hand_computed_points() {
        // Regular: each vertex is minus the sum of the other three.
        let p = vec![1.0, 1.0, 1.0, 1.0, -1.0, -1.0, -1.0, 1.0, -1.0, -1.0, -1.0, 1.0];
        let t = vec![0, 1, 2, 0, 2, 3, 0, 3, 1, 1, 3, 2];
        let s = loop_subdivision(&p, &t, 1).unwrap();
        assert_eq!((s.positions.len() / 3, s.triangles.len() / 3), (10, 16));
        // n = 3, β = 3/16: v' = 7/16 v + 3/16 (−v) = v / 4.
        for v in 0..4 {
            let q = point(&p, v as u32);
            assert!(close(&s.positions[3 * v..], scale(q, 0.25)));
        }
        // Edge a–b: 3/8 (a + b) + 1/8 (c + d) = 1/4 (a + b), as c + d = −(a + b).
        for e in 4..10 {
            let m = &s.positions[3 * e..3 * e + 3];
            let found = (0..4).any(|a| {
                (a + 1..4).any(|b| close(m, scale(add(point(&p, a), point(&p, b)), 0.25)))
            });
            assert!(found, "edge point {m:?}");
        }
        let he = HalfEdges::new(10, &s.triangles);
        assert!(is_manifold(10, &s.triangles, &he) && is_oriented(&he) && he.is_closed());
        // Two levels: 16 · 4 triangles, 10 + 24 edges' points.
        let s2 = loop_subdivision(&p, &t, 2).unwrap();
        assert_eq!((s2.positions.len() / 3, s2.triangles.len() / 3), (34, 64));
    }

    #[test]
    fn an_open_hexagon_fan_follows_the_boundary_rules() {
        // Centre (0, 0, 1) and a unit hexagon ring at z = 0.
        let mut p = vec![0.0, 0.0, 1.0];
        for i in 0..6 {
            let a = std::f64::consts::TAU * i as f64 / 6.0;
            p.extend([a.cos() as f32, a.sin() as f32, 0.0]);
        }
        let t: Vec<u32> = (0..6).flat_map(|i| [0, 1 + i, 1 + (i + 1) % 6]).collect();
        let s = loop_subdivision(&p, &t, 1).unwrap();
        assert_eq!((s.positions.len() / 3, s.triangles.len() / 3), (19, 24));
        // Centre: n = 6, β = 1/16; the ring sums to 0: (1 − 6/16) (0, 0, 1).
        assert!(close(&s.positions[0..3], [0.0, 0.0, 0.625]));
        for i in 0..6usize {
            let r = point(&p, 1 + i as u32);
            // Ring: 3/4 r + 1/8 (r₋ + r₊) = 7/8 r on a regular hexagon.
            assert!(close(&s.positions[3 + 3 * i..], scale(r, 0.875)));
            let next = point(&p, 1 + ((i + 1) % 6) as u32);
            let spoke = add([0.0, 0.0, 0.375], scale(r, 0.5));
            let rim = scale(add(r, next), 0.5);
            let has = |q: Vec3| s.positions.chunks(3).skip(7).any(|m| close(m, q));
            assert!(has(spoke), "spoke point of {i}");
            assert!(has(rim), "rim midpoint of {i}");
        }
        let he = HalfEdges::new(19, &s.triangles);
        assert!(is_manifold(19, &s.triangles, &he) && is_oriented(&he));
        assert_eq!(he.boundary_edge_count(), 12);
    }

    #[test]
    fn bad_input_is_refused_by_name() {
        let p = vec![0.0; 15];
        let fin = vec![0, 1, 2, 1, 0, 3, 0, 1, 4];
        assert_eq!(
            loop_subdivision(&p, &fin, 1),
            Err(Refusal::Input(InputDefect::NonManifoldEdges(1)))
        );
        assert_eq!(
            loop_subdivision(&p, &[0, 0, 1], 1),
            Err(Refusal::Input(InputDefect::ImproperTriangles(1)))
        );
        let big = [0u32, 1, 2].repeat(10);
        assert!(matches!(loop_subdivision(&p, &big, 12), Err(Refusal::TooLarge { .. })));
        // Unreferenced vertices stay, and an empty mesh is fine.
        let s = loop_subdivision(&p, &[], 2).unwrap();
        assert_eq!(s.positions, p);
    }
}
