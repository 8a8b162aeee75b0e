//! Helpers shared by the benches (each bench includes this module with `mod common;`):
//! timing, the 1M-vertex scan they measure on, and MeshLab timed through pymeshlab.

#![allow(dead_code)] // each bench uses its own subset

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

use meshflow_generate::ScanSpec;

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

/// The pymeshlab statements doing what the repair workflow's steps do, on a `MeshSet` `ms`
/// (each bench that sets MeshLab beside meshflow uses these).
pub const MESHLAB_REMOVE_COMPONENTS: &str =
    "ms.meshing_remove_connected_component_by_face_number(mincomponentsize=10000)";
pub const MESHLAB_LAPLACIAN: &str =
    "ms.apply_coord_laplacian_smoothing(stepsmoothnum=1, boundary=True, cotangentweight=False)";
pub const MESHLAB_FILL_HOLES: &str = "ms.meshing_close_holes(maxholesize=500)";
pub const MESHLAB_DEGENERATE: &str =
    "ms.meshing_remove_null_faces(); ms.meshing_remove_duplicate_faces()";

/// The Python that runs pymeshlab: `$PYMESHLAB_PYTHON`, else `python3`.
pub fn python() -> String {
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
