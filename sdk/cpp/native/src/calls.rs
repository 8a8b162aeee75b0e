//! The WIT `mesh` resource's calls as `plugin.h` declares them, natively: each looks up the
//! run's [`Recorder`] by its handle and makes the same call of [`MeshCalls`] a host makes.

use std::collections::BTreeMap;
use std::convert::Infallible;
use std::sync::atomic::{AtomicI32, Ordering};
use std::sync::{Mutex, MutexGuard};

use meshflow_mesh::attributes::{Domain, NumberType, Values};
use meshflow_mesh::calls::{Called, MeshCalls, Recorder};
use meshflow_mesh::store::EditErrorKind;

use crate::abi::{
    AttributeInfo, AttributeValues, Component, EditError, Handle, List, NUMBER_F32, NUMBER_F64,
    NUMBER_S32, NUMBER_U8, NUMBER_U32, Str, Tuple3F32, Tuple3U32, c_copy, c_list, c_string,
    read_str, shielded, slice, trap,
};

/// The meshes of the runs in progress, by handle. A run registers its recorder for the
/// time the plugin's `run` is called (runs on several threads each have their own).
static RUNS: Mutex<BTreeMap<i32, Recorder>> = Mutex::new(BTreeMap::new());
static NEXT_HANDLE: AtomicI32 = AtomicI32::new(1);

fn runs() -> MutexGuard<'static, BTreeMap<i32, Recorder>> {
    // A panic while the lock was held left no half-made edit: the store refuses before it
    // changes anything, so the map is still sound.
    RUNS.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// Makes `recorder` the mesh of a run; its handle.
pub fn register(recorder: Recorder) -> Handle {
    let handle = NEXT_HANDLE.fetch_add(1, Ordering::Relaxed);
    runs().insert(handle, recorder);
    Handle { handle }
}

/// Ends a run: its recorder, which no call reaches any more.
pub fn unregister(handle: Handle) -> Option<Recorder> {
    runs().remove(&handle.handle)
}

fn with<T>(call: &str, mesh: Handle, f: impl FnOnce(&mut Recorder) -> T) -> T {
    let mut runs = runs();
    match runs.get_mut(&mesh.handle) {
        Some(recorder) => f(recorder),
        None => trap(&format!(
            "{call}: mesh handle {} is no run's mesh (a meshflow::Mesh used after its run?)",
            mesh.handle
        )),
    }
}

/// The WIT `edit-error-kind` number of a store refusal (`plugin.h`'s order).
pub fn kind_code(kind: EditErrorKind) -> u8 {
    match kind {
        EditErrorKind::InvalidVertex => 0,
        EditErrorKind::InvalidTriangle => 1,
        EditErrorKind::InvalidEdge => 2,
        EditErrorKind::RepeatedVertex => 3,
        EditErrorKind::InvalidArgument => 4,
        EditErrorKind::NotApplicable => 5,
        EditErrorKind::ReadOnly => 6,
    }
}

/// Writes `value` through an out-pointer of the bindings.
///
/// # Safety
/// `out` is null (a trap) or valid for a write of T.
unsafe fn put<T>(call: &str, out: *mut T, value: T) {
    if out.is_null() {
        trap(&format!("{call}: a null result pointer"));
    }
    // SAFETY: non-null, and the caller vouches it is writable.
    unsafe { out.write(value) }
}

/// A refusal or a value, written where the bindings expect it; whether it was a value.
///
/// # Safety
/// `ret` and `err` as [`put`] needs.
unsafe fn answer<T>(
    call: &str,
    result: Result<T, meshflow_mesh::store::EditError>,
    ret: *mut T,
    err: *mut EditError,
) -> bool {
    match result {
        Ok(value) => {
            // SAFETY: the caller's promise about `ret`.
            unsafe { put(call, ret, value) };
            true
        }
        Err(e) => {
            let error = EditError { kind: kind_code(e.kind), message: c_string(&e.message) };
            // SAFETY: the caller's promise about `err`.
            unsafe { put(call, err, error) };
            false
        }
    }
}

/// An edit: the call on the run's recorder, its refusal or value answered.
///
/// # Safety
/// As [`answer`].
unsafe fn edit<T>(
    call: &str,
    mesh: Handle,
    ret: *mut T,
    err: *mut EditError,
    f: impl FnOnce(&mut Recorder) -> Called<T, Infallible>,
) -> bool {
    shielded(call, || {
        let Ok(result) = with(call, mesh, f);
        // SAFETY: the caller's promise, passed on.
        unsafe { answer(call, result, ret, err) }
    })
}

