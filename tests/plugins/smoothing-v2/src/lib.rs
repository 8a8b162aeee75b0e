//! Test fixture: "version 2" of `laplacian-smoothing`, with the built-in's parameters but
//! another result (each vertex moves half way to its neighbours' mean), so that running it
//! instead of the built-in changes a run's hashes.

use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service};

fn half_step_smoothing(mesh: &Mesh, params: &Params) -> Result<String> {
    let iterations = params.integer("iterations")?;
    let mut positions = mesh.positions();
    let triangles = mesh.triangles();
    for _ in 0..iterations {
        let mut sum = vec![0.0f32; positions.len()];
        let mut count = vec![0u32; positions.len() / 3];
        for corners in triangles.chunks_exact(3) {
            for k in 0..3 {
                let (a, b) = (corners[k] as usize, corners[(k + 1) % 3] as usize);
                for axis in 0..3 {
                    sum[3 * a + axis] += positions[3 * b + axis];
                }
                count[a] += 1;
            }
        }
        for (vertex, &n) in count.iter().enumerate().filter(|(_, n)| **n > 0) {
            for axis in 0..3 {
                let p = &mut positions[3 * vertex + axis];
                *p = 0.5 * *p + 0.5 * sum[3 * vertex + axis] / n as f32;
            }
        }
    }
    mesh.set_positions(&positions)?;
    Ok(format!("{iterations} half step(s)"))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter(
            "laplacian-smoothing",
            "Half-step smoothing (test fixture).",
            half_step_smoothing,
        )
        .param(ParamSpec::integer("iterations", 1).range(1.0, 1000.0).doc("Smoothing steps."))
        .param(ParamSpec::boolean("keep-boundary", true).doc("Ignored."))
        .param(ParamSpec::choice("weights", "uniform", &["uniform", "cotangent"]).doc("Ignored.")),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
