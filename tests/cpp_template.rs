//! The C++ plugin template (`examples/plugin-template-cpp`), built from the checkout with
//! Debian's clang and componentized by `meshflow plugin componentize`: its Taubin smoothing
//! matches the Rust built-in, it runs on a host in a workflow with the built-ins, and
//! componentize refuses what is not a meshflow core module, saying why.

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::sync::OnceLock;

use common::{Cluster, Input, builtin, components_cache};
use meshflow_mesh::MeshData;
use meshflow_runtime::{Limits, Plugin, RunOutput, Runtime, Value};
use serde_json::json;

const CPP_SERVICE: &str = "taubin-smoothing-cpp";

fn meshflow(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(args)
        .env("MESHFLOW_CACHE_DIR", components_cache())
        .output()
        .expect("running meshflow")
}

/// The template's component, built once per test run from a clean build folder.
fn cpp_plugin() -> &'static [u8] {
    static PLUGIN: OnceLock<Vec<u8>> = OnceLock::new();
    PLUGIN.get_or_init(|| {
        let build = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plugin-template-cpp");
        let _ = std::fs::remove_dir_all(&build);
        let template = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/plugin-template-cpp");
        let out = Command::new("make")
            .current_dir(template)
            .arg(format!("BUILD={}", build.display()))
            .arg(format!("MESHFLOW={}", env!("CARGO_BIN_EXE_meshflow")))
            .env("MESHFLOW_CACHE_DIR", components_cache())
            .output()
            .expect("running make: scripts/test.sh installs it with clang-19 and wasi-libc");
        assert!(
            out.status.success(),
            "building the C++ template failed (scripts/test.sh installs clang-19, lld-19, \
             wasi-libc, libc++-19-dev-wasm32, libclang-rt-19-dev-wasm32):\n{}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        );
        std::fs::read(build.join("taubin.wasm")).unwrap()
    })
}

fn taubin_params() -> Vec<(String, Value)> {
    vec![
        ("lambda".into(), Value::Real(0.5)),
        ("mu".into(), Value::Real(-0.53)),
        ("iterations".into(), Value::Integer(10)),
    ]
}

fn smoothed(runtime: &Runtime, plugin: &Plugin, service: &str, mesh: &MeshData) -> MeshData {
    let out = runtime.run(plugin, service, mesh.clone(), &taubin_params()).expect(service);
    out.mesh.expect("a filter returns its mesh")
}

#[test]
fn the_cpp_taubin_matches_the_rust_one_on_the_bunny_and_a_raw_scan() {
    let runtime = Runtime::new(Limits::default(), Some(components_cache().as_path())).unwrap();
    let cpp = runtime.load(cpp_plugin()).expect("the C++ plugin loads as an upload would");
    let rust = runtime.load(builtin("smoothing")).unwrap();
    let info = cpp.service(CPP_SERVICE).expect("the template's service");
    let names: Vec<&str> = info.params.iter().map(|p| p.name.as_str()).collect();
    assert_eq!(names, ["lambda", "mu", "iterations"]);

    // The bunny, and a scan with holes, debris, non-manifold spots and unreferenced vertices.
    for input in [Input::bunny(), Input::scan(20_000, 5)] {
        let from_cpp = smoothed(&runtime, &cpp, CPP_SERVICE, &input.mesh);
        let from_rust = smoothed(&runtime, &rust, "taubin-smoothing", &input.mesh);
        assert_eq!(from_cpp.triangles, from_rust.triangles);
        assert_ne!(from_rust.positions, input.mesh.positions, "Taubin moved nothing");
        let largest = from_cpp
            .positions
            .iter()
            .zip(&from_rust.positions)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(largest <= 1e-6, "{}: the two differ by up to {largest}", input.name);
    }
}

