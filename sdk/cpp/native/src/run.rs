//! The native API of `meshflow_native.h`: meshes from files or arrays, and runs of a
//! plugin's services through its exported `describe` and `run`, as a host runs them.

use std::fmt;
use std::path::Path;

use meshflow_mesh::MeshData;
use meshflow_mesh::calls::{MeshCalls, Recorder};
use meshflow_params::{ParamError, ServiceInfo, ServiceKind, Value, ValueType};

use crate::abi::{
    self, CValue, DescribeFn, List, OptionValue, Outcome, Param, RunFn, Str, c_list, c_string,
    c_value, free_string, panic_text, read_str, read_value, slice,
};
use crate::calls::{register, unregister};
use crate::free::{
    exports_meshflow_geometry_service_list_service_info_free, meshflow_geometry_types_outcome_free,
    plugin_list_string_free,
};

/// Why a native call failed; each says what a host would say in its place.
#[derive(Debug)]
enum Failure {
    /// A mesh file could not be read or written (the host's reader's or writer's message).
    File(String),
    /// Arrays that are no mesh.
    InvalidMesh(String),
    /// As the host's `RunError::UnknownService`.
    UnknownService { service: String, suggestion: String, available: String },
    /// Parameters refused by the host's rules (`meshflow_params::resolve`).
    Params(ParamError),
    /// The service returned an error: `RunError::Failed`.
    Failed { service: String, message: String },
    /// A result unlike the description: `RunError::BadResult`.
    BadResult { service: String, problem: meshflow_params::ResultError },
    /// What a host would trap on: `RunError::Trap`.
    Crashed { service: String, message: String },
    /// A wrong argument to this API (null pointers, lengths).
    Argument(String),
    /// A panic of this library.
    Internal(String),
}

impl fmt::Display for Failure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Failure::File(message) | Failure::InvalidMesh(message) | Failure::Argument(message) => {
                f.write_str(message)
            }
            Failure::UnknownService { service, suggestion, available } => {
                write!(
                    f,
                    "unknown service `{service}`{suggestion}; available services: {available}"
                )
            }
            Failure::Params(e) => e.fmt(f),
            Failure::Failed { service, message } => write!(f, "{service}: {message}"),
            Failure::BadResult { service, problem } => {
                write!(f, "{service}: invalid result: {problem}")
            }
            Failure::Crashed { service, message } => {
                write!(f, "{service}: the plugin crashed: {message}")
            }
            Failure::Internal(message) => write!(f, "meshflow native: internal error: {message}"),
        }
    }
}

impl Failure {
    /// The `MESHFLOW_NATIVE_ERROR_*` number.
    fn code(&self) -> u8 {
        match self {
            Failure::File(_) => 1,
            Failure::InvalidMesh(_) => 2,
            Failure::UnknownService { .. } => 3,
            Failure::Params(_) => 4,
            Failure::Failed { .. } => 5,
            Failure::BadResult { .. } => 6,
            Failure::Crashed { .. } => 7,
            Failure::Argument(_) => 8,
            Failure::Internal(_) => 9,
        }
    }
}

/// `meshflow_native_error_t`.
#[repr(C)]
pub struct NativeError {
    pub kind: u8,
    pub message: Str,
}

/// `meshflow_native_outcome_t`.
#[repr(C)]
pub struct NativeOutcome {
    pub mesh: *mut MeshData,
    pub report: Str,
    pub value: OptionValue,
    pub edits: u64,
    pub ops: List<Str>,
}

/// Runs `f` with panics caught; writes a failure to `err` (when it can) and says whether
/// `f` succeeded.
fn answer(err: *mut NativeError, f: impl FnOnce() -> Result<(), Failure>) -> bool {
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(f))
        .unwrap_or_else(|panic| Err(Failure::Internal(panic_text(&*panic))));
    match result {
        Ok(()) => true,
        Err(failure) => {
            // SAFETY: `err` is null or writable, as meshflow_native.h asks.
            if let Some(err) = unsafe { err.as_mut() } {
                *err =
                    NativeError { kind: failure.code(), message: c_string(&failure.to_string()) };
            } else {
                eprintln!("meshflow native: {failure}");
            }
            false
        }
    }
}

