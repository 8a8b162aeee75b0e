//! Cleanup filters for raw scans: small components and degenerate triangles. Algorithms are
//! pure functions over arrays (one per file); the service functions here only move data
//! between them and the host.

pub mod components;
pub mod degenerate;
pub mod mirror;

use meshflow_plugin_sdk::{Error, Mesh, ParamSpec, Params, Result, Service};

use components::Keep;
use mirror::Edit;

fn remove_smallest_components(mesh: &Mesh, params: &Params) -> Result<String> {
    let keep = match params.integer("min-triangles")? {
        0 => Keep::Largest,
        min => Keep::AtLeast(min as u32),
    };
    let removal = components::small_components(mesh.vertex_slots(), &mesh.triangles(), keep);
    // Two bulk edits; removing the vertices alone would not do, as a removed triangle may
    // have all its corners shared with kept pieces (touching them at vertices only).
    if !removal.triangles.is_empty() {
        mesh.remove_triangles(&removal.triangles)?;
    }
    if !removal.vertices.is_empty() {
        mesh.remove_vertices(&removal.vertices)?;
    }
    Ok(format!(
        "removed {} of {} component(s): {} triangle(s), {} vertex(es)",
        removal.components,
        removal.components_before,
        removal.triangles.len(),
        removal.vertices.len()
    ))
}

fn remove_degenerate_triangles(mesh: &Mesh, params: &Params) -> Result<String> {
    let epsilon = params.real("epsilon")?;
    let (repaired, report) =
        degenerate::repair_degenerate(mesh.positions(), mesh.triangles(), epsilon);
    for edit in repaired.into_edits() {
        match edit {
            Edit::RemoveTriangles(ids) => mesh.remove_triangles(&ids)?,
            Edit::SplitEdge { edge, at, vertex } => {
                let created = mesh.split_edge_at(edge, at)?;
                if created != vertex {
                    return Err(Error(format!(
                        "split-edge created vertex {created}, the local copy expected {vertex}"
                    )));
                }
            }
            Edit::CollapseEdge { edge } => mesh.collapse_edge(edge)?,
        }
    }
    Ok(report.to_string())
}

fn services() -> Vec<Service> {
    vec![
        Service::filter(
            "remove-smallest-components",
            "Keeps the largest edge-connected component (by triangle count; ties: the one with \
             the smallest triangle id) and removes the others with the vertices only they used. \
             Vertices no triangle used are left alone.",
            remove_smallest_components,
        )
        .param(ParamSpec::integer("min-triangles", 0).range(0.0, u32::MAX as f64).doc(
            "0: keep only the largest component; otherwise remove only the components with \
             fewer triangles than this.",
        )),
        Service::filter(
            "remove-degenerate-triangles",
            "Repairs zero-area triangles as MeshFix does: caps are split on their long edge, \
             needles collapsed, the rest removed; also removes duplicate triangles and \
             triangles that repeat a vertex.",
            remove_degenerate_triangles,
        )
        .param(ParamSpec::real("epsilon", 0.0).range(0.0, 0.01).doc(
            "0: only exactly flat triangles; otherwise also those whose height is at most \
             this fraction of their longest edge.",
        )),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
