//! Boundary loops (holes) and boundary vertices.

use super::NONE;
use super::halfedge::{EdgeKind, EdgeLookup, HalfEdges, next, origin, prev, target};

/// One boundary loop: a cycle (rarely an open chain, see [`boundary_loops`]) of boundary
/// half-edges, each sharing its end vertex with the start of the next.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BoundaryLoop {
    /// The boundary half-edges in walking order, starting at the smallest id of the loop.
    pub half_edges: Vec<u32>,
    /// `vertices[i]` is where step `i` (along `half_edges[i]`) starts; same length as
    /// `half_edges`. On an oriented surface step `i` runs along its half-edge, so
    /// `vertices[i] == origin(half_edges[i])` and the loop runs with the triangles on its left.
    pub vertices: Vec<u32>,
    /// Whether the last step ends where the first starts. `false` only at non-manifold
    /// configurations where the boundary edges at a vertex cannot all be paired.
    pub closed: bool,
    /// Whether every step runs along its half-edge's direction. `false` when the loop crosses
    /// an orientation seam (e.g. the boundary of a Möbius strip).
    pub consistent: bool,
}

impl BoundaryLoop {
    /// The number of edges in the loop. O(1).
    #[inline]
    pub fn len(&self) -> usize {
        self.half_edges.len()
    }

    /// Whether the loop has no edges (never true for a loop returned by [`boundary_loops`]).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.half_edges.is_empty()
    }
}

/// The boundary loops of a mesh (the `hole-count` is their number). O(B log B + Σ fan sizes at
/// boundary vertices) ≤ O(T) in practice; memory one bit per half-edge plus the result.
///
/// **Order**: loops are ordered by their smallest half-edge id, and each starts at that
/// half-edge, walked along its own direction (origin → target), so on an oriented mesh every
/// loop has the surface on its left and `vertices` are the half-edges' origins.
///
/// **Next edge rule**: arriving at vertex `v`, the walk turns through the triangle fan around
/// `v`: from the current triangle it crosses to the next triangle around `v` over manifold
/// interior edges (either orientation) until it meets a boundary edge; that is the next step.
/// This stays on the same side of a pinched (bow-tie) vertex, so a vertex where several holes
/// or sheets meet is visited once per fan. When the fan walk meets a non-manifold edge instead
/// (or returns an edge already used), the loop closes if `v` is where it started; otherwise it
/// continues with the smallest unused boundary half-edge at `v`, and if there is none the loop
/// ends open (`closed == false`). Every boundary half-edge ends up in exactly one loop.
///
/// `half_edges` must have been built from the same `triangles`: a [`HalfEdges`], or when only
/// the loops are needed, the cheaper [`EdgeBuckets::new`](super::EdgeBuckets::new).
pub fn boundary_loops(triangles: &[u32], half_edges: &impl EdgeLookup) -> Vec<BoundaryLoop> {
    let mut used = vec![0u64; half_edges.half_edge_count().div_ceil(64)];
    let is_used = |used: &[u64], h: u32| used[h as usize / 64] >> (h % 64) & 1 == 1;
    let set_used = |used: &mut [u64], h: u32| used[h as usize / 64] |= 1 << (h % 64);
    // (vertex, boundary half-edge) pairs for the fallback rule, built on first need.
    let mut at_vertex: Option<Vec<(u32, u32)>> = None;
    let mut loops = Vec::new();
    let boundary = half_edges.sorted_boundary_half_edges();
    for &h0 in &boundary {
        if is_used(&used, h0) {
            continue;
        }
        set_used(&mut used, h0);
        let start = origin(triangles, h0);
        let mut lp = BoundaryLoop {
            half_edges: vec![h0],
            vertices: vec![start],
            closed: false,
            consistent: true,
        };
        let (mut cur, mut v) = (h0, target(triangles, h0));
        loop {
            let fan = fan_successor(triangles, half_edges, cur, v);
            if fan == h0 && start == v {
                lp.closed = true;
                break;
            }
            let step = if fan != NONE && !is_used(&used, fan) {
                fan
            } else if v == start {
                lp.closed = true;
                break;
            } else {
                let list = at_vertex.get_or_insert_with(|| boundary_ends(triangles, &boundary));
                let first = list.partition_point(|&(w, _)| w < v);
                match list[first..]
                    .iter()
                    .take_while(|&&(w, _)| w == v)
                    .find(|&&(_, g)| !is_used(&used, g))
                {
                    Some(&(_, g)) => g,
                    None => break,
                }
            };
            set_used(&mut used, step);
            let (a, b) = (origin(triangles, step), target(triangles, step));
            lp.half_edges.push(step);
            lp.vertices.push(v);
            lp.consistent &= a == v;
            cur = step;
            v = if a == v { b } else { a };
        }
        loops.push(lp);
    }
    loops
}

/// From boundary half-edge `cur` incident to `v`, turns through the fan around `v` over
/// interior edges to the next boundary half-edge, or [`NONE`] at a non-manifold edge.
fn fan_successor(triangles: &[u32], half_edges: &impl EdgeLookup, cur: u32, v: u32) -> u32 {
    // The other half-edge of g's triangle that touches v (g touches v).
    let other_at = |g: u32| {
        if origin(triangles, g) == v { prev(g) } else { next(g) }
    };
    let mut e = other_at(cur);
    // A fan walk from a boundary edge visits each triangle at most once; the bound only
    // guards against misuse (half-edges built from other triangles).
    for _ in 0..=half_edges.half_edge_count() / 3 {
        match half_edges.kind(e) {
            EdgeKind::Boundary => return e,
            EdgeKind::Interior | EdgeKind::InteriorInconsistent => {
                e = other_at(half_edges.opposite(e))
            }
            EdgeKind::NonManifold | EdgeKind::Degenerate => return NONE,
        }
    }
    NONE
}

/// Every boundary half-edge listed under both endpoints, sorted by (vertex, half-edge).
fn boundary_ends(triangles: &[u32], boundary: &[u32]) -> Vec<(u32, u32)> {
    let mut ends: Vec<(u32, u32)> = boundary
        .iter()
        .flat_map(|&h| [(origin(triangles, h), h), (target(triangles, h), h)])
        .collect();
    ends.sort_unstable();
    ends
}

/// Marks the vertices `< vertex_count` that lie on a boundary edge. O(V + H).
///
/// Vertices on non-manifold edges are not marked; add them from
/// [`HalfEdges::non_manifold_edges`] if an algorithm must keep them fixed too.
pub fn boundary_vertices(
    vertex_count: usize,
    triangles: &[u32],
    half_edges: &HalfEdges,
) -> Vec<bool> {
    let mut mask = vec![false; vertex_count];
    for h in half_edges.boundary_half_edges() {
        mask[origin(triangles, h) as usize] = true;
        mask[target(triangles, h) as usize] = true;
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn single_triangle() {
        let t = [0, 1, 2];
        let he = HalfEdges::new(3, &t);
        let loops = boundary_loops(&t, &he);
        assert_eq!(loops.len(), 1);
        assert_eq!(loops[0].half_edges, [0, 1, 2]);
        assert_eq!(loops[0].vertices, [0, 1, 2]);
        assert!(loops[0].closed && loops[0].consistent);
        assert_eq!(boundary_vertices(4, &t, &he), [true, true, true, false]);
    }
}
