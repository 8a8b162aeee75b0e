//! Connectivity and geometry over flat index arrays, shared by the SDK, the plugins and the
//! codec. This crate must not depend on wit-bindgen, wasmtime or any other meshflow crate.
//!
//!
//! Every function here works on `triangles: &[u32]` (three vertex ids per triangle; a trailing
//! incomplete triangle is ignored) and, where vertices matter, an explicit `vertex_count`
//! (normally `positions.len() / 3`). Nothing here panics on raw-scan defects: non-manifold
//! edges and vertices, unreferenced vertices, degenerate and duplicated triangles are all
//! classified, never rejected.
//!
//! # Conventions
//!
//! - Half-edge `h = 3 * t + k` runs from corner `k` of triangle `t` to corner `(k + 1) % 3`
//!   (see [`halfedge`]). Ids are `u32`; [`NONE`] (`u32::MAX`) means "none".
//! - A triangle is **proper** when its three vertex ids are distinct and `< vertex_count`.
//!   Improper triangles (a repeated id, or an id out of range) have no orientation and no
//!   area, so they contribute **no half-edges**: [`HalfEdges`] classifies all three of their
//!   half-edges as [`EdgeKind::Degenerate`]. They are still listed around their (in-range)
//!   vertices by [`VertexTriangles`] and still join their neighbours in
//!   [`TriangleComponents`] through their proper edges.
//! - Results are deterministic functions of the input: no hashing, no randomness.
//! - Sizes: up to 715M triangles (half-edge ids below 2^31), far beyond a wasm32 memory.
//!
//! # Choosing a structure
//!
//! | need                                   | build                              | cost            |
//! |----------------------------------------|------------------------------------|-----------------|
//! | triangles around a vertex              | [`VertexTriangles::new`]           | O(V + T)        |
//! | neighbour vertices (e.g. Laplacian)    | [`VertexNeighbours::new`]          | O(V + T·log d)  |
//! | one pass over the edges, few lookups   | [`EdgeBuckets::new`]               | O(V + T·log d)  |
//! | twins, edge kinds, edge count          | [`HalfEdges::new`]                 | O(V + T·log d)  |
//! | twins, kinds and edge list, in bulk    | [`Connectivity::new`] (host-side)  | O(V + T·log d)  |
//! | twins and kinds from the host's arrays | [`HalfEdgeView::new`]              | O(1)            |
//! | holes                                  | [`boundary_loops`]                 | O(boundary)     |
//! | connected components                   | [`TriangleComponents::new`]        | O(V + T·log d)  |
//! | manifold / oriented / orientable       | [`manifold`] on a `HalfEdges`      | O(V + T)        |
//! | uniform / cotangent Laplacian          | [`laplacian`] on a `VertexNeighbours` | O(V + E)     |
//! | enclosed volume per closed component   | [`measure::closed_component_volumes`] | O(V + T·log d) |
//!
//! (`d` is the vertex degree, about 6 on scans, so the `log d` factors are small constants.)

pub mod adjacency;
pub mod boundary;
pub mod components;
pub mod connectivity;
mod csr;
pub mod edges;
pub mod edits;
pub mod geometry;
mod half_edge_ids;
pub mod halfedge;
pub mod laplacian;
pub mod manifold;
pub mod measure;
pub mod shapes;
pub mod transform;

pub use adjacency::{VertexNeighbours, VertexTriangles, unreferenced_vertices};
pub use boundary::{BoundaryLoop, boundary_loops, boundary_vertices};
pub use components::{TriangleComponents, UnionFind};
pub use connectivity::{
    Connectivity, ConnectivityError, HalfEdgeView, contains_kind, kinds_from_codes,
};
pub use csr::{Csr, for_each_by_four};
pub use edges::{EdgeBuckets, Members};
pub use halfedge::{EdgeKind, EdgeLookup, HalfEdges};
pub use laplacian::{
    cotangent_laplacian, uniform_laplacian, visit_uniform_laplacian, visit_weighted_mean,
};
pub use manifold::{
    has_duplicate_triangles, has_improper_triangles, is_edge_manifold, is_manifold, is_orientable,
    is_oriented, is_vertex_manifold, non_manifold_vertices, orientation_flips, orientation_patches,
};

/// "No element": a missing twin, an absent triangle. Equal to `u32::MAX`.
pub const NONE: u32 = u32::MAX;

/// The number of complete triangles in a flat index array (`triangles.len() / 3`).
#[inline]
pub fn triangle_count(triangles: &[u32]) -> usize {
    triangles.len() / 3
}

/// Every triangle not removed during the current run, as `(id, corners)`: a removed one
/// reads [`NONE`] in all three corners (the SDK's `REMOVED`). Ids stay those of the flat
/// array, so edits can name them. O(1) per item.
pub fn live_triangles(triangles: &[u32]) -> impl Iterator<Item = (u32, [u32; 3])> + '_ {
    triangles
        .chunks_exact(3)
        .enumerate()
        .filter(|(_, c)| c[0] != NONE)
        .map(|(t, c)| (t as u32, [c[0], c[1], c[2]]))
}

/// Whether triangle `t` is proper: three distinct vertex ids, all `< vertex_count`. O(1).
///
/// Panics if `t` is not a triangle of `triangles`.
#[inline]
pub fn is_proper_triangle(triangles: &[u32], vertex_count: usize, t: u32) -> bool {
    let i = 3 * t as usize;
    proper([triangles[i], triangles[i + 1], triangles[i + 2]], vertex_count)
}

#[inline]
pub(crate) fn proper(c: [u32; 3], vertex_count: usize) -> bool {
    c[0] != c[1]
        && c[1] != c[2]
        && c[0] != c[2]
        && (c[0] as usize) < vertex_count
        && (c[1] as usize) < vertex_count
        && (c[2] as usize) < vertex_count
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn live_triangles_skip_removed_ones_and_keep_their_ids() {
        let triangles = [0, 1, 2, NONE, NONE, NONE, 2, 1, 3, 7];
        let live: Vec<_> = live_triangles(&triangles).collect();
        assert_eq!(live, [(0, [0, 1, 2]), (2, [2, 1, 3])]);
    }
}
