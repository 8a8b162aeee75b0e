//! The engine routes the workbench stands on (issue 14), end to end over HTTP: downloads in
//! the user's format (written by hosts: the engine links no codec) named after the input and
//! hash-checked, a step's output and the input
//! as the viewer's raw arrays, `POST /workflows/validate` answering as `POST /runs` would,
//! a run's workflow for re-runs, and plugin upload forwarded to a registered host.

mod common;

use common::{Cluster, Input, TOKEN, builtin, steps, text};
use meshflow_meshio::{self as io, Format};
use serde_json::{Value as Json, json};

const FAMILIES: &[&[&str]] = &[&["cleanup", "smoothing", "holes", "checks"], &["checks"]];

fn repair() -> Json {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/workflows/repair.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// GET `path`: status, Content-Disposition and body.
async fn get(cluster: &Cluster, path: &str) -> (u16, String, Vec<u8>) {
    let answer = cluster.http.get(cluster.url(path)).send().await.unwrap();
    let status = answer.status().as_u16();
    let disposition = answer
        .headers()
        .get("content-disposition")
        .map(|v| v.to_str().unwrap().to_owned())
        .unwrap_or_default();
    (status, disposition, answer.bytes().await.unwrap().to_vec())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn results_steps_and_inputs_download_in_every_format_named_after_the_input() {
    let cluster = Cluster::start_allowing(FAMILIES, &[], &dead_port()).await;
    let input = Input::bunny();
    let record = cluster.run(&repair(), &cluster.upload(&input).await).await;
    assert_eq!(record["status"], "completed", "{record:#}");
    let id = text(&record["id"]);
    let hash = text(&record["result"]["hash"]);

    for format in Format::ALL {
        let ext = format.extension();
        let (status, disposition, body) =
            get(&cluster, &format!("/runs/{id}/result?format={ext}")).await;
        assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
        assert_eq!(disposition, format!("attachment; filename=\"bunny-result.{ext}\""));
        let mesh = io::load_bytes(&body, format, ext).unwrap();
        // STL keeps no shared vertices; the others are the result itself.
        if format != Format::Stl {
            assert_eq!(mesh.content_hash().to_hex(), hash, "{ext}");
        }
        assert_eq!(mesh.triangle_count() as u64, record["result"]["triangles"].as_u64().unwrap());
    }
    let (_, _, packed) = get(&cluster, &format!("/runs/{id}/result?format=mfm")).await;
    assert_eq!(meshflow_codec::pack::decode(&packed).unwrap().content_hash().to_hex(), hash);

    // The CLI's redirect stays.
    assert_eq!(cluster.result(id).await.content_hash().to_hex(), hash);

    // A filter step's output, and the viewer's raw arrays of the input.
    let first = &steps(&record)[0];
    let (status, disposition, body) =
        get(&cluster, &format!("/runs/{id}/steps/0/output?format=obj")).await;
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    assert_eq!(disposition, "attachment; filename=\"bunny-step0-remove-smallest-components.obj\"");
    let output = io::load_bytes(&body, Format::Obj, "obj").unwrap();
    assert_eq!(output.content_hash().to_hex(), text(&first["output_hash"]));
    let (status, _, raw) = get(&cluster, &format!("/runs/{id}/input?format=raw")).await;
    assert_eq!(status, 200);
    assert_eq!(&raw[..4], b"MFR1");
    let vertices = u32::from_le_bytes(raw[4..8].try_into().unwrap()) as usize;
    let triangles = u32::from_le_bytes(raw[8..12].try_into().unwrap()) as usize;
    assert_eq!((vertices, triangles), (input.mesh.vertex_count(), input.mesh.triangle_count()));
    assert_eq!(raw.len(), 12 + vertices * 12 + triangles * 12);
    let input_hash = text(&record["input"]["hash"]);
    assert_eq!(meshflow_api::raw_mesh::content_hash(&raw).unwrap(), input_hash);
    // The input in another format than it was uploaded in, written by a host of the run.
    let (status, disposition, body) = get(&cluster, &format!("/runs/{id}/input?format=ply")).await;
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    assert_eq!(disposition, "attachment; filename=\"bunny-input.ply\"");
    let mesh = io::load_bytes(&body, Format::Ply, "ply").unwrap();
    assert_eq!(mesh.content_hash().to_hex(), input_hash);

    // A quantised run's input is the mesh on the run's grid, which its hash names.
    let mut quantised = repair();
    quantised["quantize"] = json!(16);
    let on_grid = cluster.run(&quantised, &cluster.upload(&input).await).await;
    assert_eq!(on_grid["status"], "completed", "{on_grid:#}");
    let grid_input_hash = text(&on_grid["input"]["hash"]);
    assert_ne!(grid_input_hash, input.mesh.content_hash().to_hex(), "the grid moved vertices");
    let path = format!("/runs/{}/input?format=ply", text(&on_grid["id"]));
    let (status, _, body) = get(&cluster, &path).await;
    assert_eq!(status, 200, "{}", String::from_utf8_lossy(&body));
    let mesh = io::load_bytes(&body, Format::Ply, "ply").unwrap();
    assert_eq!(mesh.content_hash().to_hex(), grid_input_hash);

    // What cannot be served says why.
    for (path, status, code) in [
        (format!("/runs/{id}/result?format=exe"), 400, "bad-format"),
        (format!("/runs/{id}/steps/99/output?format=ply"), 404, "not-found"),
        ("/runs/nope/result?format=ply".to_owned(), 404, "not-found"),
    ] {
        let (got, _, body) = get(&cluster, &path).await;
        let error: Json = serde_json::from_slice(&body).unwrap();
        assert_eq!((got, error["error"]["code"].as_str().unwrap()), (status, code), "{path}");
    }

    // A failed run has no result to download, and says why.
    let dead = cluster.submit(&repair(), "http://127.0.0.1:9/gone.ply").await;
    let failed = cluster.finished(&dead).await;
    assert_eq!(failed["status"], "failed");
    let (status, _, body) = get(&cluster, &format!("/runs/{dead}/result?format=ply")).await;
    assert_eq!(status, 409, "{}", String::from_utf8_lossy(&body));

    // Re-running: the workflow and input as submitted.
    let (status, _, body) = get(&cluster, &format!("/runs/{id}/workflow")).await;
    assert_eq!(status, 200);
    let submitted: Json = serde_json::from_slice(&body).unwrap();
    assert_eq!(submitted["workflow"], repair());
    assert_eq!(submitted["input"], record["input"]["url"]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn validation_answers_as_submitting_would() {
    let cluster = Cluster::start_allowing(FAMILIES, &[], &dead_port()).await;
    let post = |path: &'static str, body: Json| {
        let cluster = &cluster;
        async move {
            let answer = cluster.http.post(cluster.url(path)).json(&body).send().await.unwrap();
            (answer.status().as_u16(), answer.json::<Json>().await.unwrap())
        }
    };
    assert_eq!(
        post("/workflows/validate", json!({"workflow": repair()})).await,
        (200, json!({"valid": true}))
    );
    let bad = json!({"workflow": {"steps": [{"run": "fill-holes"},
        {"while": {"check": "hole-count", "op": ">", "value": 0},
         "do": [{"run": "laplacian-smoothing", "params": {"iterations": 0}}]}]},
        "input": "http://127.0.0.1:9/x.ply"});
    let (status, validated) = post("/workflows/validate", bad.clone()).await;
    assert_eq!(status, 400);
    let message = text(&validated["error"]["message"]);
    assert!(message.starts_with("steps[1].do[0]"), "{message}");
    assert_eq!(post("/runs", bad).await, (400, validated));
    let (status, empty) = post("/workflows/validate", json!({"steps": []})).await;
    assert_eq!(
        (status, text(&empty["error"]["message"])),
        (400, "steps: a workflow needs at least one step")
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn plugins_are_forwarded_to_a_registered_host_with_the_users_token() {
    let cluster = Cluster::start(&[&["checks"]]).await;
    let host = cluster.hosts[0].url.clone();
    let upload_bytes = |host: String, token: &'static str, wasm: Vec<u8>| {
        let cluster = &cluster;
        async move {
            let answer = cluster
                .http
                .post(cluster.url("/plugins"))
                .query(&[("host", host)])
                .header("X-Upload-Token", token)
                .body(wasm)
                .send()
                .await
                .unwrap();
            (answer.status().as_u16(), answer.json::<Json>().await.unwrap())
        }
    };
    let upload = |host, token| upload_bytes(host, token, builtin("smoothing").to_vec());
    // The host's 401 arrives as 403: a 401 would mean the engine's own token.
    let (status, refused) = upload(host.clone(), "wrong").await;
    assert_eq!((status, text(&refused["error"]["code"])), (403, "host-unauthorized"), "{refused}");
    // So it does for a component as large as a Python one (18 MB), which the host refuses
    // before reading it all: the engine must not report the broken pipe as a host failure.
    let large = vec![0u8; 20 << 20];
    let (status, refused) = upload_bytes(host.clone(), "wrong", large).await;
    assert_eq!((status, text(&refused["error"]["code"])), (403, "host-unauthorized"), "{refused}");
    let (status, refused) = upload("http://127.0.0.1:9".into(), TOKEN).await;
    assert_eq!((status, text(&refused["error"]["code"])), (400, "unknown-host"));
    let (status, uploaded) = upload(host.clone(), TOKEN).await;
    assert_eq!(status, 201, "{uploaded}");
    assert!(
        uploaded["services"].as_array().unwrap().iter().any(|s| s["name"] == "laplacian-smoothing")
    );
    // The catalogue knows at once.
    let services = cluster.services().await;
    assert!(services.as_array().unwrap().iter().any(|s| s["name"] == "laplacian-smoothing"));
}

/// Inputs from a closed port are let through the engine's door, so such a run fails at its
/// hosts, as a mistyped URL does.
fn dead_port() -> [String; 1] {
    ["http://127.0.0.1:9".to_owned()]
}
