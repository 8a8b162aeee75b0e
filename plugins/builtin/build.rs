//! Builds the in-house plugins for wasm32-wasip2 and writes a table embedding their bytes,
//! as wasmtime's test-programs-artifacts crate does, so `cargo build` alone yields a
//! `meshflow` that knows them.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Plugin crates under `plugins/`, each built as one component.
const PLUGINS: &[&str] = &["smoothing", "checks"];
const TARGET: &str = "wasm32-wasip2";
const PROFILE: &str = "plugin";

fn main() {
    let manifest_dir = PathBuf::from(env("CARGO_MANIFEST_DIR"));
    let root = manifest_dir.join("../..").canonicalize().expect("workspace root");
    let out_dir = PathBuf::from(env("OUT_DIR"));
    let target_dir = out_dir.join("wasm");

    for watched in ["wit", "sdk/src", "sdk/Cargo.toml"] {
        println!("cargo:rerun-if-changed={}", root.join(watched).display());
    }
    for plugin in PLUGINS {
        println!("cargo:rerun-if-changed={}", root.join("plugins").join(plugin).display());
    }

    let mut cargo = Command::new(env("CARGO"));
    cargo
        .current_dir(&root)
        .args(["build", "--target", TARGET, "--profile", PROFILE, "--target-dir"])
        .arg(&target_dir);
    for plugin in PLUGINS {
        cargo.args(["-p", &format!("meshflow-plugin-{plugin}")]);
    }
    // Flags meant for the host build must not leak into the guest build.
    for var in ["CARGO_ENCODED_RUSTFLAGS", "RUSTFLAGS", "CARGO_TARGET_DIR", "CARGO_BUILD_TARGET"] {
        cargo.env_remove(var);
    }
    let status = cargo.status().expect("running cargo for the plugins");
    assert!(
        status.success(),
        "building the plugins failed; is the target installed? `rustup target add {TARGET}`"
    );

    let mut table = String::from("&[\n");
    for plugin in PLUGINS {
        let wasm = wasm_path(&target_dir, plugin);
        assert!(wasm.exists(), "{} was not built", wasm.display());
        table.push_str(&format!(
            "    BuiltinPlugin {{ name: {plugin:?}, wasm: include_bytes!({:?}) }},\n",
            wasm.display().to_string()
        ));
    }
    table.push(']');
    std::fs::write(out_dir.join("plugins.rs"), table).expect("writing the plugin table");
}

fn wasm_path(target_dir: &Path, plugin: &str) -> PathBuf {
    let file = format!("meshflow_plugin_{}.wasm", plugin.replace('-', "_"));
    target_dir.join(TARGET).join(PROFILE).join(file)
}

fn env(name: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| panic!("cargo sets {name} for build scripts"))
}
