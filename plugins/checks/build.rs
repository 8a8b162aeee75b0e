//! The checks' component starts with a small linear memory rather than the 128 MiB other
//! plugins start with (`.cargo/config.toml`), and grows as a check needs.
//!
//! A host resets a pool slot's memory after every run by rewriting each resident page up to
//! the memory's size at the end of the run, whether or not the run wrote it (without
//! userfaultfd write-protection the kernel cannot tell). Once a slot has held a large run,
//! every later run on it pays for 128 MiB, about 8 ms: most of a check that reads a byte per
//! half-edge. Started small, a check pays only for the memory it grew to.

/// The checks' initial linear memory: enough for the runtime and small meshes.
const INITIAL_MEMORY_BYTES: u32 = 2 << 20;

fn main() {
    if std::env::var("CARGO_CFG_TARGET_ARCH").as_deref() == Ok("wasm32") {
        // After the target's flags on the linker's command line: the last one counts.
        println!("cargo:rustc-link-arg-cdylib=--initial-memory={INITIAL_MEMORY_BYTES}");
    }
    println!("cargo:rerun-if-changed=build.rs");
}
