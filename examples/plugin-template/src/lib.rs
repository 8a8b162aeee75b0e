//! An example third-party plugin, built only on the meshflow SDK: a filter that scales a
//! mesh about its centroid, and a check that measures its surface area.

use meshflow_sdk::geometry::triangle_area;
use meshflow_sdk::{Mesh, ParamSpec, Params, REMOVED, Result, Service, Value, ValueType};

/// Total area of the live triangles, in f64.
pub fn surface_area(positions: &[f32], triangles: &[u32]) -> f64 {
    (0..triangles.len() as u32 / 3)
        .filter(|&t| triangles[3 * t as usize] != REMOVED)
        .map(|t| triangle_area(positions, triangles, t))
        .sum()
}

/// The mean of all vertex positions.
pub fn centroid(positions: &[f32]) -> [f64; 3] {
    let n = (positions.len() / 3).max(1) as f64;
    let mut sum = [0.0; 3];
    for p in positions.chunks_exact(3) {
        for k in 0..3 {
            sum[k] += p[k] as f64;
        }
    }
    sum.map(|s| s / n)
}

fn scale(mesh: &Mesh, params: &Params) -> Result<String> {
    let factor = params.real("factor")? as f32;
    let c = centroid(&mesh.positions()).map(|x| x as f32);
    // x' = factor * x + (1 - factor) * c, as one affine map: one recorded edit.
    let t = c.map(|ck| (1.0 - factor) * ck);
    mesh.transform(&[factor, 0.0, 0.0, t[0], 0.0, factor, 0.0, t[1], 0.0, 0.0, factor, t[2]])?;
    Ok(format!("scaled by {factor} about {c:?}"))
}

fn area(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(surface_area(&mesh.positions(), &mesh.triangles())))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter("scale", "Scales the mesh about its centroid.", scale)
            .param(ParamSpec::real("factor", 2.0).range(1e-3, 1e3).doc("Scale factor.")),
        Service::check("surface-area", "Total triangle area.", ValueType::Real, area),
    ]
}

meshflow_sdk::export_plugin!(services);

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_square_has_area_one() {
        let positions = [0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0];
        assert!((surface_area(&positions, &[0, 1, 2, 0, 2, 3]) - 1.0).abs() < 1e-12);
        assert_eq!(centroid(&positions), [0.5, 0.5, 0.0]);
    }
}