#[test]
fn the_cpp_taubin_declares_its_reach_and_runs_on_partitions_to_its_whole_hash() {
    let input = Input::scan(20_000, 5);
    let params = [("iterations".to_owned(), Value::Integer(2))];
    let run = |limits: Limits| {
        let runtime = Runtime::new(limits, Some(components_cache().as_path())).unwrap();
        let cpp = runtime.load(cpp_plugin()).unwrap();
        runtime.run(&cpp, CPP_SERVICE, input.mesh.clone(), &params).expect(CPP_SERVICE)
    };
    let whole = run(Limits::default());
    assert_eq!(whole.partitions, None);
    let cut =
        Limits { max_partition_triangles: Some(4_000), concurrent_runs: 2, ..Limits::default() };
    let parts = run(cut);
    let partitions = parts.partitions.expect("the C++ service declared its reach");
    assert!(partitions.count >= 5 && partitions.rings == 4, "{partitions:?}");
    let hash = |out: &RunOutput| out.mesh.as_ref().unwrap().content_hash();
    assert_eq!(hash(&parts), hash(&whole));
    assert_ne!(hash(&whole), input.mesh.content_hash());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_cpp_plugin_runs_in_a_workflow_with_the_built_ins() {
    let cluster = Cluster::start(&[&["smoothing", "checks"], &["checks"]]).await;
    let cpp_host = cluster.hosts[1].url.clone();
    let file = Path::new(env!("CARGO_TARGET_TMPDIR")).join("taubin-upload.wasm");
    std::fs::write(&file, cpp_plugin()).unwrap();

    // Uploaded with the CLI whose reader has gone (`| head`): no panic, the upload done.
    let mut upload = Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(["plugin", "upload", "--host", &cpp_host, file.to_str().unwrap()])
        .env("MESHFLOW_UPLOAD_TOKEN", common::TOKEN)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(upload.stdout.take());
    let upload = upload.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&upload.stderr);
    assert!(upload.status.success() && !stderr.contains("panicked"), "{stderr}");

    let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs(20);
    while !cluster.services().await.to_string().contains(CPP_SERVICE) {
        assert!(tokio::time::Instant::now() < deadline, "the engine never listed {CPP_SERVICE}");
        tokio::time::sleep(std::time::Duration::from_millis(100)).await;
    }

    let input = Input::bunny();
    let url = cluster.upload(&input).await;
    let params = json!({"lambda": 0.5, "mu": -0.53, "iterations": 10});
    let workflow = json!({"steps": [
        {"run": "add-noise", "params": {"amount": 0.5, "seed": 3}},
        {"run": CPP_SERVICE, "params": params},
        {"if": {"check": "surface-area", "op": ">", "value": 0.0},
         "then": [{"run": "laplacian-smoothing"}]},
    ]});
    let record = cluster.run(&workflow, &url).await;
    assert_eq!(record["status"], "completed", "{record:#}");
    let steps = common::steps(&record);
    let cpp_step = steps.iter().find(|s| s["service"] == CPP_SERVICE).expect("the C++ step");
    assert_eq!(cpp_step["host"], cpp_host.as_str());
    assert_eq!(cpp_step["plugin"].as_str().unwrap(), meshflow_runtime::digest(cpp_plugin()));
    let last = steps.last().unwrap();
    assert_eq!(last["service"], "laplacian-smoothing");
    assert_ne!(last["host"], cpp_host.as_str(), "the built-in runs on the other host");

    // The same chain in one local runtime gives the same mesh, bit for bit.
    let runtime = Runtime::new(Limits::default(), Some(components_cache().as_path())).unwrap();
    let (cpp, rust) =
        (runtime.load(cpp_plugin()).unwrap(), runtime.load(builtin("smoothing")).unwrap());
    let noise = [("amount".to_owned(), Value::Real(0.5)), ("seed".to_owned(), Value::Integer(3))];
    let noised = runtime.run(&rust, "add-noise", input.mesh, &noise).unwrap().mesh.unwrap();
    let smoothed = smoothed(&runtime, &cpp, CPP_SERVICE, &noised);
    let last = runtime.run(&rust, "laplacian-smoothing", smoothed, &[]).unwrap().mesh.unwrap();
    assert_eq!(record["result"]["hash"], last.content_hash().to_hex());
}

#[test]
fn componentize_refuses_what_is_not_a_meshflow_core_module() {
    let dir = tempfile::tempdir().unwrap();
    let refused = |name: &str, bytes: &[u8]| -> String {
        let path = dir.path().join(name);
        std::fs::write(&path, bytes).unwrap();
        let out_path = dir.path().join("out.wasm");
        let out = meshflow(&[
            "plugin",
            "componentize",
            path.to_str().unwrap(),
            "-o",
            out_path.to_str().unwrap(),
        ]);
        assert!(!out.status.success(), "{name} was componentized");
        assert!(!out_path.exists(), "{name} left an output");
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    assert!(refused("component.wasm", builtin("checks")).contains("already a component"));
    assert!(refused("notes.txt", b"hello").contains("not a WebAssembly file"));
    let bare = refused("bare.wasm", b"\0asm\x01\0\0\0");
    assert!(
        bare.contains("no component type") && bare.contains("plugin_component_type.o"),
        "{bare}"
    );

    // A core module whose bindings were made for another world.
    let mut resolve = wit_parser::Resolve::default();
    let package = resolve
        .push_str("other.wit", "package other:thing@1.0.0; world plugin { export run: func(); }")
        .unwrap();
    let world = resolve.select_world(&[package], Some("plugin")).unwrap();
    let mut other = b"\0asm\x01\0\0\0".to_vec();
    wit_component::embed_component_metadata(
        &mut other,
        &resolve,
        world,
        wit_component::StringEncoding::UTF8,
    )
    .unwrap();
    let wrong = refused("other-world.wasm", &other);
    assert!(wrong.contains("exports [run], not meshflow:geometry/service@0.1.0"), "{wrong}");

    // And the template's own core module goes through.
    let core = Path::new(env!("CARGO_TARGET_TMPDIR")).join("plugin-template-cpp/taubin-core.wasm");
    cpp_plugin();
    let out_path = dir.path().join("taubin.wasm");
    let out = meshflow(&[
        "plugin",
        "componentize",
        core.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success() && stdout.contains(CPP_SERVICE), "{stdout}");
}
