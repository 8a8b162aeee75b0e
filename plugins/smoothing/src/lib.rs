//! Smoothing and noise filters. Algorithms are pure functions over arrays (one per file);
//! the service functions here only move data between them and the host.

pub mod laplacian;
pub mod noise;
pub mod random;
pub mod taubin;

use meshflow_plugin_sdk::geometry::bounding_box;
use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service};

use laplacian::{Pinning, Weights};

fn laplacian_smoothing(mesh: &Mesh, params: &Params) -> Result<String> {
    let iterations = params.integer("iterations")? as u32;
    let pinning = if params.boolean("keep-boundary")? { Pinning::Boundary } else { Pinning::None };
    let weights = match params.text("weights")? {
        "cotangent" => Weights::Cotangent,
        _ => Weights::Uniform,
    };
    let smoothed =
        laplacian::smooth_owned(mesh.positions(), mesh.triangles(), iterations, pinning, weights);
    // One move-all edit for the whole step: the correction codes it as displacements.
    mesh.set_positions(&smoothed)?;
    Ok(format!(
        "{iterations} {} Laplacian iteration(s) over {} vertices",
        params.text("weights")?,
        mesh.vertex_count()
    ))
}

fn taubin_smoothing(mesh: &Mesh, params: &Params) -> Result<String> {
    let (lambda, mu) = (params.real("lambda")?, params.real("mu")?);
    let iterations = params.integer("iterations")? as u32;
    let smoothed = taubin::smooth_owned(mesh.positions(), mesh.triangles(), lambda, mu, iterations);
    mesh.set_positions(&smoothed)?;
    Ok(format!(
        "{iterations} Taubin iteration(s) (lambda {lambda}, mu {mu}) over {} vertices",
        mesh.vertex_count()
    ))
}

fn add_noise(mesh: &Mesh, params: &Params) -> Result<String> {
    let percent = params.real("amount")?;
    let seed = params.integer("seed")? as u64;
    let positions = mesh.positions();
    let diagonal = bounding_box(&positions).map_or(0.0, |b| b.diagonal());
    let radius = percent / 100.0 * diagonal;
    mesh.set_positions(&noise::add_noise(&positions, radius, seed))?;
    Ok(format!(
        "moved {} vertices by up to {radius:.6} ({percent}% of the bounding-box diagonal), seed {seed}",
        mesh.vertex_count()
    ))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter(
            "laplacian-smoothing",
            "Moves every vertex to the weighted average of its neighbours, `iterations` times.",
            laplacian_smoothing,
        )
        .param(ParamSpec::integer("iterations", 1).range(1.0, 1000.0).doc("Smoothing steps."))
        .param(ParamSpec::boolean("keep-boundary", true).doc("Keep boundary vertices fixed."))
        .param(ParamSpec::choice("weights", "uniform", &["uniform", "cotangent"]).doc(
            "uniform: every neighbour alike; cotangent: cotangent edge weights, which keep \
             the sampling and move vertices along the normal.",
        )),
        Service::filter(
            "taubin-smoothing",
            "Smooths without shrinking: each iteration moves every vertex by `lambda` times its \
             uniform Laplacian, then by `mu` (negative) times the Laplacian again. Boundary \
             vertices stay.",
            taubin_smoothing,
        )
        .param(
            ParamSpec::real("lambda", 0.5)
                .range(1e-6, 1.0)
                .doc("Shrinking step, towards the neighbours' mean."),
        )
        .param(
            ParamSpec::real("mu", -0.53)
                .range(-1.0, -1e-6)
                .doc("Inflating step (negative); |mu| slightly above lambda keeps the volume."),
        )
        .param(ParamSpec::integer("iterations", 10).range(1.0, 1000.0).doc("lambda|mu steps.")),
        Service::filter(
            "add-noise",
            "Moves every vertex by a random vector, uniform in a ball of radius `amount` % of \
             the bounding-box diagonal; the same seed gives the same result.",
            add_noise,
        )
        .param(
            ParamSpec::real("amount", 1.0)
                .range(0.0, 100.0)
                .doc("Largest displacement, in % of the bounding-box diagonal."),
        )
        .param(
            ParamSpec::integer("seed", 0)
                .range(0.0, i64::MAX as f64)
                .doc("Seed of the random sequence."),
        ),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
