//! Issue 33: the repair workflow on a scan larger than one sandbox, through `meshflow run`
//! (engine and three hosts in one process, `--memory-cap 4096`: the cap a 32-bit guest
//! allows), with total and per-step times and the process's peak memory, beside MeshLab's
//! for the same steps when pymeshlab imports (`$PYMESHLAB_PYTHON`, default `python3`).
//!
//! `cargo bench --bench large` generates a scan of `$MESHFLOW_LARGE_VERTICES` vertices
//! (default 30M: about 60M triangles, 150 spurious pieces, 400 holes). Smoothing runs on
//! partitions (the cap chooses their size); the other steps fit the cap whole. Not a test:
//! it takes minutes and gigabytes.

mod common;

use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{
    MESHLAB_DEGENERATE, MESHLAB_FILL_HOLES, MESHLAB_LAPLACIAN, MESHLAB_REMOVE_COMPONENTS,
    meshlab_available, python,
};
use serde_json::Value as Json;

const DEFAULT_VERTICES: usize = 30_000_000;

/// The repair workflow's steps and MeshLab's statements for them, in order. MeshLab's hole
/// closing refuses a mesh with non-manifold edges (a raw scan has some), so its step
/// repairs them first; meshflow's fill-holes leaves the holes at them open instead.
const STEPS: [(&str, &[&str]); 4] = [
    ("remove-smallest-components", &[MESHLAB_REMOVE_COMPONENTS]),
    ("laplacian-smoothing", &[MESHLAB_LAPLACIAN]),
    ("fill-holes", &["ms.meshing_repair_non_manifold_edges()", MESHLAB_FILL_HOLES]),
    ("remove-degenerate-triangles", &[MESHLAB_DEGENERATE]),
];

fn main() {
    let vertices = std::env::var("MESHFLOW_LARGE_VERTICES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(DEFAULT_VERTICES);
    let dir = tempfile::tempdir().expect("a temporary folder");
    let scan = dir.path().join("scan.ply");
    let meshflow = env!("CARGO_BIN_EXE_meshflow");
    let started = Instant::now();
    let generated = Command::new(meshflow)
        .args(["generate", "scan", "--vertices", &vertices.to_string(), "--components", "150"])
        .args(["--holes", "400", "-o"])
        .arg(&scan)
        .output()
        .expect("running meshflow generate");
    assert!(generated.status.success(), "{}", String::from_utf8_lossy(&generated.stderr));
    println!(
        "scan: {} ({:.0} s)",
        String::from_utf8_lossy(&generated.stdout).trim(),
        started.elapsed().as_secs_f64()
    );

    let workflow = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/workflows/repair.json");
    let (report, output) = (dir.path().join("record.json"), dir.path().join("out.ply"));
    let mut run = Command::new(meshflow);
    run.arg("run").arg(&workflow).arg(&scan).arg("-o").arg(&output).arg("--report").arg(&report);
    run.args(["--memory-cap", "4096", "--run-deadline", "3600", "--json"]);
    let (status, wall, peak) = measured(run);
    assert!(status, "meshflow run failed");
    let record: Json =
        serde_json::from_slice(&std::fs::read(&report).expect("the run's record")).unwrap();
    assert_eq!(record["status"], "completed", "{}", record["error"]);

    let meshlab = meshlab_available().then(|| meshlab(&scan)).flatten();
    println!("\n| step | meshflow: compute | host | report | MeshLab |");
    println!("|---|---:|---|---|---:|");
    let steps = record["steps"].as_array().expect("steps");
    for (index, (service, _)) in STEPS.iter().enumerate() {
        let step = steps.iter().find(|s| s["service"] == *service).expect("the step ran");
        let host = step["host"].as_str().unwrap_or("");
        let compute = step["compute_ms"].as_f64().unwrap_or(0.0) / 1e3;
        let theirs = meshlab.as_ref().map_or("—".into(), |m| format!("{:.1} s", m.steps[index]));
        let report = step["report"].as_str().unwrap_or("");
        println!("| {service} | {compute:.1} s | {host} | {report} | {theirs} |");
    }
    println!(
        "| **whole run** | {:.1} s (record: {:.1} s) | peak memory {:.2} GB | | {} |",
        wall.as_secs_f64(),
        record["total_ms"].as_f64().unwrap_or(0.0) / 1e3,
        peak as f64 / 1e9,
        meshlab.as_ref().map_or("—".into(), |m| format!(
            "{:.1} s (load {:.1} s), peak memory {:.2} GB",
            m.steps.iter().sum::<f64>(),
            m.load,
            m.peak_bytes as f64 / 1e9
        )),
    );
    if meshlab.is_none() {
        println!("pymeshlab does not import: no MeshLab figures (pip install pymeshlab)");
    }
}

/// Runs `command` to its end; whether it succeeded, its wall time and its peak resident
/// memory (`VmHWM`, read every 50 ms while it runs).
fn measured(mut command: Command) -> (bool, Duration, u64) {
    let started = Instant::now();
    let mut child = command.stdout(Stdio::null()).spawn().expect("starting the command");
    let status_path = format!("/proc/{}/status", child.id());
    let mut peak = 0;
    let status = loop {
        if let Ok(status) = std::fs::read_to_string(&status_path) {
            peak = peak.max(kib_field(&status, "VmHWM:") * 1024);
        }
        if let Some(status) = child.try_wait().expect("waiting for the command") {
            break status;
        }
        std::thread::sleep(Duration::from_millis(50));
    };
    (status.success(), started.elapsed(), peak)
}

fn kib_field(status: &str, name: &str) -> u64 {
    let line = status.lines().find(|l| l.starts_with(name));
    line.and_then(|l| l.split_whitespace().nth(1)).and_then(|n| n.parse().ok()).unwrap_or(0)
}

struct MeshLab {
    load: f64,
    steps: Vec<f64>,
    peak_bytes: u64,
}

/// MeshLab's seconds for each of [`STEPS`] in turn on the scan, and its peak memory.
fn meshlab(scan: &Path) -> Option<MeshLab> {
    let mut script = format!(
        "import resource, time, pymeshlab\nt = time.perf_counter()\nms = pymeshlab.MeshSet()\n\
         ms.load_new_mesh({:?})\nprint(time.perf_counter() - t)\n",
        scan.display().to_string()
    );
    for (_, statements) in STEPS {
        let statement = statements.join("; ");
        script +=
            &format!("t = time.perf_counter()\n{statement}\nprint(time.perf_counter() - t)\n");
    }
    script += "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)\n";
    let out = Command::new(python()).args(["-c", &script]).output().ok()?;
    let numbers: Vec<f64> =
        String::from_utf8(out.stdout).ok()?.lines().filter_map(|l| l.trim().parse().ok()).collect();
    let (&peak, times) = numbers.split_last()?;
    let (&load, steps) = times.split_first()?;
    (steps.len() == STEPS.len()).then(|| MeshLab {
        load,
        steps: steps.to_vec(),
        peak_bytes: peak as u64,
    })
}
