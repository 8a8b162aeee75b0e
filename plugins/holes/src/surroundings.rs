//! What the mesh around the holes looks like, gathered in one pass over all edges: each
//! loop vertex's scale (mean incident edge length, Liepa's σ) and neighbour ring (for
//! fairing), and the edges between loop vertices (a fill must not add them a second time).

use std::collections::BTreeSet;

use meshflow_plugin_sdk::geometry::{add, distance, point};
use meshflow_plugin_sdk::topology::NONE;
use meshflow_plugin_sdk::topology::halfedge::{EdgeKind, HalfEdges, origin, target};

use crate::fair::Ring;

/// Per-vertex data for the vertices of the holes to fill.
pub struct Surroundings {
    /// Index into `rings` / `length_sums` per mesh vertex, [`NONE`] if not on a hole.
    slot: Vec<u32>,
    rings: Vec<Ring>,
    length_sums: Vec<f64>,
    /// Edges `(min, max)` whose both ends are loop vertices: the mesh's, then the fills'.
    rim_edges: BTreeSet<(u32, u32)>,
}

impl Surroundings {
    /// Gathers the surroundings of `rim_vertices` (the vertices of every hole to fill). One
    /// pass over the half-edges: O(T + R log R) for R edges between loop vertices.
    pub fn new(
        positions: &[f32],
        triangles: &[u32],
        half_edges: &HalfEdges,
        rim_vertices: impl IntoIterator<Item = u32>,
    ) -> Self {
        let mut slot = vec![NONE; positions.len() / 3];
        let mut next_slot = 0;
        for v in rim_vertices {
            if slot[v as usize] == NONE {
                slot[v as usize] = next_slot;
                next_slot += 1;
            }
        }
        let mut this = Surroundings {
            slot,
            rings: vec![Ring::default(); next_slot as usize],
            length_sums: vec![0.0; next_slot as usize],
            rim_edges: BTreeSet::new(),
        };
        for h in 0..half_edges.len() as u32 {
            let twin = half_edges.opposite(h);
            // Each undirected edge once: from its smaller half-edge (the only one on a boundary).
            if half_edges.kind(h) == EdgeKind::Degenerate || (twin != NONE && twin < h) {
                continue;
            }
            let (a, b) = (origin(triangles, h), target(triangles, h));
            let (sa, sb) = (this.slot[a as usize], this.slot[b as usize]);
            if sa == NONE && sb == NONE {
                continue;
            }
            let (pa, pb) = (point(positions, a), point(positions, b));
            let length = distance(pa, pb);
            for (s, other) in [(sa, pb), (sb, pa)] {
                if s != NONE {
                    let ring = &mut this.rings[s as usize];
                    *ring = Ring { sum: add(ring.sum, other), count: ring.count + 1 };
                    this.length_sums[s as usize] += length;
                }
            }
            if sa != NONE && sb != NONE {
                this.rim_edges.insert((a.min(b), a.max(b)));
            }
        }
        this
    }

    /// The mean length of the mesh edges at loop vertex `v` (0 if it has none).
    pub fn scale(&self, v: u32) -> f64 {
        let s = self.slot[v as usize] as usize;
        self.length_sums[s] / self.rings[s].count.max(1) as f64
    }

    /// The mesh neighbours of loop vertex `v`.
    pub fn ring(&self, v: u32) -> Ring {
        self.rings[self.slot[v as usize] as usize]
    }

    /// Whether loop vertices `a` and `b` are already joined by an edge.
    pub fn has_edge(&self, a: u32, b: u32) -> bool {
        self.rim_edges.contains(&(a.min(b), a.max(b)))
    }

    /// Records an edge a fill added between loop vertices `a` and `b`.
    pub fn add_edge(&mut self, a: u32, b: u32) {
        self.rim_edges.insert((a.min(b), a.max(b)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rings_scales_and_edges_of_a_square_fan() {
        // Four triangles around centre 4; vertices 0..4 form the outer (boundary) square.
        let positions = [0., 0., 0., 2., 0., 0., 2., 2., 0., 0., 2., 0., 1., 1., 0.];
        let triangles = [0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4];
        let he = HalfEdges::new(5, &triangles);
        let s = Surroundings::new(&positions, &triangles, &he, [0, 1, 2, 3, 0]);
        // Vertex 0: neighbours 1, 3 (length 2) and 4 (length √2), each once.
        assert_eq!(s.ring(0), Ring { sum: [3.0, 3.0, 0.0], count: 3 });
        assert!((s.scale(0) - (4.0 + 2f64.sqrt()) / 3.0).abs() < 1e-12);
        assert!(s.has_edge(1, 0) && s.has_edge(3, 0) && !s.has_edge(0, 2));
    }
}
