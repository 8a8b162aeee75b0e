//! The sandbox against misbehaving plugins: every failure is a clear, typed error within
//! the limits, and the runtime keeps working afterwards.

mod common;

use common::builtin;

use std::time::{Duration, Instant};

use meshflow_builtin_plugins::{PLUGINS, fixture};
use meshflow_mesh::MeshData;
use meshflow_mesh::store::{MeshStore, Op};
use meshflow_runtime::{Limits, PluginError, RunError, Runtime, Value};

/// A small closed mesh: an octahedron.
fn octahedron() -> MeshData {
    MeshData::new(
        vec![
            1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0,
            -1.0,
        ],
        vec![0, 2, 4, 2, 1, 4, 1, 3, 4, 3, 0, 4, 2, 0, 5, 1, 2, 5, 3, 1, 5, 0, 3, 5],
    )
}

fn runtime_with(limits: Limits) -> Runtime {
    Runtime::new(limits, None).expect("a runtime")
}

fn quick_limits() -> Limits {
    Limits { deadline: Duration::from_secs(2), memory_bytes: 256 << 20, ..Limits::default() }
}

/// The sandbox is usable after a failure: a real service runs and gives the right answer.
fn assert_still_works(runtime: &Runtime) {
    let checks = builtin(runtime, "checks");
    let out = runtime.run(&checks, "vertex-count", octahedron(), &[]).expect("a normal run");
    assert_eq!(out.value, Some(Value::Integer(6)));
}

fn run_hostile(runtime: &Runtime, service: &str) -> RunError {
    let hostile = runtime.load(fixture("hostile")).expect("the hostile fixture loads");
    let started = Instant::now();
    let error = runtime.run(&hostile, service, octahedron(), &[]).expect_err(service);
    assert!(started.elapsed() < Duration::from_secs(20), "{service} was not stopped in time");
    error
}

#[test]
fn an_infinite_loop_stops_at_the_deadline() {
    let runtime = runtime_with(Limits { deadline: Duration::from_millis(300), ..quick_limits() });
    let started = Instant::now();
    let error = run_hostile(&runtime, "loop-forever");
    assert!(matches!(error, RunError::Deadline { .. }), "{error}");
    assert!(started.elapsed() < Duration::from_secs(5));
    assert!(error.to_string().contains("loop-forever"), "{error}");
    assert_still_works(&runtime);
}

#[test]
fn fuel_stops_a_loop_when_enabled() {
    let runtime = runtime_with(Limits { fuel: Some(50_000_000), ..quick_limits() });
    let error = run_hostile(&runtime, "loop-forever");
    assert!(matches!(error, RunError::Fuel { .. }), "{error}");
    assert_still_works(&runtime);
}

#[test]
fn a_memory_bomb_stops_at_the_memory_limit() {
    let runtime = runtime_with(quick_limits());
    let error = run_hostile(&runtime, "allocate-forever");
    assert!(matches!(error, RunError::Memory { limit_mib: 256, .. }), "{error}");
    assert_still_works(&runtime);
}

#[test]
fn a_trap_and_a_panic_are_reported_with_the_panic_message() {
    let runtime = runtime_with(quick_limits());
    let error = run_hostile(&runtime, "trap");
    assert!(matches!(error, RunError::Trap { .. }), "{error}");
    let text = run_hostile(&runtime, "panic").to_string();
    // The panic's message first, the stack after it, and no advice the sandbox forbids.
    let said = text.find("panics on purpose").expect(&text);
    let stack = text.find("wasm stack:").expect(&text);
    assert!(said < stack && said < 300, "{text}");
    assert!(!text.contains("RUST_BACKTRACE"), "{text}");
    assert_still_works(&runtime);
}

