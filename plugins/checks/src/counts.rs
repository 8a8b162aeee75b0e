//! Element counts, straight from the host: no arrays need to cross the boundary.

use meshflow_sdk::{Mesh, Params, Result, Value};

pub fn vertex_count(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Integer(mesh.vertex_count() as i64))
}

pub fn triangle_count(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Integer(mesh.triangle_count() as i64))
}
