//! Hosts that lie (issue 30): a reverse proxy in front of a real in-process host alters a
//! filter's announced result (serving another mesh under it) or accuses honest receivers.
//! A third host's replay decides; the run completes with the local chain's hash, the liar
//! is suspect and stays so across an engine restart; an `untrusted` host's results are
//! replayed before anyone builds on them.

mod common;

use std::sync::Arc;
use std::sync::atomic::Ordering;
use std::time::Duration;

use common::local::Local;
use common::proxy::{Lies, Proxy, start_proxy};
use common::{API_TOKEN, EngineApi, Input, components_cache, start_hosts, steps, text};
use meshflow_engine::workflow::Workflow;
use serde_json::{Value as Json, json};
use tokio::net::TcpListener;

const ALL: &[&str] = &["smoothing", "cleanup", "holes", "checks"];

/// Four hosts: the first (smoothing) behind a proxy lying as `first` says, the second
/// (cleanup) behind one lying as `second` says, two more offering everything.
struct Setup {
    api: EngineApi,
    hosts: Vec<String>,
    proxies: Vec<Arc<Proxy>>,
    data: tempfile::TempDir,
    _real: Vec<meshflow_host::HostHandle>,
    _engine: meshflow_engine::EngineHandle,
}

async fn setup(first: Lies, second: Lies) -> Setup {
    let data = tempfile::tempdir().unwrap();
    let real = start_hosts(&[&["smoothing"], &["cleanup"], ALL, ALL], data.path(), &[]).await;
    let (first, p1) = start_proxy(&real[0].url, first).await;
    let (second, p2) = start_proxy(&real[1].url, second).await;
    let hosts = vec![first, second, real[2].url.clone(), real[3].url.clone()];
    let engine = start_engine(data.path(), &hosts).await;
    let api = EngineApi::new(&engine.url);
    Setup { api, hosts, proxies: vec![p1, p2], data, _real: real, _engine: engine }
}

async fn start_engine(data: &std::path::Path, hosts: &[String]) -> meshflow_engine::EngineHandle {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let access = meshflow_engine::Access {
        api_token: Some(API_TOKEN.into()),
        cluster_token: Some(common::CLUSTER_TOKEN.into()),
        ..Default::default()
    };
    meshflow_engine::start(data.join("engine"), None, hosts, access, listener).await.unwrap()
}

fn workflow() -> Json {
    json!({"steps": [
        {"run": "laplacian-smoothing", "params": {"iterations": 2}},
        {"run": "remove-degenerate-triangles"}
    ], "transfer": "correction"})
}

fn expected_hash(input: &Input) -> String {
    let local = Local::new(&components_cache());
    local.run(&Workflow::from_json(&workflow()).unwrap(), input.mesh.clone()).hash()
}

/// Another mesh than any step makes, packed, and its hash.
fn fake_result() -> (String, Vec<u8>) {
    let mesh = Input::scan(300, 7).mesh;
    (mesh.content_hash().to_hex(), meshflow_codec::pack::encode(&mesh).unwrap())
}

async fn hosts(api: &EngineApi) -> Vec<Json> {
    let answer = api.http.get(api.url("/hosts")).send().await.unwrap();
    answer.json::<Vec<Json>>().await.unwrap()
}

async fn entry(api: &EngineApi, url: &str) -> Json {
    hosts(api).await.into_iter().find(|h| h["url"] == url).expect("a registered host")
}

async fn run(setup: &Setup) -> Json {
    let input = Input::bunny();
    let url = setup.api.upload(&input).await;
    let record = tokio::time::timeout(Duration::from_secs(150), setup.api.run(&workflow(), &url))
        .await
        .expect("the run ended in time");
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(text(&record["result"]["hash"]), expected_hash(&input));
    record
}