#[test]
fn a_core_module_or_a_non_wasm_file_is_refused_saying_what_to_build() {
    let runtime = runtime_with(quick_limits());
    // The smallest core module: what `--target wasm32-unknown-unknown` or wasip1 produces.
    let error = runtime.load(b"\0asm\x01\0\0\0").unwrap_err();
    assert!(matches!(error, PluginError::CoreModule), "{error}");
    let text = error.to_string();
    assert!(
        text.contains("--target wasm32-wasip2") && text.contains("plugin componentize"),
        "{text}"
    );
    // An rlib (what a crate without `crate-type = ["cdylib"]` leaves behind).
    let error = runtime.load(b"!<arch>\n/               0").unwrap_err();
    assert!(matches!(error, PluginError::NotWasm), "{error}");
}

#[test]
fn an_invalid_edit_is_refused_with_the_reason() {
    let runtime = runtime_with(quick_limits());
    let error = run_hostile(&runtime, "bad-edit");
    let text = error.to_string();
    assert!(matches!(error, RunError::Failed { .. }), "{text}");
    assert!(text.contains("vertex 4000000000") && text.contains("does not exist"), "{text}");
    assert_still_works(&runtime);
}

#[test]
fn refused_edits_leave_no_trace_in_the_mesh_or_the_log() {
    let runtime = runtime_with(quick_limits());
    let hostile = runtime.load(fixture("hostile")).unwrap();
    let out = runtime.run(&hostile, "ignore-bad-edits", octahedron(), &[]).expect("runs");
    assert_eq!(out.report, "every invalid edit was refused");
    assert_eq!(out.log, vec![Op::FlipTriangles { ids: vec![0] }]);
    let mut expected = octahedron();
    expected.triangles.swap(1, 2);
    assert_eq!(out.mesh.unwrap(), expected);
}

#[test]
fn non_finite_coordinates_are_refused_in_every_edit_from_the_sandbox() {
    let runtime = runtime_with(quick_limits());
    let hostile = runtime.load(fixture("hostile")).unwrap();
    let out = runtime.run(&hostile, "non-finite-edits", octahedron(), &[]).expect("runs");
    assert_eq!(out.report, "every non-finite coordinate was refused");
    assert!(out.log.is_empty(), "{:?}", out.log);
    assert_eq!(out.mesh.unwrap(), octahedron());
}

#[test]
fn endless_edits_stop_at_the_edit_budget() {
    let runtime = runtime_with(Limits { deadline: Duration::from_secs(30), ..quick_limits() });
    let error = run_hostile(&runtime, "edit-forever");
    assert!(matches!(error, RunError::EditBudget { .. }), "{error}");
    assert_still_works(&runtime);
}

#[test]
fn endless_output_stops_at_the_capture_limit() {
    let runtime = runtime_with(quick_limits());
    let error = run_hostile(&runtime, "print-forever");
    assert!(matches!(error, RunError::Output { .. }), "{error}");
    assert_still_works(&runtime);
}

#[test]
fn a_check_cannot_edit() {
    let runtime = runtime_with(quick_limits());
    let error = run_hostile(&runtime, "edit-in-check");
    assert!(error.to_string().contains("a check may not edit"), "{error}");
}

#[test]
fn a_check_returning_the_wrong_type_is_refused() {
    let runtime = runtime_with(quick_limits());
    let error = run_hostile(&runtime, "wrong-result-type");
    assert!(matches!(error, RunError::BadResult { .. }), "{error}");
    assert!(error.to_string().contains("expected an integer"), "{error}");
}

#[test]
fn a_service_error_is_passed_on() {
    let runtime = runtime_with(quick_limits());
    let error = run_hostile(&runtime, "fail");
    assert_eq!(error.to_string(), "fail: the input is not what this service wants");
}

