//! What the export macro answers the host's `locality` and `blocks` questions with.

use meshflow_plugin_sdk::bindings::meshflow::geometry::types::Param;
use meshflow_plugin_sdk::{
    Mesh, ParamSpec, Params, Result, Service, Value, ValueType, block_triangles,
};

fn simplify(_: &Mesh, _: &Params) -> Result<String> {
    Ok(String::new())
}

fn measure(_: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Integer(0))
}

/// The parameter as the block size, whatever it is: 0 included.
fn as_given(params: &Params) -> Result<Option<u32>> {
    Ok(Some(params.integer("block-triangles")? as u32))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter("simplify", "Simplifies.", simplify)
            .param(ParamSpec::integer("block-triangles", 5000).range(0.0, 4e9))
            .blocks(as_given),
        Service::filter("whole", "Always whole.", simplify),
        Service::check("measure", "Measures.", ValueType::Integer, measure),
    ]
}

fn size(n: i64) -> Vec<Param> {
    vec![Param { name: "block-triangles".into(), value: Value::Integer(n) }]
}

#[test]
fn blocks_are_declared_per_service_and_zero_means_whole() {
    // The host asks with the parameters resolved: a missing one is refused, so whole.
    assert_eq!(block_triangles(&services(), "simplify", size(2000)), Some(2000));
    assert_eq!(block_triangles(&services(), "simplify", Vec::new()), None);
    // 0 runs whole, as in the C++ and Python SDKs, rather than failing the step.
    assert_eq!(block_triangles(&services(), "simplify", size(0)), None);
    assert_eq!(block_triangles(&services(), "whole", Vec::new()), None);
    assert_eq!(block_triangles(&services(), "measure", Vec::new()), None);
    assert_eq!(block_triangles(&services(), "nope", Vec::new()), None);
}
