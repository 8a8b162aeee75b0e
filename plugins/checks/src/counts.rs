//! Counts that need the connectivity: edges, components, holes.
//!
//! Vertex and triangle counts come straight from the host (see `lib.rs`); these need the
//! triangle array. Triangles with a repeated or out-of-range vertex id are raw-scan defects:
//! they are counted as the SDK's [`topology`](meshflow_plugin_sdk::topology) module documents,
//! never rejected.

use meshflow_plugin_sdk::topology::{EdgeBuckets, UnionFind, boundary_loops};

/// The number of distinct undirected edges `{a, b}` of the proper triangles (three distinct
/// in-range vertex ids); an edge shared by any number of triangles counts once. O(V + T).
pub fn edge_count(vertex_count: usize, triangles: &[u32]) -> usize {
    let mut edges = 0;
    EdgeBuckets::new(vertex_count, triangles).for_each_edge(|_, _| edges += 1);
    edges
}

/// The number of edge-connected components of triangles: triangles sharing an edge (manifold
/// or not, whatever their orientations) are connected; triangles touching only at a vertex
/// are not. Unreferenced vertices form no component. O(V + T).
pub fn component_count(vertex_count: usize, triangles: &[u32]) -> usize {
    UnionFind::edge_connected(vertex_count, triangles).sets()
}

/// The number of boundary loops (holes, the outer border of an open surface included); a
/// closed surface has none. Loops are separated at bow-tie vertices, so two holes touching
/// at a vertex count twice. O(V + T); the loop walk looks twins up in the edge buckets, as
/// it visits only the boundary, rather than building every half-edge's twin.
pub fn hole_count(vertex_count: usize, triangles: &[u32]) -> usize {
    boundary_loops(triangles, &EdgeBuckets::new(vertex_count, triangles)).len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::*;

    /// `(edges, components, holes)` of a fixture.
    fn counts(mesh: &Fixture) -> (usize, usize, usize) {
        let (v, t) = (mesh.vertex_count(), &mesh.triangles);
        (edge_count(v, t), component_count(v, t), hole_count(v, t))
    }

    #[test]
    fn closed_surfaces_have_no_holes() {
        // Euler: V - E + T = 2 for both.
        assert_eq!(counts(&cube()), (18, 1, 0));
        assert_eq!(counts(&tetrahedron()), (6, 1, 0));
        assert_eq!(counts(&flipped_cube()), (18, 1, 0), "orientation does not change counts");
    }

    #[test]
    fn an_open_face_is_one_hole() {
        // The removed face takes its diagonal with it; the other 17 edges remain.
        assert_eq!(counts(&open_cube()), (17, 1, 1));
    }

    #[test]
    fn a_mobius_strip_has_one_boundary_loop() {
        // Euler characteristic 0: E = V + T = 4 × quads; the border runs around twice.
        assert_eq!(counts(&mobius_strip(6)), (24, 1, 1));
    }

    #[test]
    fn sheets_sharing_an_edge_are_one_component_with_two_borders() {
        // The shared edge once plus two free edges per triangle; the four border paths
        // between vertices 0 and 1 pair up into two loops.
        assert_eq!(counts(&two_sheets()), (9, 1, 2));
    }

    #[test]
    fn a_bow_tie_is_two_components_and_two_holes() {
        assert_eq!(counts(&bow_tie()), (6, 2, 2));
    }

    #[test]
    fn defects_are_counted_not_rejected() {
        // Only the collinear triangle is proper (its edges are three, and it bounds one
        // loop); the repeated-id triangle joins it through edge {0, 1}; the out-of-range one
        // shares {0, 1} too.
        assert_eq!(counts(&degenerate_only()), (3, 1, 1));
        assert_eq!(counts(&Fixture { positions: vec![], triangles: vec![] }), (0, 0, 0));
    }
}
