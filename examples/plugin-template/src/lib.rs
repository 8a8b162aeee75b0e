//! An example third-party plugin, built only on the meshflow SDK: a filter that scales a
//! mesh about its centroid, and a check that measures its surface area.

use meshflow_plugin_sdk::geometry::{centroid, total_area};
use meshflow_plugin_sdk::topology::transform::{compose, scaling, to_f32_matrix, translation};
use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service, Value, ValueType};

/// `x' = factor * (x - c) + c` about the mean vertex `c`, composed in f64.
pub fn scale_about_centroid(positions: &[f32], factor: f64) -> [f32; 12] {
    let c = centroid(positions).unwrap_or([0.0; 3]);
    let back = translation(c);
    let to_origin = translation(c.map(|x| -x));
    to_f32_matrix(&compose(&back, &compose(&scaling([factor; 3]), &to_origin)))
}
fn scale(mesh: &Mesh, params: &Params) -> Result<String> {
    let factor = params.real("factor")?;
    // One affine map: one recorded edit.
    mesh.transform(&scale_about_centroid(&mesh.positions(), factor))?;
    Ok(format!("scaled by {factor} about the centroid"))
}

fn area(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(total_area(&mesh.positions(), &mesh.triangles())))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter("scale-about-centroid", "Scales the mesh about its centroid.", scale)
            .param(ParamSpec::real("factor", 2.0).range(1e-3, 1e3).doc("Scale factor.")),
        Service::check("total-area", "Total triangle area.", ValueType::Real, area),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scaling_by_two_about_the_centroid_doubles_the_offsets() {
        let positions = [0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 2.0, 2.0, 0.0, 0.0, 2.0, 0.0];
        let m = scale_about_centroid(&positions, 2.0);
        assert_eq!(m, [2.0, 0.0, 0.0, -1.0, 0.0, 2.0, 0.0, -1.0, 0.0, 0.0, 2.0, 0.0]);
    }
}
