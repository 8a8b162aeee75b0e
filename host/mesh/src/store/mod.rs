//! The recording mesh store: the only writer of mesh state on a host.
//!
//! A step starts from a compact [`MeshData`]. Every edit goes through [`MeshStore::apply`],
//! which validates it completely before changing anything, performs it, and appends it to
//! the log. Removed elements stay as tombstones until [`MeshStore::finish`] compacts the mesh
//! deterministically (survivors keep their relative order), so two stores that apply the
//! same ops to the same mesh end with byte-identical data.
//!
//! ```
//! use meshflow_mesh::{MeshData, store::{MeshStore, Op}};
//! let quad = MeshData::new(
//!     vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
//!     vec![0, 1, 2, 0, 2, 3],
//! );
//! let mut store = MeshStore::new(quad.clone());
//! store.apply(Op::RemoveTriangles { ids: vec![1] }).unwrap();
//! let (result, log) = store.finish();
//! assert_eq!(result.triangles, vec![0, 1, 2]);
//!
//! let mut replay = MeshStore::new(quad);
//! for op in log {
//!     replay.apply(op).unwrap();
//! }
//! assert_eq!(replay.finish().0.content_hash(), result.content_hash());
//! ```

mod attributes;
mod compact;
mod components;
mod edges;
mod error;
mod incidence;
mod op;
mod triangles;
mod vertices;

pub use components::Component;
pub use error::{EditError, EditErrorKind};
pub use op::{Affine, Op, OpKind};

use std::sync::Arc;

use crate::MeshData;
use crate::attributes::{Domain, NORMAL};
use crate::partition::Whole;
use attributes::{CornerOrigin, NormalTracking};
use incidence::Incidence;

/// What the bulk triangle read shows in all three corners of a removed triangle.
pub const REMOVED: u32 = u32::MAX;

/// Finding the triangles around a vertex without the incidence index is a scan of every
/// corner (0.5 ms on 2M triangles); building the index costs about 40 scans (20 ms). A step
/// making a handful of topological edits (repairing the degenerate triangles of a scan:
/// five) scans; one making more builds the index at the first query past this many, paying
/// at most half as much again.
const SCANS_BEFORE_INDEX: usize = 16;

/// A copied array gets capacity for `len / GROWTH_ROOM_DIVISOR` more values.
const GROWTH_ROOM_DIVISOR: usize = 8;

pub struct MeshStore {
    /// Positions, and corners per triangle slot (a removed triangle holds `REMOVED` three
    /// times). Shared with the caller until the first edit, so a read-only run (a check)
    /// never copies the mesh.
    mesh: Arc<MeshData>,
    vertex_removed: Vec<bool>,
    removed_vertex_count: usize,
    removed_triangle_count: usize,
    /// Built once a step has asked for the triangles around a vertex more than
    /// [`SCANS_BEFORE_INDEX`] times; until then each answer is a scan of the triangles.
    incidence: Option<Incidence>,
    /// Per triangle slot, whether a component search reached it: all false between
    /// searches (`component_of` clears what it set).
    component_marks: Vec<bool>,
    scans: usize,
    log: Vec<Op>,
    /// Present while the mesh has vertex normals: what the step touched and set.
    normals: Option<NormalTracking>,
    /// Vertices `add-vertices` made that took default attribute values, ascending.
    defaulted: Vec<u32>,
    /// Present when the mesh is a partition: what it is part of.
    whole: Option<Whole>,
}

impl MeshStore {
    /// A store over `mesh`; an `Arc` is shared, and copied only on the first edit.
    pub fn new(mesh: impl Into<Arc<MeshData>>) -> Self {
        let mesh = mesh.into();
        let vertex_slots = mesh.vertex_count();
        let normals =
            mesh.attributes.get(Domain::Vertex, NORMAL).map(|_| NormalTracking::new(vertex_slots));
        Self {
            mesh,
            vertex_removed: vec![false; vertex_slots],
            removed_vertex_count: 0,
            removed_triangle_count: 0,
            incidence: None,
            component_marks: Vec::new(),
            scans: 0,
            log: Vec::new(),
            normals,
            defaulted: Vec::new(),
            whole: None,
        }
    }

    /// Marks the mesh as a partition of `whole`.
    pub fn set_whole(&mut self, whole: Whole) {
        self.whole = Some(whole);
    }

    /// What the mesh is a partition of; `None` when it is the whole mesh.
    pub fn whole(&self) -> Option<&Whole> {
        self.whole.as_ref()
    }

    // ---- reads -------------------------------------------------------------------------

    pub fn vertex_slots(&self) -> u32 {
        self.vertex_removed.len() as u32
    }

    pub fn triangle_slots(&self) -> u32 {
        (self.mesh.triangles.len() / 3) as u32
    }

