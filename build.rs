//! Builds the C/C++ SDK's native test library (`sdk/cpp/native`, a cdylib for the machine
//! meshflow is built for), which `meshflow plugin new --lang cpp` writes into a project so
//! `make test` can run its services in process. A nested cargo build, as
//! plugins/builtin/build.rs builds the wasm plugins, into a target folder of its own: one
//! for every profile of this package, so a debug and a release meshflow share one build.

use std::path::{Path, PathBuf};
use std::process::Command;

const PACKAGE: &str = "meshflow-cpp-native";
const LIBRARY: &str = "meshflow_native";

fn main() {
    let root = PathBuf::from(env("CARGO_MANIFEST_DIR"));
    // What the library is made of; anything else changing need not rerun this.
    for watched in [
        "build.rs",
        "Cargo.lock",
        "sdk/cpp/native",
        "host/mesh/src",
        "host/mesh/Cargo.toml",
        "host/meshio/src",
        "host/meshio/Cargo.toml",
        "api/params/src",
        "api/params/Cargo.toml",
        "sdk/topology/src",
        "sdk/topology/Cargo.toml",
    ] {
        println!("cargo:rerun-if-changed={}", root.join(watched).display());
    }
    let target = env("TARGET");
    let target_dir = native_target_dir(&PathBuf::from(env("OUT_DIR")));
    let mut cargo = Command::new(env("CARGO"));
    cargo
        .current_dir(&root)
        .args(["build", "--release", "-p", PACKAGE, "--target", &target, "--target-dir"])
        .arg(&target_dir);
    // Flags meant for this build (coverage, sanitizers, another target dir) stay out.
    for var in ["CARGO_ENCODED_RUSTFLAGS", "RUSTFLAGS", "CARGO_TARGET_DIR", "CARGO_BUILD_TARGET"] {
        cargo.env_remove(var);
    }
    let status = cargo.status().expect("running cargo for the C++ SDK's native library");
    assert!(status.success(), "building {PACKAGE} (the C++ SDK's native test library) failed");

    let (prefix, suffix) = match env("CARGO_CFG_TARGET_OS").as_str() {
        "windows" => ("", ".dll"),
        "macos" | "ios" => ("lib", ".dylib"),
        _ => ("lib", ".so"),
    };
    let file = format!("{prefix}{LIBRARY}{suffix}");
    let library = target_dir.join(&target).join("release").join(&file);
    assert!(library.exists(), "{} was not built", library.display());
    println!("cargo:rustc-env=MESHFLOW_CPP_NATIVE_LIB={}", library.display());
    println!("cargo:rustc-env=MESHFLOW_CPP_NATIVE_FILE={file}");
}

/// `<target>/cpp-native` beside the profile folders (OUT_DIR is
/// `<target>[/<triple>]/<profile>/build/<package>-<hash>/out`), else inside OUT_DIR.
fn native_target_dir(out_dir: &Path) -> PathBuf {
    let build = out_dir.parent().and_then(Path::parent);
    match build.filter(|b| b.file_name().is_some_and(|n| n == "build")) {
        Some(build) => build.parent().and_then(Path::parent).unwrap_or(out_dir).join("cpp-native"),
        None => out_dir.join("cpp-native"),
    }
}

fn env(name: &str) -> String {
    std::env::var(name).unwrap_or_else(|_| panic!("cargo sets {name} for build scripts"))
}
