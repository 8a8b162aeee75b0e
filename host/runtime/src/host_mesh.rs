//! The host side of the WIT `mesh` interface: every call is a read of, or an [`Op`] on, the
//! run's [`MeshStore`](meshflow_mesh::store::MeshStore).

use wasmtime::component::Resource;

use super::bindings::meshflow::geometry::mesh::{Host, HostMesh};
use super::bindings::{EditError, EditErrorKind};
use super::state::{MeshHandle, RunState};
use meshflow_mesh::store::{self, Op};

type EditResult<T> = wasmtime::Result<Result<T, EditError>>;

impl RunState {
    /// Performs an edit after the read-only and budget checks. `elements` is the size of
    /// the arguments, charged against the run's edit budget.
    fn edit(&mut self, op: Op, elements: usize) -> EditResult<Option<u32>> {
        if self.read_only {
            return Ok(Err(EditError {
                kind: EditErrorKind::ReadOnly,
                message: format!("{} refused: a check may not edit the mesh", op.kind().name()),
            }));
        }
        let cost = elements as u64 + 1;
        if cost > self.edit_budget {
            self.edit_budget_exceeded = true;
            wasmtime::bail!("edit budget exhausted at {}", op.kind().name());
        }
        self.edit_budget -= cost;
        Ok(self.mesh.apply(op).map_err(to_wit))
    }

    fn edit_unit(&mut self, op: Op, elements: usize) -> EditResult<()> {
        Ok(self.edit(op, elements)?.map(|_| ()))
    }

    fn edit_id(&mut self, op: Op, elements: usize) -> EditResult<u32> {
        Ok(self.edit(op, elements)?.map(|id| id.expect("this op creates an element")))
    }
}

fn to_wit(e: store::EditError) -> EditError {
    use store::EditErrorKind as K;
    let kind = match e.kind {
        K::InvalidVertex => EditErrorKind::InvalidVertex,
        K::InvalidTriangle => EditErrorKind::InvalidTriangle,
        K::InvalidEdge => EditErrorKind::InvalidEdge,
        K::RepeatedVertex => EditErrorKind::RepeatedVertex,
        K::InvalidArgument => EditErrorKind::InvalidArgument,
        K::NotApplicable => EditErrorKind::NotApplicable,
        K::ReadOnly => EditErrorKind::ReadOnly,
    };
    EditError { kind, message: e.message }
}

fn affine(matrix: &[f32]) -> Result<store::Affine, EditError> {
    matrix.try_into().map_err(|_| EditError {
        kind: EditErrorKind::InvalidArgument,
        message: format!("an affine map has 12 values (row-major 3x4), got {}", matrix.len()),
    })
}

impl Host for RunState {}

impl super::bindings::meshflow::geometry::types::Host for RunState {}

impl HostMesh for RunState {
    fn vertex_slots(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(self.mesh.vertex_slots())
    }

    fn triangle_slots(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(self.mesh.triangle_slots())
    }

    fn vertex_count(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(self.mesh.vertex_count())
    }

