//! Services run natively against an in-process mesh: the host's edit checks apply, a check
//! cannot edit, and parameters resolve as on a host.

use meshflow_plugin_sdk::native::{Op, load, run};
use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service, Value, ValueType};

fn lift(mesh: &Mesh, params: &Params) -> Result<String> {
    let h = params.real("height")? as f32;
    mesh.transform(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, h])?;
    Ok(format!("lifted by {h}"))
}

fn bad_edit(mesh: &Mesh, _: &Params) -> Result<String> {
    mesh.add_triangle([0, 0, 1])?;
    Ok("added a triangle with a repeated corner".into())
}

fn sneaky_check(mesh: &Mesh, _: &Params) -> Result<Value> {
    mesh.clear()?;
    Ok(Value::Integer(0))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter("lift", "Moves the mesh up.", lift)
            .param(ParamSpec::real("height", 1.0).range(-10.0, 10.0)),
        Service::filter("bad-edit", "Makes an edit the host refuses.", bad_edit),
        Service::check("sneaky", "Tries to edit.", ValueType::Integer, sneaky_check),
    ]
}

fn bunny() -> meshflow_plugin_sdk::native::MeshData {
    load(concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/data/bunny.obj").as_ref()).unwrap()
}

#[test]
fn a_filter_edits_the_loaded_mesh_and_its_edits_are_recorded() {
    let input = bunny();
    let out = run(&services(), "lift", input.clone(), &[]).unwrap();
    assert_eq!(out.report, "lifted by 1");
    assert_eq!(out.edits.len(), 1);
    assert!(matches!(out.edits[0], Op::Transform { .. }));
    assert_eq!(out.mesh.positions[2], input.positions[2] + 1.0);
    let out = run(&services(), "lift", input.clone(), &[("height", Value::Real(-2.0))]).unwrap();
    assert_eq!(out.mesh.positions[2], input.positions[2] - 2.0);
}

#[test]
fn the_host_checks_refuse_bad_edits_and_edits_in_checks() {
    let error = run(&services(), "bad-edit", bunny(), &[]).unwrap_err();
    assert!(error.0.contains("repeated vertex"), "{error}");
    let error = run(&services(), "sneaky", bunny(), &[]).unwrap_err();
    assert!(error.0.contains("read-only") && error.0.contains("a check may not edit"), "{error}");
}

#[test]
fn unknown_services_and_parameters_are_refused() {
    assert!(run(&services(), "nope", bunny(), &[]).unwrap_err().0.contains("lift, bad-edit"));
    let error = run(&services(), "lift", bunny(), &[("depth", Value::Real(1.0))]).unwrap_err();
    assert!(error.0.contains("no parameter `depth`"), "{error}");
    let error = run(&services(), "lift", bunny(), &[("height", Value::Boolean(true))]).unwrap_err();
    assert!(error.0.contains("`height`"), "{error}");
    let error = run(&services(), "lift", bunny(), &[("height", Value::Integer(20))]).unwrap_err();
    assert!(error.0.contains("outside"), "{error}");
}
