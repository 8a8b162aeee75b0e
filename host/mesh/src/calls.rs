//! The WIT `mesh` interface over a recording [`MeshStore`], written once for every
//! embedder: the wasmtime runtime (`host/runtime/src/host_mesh.rs`) and the SDK's native
//! test runs (`sdk/src/native.rs`) both wrap [`MeshCalls`].
//!
//! Every call is a read of the store or an [`Op`] on it. An edit call is refused with a
//! [`EditErrorKind::ReadOnly`] error in a check, then charged against the embedder's edit
//! budget ([`MeshCalls::charge`], which may stop the run), then validated and performed by
//! [`MeshStore::apply`]. Refusals are [`EditError`]s of the store; [`wit_edit_error!`]
//! writes the conversion to a WIT binding's own `edit-error`.
//!
//! The bulk reads (`positions`, `triangles`) are not here: an embedder serves them from
//! [`MeshStore::positions`] and [`MeshStore::triangles`] as cheaply as it can (the runtime
//! lowers them into the guest without a copy).
//!
//! ```
//! use meshflow_mesh::MeshData;
//! use meshflow_mesh::calls::{MeshCalls, Recorder};
//! use meshflow_mesh::store::EditErrorKind;
//!
//! let triangle = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2]);
//! let mut check = Recorder::new(triangle, true);
//! let Ok(refused) = check.clear();
//! assert_eq!(refused.unwrap_err().kind, EditErrorKind::ReadOnly);
//! assert_eq!(check.triangle_count(), 1);
//! ```

use std::convert::Infallible;
use std::sync::Arc;

use crate::MeshData;
use crate::store::{Affine, EditError, EditErrorKind, MeshStore, Op, OpKind};

/// What an edit call gives: `Err` stops the run (the embedder's [`MeshCalls::Stop`]), an
/// inner `Err` is a refused edit the guest sees.
pub type Called<T, Stop> = Result<Result<T, EditError>, Stop>;

/// The checked calls of the WIT `mesh` resource on a recording store. An embedder gives the
/// store, whether the run is a check, and (optionally) an edit budget; every call is
/// provided. The WIT's tuples and lists are kept: `(x, y, z)` arguments, `Vec` lists.
pub trait MeshCalls {
    /// What stops a run from inside an edit call ([`Infallible`] where nothing does).
    type Stop;

    fn store(&self) -> &MeshStore;
    fn store_mut(&mut self) -> &mut MeshStore;

    /// Whether the run is a check, which may read but not edit.
    fn read_only(&self) -> bool;

    /// Charges an edit of `kind` whose arguments hold `elements` values, before it is
    /// performed; `Err` stops the run instead. Free unless the embedder has a budget.
    fn charge(&mut self, kind: OpKind, elements: usize) -> Result<(), Self::Stop> {
        let _ = (kind, elements);
        Ok(())
    }

    /// Performs an edit after the read-only check and the charge. Returns the id of the
    /// element it created, where it creates one.
    fn edit(&mut self, op: Op, elements: usize) -> Called<Option<u32>, Self::Stop> {
        let kind = op.kind();
        if self.read_only() {
            let message = format!("{} refused: a check may not edit the mesh", kind.name());
            return Ok(Err(EditError::new(EditErrorKind::ReadOnly, message)));
        }
        self.charge(kind, elements)?;
        Ok(self.store_mut().apply(op))
    }

    /// An edit that creates nothing.
    fn edit_unit(&mut self, op: Op, elements: usize) -> Called<(), Self::Stop> {
        Ok(self.edit(op, elements)?.map(|_| ()))
    }

    /// An edit that creates an element, whose id it returns.
    fn edit_id(&mut self, op: Op, elements: usize) -> Called<u32, Self::Stop> {
        Ok(self.edit(op, elements)?.map(|id| id.expect("this op creates an element")))
    }

    // ---- reads -------------------------------------------------------------------------

    fn vertex_slots(&self) -> u32 {
        self.store().vertex_slots()
    }
    fn triangle_slots(&self) -> u32 {
        self.store().triangle_slots()
    }
    fn vertex_count(&self) -> u32 {
        self.store().vertex_count()
    }
    fn triangle_count(&self) -> u32 {
        self.store().triangle_count()
    }
    fn removed_vertices(&self) -> Vec<u32> {
        self.store().removed_vertices()
    }
    fn position(&self, vertex: u32) -> Result<(f32, f32, f32), EditError> {
        self.store().position(vertex).map(|[x, y, z]| (x, y, z))
    }
    fn triangle(&self, triangle: u32) -> Result<(u32, u32, u32), EditError> {
        self.store().triangle(triangle).map(|[a, b, c]| (a, b, c))
    }
    fn is_vertex_live(&self, vertex: u32) -> bool {
        self.store().is_vertex_live(vertex)
    }
    fn is_triangle_live(&self, triangle: u32) -> bool {
        self.store().is_triangle_live(triangle)
    }

    // ---- edits: each the op it records and the values it is charged --------------------

