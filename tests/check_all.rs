//! `meshflow check --all`: every check on one load gives what each check gives alone.

use std::path::Path;
use std::process::Command;

fn meshflow(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(args)
        // Share compiled components between tests, as a user's cache would.
        .env("MESHFLOW_CACHE_DIR", Path::new(env!("CARGO_TARGET_TMPDIR")).join("components"))
        .output()
        .expect("running meshflow")
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = meshflow(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "meshflow {args:?} failed: {stderr}");
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

fn bunny() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj").display().to_string()
}

/// A mesh with defects (a flipped triangle, a non-manifold fin, an open border) and a
/// closed cube beside it, so the topology checks take their less common paths.
const DEFECTS: &str = "
v 0 0 0
v 1 0 0
v 0 1 0
v 1 1 0
v 0.5 0.5 1
v 5 5 5
v 6 5 5
v 5 6 5
v 6 6 5
v 5 5 6
v 6 5 6
v 5 6 6
v 6 6 6
f 1 2 3
f 3 4 2
f 2 3 5
f 6 8 9
f 6 9 7
f 10 11 13
f 10 13 12
f 6 7 11
f 6 11 10
f 8 12 13
f 8 13 9
f 6 10 12
f 6 12 8
f 7 9 13
f 7 13 11
";

#[test]
fn every_check_on_one_load_gives_what_each_gives_alone() {
    let dir = tempfile::tempdir().unwrap();
    let defects = dir.path().join("defects.obj");
    std::fs::write(&defects, DEFECTS).unwrap();
    for mesh in [bunny(), defects.display().to_string()] {
        let all = json(&["check", "--all", &mesh, "--json"]);
        let checks = all["checks"].as_array().expect("a list of checks");
        let names: Vec<&str> = checks.iter().map(|c| c["service"].as_str().unwrap()).collect();
        for expected in ["vertex-count", "edge-count", "hole-count", "is-manifold", "volume"] {
            assert!(names.contains(&expected), "{mesh}: {expected} missing from {names:?}");
        }
        for check in checks {
            let service = check["service"].as_str().unwrap();
            assert!(check["timings_ms"]["run"].as_f64().unwrap() >= 0.0, "{service}");
            let alone = meshflow(&["check", service, &mesh, "--json"]);
            if alone.status.success() {
                let alone: serde_json::Value = serde_json::from_slice(&alone.stdout).unwrap();
                assert_eq!(check["value"], alone["value"], "{mesh}: {service}");
                assert!(check.get("error").is_none(), "{mesh}: {service}");
            } else {
                // Refused alone (volume of an open mesh): refused here too, saying why.
                let why = String::from_utf8_lossy(&alone.stderr);
                let error = check["error"].as_str().expect("the reason");
                assert!(check["value"].is_null() && why.contains(error), "{error} / {why}");
            }
        }
        // All together: at least the longest check (they may run side by side).
        let run = all["timings_ms"]["run"].as_f64().unwrap();
        let longest =
            checks.iter().map(|c| c["timings_ms"]["run"].as_f64().unwrap()).fold(0.0, f64::max);
        assert!(run >= longest && all["timings_ms"]["load"].as_f64().unwrap() >= 0.0, "{all}");
    }
}

#[test]
fn all_takes_the_mesh_only_and_no_parameters() {
    let out = meshflow(&["check", "--all", "vertex-count", &bunny()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("`check --all MESH`"), "{stderr}");
    let out = meshflow(&["check", "--all", &bunny(), "--param", "x=1"]);
    assert!(!out.status.success());
    let out = meshflow(&["check", &bunny()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success() && stderr.contains("check SERVICE MESH"), "{stderr}");
}
