//! Across institutions (issue 36): an engine and two hosts that speak only TLS, with a lab's
//! own CA, run the repair workflow bit-identically to the local chain, on an input fetched
//! over https; a host whose certificate another CA signed is not used.
//!
//! One test: the trust of a process's clients is the process's (`ClientPolicy`).

mod common;

use std::path::Path;
use std::time::Duration;

use common::local::Local;
use common::process::UpProcess;
use common::{
    API_TOKEN, CLUSTER_TOKEN, Input, bearer_client, builtins, components_cache, executed,
};
use meshflow_api::server::{TlsFiles, serve_with, throwaway};
use meshflow_api::tls::ClientPolicy;
use meshflow_engine::workflow::Workflow;
use meshflow_host::{HostConfig, HostHandle};
use serde_json::{Value as Json, json};
use tokio::net::TcpListener;

/// An https server that serves `bytes` at `/scan.ply`: a public archive's input.
async fn https_origin(files: &TlsFiles, bytes: Vec<u8>) -> String {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let address = listener.local_addr().unwrap();
    let app = axum::Router::new()
        .route("/scan.ply", axum::routing::get(move || std::future::ready(bytes.clone())));
    let tls = Some(files.server_config().unwrap());
    tokio::spawn(serve_with(listener, app, tls, std::future::pending()));
    format!("https://127.0.0.1:{}", address.port())
}

