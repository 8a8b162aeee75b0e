//! What a check reads of a mesh, each array fetched on first use and only then: every
//! array copied into the sandbox costs time (about 1 ms per 8 MB, and as much again when the
//! instance's memory is reset), so `is-oriented` reads one byte per half-edge and nothing
//! else.
//!
//! On the host, the connectivity (twins, edge kinds, the edge list) is the host's derived
//! reads: derived once per mesh version and shared by every check that follows. Natively
//! (tests, benches) it is derived here from the arrays, with the same function the host uses.

use std::cell::OnceCell;

use meshflow_plugin_sdk::topology::{Connectivity, EdgeKind, HalfEdgeView};
use meshflow_plugin_sdk::{Error, Mesh, Result};

/// A mesh's arrays and derived connectivity, read lazily.
pub struct MeshArrays<'a> {
    source: Source<'a>,
    positions: OnceCell<Vec<f32>>,
    triangles: OnceCell<Vec<u32>>,
    opposites: OnceCell<Vec<u32>>,
    kinds: OnceCell<Vec<EdgeKind>>,
    edges: OnceCell<Vec<u32>>,
}

enum Source<'a> {
    Host(Mesh<'a>),
    Arrays { positions: &'a [f32], triangles: &'a [u32], connectivity: Derivation<'a> },
}

/// Plain arrays' connectivity: derived on first use, or given.
enum Derivation<'a> {
    Lazy(OnceCell<Connectivity>),
    Given(&'a Connectivity),
}

impl<'a> MeshArrays<'a> {
    /// The mesh a service runs on: arrays and connectivity come from the host.
    pub fn of(mesh: Mesh<'a>) -> Self {
        Self::with(Source::Host(mesh))
    }

    /// Plain arrays (`x y z` per vertex, three ids per triangle); the connectivity is derived
    /// on first use.
    pub fn native(positions: &'a [f32], triangles: &'a [u32]) -> Self {
        let connectivity = Derivation::Lazy(OnceCell::new());
        Self::with(Source::Arrays { positions, triangles, connectivity })
    }

    /// Plain arrays with their connectivity already derived (by [`Connectivity::new`] on
    /// these triangles), as a host holds it for the checks that follow: what a native
    /// bench times a check alone with.
    pub fn derived(
        positions: &'a [f32],
        triangles: &'a [u32],
        connectivity: &'a Connectivity,
    ) -> Self {
        let connectivity = Derivation::Given(connectivity);
        Self::with(Source::Arrays { positions, triangles, connectivity })
    }

    fn with(source: Source<'a>) -> Self {
        Self {
            source,
            positions: OnceCell::new(),
            triangles: OnceCell::new(),
            opposites: OnceCell::new(),
            kinds: OnceCell::new(),
            edges: OnceCell::new(),
        }
    }

    /// Vertex ids, removed ones included: what makes a triangle's ids in range.
    pub fn vertex_slots(&self) -> usize {
        match &self.source {
            Source::Host(mesh) => mesh.vertex_slots(),
            Source::Arrays { positions, .. } => positions.len() / 3,
        }
    }

    pub fn positions(&self) -> &[f32] {
        match &self.source {
            Source::Host(mesh) => self.positions.get_or_init(|| mesh.positions()),
            Source::Arrays { positions, .. } => positions,
        }
    }

    pub fn triangles(&self) -> &[u32] {
        match &self.source {
            Source::Host(mesh) => self.triangles.get_or_init(|| mesh.triangles()),
            Source::Arrays { triangles, .. } => triangles,
        }
    }

    /// Per half-edge: its twin on a manifold interior edge, else `NONE`.
    pub fn opposites(&self) -> &[u32] {
        match &self.source {
            Source::Host(mesh) => self.opposites.get_or_init(|| mesh.half_edge_opposites()),
            Source::Arrays { positions, triangles, connectivity } => {
                derived(connectivity, positions, triangles).opposites()
            }
        }
    }

    /// Per half-edge: the kind of edge it lies on; an error if the host sent a byte that
    /// names no kind.
    pub fn kinds(&self) -> Result<&[EdgeKind]> {
        match &self.source {
            Source::Host(mesh) => {
                if let Some(kinds) = self.kinds.get() {
                    return Ok(kinds);
                }
                let kinds = mesh.half_edge_kinds()?;
                Ok(self.kinds.get_or_init(|| kinds))
            }
            Source::Arrays { positions, triangles, connectivity } => {
                Ok(derived(connectivity, positions, triangles).half_edges().kinds())
            }
        }
    }

    /// Every edge once in ascending `(smaller, larger)` vertex order, as its smallest
    /// half-edge.
    pub fn edges(&self) -> &[u32] {
        match &self.source {
            Source::Host(mesh) => self.edges.get_or_init(|| mesh.edges()),
            Source::Arrays { positions, triangles, connectivity } => {
                derived(connectivity, positions, triangles).edges()
            }
        }
    }

    /// Twins and kinds together, for the SDK's walks over half-edges.
    pub fn view(&self) -> Result<HalfEdgeView<'_>> {
        HalfEdgeView::new(self.opposites(), self.kinds()?)
            .map_err(|e| Error(format!("the host's connectivity: {e}")))
    }
}

/// The connectivity of plain arrays, derived once (as the host derives it) unless given.
fn derived<'c>(
    derivation: &'c Derivation<'_>,
    positions: &[f32],
    triangles: &[u32],
) -> &'c Connectivity {
    match derivation {
        Derivation::Lazy(cell) => {
            cell.get_or_init(|| Connectivity::new(positions.len() / 3, triangles))
        }
        Derivation::Given(connectivity) => connectivity,
    }
}
