//! Hole filling (Liepa 2003). Algorithms are pure functions over arrays, one per file; the
//! service function here only moves data between them and the host.

pub mod blend;
pub mod fair;
pub mod fill;
pub mod patch;
pub mod refine;
pub mod surroundings;
pub mod triangulate;

use meshflow_plugin_sdk::{
    Error, Mesh, ParamSpec, Params, Result, Service, blend_new_vertex_attributes,
};

use fill::{Settings, fill_holes};

/// The default `max-hole-edges`. A scan's outer border (~2,500 edges) is not a hole: at
/// O(n³) it alone would cost seconds, so it stays open; real holes are far smaller.
pub const DEFAULT_MAX_HOLE_EDGES: i64 = 500;

fn fill_holes_service(mesh: &Mesh, params: &Params) -> Result<String> {
    let settings = Settings {
        max_hole_edges: params.integer("max-hole-edges")? as usize,
        refine: params.boolean("refine")?,
        fairing_iterations: params.integer("fairing-iterations")? as u32,
    };
    let filling = fill_holes(&mesh.positions(), &mesh.triangles(), settings);
    let expected = mesh.vertex_slots() as u32;
    if !filling.new_positions.is_empty() {
        // The new triangles name new vertices by the ids they get when appended in bulk.
        let first = mesh.add_vertices(&filling.new_positions)?;
        if first != expected {
            return Err(Error(format!("new vertices start at {first}, expected {expected}")));
        }
    }
    if !filling.new_triangles.is_empty() {
        mesh.add_triangles(&filling.new_triangles)?;
    }
    // New vertices take colours, quality, … spread in from each hole's boundary.
    blend_new_vertex_attributes(mesh, &filling.blends)?;
    Ok(format!(
        "filled {} hole(s) with {} triangles and {} vertices; left open: {} above {} edges, \
         {} through a non-manifold vertex, {} without a valid triangulation",
        filling.filled,
        filling.new_triangles.len() / 3,
        filling.new_positions.len() / 3,
        filling.too_large,
        settings.max_hole_edges,
        filling.non_manifold,
        filling.unfillable,
    ))
}

fn services() -> Vec<Service> {
    vec![
        Service::filter(
            "fill-holes",
            "Fills holes (Liepa 2003): minimum-weight triangulation by dihedral angle then \
             area, refinement to the surrounding edge density, umbrella-operator fairing. \
             New vertices take their attributes (colour, quality, …) from the hole's \
             boundary, spread inwards ring by ring, each blending its neighbours nearer \
             the boundary by inverse distance.",
            fill_holes_service,
        )
        .param(
            ParamSpec::integer("max-hole-edges", DEFAULT_MAX_HOLE_EDGES)
                .range(3.0, 100_000.0)
                .doc("Holes with more boundary edges stay open (the cost grows as n³)."),
        )
        .param(ParamSpec::boolean("refine", true).doc("Add vertices to match the density around."))
        .param(ParamSpec::integer("fairing-iterations", 100).range(0.0, 10_000.0).doc(
            "Fairing solver steps on the new vertices (0: keep them where refinement put them).",
        )),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