    fn triangle_count(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<u32> {
        Ok(self.mesh.triangle_count())
    }

    // The bulk reads are redefined in the linker to lower without a copy (see
    // `array_reads`); the generated trait still asks for these, which a run never reaches.
    fn positions(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<f32>> {
        wasmtime::bail!("mesh.positions is served by `array_reads`")
    }

    fn triangles(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<u32>> {
        wasmtime::bail!("mesh.triangles is served by `array_reads`")
    }

    fn removed_vertices(&mut self, _: Resource<MeshHandle>) -> wasmtime::Result<Vec<u32>> {
        Ok(self.mesh.removed_vertices())
    }

    fn position(&mut self, _: Resource<MeshHandle>, v: u32) -> EditResult<(f32, f32, f32)> {
        Ok(self.mesh.position(v).map(|[x, y, z]| (x, y, z)).map_err(to_wit))
    }

    fn triangle(&mut self, _: Resource<MeshHandle>, t: u32) -> EditResult<(u32, u32, u32)> {
        Ok(self.mesh.triangle(t).map(|[a, b, c]| (a, b, c)).map_err(to_wit))
    }

    fn is_vertex_live(&mut self, _: Resource<MeshHandle>, v: u32) -> wasmtime::Result<bool> {
        Ok(self.mesh.is_vertex_live(v))
    }

    fn is_triangle_live(&mut self, _: Resource<MeshHandle>, t: u32) -> wasmtime::Result<bool> {
        Ok(self.mesh.is_triangle_live(t))
    }

    fn add_vertex(&mut self, _: Resource<MeshHandle>, x: f32, y: f32, z: f32) -> EditResult<u32> {
        self.edit_id(Op::AddVertices { xyz: vec![x, y, z] }, 3)
    }

    fn add_vertices(&mut self, _: Resource<MeshHandle>, xyz: Vec<f32>) -> EditResult<u32> {
        let n = xyz.len();
        self.edit_id(Op::AddVertices { xyz }, n)
    }

    fn move_vertex(
        &mut self,
        _: Resource<MeshHandle>,
        vertex: u32,
        x: f32,
        y: f32,
        z: f32,
    ) -> EditResult<()> {
        self.edit_unit(Op::MoveVertices { ids: vec![vertex], xyz: vec![x, y, z] }, 4)
    }

    fn move_vertices(
        &mut self,
        _: Resource<MeshHandle>,
        ids: Vec<u32>,
        xyz: Vec<f32>,
    ) -> EditResult<()> {
        let n = ids.len() + xyz.len();
        self.edit_unit(Op::MoveVertices { ids, xyz }, n)
    }

    fn set_positions(&mut self, _: Resource<MeshHandle>, xyz: Vec<f32>) -> EditResult<()> {
        let n = xyz.len();
        self.edit_unit(Op::SetPositions { xyz }, n)
    }

    fn remove_vertex(&mut self, _: Resource<MeshHandle>, vertex: u32) -> EditResult<()> {
        self.edit_unit(Op::RemoveVertices { ids: vec![vertex] }, 1)
    }

    fn remove_vertices(&mut self, _: Resource<MeshHandle>, ids: Vec<u32>) -> EditResult<()> {
        let n = ids.len();
        self.edit_unit(Op::RemoveVertices { ids }, n)
    }

    fn add_triangle(&mut self, _: Resource<MeshHandle>, a: u32, b: u32, c: u32) -> EditResult<u32> {
        self.edit_id(Op::AddTriangles { abc: vec![a, b, c] }, 3)
    }

    fn add_triangles(&mut self, _: Resource<MeshHandle>, abc: Vec<u32>) -> EditResult<u32> {
        let n = abc.len();
        self.edit_id(Op::AddTriangles { abc }, n)
    }

    fn remove_triangle(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<()> {
        self.edit_unit(Op::RemoveTriangles { ids: vec![triangle] }, 1)
    }

    fn remove_triangles(&mut self, _: Resource<MeshHandle>, ids: Vec<u32>) -> EditResult<()> {
        let n = ids.len();
        self.edit_unit(Op::RemoveTriangles { ids }, n)
    }

    fn flip_triangle(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<()> {
        self.edit_unit(Op::FlipTriangles { ids: vec![triangle] }, 1)
    }

    fn flip_triangles(&mut self, _: Resource<MeshHandle>, ids: Vec<u32>) -> EditResult<()> {
        let n = ids.len();
        self.edit_unit(Op::FlipTriangles { ids }, n)
    }

    fn split_triangle(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<u32> {
        self.edit_id(Op::SplitTriangle { triangle, at: None }, 1)
    }

    fn split_triangle_at(
        &mut self,
        _: Resource<MeshHandle>,
        triangle: u32,
        x: f32,
        y: f32,
        z: f32,
    ) -> EditResult<u32> {
        self.edit_id(Op::SplitTriangle { triangle, at: Some([x, y, z]) }, 4)
    }

    fn extend_edge(&mut self, _: Resource<MeshHandle>, edge: u32, vertex: u32) -> EditResult<u32> {
        self.edit_id(Op::ExtendEdge { edge, vertex }, 2)
    }

    fn split_edge(&mut self, _: Resource<MeshHandle>, edge: u32) -> EditResult<u32> {
        self.edit_id(Op::SplitEdge { edge, at: None }, 1)
    }

    fn split_edge_at(
        &mut self,
        _: Resource<MeshHandle>,
        edge: u32,
        x: f32,
        y: f32,
        z: f32,
    ) -> EditResult<u32> {
        self.edit_id(Op::SplitEdge { edge, at: Some([x, y, z]) }, 4)
    }

    fn swap_edge(&mut self, _: Resource<MeshHandle>, edge: u32) -> EditResult<()> {
        self.edit_unit(Op::SwapEdge { edge }, 1)
    }

    fn collapse_edge(&mut self, _: Resource<MeshHandle>, edge: u32) -> EditResult<()> {
        self.edit_unit(Op::CollapseEdge { edge }, 1)
    }

    fn remove_component(&mut self, _: Resource<MeshHandle>, triangle: u32) -> EditResult<()> {
        self.edit_unit(Op::RemoveComponent { triangle }, 1)
    }

    fn transform_component(
        &mut self,
        _: Resource<MeshHandle>,
        triangle: u32,
        matrix: Vec<f32>,
    ) -> EditResult<()> {
        match affine(&matrix) {
            Ok(matrix) => self.edit_unit(Op::TransformComponent { triangle, matrix }, 13),
            Err(e) => Ok(Err(e)),
        }
    }

    fn transform(&mut self, _: Resource<MeshHandle>, matrix: Vec<f32>) -> EditResult<()> {
        match affine(&matrix) {
            Ok(matrix) => self.edit_unit(Op::Transform { matrix }, 12),
            Err(e) => Ok(Err(e)),
        }
    }

    fn clear(&mut self, _: Resource<MeshHandle>) -> EditResult<()> {
        self.edit_unit(Op::Clear, 1)
    }

    fn drop(&mut self, handle: Resource<MeshHandle>) -> wasmtime::Result<()> {
        self.table().delete(handle)?;
        Ok(())
    }
}
