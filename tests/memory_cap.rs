//! The guest's memory cap is the operator's choice (`--memory-cap MIB`, issue 33): a run
//! past it is refused naming the cap and the flag, the same run passes under a cap just
//! large enough, and caps the sandbox cannot give are refused before anything starts.

mod common;

use std::path::Path;

use common::process::{failure, meshflow, ok};
use meshflow_builtin_plugins::fixture;
use meshflow_mesh::MeshData;
use meshflow_runtime::{Limits, MAX_MEMORY_BYTES, MIB, MemoryCapError, PluginError, RunError};
use meshflow_runtime::{Runtime, memory_cap_bytes};

/// The in-house plugins start with 128 MiB of linear memory (`.cargo/config.toml`).
const INITIAL_GUEST_BYTES: u64 = 128 << 20;

#[test]
fn a_run_past_the_cap_is_refused_naming_the_cap_and_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let (scan, out) = (path("scan.ply"), path("out.ply"));
    // Large enough that hole filling grows the guest past its initial memory (a service that
    // runs whole: smoothing would run on partitions under a cap it does not fit).
    ok(&["generate", "scan", "--vertices", "1500000", "-o", &scan]);
    let apply = |cap: Option<u64>| {
        let mut args = vec!["apply", "fill-holes", &scan, "-o", &out, "--json"];
        let cap = cap.map(|mib| mib.to_string());
        if let Some(cap) = &cap {
            args.extend(["--memory-cap", cap]);
        }
        meshflow(&args)
    };

    let passed = apply(None);
    assert!(passed.status.success(), "{}", String::from_utf8_lossy(&passed.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&passed.stdout).unwrap();
    let peak = summary["guest_peak_bytes"].as_u64().expect("the guest's peak memory");
    assert!(peak > INITIAL_GUEST_BYTES, "the run never grew its memory: {peak}");
    assert!(peak < (2048 << 20), "{peak}");

    // A MiB less than the run needed: refused, saying which cap and how to raise it.
    let below = (peak - 1) / MIB as u64;
    let refused = apply(Some(below));
    assert!(!refused.status.success());
    let error = String::from_utf8_lossy(&refused.stderr);
    let expected =
        format!("fill-holes: stopped at the memory limit of {below} MiB: on this mesh's ");
    assert!(
        error.contains(&expected) && error.contains(" triangles it needed more than "),
        "{error}"
    );
    assert!(error.contains("a triangle (raise it with --memory-cap, at most 4096)"), "{error}");

    // Just what it needed: the same result as under the default cap.
    let enough = apply(Some(peak.div_ceil(MIB as u64)));
    assert!(enough.status.success(), "{}", String::from_utf8_lossy(&enough.stderr));
    let again: serde_json::Value = serde_json::from_slice(&enough.stdout).unwrap();
    assert_eq!(again["output_hash"], summary["output_hash"]);
    assert_eq!(again["guest_peak_bytes"], peak);
}