#[test]
fn unknown_services_and_bad_parameters_list_what_is_accepted() {
    let runtime = runtime_with(quick_limits());
    let smoothing = builtin(&runtime, "smoothing");
    let error = runtime.run(&smoothing, "smooth", octahedron(), &[]).unwrap_err();
    assert!(error.to_string().contains("laplacian-smoothing"), "{error}");
    for (name, value, problem) in [
        ("iterations", Value::Integer(0), "out of range [1, 1000]"),
        ("iterations", Value::Text("many".into()), "`many` is not an integer"),
        ("iterations", Value::Real(2.5), "must be an integer"),
        ("speed", Value::Integer(1), "unknown parameter `speed`"),
    ] {
        let params = [(name.to_owned(), value)];
        let error = runtime.run(&smoothing, "laplacian-smoothing", octahedron(), &params);
        let text = error.unwrap_err().to_string();
        assert!(text.contains(problem), "{text}");
        assert!(text.contains("iterations (an integer, default 1, range [1, 1000])"), "{text}");
    }
}

#[test]
fn components_that_are_not_plugins_are_refused_at_load() {
    let runtime = runtime_with(quick_limits());
    let error = runtime.load(fixture("bad-describe")).unwrap_err();
    assert!(matches!(error, PluginError::Description(_)), "{error}");
    assert!(error.to_string().contains("`twin` is described twice"), "{error}");
    // Bytes that are not wasm, and core modules: `a_core_module_or_a_non_wasm_file_is_refused_saying_what_to_build`.
    // An empty component exports nothing of the plugin world.
    let error = runtime.load(b"\0asm\x0d\0\x01\0").unwrap_err();
    assert!(matches!(error, PluginError::World(_)), "{error}");
    assert_still_works(&runtime);
}

#[test]
fn every_edit_of_a_plugin_is_in_the_log() {
    let runtime = runtime_with(quick_limits());
    let smoothing = builtin(&runtime, "smoothing");
    let params = [
        ("iterations".to_owned(), Value::Integer(3)),
        ("keep-boundary".to_owned(), Value::Boolean(false)),
    ];
    let out = runtime.run(&smoothing, "laplacian-smoothing", octahedron(), &params).unwrap();
    let result = out.mesh.unwrap();
    assert_ne!(result.content_hash(), octahedron().content_hash(), "smoothing moved nothing");
    // Replaying the log alone reproduces the plugin's result bit for bit.
    let mut replay = MeshStore::new(octahedron());
    for op in out.log {
        replay.apply(op).unwrap();
    }
    assert_eq!(replay.finish().0, result);
}

#[test]
fn runs_are_deterministic_and_concurrent_runs_agree() {
    let runtime = runtime_with(quick_limits());
    let smoothing = builtin(&runtime, "smoothing");
    let params = [("keep-boundary".to_owned(), Value::Boolean(false))];
    let hashes: Vec<_> = std::thread::scope(|scope| {
        let handles: Vec<_> = (0..4)
            .map(|_| {
                scope.spawn(|| {
                    let out = runtime.run(&smoothing, "laplacian-smoothing", octahedron(), &params);
                    out.unwrap().mesh.unwrap().content_hash()
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    assert!(hashes.windows(2).all(|w| w[0] == w[1]));
}

#[test]
fn compiled_components_are_cached_on_disk_and_reused() {
    let dir = tempfile::tempdir().unwrap();
    let wasm = PLUGINS[0].wasm;
    let first = Runtime::new(quick_limits(), Some(dir.path())).unwrap().load(wasm).unwrap();
    let artefacts: Vec<_> =
        std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().path()).collect();
    assert_eq!(artefacts.len(), 1);
    assert!(artefacts[0].to_string_lossy().contains(&first.digest));
    // A later runtime loads from the artefact; a corrupt artefact is compiled again.
    let again = Runtime::new(quick_limits(), Some(dir.path())).unwrap();
    assert_eq!(again.load(wasm).unwrap().services.len(), first.services.len());
    std::fs::write(&artefacts[0], b"garbage").unwrap();
    let repaired = Runtime::new(quick_limits(), Some(dir.path())).unwrap();
    let plugin = repaired.load(wasm).unwrap();
    assert_eq!(plugin.digest, first.digest);
    assert_ne!(std::fs::read(&artefacts[0]).unwrap(), b"garbage");
}
