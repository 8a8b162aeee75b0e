//! The meshflow host as a library: the recording mesh store, mesh IO and the sandboxed
//! plugin runtime.

pub mod catalog;
pub mod correction;
pub mod generate;
pub mod io;
pub mod mesh;
pub mod pack;
pub mod runtime;
pub mod store;

pub use catalog::Catalog;
pub use mesh::{ContentHash, MeshData};
pub use runtime::Runtime;