    pub fn vertex_count(&self) -> u32 {
        (self.vertex_removed.len() - self.removed_vertex_count) as u32
    }

    pub fn triangle_count(&self) -> u32 {
        (self.mesh.triangles.len() / 3 - self.removed_triangle_count) as u32
    }

    /// `x y z` per vertex slot; removed vertices keep their last position.
    pub fn positions(&self) -> &[f32] {
        &self.mesh.positions
    }

    /// `a b c` per triangle slot; removed triangles read `REMOVED` three times.
    pub fn triangles(&self) -> &[u32] {
        &self.mesh.triangles
    }

    /// [`positions`](Self::positions) and [`triangles`](Self::triangles) in one shared
    /// value, without a copy: slots, tombstones included, not a compact mesh. Drop it before
    /// the next edit, or that edit copies the mesh.
    pub fn shared_slots(&self) -> Arc<MeshData> {
        Arc::clone(&self.mesh)
    }

    pub fn removed_vertices(&self) -> Vec<u32> {
        (0..self.vertex_slots()).filter(|&v| self.vertex_removed[v as usize]).collect()
    }

    pub fn is_vertex_live(&self, vertex: u32) -> bool {
        self.vertex_removed.get(vertex as usize) == Some(&false)
    }

    pub fn is_triangle_live(&self, triangle: u32) -> bool {
        self.mesh.triangles.get(3 * triangle as usize).is_some_and(|&a| a != REMOVED)
    }

    pub fn position(&self, vertex: u32) -> Result<[f32; 3], EditError> {
        self.check_vertex(vertex)?;
        Ok(self.point(vertex))
    }

    pub fn triangle(&self, triangle: u32) -> Result<[u32; 3], EditError> {
        self.check_triangle(triangle)?;
        Ok(self.corners(triangle))
    }

    /// Every op applied so far, consecutive bulk ops of one kind merged.
    pub fn log(&self) -> &[Op] {
        &self.log
    }

    /// The log, taken out without a copy, for a caller done with this store (a partition's
    /// or block's edits, placed in the whole mesh): the store's log is empty afterwards.
    pub fn take_log(&mut self) -> Vec<Op> {
        std::mem::take(&mut self.log)
    }

    // ---- edits ---------------------------------------------------------------------------

    /// Validates and performs one edit, then records it. Returns the id of the element the
    /// edit created, where it creates one (the first, for bulk additions).
    pub fn apply(&mut self, op: Op) -> Result<Option<u32>, EditError> {
        let created = match &op {
            Op::AddVertices { xyz } => Some(self.add_vertices(xyz)?),
            Op::MoveVertices { ids, xyz } => self.move_vertices(ids, xyz).map(|_| None)?,
            Op::SetPositions { xyz } => self.set_positions(xyz).map(|_| None)?,
            Op::RemoveVertices { ids } => self.remove_vertices(ids).map(|_| None)?,
            Op::AddTriangles { abc } => Some(self.add_triangles(abc)?),
            Op::RemoveTriangles { ids } => self.remove_triangles(ids).map(|_| None)?,
            Op::FlipTriangles { ids } => self.flip_triangles(ids).map(|_| None)?,
            Op::SplitTriangle { triangle, at } => Some(self.split_triangle(*triangle, *at)?),
            Op::ExtendEdge { edge, vertex } => Some(self.extend_edge(*edge, *vertex)?),
            Op::SplitEdge { edge, at } => Some(self.split_edge(*edge, *at)?),
            Op::SwapEdge { edge } => self.swap_edge(*edge).map(|_| None)?,
            Op::CollapseEdge { edge } => self.collapse_edge(*edge).map(|_| None)?,
            Op::RemoveComponent { triangle } => self.remove_component(*triangle).map(|_| None)?,
            Op::TransformComponent { triangle, matrix } => {
                self.transform_component(*triangle, matrix).map(|_| None)?
            }
            Op::Transform { matrix } => self.transform(matrix).map(|_| None)?,
            Op::Clear => self.clear().map(|_| None)?,
            Op::SetAttribute { domain, name, components, ids, values } => self
                .set_attribute(*domain, name, *components, ids.as_deref(), values)
                .map(|_| None)?,
            Op::RemoveAttribute { domain, name } => {
                self.remove_attribute(*domain, name).map(|_| None)?
            }
        };
        // Removed slots keep their positions whatever the op said, and the log records what
        // they hold; with none removed the op's values are the positions, kept as they came.
        let op = match op {
            Op::SetPositions { .. } if self.removed_vertex_count > 0 => {
                Op::SetPositions { xyz: self.mesh.positions.clone() }
            }
            op => op,
        };
        self.record(op);
        Ok(created)
    }

    fn record(&mut self, op: Op) {
        let op = match self.log.last_mut() {
            Some(last) => match last.absorb(op) {
                None => return,
                Some(op) => op,
            },
            None => op,
        };
        self.log.push(op);
    }

