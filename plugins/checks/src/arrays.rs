//! What a check reads of a mesh, each array fetched on first use and only then: every
//! array copied into the sandbox costs time (about 1 ms per 8 MB, and as much again when the
//! instance's memory is reset), so `is-oriented` reads one byte per half-edge and nothing
//! else.
//!
//! On the host, the connectivity (twins, edge kinds, the edge list) is the host's derived
//! reads: derived once per mesh version and shared by every check that follows. Natively
//! (tests, benches) it is derived here from the arrays, with the same function the host uses.
//!
//! What was read, and the angle extremes, stay for the next check on the same mesh in the
//! same instance (`check --all` runs several checks in one): a check's mesh is read-only,
//! so they cannot go stale; a mesh under another key replaces them.

use std::cell::{OnceCell, RefCell};
use std::rc::Rc;

use meshflow_plugin_sdk::topology::{Connectivity, EdgeKind, HalfEdgeView};
use meshflow_plugin_sdk::{Error, Mesh, MeshKey, Result};

use crate::angles;

/// A mesh's arrays and derived connectivity, read lazily.
pub struct MeshArrays<'a> {
    source: Source<'a>,
    read: Rc<Read>,
}

/// What has been read from the host or derived so far.
#[derive(Default)]
struct Read {
    positions: OnceCell<Vec<f32>>,
    triangles: OnceCell<Vec<u32>>,
    opposites: OnceCell<Vec<u32>>,
    kinds: OnceCell<Vec<EdgeKind>>,
    edges: OnceCell<Vec<u32>>,
    /// The smallest and largest angle in degrees.
    angle_extremes: OnceCell<(f64, f64)>,
}

thread_local! {
    /// The last host mesh's reads, for the next check on it in this instance.
    static LAST_READ: RefCell<Option<(MeshKey, Rc<Read>)>> = const { RefCell::new(None) };
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
    /// The mesh a service runs on: arrays and connectivity come from the host, or from an
    /// earlier check's reads of the same mesh in this instance.
    pub fn of(mesh: Mesh<'a>) -> Self {
        let key = mesh.instance_key();
        let read = LAST_READ.with_borrow_mut(|last| match last {
            Some((last_key, read)) if *last_key == key => Rc::clone(read),
            _ => {
                let read = Rc::<Read>::default();
                *last = Some((key, Rc::clone(&read)));
                read
            }
        });
        Self { source: Source::Host(mesh), read }
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
        Self { source, read: Rc::default() }
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
            Source::Host(mesh) => self.read.positions.get_or_init(|| mesh.positions()),
            Source::Arrays { positions, .. } => positions,
        }
    }

    pub fn triangles(&self) -> &[u32] {
        match &self.source {
            Source::Host(mesh) => self.read.triangles.get_or_init(|| mesh.triangles()),
            Source::Arrays { triangles, .. } => triangles,
        }
    }

    /// Per half-edge: its twin on a manifold interior edge, else `NONE`.
    pub fn opposites(&self) -> &[u32] {
        match &self.source {
            Source::Host(mesh) => self.read.opposites.get_or_init(|| mesh.half_edge_opposites()),
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
                if let Some(kinds) = self.read.kinds.get() {
                    return Ok(kinds);
                }
                let kinds = mesh.half_edge_kinds()?;
                Ok(self.read.kinds.get_or_init(|| kinds))
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
            Source::Host(mesh) => self.read.edges.get_or_init(|| mesh.edges()),
            Source::Arrays { positions, triangles, connectivity } => {
                derived(connectivity, positions, triangles).edges()
            }
        }
    }

    /// The smallest and the largest angle in degrees ([`angles::angle_extremes`]), found in
    /// one pass for both checks.
    pub fn angle_extremes(&self) -> (f64, f64) {
        *self
            .read
            .angle_extremes
            .get_or_init(|| angles::angle_extremes(self.positions(), self.triangles()))
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
