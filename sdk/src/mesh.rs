//! [`Mesh`]: the host's mesh as a plugin sees it.
//!
//! Read arrays once ([`Mesh::positions`], [`Mesh::triangles`]), compute on them, and write
//! edits back in bulk where a bulk form exists: each call crosses the sandbox boundary
//! (~100 ns) and each list element is copied (~1 ns). Every edit is recorded by the host.

use crate::Result;
use crate::attributes::{
    AttributeDomain, AttributeInfo, AttributeValues, COLOR, NORMAL, QUALITY, TEXCOORD,
};
use crate::bindings::meshflow::geometry::mesh::Mesh as RawMesh;
use crate::geometry::{BoundingBox, bounding_box};

/// What [`Mesh::triangles`] shows in all three corners of a triangle removed in this run.
pub const REMOVED: u32 = u32::MAX;

/// What [`Mesh::instance_key`] returns: the handle, and the mesh's sizes as a second
/// safeguard.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MeshKey {
    handle: u64,
    vertex_slots: usize,
    triangle_slots: usize,
}

/// A borrowed handle to the mesh a service runs on: the host's, or with the `native`
/// feature an in-process one (see [`crate::native`]).
#[derive(Clone, Copy)]
pub struct Mesh<'a> {
    backend: Backend<'a>,
}

