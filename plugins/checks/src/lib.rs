//! Checks: services that measure a mesh and return a value. They run read-only.

mod counts;

use meshflow_sdk::{Service, ValueType};

fn services() -> Vec<Service> {
    vec![
        Service::check(
            "vertex-count",
            "Number of vertices, unreferenced ones included.",
            ValueType::Integer,
            counts::vertex_count,
        ),
        Service::check(
            "triangle-count",
            "Number of triangles.",
            ValueType::Integer,
            counts::triangle_count,
        ),
    ]
}

meshflow_sdk::export_plugin!(services);
