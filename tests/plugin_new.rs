//! `meshflow plugin new`: the Rust and the C++ project it writes into an empty folder build
//! with one command each and run with `meshflow apply --plugin`; and `--plugin` says when a
//! local service hides a built-in.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use common::process::meshflow_in;

fn ok_in(dir: &Path, args: &[&str]) -> Output {
    let out = meshflow_in(dir, args);
    assert!(
        out.status.success(),
        "meshflow {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn bunny() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj").display().to_string()
}

fn stdout(out: &Output) -> String {
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn files_under(dir: &Path) -> Vec<PathBuf> {
    fn walk(root: &Path, dir: &Path, found: &mut Vec<PathBuf>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, found);
            } else {
                found.push(path.strip_prefix(root).unwrap().to_owned());
            }
        }
    }
    let mut found = Vec::new();
    walk(dir, dir, &mut found);
    found.sort();
    found
}

#[test]
fn a_new_rust_plugin_builds_with_one_command_and_runs() {
    let scratch = tempfile::tempdir().unwrap();
    let sdk = Path::new(env!("CARGO_MANIFEST_DIR")).join("sdk");
    let sdk = sdk.to_str().unwrap();
    let written =
        ok_in(scratch.path(), &["plugin", "new", "my-tools", "--lang", "rust", "--sdk-path", sdk]);
    assert!(stdout(&written).contains("cargo build --release --target wasm32-wasip2"));
    let project = scratch.path().join("my-tools");
    let manifest = std::fs::read_to_string(project.join("Cargo.toml")).unwrap();
    assert!(manifest.contains("name = \"my-tools\"") && !manifest.contains("[patch"), "{manifest}");
    assert!(manifest.contains(&format!("path = {sdk:?}")), "{manifest}");
    // Not over a folder that holds something.
    let again = meshflow_in(scratch.path(), &["plugin", "new", "my-tools", "--lang", "rust"]);
    assert!(String::from_utf8_lossy(&again.stderr).contains("not empty"));

    // The one command (offline: the lock pins what the workspace already fetched), its
    // target folder shared with the README walkthrough's build in tests/cli.rs.
    let target_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plugin-template");
    let status = Command::new(env!("CARGO"))
        .current_dir(&project)
        .args(["build", "--release", "--offline", "--target", "wasm32-wasip2"])
        .env("CARGO_TARGET_DIR", &target_dir)
        .status()
        .expect("running cargo");
    assert!(status.success(), "building the new Rust project failed");
    let wasm = target_dir.join("wasm32-wasip2/release/my_tools.wasm").display().to_string();

    let big = scratch.path().join("big.ply").display().to_string();
    let applied = ok_in(
        scratch.path(),
        &[
            "apply",
            "scale-about-centroid",
            &bunny(),
            "-o",
            &big,
            "--param",
            "factor=3",
            "--plugin",
            &wasm,
        ],
    );
    assert!(applied.stderr.is_empty(), "{}", String::from_utf8_lossy(&applied.stderr));
    let area = |mesh: &str| -> f64 {
        let out = ok_in(scratch.path(), &["check", "total-area", mesh, "--plugin", &wasm]);
        stdout(&out).trim().parse().unwrap()
    };
    let ratio = area(&big) / area(&bunny());
    assert!((ratio - 9.0).abs() < 1e-3, "area grew by {ratio}, not 9");
}

