//! Running services natively, in a test, against an in-process mesh (feature `native`).
//!
//! The mesh lives in the host's own recording store (`meshflow-mesh`), so every edit is
//! checked exactly as a host checks it (live ids, distinct corners, finite coordinates, a
//! read-only mesh for checks) and the result is compacted as a host compacts it. Meshes load
//! from OBJ, PLY, OFF or STL with the host's readers (`meshflow-meshio`).
//!
//! ```no_run
//! # fn services() -> Vec<meshflow_plugin_sdk::Service> { Vec::new() }
//! use meshflow_plugin_sdk::Value;
//! use meshflow_plugin_sdk::native::{load, run};
//!
//! let bunny = load("tests/bunny.obj".as_ref()).unwrap();
//! let out = run(&services(), "my-filter", bunny, &[("iterations", Value::Integer(3))]).unwrap();
//! assert_eq!(out.mesh.vertex_count(), 1839);
//! ```
//!
//! Layers stay one way: the SDK uses the store and the readers, which know nothing of the
//! SDK, the WIT or wasmtime; the runtime, which links wasmtime, is not involved.

use std::cell::RefCell;
use std::path::Path;

pub use meshflow_mesh::MeshData;
pub use meshflow_mesh::store::Op;
use meshflow_mesh::store::{self, Affine, MeshStore};

use crate::bindings::meshflow::geometry::types::{
    EditError, EditErrorKind, Param, ParamInfo, ServiceKind, Value,
};
use crate::{Error, Mesh, Result, Service};

/// Loads a mesh file as a host would (the format from the extension).
pub fn load(path: &Path) -> Result<MeshData> {
    meshflow_meshio::load(path).map_err(|e| Error(e.to_string()))
}

/// What a native run gives.
#[derive(Debug)]
pub struct Outcome {
    /// The mesh after the service, compacted as a host compacts it (the input for a check).
    pub mesh: MeshData,
    /// Every edit, in order, as the host would record it.
    pub edits: Vec<Op>,
    /// A filter's report.
    pub report: String,
    /// A check's value.
    pub value: Option<Value>,
}

/// Runs the named service of `services` on `mesh`. Parameters not given take their
/// declared defaults; an unknown name or a value of the wrong type is refused, as a host
/// refuses it. A check runs on a read-only mesh.
pub fn run(
    services: &[Service],
    name: &str,
    mesh: MeshData,
    params: &[(&str, Value)],
) -> Result<Outcome> {
    let service = services.iter().find(|s| s.name() == name).ok_or_else(|| {
        let known: Vec<&str> = services.iter().map(|s| s.name()).collect();
        Error(format!("unknown service `{name}`; the services are: {}", known.join(", ")))
    })?;
    let info = service.info();
    for (given, value) in params {
        let declared = info.params.iter().find(|p| p.name == *given);
        let declared =
            declared.ok_or_else(|| Error(format!("{name} has no parameter `{given}`")))?;
        check_value(name, declared, value)?;
    }
    let resolved = info
        .params
        .iter()
        .map(|p| {
            let given = params.iter().find(|(n, _)| *n == p.name).map(|(_, v)| v.clone());
            Param { name: p.name.clone(), value: given.unwrap_or_else(|| p.default.clone()) }
        })
        .collect();
    let native = NativeMesh {
        store: RefCell::new(MeshStore::new(mesh)),
        read_only: info.kind == ServiceKind::Check,
    };
    let outcome = crate::run(services, name, Mesh::native(&native), resolved).map_err(Error)?;
    let (mesh, edits) = native.store.into_inner().finish();
    Ok(Outcome { mesh, edits, report: outcome.report, value: outcome.value })
}

/// Refuses what a host refuses: a value of another type (an integer passes for a real),
/// outside the declared range, or not among the declared choices.
fn check_value(service: &str, declared: &ParamInfo, value: &Value) -> Result<()> {
    let refuse =
        |why: String| Err(Error(format!("{service}: parameter `{}` {why}", declared.name)));
    let number = match (value, &declared.default) {
        (Value::Integer(x), Value::Integer(_) | Value::Real(_)) => Some(*x as f64),
        (Value::Real(x), Value::Real(_)) => Some(*x),
        (Value::Boolean(_), Value::Boolean(_)) => None,
        (Value::Text(text), Value::Text(_)) => {
            if !declared.choices.is_empty() && !declared.choices.contains(text) {
                return refuse(format!("must be one of {}", declared.choices.join(", ")));
            }
            None
        }
        _ => return refuse(format!("must be of type {:?}, got {value:?}", declared.ty)),
    };
    if let Some(x) = number {
        let below = declared.min.is_some_and(|min| x < min);
        if below || declared.max.is_some_and(|max| x > max) {
            return refuse(format!("is {x}, outside [{:?}, {:?}]", declared.min, declared.max));
        }
    }
    Ok(())
}

/// The in-process twin of the host's mesh resource: the same methods as the generated
/// import, each a read of, or an [`Op`] on, the recording store.
pub(crate) struct NativeMesh {
    store: RefCell<MeshStore>,
    read_only: bool,
}

type Edit<T> = std::result::Result<T, EditError>;

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

fn affine(matrix: &[f32]) -> Edit<Affine> {
    matrix.try_into().map_err(|_| EditError {
        kind: EditErrorKind::InvalidArgument,
        message: format!("an affine map has 12 values (row-major 3x4), got {}", matrix.len()),
    })
}

impl NativeMesh {
    fn edit(&self, op: Op) -> Edit<Option<u32>> {
        if self.read_only {
            let message = format!("{} refused: a check may not edit the mesh", op.kind().name());
            return Err(EditError { kind: EditErrorKind::ReadOnly, message });
        }
        self.store.borrow_mut().apply(op).map_err(to_wit)
    }