    /// Ends the step: the compacted mesh and the log of everything applied.
    pub fn finish(mut self) -> (MeshData, Vec<Op>) {
        self.recompute_normals();
        let mesh = Arc::unwrap_or_clone(self.mesh);
        let mesh = if self.removed_vertex_count == 0 && self.removed_triangle_count == 0 {
            mesh
        } else {
            compact::compact(mesh, &self.vertex_removed)
        };
        (mesh, self.log)
    }

    // ---- shared helpers for the edit modules ---------------------------------------------

    /// The positions, to edit; see [`owned`].
    fn positions_mut(&mut self) -> &mut Vec<f32> {
        &mut owned(&mut self.mesh).positions
    }

    /// The corners, to edit; see [`owned`].
    fn triangles_mut(&mut self) -> &mut Vec<u32> {
        &mut owned(&mut self.mesh).triangles
    }

    fn point(&self, vertex: u32) -> [f32; 3] {
        let i = 3 * vertex as usize;
        [self.mesh.positions[i], self.mesh.positions[i + 1], self.mesh.positions[i + 2]]
    }

    fn corners(&self, triangle: u32) -> [u32; 3] {
        let i = 3 * triangle as usize;
        [self.mesh.triangles[i], self.mesh.triangles[i + 1], self.mesh.triangles[i + 2]]
    }

    fn check_vertex(&self, vertex: u32) -> Result<(), EditError> {
        match self.vertex_removed.get(vertex as usize) {
            Some(false) => Ok(()),
            Some(true) => Err(EditError::new(
                EditErrorKind::InvalidVertex,
                format!("vertex {vertex} was removed in this step"),
            )),
            None => Err(EditError::new(
                EditErrorKind::InvalidVertex,
                format!("vertex {vertex} does not exist ({} vertex slots)", self.vertex_slots()),
            )),
        }
    }

    fn check_triangle(&self, triangle: u32) -> Result<(), EditError> {
        if triangle >= self.triangle_slots() {
            return Err(EditError::new(
                EditErrorKind::InvalidTriangle,
                format!(
                    "triangle {triangle} does not exist ({} triangle slots)",
                    self.triangle_slots()
                ),
            ));
        }
        if !self.is_triangle_live(triangle) {
            return Err(EditError::new(
                EditErrorKind::InvalidTriangle,
                format!("triangle {triangle} was removed in this step"),
            ));
        }
        Ok(())
    }

    /// A new triangle's corners must be live and distinct.
    fn check_new_triangle(&self, corners: [u32; 3]) -> Result<(), EditError> {
        for v in corners {
            self.check_vertex(v)?;
        }
        let [a, b, c] = corners;
        if a == b || b == c || a == c {
            return Err(EditError::new(
                EditErrorKind::RepeatedVertex,
                format!("triangle ({a}, {b}, {c}) repeats a vertex"),
            ));
        }
        Ok(())
    }

    fn incidence(&mut self) -> &mut Incidence {
        let (slots, triangles) = (self.vertex_removed.len(), &self.mesh.triangles);
        self.incidence.get_or_insert_with(|| Incidence::build(slots, triangles))
    }

    /// Appends a vertex at `p` whose attribute values blend `parents` (weights summing to
    /// one), or take the defaults when there are none.
    fn push_vertex(&mut self, p: [f32; 3], parents: &[(u32, f64)]) -> u32 {
        let id = self.vertex_slots();
        self.positions_mut().extend_from_slice(&p);
        self.vertex_removed.push(false);
        if let Some(incidence) = &mut self.incidence {
            incidence.add_vertex();
        }
        self.attributes_for_new_vertex(parents);
        id
    }

    /// Appends a triangle whose face values copy `from` (else the defaults) and whose
    /// corner values come from `corner_origins` (read before the edit changed anything).
    fn push_triangle(
        &mut self,
        corners: [u32; 3],
        from: Option<u32>,
        corner_origins: Option<[CornerOrigin; 3]>,
    ) -> u32 {
        let values = corner_origins.map(|origins| self.corner_values(&origins));
        let id = self.triangle_slots();
        self.triangles_mut().extend_from_slice(&corners);
        if let Some(incidence) = &mut self.incidence {
            incidence.add_triangle(id, corners);
        }
        self.attributes_for_new_triangle(from);
        if let Some(values) = values {
            self.write_corners(id, values);
        }
        corners.iter().for_each(|&v| self.touch(v));
        id
    }

    fn set_corners(&mut self, triangle: u32, corners: [u32; 3]) {
        let old = self.corners(triangle);
        old.iter().chain(&corners).for_each(|&v| self.touch(v));
        if let Some(incidence) = &mut self.incidence {
            incidence.remove_triangle(triangle, old);
            incidence.add_triangle(triangle, corners);
        }
        let i = 3 * triangle as usize;
        self.triangles_mut()[i..i + 3].copy_from_slice(&corners);
    }

