//! The C ABI driven from Rust as a C plugin drives it: a plugin's exports written here over
//! `plugin.h`'s calls, run by `meshflow_native_run` (the C++ side is tests/cpp_native.rs).

use meshflow_params::Value;

use crate::abi::{
    CValue, EditError, Handle, List, OptionF64, OptionValue, OptionValueType, Outcome, Param,
    ParamInfo, ServiceInfo, Str, c_list, c_string, c_value, read_str, read_value,
};
use crate::calls::*;
use crate::free::*;
use crate::run::*;

/// A filter `lift` (`dz`, a real in [0, 10], default 1) and a check `count` (an integer).
unsafe extern "C" fn describe(ret: *mut List<ServiceInfo>) {
    let dz = ParamInfo {
        name: c_string("dz"),
        doc: c_string(""),
        ty: 2,
        default: c_value(&Value::Real(1.0)),
        min: OptionF64 { is_some: true, val: 0.0 },
        max: OptionF64 { is_some: true, val: 10.0 },
        choices: c_list(Vec::new()),
    };
    let service = |name: &str, kind: u8, params: Vec<ParamInfo>, result: Option<u8>| ServiceInfo {
        name: c_string(name),
        kind,
        doc: c_string("a test service"),
        params: c_list(params),
        result_type: OptionValueType { is_some: result.is_some(), val: result.unwrap_or(0) },
    };
    let services = vec![service("lift", 0, vec![dz], None), service("count", 1, vec![], Some(1))];
    // SAFETY: the test's caller passes a writable list.
    unsafe { ret.write(c_list(services)) };
}

fn refused(err: &mut EditError) -> (u8, String) {
    // SAFETY: the call that failed wrote the error.
    let message = unsafe { read_str(&err.message) }.unwrap();
    // SAFETY: as above; freed once.
    unsafe { meshflow_geometry_mesh_edit_error_free(err) };
    (err.kind, message)
}

unsafe extern "C" fn run(
    name: *mut Str,
    mesh: Handle,
    params: *mut List<Param>,
    ret: *mut Outcome,
    err: *mut Str,
) -> bool {
    // SAFETY: the arguments are as meshflow_native_run lays them out; each is freed once.
    unsafe {
        let service = read_str(&*name).unwrap();
        let dz = crate::abi::slice((*params).ptr, (*params).len)
            .unwrap()
            .first()
            .map(|p| read_value(&p.value).unwrap());
        plugin_string_free(name);
        exports_meshflow_geometry_service_list_param_free(params);
        let mut error = EditError { kind: 0, message: c_string("") };
        let report = if service == "lift" {
            let Some(Value::Real(dz)) = dz else { panic!("dz resolved to {dz:?}") };
            let mut xyz = List { ptr: std::ptr::null_mut(), len: 0 };
            meshflow_geometry_mesh_method_mesh_positions(mesh, &mut xyz);
            let values = std::slice::from_raw_parts_mut(xyz.ptr, xyz.len);
            values.iter_mut().skip(2).step_by(3).for_each(|z| *z += dz as f32);
            assert!(meshflow_geometry_mesh_method_mesh_set_positions(mesh, &xyz, &mut error));
            plugin_list_f32_free(&mut xyz);
            let mut t = 0;
            let ok =
                meshflow_geometry_mesh_method_mesh_add_triangle(mesh, 0, 0, 1, &mut t, &mut error);
            assert!(!ok);
            let (kind, message) = refused(&mut error);
            format!("{kind} {message}")
        } else {
            assert!(!meshflow_geometry_mesh_method_mesh_clear(mesh, &mut error));
            let (kind, _) = refused(&mut error);
            let count = meshflow_geometry_mesh_method_mesh_vertex_count(mesh) as i64;
            let value = CValue { tag: 1, ..c_value(&Value::Integer(count * 10 + kind as i64)) };
            ret.write(Outcome {
                value: OptionValue { is_some: true, val: value },
                report: c_string(""),
            });
            return true;
        };
        meshflow_geometry_mesh_mesh_drop_borrow(mesh);
        if report.is_empty() {
            err.write(c_string("no report"));
            return false;
        }
        ret.write(Outcome {
            value: OptionValue { is_some: false, val: c_value(&Value::Boolean(false)) },
            report: c_string(&report),
        });
        true
    }
}

fn triangle() -> *mut meshflow_mesh::MeshData {
    let (xyz, abc) = ([0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], [0u32, 1, 2]);
    let mut mesh = std::ptr::null_mut();
    // SAFETY: arrays and out-pointers valid for the call.
    let ok = unsafe {
        meshflow_native_mesh_new(xyz.as_ptr(), 9, abc.as_ptr(), 3, &mut mesh, std::ptr::null_mut())
    };
    assert!(ok);
    mesh
}

/// Runs `service` with `params`; the outcome or the error's kind and message.
fn native_run(service: &str, params: &[(&str, Value)]) -> Result<NativeOutcome, (u8, String)> {
    let mesh = triangle();
    let params: Vec<Param> =
        params.iter().map(|(n, v)| Param { name: c_string(n), value: c_value(v) }).collect();
    let mut out = std::mem::MaybeUninit::<NativeOutcome>::uninit();
    let mut err = NativeError { kind: 0, message: c_string("") };
    // SAFETY: every pointer is valid for the call; the exports are this file's.
    let ok = unsafe {
        meshflow_native_run(
            Some(describe),
            Some(run),
            service.as_ptr(),
            service.len(),
            mesh,
            params.as_ptr(),
            params.len(),
            out.as_mut_ptr(),
            &mut err,
        )
    };
    // SAFETY: each value is freed once, after the run.
    unsafe {
        for mut p in params {
            meshflow_geometry_types_param_free(&mut p);
        }
        meshflow_native_mesh_free(mesh);
        if ok {
            return Ok(out.assume_init());
        }
        let message = read_str(&err.message).unwrap();
        meshflow_native_error_free(&mut err);
        Err((err.kind, message))
    }
}

#[test]
fn a_filter_runs_with_its_defaults_and_its_refused_edit_has_the_hosts_kind() {
    let mut out = native_run("lift", &[]).unwrap();
    // SAFETY: the outcome's fields as meshflow_native_run wrote them; freed once.
    unsafe {
        let mesh = &*out.mesh;
        assert_eq!(mesh.positions[2], 1.0, "dz took its default");
        assert_eq!(out.edits, 3);
        let report = read_str(&out.report).unwrap();
        assert!(report.starts_with("3 "), "a repeated vertex: {report}");
        meshflow_native_outcome_free(&mut out);
    }
}

#[test]
fn parameters_are_checked_by_the_hosts_rules() {
    let (kind, message) = native_run("lift", &[("dz", Value::Real(20.0))]).err().unwrap();
    assert_eq!(kind, 4, "{message}");
    assert!(message.contains("out of range [0, 10]"), "{message}");
    let (kind, message) = native_run("lfit", &[]).err().unwrap();
    assert_eq!(kind, 3, "{message}");
    assert!(message.contains("did you mean `lift`?") || message.contains("lift"), "{message}");
}

#[test]
fn a_check_reads_a_read_only_mesh() {
    let mut out = native_run("count", &[]).unwrap();
    // SAFETY: as above.
    unsafe {
        assert_eq!(read_value(&out.value.val), Some(Value::Integer(36)), "3 vertices, read-only");
        assert_eq!((*out.mesh).vertex_count(), 3);
        meshflow_native_outcome_free(&mut out);
    }
}
