//! Helpers shared by the benches (each bench includes this module with `mod common;`):
//! timing, the 1M-vertex scan they measure on, and MeshLab timed through pymeshlab.

#![allow(dead_code)] // each bench uses its own subset

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use meshflow_generate::ScanSpec;
use meshflow_mesh::MeshData;

/// The generated scan of issue 4's speed targets: 1M vertices, 2M triangles, 150 spurious
/// pieces, 400 holes.
pub const SCAN_1M: ScanSpec =
    ScanSpec { vertices: 1_000_000, components: 150, holes: 400, noise: 0.1, seed: 1 };

/// The fastest of `runs` calls of `f` (the machine is shared and noisy), with the last value.
pub fn best<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut fastest = Duration::MAX;
    let mut last = None;
    for _ in 0..runs {
        let started = Instant::now();
        let value = f();
        fastest = fastest.min(started.elapsed());
        last = Some(value);
    }
    (fastest, last.expect("at least one run"))
}

/// Milliseconds.
pub fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// `a / b`.
pub fn ratio(a: Duration, b: Duration) -> f64 {
    a.as_secs_f64() / b.as_secs_f64()
}

/// The Python that runs pymeshlab: `$PYMESHLAB_PYTHON`, else `python3`.
fn python() -> String {
    std::env::var("PYMESHLAB_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// Whether pymeshlab imports, so MeshLab can be timed side by side.
pub fn meshlab_available() -> bool {
    Command::new(python())
        .args(["-c", "import pymeshlab"])
        .output()
        .is_ok_and(|out| out.status.success())
}

/// MeshLab's best of `runs` for the pymeshlab statements `timed`, each run on a fresh
/// `MeshSet` named `ms` after the untimed statements `setup`; `None` if pymeshlab does not
/// import or the script fails. `MESH` in either is replaced by the quoted `mesh` path.
pub fn meshlab_time(mesh: &Path, setup: &str, timed: &str, runs: usize) -> Option<Duration> {
    let quoted = format!("{:?}", mesh.display().to_string());
    let script = format!(
        "import time, pymeshlab\nbest = 1e9\nfor _ in range({runs}):\n    ms = pymeshlab.MeshSet()\n    {setup}\n    t = time.perf_counter()\n    {timed}\n    best = min(best, time.perf_counter() - t)\nprint(best)",
        setup = if setup.is_empty() { "pass" } else { setup },
    )
    .replace("MESH", &quoted);
    let out = Command::new(python()).args(["-c", &script]).output().ok()?;
    let seconds: f64 = String::from_utf8(out.stdout).ok()?.trim().parse().ok()?;
    Some(Duration::from_secs_f64(seconds))
}

/// The mesh with vertices and triangles in a fixed pseudo-random order.
pub fn shuffled(mesh: &MeshData) -> MeshData {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |n: usize| {
        state =
            state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        ((state >> 33) as usize) % n
    };
    let vertices = mesh.vertex_count();
    let mut order: Vec<usize> = (0..vertices).collect();
    for i in (1..vertices).rev() {
        order.swap(i, next(i + 1));
    }
    let mut new_id = vec![0u32; vertices];
    let mut positions = vec![0.0; 3 * vertices];
    for (new, &old) in order.iter().enumerate() {
        positions[3 * new..3 * new + 3].copy_from_slice(&mesh.positions[3 * old..3 * old + 3]);
        new_id[old] = new as u32;
    }
    let mut faces: Vec<[u32; 3]> = mesh
        .triangles
        .chunks_exact(3)
        .map(|t| [new_id[t[0] as usize], new_id[t[1] as usize], new_id[t[2] as usize]])
        .collect();
    for i in (1..faces.len()).rev() {
        faces.swap(i, next(i + 1));
    }
    MeshData::new(positions, faces.concat())
}
