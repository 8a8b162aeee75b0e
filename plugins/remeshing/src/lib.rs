//! Filters that change a mesh's resolution: quadric decimation, isotropic remeshing and
//! Loop subdivision.
//! Algorithms are pure functions over arrays, one per file; the service functions here only
//! move data between them and the host.

pub mod closest;
pub mod decimate;
#[cfg(test)]
mod fixtures;
pub mod input;
pub mod isotropic;
pub mod local;
pub mod loop_subdivision;
pub mod renumber;

use meshflow_plugin_sdk::geometry::bounding_box;
use meshflow_plugin_sdk::{
    Error, Mesh, ParamSpec, Params, Result, Service, blend_new_vertex_attributes,
};

use decimate::{Settings, decimate_owned};
use isotropic::{Edit, remesh_owned};
use loop_subdivision::loop_subdivision;

/// The most Loop iterations a run may ask for (each quadruples the triangles).
pub const MAX_LOOP_ITERATIONS: i64 = 5;

/// The default block size of quadric decimation: a block's guest takes ~262 bytes a
/// triangle (docs/benchmarks.md), so 6M-triangle blocks fit the default 2 GiB cap.
const DECIMATION_BLOCK_TRIANGLES: u32 = 6_000_000;

/// Blocks for a ratio target with the boundary kept: each block then keeps its share of
/// the triangles and the vertices blocks share stay. An absolute target has no share of a
/// block, and a boundary that may move would move the blocks' shared vertices. A size of 0
/// runs it whole (the SDK reads blocks of 0 triangles so).
fn decimation_blocks(params: &Params) -> Result<Option<u32>> {
    let by_ratio = params.integer("target-triangles")? == 0;
    let kept = params.boolean("preserve-boundary")?;
    let size = params.integer("block-triangles")?;
    Ok((by_ratio && kept).then_some(size as u32))
}

fn quadric_decimation(mesh: &Mesh, params: &Params) -> Result<String> {
    let input = mesh.triangle_count();
    let target = match params.integer("target-triangles")? {
        0 => {
            let ratio = params.real("target-ratio")?;
            if !(ratio > 0.0 && ratio < 1.0) {
                return Err(Error(format!(
                    "target-ratio must be above 0 and below 1 (got {ratio}), or give \
                     target-triangles"
                )));
            }
            (ratio * input as f64).round() as usize
        }
        n => n as usize,
    };
    if target == 0 || target >= input {
        return Err(Error(format!(
            "the target of {target} triangle(s) must be above 0 and below the input's {input}"
        )));
    }
    let settings = Settings {
        target_triangles: target,
        preserve_boundary: params.boolean("preserve-boundary")?,
        quality_weight: params.real("quality-weight")?,
    };
    let result = decimate_owned(mesh.positions(), mesh.triangles(), settings);
    for &edge in &result.collapses {
        mesh.collapse_edge(edge)?;
    }
    if !result.moved.is_empty() {
        mesh.move_vertices(&result.moved, &result.moved_positions)?;
    }
    let mut report = format!(
        "collapsed {} edge(s): {} → {} triangles (target {target})",
        result.collapses.len(),
        result.triangles_before,
        result.triangles_after
    );
    if result.triangles_after > target {
        report += "; stopped early: every remaining collapse would change the topology, \
                   fold a triangle or move the preserved boundary";
    }
    if result.locked_vertices > 0 {
        report += &format!(
            "; {} vertex(es) on non-manifold spots or degenerate triangles kept in place",
            result.locked_vertices
        );
    }
    Ok(report)
}

fn loop_subdivision_service(mesh: &Mesh, params: &Params) -> Result<String> {
    let iterations = params.integer("iterations")? as u32;
    let positions = mesh.positions();
    let triangles = mesh.triangles();
    let old_vertices = positions.len();
    let result = loop_subdivision(&positions, &triangles, iterations)
        .map_err(|refusal| Error(format!("loop-subdivision: {refusal}")))?;
    mesh.set_positions(&result.positions[..old_vertices])?;
    let expected = mesh.vertex_slots() as u32;
    let first = mesh.add_vertices(&result.positions[old_vertices..])?;
    if first != expected {
        return Err(Error(format!("new vertices start at {first}, expected {expected}")));
    }
    // Each edge point's colour, quality, … is the mean of its edge's ends'.
    let blends: Vec<(u32, [(u32, f64); 2])> =
        (first..).zip(&result.edge_ends).map(|(v, &[a, b])| (v, [(a, 0.5), (b, 0.5)])).collect();
    blend_new_vertex_attributes(mesh, &blends)?;
    let old: Vec<u32> = (0..mesh.triangle_slots() as u32).collect();
    mesh.remove_triangles(&old)?;
    mesh.add_triangles(&result.triangles)?;
    Ok(format!(
        "{iterations} iteration(s): {} → {} triangles, {} → {} vertices",
        triangles.len() / 3,
        result.triangles.len() / 3,
        old_vertices / 3,
        result.positions.len() / 3
    ))
}