#[test]
fn a_refusal_says_the_largest_mesh_the_service_took_on_earlier_runs() {
    let spec = |vertices| meshflow_generate::ScanSpec {
        vertices,
        components: 20,
        holes: 40,
        noise: 0.1,
        seed: 7,
    };
    let scan = meshflow_generate::scan(&spec(1_500_000));
    let holes = meshflow_builtin_plugins::PLUGINS.iter().find(|p| p.name == "holes").unwrap();
    let learn = Runtime::new(Limits::default(), None).unwrap();
    let plugin = learn.load(holes.wasm).unwrap();
    let peak = learn.run(&plugin, "fill-holes", scan.clone(), &[]).unwrap().guest_peak_bytes;
    assert!(peak as u64 > INITIAL_GUEST_BYTES, "the run must grow its memory: {peak}");

    // Under a cap just what that run needed: it passes again (and is learned), a scan of
    // twice the triangles stops, and the refusal says how large a mesh fits.
    let cap_mib = peak.div_ceil(MIB);
    let limits = Limits { memory_bytes: cap_mib * MIB, ..Limits::default() };
    let runtime = Runtime::new(limits, None).unwrap();
    let plugin = runtime.load(holes.wasm).unwrap();
    runtime.run(&plugin, "fill-holes", scan.clone(), &[]).expect("it fits");
    let larger = meshflow_generate::scan(&spec(3_000_000));
    let error = runtime.run(&plugin, "fill-holes", larger.clone(), &[]).unwrap_err();
    let RunError::Memory { fit: Some(fit), .. } = &error else { panic!("{error}") };
    assert_eq!(fit.triangles, larger.triangle_count());
    let learned = fit.learned_bytes_per_triangle.expect("learned from the run that fitted");
    assert_eq!(learned, peak as f64 / scan.triangle_count() as f64);
    // The scan that fitted is about the largest that fits.
    let said = error.to_string();
    let fits = ((cap_mib * MIB) as f64 / learned) as usize;
    assert!(said.contains(&format!("up to about {fits} triangles under this limit")), "{said}");
    assert!(fits >= scan.triangle_count() && fits < larger.triangle_count(), "{said}");
}

#[test]
fn a_cap_below_a_plugins_initial_memory_is_named_too() {
    let bunny = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj");
    let bunny = bunny.to_str().unwrap();
    let error = failure(&["check", "vertex-count", bunny, "--memory-cap", "64"]);
    assert!(error.contains("memory limit of 64 MiB (raise it with --memory-cap"), "{error}");
}

#[test]
fn caps_the_sandbox_cannot_give_are_refused_by_every_command() {
    let commands: [&[&str]; 5] = [
        &["apply", "laplacian-smoothing", "in.ply", "-o", "out.ply"],
        &["check", "vertex-count", "in.ply"],
        &["run", "workflow.json", "in.ply"],
        &["host", "--data", "nowhere"],
        &["up", "--data", "nowhere"],
    ];
    for command in commands {
        for (cap, reason) in [
            ("0", "at least 1 MiB"),
            ("5000", "more than a 32-bit guest can address: at most 4096 MiB"),
            ("two", "a whole number of MiB"),
        ] {
            let error = failure(&[command, &["--memory-cap", cap]].concat());
            assert!(error.contains("--memory-cap") && error.contains(reason), "{cap}: {error}");
        }
    }
}

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

#[test]
fn the_largest_cap_lets_a_guest_grow_to_4_gib() {
    let limits = Limits { memory_bytes: MAX_MEMORY_BYTES, concurrent_runs: 1, ..Limits::default() };
    let runtime = Runtime::new(limits, None).expect("a runtime at the largest cap");
    let hostile = runtime.load(fixture("hostile")).expect("the hostile fixture loads");
    // It allocates 16 MiB at a time until refused: the limiter only refuses growth beyond
    // the cap, so it was granted everything up to 4 GiB first.
    let error = runtime.run(&hostile, "allocate-forever", octahedron(), &[]).unwrap_err();
    assert!(matches!(error, RunError::Memory { limit_mib: 4096, .. }), "{error}");
    assert!(error.to_string().ends_with("(the most a 32-bit guest can address)"), "{error}");
}

#[test]
fn a_runtime_refuses_a_cap_it_cannot_give() {
    assert_eq!(memory_cap_bytes(4096), Ok(MAX_MEMORY_BYTES));
    assert_eq!(memory_cap_bytes(1), Ok(MIB));
    assert_eq!(memory_cap_bytes(0), Err(MemoryCapError::Zero));
    assert_eq!(memory_cap_bytes(4097), Err(MemoryCapError::TooLarge { mib: 4097 }));
    for memory_bytes in [0, MAX_MEMORY_BYTES + 1] {
        let limits = Limits { memory_bytes, ..Limits::default() };
        let error = Runtime::new(limits, None).err().expect("refused");
        assert!(matches!(error, PluginError::MemoryCap(_)), "{error}");
    }
}
