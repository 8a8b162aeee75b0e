//! The wire: the bodies of the host HTTP API ([`host`]) as the project's own serde types,
//! and [`HostClient`], the typed client the engine and the CLI call hosts with. Service
//! descriptions and values come from `meshflow-params` and travel as plain JSON.
//!
//! This crate must not depend on wasmtime, the mesh store or the codecs: the engine links
//! it, and the engine runs no plugins.

pub mod host;
mod host_client;

pub use host_client::{ClientError, HostClient, fetch};
pub use meshflow_params as params;