/// A path argument.
///
/// # Safety
/// `path` holds `len` readable bytes.
unsafe fn path_arg(path: *const u8, len: usize) -> Result<String, Failure> {
    // SAFETY: the caller's promise.
    let bytes = unsafe { slice(path, len) }.ok_or(Failure::Argument("a null path".into()))?;
    String::from_utf8(bytes.to_vec()).map_err(|_| Failure::Argument("a path not in UTF-8".into()))
}

/// Writes `mesh` to an out-pointer as a new handle.
///
/// # Safety
/// `out` is null or writable.
unsafe fn give_mesh(out: *mut *mut MeshData, mesh: MeshData) -> Result<(), Failure> {
    // SAFETY: the caller's promise.
    let out = unsafe { out.as_mut() }.ok_or(Failure::Argument("a null mesh out-pointer".into()))?;
    *out = Box::into_raw(Box::new(mesh));
    Ok(())
}

/// Loads a mesh file (OBJ, PLY, OFF, STL; the format from the extension) as a host does.
///
/// # Safety
/// `path` holds `len` readable bytes; `out` and `err` are null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_load(
    path: *const u8,
    len: usize,
    out: *mut *mut MeshData,
    err: *mut NativeError,
) -> bool {
    answer(err, || {
        // SAFETY: the caller's promise.
        let path = unsafe { path_arg(path, len) }?;
        let mesh = meshflow_meshio::load(Path::new(&path))
            .map_err(|e| Failure::File(format!("cannot read {path}: {e}")))?;
        // SAFETY: the caller's promise.
        unsafe { give_mesh(out, mesh) }
    })
}

/// A mesh from arrays: x y z per vertex, a b c per triangle, every corner in range and every
/// coordinate finite.
///
/// # Safety
/// `xyz` and `abc` hold their lengths' readable values; `out` and `err` are null or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_new(
    xyz: *const f32,
    xyz_len: usize,
    abc: *const u32,
    abc_len: usize,
    out: *mut *mut MeshData,
    err: *mut NativeError,
) -> bool {
    answer(err, || {
        // SAFETY: the caller's promise.
        let (xyz, abc) = unsafe { (slice(xyz, xyz_len), slice(abc, abc_len)) };
        let (Some(xyz), Some(abc)) = (xyz, abc) else {
            return Err(Failure::Argument("a null array".into()));
        };
        let invalid = |why: String| Err(Failure::InvalidMesh(why));
        if xyz.len() % 3 != 0 || abc.len() % 3 != 0 {
            return invalid(format!(
                "{} coordinates and {} corners: both must be multiples of 3",
                xyz.len(),
                abc.len()
            ));
        }
        if let Some(i) = xyz.iter().position(|x| !x.is_finite()) {
            return invalid(format!("coordinate {i} is {}", xyz[i]));
        }
        let vertices = xyz.len() / 3;
        if let Some(i) = abc.iter().position(|&v| v as usize >= vertices) {
            return invalid(format!("corner {i} is vertex {}, of {vertices} vertices", abc[i]));
        }
        // SAFETY: the caller's promise.
        unsafe { give_mesh(out, MeshData::new(xyz.to_vec(), abc.to_vec())) }
    })
}

/// Writes a mesh file (PLY binary, OBJ or OFF, from the extension) as a host does.
///
/// # Safety
/// `mesh` is null or a live mesh; `path` holds `len` readable bytes; `err` is null or
/// writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_save(
    mesh: *const MeshData,
    path: *const u8,
    len: usize,
    err: *mut NativeError,
) -> bool {
    answer(err, || {
        // SAFETY: the caller's promise.
        let (mesh, path) = unsafe { (mesh.as_ref(), path_arg(path, len)?) };
        let mesh = mesh.ok_or(Failure::Argument("a null mesh".into()))?;
        meshflow_meshio::save(Path::new(&path), mesh)
            .map_err(|e| Failure::File(format!("cannot write {path}: {e}")))
    })
}

/// The same mesh, a handle of its own.
///
/// # Safety
/// `mesh` is a live mesh.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_clone(mesh: *const MeshData) -> *mut MeshData {
    // SAFETY: the caller's promise.
    let mesh = unsafe { mesh.as_ref() }.unwrap_or_else(|| abi::trap("mesh_clone: a null mesh"));
    abi::shielded("mesh_clone", || Box::into_raw(Box::new(mesh.clone())))
}

/// # Safety
/// `mesh` is null or a live mesh, not used after this.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_free(mesh: *mut MeshData) {
    if !mesh.is_null() {
        // SAFETY: it came from Box::into_raw in this file, and is freed once.
        drop(unsafe { Box::from_raw(mesh) });
    }
}