/// An edit without a value.
///
/// # Safety
/// `err` as [`put`] needs.
unsafe fn edit_unit(
    call: &str,
    mesh: Handle,
    err: *mut EditError,
    f: impl FnOnce(&mut Recorder) -> Called<(), Infallible>,
) -> bool {
    let mut unit = ();
    // SAFETY: `unit` is a valid place for a (); `err` is the caller's promise.
    unsafe { edit(call, mesh, &mut unit, err, f) }
}

/// A read that cannot fail.
fn read<T>(call: &str, mesh: Handle, f: impl FnOnce(&Recorder) -> T) -> T {
    shielded(call, || with(call, mesh, |recorder| f(recorder)))
}

/// The values of a list argument, copied.
///
/// # Safety
/// `list` is null (a trap) or points to a list whose elements are readable.
unsafe fn list_arg<T: Copy>(call: &str, list: *const List<T>) -> Vec<T> {
    // SAFETY: checked for null; then the caller's promise.
    let items = unsafe { list.as_ref().and_then(|list| slice(list.ptr, list.len)) };
    match items {
        Some(items) => items.to_vec(),
        None => trap(&format!("{call}: a null list")),
    }
}

// ---- reads --------------------------------------------------------------------------------

#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_method_mesh_vertex_slots(mesh: Handle) -> u32 {
    read("vertex-slots", mesh, |m| m.vertex_slots())
}

#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_method_mesh_triangle_slots(mesh: Handle) -> u32 {
    read("triangle-slots", mesh, |m| m.triangle_slots())
}

#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_method_mesh_vertex_count(mesh: Handle) -> u32 {
    read("vertex-count", mesh, |m| m.vertex_count())
}