async fn tls_host(dir: &Path, families: &[&str], files: &TlsFiles, origin: &str) -> HostHandle {
    let config = HostConfig {
        builtins: builtins(families),
        artefact_cache: Some(components_cache()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        allow_input_from: vec![origin.to_owned()],
        tls: Some(files.clone()),
        ..HostConfig::new(dir)
    };
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    meshflow_host::start(config, listener).await.unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cluster_over_tls_runs_the_repair_workflow_bit_identically() {
    let dir = tempfile::tempdir().unwrap();
    let lab = throwaway::make(&dir.path().join("lab"), "lab").unwrap();
    let other = throwaway::make(&dir.path().join("other"), "other").unwrap();
    ClientPolicy::default().with_ca_file(&lab.ca).unwrap().install();

    let input = Input::scan(20_000, 5);
    let origin = https_origin(&lab.server, input.bytes.clone()).await;
    let hosts = [
        tls_host(&dir.path().join("host-0"), &["cleanup", "smoothing"], &lab.server, &origin).await,
        tls_host(&dir.path().join("host-1"), &["holes", "checks"], &lab.server, &origin).await,
    ];
    let urls: Vec<String> = hosts.iter().map(|h| h.url.clone()).collect();
    assert!(urls.iter().all(|url| url.starts_with("https://")), "{urls:?}");
    let access = meshflow_engine::Access {
        api_token: Some(API_TOKEN.into()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        allow_input_from: vec![origin.clone()],
        tls: Some(lab.server.clone()),
        ..Default::default()
    };
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let engine = meshflow_engine::start(dir.path().join("engine"), None, &urls, access, listener)
        .await
        .unwrap();
    assert!(engine.url.starts_with("https://"), "{}", engine.url);
    let api = tls_client(&lab.ca);

    // The plain port of a TLS server answers nothing a client could mistake for HTTP.
    let plain = engine.url.replacen("https://", "http://", 1);
    assert!(bearer_client(API_TOKEN).get(format!("{plain}/runs")).send().await.is_err());

    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/workflows/repair.json");
    let workflow: Json = serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap();
    let expected = Local::new(&components_cache())
        .run(&Workflow::from_json(&workflow).unwrap(), input.mesh.clone());
    let body = json!({"workflow": workflow, "input": format!("{origin}/scan.ply")});
    let submitted = api.post(format!("{}/runs", engine.url)).json(&body).send().await.unwrap();
    assert_eq!(submitted.status(), 202, "{}", submitted.text().await.unwrap());
    let id = submitted.json::<Json>().await.unwrap()["id"].as_str().unwrap().to_owned();
    let record = finished(&api, &engine.url, &id).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(executed(&record), expected.steps);
    assert_eq!(record["result"]["hash"], expected.hash());
    let hosts_used: Vec<&str> =
        record["steps"].as_array().unwrap().iter().filter_map(|s| s["host"].as_str()).collect();
    assert!(hosts_used.iter().all(|h| h.starts_with("https://")), "{hosts_used:?}");
    let result = api.get(format!("{}/runs/{id}/result", engine.url)).send().await.unwrap();
    let mesh = meshflow_codec::pack::decode(&result.bytes().await.unwrap()).unwrap();
    assert_eq!(mesh.content_hash().to_hex(), expected.hash());

    // A host whose certificate the lab CA did not sign: registered, never trusted.
    let stranger =
        tls_host(&dir.path().join("host-x"), &["smoothing"], &other.server, &origin).await;
    let registered = api
        .post(format!("{}/hosts", engine.url))
        .bearer_auth(CLUSTER_TOKEN)
        .json(&json!({"url": stranger.url}))
        .send()
        .await
        .unwrap();
    assert!(registered.status().is_success(), "{}", registered.status());
    let listed: Json =
        api.get(format!("{}/hosts", engine.url)).send().await.unwrap().json().await.unwrap();
    let entry = listed
        .as_array()
        .unwrap()
        .iter()
        .find(|h| h["url"] == stranger.url.as_str())
        .unwrap_or_else(|| panic!("{listed:#}"));
    assert_eq!(entry["up"], false, "{entry:#}");
    let error = entry["last_error"].as_str().unwrap_or_default();
    assert!(error.contains("certificate"), "the refusal names the certificate: {error}");
}

/// A client that trusts only `ca` and sends the API token.
fn tls_client(ca: &Path) -> reqwest::Client {
    let pem = std::fs::read(ca).unwrap();
    let value = format!("Bearer {API_TOKEN}").parse().unwrap();
    reqwest::Client::builder()
        .use_rustls_tls()
        .tls_built_in_root_certs(false)
        .add_root_certificate(reqwest::Certificate::from_pem(&pem).unwrap())
        .default_headers([(reqwest::header::AUTHORIZATION, value)].into_iter().collect())
        .build()
        .unwrap()
}

async fn finished(api: &reqwest::Client, engine: &str, id: &str) -> Json {
    for _ in 0..1200 {
        let record: Json =
            api.get(format!("{engine}/runs/{id}")).send().await.unwrap().json().await.unwrap();
        if common::has_ended(&record) {
            return record;
        }
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    panic!("run {id} did not end in 120 s");
}

/// `meshflow up --tls` serves everything over https with a throwaway CA, and `submit`,
/// given that CA, runs the demo's WHILE workflow on the bunny to the local chain's mesh.
#[test]
fn up_with_tls_runs_the_demo_workflow() {
    use std::process::Command;
    let dir = tempfile::tempdir().unwrap();
    let meshflow = env!("CARGO_BIN_EXE_meshflow");
    let data = dir.path().join("up").display().to_string();
    let args = ["--tls", "--hosts", "2", "--layout", "all", "--listen", "127.0.0.1:0", "--data"];
    let up = UpProcess::start(&[&args[..], &[data.as_str()]].concat());
    let engine = up.field("engine: ");
    assert!(engine.starts_with("https://127.0.0.1:"), "{}", up.printed);
    assert!(up.hosts().iter().all(|url| url.starts_with("https://")), "{}", up.printed);
    let token = up.field("export MESHFLOW_API_TOKEN=");
    let ca = up.field("export MESHFLOW_CA_FILE=").trim_end_matches(')').to_owned();

    let workflow =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/workflows/smooth-while-unstable.json");
    let bunny = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj");
    let out = dir.path().join("smooth.ply");
    let submit = |ca: Option<&str>| {
        let mut command = Command::new(meshflow);
        command.args(["submit", "--engine", &engine]).arg(&workflow).arg("--input").arg(&bunny);
        command
            .arg("-o")
            .arg(&out)
            .env("MESHFLOW_API_TOKEN", &token)
            .env_remove("MESHFLOW_CA_FILE");
        if let Some(ca) = ca {
            command.env("MESHFLOW_CA_FILE", ca);
        }
        command.output().expect("running meshflow submit")
    };
    let untrusting = submit(None);
    assert!(!untrusting.status.success(), "a client without the CA must not trust the engine");
    let stderr = String::from_utf8_lossy(&untrusting.stderr);
    assert!(stderr.contains("certificate"), "{stderr}");
    let done = submit(Some(&ca));
    assert!(done.status.success(), "{}", String::from_utf8_lossy(&done.stderr));

    let workflow_json: Json =
        serde_json::from_str(&std::fs::read_to_string(&workflow).unwrap()).unwrap();
    let expected = Local::new(&components_cache())
        .run(&Workflow::from_json(&workflow_json).unwrap(), Input::bunny().mesh);
    let written = meshflow_meshio::load(&out).unwrap();
    assert_eq!(written.content_hash().to_hex(), expected.hash());
}
