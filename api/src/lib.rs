//! The wire: the bodies of the host HTTP API ([`host`]) and of the engine HTTP API
//! ([`engine`], the run record included) as the project's own serde types, and the typed
//! clients of both: [`HostClient`] (the engine and the CLI call hosts with it) and
//! [`EngineClient`] (the CLI), with the rules of what a server fetches ([`fetch_rules`]) and,
//! with the `server` feature, what both servers share ([`server`]). Service descriptions and values come from `meshflow-params`
//! and travel as plain JSON; `docs/api.md` shows every route.
//!
//! This crate must not depend on wasmtime, the mesh store or the codecs: the engine links
//! it, and the engine runs no plugins.

pub mod engine;
mod engine_client;
pub mod fetch_rules;
pub mod host;
mod host_client;
pub mod raw_mesh;
#[cfg(feature = "server")]
pub mod server;
pub mod tls;
mod transport;

pub use engine_client::EngineClient;
pub use host_client::{ClusterAccess, HostClient};
pub use meshflow_params as params;
pub use transport::{
    CONNECT_TIMEOUT, ClientError, LONG_POLL_TIMEOUT, MAX_ERROR_BODY_BYTES, MAX_REDIRECTS,
    QUERY_TIMEOUT, WORK_TIMEOUT, accepts_zstd, fetch_compressible, fetch_response,
};