/// The mesh behind a handle, or a trap.
///
/// # Safety
/// `mesh` is null or a live mesh.
unsafe fn mesh_ref<'a>(call: &str, mesh: *const MeshData) -> &'a MeshData {
    // SAFETY: the caller's promise.
    unsafe { mesh.as_ref() }.unwrap_or_else(|| abi::trap(&format!("{call}: a null mesh")))
}

/// # Safety
/// `mesh` is a live mesh.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_vertex_count(mesh: *const MeshData) -> u32 {
    // SAFETY: the caller's promise.
    unsafe { mesh_ref("vertex_count", mesh) }.vertex_count() as u32
}

/// # Safety
/// `mesh` is a live mesh.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_triangle_count(mesh: *const MeshData) -> u32 {
    // SAFETY: the caller's promise.
    unsafe { mesh_ref("triangle_count", mesh) }.triangle_count() as u32
}

/// x y z per vertex, borrowed for as long as the mesh lives.
///
/// # Safety
/// `mesh` is a live mesh; `len` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_positions(
    mesh: *const MeshData,
    len: *mut usize,
) -> *const f32 {
    // SAFETY: the caller's promise.
    let positions = &unsafe { mesh_ref("positions", mesh) }.positions;
    // SAFETY: the caller's promise.
    unsafe { put_len(len, positions.len()) };
    positions.as_ptr()
}

/// a b c per triangle, borrowed for as long as the mesh lives.
///
/// # Safety
/// `mesh` is a live mesh; `len` is writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_triangles(
    mesh: *const MeshData,
    len: *mut usize,
) -> *const u32 {
    // SAFETY: the caller's promise.
    let triangles = &unsafe { mesh_ref("triangles", mesh) }.triangles;
    // SAFETY: the caller's promise.
    unsafe { put_len(len, triangles.len()) };
    triangles.as_ptr()
}

/// # Safety
/// `len` is null (a trap) or writable.
unsafe fn put_len(len: *mut usize, value: usize) {
    // SAFETY: the caller's promise.
    match unsafe { len.as_mut() } {
        Some(len) => *len = value,
        None => abi::trap("a null length pointer"),
    }
}

/// The canonical content hash, as `meshflow hash` prints it: 64 hex digits and a NUL.
///
/// # Safety
/// `mesh` is a live mesh; `out` has room for 65 bytes.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_mesh_hash(mesh: *const MeshData, out: *mut u8) {
    // SAFETY: the caller's promise.
    let mesh = unsafe { mesh_ref("hash", mesh) };
    if out.is_null() {
        abi::trap("hash: a null buffer");
    }
    let hex = abi::shielded("hash", || mesh.content_hash().to_hex());
    // SAFETY: `out` has room for 65 bytes; the hex is 64 ASCII bytes.
    unsafe {
        std::ptr::copy_nonoverlapping(hex.as_ptr(), out, hex.len());
        out.add(hex.len()).write(0);
    }
}

/// # Safety
/// `err` is null or a valid error.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_error_free(err: *mut NativeError) {
    // SAFETY: the caller's promise.
    if let Some(err) = unsafe { err.as_mut() } {
        free_string(&mut err.message);
    }
}

/// # Safety
/// `outcome` is null or an outcome `meshflow_native_run` wrote, freed once.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn meshflow_native_outcome_free(outcome: *mut NativeOutcome) {
    // SAFETY: the caller's promise; each field is as meshflow_native_run wrote it.
    unsafe {
        let Some(o) = outcome.as_mut() else { return };
        meshflow_native_mesh_free(o.mesh);
        o.mesh = std::ptr::null_mut();
        free_string(&mut o.report);
        crate::free::meshflow_geometry_types_option_value_free(&mut o.value);
        o.value.is_some = false;
        plugin_list_string_free(&mut o.ops);
    }
}

