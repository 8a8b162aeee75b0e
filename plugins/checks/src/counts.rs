//! Counts that need the connectivity: edges, components, holes.
//!
//! Vertex and triangle counts come straight from the host (see `lib.rs`); these read the
//! host's derived connectivity ([`MeshArrays`]). Triangles with a repeated or out-of-range
//! vertex id are raw-scan defects: they are counted as the SDK's
//! [`topology`](meshflow_plugin_sdk::topology) module documents, never rejected.

use meshflow_plugin_sdk::Result;
use meshflow_plugin_sdk::topology::halfedge::edge_key;
use meshflow_plugin_sdk::topology::{EdgeKind, NONE, UnionFind, boundary_loops, contains_kind};

use crate::arrays::MeshArrays;

/// The number of distinct undirected edges `{a, b}` of the proper triangles (three distinct
/// in-range vertex ids); an edge shared by any number of triangles counts once: the length
/// of the host's edge list.
pub fn edge_count(mesh: &MeshArrays) -> usize {
    mesh.edges().len()
}

/// The number of edge-connected components of triangles: triangles sharing an edge (manifold
/// or not, whatever their orientations) are connected; triangles touching only at a vertex
/// are not. Unreferenced vertices form no component. O(T) over the twins.
pub fn component_count(mesh: &MeshArrays) -> Result<usize> {
    Ok(edge_connected(mesh)?.sets())
}

/// The triangles joined through every edge they share (as
/// [`UnionFind::edge_connected`](meshflow_plugin_sdk::topology::UnionFind::edge_connected)
/// groups them), from the derived connectivity where it has every edge.
pub fn edge_connected(mesh: &MeshArrays) -> Result<UnionFind> {
    let kinds = mesh.kinds()?;
    // An improper triangle still joins its neighbours through its edges with two distinct
    // in-range ids, which the derived connectivity leaves out: such a mesh is grouped over
    // every edge from the triangles, as before the host derived anything.
    if contains_kind(kinds, EdgeKind::Degenerate) {
        return Ok(UnionFind::edge_connected(mesh.vertex_slots(), mesh.triangles()));
    }
    let mut forest = UnionFind::new(kinds.len() / 3);
    for (h, &twin) in mesh.opposites().iter().enumerate() {
        if twin != NONE && twin as usize > h {
            forest.union(h as u32 / 3, twin / 3);
        }
    }
    // The triangles of a non-manifold edge have no twins: group its half-edges by edge.
    if contains_kind(kinds, EdgeKind::NonManifold) {
        let triangles = mesh.triangles();
        let mut sheets: Vec<((u32, u32), u32)> = (0..kinds.len() as u32)
            .filter(|&h| kinds[h as usize] == EdgeKind::NonManifold)
            .map(|h| (edge_key(triangles, h), h))
            .collect();
        sheets.sort_unstable();
        for pair in sheets.windows(2) {
            if pair[0].0 == pair[1].0 {
                forest.union(pair[0].1 / 3, pair[1].1 / 3);
            }
        }
    }
    Ok(forest)
}

/// The number of boundary loops (holes, the outer border of an open surface included); a
/// closed surface has none. Loops are separated at bow-tie vertices, so two holes touching
/// at a vertex count twice. O(boundary) walking, after one pass over the kinds.
pub fn hole_count(mesh: &MeshArrays) -> Result<usize> {
    Ok(boundary_loops(mesh.triangles(), &mesh.view()?).len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::*;

    /// `(edges, components, holes)` of a fixture.
    fn counts(mesh: &Fixture) -> (usize, usize, usize) {
        let arrays = MeshArrays::native(&mesh.positions, &mesh.triangles);
        (edge_count(&arrays), component_count(&arrays).unwrap(), hole_count(&arrays).unwrap())
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