    fn add_vertex(&mut self, x: f32, y: f32, z: f32) -> Called<u32, Self::Stop> {
        self.edit_id(Op::AddVertices { xyz: vec![x, y, z] }, 3)
    }
    fn add_vertices(&mut self, xyz: Vec<f32>) -> Called<u32, Self::Stop> {
        let n = xyz.len();
        self.edit_id(Op::AddVertices { xyz }, n)
    }
    fn move_vertex(&mut self, vertex: u32, x: f32, y: f32, z: f32) -> Called<(), Self::Stop> {
        self.edit_unit(Op::MoveVertices { ids: vec![vertex], xyz: vec![x, y, z] }, 4)
    }
    fn move_vertices(&mut self, ids: Vec<u32>, xyz: Vec<f32>) -> Called<(), Self::Stop> {
        let n = ids.len() + xyz.len();
        self.edit_unit(Op::MoveVertices { ids, xyz }, n)
    }
    fn set_positions(&mut self, xyz: Vec<f32>) -> Called<(), Self::Stop> {
        let n = xyz.len();
        self.edit_unit(Op::SetPositions { xyz }, n)
    }
    fn remove_vertex(&mut self, vertex: u32) -> Called<(), Self::Stop> {
        self.edit_unit(Op::RemoveVertices { ids: vec![vertex] }, 1)
    }
    fn remove_vertices(&mut self, ids: Vec<u32>) -> Called<(), Self::Stop> {
        let n = ids.len();
        self.edit_unit(Op::RemoveVertices { ids }, n)
    }
    fn add_triangle(&mut self, a: u32, b: u32, c: u32) -> Called<u32, Self::Stop> {
        self.edit_id(Op::AddTriangles { abc: vec![a, b, c] }, 3)
    }
    fn add_triangles(&mut self, abc: Vec<u32>) -> Called<u32, Self::Stop> {
        let n = abc.len();
        self.edit_id(Op::AddTriangles { abc }, n)
    }
    fn remove_triangle(&mut self, triangle: u32) -> Called<(), Self::Stop> {
        self.edit_unit(Op::RemoveTriangles { ids: vec![triangle] }, 1)
    }
    fn remove_triangles(&mut self, ids: Vec<u32>) -> Called<(), Self::Stop> {
        let n = ids.len();
        self.edit_unit(Op::RemoveTriangles { ids }, n)
    }
    fn flip_triangle(&mut self, triangle: u32) -> Called<(), Self::Stop> {
        self.edit_unit(Op::FlipTriangles { ids: vec![triangle] }, 1)
    }
    fn flip_triangles(&mut self, ids: Vec<u32>) -> Called<(), Self::Stop> {
        let n = ids.len();
        self.edit_unit(Op::FlipTriangles { ids }, n)
    }
    fn split_triangle(&mut self, triangle: u32) -> Called<u32, Self::Stop> {
        self.edit_id(Op::SplitTriangle { triangle, at: None }, 1)
    }
    fn split_triangle_at(
        &mut self,
        triangle: u32,
        x: f32,
        y: f32,
        z: f32,
    ) -> Called<u32, Self::Stop> {
        self.edit_id(Op::SplitTriangle { triangle, at: Some([x, y, z]) }, 4)
    }
    fn extend_edge(&mut self, edge: u32, vertex: u32) -> Called<u32, Self::Stop> {
        self.edit_id(Op::ExtendEdge { edge, vertex }, 2)
    }
    fn split_edge(&mut self, edge: u32) -> Called<u32, Self::Stop> {
        self.edit_id(Op::SplitEdge { edge, at: None }, 1)
    }
    fn split_edge_at(&mut self, edge: u32, x: f32, y: f32, z: f32) -> Called<u32, Self::Stop> {
        self.edit_id(Op::SplitEdge { edge, at: Some([x, y, z]) }, 4)
    }
    fn swap_edge(&mut self, edge: u32) -> Called<(), Self::Stop> {
        self.edit_unit(Op::SwapEdge { edge }, 1)
    }
    fn collapse_edge(&mut self, edge: u32) -> Called<(), Self::Stop> {
        self.edit_unit(Op::CollapseEdge { edge }, 1)
    }
    fn remove_component(&mut self, triangle: u32) -> Called<(), Self::Stop> {
        self.edit_unit(Op::RemoveComponent { triangle }, 1)
    }
    /// A matrix of other than 12 values is refused before the read-only check.
    fn transform_component(&mut self, triangle: u32, matrix: &[f32]) -> Called<(), Self::Stop> {
        match affine(matrix) {
            Ok(matrix) => self.edit_unit(Op::TransformComponent { triangle, matrix }, 13),
            Err(e) => Ok(Err(e)),
        }
    }
    /// A matrix of other than 12 values is refused before the read-only check.
    fn transform(&mut self, matrix: &[f32]) -> Called<(), Self::Stop> {
        match affine(matrix) {
            Ok(matrix) => self.edit_unit(Op::Transform { matrix }, 12),
            Err(e) => Ok(Err(e)),
        }
    }
    fn clear(&mut self) -> Called<(), Self::Stop> {
        self.edit_unit(Op::Clear, 1)
    }
}