async fn set_trust(api: &EngineApi, url: &str, trust: &str) {
    let body = json!({"url": url, "trust": trust});
    let answer = api.http.patch(api.url("/hosts")).json(&body).send().await.unwrap();
    assert_eq!(answer.status(), 200);
    assert_eq!(answer.json::<Json>().await.unwrap()["trust"], trust);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_producer_announcing_another_mesh_is_overruled_and_stays_suspect_after_a_restart() {
    let (fake, bytes) = fake_result();
    let lies = Lies { result: Some((fake.clone(), bytes)), ..Lies::default() };
    let setup = setup(lies, Lies::default()).await;
    let record = run(&setup).await;
    let first = &steps(&record)[0];
    assert_eq!(text(&first["host"]), setup.hosts[0]);
    assert_ne!(text(&first["output_hash"]), fake);
    assert_eq!(first["verdict"]["wrong"], json!([setup.hosts[0]]), "{first:#}");
    assert_eq!(first["claims"][0]["hash"], json!(fake));
    assert!(entry(&setup.api, &setup.hosts[0]).await["suspect"].is_string());
    for honest in &setup.hosts[1..] {
        assert_eq!(entry(&setup.api, honest).await["suspect"], Json::Null, "{honest}");
    }
    // Another engine on the same data folder knows the verdicts.
    let restarted = start_engine(setup.data.path(), &[]).await;
    let api = EngineApi::new(&restarted.url);
    assert!(entry(&api, &setup.hosts[0]).await["suspect"].is_string());
    assert_eq!(entry(&api, &setup.hosts[1]).await["suspect"], Json::Null);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_receiver_accusing_an_honest_producer_is_proven_wrong() {
    let setup = setup(Lies::default(), Lies { accuse: true, ..Lies::default() }).await;
    let record = run(&setup).await;
    let first = &steps(&record)[0];
    assert_eq!(first["verdict"]["wrong"], json!([setup.hosts[1]]), "{first:#}");
    assert_eq!(first["verdict"]["right"], json!([setup.hosts[0]]));
    assert!(entry(&setup.api, &setup.hosts[1]).await["suspect"].is_string());
    assert_eq!(entry(&setup.api, &setup.hosts[0]).await["suspect"], Json::Null);
}

#[tokio::test(flavor = "multi_thread")]
async fn an_untrusted_liars_result_never_reaches_a_receiver() {
    let (fake, bytes) = fake_result();
    let lies = Lies { result: Some((fake.clone(), bytes)), ..Lies::default() };
    let setup = setup(lies, Lies::default()).await;
    set_trust(&setup.api, &setup.hosts[0], "untrusted").await;
    let record = run(&setup).await;
    assert_eq!(setup.proxies[0].served_fake.load(Ordering::SeqCst), 0, "a receiver took the lie");
    let first = &steps(&record)[0];
    assert_ne!(text(&first["output_hash"]), fake);
    assert_eq!(first["verdict"]["wrong"], json!([setup.hosts[0]]), "{first:#}");
    assert!(entry(&setup.api, &setup.hosts[0]).await["suspect"].is_string());
    assert_eq!(entry(&setup.api, &setup.hosts[0]).await["trust"], "untrusted");
}

#[tokio::test(flavor = "multi_thread")]
async fn an_honest_untrusted_hosts_steps_are_replayed_and_verified() {
    let setup = setup(Lies::default(), Lies::default()).await;
    set_trust(&setup.api, &setup.hosts[0], "untrusted").await;
    let record = run(&setup).await;
    let first = &steps(&record)[0];
    assert_eq!(text(&first["host"]), setup.hosts[0]);
    let verified = first["verified_by"].as_array().expect("verified");
    assert_eq!(verified[0]["how"], "replay", "{first:#}");
    assert_eq!(verified[0]["hash"], first["output_hash"]);
    assert_eq!(entry(&setup.api, &setup.hosts[0]).await["suspect"], Json::Null);
}

#[tokio::test(flavor = "multi_thread")]
async fn a_spot_checked_hosts_steps_are_replayed_elsewhere_off_the_critical_path() {
    let setup = setup(Lies::default(), Lies::default()).await;
    set_trust(&setup.api, &setup.hosts[0], "spot-check").await;
    // Every step of a spot-checked host is replayed elsewhere (the default is one in ten).
    setup._engine.engine.registry.set_spot_check_share(1.0);
    let record = run(&setup).await;
    let first = &steps(&record)[0];
    assert_eq!(text(&first["host"]), setup.hosts[0]);
    let verified = first["verified_by"].as_array().expect("spot-checked");
    assert_eq!(verified[0]["how"], "spot-check", "{first:#}");
    assert_eq!(verified[0]["hash"], first["output_hash"]);
    assert_ne!(verified[0]["host"], first["host"], "replayed on another host");
    assert_eq!(entry(&setup.api, &setup.hosts[0]).await["suspect"], Json::Null);
}
