//! The mesh model every host shares: [`MeshData`] (a compact indexed triangle set) with its
//! canonical [`ContentHash`], and the recording [`store`] through which every edit passes
//! and is logged as an [`store::Op`] — the vocabulary corrections are made of — and the
//! WIT `mesh` interface's checked [`calls`] on that store, which the runtime and the SDK's
//! native runs both wrap; and the [`partition`]s a mesh too large for one sandbox is cut into.
//!
//! This crate must not depend on file formats, codecs, wasmtime or HTTP: everything else
//! builds on it.

pub mod attributes;
pub mod calls;
mod data;
pub mod partition;
pub mod store;

pub use data::{ContentHash, MeshData, as_le_bytes_f32, as_le_bytes_u32};
