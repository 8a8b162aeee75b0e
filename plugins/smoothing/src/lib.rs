//! Smoothing and noise filters, and the curvature they smooth away (written as quality).
//! Algorithms are pure functions over arrays (one per file); the service functions here
//! only move data between them and the host.

pub mod curvature;
pub mod laplacian;
pub mod noise;
pub mod random;
pub mod taubin;

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

/// Each Laplacian step reads one ring further: `k` steps reach `k` rings.
fn laplacian_reach(params: &Params) -> Result<u32> {
    Ok(params.integer("iterations")? as u32)
}

/// Each vertex moves by a draw of its own.
fn noise_reach(_: &Params) -> Result<u32> {
    Ok(0)
}

/// A Taubin iteration is two Laplacian steps.
fn taubin_reach(params: &Params) -> Result<u32> {
    Ok(2 * params.integer("iterations")? as u32)
}

fn add_noise(mesh: &Mesh, params: &Params) -> Result<String> {
    let percent = params.real("amount")?;
    let seed = params.integer("seed")? as u64;
    // The whole mesh's size and ids: the same draws on partitions as on the whole mesh.
    let positions = mesh.positions();
    let diagonal = mesh.whole_bounds(&positions).map_or(0.0, |b| b.diagonal());
    let radius = percent / 100.0 * diagonal;
    mesh.set_positions(&noise::add_noise(&positions, &mesh.whole_ids(), radius, seed))?;
    Ok(format!(
        "moved {} vertices by up to {radius:.6} ({percent}% of the bounding-box diagonal), seed {seed}",
        mesh.vertex_count()
    ))
}

fn curvature_service(mesh: &Mesh, params: &Params) -> Result<String> {
    let kind = match params.text("kind")? {
        "gaussian" => curvature::Kind::Gaussian,
        _ => curvature::Kind::Mean,
    };
    let (positions, triangles) = (mesh.positions(), mesh.triangles());
    let kinds = mesh.half_edge_kinds()?;
    let result = curvature::curvature(&positions, &triangles, &kinds, kind);
    mesh.set_quality(None, &result.values)?;
    let name = params.text("kind")?;
    let mut report = format!("{name} curvature of {} vertices as quality", result.values.len());
    let computed =
        result.values.len() - result.not_interior - result.without_area - result.unreferenced;
    if computed > 0 {
        let (lo, hi) =
            result.values.iter().fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
        report += &format!(": from {lo:.6} to {hi:.6}");
    }
    for (count, what) in [
        (result.not_interior, "on a boundary, non-manifold or misoriented edge"),
        (result.without_area, "with no area around them"),
        (result.unreferenced, "in no triangle"),
    ] {
        if count > 0 {
            report += &format!("; {count} vertices {what} got 0");
        }
    }
    Ok(report)
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
        ))
        .local(laplacian_reach),
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
        .param(ParamSpec::integer("iterations", 10).range(1.0, 1000.0).doc("lambda|mu steps."))
        .local(taubin_reach),
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
        )
        .local(noise_reach),
        Service::filter(
            "curvature",
            "Writes each vertex's discrete curvature as its quality, to colour by (Meyer et \
             al. 2003, over mixed Voronoi areas). mean: half the length of the cotangent \
             Laplacian of the position, positive where the surface bends away from its \
             normal (1/r on a sphere of radius r); gaussian: the angle deficit over the area \
             (1/r²). Boundary and non-manifold vertices get 0. The geometry is unchanged.",
            curvature_service,
        )
        .param(
            ParamSpec::choice("kind", "mean", &["mean", "gaussian"])
                .doc("mean: signed mean curvature H; gaussian: Gaussian curvature K."),
        ),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