fn affine(matrix: &[f32]) -> Result<Affine, EditError> {
    matrix.try_into().map_err(|_| {
        EditError::argument(format!(
            "an affine map has 12 values (row-major 3x4), got {}",
            matrix.len()
        ))
    })
}

/// A store with nothing around it but the read-only flag: no budget, nothing stops a run.
/// What a native test run of the SDK uses.
pub struct Recorder {
    store: MeshStore,
    read_only: bool,
}

impl Recorder {
    pub fn new(mesh: impl Into<Arc<MeshData>>, read_only: bool) -> Self {
        Self { store: MeshStore::new(mesh), read_only }
    }

    /// Ends the run: see [`MeshStore::finish`].
    pub fn finish(self) -> (MeshData, Vec<Op>) {
        self.store.finish()
    }
}

impl MeshCalls for Recorder {
    type Stop = Infallible;

    fn store(&self) -> &MeshStore {
        &self.store
    }
    fn store_mut(&mut self) -> &mut MeshStore {
        &mut self.store
    }
    fn read_only(&self) -> bool {
        self.read_only
    }
}

/// Writes `fn $name(e: EditError) -> $error`, the store's refusal as a WIT binding's
/// `edit-error` record, where `$error` has fields `kind: $kind` and `message: String` and
/// `$kind` is that binding's `edit-error-kind` enum (both in scope). The kinds match one to
/// one, by name.
#[macro_export]
macro_rules! wit_edit_error {
    ($vis:vis fn $name:ident -> $error:ident { kind: $kind:ident }) => {
        $vis fn $name(e: $crate::store::EditError) -> $error {
            use $crate::store::EditErrorKind as K;
            let kind = match e.kind {
                K::InvalidVertex => $kind::InvalidVertex,
                K::InvalidTriangle => $kind::InvalidTriangle,
                K::InvalidEdge => $kind::InvalidEdge,
                K::RepeatedVertex => $kind::RepeatedVertex,
                K::InvalidArgument => $kind::InvalidArgument,
                K::NotApplicable => $kind::NotApplicable,
                K::ReadOnly => $kind::ReadOnly,
            };
            $error { kind, message: e.message }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangle() -> MeshData {
        MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2])
    }

    /// What stops a budgeted run: the edit whose charge the budget could not pay.
    #[derive(Debug, PartialEq)]
    struct Exhausted(&'static str);

    /// A recorder with a budget, as the runtime keeps one.
    struct Budgeted {
        recorder: Recorder,
        budget: u64,
    }

    impl MeshCalls for Budgeted {
        type Stop = Exhausted;
        fn store(&self) -> &MeshStore {
            &self.recorder.store
        }
        fn store_mut(&mut self) -> &mut MeshStore {
            &mut self.recorder.store
        }
        fn read_only(&self) -> bool {
            self.recorder.read_only
        }
        fn charge(&mut self, kind: OpKind, elements: usize) -> Result<(), Exhausted> {
            let cost = elements as u64 + 1;
            if cost > self.budget {
                return Err(Exhausted(kind.name()));
            }
            self.budget -= cost;
            Ok(())
        }
    }

    #[test]
    fn edits_are_recorded_and_refusals_leave_the_store_unchanged() {
        let mut calls = Recorder::new(triangle(), false);
        let Ok(v) = calls.add_vertex(1.0, 1.0, 0.0);
        assert_eq!(v, Ok(3));
        let Ok(refused) = calls.add_triangle(0, 0, 3);
        assert_eq!(refused.unwrap_err().kind, EditErrorKind::RepeatedVertex);
        let Ok(refused) = calls.transform(&[1.0; 11]);
        let refused = refused.unwrap_err();
        assert_eq!(refused.kind, EditErrorKind::InvalidArgument);
        assert_eq!(refused.message, "an affine map has 12 values (row-major 3x4), got 11");
        assert_eq!(calls.position(3), Ok((1.0, 1.0, 0.0)));
        assert_eq!(calls.triangle(0), Ok((0, 1, 2)));
        let (mesh, log) = calls.finish();
        assert_eq!(mesh.vertex_count(), 4);
        assert_eq!(log, vec![Op::AddVertices { xyz: vec![1.0, 1.0, 0.0] }]);
    }

    #[test]
    fn a_check_is_refused_before_it_is_charged() {
        let mut check = Budgeted { recorder: Recorder::new(triangle(), true), budget: 0 };
        let refused = check.remove_triangle(0).expect("not charged").unwrap_err();
        assert_eq!(refused.kind, EditErrorKind::ReadOnly);
        assert_eq!(refused.message, "remove-triangles refused: a check may not edit the mesh");
    }

    #[test]
    fn the_budget_is_charged_per_value_plus_one() {
        let mut run = Budgeted { recorder: Recorder::new(triangle(), false), budget: 5 };
        assert_eq!(run.move_vertex(0, 0.5, 0.0, 0.0), Ok(Ok(())));
        assert_eq!(run.budget, 0);
        let stop = run.clear().unwrap_err();
        assert_eq!(stop, Exhausted("clear"));
    }
}