#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_method_mesh_triangle_count(mesh: Handle) -> u32 {
    read("triangle-count", mesh, |m| m.triangle_count())
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_positions(
    mesh: Handle,
    ret: *mut List<f32>,
) {
    let list = read("positions", mesh, |m| c_copy(m.store().positions()));
    // SAFETY: the caller's promise.
    unsafe { put("positions", ret, list) }
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_triangles(
    mesh: Handle,
    ret: *mut List<u32>,
) {
    let list = read("triangles", mesh, |m| c_copy(m.store().triangles()));
    // SAFETY: the caller's promise.
    unsafe { put("triangles", ret, list) }
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_removed_vertices(
    mesh: Handle,
    ret: *mut List<u32>,
) {
    let list = read("removed-vertices", mesh, |m| c_copy(&m.removed_vertices()));
    // SAFETY: the caller's promise.
    unsafe { put("removed-vertices", ret, list) }
}

/// A list if the mesh is a partition, written to `ret`; whether it is one.
///
/// # Safety
/// `ret` is writable.
unsafe fn put_whole<T>(call: &str, ret: *mut List<T>, list: Option<Vec<T>>) -> bool {
    let Some(list) = list else { return false };
    // SAFETY: the caller's promise.
    unsafe { put(call, ret, c_list(list)) };
    true
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_whole_ids(
    mesh: Handle,
    ret: *mut List<u32>,
) -> bool {
    let ids = read("whole-ids", mesh, |m| m.whole_ids());
    // SAFETY: the caller's promise.
    unsafe { put_whole("whole-ids", ret, ids) }
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_whole_bounds(
    mesh: Handle,
    ret: *mut List<f32>,
) -> bool {
    let bounds = read("whole-bounds", mesh, |m| m.whole_bounds());
    // SAFETY: the caller's promise.
    unsafe { put_whole("whole-bounds", ret, bounds) }
}

/// The connectivity of the mesh as it is now: derived at each call, as a host does in a
/// run that edits (and as the Rust SDK's native runs do).
fn connectivity(call: &str, mesh: Handle) -> meshflow_topology::Connectivity {
    read(call, mesh, |m| {
        let store = m.store();
        meshflow_topology::Connectivity::new(store.positions().len() / 3, store.triangles())
    })
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_half_edge_opposites(
    mesh: Handle,
    ret: *mut List<u32>,
) {
    let call = "half-edge-opposites";
    let list = shielded(call, || c_copy(connectivity(call, mesh).opposites()));
    // SAFETY: the caller's promise.
    unsafe { put(call, ret, list) }
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_half_edge_kinds(
    mesh: Handle,
    ret: *mut List<u8>,
) {
    let call = "half-edge-kinds";
    let list = shielded(call, || c_copy(connectivity(call, mesh).kind_codes()));
    // SAFETY: the caller's promise.
    unsafe { put(call, ret, list) }
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_edges(
    mesh: Handle,
    ret: *mut List<u32>,
) {
    let call = "edges";
    let list = shielded(call, || c_copy(connectivity(call, mesh).edges()));
    // SAFETY: the caller's promise.
    unsafe { put(call, ret, list) }
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_components(
    mesh: Handle,
    ret: *mut List<Component>,
) {
    let list = read("components", mesh, |m| {
        let found = m.components();
        let found: Vec<Component> = found
            .iter()
            .map(|c| Component { first_triangle: c.first_triangle, triangles: c.triangles })
            .collect();
        c_copy(&found)
    });
    // SAFETY: the caller's promise.
    unsafe { put("components", ret, list) }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_position(
    mesh: Handle,
    vertex: u32,
    ret: *mut Tuple3F32,
    err: *mut EditError,
) -> bool {
    let result = read("position", mesh, |m| m.position(vertex));
    let result = result.map(|(f0, f1, f2)| Tuple3F32 { f0, f1, f2 });
    // SAFETY: the caller's promise.
    unsafe { answer("position", result, ret, err) }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_triangle(
    mesh: Handle,
    triangle: u32,
    ret: *mut Tuple3U32,
    err: *mut EditError,
) -> bool {
    let result = read("triangle", mesh, |m| m.triangle(triangle));
    let result = result.map(|(f0, f1, f2)| Tuple3U32 { f0, f1, f2 });
    // SAFETY: the caller's promise.
    unsafe { answer("triangle", result, ret, err) }
}

#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_method_mesh_is_vertex_live(
    mesh: Handle,
    vertex: u32,
) -> bool {
    read("is-vertex-live", mesh, |m| m.is_vertex_live(vertex))
}

#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_method_mesh_is_triangle_live(
    mesh: Handle,
    triangle: u32,
) -> bool {
    read("is-triangle-live", mesh, |m| m.is_triangle_live(triangle))
}

// ---- edits: every pointer argument is the bindings' (`ret`, `err` writable, lists readable)

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_add_vertex(
    mesh: Handle,
    x: f32,
    y: f32,
    z: f32,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit("add-vertex", mesh, ret, err, |m| m.add_vertex(x, y, z)) }
}

/// # Safety
/// `xyz` is readable; `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_add_vertices(
    mesh: Handle,
    xyz: *const List<f32>,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let xyz = list_arg("add-vertices", xyz);
        edit("add-vertices", mesh, ret, err, |m| m.add_vertices(xyz))
    }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_move_vertex(
    mesh: Handle,
    vertex: u32,
    x: f32,
    y: f32,
    z: f32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("move-vertex", mesh, err, |m| m.move_vertex(vertex, x, y, z)) }
}

/// # Safety
/// The lists are readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_move_vertices(
    mesh: Handle,
    ids: *const List<u32>,
    xyz: *const List<f32>,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let (ids, xyz) = (list_arg("move-vertices", ids), list_arg("move-vertices", xyz));
        edit_unit("move-vertices", mesh, err, |m| m.move_vertices(ids, xyz))
    }
}

/// # Safety
/// `xyz` is readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_set_positions(
    mesh: Handle,
    xyz: *const List<f32>,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let xyz = list_arg("set-positions", xyz);
        edit_unit("set-positions", mesh, err, |m| m.set_positions(xyz))
    }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_remove_vertex(
    mesh: Handle,
    vertex: u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("remove-vertex", mesh, err, |m| m.remove_vertex(vertex)) }
}

/// # Safety
/// `ids` is readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_remove_vertices(
    mesh: Handle,
    ids: *const List<u32>,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let ids = list_arg("remove-vertices", ids);
        edit_unit("remove-vertices", mesh, err, |m| m.remove_vertices(ids))
    }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_add_triangle(
    mesh: Handle,
    a: u32,
    b: u32,
    c: u32,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit("add-triangle", mesh, ret, err, |m| m.add_triangle(a, b, c)) }
}

/// # Safety
/// `abc` is readable; `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_add_triangles(
    mesh: Handle,
    abc: *const List<u32>,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let abc = list_arg("add-triangles", abc);
        edit("add-triangles", mesh, ret, err, |m| m.add_triangles(abc))
    }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_remove_triangle(
    mesh: Handle,
    triangle: u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("remove-triangle", mesh, err, |m| m.remove_triangle(triangle)) }
}

