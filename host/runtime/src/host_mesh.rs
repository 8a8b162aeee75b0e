//! The host side of the WIT `mesh` interface: every call is a read of, or an [`Op`] on, the
//! run's [`MeshStore`], through the checks shared with the SDK's native runs
//! ([`MeshCalls`]); the run adds its edit budget, whose exhaustion traps.
//!
//! [`Op`]: meshflow_mesh::store::Op

use wasmtime::component::Resource;

use super::bindings::meshflow::geometry::mesh::{Host, HostMesh};
use super::bindings::{
    AttributeDomain, AttributeInfo, AttributeValues, Component, EditError, EditErrorKind,
};
use super::state::{MeshHandle, RunState};
use meshflow_mesh::calls::{Called, MeshCalls};
use meshflow_mesh::store::{MeshStore, OpKind};

type EditResult<T> = wasmtime::Result<Result<T, EditError>>;

impl MeshCalls for RunState {
    type Stop = wasmtime::Error;

    fn store(&self) -> &MeshStore {
        &self.mesh
    }

    fn store_mut(&mut self) -> &mut MeshStore {
        &mut self.mesh
    }

    fn read_only(&self) -> bool {
        self.read_only
    }

    /// `elements + 1` against the run's edit budget; past it the run is stopped.
    fn charge(&mut self, kind: OpKind, elements: usize) -> wasmtime::Result<()> {
        let cost = elements as u64 + 1;
        if cost > self.edit_budget {
            self.edit_budget_exceeded = true;
            wasmtime::bail!("edit budget exhausted at {}", kind.name());
        }
        self.edit_budget -= cost;
        Ok(())
    }
}

meshflow_mesh::wit_edit_error!(fn to_wit -> EditError { kind: EditErrorKind });

/// A shared call's answer in the generated trait's shape.
fn wit<T>(called: Called<T, wasmtime::Error>) -> EditResult<T> {
    Ok(called?.map_err(to_wit))
}

impl Host for RunState {}

impl super::bindings::meshflow::geometry::types::Host for RunState {}

impl HostMesh for RunState {
    fn vertex_slots(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(MeshCalls::vertex_slots(self))
    }

    fn triangle_slots(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(MeshCalls::triangle_slots(self))
    }

    fn vertex_count(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(MeshCalls::vertex_count(self))
    }

    fn triangle_count(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(MeshCalls::triangle_count(self))
    }

