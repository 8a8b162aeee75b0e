//! Write meshflow plugins: services that run sandboxed on any meshflow host.
//!
//! A plugin is a `cdylib` built for `wasm32-wasip2`. Its author writes each service as a
//! function over [`Mesh`], lists the services with their parameters, and exports them in
//! one line:
//!
//! ```no_run
//! use meshflow_plugin_sdk::{Mesh, ParamSpec, Params, Result, Service};
//!
//! /// Moves the mesh up by `height`.
//! fn lift(mesh: &Mesh, params: &Params) -> Result<String> {
//!     let h = params.real("height")? as f32;
//!     mesh.transform(&[1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, h])?;
//!     Ok(format!("lifted {} vertices", mesh.vertex_count()))
//! }
//!
//! fn services() -> Vec<Service> {
//!     vec![Service::filter("lift", "Moves the mesh up.", lift)
//!         .param(ParamSpec::real("height", 1.0).range(-1e6, 1e6))]
//! }
//!
//! meshflow_plugin_sdk::export_plugin!(services);
//! ```
//!
//! Colours, normals, quality, texture coordinates and other per-vertex, per-face or
//! per-corner numbers are read and written whole ([`Mesh::attributes`],
//! [`Mesh::vertex_colors`], [`Mesh::set_quality`], [`Mesh::read_attribute`],
//! [`Mesh::set_attribute`]); a service that makes vertices with `add-vertices` gives them
//! values with [`blend_new_vertex_attributes`] (see [`attributes`]).
//!
//! Algorithms are best written as pure functions over the flat arrays
//! ([`Mesh::positions`], [`Mesh::triangles`]); [`topology`] and [`geometry`] provide what
//! most of them need, and work natively too, so they can be tested with `cargo test`.
//!
//! With the `native` feature (for tests), [`native::run`] runs a service in process on a
//! mesh loaded from a file, with the host's own edit checks.
//!
//! What is compiled into plugins depends on no host-side meshflow crate. The `native`
//! feature alone links the recording store (`meshflow-mesh`) and the mesh readers
//! (`meshflow-meshio`), which depend on nothing of the SDK's, wasmtime or the runtime.

// The generated code names this crate by its public path, which must work inside it too.
extern crate self as meshflow_plugin_sdk;

pub mod attributes;
pub mod bindings;
mod error;
mod mesh;
#[cfg(feature = "native")]
pub mod native;
mod service;

pub use meshflow_topology as topology;
pub use meshflow_topology::geometry;

pub use attributes::{
    AttributeDomain, AttributeInfo, AttributeValues, NumberType, blend_new_vertex_attributes,
};
pub use bindings::meshflow::geometry::mesh::Component;
pub use bindings::meshflow::geometry::types::{Value, ValueType};
pub use error::{Error, Result};
pub use mesh::{Mesh, MeshKey, REMOVED};
pub use service::{
    BlocksFn, CheckFn, FilterFn, ParamSpec, Params, ReachFn, Service, block_triangles, describe,
    reach, run,
};

/// Exports the services returned by a `fn() -> Vec<Service>` as this component's
/// `meshflow:geometry/service` interface, their reach (see [`Service::local`]) as its
/// `meshflow:geometry/locality` interface, and their block size (see [`Service::blocks`]) as
/// its `meshflow:geometry/blocks` interface. Only on wasm targets: a native build of the same
/// crate (for tests and benches) links with others without clashing export names.
#[macro_export]
macro_rules! export_plugin {
    ($services:path) => {
        // Natively the services are still part of the crate's API surface, not dead code.
        #[cfg(not(target_arch = "wasm32"))]
        const _: fn() -> Vec<$crate::Service> = $services;

        #[cfg(target_arch = "wasm32")]
        struct MeshflowPlugin;

        #[cfg(target_arch = "wasm32")]
        impl $crate::bindings::exports::meshflow::geometry::service::Guest for MeshflowPlugin {
            fn describe() -> Vec<$crate::bindings::meshflow::geometry::types::ServiceInfo> {
                $crate::describe(&$services())
            }

            fn run(
                name: String,
                target: &$crate::bindings::meshflow::geometry::mesh::Mesh,
                params: Vec<$crate::bindings::meshflow::geometry::types::Param>,
            ) -> Result<$crate::bindings::meshflow::geometry::types::Outcome, String> {
                $crate::run(&$services(), &name, $crate::Mesh::new(target), params)
            }
        }

        #[cfg(target_arch = "wasm32")]
        impl $crate::bindings::exports::meshflow::geometry::locality::Guest for MeshflowPlugin {
            fn reach(
                name: String,
                params: Vec<$crate::bindings::meshflow::geometry::types::Param>,
            ) -> Option<u32> {
                $crate::reach(&$services(), &name, params)
            }
        }

        #[cfg(target_arch = "wasm32")]
        impl $crate::bindings::exports::meshflow::geometry::blocks::Guest for MeshflowPlugin {
            fn block_triangles(
                name: String,
                params: Vec<$crate::bindings::meshflow::geometry::types::Param>,
            ) -> Option<u32> {
                $crate::block_triangles(&$services(), &name, params)
            }
        }

        #[cfg(target_arch = "wasm32")]
        $crate::bindings::export_component!(MeshflowPlugin with_types_in $crate::bindings);
    };
}

#[doc(hidden)]
pub mod __private {
    pub use wit_bindgen;
}
