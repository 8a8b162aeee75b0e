//! How meshes and their edits travel between hosts: [`correction`] (`.mfc`, a step's op
//! log, entropy coded and replayed through the store), [`replay`] (`.mfr`, a step named by
//! plugin, service and parameters, for a host to re-run), [`pack`] (`.mfm`, a whole mesh)
//! and [`quantize`] (the coordinate grids both detect and a workflow may snap to).
//!
//! This crate must not depend on the runtime, file formats or HTTP; it knows the mesh
//! model (`meshflow-mesh`) and the plain-array topology (`meshflow-topology`).

pub mod correction;
pub mod pack;
pub mod quantize;
pub mod replay;
