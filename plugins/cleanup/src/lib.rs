//! Cleanup filters for raw scans: small components, degenerate triangles, non-manifold spots
//! and incoherent orientation. Algorithms are
//! pure functions over arrays (one per file); the service functions here only move data
//! between them and the host.

pub mod components;
pub mod degenerate;
pub mod mirror;
pub mod nonmanifold;
pub mod orient;

use meshflow_plugin_sdk::{
    Error, Mesh, ParamSpec, Params, Result, Service, blend_new_vertex_attributes,
};

use components::Keep;
use mirror::Edit;

fn remove_smallest_components(mesh: &Mesh, params: &Params) -> Result<String> {
    let keep = match params.integer("min-triangles")? {
        0 => Keep::Largest,
        min => Keep::AtLeast(min as u32),
    };
    let found = mesh.components();
    let removed = components::to_remove(&found, keep);
    let (vertices, triangles) = (mesh.vertex_count(), mesh.triangle_count());
    for &first in &removed {
        mesh.remove_component(first)?;
    }
    Ok(format!(
        "removed {} of {} component(s): {} triangle(s), {} vertex(es)",
        removed.len(),
        found.len(),
        triangles - mesh.triangle_count(),
        vertices - mesh.vertex_count()
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

fn repair_non_manifold(mesh: &Mesh, _: &Params) -> Result<String> {
    let repair = nonmanifold::repair_non_manifold_owned(&mesh.positions(), mesh.triangles());
    let gone: Vec<u32> = repair.removed.iter().chain(&repair.repointed).copied().collect();
    if !gone.is_empty() {
        mesh.remove_triangles(&gone)?;
    }
    if !repair.new_positions.is_empty() {
        // The re-added triangles name the copies by the ids they get when appended in bulk.
        let expected = mesh.vertex_slots() as u32;
        let first = mesh.add_vertices(&repair.new_positions)?;
        if first != expected {
            return Err(Error(format!("new vertices start at {first}, expected {expected}")));
        }
        // A copy carries on its original's colour, quality, …
        let copies: Vec<(u32, [(u32, f64); 1])> =
            (first..).zip(&repair.copied_from).map(|(copy, &v)| (copy, [(v, 1.0)])).collect();
        blend_new_vertex_attributes(mesh, &copies)?;
    }
    if !repair.readded.is_empty() {
        mesh.add_triangles(&repair.readded)?;
    }
    Ok(format!(
        "removed {} improper, {} duplicate and {} extra triangle(s) on {} non-manifold edge(s); \
         split {} non-manifold vertex(es) into {} new one(s)",
        repair.improper,
        repair.duplicates,
        repair.removed.len() - repair.improper - repair.duplicates,
        repair.non_manifold_edges,
        repair.non_manifold_vertices,
        repair.new_positions.len() / 3,
    ))
}

fn orient_consistently(mesh: &Mesh, _: &Params) -> Result<String> {
    let orientation = orient::orient_consistently(&mesh.positions(), &mesh.triangles());
    if !orientation.flips.is_empty() {
        mesh.flip_triangles(&orientation.flips)?;
    }
    let mut report = format!(
        "flipped {} triangle(s) in {} patch(es); {} closed patch(es) turned outward",
        orientation.flips.len(),
        orientation.patches,
        orientation.turned_outward
    );
    if orientation.non_orientable > 0 {
        report += &format!(
            "; {} patch(es) are not orientable (Möbius-like) and keep some inconsistent edges",
            orientation.non_orientable
        );
    }
    Ok(report)
}

/// Each repair reads the triangles around the vertices it changes (their neighbours, the
/// link condition, whether they are on the boundary) and the positions of those triangles'
/// corners: one ring; one more for margin. Which triangles are repaired, in which order, and
/// how many repairs the budget allows depend only on the triangles that are degenerate,
/// duplicate or repeat a vertex, all of which the repair changes.
fn degenerate_reach(_: &Params) -> Result<u32> {
    Ok(2)
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
        ))
        .local(degenerate_reach),
        Service::filter(
            "repair-non-manifold",
            "Makes the mesh manifold: removes triangles that repeat a vertex and duplicated \
             triangles, keeps two triangles on each edge that has more (an oppositely oriented \
             pair where there is one), and splits each vertex where separate fans meet into \
             one vertex per fan. Unreferenced vertices are left alone.",
            repair_non_manifold,
        ),
        Service::filter(
            "orient-consistently",
            "Flips triangles so that each patch joined by manifold edges is consistently \
             oriented: closed patches with their normals outward, open ones with the fewest \
             flips. Non-manifold edges separate patches; a non-orientable patch is reported.",
            orient_consistently,
        ),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
