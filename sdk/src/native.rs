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
use meshflow_mesh::calls::{Called, MeshCalls, Recorder};
pub use meshflow_mesh::store::Op;

use meshflow_mesh::attributes::{self as model, Domain, Values};

use crate::attributes::{AttributeDomain, AttributeInfo, AttributeValues, NumberType};
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
    let native =
        NativeMesh { calls: RefCell::new(Recorder::new(mesh, info.kind == ServiceKind::Check)) };
    let outcome = crate::run(services, name, Mesh::native(&native), resolved).map_err(Error)?;
    let recorder = native.calls.into_inner();
    let report = meshflow_mesh::calls::with_defaulted_note(outcome.report, recorder.store());
    let (mesh, edits) = recorder.finish();
    Ok(Outcome { mesh, edits, report, value: outcome.value })
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
/// import, each a call of the store's checked interface ([`MeshCalls`]), which the runtime
/// wraps too.
pub(crate) struct NativeMesh {
    calls: RefCell<Recorder>,
}

type Edit<T> = std::result::Result<T, EditError>;

meshflow_mesh::wit_edit_error!(fn to_wit -> EditError { kind: EditErrorKind });

impl NativeMesh {
    /// Reads or edits through the shared calls; nothing stops a native run.
    fn call<T>(
        &self,
        call: impl FnOnce(&mut Recorder) -> Called<T, std::convert::Infallible>,
    ) -> Edit<T> {
        let Ok(result) = call(&mut self.calls.borrow_mut());
        result.map_err(to_wit)
    }

    fn read<T>(&self, read: impl FnOnce(&Recorder) -> T) -> T {
        read(&self.calls.borrow())
    }

    pub fn vertex_slots(&self) -> u32 {
        self.read(|m| m.vertex_slots())
    }
    pub fn triangle_slots(&self) -> u32 {
        self.read(|m| m.triangle_slots())
    }
    pub fn vertex_count(&self) -> u32 {
        self.read(|m| m.vertex_count())
    }
    pub fn triangle_count(&self) -> u32 {
        self.read(|m| m.triangle_count())
    }
    pub fn positions(&self) -> Vec<f32> {
        self.read(|m| m.store().positions().to_vec())
    }
    pub fn triangles(&self) -> Vec<u32> {
        self.read(|m| m.store().triangles().to_vec())
    }
    pub fn removed_vertices(&self) -> Vec<u32> {
        self.read(|m| m.removed_vertices())
    }
    pub fn whole_ids(&self) -> Option<Vec<u32>> {
        self.read(|m| m.whole_ids())
    }
    pub fn whole_bounds(&self) -> Option<Vec<f32>> {
        self.read(|m| m.whole_bounds())
    }
    /// Derived from the current state at each call, as the host does in a run that edits.
    fn connectivity(&self) -> meshflow_topology::Connectivity {
        self.read(|m| {
            let store = m.store();
            meshflow_topology::Connectivity::new(store.positions().len() / 3, store.triangles())
        })
    }
    pub fn half_edge_opposites(&self) -> Vec<u32> {
        self.connectivity().opposites().to_vec()
    }
    pub fn half_edge_kinds(&self) -> Vec<u8> {
        self.connectivity().kind_codes().to_vec()
    }
    pub fn edges(&self) -> Vec<u32> {
        self.connectivity().edges().to_vec()
    }
    pub fn components(&self) -> Vec<crate::Component> {
        let found = self.read(|m| m.components());
        found
            .into_iter()
            .map(|c| crate::Component { first_triangle: c.first_triangle, triangles: c.triangles })
            .collect()
    }
    pub fn position(&self, v: u32) -> Edit<(f32, f32, f32)> {
        self.read(|m| m.position(v)).map_err(to_wit)
    }
    pub fn triangle(&self, t: u32) -> Edit<(u32, u32, u32)> {
        self.read(|m| m.triangle(t)).map_err(to_wit)
    }
    pub fn is_vertex_live(&self, v: u32) -> bool {
        self.read(|m| m.is_vertex_live(v))
    }
    pub fn is_triangle_live(&self, t: u32) -> bool {
        self.read(|m| m.is_triangle_live(t))
    }
    pub fn add_vertex(&self, x: f32, y: f32, z: f32) -> Edit<u32> {
        self.call(|m| m.add_vertex(x, y, z))
    }
    pub fn add_vertices(&self, xyz: &[f32]) -> Edit<u32> {
        self.call(|m| m.add_vertices(xyz.to_vec()))
    }
    pub fn move_vertex(&self, vertex: u32, x: f32, y: f32, z: f32) -> Edit<()> {
        self.call(|m| m.move_vertex(vertex, x, y, z))
    }
    pub fn move_vertices(&self, ids: &[u32], xyz: &[f32]) -> Edit<()> {
        self.call(|m| m.move_vertices(ids.to_vec(), xyz.to_vec()))
    }
    pub fn set_positions(&self, xyz: &[f32]) -> Edit<()> {
        self.call(|m| m.set_positions(xyz.to_vec()))
    }
    pub fn remove_vertex(&self, vertex: u32) -> Edit<()> {
        self.call(|m| m.remove_vertex(vertex))
    }
    pub fn remove_vertices(&self, ids: &[u32]) -> Edit<()> {
        self.call(|m| m.remove_vertices(ids.to_vec()))
    }
    pub fn add_triangle(&self, a: u32, b: u32, c: u32) -> Edit<u32> {
        self.call(|m| m.add_triangle(a, b, c))
    }
    pub fn add_triangles(&self, abc: &[u32]) -> Edit<u32> {
        self.call(|m| m.add_triangles(abc.to_vec()))
    }
    pub fn remove_triangle(&self, triangle: u32) -> Edit<()> {
        self.call(|m| m.remove_triangle(triangle))
    }
    pub fn remove_triangles(&self, ids: &[u32]) -> Edit<()> {
        self.call(|m| m.remove_triangles(ids.to_vec()))
    }
    pub fn flip_triangle(&self, triangle: u32) -> Edit<()> {
        self.call(|m| m.flip_triangle(triangle))
    }
    pub fn flip_triangles(&self, ids: &[u32]) -> Edit<()> {
        self.call(|m| m.flip_triangles(ids.to_vec()))
    }
    pub fn split_triangle(&self, triangle: u32) -> Edit<u32> {
        self.call(|m| m.split_triangle(triangle))
    }
    pub fn split_triangle_at(&self, triangle: u32, x: f32, y: f32, z: f32) -> Edit<u32> {
        self.call(|m| m.split_triangle_at(triangle, x, y, z))
    }
    pub fn extend_edge(&self, edge: u32, vertex: u32) -> Edit<u32> {
        self.call(|m| m.extend_edge(edge, vertex))
    }
    pub fn split_edge(&self, edge: u32) -> Edit<u32> {
        self.call(|m| m.split_edge(edge))
    }
    pub fn split_edge_at(&self, edge: u32, x: f32, y: f32, z: f32) -> Edit<u32> {
        self.call(|m| m.split_edge_at(edge, x, y, z))
    }
    pub fn swap_edge(&self, edge: u32) -> Edit<()> {
        self.call(|m| m.swap_edge(edge))
    }
    pub fn collapse_edge(&self, edge: u32) -> Edit<()> {
        self.call(|m| m.collapse_edge(edge))
    }
    pub fn remove_component(&self, triangle: u32) -> Edit<()> {
        self.call(|m| m.remove_component(triangle))
    }
    pub fn transform_component(&self, triangle: u32, matrix: &[f32]) -> Edit<()> {
        self.call(|m| m.transform_component(triangle, matrix))
    }
    pub fn transform(&self, matrix: &[f32]) -> Edit<()> {
        self.call(|m| m.transform(matrix))
    }
    pub fn clear(&self) -> Edit<()> {
        self.call(|m| m.clear())
    }
    pub fn attributes(&self) -> Vec<AttributeInfo> {
        self.read(|m| m.attributes()).into_iter().map(info_to_wit).collect()
    }
    pub fn read_attribute(&self, domain: AttributeDomain, name: &str) -> Edit<AttributeValues> {
        self.read(|m| m.read_attribute(domain_from_wit(domain), name))
            .map(values_to_wit)
            .map_err(to_wit)
    }
    pub fn set_attribute(
        &self,
        domain: AttributeDomain,
        name: &str,
        components: u8,
        ids: Option<&[u32]>,
        values: &AttributeValues,
    ) -> Edit<()> {
        let (domain, ids, values) =
            (domain_from_wit(domain), ids.map(<[u32]>::to_vec), values_from_wit(values));
        self.call(|m| m.set_attribute(domain, name.to_owned(), components, ids, values))
    }
    pub fn remove_attribute(&self, domain: AttributeDomain, name: &str) -> Edit<()> {
        self.call(|m| m.remove_attribute(domain_from_wit(domain), name.to_owned()))
    }
}