    fn kill_triangle(&mut self, triangle: u32) {
        let old = self.corners(triangle);
        old.iter().for_each(|&v| self.touch(v));
        if let Some(incidence) = &mut self.incidence {
            incidence.remove_triangle(triangle, old);
        }
        let i = 3 * triangle as usize;
        self.triangles_mut()[i..i + 3].fill(REMOVED);
        self.removed_triangle_count += 1;
    }

    fn kill_vertex(&mut self, vertex: u32) {
        self.vertex_removed[vertex as usize] = true;
        self.removed_vertex_count += 1;
    }

    /// Live triangles around a vertex, ascending: the canonical order for edits that append.
    pub fn triangles_around(&mut self, vertex: u32) -> Vec<u32> {
        if self.incidence.is_none() && self.scans < SCANS_BEFORE_INDEX {
            self.scans += 1;
            return scan_around(&self.mesh.triangles, vertex);
        }
        let mut around = self.incidence().around(vertex).to_vec();
        around.sort_unstable();
        around
    }
}

/// The store's mesh, to edit. The first edit of a run copies a shared mesh, with room to
/// append ([`GROWTH_ROOM_DIVISOR`]): a step that adds a few elements then copies nothing
/// more, where growing a full array would copy it again (a split edge on a 1M-vertex scan:
/// 8 ms). Room never written is never paged in.
fn owned(mesh: &mut Arc<MeshData>) -> &mut MeshData {
    if Arc::get_mut(mesh).is_none() {
        let mut copy = MeshData::new(with_room(&mesh.positions), with_room(&mesh.triangles));
        copy.attributes = mesh.attributes.clone();
        *mesh = Arc::new(copy);
    }
    Arc::get_mut(mesh).expect("the store's own copy")
}

/// The triangles having `vertex` as a corner, ascending, by reading every corner. A removed
/// triangle reads REMOVED, never a vertex id; a triangle repeating the vertex is listed once,
/// as the index lists it.
fn scan_around(triangles: &[u32], vertex: u32) -> Vec<u32> {
    // Blocks of whole triangles are tested without a branch per corner, which the compiler
    // vectorises; the rare block with a hit is read corner by corner.
    const BLOCK: usize = 3 * 16;
    let mut around = Vec::new();
    let (blocks, rest) = triangles.as_chunks::<BLOCK>();
    let mut hits = |first: usize, corners: &[u32]| {
        for (i, c) in (first..).zip(corners.chunks_exact(3)) {
            if c.contains(&vertex) {
                around.push(i as u32);
            }
        }
    };
    for (b, block) in blocks.iter().enumerate() {
        if block.iter().fold(false, |hit, &v| hit | (v == vertex)) {
            hits(b * BLOCK / 3, block);
        }
    }
    hits(blocks.len() * BLOCK / 3, rest);
    around
}

/// A copy of `values` with room to append (see [`owned`]).
fn with_room<T: Copy>(values: &[T]) -> Vec<T> {
    let mut copy = Vec::with_capacity(values.len() + values.len() / GROWTH_ROOM_DIVISOR);
    copy.extend_from_slice(values);
    copy
}

/// Refuses a non-finite value, named as a coordinate (`y`, or `point 2's z` in a list of
/// points) or, in a matrix, by its place.
fn check_finite(values: &[f32], what: &str) -> Result<(), EditError> {
    let Some(i) = values.iter().position(|v| !v.is_finite()) else { return Ok(()) };
    let axis = ["x", "y", "z"][i % 3];
    let place = match (what.ends_with("matrix"), values.len()) {
        (true, _) => format!("entry {i}"),
        (false, 3) => axis.to_owned(),
        (false, _) => format!("point {}'s {axis}", i / 3),
    };
    Err(EditError::argument(format!(
        "{what}: {place} is {}; coordinates must be finite",
        values[i]
    )))
}

fn check_triples(len: usize, what: &str) -> Result<(), EditError> {
    if len.is_multiple_of(3) {
        Ok(())
    } else {
        Err(EditError::argument(format!("{what}: {len} values is not a multiple of 3")))
    }
}

/// Ids in a bulk removal must be distinct: removing one element twice is a bug in the caller.
fn check_distinct(ids: &[u32], what: &str) -> Result<(), EditError> {
    let mut sorted = ids.to_vec();
    sorted.sort_unstable();
    match sorted.windows(2).find(|w| w[0] == w[1]) {
        None => Ok(()),
        Some(w) => Err(EditError::argument(format!("{what}: id {} appears twice", w[0]))),
    }
}

#[cfg(test)]
mod tests;
