//! Meshes larger than one sandbox (issue 33): services that declare themselves local
//! (Laplacian and Taubin smoothing, add-noise, degenerate-triangle repair) run on partitions of a large mesh, and give the
//! whole-mesh result bit for bit — by the step's edit log and by a replay on another run —
//! and under a memory cap the whole run exceeds they still finish.

mod common;

use common::process::{meshflow, ok};
use serde_json::Value as Json;

/// `--max-partition-triangles` that never cuts a mesh of this test.
const NEVER: &str = "4000000000";

fn apply(scan: &str, out: &str, service: &str, extra: &[&str]) -> Json {
    let args = [&["apply", service, scan, "-o", out, "--json"], extra].concat();
    serde_json::from_str(&ok(&args)).expect("apply --json prints JSON")
}

#[test]
fn local_services_on_partitions_of_a_2m_vertex_scan_give_the_whole_mesh_hash() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).display().to_string();
    let scan = path("scan.ply");
    ok(&["generate", "scan", "--vertices", "2000000", "--seed", "5", "-o", &scan]);
    let (whole_out, parts_out, replayed) = (path("whole.ply"), path("parts.ply"), path("r.ply"));
    let (edits, replay) = (path("step.mfc"), path("step.mfr"));

    for (service, params) in [
        ("laplacian-smoothing", vec!["--param", "iterations=3"]),
        ("taubin-smoothing", vec!["--param", "iterations=2"]),
        ("add-noise", vec!["--param", "amount=0.2", "--param", "seed=9"]),
        // Edits connectivity: made again on the region around what the partitions changed.
        ("remove-degenerate-triangles", vec!["--param", "epsilon=0.001"]),
    ] {
        let whole = apply(
            &scan,
            &whole_out,
            service,
            &[&params[..], &["--max-partition-triangles", NEVER]].concat(),
        );
        assert_eq!(whole["partitions"], Json::Null, "{service}: {whole}");
        let hash = whole["output_hash"].as_str().unwrap().to_owned();
        assert_ne!(whole["input_hash"], whole["output_hash"]);

        let cut = ["--max-partition-triangles", "300000"];
        let on_edits = ["--correction", &edits, "--correction-kind", "edits"];
        let parts = apply(&scan, &parts_out, service, &[&params[..], &cut, &on_edits].concat());
        assert_eq!(parts["output_hash"], hash.as_str(), "{service}: {parts}");
        let count = parts["partitions"]["count"].as_u64().expect("it ran on partitions");
        assert!(count >= 13, "{service}: 4M triangles in pieces of 300k: {parts}");
        assert!(parts["report"].as_str().unwrap().contains("partitions"), "{parts}");

        // The merged step's edit log rebuilds the result, verified against its hash.
        let rebuilt = ok(&["correction", "apply", &scan, &edits, "-o", &replayed]);
        assert!(rebuilt.contains(&hash), "{service}: {rebuilt}");
        // A replay of the whole run, re-run on partitions, reaches it too (and the other
        // way round: the same step named by a partitioned run, re-run whole).
        let on_replay = ["--correction", &replay, "--correction-kind", "replay"];
        apply(
            &scan,
            &whole_out,
            service,
            &[&params[..], &["--max-partition-triangles", NEVER], &on_replay].concat(),
        );
        let rerun = ok(&["correction", "apply", &scan, &replay, "-o", &replayed, cut[0], cut[1]]);
        assert!(rerun.contains(&hash), "{service}: {rerun}");
        apply(&scan, &parts_out, service, &[&params[..], &cut, &on_replay].concat());
        let rerun = ok(&[
            "correction",
            "apply",
            &scan,
            &replay,
            "-o",
            &replayed,
            "--max-partition-triangles",
            NEVER,
        ]);
        assert!(rerun.contains(&hash), "{service}: {rerun}");
    }

    // Under a cap a MiB below what the whole run needs, it stops whole, and without
    // --max-partition-triangles it is then cut into the partitions the cap itself chooses
    // and finishes, to the bit.
    let service = "laplacian-smoothing";
    let whole = apply(&scan, &whole_out, service, &["--max-partition-triangles", NEVER]);
    let peak = whole["guest_peak_bytes"].as_u64().unwrap();
    let below = ((peak - 1) >> 20).to_string();
    let refused = meshflow(&[
        "apply",
        service,
        &scan,
        "-o",
        &parts_out,
        "--memory-cap",
        &below,
        "--max-partition-triangles",
        NEVER,
    ]);
    assert!(!refused.status.success(), "the whole run fits under {below} MiB");
    let error = String::from_utf8_lossy(&refused.stderr);
    assert!(error.contains("stopped at the memory limit"), "{error}");
    let parts = apply(&scan, &parts_out, service, &["--memory-cap", &below]);
    assert_eq!(parts["output_hash"], whole["output_hash"], "{parts}");
    assert!(parts["partitions"]["count"].as_u64().unwrap() >= 2, "{parts}");
    assert!(parts["guest_peak_bytes"].as_u64().unwrap() < peak, "{parts}");
}
