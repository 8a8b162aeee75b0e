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
//! Attributes are read and written whole, one at a time ([`MeshCalls::read_attribute`],
//! [`MeshCalls::set_attribute`]); a step whose `add-vertices` left vertices at their
//! defaults says so in its report ([`defaulted_vertices_note`]).
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
use crate::attributes::{COLOR, Domain, NORMAL, NumberType, TEXCOORD, Values};
use crate::store::{Affine, Component, EditError, EditErrorKind, MeshStore, Op, OpKind};

/// One attribute as the WIT's `attribute-info` lists it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AttributeInfo {
    pub domain: Domain,
    pub name: String,
    pub components: u8,
    pub number_type: NumberType,
}

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
    fn components(&self) -> Vec<Component> {
        self.store().components()
    }
    fn whole_ids(&self) -> Option<Vec<u32>> {
        self.store().whole().map(|whole| whole.ids.clone())
    }
    fn whole_bounds(&self) -> Option<Vec<f32>> {
        self.store().whole().map(|whole| whole.bounds.clone())
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

    /// Every attribute, in canonical order (domain, then name).
    fn attributes(&self) -> Vec<AttributeInfo> {
        // The shared mesh is dropped before the next edit, which so finds the store's copy
        // unshared.
        let mesh = self.store().shared_slots();
        mesh.attributes
            .iter()
            .map(|a| AttributeInfo {
                domain: a.domain,
                name: a.name.clone(),
                components: a.components,
                number_type: a.values.number_type(),
            })
            .collect()
    }

    /// One attribute's values for every slot of its domain; `NotApplicable` when the mesh
    /// does not carry it.
    fn read_attribute(&self, domain: Domain, name: &str) -> Result<Values, EditError> {
        let mesh = self.store().shared_slots();
        match mesh.attributes.get(domain, name) {
            Some(a) => Ok(a.values.clone()),
            None => Err(EditError::not_applicable(format!(
                "read-attribute: the mesh has no {} attribute {name:?}",
                domain.name()
            ))),
        }
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
    /// Charged as the ids and the numbers it carries.
    fn set_attribute(
        &mut self,
        domain: Domain,
        name: String,
        components: u8,
        ids: Option<Vec<u32>>,
        values: Values,
    ) -> Called<(), Self::Stop> {
        let n = ids.as_ref().map_or(0, Vec::len) + values.len();
        self.edit_unit(Op::SetAttribute { domain, name, components, ids, values }, n)
    }
    fn remove_attribute(&mut self, domain: Domain, name: String) -> Called<(), Self::Stop> {
        self.edit_unit(Op::RemoveAttribute { domain, name }, 1)
    }
}

/// The line a step's report gains when `add-vertices` left vertices at their attribute
/// defaults (the service set none of their values): `3 new vertices took default colour,
/// quality: the service gave none`. Normals are not named, as the store recomputes them.
/// `None` when every new vertex got values, or the mesh carries no vertex attribute.
pub fn defaulted_vertices_note(store: &MeshStore) -> Option<String> {
    let count = store.defaulted_vertex_count();
    if count == 0 {
        return None;
    }
    let mesh = store.shared_slots();
    let names: Vec<&str> = mesh
        .attributes
        .iter()
        .filter(|a| a.domain == Domain::Vertex && a.name != NORMAL)
        .map(|a| match a.name.as_str() {
            COLOR => "colour",
            TEXCOORD => "texture coordinate",
            name => name,
        })
        .collect();
    if names.is_empty() {
        return None;
    }
    let vertices = if count == 1 { "vertex" } else { "vertices" };
    Some(format!("{count} new {vertices} took default {}: the service gave none", names.join(", ")))
}

/// `report` with the [`defaulted_vertices_note`] of `store` on a line of its own, where
/// there is one.
pub fn with_defaulted_note(report: String, store: &MeshStore) -> String {
    match defaulted_vertices_note(store) {
        None => report,
        Some(note) if report.is_empty() => note,
        Some(note) => format!("{report}\n{note}"),
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
    fn attributes_are_read_and_set_in_bulk_and_a_check_may_only_read() {
        let mut calls = Recorder::new(triangle(), false);
        assert!(calls.attributes().is_empty());
        let missing = calls.read_attribute(Domain::Vertex, "quality").unwrap_err();
        assert_eq!(missing.kind, EditErrorKind::NotApplicable);
        let Ok(set) = calls.set_attribute(
            Domain::Vertex,
            "quality".into(),
            1,
            None,
            Values::F32(vec![0.5, 1.0, 2.0]),
        );
        set.unwrap();
        let Ok(set) = calls.set_attribute(
            Domain::Vertex,
            "quality".into(),
            1,
            Some(vec![2]),
            Values::F32(vec![4.0]),
        );
        set.unwrap();
        let info = AttributeInfo {
            domain: Domain::Vertex,
            name: "quality".into(),
            components: 1,
            number_type: NumberType::F32,
        };
        assert_eq!(calls.attributes(), vec![info]);
        assert_eq!(
            calls.read_attribute(Domain::Vertex, "quality"),
            Ok(Values::F32(vec![0.5, 1.0, 4.0]))
        );
        let Ok(wrong) = calls.set_attribute(
            Domain::Vertex,
            "quality".into(),
            1,
            None,
            Values::U8(vec![1, 2, 3]),
        );
        assert_eq!(wrong.unwrap_err().kind, EditErrorKind::InvalidArgument);
        let (mesh, _) = calls.finish();

        let mut check = Recorder::new(mesh, true);
        assert_eq!(check.read_attribute(Domain::Vertex, "quality").unwrap().len(), 3);
        let Ok(refused) = check.set_attribute(
            Domain::Vertex,
            "quality".into(),
            1,
            None,
            Values::F32(vec![0.0; 3]),
        );
        let refused = refused.unwrap_err();
        assert_eq!(refused.kind, EditErrorKind::ReadOnly);
        assert_eq!(refused.message, "set-attribute refused: a check may not edit the mesh");
        let Ok(refused) = check.remove_attribute(Domain::Vertex, "quality".into());
        assert_eq!(refused.unwrap_err().kind, EditErrorKind::ReadOnly);
    }

    #[test]
    fn vertices_left_at_their_defaults_are_noted_in_the_report() {
        let mut mesh = triangle();
        mesh.attributes.insert(crate::attributes::Attribute::color(vec![9; 12]), 3, 1).unwrap();
        mesh.attributes.insert(crate::attributes::Attribute::quality(vec![1.0; 3]), 3, 1).unwrap();
        let mut calls = Recorder::new(mesh, false);
        assert_eq!(defaulted_vertices_note(calls.store()), None);
        let Ok(first) = calls.add_vertices(vec![1.0, 1.0, 0.0, 2.0, 2.0, 0.0, 3.0, 3.0, 0.0]);
        assert_eq!(first, Ok(3));
        assert_eq!(
            with_defaulted_note("added 3".into(), calls.store()),
            "added 3\n3 new vertices took default colour, quality: the service gave none"
        );
        // Values given to two of them leave one at the defaults.
        let Ok(set) = calls.set_attribute(
            Domain::Vertex,
            "color".into(),
            4,
            Some(vec![3, 4]),
            Values::U8(vec![1; 8]),
        );
        set.unwrap();
        let note = defaulted_vertices_note(calls.store()).unwrap();
        assert_eq!(note, "1 new vertex took default colour, quality: the service gave none");
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