    fn unit(&self, op: Op) -> Edit<()> {
        self.edit(op).map(|_| ())
    }

    fn id(&self, op: Op) -> Edit<u32> {
        self.edit(op).map(|id| id.expect("this op creates an element"))
    }

    pub fn vertex_slots(&self) -> u32 {
        self.store.borrow().vertex_slots()
    }
    pub fn triangle_slots(&self) -> u32 {
        self.store.borrow().triangle_slots()
    }
    pub fn vertex_count(&self) -> u32 {
        self.store.borrow().vertex_count()
    }
    pub fn triangle_count(&self) -> u32 {
        self.store.borrow().triangle_count()
    }
    pub fn positions(&self) -> Vec<f32> {
        self.store.borrow().positions().to_vec()
    }
    pub fn triangles(&self) -> Vec<u32> {
        self.store.borrow().triangles().to_vec()
    }
    pub fn removed_vertices(&self) -> Vec<u32> {
        self.store.borrow().removed_vertices()
    }
    pub fn position(&self, v: u32) -> Edit<(f32, f32, f32)> {
        self.store.borrow().position(v).map(|[x, y, z]| (x, y, z)).map_err(to_wit)
    }
    pub fn triangle(&self, t: u32) -> Edit<(u32, u32, u32)> {
        self.store.borrow().triangle(t).map(|[a, b, c]| (a, b, c)).map_err(to_wit)
    }
    pub fn is_vertex_live(&self, v: u32) -> bool {
        self.store.borrow().is_vertex_live(v)
    }
    pub fn is_triangle_live(&self, t: u32) -> bool {
        self.store.borrow().is_triangle_live(t)
    }
    pub fn add_vertex(&self, x: f32, y: f32, z: f32) -> Edit<u32> {
        self.id(Op::AddVertices { xyz: vec![x, y, z] })
    }
    pub fn add_vertices(&self, xyz: &[f32]) -> Edit<u32> {
        self.id(Op::AddVertices { xyz: xyz.to_vec() })
    }
    pub fn move_vertex(&self, vertex: u32, x: f32, y: f32, z: f32) -> Edit<()> {
        self.unit(Op::MoveVertices { ids: vec![vertex], xyz: vec![x, y, z] })
    }
    pub fn move_vertices(&self, ids: &[u32], xyz: &[f32]) -> Edit<()> {
        self.unit(Op::MoveVertices { ids: ids.to_vec(), xyz: xyz.to_vec() })
    }
    pub fn set_positions(&self, xyz: &[f32]) -> Edit<()> {
        self.unit(Op::SetPositions { xyz: xyz.to_vec() })
    }
    pub fn remove_vertex(&self, vertex: u32) -> Edit<()> {
        self.unit(Op::RemoveVertices { ids: vec![vertex] })
    }
    pub fn remove_vertices(&self, ids: &[u32]) -> Edit<()> {
        self.unit(Op::RemoveVertices { ids: ids.to_vec() })
    }
    pub fn add_triangle(&self, a: u32, b: u32, c: u32) -> Edit<u32> {
        self.id(Op::AddTriangles { abc: vec![a, b, c] })
    }
    pub fn add_triangles(&self, abc: &[u32]) -> Edit<u32> {
        self.id(Op::AddTriangles { abc: abc.to_vec() })
    }
    pub fn remove_triangle(&self, triangle: u32) -> Edit<()> {
        self.unit(Op::RemoveTriangles { ids: vec![triangle] })
    }
    pub fn remove_triangles(&self, ids: &[u32]) -> Edit<()> {
        self.unit(Op::RemoveTriangles { ids: ids.to_vec() })
    }
    pub fn flip_triangle(&self, triangle: u32) -> Edit<()> {
        self.unit(Op::FlipTriangles { ids: vec![triangle] })
    }
    pub fn flip_triangles(&self, ids: &[u32]) -> Edit<()> {
        self.unit(Op::FlipTriangles { ids: ids.to_vec() })
    }
    pub fn split_triangle(&self, triangle: u32) -> Edit<u32> {
        self.id(Op::SplitTriangle { triangle, at: None })
    }
    pub fn split_triangle_at(&self, triangle: u32, x: f32, y: f32, z: f32) -> Edit<u32> {
        self.id(Op::SplitTriangle { triangle, at: Some([x, y, z]) })
    }
    pub fn extend_edge(&self, edge: u32, vertex: u32) -> Edit<u32> {
        self.id(Op::ExtendEdge { edge, vertex })
    }
    pub fn split_edge(&self, edge: u32) -> Edit<u32> {
        self.id(Op::SplitEdge { edge, at: None })
    }
    pub fn split_edge_at(&self, edge: u32, x: f32, y: f32, z: f32) -> Edit<u32> {
        self.id(Op::SplitEdge { edge, at: Some([x, y, z]) })
    }
    pub fn swap_edge(&self, edge: u32) -> Edit<()> {
        self.unit(Op::SwapEdge { edge })
    }
    pub fn collapse_edge(&self, edge: u32) -> Edit<()> {
        self.unit(Op::CollapseEdge { edge })
    }
    pub fn remove_component(&self, triangle: u32) -> Edit<()> {
        self.unit(Op::RemoveComponent { triangle })
    }
    pub fn transform_component(&self, triangle: u32, matrix: &[f32]) -> Edit<()> {
        self.unit(Op::TransformComponent { triangle, matrix: affine(matrix)? })
    }
    pub fn transform(&self, matrix: &[f32]) -> Edit<()> {
        self.unit(Op::Transform { matrix: affine(matrix)? })
    }
    pub fn clear(&self) -> Edit<()> {
        self.unit(Op::Clear)
    }
}