fn isotropic_remeshing(mesh: &Mesh, params: &Params) -> Result<String> {
    let positions = mesh.positions();
    let triangles = mesh.triangles();
    let target_length = if params.boolean("mean-edge-length")? {
        mean_edge_length(&positions, &triangles)
    } else {
        let diagonal = bounding_box(&positions).map_or(0.0, |b| b.diagonal());
        params.real("target-edge-length")? / 100.0 * diagonal
    };
    if target_length.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return Err(Error("isotropic-remeshing: the mesh has no edge with a length".into()));
    }
    let settings = isotropic::Settings {
        target_length,
        iterations: params.integer("iterations")? as u32,
        feature_angle_degrees: params.real("feature-angle")?,
    };
    let input_triangles = triangles.len() / 3;
    let result = remesh_owned(positions, triangles, settings)
        .map_err(|refusal| Error(format!("isotropic-remeshing: {refusal}")))?;
    let mut next_vertex = mesh.vertex_slots() as u32;
    for edit in &result.edits {
        match *edit {
            Edit::SplitEdge { edge, at } => {
                let created = mesh.split_edge_at(edge, at)?;
                if created != next_vertex {
                    return Err(Error(format!(
                        "split-edge created vertex {created}, the local copy expected {next_vertex}"
                    )));
                }
                next_vertex += 1;
            }
            Edit::CollapseEdge { edge } => mesh.collapse_edge(edge)?,
            Edit::SwapEdge { edge } => mesh.swap_edge(edge)?,
        }
    }
    mesh.set_positions(&result.positions)?;
    Ok(format!(
        "target edge length {target_length:.6}: {} split(s), {} collapse(s), {} flip(s) over {} \
         iteration(s); {} → {} triangles",
        result.splits,
        result.collapses,
        result.flips,
        settings.iterations,
        input_triangles,
        mesh.triangle_count()
    ))
}

/// The mean length of the triangles' edges (interior edges counted twice).
fn mean_edge_length(positions: &[f32], triangles: &[u32]) -> f64 {
    use meshflow_plugin_sdk::geometry::{distance, point};
    let edges = triangles.chunks_exact(3).flat_map(|c| [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])]);
    let (sum, count) = edges
        .filter(|&(a, b)| (a as usize) < positions.len() / 3 && (b as usize) < positions.len() / 3)
        .fold((0.0, 0usize), |(s, n), (a, b)| {
            (s + distance(point(positions, a), point(positions, b)), n + 1)
        });
    if count == 0 { 0.0 } else { sum / count as f64 }
}

fn services() -> Vec<Service> {
    vec![
        Service::filter(
            "quadric-decimation",
            "Garland–Heckbert quadric edge collapse down to a triangle count. Keeps the \
             topology (no collapse that breaks the link condition), the orientation and \
             manifoldness; refuses collapses that fold a triangle over. Every collapse is \
             recorded as an edge collapse, then the survivors move to their optimal points.",
            quadric_decimation,
        )
        .param(
            ParamSpec::integer("target-triangles", 0)
                .range(0.0, u32::MAX as f64)
                .doc("Triangles to keep; 0: use target-ratio."),
        )
        .param(
            ParamSpec::real("target-ratio", 0.5)
                .range(0.0, 1.0)
                .doc("Fraction of the triangles to keep when target-triangles is 0 (0 < r < 1)."),
        )
        .param(ParamSpec::boolean("preserve-boundary", true).doc(
            "Boundary vertices stay fixed; otherwise planes through the boundary edges hold it.",
        ))
        .param(
            ParamSpec::real("quality-weight", 0.0).range(0.0, 1000.0).doc(
                "0: pure quadric error; more: also avoid collapses that leave thin triangles.",
            ),
        )
        .param(
            ParamSpec::integer("block-triangles", DECIMATION_BLOCK_TRIANGLES.into())
                .range(0.0, u32::MAX as f64)
                .doc(
                    "With target-ratio and preserve-boundary, a mesh of more triangles is \
                     decimated in blocks of about this many, their shared vertices kept (the \
                     same on every host; not a whole-mesh result); 0: always whole.",
                ),
        )
        .blocks(decimation_blocks),
        Service::filter(
            "isotropic-remeshing",
            "Botsch–Kobbelt isotropic remeshing: splits long edges, collapses short ones, flips \
             toward valence 6, relaxes tangentially and projects back onto the input. Sharp \
             edges (feature-angle), boundaries and their vertices are kept. Needs at most two \
             triangles per edge.",
            isotropic_remeshing,
        )
        .param(ParamSpec::boolean("mean-edge-length", true).doc(
            "Aim at the input's mean edge length; off: at target-edge-length.",
        ))
        .param(ParamSpec::real("target-edge-length", 1.0).range(0.01, 100.0).doc(
            "Edge length to reach, in % of the bounding-box diagonal (when mean-edge-length is off).",
        ))
        .param(ParamSpec::integer("iterations", 10).range(1.0, 100.0).doc("Rounds of split, collapse, flip, relax."))
        .param(ParamSpec::real("feature-angle", 45.0).range(0.0, 180.0).doc(
            "Edges whose triangles' normals differ by more degrees are kept as features.",
        )),
        Service::filter(
            "loop-subdivision",
            "Loop subdivision: each triangle becomes four; Loop's weights inside, the curve \
             rule on boundaries, corners held. Needs at most two triangles per edge. A new \
             vertex's attributes (colour, quality, …) are the mean of its edge's ends'.",
            loop_subdivision_service,
        )
        .param(
            ParamSpec::integer("iterations", 1)
                .range(1.0, MAX_LOOP_ITERATIONS as f64)
                .doc("Levels of subdivision (×4 triangles each)."),
        ),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
