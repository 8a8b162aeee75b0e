//! Builds the in-house plugins (and, with the `test-fixtures` feature, the misbehaving test
//! plugins) for wasm32-wasip2 and writes tables embedding their bytes, as wasmtime's
//! test-programs-artifacts crate does, so `cargo build` alone yields a `meshflow` that
//! knows them.

use std::path::{Path, PathBuf};
use std::process::Command;

/// In-house plugin crates, under `plugins/`.
const PLUGINS: &[&str] = &["smoothing", "checks", "cleanup", "holes", "remeshing"];
/// Test fixture plugin crates, under `tests/plugins/`.
const FIXTURES: &[&str] = &["hostile", "bad-describe", "smoothing-v2"];
const TARGET: &str = "wasm32-wasip2";
const PROFILE: &str = "plugin";

fn main() {
    let root = PathBuf::from(env("CARGO_MANIFEST_DIR")).join("../..").canonicalize().unwrap();
    let out_dir = PathBuf::from(env("OUT_DIR"));
    let target_dir = out_dir.join("wasm");
    let with_fixtures = std::env::var_os("CARGO_FEATURE_TEST_FIXTURES").is_some();

    let plugins: Vec<(&str, PathBuf)> =
        PLUGINS.iter().map(|p| (*p, root.join("plugins").join(p))).collect();
    let fixtures: Vec<(&str, PathBuf)> = if with_fixtures {
        FIXTURES.iter().map(|p| (*p, root.join("tests/plugins").join(p))).collect()
    } else {
        Vec::new()
    };

    for watched in ["wit", "sdk/src", "sdk/Cargo.toml", "sdk/topology", ".cargo/config.toml"] {
        println!("cargo:rerun-if-changed={}", root.join(watched).display());
    }
    for (_, dir) in plugins.iter().chain(&fixtures) {
        println!("cargo:rerun-if-changed={}", dir.display());
    }

    build(&root, &target_dir, plugins.iter().chain(&fixtures).map(|(name, _)| *name));
    write_table(&out_dir.join("plugins.rs"), &target_dir, &plugins);
    write_table(&out_dir.join("fixtures.rs"), &target_dir, &fixtures);
}

fn build<'a>(root: &Path, target_dir: &Path, names: impl Iterator<Item = &'a str>) {
    let mut cargo = Command::new(env("CARGO"));
    cargo
        .current_dir(root)
        .args(["build", "--target", TARGET, "--profile", PROFILE, "--target-dir"])
        .arg(target_dir);
    for name in names {
        cargo.args(["-p", &format!("meshflow-plugin-{name}")]);
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
}

fn write_table(path: &Path, target_dir: &Path, plugins: &[(&str, PathBuf)]) {
    let mut table = String::from("&[\n");
    for (name, _) in plugins {
        let file = format!("meshflow_plugin_{}.wasm", name.replace('-', "_"));
        let wasm = target_dir.join(TARGET).join(PROFILE).join(file);
        assert!(wasm.exists(), "{} was not built", wasm.display());
        table.push_str(&format!(
            "    BuiltinPlugin {{ name: {name:?}, wasm: include_bytes!({:?}) }},\n",
            wasm.display().to_string()
        ));
    }
    table.push(']');
    std::fs::write(path, table).expect("writing a plugin table");
}

fn env(name: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| panic!("cargo sets {name} for build scripts"))
}