    // The bulk reads (these two and the derived connectivity below) are redefined in the
    // linker to lower without a copy (see `array_reads`); the generated trait still asks for
    // these, which a run never reaches.
    fn positions(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<f32>> {
        wasmtime::bail!("mesh.positions is served by `array_reads`")
    }

    fn triangles(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<u32>> {
        wasmtime::bail!("mesh.triangles is served by `array_reads`")
    }

    fn half_edge_opposites(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<u32>> {
        wasmtime::bail!("mesh.half-edge-opposites is served by `array_reads`")
    }

    fn half_edge_kinds(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<u8>> {
        wasmtime::bail!("mesh.half-edge-kinds is served by `array_reads`")
    }

    fn edges(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<u32>> {
        wasmtime::bail!("mesh.edges is served by `array_reads`")
    }

    fn removed_vertices(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<u32>> {
        Ok(MeshCalls::removed_vertices(self))
    }

    fn components(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<Component>> {
        Ok(MeshCalls::components(self).into_iter().map(Component::from).collect())
    }

    fn whole_ids(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Option<Vec<u32>>> {
        Ok(MeshCalls::whole_ids(self))
    }

    fn whole_bounds(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Option<Vec<f32>>> {
        Ok(MeshCalls::whole_bounds(self))
    }

    fn position(&mut self, _: Resource<MeshHandle>, v: u32) -> EditResult<(f32, f32, f32)> {
        Ok(MeshCalls::position(self, v).map_err(to_wit))
    }

    fn triangle(&mut self, _: Resource<MeshHandle>, t: u32) -> EditResult<(u32, u32, u32)> {
        Ok(MeshCalls::triangle(self, t).map_err(to_wit))
    }

    fn is_vertex_live(&mut self, _: Resource<MeshHandle>, v: u32) -> wasmtime::Result<bool> {
        Ok(MeshCalls::is_vertex_live(self, v))
    }

    fn is_triangle_live(&mut self, _: Resource<MeshHandle>, t: u32) -> wasmtime::Result<bool> {
        Ok(MeshCalls::is_triangle_live(self, t))
    }

    fn add_vertex(&mut self, _: Resource<MeshHandle>, x: f32, y: f32, z: f32) -> EditResult<u32> {
        wit(MeshCalls::add_vertex(self, x, y, z))
    }

    fn add_vertices(&mut self, _: Resource<MeshHandle>, xyz: Vec<f32>) -> EditResult<u32> {
        wit(MeshCalls::add_vertices(self, xyz))
    }

    fn move_vertex(
        &mut self,
        _: Resource<MeshHandle>,
        vertex: u32,
        x: f32,
        y: f32,
        z: f32,
    ) -> EditResult<()> {
        wit(MeshCalls::move_vertex(self, vertex, x, y, z))
    }

    fn move_vertices(
        &mut self,
        _: Resource<MeshHandle>,
        ids: Vec<u32>,
        xyz: Vec<f32>,
    ) -> EditResult<()> {
        wit(MeshCalls::move_vertices(self, ids, xyz))
    }

    fn set_positions(&mut self, _: Resource<MeshHandle>, xyz: Vec<f32>) -> EditResult<()> {
        wit(MeshCalls::set_positions(self, xyz))
    }

    fn remove_vertex(&mut self, _: Resource<MeshHandle>, vertex: u32) -> EditResult<()> {
        wit(MeshCalls::remove_vertex(self, vertex))
    }

    fn remove_vertices(&mut self, _: Resource<MeshHandle>, ids: Vec<u32>) -> EditResult<()> {
        wit(MeshCalls::remove_vertices(self, ids))
    }

    fn add_triangle(&mut self, _: Resource<MeshHandle>, a: u32, b: u32, c: u32) -> EditResult<u32> {
        wit(MeshCalls::add_triangle(self, a, b, c))
    }

    fn add_triangles(&mut self, _: Resource<MeshHandle>, abc: Vec<u32>) -> EditResult<u32> {
        wit(MeshCalls::add_triangles(self, abc))
    }

    fn remove_triangle(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<()> {
        wit(MeshCalls::remove_triangle(self, triangle))
    }

    fn remove_triangles(&mut self, _: Resource<MeshHandle>, ids: Vec<u32>) -> EditResult<()> {
        wit(MeshCalls::remove_triangles(self, ids))
    }

    fn flip_triangle(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<()> {
        wit(MeshCalls::flip_triangle(self, triangle))
    }

    fn flip_triangles(&mut self, _: Resource<MeshHandle>, ids: Vec<u32>) -> EditResult<()> {
        wit(MeshCalls::flip_triangles(self, ids))
    }

    fn split_triangle(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<u32> {
        wit(MeshCalls::split_triangle(self, triangle))
    }

    fn split_triangle_at(
        &mut self,
        _: Resource<MeshHandle>,
        triangle: u32,
        x: f32,
        y: f32,
        z: f32,
    ) -> EditResult<u32> {
        wit(MeshCalls::split_triangle_at(self, triangle, x, y, z))
    }

    fn extend_edge(&mut self, _: Resource<MeshHandle>, edge: u32, vertex: u32) -> EditResult<u32> {
        wit(MeshCalls::extend_edge(self, edge, vertex))
    }

    fn split_edge(&mut self, _: Resource<MeshHandle>, edge: u32) -> EditResult<u32> {
        wit(MeshCalls::split_edge(self, edge))
    }

    fn split_edge_at(
        &mut self,
        _: Resource<MeshHandle>,
        edge: u32,
        x: f32,
        y: f32,
        z: f32,
    ) -> EditResult<u32> {
        wit(MeshCalls::split_edge_at(self, edge, x, y, z))
    }

    fn swap_edge(&mut self, _: Resource<MeshHandle>, edge: u32) -> EditResult<()> {
        wit(MeshCalls::swap_edge(self, edge))
    }

    fn collapse_edge(&mut self, _: Resource<MeshHandle>, edge: u32) -> EditResult<()> {
        wit(MeshCalls::collapse_edge(self, edge))
    }

    fn remove_component(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<()> {
        wit(MeshCalls::remove_component(self, triangle))
    }

    fn transform_component(
        &mut self,
        _: Resource<MeshHandle>,
        triangle: u32,
        matrix: Vec<f32>,
    ) -> EditResult<()> {
        wit(MeshCalls::transform_component(self, triangle, &matrix))
    }

    fn transform(&mut self, _: Resource<MeshHandle>, matrix: Vec<f32>) -> EditResult<()> {
        wit(MeshCalls::transform(self, &matrix))
    }

    fn clear(&mut self, _: Resource<MeshHandle>) -> EditResult<()> {
        wit(MeshCalls::clear(self))
    }

    fn attributes(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<AttributeInfo>> {
        Ok(MeshCalls::attributes(self).into_iter().map(Into::into).collect())
    }

    fn read_attribute(
        &mut self,
        _: Resource<MeshHandle>,
        domain: AttributeDomain,
        name: String,
    ) -> EditResult<AttributeValues> {
        Ok(MeshCalls::read_attribute(self, domain.into(), &name).map(Into::into).map_err(to_wit))
    }

    fn set_attribute(
        &mut self,
        _: Resource<MeshHandle>,
        domain: AttributeDomain,
        name: String,
        components: u8,
        ids: Option<Vec<u32>>,
        values: AttributeValues,
    ) -> EditResult<()> {
        wit(MeshCalls::set_attribute(self, domain.into(), name, components, ids, values.into()))
    }

    fn remove_attribute(
        &mut self,
        _: Resource<MeshHandle>,
        domain: AttributeDomain,
        name: String,
    ) -> EditResult<()> {
        wit(MeshCalls::remove_attribute(self, domain.into(), name))
    }

    fn drop(&mut self, handle: Resource<MeshHandle>) -> wasmtime::Result<()> {
        self.table().delete(handle)?;
        Ok(())
    }
}
