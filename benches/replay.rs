//! Replay corrections against edit logs and full meshes (issue 15), printed as a table. Run
//! with `cargo bench --bench replay` (release).
//!
//! On the bunny, the generated 1M-vertex scan, and that scan with its vertices and triangles
//! in a random order (as a range scanner interleaves its pieces), three steps: add-noise,
//! one cotangent Laplacian iteration (global edits the edit log cannot predict) and
//! remove-smallest-components (a local one). Per step: the producer's compute time in the
//! sandbox, the edit log's, the replay's and the packed result's bytes, and the time to
//! apply each on a receiver: the edit log replayed through the store, the replay re-run in
//! the sandbox and hash-checked (target: at most 1.5x the producer's compute).

mod common;

use std::path::Path;
use std::sync::Arc;

use common::{SCAN_1M, best, ms};

use meshflow_codec::{correction, pack, replay};
use meshflow_generate::{scan, shuffled};
use meshflow_params::Value;
use meshflow_runtime::{Catalog, Limits, Runtime};

const RUNS: usize = 3;

/// A step of the table: its short name, the service and its parameters.
type Step = (&'static str, &'static str, Vec<(String, Value)>);

fn main() {
    let cache = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bench-components");
    let runtime = Runtime::new(Limits::default(), Some(&cache)).expect("a runtime");
    let mut catalog = Catalog::new();
    for builtin in meshflow_builtin_plugins::PLUGINS {
        catalog.add(runtime.load(builtin.wasm).expect("a built-in plugin loads"));
    }
    let bunny = meshflow_meshio::load(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj"),
    )
    .expect("the bunny loads");
    let scan_1m = scan(&SCAN_1M);
    let interleaved = shuffled(&scan_1m);
    let meshes = [("bunny", bunny), ("scan 1M", scan_1m), ("scan 1M, shuffled", interleaved)];
    let steps: [Step; 3] = [
        ("AN", "add-noise", vec![("seed".into(), Value::Integer(7))]),
        (
            "LS(cot)",
            "laplacian-smoothing",
            vec![
                ("iterations".into(), Value::Integer(1)),
                ("weights".into(), Value::Text("cotangent".into())),
            ],
        ),
        ("RSC", "remove-smallest-components", vec![]),
    ];

    println!(
        "| mesh | step | compute ms | edit log B | replay B | packed result B | apply edits ms \
         | re-run + check ms | re-run / compute |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for (name, mesh) in &meshes {
        let mesh = Arc::new(mesh.clone());
        for (label, service, params) in &steps {
            let (plugin, info) = catalog.find(service).expect("a built-in service");
            let (compute, output) = best(RUNS, || {
                runtime.run(plugin, service, Arc::clone(&mesh), params).expect("the step runs")
            });
            let result = output.mesh.expect("a filter returns a mesh");
            let edits = correction::encode(&mesh, &output.log, &result).expect("the log encodes");
            let (base, result_hash) = (mesh.content_hash(), result.content_hash());
            let named =
                meshflow_host::replay::name(plugin, info, params, base, &result, result_hash)
                    .expect("the step is named");
            let replay_bytes = replay::encode(&named);
            let packed = pack::encode(&result).expect("the result packs");
            let (apply, _) = best(RUNS, || {
                correction::apply(Arc::clone(&mesh), &edits).expect("the edit log applies")
            });
            let (rerun, _) = best(RUNS, || {
                meshflow_host::replay::rerun(&runtime, plugin, &named, Arc::clone(&mesh), None)
                    .expect("the replay reaches the result")
            });
            println!(
                "| {name} | {label} | {:.1} | {} | {} | {} | {:.1} | {:.1} | {:.2} |",
                ms(compute),
                edits.len(),
                replay_bytes.len(),
                packed.len(),
                ms(apply),
                ms(rerun),
                ms(rerun) / ms(compute)
            );
        }
    }
}
