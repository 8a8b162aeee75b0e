//! What remeshing and subdivision need of their input: proper triangles, at most two on
//! each edge, none duplicated. A refusal names the defect and the filter that repairs it.

use std::fmt;

use meshflow_plugin_sdk::topology::halfedge::{EdgeKind, HalfEdges};
use meshflow_plugin_sdk::topology::manifold::has_duplicate_triangles;

#[derive(Clone, Debug, PartialEq, Eq)]
pub enum InputDefect {
    /// Triangles with a repeated or out-of-range corner (or removed ones).
    ImproperTriangles(usize),
    /// Edges with three or more triangles.
    NonManifoldEdges(usize),
    DuplicateTriangles,
}

impl fmt::Display for InputDefect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InputDefect::ImproperTriangles(n) => {
                write!(f, "{n} triangle(s) repeat a vertex; run remove-degenerate-triangles first")
            }
            InputDefect::NonManifoldEdges(n) => {
                write!(f, "{n} edge(s) have more than two triangles; run repair-non-manifold first")
            }
            InputDefect::DuplicateTriangles => {
                write!(f, "some triangles are duplicated; run repair-non-manifold first")
            }
        }
    }
}

/// The half-edges of `triangles`, or the first defect found.
pub fn manifold_edges(vertex_count: usize, triangles: &[u32]) -> Result<HalfEdges, InputDefect> {
    let half_edges = HalfEdges::new(vertex_count, triangles);
    let improper = half_edges.kinds().chunks(3).filter(|k| k[0] == EdgeKind::Degenerate).count();
    if improper > 0 {
        return Err(InputDefect::ImproperTriangles(improper));
    }
    if half_edges.non_manifold_edge_count() > 0 {
        return Err(InputDefect::NonManifoldEdges(half_edges.non_manifold_edge_count()));
    }
    if has_duplicate_triangles(triangles, &half_edges) {
        return Err(InputDefect::DuplicateTriangles);
    }
    Ok(half_edges)
}