/// Runs `service` on a copy of `mesh` through the plugin's exported `describe` and `run`, as
/// a host does: the parameters resolved by the host's rules (defaults filled in, types and
/// ranges checked), a check on a read-only mesh, a check's value checked against its type,
/// the result compacted as a host compacts it.
///
/// # Safety
/// `describe` and `run` are the plugin's exports (MESHFLOW_EXPORT_PLUGIN); `service` holds
/// `service_len` readable bytes; `mesh` is a live mesh; `params` holds `params_len` valid
/// parameters (borrowed); `out` and `err` are null or writable.
#[unsafe(no_mangle)]
#[allow(clippy::too_many_arguments)]
pub unsafe extern "C" fn meshflow_native_run(
    describe: Option<DescribeFn>,
    run: Option<RunFn>,
    service: *const u8,
    service_len: usize,
    mesh: *const MeshData,
    params: *const Param,
    params_len: usize,
    out: *mut NativeOutcome,
    err: *mut NativeError,
) -> bool {
    answer(err, || {
        let (Some(describe), Some(run)) = (describe, run) else {
            return Err(Failure::Argument("null describe or run function".into()));
        };
        // SAFETY: the caller's promise, for each argument.
        let (service, mesh, given) = unsafe {
            let service = slice(service, service_len)
                .ok_or(Failure::Argument("a null service name".into()))?;
            let mesh = mesh.as_ref().ok_or(Failure::Argument("a null mesh".into()))?;
            let given = given_params(params, params_len)?;
            (String::from_utf8_lossy(service).into_owned(), mesh, given)
        };
        let out = NonNullOut(out);
        // SAFETY: the exports are the plugin's, called as a host calls them.
        let outcome = unsafe { run_service(describe, run, &service, mesh, &given) }?;
        out.write(outcome)
    })
}

struct NonNullOut(*mut NativeOutcome);

impl NonNullOut {
    fn write(self, outcome: NativeOutcome) -> Result<(), Failure> {
        if self.0.is_null() {
            let mut outcome = outcome;
            // SAFETY: the outcome was just written by this library.
            unsafe { meshflow_native_outcome_free(&mut outcome) };
            return Err(Failure::Argument("a null outcome pointer".into()));
        }
        // SAFETY: non-null, and writable by meshflow_native_run's contract.
        unsafe { self.0.write(outcome) };
        Ok(())
    }
}

/// The caller's parameters, as a host takes them from a request.
///
/// # Safety
/// `params` holds `len` valid parameters.
unsafe fn given_params(params: *const Param, len: usize) -> Result<Vec<(String, Value)>, Failure> {
    // SAFETY: the caller's promise.
    let params = unsafe { slice(params, len) }.ok_or(Failure::Argument("null params".into()))?;
    let bad = || Failure::Argument("a parameter with a null name or an unknown value tag".into());
    // SAFETY: each parameter is valid, by the caller's promise.
    let read = |p: &Param| unsafe { Some((read_str(&p.name)?, read_value(&p.value)?)) };
    params.iter().map(|p| read(p).ok_or_else(bad)).collect()
}

