//! The C/C++ SDK's native backend: `libmeshflow_native.so`, against which `make test` links
//! a C++ plugin's services to run them in process, as the Rust SDK's `native` feature does.
//!
//! It implements, for the host's CPU, every function the generated bindings
//! (`sdk/cpp/generated/plugin.h`) declare except those a plugin exports: the 42 calls of
//! the WIT `mesh` resource, each a call of the host's own checked adapter
//! ([`meshflow_mesh::calls::MeshCalls`] over a [`meshflow_mesh::calls::Recorder`]), so every
//! edit is checked and recorded exactly as a host does it; and the bindings' free and
//! string helpers, allocating with the C library's `malloc` as the canonical ABI does in a
//! guest. The same header (`meshflow.hpp`) thus compiles for both backends unchanged.
//!
//! On top, a small API of its own (`sdk/cpp/include/meshflow_native.h`, [`run`]): load and
//! save mesh files with the host's readers and writers (`meshflow-meshio`), and run a
//! service through the plugin's exported `describe` and `run` as a host does — parameters
//! resolved by the host's rules (`meshflow-params`), a check on a read-only mesh, the
//! check's value checked against its declared type, the result compacted as a host compacts
//! it, with its content hash and edit count.
//!
//! Where a host would trap (an unknown mesh handle, a null pointer where the canonical ABI
//! has memory), the process aborts with a message: a test of a plugin must not go on after
//! what a host would call a crash. No panic crosses the C boundary: each entry point catches
//! it, and aborts or returns it as an error where the function has an error channel.
//!
//! Layers stay one way: this crate uses the store, the readers and the parameter rules,
//! none of which knows the SDK, the WIT or wasmtime.

mod abi;
mod calls;
mod free;
mod run;

#[cfg(test)]
mod tests;