// The WIT's attribute types and the model's, one to one (the runtime has the same at its
// own bindings' edge).

fn domain_from_wit(domain: AttributeDomain) -> Domain {
    match domain {
        AttributeDomain::Vertex => Domain::Vertex,
        AttributeDomain::Face => Domain::Face,
        AttributeDomain::Corner => Domain::Corner,
    }
}

fn info_to_wit(info: meshflow_mesh::calls::AttributeInfo) -> AttributeInfo {
    AttributeInfo {
        domain: match info.domain {
            Domain::Vertex => AttributeDomain::Vertex,
            Domain::Face => AttributeDomain::Face,
            Domain::Corner => AttributeDomain::Corner,
        },
        name: info.name,
        components: info.components,
        number_type: match info.number_type {
            model::NumberType::U8 => NumberType::U8,
            model::NumberType::I32 => NumberType::S32,
            model::NumberType::U32 => NumberType::U32,
            model::NumberType::F32 => NumberType::F32,
            model::NumberType::F64 => NumberType::F64,
        },
    }
}

fn values_from_wit(values: &AttributeValues) -> Values {
    match values {
        AttributeValues::U8(v) => Values::U8(v.clone()),
        AttributeValues::S32(v) => Values::I32(v.clone()),
        AttributeValues::U32(v) => Values::U32(v.clone()),
        AttributeValues::F32(v) => Values::F32(v.clone()),
        AttributeValues::F64(v) => Values::F64(v.clone()),
    }
}

fn values_to_wit(values: Values) -> AttributeValues {
    match values {
        Values::U8(v) => AttributeValues::U8(v),
        Values::I32(v) => AttributeValues::S32(v),
        Values::U32(v) => AttributeValues::U32(v),
        Values::F32(v) => AttributeValues::F32(v),
        Values::F64(v) => AttributeValues::F64(v),
    }
}
