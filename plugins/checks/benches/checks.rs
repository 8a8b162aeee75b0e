//! All checks on a generated 1M-vertex / 2M-triangle scan (150 pieces, 400 holes), printed
//! as a table: each check natively (the plain function on arrays) and as WebAssembly through
//! the host (whole run: array copies, sandbox), best of a few runs. Run with
//! `cargo bench -p meshflow-plugin-checks --bench checks`.
//!
//! Goal (issue 4): all checks together ≤ 0.8 s in the sandbox (MeshLab: 8.0 s), WASM ≤ 1.3×
//! native. With pymeshlab importable by `$PYMESHLAB_PYTHON` (default `python3`), MeshLab's
//! topological measures are timed on the same mesh alongside.

use std::process::Command;
use std::time::{Duration, Instant};

use meshflow_builtin_plugins::PLUGINS;
use meshflow_host::generate::{ScanSpec, scan};
use meshflow_host::runtime::{Limits, Runtime, Value};
use meshflow_host::{MeshData, io};
use meshflow_plugin_checks::{angles, counts, normals, topology};

const RUNS: usize = 3;

/// A check run natively on the host's arrays.
type Native = fn(&MeshData) -> Value;

/// Every service with its native twin.
const CHECKS: [(&str, Native); 11] = [
    ("vertex-count", |m| Value::Integer(m.vertex_count() as i64)),
    ("edge-count", |m| Value::Integer(counts::edge_count(m.vertex_count(), &m.triangles) as i64)),
    ("triangle-count", |m| Value::Integer(m.triangle_count() as i64)),
    ("component-count", |m| {
        Value::Integer(counts::component_count(m.vertex_count(), &m.triangles) as i64)
    }),
    ("hole-count", |m| Value::Integer(counts::hole_count(m.vertex_count(), &m.triangles) as i64)),
    ("is-manifold", |m| Value::Boolean(topology::is_manifold(m.vertex_count(), &m.triangles))),
    ("is-oriented", |m| Value::Boolean(topology::is_oriented(m.vertex_count(), &m.triangles))),
    ("is-orientable", |m| Value::Boolean(topology::is_orientable(m.vertex_count(), &m.triangles))),
    ("min-angle", |m| Value::Real(angles::min_angle(&m.positions, &m.triangles))),
    ("max-angle", |m| Value::Real(angles::max_angle(&m.positions, &m.triangles))),
    ("normal-instability", |m| {
        Value::Real(normals::normal_instability(&m.positions, &m.triangles))
    }),
];

fn best<T>(mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut fastest = Duration::MAX;
    let mut last = None;
    for _ in 0..RUNS {
        let started = Instant::now();
        let value = f();
        fastest = fastest.min(started.elapsed());
        last = Some(value);
    }
    (fastest, last.expect("at least one run"))
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn main() {
    let spec = ScanSpec { vertices: 1_000_000, components: 150, holes: 400, noise: 0.1, seed: 1 };
    let mesh = scan(&spec);
    println!(
        "mesh: generated scan, {} vertices, {} triangles\n",
        mesh.vertex_count(),
        mesh.triangle_count()
    );

    let runtime = Runtime::new(Limits::default(), None).expect("a runtime");
    let wasm = PLUGINS.iter().find(|p| p.name == "checks").expect("the checks plugin").wasm;
    let plugin = runtime.load(wasm).expect("the checks plugin loads");

    println!(
        "| {:<20} | {:>20} | {:>11} | {:>11} | {:>5} |",
        "check", "value", "native ms", "wasm ms", "ratio"
    );
    println!("|{:-<22}|{:->22}|{:->13}|{:->13}|{:->7}|", "", "", "", "", "");
    let (mut native_total, mut wasm_total) = (Duration::ZERO, Duration::ZERO);
    for (service, native) in CHECKS {
        let (native_time, expected) = best(|| native(&mesh));
        let (wasm_time, out) =
            best(|| runtime.run(&plugin, service, &mesh, &[]).expect("a check run"));
        let value = out.value.expect("a check value");
        // Reals may differ in the last bits: wasm links its own libm (atan2).
        let agree = match (&value, &expected) {
            (Value::Real(a), Value::Real(b)) => (a - b).abs() <= 1e-12 * b.abs().max(1.0),
            _ => value == expected,
        };
        assert!(agree, "{service}: the sandbox gave {value:?}, native {expected:?}");
        native_total += native_time;
        wasm_total += wasm_time;
        println!(
            "| {service:<20} | {:>20} | {:>11.1} | {:>11.1} | {:>5.2} |",
            format!("{value:?}"),
            ms(native_time),
            ms(wasm_time),
            wasm_time.as_secs_f64() / native_time.as_secs_f64()
        );
    }
    println!(
        "| {:<20} | {:>20} | {:>11.1} | {:>11.1} | {:>5.2} |",
        "all checks",
        "goal ≤ 800 ms wasm",
        ms(native_total),
        ms(wasm_total),
        wasm_total.as_secs_f64() / native_total.as_secs_f64()
    );

    match meshlab_topology_time(&mesh) {
        Some(t) => println!("\nMeshLab get_topological_measures on the same mesh: {:.0} ms", ms(t)),
        None => {
            println!("\n(pymeshlab not importable by $PYMESHLAB_PYTHON / python3: no MeshLab row)")
        }
    }
}

/// MeshLab's topological measures on the same mesh (saved as binary PLY), best of `RUNS`.
fn meshlab_topology_time(mesh: &MeshData) -> Option<Duration> {
    let dir = tempfile::tempdir().ok()?;
    let ply = dir.path().join("scan.ply");
    io::save(&ply, mesh).ok()?;
    let script = format!(
        "import time, pymeshlab\nms = pymeshlab.MeshSet()\nms.load_new_mesh({:?})\nbest = 1e9\nfor _ in range({RUNS}):\n    t = time.perf_counter()\n    ms.get_topological_measures()\n    best = min(best, time.perf_counter() - t)\nprint(best)",
        ply.display().to_string()
    );
    let python = std::env::var("PYMESHLAB_PYTHON").unwrap_or_else(|_| "python3".into());
    let out = Command::new(python).args(["-c", &script]).output().ok()?;
    let seconds: f64 = String::from_utf8(out.stdout).ok()?.trim().parse().ok()?;
    Some(Duration::from_secs_f64(seconds))
}
