//! Smoothing filters. Algorithms are pure functions over arrays (one per file); the service
//! functions here only move data between them and the host.

pub mod laplacian;

use meshflow_sdk::{Mesh, ParamSpec, Params, Result, Service};

use laplacian::Pinning;

fn laplacian_smoothing(mesh: &Mesh, params: &Params) -> Result<String> {
    let iterations = params.integer("iterations")? as u32;
    let pinning = if params.boolean("keep-boundary")? { Pinning::Boundary } else { Pinning::None };
    let smoothed =
        laplacian::smooth_uniform(&mesh.positions(), &mesh.triangles(), iterations, pinning);
    // One move-all edit for the whole step: the correction codes it as displacements.
    mesh.set_positions(&smoothed)?;
    Ok(format!("{iterations} uniform Laplacian iteration(s) over {} vertices", mesh.vertex_count()))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter(
            "laplacian-smoothing",
            "Moves every vertex to the average of its neighbours, `iterations` times.",
            laplacian_smoothing,
        )
        .param(ParamSpec::integer("iterations", 1).range(1.0, 1000.0).doc("Smoothing steps."))
        .param(ParamSpec::boolean("keep-boundary", true).doc("Keep boundary vertices fixed.")),
    ]
}

meshflow_sdk::export_plugin!(services);