#[derive(Clone, Copy)]
enum Backend<'a> {
    Host(&'a RawMesh),
    #[cfg(feature = "native")]
    Native(&'a crate::native::NativeMesh),
}

/// Calls the method of whichever mesh backs this handle; both have the generated import's
/// signatures.
macro_rules! dispatch {
    ($self:ident, $method:ident ( $($arg:expr),* )) => {
        match $self.backend {
            Backend::Host(raw) => raw.$method($($arg),*),
            #[cfg(feature = "native")]
            Backend::Native(native) => native.$method($($arg),*),
        }
    };
}

impl<'a> Mesh<'a> {
    pub fn new(raw: &'a RawMesh) -> Self {
        Self { backend: Backend::Host(raw) }
    }

    #[cfg(feature = "native")]
    pub(crate) fn native(native: &'a crate::native::NativeMesh) -> Self {
        Self { backend: Backend::Native(native) }
    }

    /// Which mesh this is, among those one instance of the plugin is given: equal keys
    /// within one instance are the same mesh. A check (read-only: its mesh cannot change)
    /// may keep what it derived under this key for the checks that follow in the same
    /// instance, as `meshflow check --all` runs them; every other run is an instance of
    /// its own.
    pub fn instance_key(&self) -> MeshKey {
        let handle = match self.backend {
            Backend::Host(raw) => u64::from(raw.handle()),
            #[cfg(feature = "native")]
            Backend::Native(native) => std::ptr::from_ref(native) as u64,
        };
        MeshKey { handle, vertex_slots: self.vertex_slots(), triangle_slots: self.triangle_slots() }
    }

    // ---- bulk reads ------------------------------------------------------------------------

    /// Vertex ids in use, removed ones included.
    pub fn vertex_slots(&self) -> usize {
        dispatch!(self, vertex_slots()) as usize
    }

    /// Triangle ids in use, removed ones included.
    pub fn triangle_slots(&self) -> usize {
        dispatch!(self, triangle_slots()) as usize
    }

    /// Live vertices.
    pub fn vertex_count(&self) -> usize {
        dispatch!(self, vertex_count()) as usize
    }

    /// Live triangles.
    pub fn triangle_count(&self) -> usize {
        dispatch!(self, triangle_count()) as usize
    }

    /// `x y z` per vertex slot.
    pub fn positions(&self) -> Vec<f32> {
        dispatch!(self, positions())
    }

    /// `a b c` per triangle slot; removed triangles read [`REMOVED`] three times.
    pub fn triangles(&self) -> Vec<u32> {
        dispatch!(self, triangles())
    }

    /// Vertices removed during this run, ascending.
    pub fn removed_vertices(&self) -> Vec<u32> {
        dispatch!(self, removed_vertices())
    }

    // ---- the whole mesh, for a service that runs on partitions ---------------------------

    /// Per vertex slot, its id in the whole mesh: on a partition (see [`Service::local`]),
    /// what the host says; on the whole mesh, the slot's own id. A key that stays with a
    /// vertex however the mesh is cut.
    ///
    /// [`Service::local`]: crate::Service::local
    pub fn whole_ids(&self) -> Vec<u32> {
        dispatch!(self, whole_ids()).unwrap_or_else(|| (0..self.vertex_slots() as u32).collect())
    }

    /// The bounding box of the whole mesh as the step received it: on a partition, what the
    /// host says; on the whole mesh, that of `positions`, which must be what
    /// [`positions`](Self::positions) read before any move (passed in, not read again: a
    /// copy of every position). `None` when no coordinate is a number.
    pub fn whole_bounds(&self, positions: &[f32]) -> Option<BoundingBox> {
        match dispatch!(self, whole_bounds()) {
            None => bounding_box(positions),
            Some(bounds) => match bounds[..] {
                [x0, y0, z0, x1, y1, z1] => {
                    Some(BoundingBox { min: [x0, y0, z0], max: [x1, y1, z1] })
                }
                _ => None,
            },
        }
    }

    // ---- derived connectivity: the host derives it once per mesh version ------------------

    /// Per half-edge: its twin on a manifold interior edge (exactly two half-edges of proper
    /// triangles, either orientation), else [`REMOVED`] (`u32::MAX`). Read once per mesh
    /// version by the host, not derived here (see [`topology::HalfEdgeView`]).
    ///
    /// [`topology::HalfEdgeView`]: crate::topology::HalfEdgeView
    pub fn half_edge_opposites(&self) -> Vec<u32> {
        dispatch!(self, half_edge_opposites())
    }

    /// Per half-edge: the kind of edge it lies on; an unknown kind from the host is an
    /// error.
    pub fn half_edge_kinds(&self) -> Result<Vec<crate::topology::EdgeKind>> {
        crate::topology::kinds_from_codes(dispatch!(self, half_edge_kinds()))
            .map_err(|e| crate::Error(format!("the host's edge kinds: {e}")))
    }

    /// Every edge of the proper triangles once, ascending by its (smaller, larger) vertex
    /// ids, as its smallest half-edge id; its length is the edge count.
    pub fn edges(&self) -> Vec<u32> {
        dispatch!(self, edges())
    }

    /// The edge-connected components of the live triangles (joined by an undirected edge
    /// they share, manifold or not, whatever their orientations), ascending by first
    /// triangle, derived by the host: a service that only chooses whole pieces (and removes
    /// them with [`remove_component`](Self::remove_component)) need not read the mesh, and so
    /// takes meshes of any size.
    pub fn components(&self) -> Vec<crate::Component> {
        dispatch!(self, components())
    }

    // ---- per-element reads: one host call each ------------------------------------------

    pub fn position(&self, vertex: u32) -> Result<[f32; 3]> {
        let (x, y, z) = dispatch!(self, position(vertex))?;
        Ok([x, y, z])
    }

    pub fn triangle(&self, triangle: u32) -> Result<[u32; 3]> {
        let (a, b, c) = dispatch!(self, triangle(triangle))?;
        Ok([a, b, c])
    }

    pub fn is_vertex_live(&self, vertex: u32) -> bool {
        dispatch!(self, is_vertex_live(vertex))
    }

    pub fn is_triangle_live(&self, triangle: u32) -> bool {
        dispatch!(self, is_triangle_live(triangle))
    }

    // ---- vertices --------------------------------------------------------------------------

    /// Appends a vertex; returns its id.
    pub fn add_vertex(&self, [x, y, z]: [f32; 3]) -> Result<u32> {
        Ok(dispatch!(self, add_vertex(x, y, z))?)
    }

    /// Appends `xyz.len() / 3` vertices; returns the first id.
    pub fn add_vertices(&self, xyz: &[f32]) -> Result<u32> {
        Ok(dispatch!(self, add_vertices(xyz))?)
    }

    pub fn move_vertex(&self, vertex: u32, [x, y, z]: [f32; 3]) -> Result<()> {
        Ok(dispatch!(self, move_vertex(vertex, x, y, z))?)
    }

    /// Moves `ids[i]` to `xyz[3i..3i + 3]`.
    pub fn move_vertices(&self, ids: &[u32], xyz: &[f32]) -> Result<()> {
        Ok(dispatch!(self, move_vertices(ids, xyz))?)
    }

    /// Moves every vertex at once: `xyz` has 3 values per vertex slot.
    pub fn set_positions(&self, xyz: &[f32]) -> Result<()> {
        Ok(dispatch!(self, set_positions(xyz))?)
    }

    /// Removes the vertex and every triangle using it.
    pub fn remove_vertex(&self, vertex: u32) -> Result<()> {
        Ok(dispatch!(self, remove_vertex(vertex))?)
    }

    pub fn remove_vertices(&self, ids: &[u32]) -> Result<()> {
        Ok(dispatch!(self, remove_vertices(ids))?)
    }

    // ---- triangles -------------------------------------------------------------------------

    /// Appends a triangle; returns its id. Corners must be live and distinct.
    pub fn add_triangle(&self, [a, b, c]: [u32; 3]) -> Result<u32> {
        Ok(dispatch!(self, add_triangle(a, b, c))?)
    }

    /// Appends `abc.len() / 3` triangles; returns the first id.
    pub fn add_triangles(&self, abc: &[u32]) -> Result<u32> {
        Ok(dispatch!(self, add_triangles(abc))?)
    }

    /// Removes a triangle; its vertices stay.
    pub fn remove_triangle(&self, triangle: u32) -> Result<()> {
        Ok(dispatch!(self, remove_triangle(triangle))?)
    }

    pub fn remove_triangles(&self, ids: &[u32]) -> Result<()> {
        Ok(dispatch!(self, remove_triangles(ids))?)
    }

    /// Reverses the orientation (swaps corners 1 and 2).
    pub fn flip_triangle(&self, triangle: u32) -> Result<()> {
        Ok(dispatch!(self, flip_triangle(triangle))?)
    }

    pub fn flip_triangles(&self, ids: &[u32]) -> Result<()> {
        Ok(dispatch!(self, flip_triangles(ids))?)
    }

    /// Splits into three at the centroid; returns the new vertex.
    pub fn split_triangle(&self, triangle: u32) -> Result<u32> {
        Ok(dispatch!(self, split_triangle(triangle))?)
    }

    /// Splits into three at `point`; returns the new vertex.
    pub fn split_triangle_at(&self, triangle: u32, [x, y, z]: [f32; 3]) -> Result<u32> {
        Ok(dispatch!(self, split_triangle_at(triangle, x, y, z))?)
    }

    // ---- edges: half-edge `3 * t + k` runs from corner k to corner (k + 1) % 3 -------------

    /// Adds the triangle `b a apex` beyond half-edge `a -> b`; returns its id.
    pub fn extend_edge(&self, edge: u32, apex: u32) -> Result<u32> {
        Ok(dispatch!(self, extend_edge(edge, apex))?)
    }

    /// Splits the edge (and its triangles) at the midpoint; returns the new vertex.
    pub fn split_edge(&self, edge: u32) -> Result<u32> {
        Ok(dispatch!(self, split_edge(edge))?)
    }

    /// Splits the edge (and its triangles) at `point`; returns the new vertex.
    pub fn split_edge_at(&self, edge: u32, [x, y, z]: [f32; 3]) -> Result<u32> {
        Ok(dispatch!(self, split_edge_at(edge, x, y, z))?)
    }

    /// Flips the diagonal of the two triangles on a manifold interior edge.
    pub fn swap_edge(&self, edge: u32) -> Result<()> {
        Ok(dispatch!(self, swap_edge(edge))?)
    }

    /// Merges the edge's end vertex into its start vertex.
    pub fn collapse_edge(&self, edge: u32) -> Result<()> {
        Ok(dispatch!(self, collapse_edge(edge))?)
    }

    // ---- components and the whole mesh -------------------------------------------------------

    /// Removes the edge-connected component of `triangle` and the vertices it leaves unused.
    pub fn remove_component(&self, triangle: u32) -> Result<()> {
        Ok(dispatch!(self, remove_component(triangle))?)
    }

    /// Applies a row-major 3x4 affine map to the component of `triangle`.
    pub fn transform_component(&self, triangle: u32, matrix: &[f32; 12]) -> Result<()> {
        Ok(dispatch!(self, transform_component(triangle, matrix))?)
    }

    /// Applies a row-major 3x4 affine map to every vertex.
    pub fn transform(&self, matrix: &[f32; 12]) -> Result<()> {
        Ok(dispatch!(self, transform(matrix))?)
    }

    /// Removes everything.
    pub fn clear(&self) -> Result<()> {
        Ok(dispatch!(self, clear())?)
    }

    // ---- attributes: whole arrays, one call each (see [`crate::attributes`]) ----------------

    /// Every attribute the mesh carries, by domain, then name.
    pub fn attributes(&self) -> Vec<AttributeInfo> {
        dispatch!(self, attributes())
    }

    /// An attribute's numbers for every slot of its domain (`components` per element;
    /// removed elements keep their last values), or `None` when the mesh does not carry it.
    pub fn read_attribute(&self, domain: AttributeDomain, name: &str) -> Option<AttributeValues> {
        // The host refuses a read only for a missing attribute (`not-applicable`).
        dispatch!(self, read_attribute(domain, name)).ok()
    }

    /// Sets an attribute at `ids` (`components` numbers each, in order), or at every slot
    /// of its domain when `ids` is `None`; an attribute the mesh does not carry yet is made,
    /// the other elements at the default (opaque white for `color`, else zero). The type and
    /// `components` must match the attribute's (and the shapes of the well-known names).
    /// A check is refused (`read-only`).
    pub fn set_attribute(
        &self,
        domain: AttributeDomain,
        name: &str,
        components: u8,
        ids: Option<&[u32]>,
        values: &AttributeValues,
    ) -> Result<()> {
        Ok(dispatch!(self, set_attribute(domain, name, components, ids, values))?)
    }

    /// Drops an attribute; refused when the mesh does not carry it.
    pub fn remove_attribute(&self, domain: AttributeDomain, name: &str) -> Result<()> {
        Ok(dispatch!(self, remove_attribute(domain, name))?)
    }

    /// RGBA per vertex slot, if the mesh has colours.
    pub fn vertex_colors(&self) -> Option<Vec<[u8; 4]>> {
        match self.read_attribute(AttributeDomain::Vertex, COLOR)? {
            AttributeValues::U8(v) => Some(v.as_chunks::<4>().0.to_vec()),
            _ => None,
        }
    }

    /// Sets colours at `ids` (every vertex slot when `None`).
    pub fn set_vertex_colors(&self, ids: Option<&[u32]>, rgba: &[[u8; 4]]) -> Result<()> {
        let values = AttributeValues::U8(rgba.as_flattened().to_vec());
        self.set_attribute(AttributeDomain::Vertex, COLOR, 4, ids, &values)
    }

    /// Quality per vertex slot, if the mesh has it.
    pub fn quality(&self) -> Option<Vec<f32>> {
        match self.read_attribute(AttributeDomain::Vertex, QUALITY)? {
            AttributeValues::F32(v) => Some(v),
            _ => None,
        }
    }

    /// Sets quality at `ids` (every vertex slot when `None`); values must be finite.
    pub fn set_quality(&self, ids: Option<&[u32]>, quality: &[f32]) -> Result<()> {
        let values = AttributeValues::F32(quality.to_vec());
        self.set_attribute(AttributeDomain::Vertex, QUALITY, 1, ids, &values)
    }

    /// The normal per vertex slot, if the mesh carries normals.
    pub fn vertex_normals(&self) -> Option<Vec<[f32; 3]>> {
        match self.read_attribute(AttributeDomain::Vertex, NORMAL)? {
            AttributeValues::F32(v) => Some(v.as_chunks::<3>().0.to_vec()),
            _ => None,
        }
    }

    /// Sets normals at `ids` (every vertex slot when `None`); the host then leaves those
    /// vertices' normals as given rather than recomputing them.
    pub fn set_vertex_normals(&self, ids: Option<&[u32]>, normals: &[[f32; 3]]) -> Result<()> {
        let values = AttributeValues::F32(normals.as_flattened().to_vec());
        self.set_attribute(AttributeDomain::Vertex, NORMAL, 3, ids, &values)
    }

    /// `u v` per vertex slot, if the mesh has per-vertex texture coordinates.
    pub fn vertex_texcoords(&self) -> Option<Vec<[f32; 2]>> {
        match self.read_attribute(AttributeDomain::Vertex, TEXCOORD)? {
            AttributeValues::F32(v) => Some(v.as_chunks::<2>().0.to_vec()),
            _ => None,
        }
    }

    /// `u v` per corner (`3 * t + k`), if the mesh has per-corner texture coordinates.
    pub fn corner_texcoords(&self) -> Option<Vec<[f32; 2]>> {
        match self.read_attribute(AttributeDomain::Corner, TEXCOORD)? {
            AttributeValues::F32(v) => Some(v.as_chunks::<2>().0.to_vec()),
            _ => None,
        }
    }
}
