//! The meshflow host as a library: the recording mesh store, mesh IO and the sandboxed
//! plugin runtime.

#[cfg(feature = "server")]
pub mod api;
pub mod catalog;
#[cfg(feature = "server")]
pub mod client;
pub mod correction;
pub mod generate;
pub mod io;
pub mod mesh;
pub mod pack;
pub mod quantize;
pub mod runtime;
#[cfg(feature = "server")]
pub mod server;
pub mod store;

pub use catalog::Catalog;
pub use mesh::{ContentHash, MeshData};
pub use runtime::Runtime;