/// The service run end to end; the outcome in C's terms.
///
/// # Safety
/// `describe` and `run` are the plugin's exports.
unsafe fn run_service(
    describe: DescribeFn,
    run: RunFn,
    service: &str,
    mesh: &MeshData,
    given: &[(String, Value)],
) -> Result<NativeOutcome, Failure> {
    // SAFETY: the caller's promise.
    let services = unsafe { described(describe) }?;
    let names = || services.iter().map(|s| s.name.as_str());
    let info =
        services.iter().find(|s| s.name == service).ok_or_else(|| Failure::UnknownService {
            service: service.to_owned(),
            suggestion: meshflow_params::did_you_mean(service, names()),
            available: names().collect::<Vec<_>>().join(", "),
        })?;
    let params = meshflow_params::resolve(info, given).map_err(Failure::Params)?;

    let is_check = info.kind == ServiceKind::Check;
    let handle = register(Recorder::new(mesh.clone(), is_check));
    // The arguments as the canonical ABI lifts them into a guest: owned by the callee.
    let mut name = c_string(service);
    let mut list = c_list(
        params
            .iter()
            .map(|(name, value)| Param { name: c_string(name), value: c_value(value) })
            .collect(),
    );
    let mut ret = Outcome {
        value: OptionValue { is_some: false, val: c_value(&Value::Boolean(false)) },
        report: Str { ptr: std::ptr::null_mut(), len: 0 },
    };
    let mut message = Str { ptr: std::ptr::null_mut(), len: 0 };
    // SAFETY: the plugin's export, with arguments laid out as plugin.h declares them.
    let ok = unsafe { run(&mut name, handle, &mut list, &mut ret, &mut message) };
    let recorder = unregister(handle)
        .ok_or_else(|| Failure::Internal(format!("the run's mesh {handle:?} went missing")))?;

    let crashed = |message: &str| Failure::Crashed {
        service: service.to_owned(),
        message: message.to_owned(),
    };
    if !ok {
        // SAFETY: on failure the plugin wrote its message.
        let text = unsafe { read_str(&message) };
        free_string(&mut message);
        let text = text.ok_or_else(|| crashed("a null error message"))?;
        return Err(Failure::Failed { service: service.to_owned(), message: text });
    }
    // SAFETY: on success the plugin wrote the outcome; it is read, then freed once.
    let (report, value) = unsafe {
        let report = read_str(&ret.report);
        let value = if ret.value.is_some { Some(read_value(&ret.value.val)) } else { None };
        meshflow_geometry_types_outcome_free(&mut ret);
        (report, value)
    };
    let report = report.ok_or_else(|| crashed("a null report"))?;
    let value =
        value.map(|v| v.ok_or_else(|| crashed("a value of an unknown type"))).transpose()?;
    meshflow_params::check_result(info, value.as_ref())
        .map_err(|problem| Failure::BadResult { service: service.to_owned(), problem })?;

    let report = meshflow_mesh::calls::with_defaulted_note(report, recorder.store());
    let (mesh, ops) = recorder.finish();
    let edits = ops.iter().map(|op| op.edit_count() as u64).sum();
    let op_names = ops.iter().map(|op| c_string(op.kind().name())).collect();
    Ok(NativeOutcome {
        mesh: Box::into_raw(Box::new(mesh)),
        report: c_string(&report),
        value: match &value {
            Some(v) => OptionValue { is_some: true, val: c_value(v) },
            None => OptionValue { is_some: false, val: no_value() },
        },
        edits,
        ops: c_list(op_names),
    })
}

fn no_value() -> CValue {
    c_value(&Value::Boolean(false))
}

/// The plugin's services, as a host reads `describe()`.
///
/// # Safety
/// `describe` is the plugin's export.
unsafe fn described(describe: DescribeFn) -> Result<Vec<ServiceInfo>, Failure> {
    let mut list = List { ptr: std::ptr::null_mut(), len: 0 };
    // SAFETY: the export writes a list of descriptions it allocated.
    unsafe { describe(&mut list) };
    // SAFETY: the list is read, then freed once.
    let services = unsafe {
        let services = slice(list.ptr, list.len)
            .and_then(|all| all.iter().map(|s| service_info(s)).collect::<Option<Vec<_>>>());
        exports_meshflow_geometry_service_list_service_info_free(&mut list);
        services
    };
    services.ok_or_else(|| Failure::Crashed {
        service: "describe".into(),
        message: "a description with null strings or unknown types".into(),
    })
}

/// One description in meshflow's terms, as the runtime's bindings convert it.
///
/// # Safety
/// `s` is a valid description.
unsafe fn service_info(s: &abi::ServiceInfo) -> Option<ServiceInfo> {
    // SAFETY: the caller's promise, for each field.
    unsafe {
        let params = slice(s.params.ptr, s.params.len)?;
        let params = params
            .iter()
            .map(|p| {
                let choices = slice(p.choices.ptr, p.choices.len)?;
                Some(meshflow_params::ParamInfo {
                    name: read_str(&p.name)?,
                    ty: value_type(p.ty)?,
                    default: read_value(&p.default)?,
                    min: p.min.is_some.then_some(p.min.val),
                    max: p.max.is_some.then_some(p.max.val),
                    choices: choices.iter().map(|c| read_str(c)).collect::<Option<_>>()?,
                    doc: read_str(&p.doc)?,
                })
            })
            .collect::<Option<_>>()?;
        let result_type = match s.result_type.is_some {
            true => Some(value_type(s.result_type.val)?),
            false => None,
        };
        Some(ServiceInfo {
            name: read_str(&s.name)?,
            kind: if s.kind == abi::KIND_CHECK { ServiceKind::Check } else { ServiceKind::Filter },
            doc: read_str(&s.doc)?,
            params,
            result_type,
        })
    }
}

fn value_type(code: u8) -> Option<ValueType> {
    Some(match code {
        0 => ValueType::Boolean,
        1 => ValueType::Integer,
        2 => ValueType::Real,
        3 => ValueType::Text,
        _ => return None,
    })
}
