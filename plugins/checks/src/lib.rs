//! Checks: services that measure a mesh and return a value. They run read-only.
//!
//! Each family of checks is a set of functions in its own module over [`MeshArrays`], which
//! fetches from the host only what a check reads: the topology checks read the host's
//! derived connectivity (twins, edge kinds, the edge list), derived once per mesh version
//! and shared by every check on it, rather than each building its own from the triangles.

pub mod angles;
pub mod arrays;
pub mod counts;
pub mod forest;
pub mod measures;
pub mod normals;
pub mod topology;

#[cfg(test)]
mod fixtures;
#[cfg(test)]
mod reference;
#[cfg(test)]
mod same_as_before;

pub use arrays::MeshArrays;

use meshflow_plugin_sdk::{Mesh, Params, Result, Service, Value, ValueType};

fn integer(n: usize) -> Result<Value> {
    Ok(Value::Integer(n as i64))
}

fn vertex_count(mesh: &Mesh, _: &Params) -> Result<Value> {
    integer(mesh.vertex_count())
}

fn triangle_count(mesh: &Mesh, _: &Params) -> Result<Value> {
    integer(mesh.triangle_count())
}

fn edge_count(mesh: &Mesh, _: &Params) -> Result<Value> {
    integer(counts::edge_count(&MeshArrays::of(*mesh)))
}

fn component_count(mesh: &Mesh, _: &Params) -> Result<Value> {
    integer(counts::component_count(&MeshArrays::of(*mesh))?)
}

fn hole_count(mesh: &Mesh, _: &Params) -> Result<Value> {
    integer(counts::hole_count(&MeshArrays::of(*mesh))?)
}

fn is_manifold(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Boolean(topology::is_manifold(&MeshArrays::of(*mesh))?))
}

fn is_oriented(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Boolean(topology::is_oriented(&MeshArrays::of(*mesh))?))
}

fn is_orientable(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Boolean(topology::is_orientable(&MeshArrays::of(*mesh))?))
}

fn min_angle(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(MeshArrays::of(*mesh).angle_extremes().0))
}

fn max_angle(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(MeshArrays::of(*mesh).angle_extremes().1))
}

fn normal_instability(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(normals::normal_instability(&MeshArrays::of(*mesh))))
}

fn surface_area(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(measures::surface_area(&MeshArrays::of(*mesh))))
}

fn volume(mesh: &Mesh, _: &Params) -> Result<Value> {
    Ok(Value::Real(measures::enclosed_volume(&MeshArrays::of(*mesh))?))
}

/// Topology first, then what reads only the arrays: `check --all`'s second instance works
/// from the end of the list while the first derives the connectivity.
fn services() -> Vec<Service> {
    use ValueType::{Boolean, Integer, Real};
    vec![
        Service::check(
            "vertex-count",
            "Number of vertices, unreferenced ones included.",
            Integer,
            vertex_count,
        ),
        Service::check(
            "edge-count",
            "Number of distinct undirected edges; an edge shared by several triangles counts \
             once. Triangles with a repeated vertex have no edges.",
            Integer,
            edge_count,
        ),
        Service::check(
            "triangle-count",
            "Number of triangles, degenerate ones included.",
            Integer,
            triangle_count,
        ),
        Service::check(
            "component-count",
            "Number of connected pieces: triangles sharing an edge belong together; touching \
             at a single vertex is not enough.",
            Integer,
            component_count,
        ),
        Service::check(
            "hole-count",
            "Number of boundary loops (the outer border of an open surface included); 0 for a \
             closed surface.",
            Integer,
            hole_count,
        ),
        Service::check(
            "is-manifold",
            "Whether every edge has at most two triangles and the triangles around every \
             vertex form a single fan (no bow-tie).",
            Boolean,
            is_manifold,
        ),
        Service::check(
            "is-oriented",
            "Whether the two triangles of every interior edge traverse it in opposite \
             directions.",
            Boolean,
            is_oriented,
        ),
        Service::check(
            "is-orientable",
            "Whether flipping some triangles could make the mesh oriented (false for a \
             Möbius strip).",
            Boolean,
            is_orientable,
        ),
        Service::check(
            "volume",
            "Signed volume enclosed by the closed components (positive when wound outward), \
             summed; open components are skipped, and a mesh with no closed component is \
             refused.",
            Real,
            volume,
        ),
        Service::check(
            "normal-instability",
            "Mean angle in degrees between the normals (as stored) of the two triangles of \
             each interior manifold edge; 0 if there is none.",
            Real,
            normal_instability,
        ),
        Service::check(
            "min-angle",
            "Smallest triangle angle in degrees, over non-degenerate triangles; 0 if there \
             is none.",
            Real,
            min_angle,
        ),
        Service::check(
            "max-angle",
            "Largest triangle angle in degrees, over non-degenerate triangles; 0 if there is \
             none.",
            Real,
            max_angle,
        ),
        Service::check(
            "surface-area",
            "Total area of the triangles, in the mesh's units squared.",
            Real,
            surface_area,
        ),
    ]
}

meshflow_plugin_sdk::export_plugin!(services);