/// # Safety
/// `ids` is readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_remove_triangles(
    mesh: Handle,
    ids: *const List<u32>,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let ids = list_arg("remove-triangles", ids);
        edit_unit("remove-triangles", mesh, err, |m| m.remove_triangles(ids))
    }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_flip_triangle(
    mesh: Handle,
    triangle: u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("flip-triangle", mesh, err, |m| m.flip_triangle(triangle)) }
}

/// # Safety
/// `ids` is readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_flip_triangles(
    mesh: Handle,
    ids: *const List<u32>,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let ids = list_arg("flip-triangles", ids);
        edit_unit("flip-triangles", mesh, err, |m| m.flip_triangles(ids))
    }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_split_triangle(
    mesh: Handle,
    triangle: u32,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit("split-triangle", mesh, ret, err, |m| m.split_triangle(triangle)) }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_split_triangle_at(
    mesh: Handle,
    triangle: u32,
    x: f32,
    y: f32,
    z: f32,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit("split-triangle-at", mesh, ret, err, |m| m.split_triangle_at(triangle, x, y, z)) }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_extend_edge(
    mesh: Handle,
    edge: u32,
    vertex: u32,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit("extend-edge", mesh, ret, err, |m| m.extend_edge(edge, vertex)) }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_split_edge(
    mesh: Handle,
    edge: u32,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit("split-edge", mesh, ret, err, |m| m.split_edge(edge)) }
}

/// # Safety
/// `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_split_edge_at(
    mesh: Handle,
    edge: u32,
    x: f32,
    y: f32,
    z: f32,
    ret: *mut u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit("split-edge-at", mesh, ret, err, |m| m.split_edge_at(edge, x, y, z)) }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_swap_edge(
    mesh: Handle,
    edge: u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("swap-edge", mesh, err, |m| m.swap_edge(edge)) }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_collapse_edge(
    mesh: Handle,
    edge: u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("collapse-edge", mesh, err, |m| m.collapse_edge(edge)) }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_remove_component(
    mesh: Handle,
    triangle: u32,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("remove-component", mesh, err, |m| m.remove_component(triangle)) }
}

/// # Safety
/// `matrix` is readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_transform_component(
    mesh: Handle,
    triangle: u32,
    matrix: *const List<f32>,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let matrix = list_arg("transform-component", matrix);
        edit_unit("transform-component", mesh, err, |m| m.transform_component(triangle, &matrix))
    }
}

/// # Safety
/// `matrix` is readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_transform(
    mesh: Handle,
    matrix: *const List<f32>,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe {
        let matrix = list_arg("transform", matrix);
        edit_unit("transform", mesh, err, |m| m.transform(&matrix))
    }
}

/// # Safety
/// `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_clear(
    mesh: Handle,
    err: *mut EditError,
) -> bool {
    // SAFETY: the caller's promise.
    unsafe { edit_unit("clear", mesh, err, |m| m.clear()) }
}

// ---- attributes ----------------------------------------------------------------------------

fn domain_arg(call: &str, domain: u8) -> Domain {
    match domain {
        0 => Domain::Vertex,
        1 => Domain::Face,
        2 => Domain::Corner,
        _ => trap(&format!("{call}: attribute domain {domain} is none of the WIT's")),
    }
}

fn domain_code(domain: Domain) -> u8 {
    match domain {
        Domain::Vertex => 0,
        Domain::Face => 1,
        Domain::Corner => 2,
    }
}

fn number_code(ty: NumberType) -> u8 {
    match ty {
        NumberType::U8 => NUMBER_U8,
        NumberType::I32 => NUMBER_S32,
        NumberType::U32 => NUMBER_U32,
        NumberType::F32 => NUMBER_F32,
        NumberType::F64 => NUMBER_F64,
    }
}

/// A string argument's text.
///
/// # Safety
/// `name` is null (a trap) or a valid string.
unsafe fn string_arg(call: &str, name: *const Str) -> String {
    // SAFETY: checked for null; then the caller's promise.
    match unsafe { name.as_ref().and_then(|s| read_str(s)) } {
        Some(text) => text,
        None => trap(&format!("{call}: a null string")),
    }
}