#[test]
fn a_new_cpp_plugin_builds_with_make_alone_and_runs() {
    let scratch = tempfile::tempdir().unwrap();
    ok_in(scratch.path(), &["plugin", "new", "smoother", "--lang", "cpp", "--dir", "cpp"]);
    let project = scratch.path().join("cpp");
    let files: Vec<String> =
        files_under(&project).iter().map(|p| p.display().to_string()).collect();
    assert!(files.contains(&"meshflow-sdk/include/meshflow.hpp".to_owned()), "{files:?}");
    assert!(files.contains(&"meshflow-sdk/generated/plugin_component_type.o".to_owned()));
    // The SDK in the project is the checkout's, byte for byte.
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    for (ours, theirs) in [
        ("meshflow-sdk/include/meshflow.hpp", "sdk/cpp/include/meshflow.hpp"),
        ("meshflow-sdk/generated/plugin.c", "sdk/cpp/generated/plugin.c"),
        (
            "meshflow-sdk/generated/plugin_component_type.o",
            "sdk/cpp/generated/plugin_component_type.o",
        ),
    ] {
        assert_eq!(
            std::fs::read(project.join(ours)).unwrap(),
            std::fs::read(root.join(theirs)).unwrap()
        );
    }

    // `make`, with the meshflow binary named as a user whose meshflow is not on PATH would.
    let made = Command::new("make")
        .current_dir(&project)
        .arg(format!("MESHFLOW={}", env!("CARGO_BIN_EXE_meshflow")))
        .env("MESHFLOW_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("components"))
        .output()
        .expect("running make (scripts/test.sh installs clang-19 and wasi-libc)");
    assert!(
        made.status.success(),
        "make failed:\n{}{}",
        String::from_utf8_lossy(&made.stdout),
        String::from_utf8_lossy(&made.stderr)
    );
    let wasm = project.join("build/smoother.wasm").display().to_string();
    let smooth = scratch.path().join("smooth.ply").display().to_string();
    let applied = ok_in(
        scratch.path(),
        &[
            "apply",
            "taubin-smoothing-cpp",
            &bunny(),
            "-o",
            &smooth,
            "--param",
            "iterations=5",
            "--plugin",
            &wasm,
        ],
    );
    assert!(applied.stderr.is_empty(), "{}", String::from_utf8_lossy(&applied.stderr));
    let hash = |mesh: &str| stdout(&ok_in(scratch.path(), &["hash", mesh]));
    assert_ne!(hash(&smooth), hash(&bunny()), "the C++ plugin moved nothing");
}

#[test]
fn new_refuses_a_bad_name_and_sdk_flags_for_cpp() {
    let scratch = tempfile::tempdir().unwrap();
    for name in ["My-Tools", "9lives", "tools-", "a_b"] {
        let out = meshflow_in(scratch.path(), &["plugin", "new", name, "--lang", "cpp"]);
        assert!(!out.status.success(), "{name} was taken");
        assert!(String::from_utf8_lossy(&out.stderr).contains("not a plugin name"));
    }
    let out =
        meshflow_in(scratch.path(), &["plugin", "new", "x", "--lang", "cpp", "--sdk-git", "u"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("for Rust projects"));
    let out =
        meshflow_in(scratch.path(), &["plugin", "new", "x", "--lang", "rust", "--sdk-path", "."]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("not the SDK crate"));
    assert!(files_under(scratch.path()).is_empty(), "a refused project left files");
}

#[test]
fn a_local_plugin_that_hides_a_built_in_service_says_so_on_one_line() {
    let scratch = tempfile::tempdir().unwrap();
    let v2 = scratch.path().join("v2.wasm");
    std::fs::write(&v2, meshflow_builtin_plugins::fixture("smoothing-v2")).unwrap();
    let v2 = v2.display().to_string();
    let out = scratch.path().join("out.ply").display().to_string();
    let applied = ok_in(
        scratch.path(),
        &["apply", "laplacian-smoothing", &bunny(), "-o", &out, "--plugin", &v2],
    );
    let stderr = String::from_utf8_lossy(&applied.stderr);
    let lines: Vec<&str> = stderr.lines().filter(|l| l.contains("laplacian-smoothing")).collect();
    assert_eq!(lines.len(), 1, "{stderr}");
    assert!(lines[0].contains("shadows the built-in") && lines[0].contains(&v2), "{stderr}");
    // Without a clash, nothing.
    let quiet = ok_in(scratch.path(), &["services"]);
    assert!(quiet.stderr.is_empty());
}
