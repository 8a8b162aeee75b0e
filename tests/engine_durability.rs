//! The engine keeps its state across a crash (DESIGN §10): an engine killed with SIGKILL in
//! the middle of runs and started again on the same data knows its hosts and every run;
//! runs in flight resume from their last finished step (or end `interrupted` with the
//! reason), finished runs read back the same. Runs can be cancelled, and free their host
//! sessions. Workflows that would grow without bound are refused.

mod common;

use std::collections::BTreeSet;
use std::path::Path;
use std::time::Duration;

use common::local::Local;
use common::process::EngineProcess;
use common::{Cluster, EngineApi, Input, components_cache, executed, has_ended, start_hosts, text};
use meshflow_engine::limits::PERSIST_INTERVAL;
use meshflow_engine::workflow::Workflow;
use serde_json::{Value as Json, json};

const SPREAD: &[&[&str]] =
    &[&["cleanup", "checks"], &["smoothing", "checks"], &["holes", "checks"]];

fn example(name: &str) -> Json {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("examples/workflows/{name}.json"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// Waits until no host holds a session (`GET /health`), failing after `within`.
async fn sessions_all_closed(hosts: &[meshflow_host::HostHandle], within: Duration) {
    let deadline = tokio::time::Instant::now() + within;
    for host in hosts {
        let health = format!("{}/health", host.url);
        loop {
            let health: Json = reqwest::get(&health).await.unwrap().json().await.unwrap();
            if health["sessions"] == 0 {
                break;
            }
            assert!(tokio::time::Instant::now() < deadline, "{}: {health}", host.url);
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }
}

/// In-process hosts (SPREAD) and an engine process that can be killed, under `data`.
async fn hosts_and_engine_process(
    data: &Path,
) -> (Vec<meshflow_host::HostHandle>, EngineProcess, EngineApi) {
    let hosts = start_hosts(SPREAD, data, &[]).await;
    let urls: Vec<String> = hosts.iter().map(|h| h.url.clone()).collect();
    let engine = EngineProcess::start(&data.join("engine"), &urls, &[]).await;
    let api = EngineApi::new(&engine.url);
    (hosts, engine, api)
}

/// Every run's record through `GET /runs/{id}`, once all have ended.
async fn all_ended(api: &EngineApi, ids: &[String]) -> Vec<Json> {
    futures_util::future::join_all(ids.iter().map(|id| api.finished(id))).await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn an_engine_killed_mid_runs_resumes_them_after_a_restart_and_loses_none() {
    let data = tempfile::tempdir().unwrap();
    let (hosts, mut engine, api) = hosts_and_engine_process(data.path()).await;

    // The repair, then a WHILE that smooths for 20 rounds: long enough that runs are caught
    // part-way, and a resumed WHILE must count its rounds on from the record.
    let mut workflow = example("repair");
    workflow["steps"].as_array_mut().unwrap().push(json!({
        "while": {"check": "vertex-count", "op": ">", "value": 0},
        "do": [{"run": "laplacian-smoothing"}],
        "max-iterations": 20
    }));
    let input = Input::scan(30_000, 7);
    let expected = Local::new(&components_cache())
        .run(&Workflow::from_json(&workflow).unwrap(), input.mesh.clone());
    let input_url = api.upload(&input).await;
    let finished_before = api.run(&workflow, &input_url).await;
    assert_eq!(finished_before["status"], "completed", "{}", finished_before["error"]);
    // Its host packed and stored the result as it finished: it outlives the run's sessions.
    assert!(
        finished_before["result"]["bytes"].as_u64().is_some_and(|b| b > 0),
        "{finished_before:#}"
    );

    let ids: Vec<String> =
        futures_util::future::join_all((0..20).map(|_| api.submit(&workflow, &input_url))).await;
    // Kill the engine once some run is part-way: a step done and written (the engine
    // writes a record's changes within PERSIST_INTERVAL), the run not finished.
    let deadline = tokio::time::Instant::now() + Duration::from_secs(120);
    let part_way = loop {
        assert!(tokio::time::Instant::now() < deadline, "no run got part-way");
        let records = futures_util::future::join_all(ids.iter().map(|id| api.record(id))).await;
        let started = records
            .iter()
            .find(|r| !has_ended(r) && r["steps"].as_array().is_some_and(|s| !s.is_empty()));
        let Some(record) = started else {
            tokio::time::sleep(Duration::from_millis(20)).await;
            continue;
        };
        tokio::time::sleep(PERSIST_INTERVAL * 3).await;
        if !has_ended(&api.record(text(&record["id"])).await) {
            break record.clone();
        }
    };
    engine.kill_and_restart().await;

    // The hosts come back from the database: the restart named none.
    let known: Json = api.http.get(api.url("/hosts")).send().await.unwrap().json().await.unwrap();
    let known: BTreeSet<&str> = known.as_array().unwrap().iter().map(|h| text(&h["url"])).collect();
    assert_eq!(known, hosts.iter().map(|h| h.url.as_str()).collect());
    // The run finished before the crash reads back the same.
    assert_eq!(api.record(text(&finished_before["id"])).await, finished_before);

    let records = all_ended(&api, &ids).await;
    for record in &records {
        match text(&record["status"]) {
            "completed" => {
                assert_eq!(text(&record["result"]["hash"]), expected.hash(), "{record:#}");
                // Resuming repeats no step and skips none.
                assert_eq!(executed(record), expected.steps, "{}", record["id"]);
            }
            "interrupted" => {
                let reason = text(&record["error"]);
                assert!(reason.contains("the engine restarted"), "{reason}");
            }
            other => panic!("run {} ended {other}: {}", record["id"], record["error"]),
        }
    }
    // The run caught part-way resumed from its finished steps, on the hosts that kept them.
    let resumed = records.iter().find(|r| r["id"] == part_way["id"]).unwrap();
    assert_eq!(resumed["status"], "completed", "{}", resumed["error"]);
    let identity = |step: &Json| {
        (
            step["path"].clone(),
            step["host"].clone(),
            step["started_ms"].clone(),
            step["output_hash"].clone(),
        )
    };
    let before: Vec<_> = part_way["steps"].as_array().unwrap().iter().map(identity).collect();
    let after: Vec<_> = resumed["steps"].as_array().unwrap().iter().map(identity).collect();
    assert_eq!(after[..before.len()], before[..], "the steps done before the kill were run again");
    let listed: Json = api.http.get(api.url("/runs")).send().await.unwrap().json().await.unwrap();
    let listed: BTreeSet<&str> =
        listed.as_array().unwrap().iter().map(|r| text(&r["id"])).collect();
    assert!(ids.iter().all(|id| listed.contains(id.as_str())), "GET /runs lost a run");
    assert_eq!(listed.len(), 21);

    // Every session the runs opened, before and after the restart, is deleted in the end.
    sessions_all_closed(&hosts, Duration::from_secs(20)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cancelled_run_stops_within_a_second_and_frees_its_host_sessions() {
    let cluster = Cluster::start(SPREAD).await;
    let endless = json!([{
        "while": {"check": "vertex-count", "op": ">", "value": 0},
        "do": [{"run": "laplacian-smoothing"}],
        "max-iterations": 10000
    }]);
    let id = cluster.submit(&endless, &cluster.upload(&Input::bunny()).await).await;
    cluster.under_way_until(&id, |r| r["steps"].as_array().is_some_and(|s| s.len() >= 4)).await;
    let asked = tokio::time::Instant::now();
    let cancelled = std::process::Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(["cancel", "--engine", &cluster.base, &id])
        .env("MESHFLOW_API_TOKEN", common::API_TOKEN)
        .output()
        .unwrap();
    let said = String::from_utf8_lossy(&cancelled.stdout);
    assert!(cancelled.status.success(), "{}", String::from_utf8_lossy(&cancelled.stderr));
    assert!(said.starts_with(&format!("run {id}: cancelled")), "{said}");
    let record = cluster.finished(&id).await;
    assert!(asked.elapsed() < Duration::from_secs(1), "took {:?}", asked.elapsed());
    assert_eq!(record["status"], "cancelled", "{record:#}");
    // Its record no longer grows, and a second cancel is refused.
    let steps = record["steps"].as_array().unwrap().len();
    tokio::time::sleep(Duration::from_millis(500)).await;
    assert_eq!(cluster.record(&id).await["steps"].as_array().unwrap().len(), steps);
    let cancel = cluster.url(&format!("/runs/{id}/cancel"));
    assert_eq!(cluster.http.post(&cancel).send().await.unwrap().status(), 409);
    sessions_all_closed(&cluster.hosts, Duration::from_secs(10)).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn workflows_that_would_grow_without_bound_are_refused() {
    let cluster = Cluster::start(&[&["smoothing", "checks"]]).await;
    let url = cluster.upload(&Input::bunny()).await;
    let refused = |workflow: Json| {
        let body = json!({"workflow": workflow, "input": url}).to_string();
        async { cluster.post_run(body).await }
    };
    let (status, answer) = refused(json!([{
        "while": {"check": "vertex-count", "op": ">", "value": 0},
        "do": [{"run": "laplacian-smoothing"}],
        "max-iterations": 1_000_000_000u64
    }]))
    .await;
    assert_eq!(status, 400, "{answer}");
    assert!(text(&answer["error"]["message"]).contains("from 0 to 10000"), "{answer}");
    let (status, answer) = refused(json!({"steps": []})).await;
    assert_eq!(status, 400, "{answer}");
    let many: Vec<Json> = (0..1001).map(|_| json!({"run": "laplacian-smoothing"})).collect();
    let (status, answer) = refused(json!(many)).await;
    assert_eq!(status, 400, "{answer}");
    // A body over the submission limit is refused before it is parsed.
    let huge = format!("{{\"workflow\": [], \"padding\": \"{}\"}}", "x".repeat(2 << 20));
    let (status, _) = cluster.post_run(huge).await;
    assert_eq!(status, 413);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_result_the_engine_died_before_packing_is_packed_when_it_restarts() {
    let data = tempfile::tempdir().unwrap();
    let (_hosts, mut engine, api) = hosts_and_engine_process(data.path()).await;
    let input = api.upload(&Input::bunny()).await;
    let done = api.run(&json!([{"run": "laplacian-smoothing"}]), &input).await;
    assert_eq!(done["status"], "completed", "{}", done["error"]);
    let (id, packed) = (text(&done["id"]).to_owned(), done["result"]["bytes"].as_u64().unwrap());

    // The record as a crash right after the run's end leaves it: completed, held, not
    // packed, not settled (once the settled one is written, within PERSIST_INTERVAL).
    tokio::time::sleep(PERSIST_INTERVAL * 3).await;
    engine.kill();
    let database = rusqlite::Connection::open(data.path().join("engine/engine.sqlite3")).unwrap();
    let stored: String = database
        .query_row("SELECT record FROM runs WHERE id = ?1", [&id], |row| row.get(0))
        .unwrap();
    let mut record: Json = serde_json::from_str(&stored).unwrap();
    assert_eq!(record["result"]["bytes"].as_u64(), Some(packed), "{record:#}");
    record["result"]["bytes"] = Json::Null;
    record.as_object_mut().unwrap().remove("settled_ms");
    let unsettled = serde_json::to_string(&record).unwrap();
    database.execute("UPDATE runs SET record = ?2 WHERE id = ?1", [&id, &unsettled]).unwrap();
    drop(database);

    engine.restart().await;
    let settled = api.finished(&id).await;
    assert_eq!(settled["status"], "completed");
    assert!(settled["settled_ms"].is_number(), "{settled:#}");
    assert_eq!(settled["result"]["bytes"].as_u64(), Some(packed), "{settled:#}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn event_streams_end_with_their_run_and_at_once_for_a_finished_one() {
    let cluster = Cluster::start(&[&["smoothing", "checks"]]).await;
    let url = cluster.upload(&Input::bunny()).await;
    let workflow = json!([{"run": "laplacian-smoothing"}]);
    let id = cluster.submit(&workflow, &url).await;
    let events = cluster.url(&format!("/runs/{id}/events"));
    let read_all = |url: String| async move {
        let answer = common::bearer_client(common::API_TOKEN).get(url).send().await.unwrap();
        let body = tokio::time::timeout(Duration::from_secs(60), answer.text()).await;
        body.expect("the event stream ended").unwrap()
    };
    let live = read_all(events.clone()).await;
    assert!(live.starts_with("event: record"), "{live}");
    assert!(live.contains("\"status\":\"completed\""), "{live}");
    // It goes on past completion until the result is packed: its last event settles the
    // run (or, if the run settled before the stream began, it is the settled record alone).
    let last = live.rsplit("event: ").next().unwrap();
    let settled = match live.matches("event: ").count() {
        1 => last.contains("\"settled_ms\":"),
        _ => last.starts_with("settled"),
    };
    assert!(settled && last.contains("\"bytes\":"), "{live}");
    let after = read_all(events).await;
    assert_eq!(after.matches("event: ").count(), 1, "only the record: {after}");
    assert!(after.contains("\"status\":\"completed\""), "{after}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn submit_wait_follows_its_run_across_an_engine_restart() {
    let data = tempfile::tempdir().unwrap();
    // The hosts must outlive the test body: kept, if unused.
    let (_hosts, mut engine, api) = hosts_and_engine_process(data.path()).await;
    let input = Input::scan(30_000, 11);
    let repair = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/workflows/repair.json");
    let expected = Local::new(&components_cache())
        .run(&Workflow::from_json(&example("repair")).unwrap(), input.mesh.clone());
    let input_url = api.upload(&input).await;
    let output = data.path().join("repaired.ply");
    let mut submit = std::process::Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(["submit", "--engine", &engine.url, "--json", "--input", &input_url, "-o"])
        .env("MESHFLOW_API_TOKEN", common::API_TOKEN)
        .arg(&output)
        .arg(&repair)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Once its run has a step, the engine dies under it and comes back.
    let deadline = tokio::time::Instant::now() + Duration::from_secs(120);
    loop {
        assert!(tokio::time::Instant::now() < deadline, "the run never started");
        let runs: Json = api.http.get(api.url("/runs")).send().await.unwrap().json().await.unwrap();
        if runs.as_array().unwrap().iter().any(|r| r["steps"].as_u64() > Some(0)) {
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    engine.kill_and_restart().await;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(180);
    let status = loop {
        if let Some(status) = submit.try_wait().unwrap() {
            break status;
        }
        assert!(tokio::time::Instant::now() < deadline, "submit --wait did not return");
        tokio::time::sleep(Duration::from_millis(100)).await;
    };
    let mut stderr = String::new();
    std::io::Read::read_to_string(&mut submit.stderr.take().unwrap(), &mut stderr).unwrap();
    assert!(status.success(), "submit failed: {stderr}");
    let written = meshflow_meshio::load(&output).unwrap();
    assert_eq!(written.content_hash().to_hex(), expected.hash());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_batch_goes_on_after_the_engine_is_killed_and_every_input_gets_its_local_result() {
    let data = tempfile::tempdir().unwrap();
    let (_hosts, mut engine, api) = hosts_and_engine_process(data.path()).await;
    let workflow = json!([
        {"run": "remove-smallest-components"},
        {"while": {"check": "vertex-count", "op": ">", "value": 0},
         "do": [{"run": "laplacian-smoothing"}], "max-iterations": 8}
    ]);
    let local = Local::new(&components_cache());
    let parsed = Workflow::from_json(&workflow).unwrap();
    let mut urls = Vec::new();
    let mut expected = Vec::new();
    for seed in 0..4 {
        let input = Input::scan(8_000, 40 + seed);
        expected.push(local.run(&parsed, input.mesh.clone()).hash());
        urls.push(api.upload(&input).await);
    }
    let body = json!({"workflow": workflow, "inputs": urls, "concurrency": 1});
    let answer = api.http.post(api.url("/batches")).json(&body).send().await.unwrap();
    assert_eq!(answer.status(), 202);
    let id = text(&answer.json::<Json>().await.unwrap()["id"]).to_owned();
    let batch = || {
        let (api, id) = (&api, id.clone());
        async move {
            let answer = api.http.get(api.url(&format!("/batches/{id}"))).send().await.unwrap();
            assert_eq!(answer.status(), 200);
            answer.json::<Json>().await.unwrap()
        }
    };
    // Killed while the first input runs, the others waiting their turn.
    loop {
        let now = batch().await;
        if now["entries"][0]["run"].is_string() {
            assert!(now["entries"][3]["run"].is_null(), "{now:#}");
            break;
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    engine.kill_and_restart().await;
    let deadline = tokio::time::Instant::now() + Duration::from_secs(240);
    let done = loop {
        let now = batch().await;
        if now["status"] == "completed" {
            break now;
        }
        assert!(tokio::time::Instant::now() < deadline, "{now:#}");
        tokio::time::sleep(Duration::from_millis(200)).await;
    };
    let hashes: Vec<&str> =
        done["rows"].as_array().unwrap().iter().map(|r| text(&r["result_hash"])).collect();
    assert_eq!(hashes, expected, "{done:#}");
}