/// The values of an `attribute-values` argument, copied.
///
/// # Safety
/// `values` is null (a trap) or a valid variant whose list is readable.
unsafe fn values_arg(call: &str, values: *const AttributeValues) -> Values {
    // SAFETY: checked for null; each arm reads the list as its tag says it was written.
    unsafe {
        let Some(values) = values.as_ref() else { trap(&format!("{call}: null values")) };
        let (ptr, len) = (values.list.ptr, values.list.len);
        let copied = match values.tag {
            NUMBER_U8 => slice(ptr.cast::<u8>(), len).map(|v| Values::U8(v.to_vec())),
            NUMBER_S32 => slice(ptr.cast::<i32>(), len).map(|v| Values::I32(v.to_vec())),
            NUMBER_U32 => slice(ptr.cast::<u32>(), len).map(|v| Values::U32(v.to_vec())),
            NUMBER_F32 => slice(ptr.cast::<f32>(), len).map(|v| Values::F32(v.to_vec())),
            NUMBER_F64 => slice(ptr.cast::<f64>(), len).map(|v| Values::F64(v.to_vec())),
            tag => trap(&format!("{call}: attribute values of tag {tag}, none of the WIT's")),
        };
        copied.unwrap_or_else(|| trap(&format!("{call}: a null list")))
    }
}

/// Values as the bindings' variant, its list `malloc`ed.
fn c_values(values: &Values) -> AttributeValues {
    fn untyped<T>(list: List<T>) -> List<std::ffi::c_void> {
        List { ptr: list.ptr.cast(), len: list.len }
    }
    let list = match values {
        Values::U8(v) => untyped(c_copy(v)),
        Values::I32(v) => untyped(c_copy(v)),
        Values::U32(v) => untyped(c_copy(v)),
        Values::F32(v) => untyped(c_copy(v)),
        Values::F64(v) => untyped(c_copy(v)),
    };
    AttributeValues { tag: number_code(values.number_type()), list }
}

/// # Safety
/// `ret` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_attributes(
    mesh: Handle,
    ret: *mut List<AttributeInfo>,
) {
    let list = read("attributes", mesh, |m| {
        let infos = m.attributes().into_iter().map(|a| AttributeInfo {
            domain: domain_code(a.domain),
            name: c_string(&a.name),
            components: a.components,
            number_type: number_code(a.number_type),
        });
        c_list(infos.collect())
    });
    // SAFETY: the caller's promise.
    unsafe { put("attributes", ret, list) }
}

/// # Safety
/// `name` is readable; `ret` and `err` are writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_read_attribute(
    mesh: Handle,
    domain: u8,
    name: *const Str,
    ret: *mut AttributeValues,
    err: *mut EditError,
) -> bool {
    let call = "read-attribute";
    let (domain, name) = (domain_arg(call, domain), unsafe { string_arg(call, name) });
    let result = read(call, mesh, |m| m.read_attribute(domain, &name).map(|v| c_values(&v)));
    // SAFETY: the caller's promise.
    unsafe { answer(call, result, ret, err) }
}

/// # Safety
/// `name` and `values` are readable, `maybe_ids` null (none) or readable; `err` writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_set_attribute(
    mesh: Handle,
    domain: u8,
    name: *const Str,
    components: u8,
    maybe_ids: *const List<u32>,
    values: *const AttributeValues,
    err: *mut EditError,
) -> bool {
    let call = "set-attribute";
    // SAFETY: the caller's promise.
    unsafe {
        let (domain, name) = (domain_arg(call, domain), string_arg(call, name));
        let ids = (!maybe_ids.is_null()).then(|| list_arg(call, maybe_ids));
        let values = values_arg(call, values);
        edit_unit(call, mesh, err, |m| m.set_attribute(domain, name, components, ids, values))
    }
}

/// # Safety
/// `name` is readable; `err` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_geometry_mesh_method_mesh_remove_attribute(
    mesh: Handle,
    domain: u8,
    name: *const Str,
    err: *mut EditError,
) -> bool {
    let call = "remove-attribute";
    // SAFETY: the caller's promise.
    unsafe {
        let (domain, name) = (domain_arg(call, domain), string_arg(call, name));
        edit_unit(call, mesh, err, |m| m.remove_attribute(domain, name))
    }
}

// ---- the resource itself ------------------------------------------------------------------

/// Ends the plugin's borrow; the run still holds the mesh.
#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_mesh_drop_borrow(mesh: Handle) {
    read("drop-borrow", mesh, |_| ())
}

/// A plugin never owns a mesh (`run` borrows it): a host would trap on this.
#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_mesh_drop_own(mesh: Handle) {
    trap(&format!("[resource-drop]mesh: handle {} is borrowed, not owned", mesh.handle))
}

/// A plugin never owns a mesh; the handle, borrowed, as the bindings define it.
#[unsafe(no_mangle)]
pub extern "C" fn meshflow_geometry_mesh_borrow_mesh(mesh: Handle) -> Handle {
    mesh
}
