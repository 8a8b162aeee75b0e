//! Workflows end to end (issue 5): an engine and 2–3 hosts on 127.0.0.1, real HTTP, held to
//! the same services applied locally in sequence.

mod common;
mod fake_host;

use std::collections::BTreeSet;
use std::path::Path;

use common::local::{Local, Trace};
use common::process::HostProcess;
use common::{Cluster, Input, TOKEN, builtin, components_cache, executed, steps, text};
use fake_host::{FakeHost, Script};
use meshflow_api::HostClient;
use meshflow_engine::workflow::Workflow;
use meshflow_host::HostHandle;
use meshflow_runtime::Limits;
use serde_json::{Value as Json, json};

/// Each filter family on its own host and the checks with the hole filler, so every example
/// crosses hosts.
const SPREAD: &[&[&str]] = &[&["smoothing"], &["cleanup"], &["holes", "checks"]];

fn example(name: &str) -> Json {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("examples/workflows/{name}.json"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// The workflow run locally on `input`.
fn locally(workflow: &Json, input: &Input) -> Trace {
    let local = Local::new(&components_cache());
    local.run(&Workflow::from_json(workflow).unwrap(), input.mesh.clone())
}

/// Runs `workflow` with `transfer` auto and then full: both give the local result, step by
/// step, and move data between hosts as the mode says.
async fn run_both_ways(cluster: &Cluster, workflow: &Json, input: &Input, expected: &Trace) {
    run_in_modes(cluster, workflow, input, expected, &["auto", "full"]).await;
}

async fn run_in_modes(
    cluster: &Cluster,
    workflow: &Json,
    input: &Input,
    expected: &Trace,
    modes: &[&str],
) {
    let url = cluster.upload(input).await;
    for &mode in modes {
        let mut workflow = workflow.clone();
        workflow["transfer"] = mode.into();
        let id = cluster.submit(&workflow, &url).await;
        let record = cluster.finished(&id).await;
        assert_eq!(record["status"], "completed", "{mode}: {}", record["error"]);
        assert_eq!(executed(&record), expected.steps, "{mode}: steps and their outcomes");
        assert_eq!(text(&record["result"]["hash"]), expected.hash(), "{mode}");
        assert_eq!(cluster.result(&id).await.content_hash().to_hex(), expected.hash(), "{mode}");
        assert_transfers(&record, mode);
    }
}

/// The input reached every host of the plan once; afterwards each filter's result went, as
/// `mode` says (`full` mesh, `replay`, or in `auto` the way the cost model chose, whose
/// estimates are recorded), to every other host that ran a later step, and to no host
/// outside the plan. Every edit log's real size replaced the producer's estimate.
fn assert_transfers(record: &Json, mode: &str) {
    let loads: Vec<&str> =
        record["broadcast"]["hosts"].as_array().unwrap().iter().map(|h| text(&h["host"])).collect();
    let plan: BTreeSet<&str> = loads.iter().copied().collect();
    assert_eq!(plan.len(), loads.len(), "one input load per host: {loads:?}");
    let steps = steps(record);
    let workers: BTreeSet<&str> = steps.iter().map(|s| text(&s["host"])).collect();
    assert!(workers.is_subset(&plan), "steps ran on {workers:?}, the input went to {plan:?}");
    // Only code moving to the data (a planned host still re-running the step before, in a
    // slow build) keeps a run on one host; the planned hosts still take every result.
    let moved = steps.iter().any(|s| !s["moved"].is_null());
    assert!(workers.len() >= 2 || moved, "the run stayed on {workers:?}");
    for (index, step) in steps.iter().enumerate().filter(|(_, s)| s["kind"] == "filter") {
        let transfers = step["transfers"].as_array().unwrap();
        let receivers: BTreeSet<&str> = transfers.iter().map(|t| text(&t["host"])).collect();
        let producer = text(&step["host"]);
        let later: BTreeSet<&str> = steps[index + 1..]
            .iter()
            .map(|s| text(&s["host"]))
            .filter(|h| *h != producer)
            .collect();
        assert!(
            later.is_subset(&receivers),
            "{}: sent to {receivers:?}, needed on {later:?}",
            step["path"]
        );
        assert!(receivers.is_subset(&plan) && !receivers.contains(producer), "{receivers:?}");
        for transfer in transfers {
            let asked = text(&transfer["asked"]);
            if mode == "auto" {
                assert!(transfer["estimates"]["replay_ms"].as_f64().unwrap() > 0.0, "{transfer}");
            } else {
                assert_eq!(asked, mode, "{}: {transfer}", step["path"]);
            }
            assert_eq!(transfer["via"], asked, "{}: {transfer}", step["path"]);
            assert_eq!((&transfer["error"], &transfer["fallback"]), (&Json::Null, &Json::Null));
            if transfer["via"] == "correction" {
                assert_eq!(transfer["bytes"], step["correction_bytes"], "{}", step["path"]);
            }
        }
        assert_eq!(step["correction_estimated"], false, "{step}");
        // The estimate the engine chose by stays beside the real size; a small step's
        // log is encoded before its answer, so its "estimate" is its size.
        let estimate = step["correction_estimate_bytes"].as_u64().unwrap();
        if step["edits"].as_u64().unwrap() <= 20_000 {
            assert_eq!(Some(estimate), step["correction_bytes"].as_u64(), "{step}");
        }
        if mode == "full" && !transfers.is_empty() {
            assert!(step["full_bytes"].as_u64().unwrap() > 0, "{step}");
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn repair_gives_the_local_result_by_corrections_replays_or_full_meshes() {
    let cluster = Cluster::start(SPREAD).await;
    let (workflow, input) = (example("repair"), Input::bunny());
    let expected = locally(&workflow, &input);
    // Replays run each step again on hosts that lack its plugin: they fetch it.
    let modes = ["auto", "correction", "replay", "full"];
    run_in_modes(&cluster, &workflow, &input, &expected, &modes).await;
}

/// `"quantize": 12` keeps the run on a grid over the input's bounding box: the hosts snap
/// the input and every step's result, replays included, exactly as the local chain does.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_quantised_workflow_keeps_every_step_on_the_grid_as_locally() {
    let cluster = Cluster::start(SPREAD).await;
    let (mut workflow, input) = (example("repair"), Input::bunny());
    workflow["quantize"] = 12.into();
    let expected = locally(&workflow, &input);
    let grid = expected.grid.expect("the local chain keeps a grid");
    assert!(grid.holds(&expected.mesh.positions));
    assert_ne!(expected.hash(), locally(&example("repair"), &input).hash());
    run_in_modes(&cluster, &workflow, &input, &expected, &["auto", "replay"]).await;

    workflow["quantize"] = 25.into();
    let url = cluster.upload(&input).await;
    let body = json!({"workflow": workflow, "input": url}).to_string();
    let (status, answer) = cluster.post_run(body).await;
    assert_eq!(status, 400, "{answer}");
    assert!(answer["error"]["message"].as_str().unwrap().contains("quantize"), "{answer}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn smoothing_while_unstable_runs_as_many_rounds_as_locally() {
    let cluster = Cluster::start(SPREAD).await;
    let (workflow, input) = (example("smooth-while-unstable"), Input::bunny());
    let expected = locally(&workflow, &input);
    let rounds = expected.count("steps[1].do[0]");
    assert!(rounds > 1, "the example should take several rounds, took {rounds}");
    assert_eq!(expected.capped_whiles, 0);
    // Step by step equality includes the number of rounds.
    run_both_ways(&cluster, &workflow, &input, &expected).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn branch_on_manifold_takes_either_branch_as_the_input_needs() {
    let cluster = Cluster::start(SPREAD).await;
    let workflow = example("branch-on-manifold");
    let local = Local::new(&components_cache());
    for (input, manifold, branch) in [
        (Input::bunny(), true, "steps[0].then[0]"),
        (Input::scan(20_000, 5), false, "steps[0].else[0]"),
    ] {
        assert_eq!(local.check("is-manifold", &input.mesh), manifold, "{}", input.name);
        let expected = locally(&workflow, &input);
        assert_eq!(expected.count(branch), 1, "{}", input.name);
        run_both_ways(&cluster, &workflow, &input, &expected).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_plugin_uploaded_to_a_host_joins_the_catalogue_and_runs_in_a_workflow() {
    let cluster = Cluster::start(&[&["smoothing", "checks"], &["holes"]]).await;
    let service = "remove-smallest-components";
    let workflow = json!([{"run": service}, {"run": "laplacian-smoothing"}]);
    let input = Input::scan(20_000, 8);
    let url = cluster.upload(&input).await;
    let (status, refused) =
        cluster.post_run(json!({"workflow": workflow, "input": url}).to_string()).await;
    assert_eq!(status, 400, "{refused}");
    assert!(text(&refused["error"]["message"]).contains("steps[0]"), "{refused}");

    let uploader = &cluster.hosts[1].url;
    let uploaded = HostClient::new(uploader)
        .upload_plugin(builtin("cleanup").to_vec(), Some(TOKEN), false)
        .await
        .unwrap();
    assert!(uploaded.services.iter().any(|s| s.name == service));
    let registered = cluster.register(uploader).await;
    assert_eq!(registered.status(), 201);
    let services = cluster.services().await;
    let offer = services.as_array().unwrap().iter().find(|s| s["name"] == service);
    assert_eq!(offer.map(|o| &o["hosts"]), Some(&json!([uploader])), "{services:#}");

    let expected = locally(&workflow, &input);
    let record = cluster.run(&workflow, &url).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(steps(&record)[0]["host"], json!(uploader));
    assert_eq!(steps(&record)[0]["plugin"], json!(uploaded.digest));
    assert_eq!(text(&record["result"]["hash"]), expected.hash());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_killed_mid_run_leaves_the_run_to_another_host() {
    // Killed as soon as it has produced a result: it is the only host that holds it.
    killed_mid_run(&[], |_| true).await;
}

/// As above, with the checks on a host of their own, which follows every result: killed
/// once that host holds the result too.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_killed_mid_run_is_replaced_from_a_host_that_follows_the_run() {
    let followed = |step: &Json| {
        let transfers = step["transfers"].as_array().unwrap();
        !transfers.is_empty() && transfers.iter().all(|t| t["error"].is_null())
    };
    killed_mid_run(&[&["checks"]], followed).await;
}

/// Three `meshflow host` processes offering everything, after in-process hosts offering
/// `families`; the host that produced the first result is killed (SIGKILL) once
/// `kill_when` holds for that step, while the run goes on; the run must still end with the
/// local result.
async fn killed_mid_run(families: &[&[&str]], kill_when: impl Fn(&Json) -> bool) {
    let data = tempfile::tempdir().unwrap();
    let mut hosts = Vec::new();
    for name in ["a", "b", "c"] {
        hosts.push(HostProcess::start(&data.path().join(name), &[]).await);
    }
    let urls: Vec<String> = hosts.iter().map(|h| h.url.clone()).collect();
    let cluster = Cluster::start_with(families, &urls).await;
    // Long enough to be caught in the middle: rounds of smoothing on a larger scan.
    let workflow = json!([{
        "while": {"check": "vertex-count", "op": ">", "value": 0},
        "do": [{"run": "laplacian-smoothing", "params": {"iterations": 2}}],
        "max-iterations": 8
    }]);
    let input = Input::scan(150_000, 13);
    let expected = locally(&workflow, &input);
    let id = cluster.submit(&workflow, &cluster.upload(&input).await).await;

    let produced = |record: &Json| {
        steps(record).iter().find(|s| s["kind"] == "filter").filter(|step| kill_when(step)).cloned()
    };
    let record = cluster.under_way_until(&id, |record| produced(record).is_some()).await;
    let victim = text(&produced(&record).unwrap()["host"]).to_owned();
    let done = steps(&record).len();
    hosts.iter_mut().find(|h| h.url == victim).unwrap().kill();

    assert!(done < expected.steps.len(), "the run was over before the kill");
    let record = cluster.finished(&id).await;
    assert_eq!(record["status"], "completed", "after killing {victim}: {}", record["error"]);
    let failed = |s: &Json| s["failed_hosts"].as_array().unwrap().contains(&json!(victim));
    assert!(steps(&record).iter().any(failed), "no step records {victim} as failed");
    assert_ne!(steps(&record).last().unwrap()["host"], json!(victim));
    assert_eq!(executed(&record), expected.steps);
    assert_eq!(text(&record["result"]["hash"]), expected.hash());
}

/// The only host holding the run's mesh dies, and the host left cannot rebuild it: it lacks
/// a service the run used. The run fails saying so; the engine serves the next run.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_lost_mesh_that_cannot_be_rebuilt_fails_the_run_clearly() {
    let data = tempfile::tempdir().unwrap();
    let mut holder = HostProcess::start(data.path(), &["cleanup", "smoothing", "checks"]).await;
    let cluster = Cluster::start_with(&[&["smoothing", "checks"]], &[holder.url.clone()]).await;
    let smoothing = json!({"run": "laplacian-smoothing", "params": {"iterations": 2}});
    // Every task prefers the host already in the plan: all run on the holder.
    let workflow = json!([
        {"run": "remove-smallest-components"},
        {"while": {"check": "vertex-count", "op": ">", "value": 0}, "do": [smoothing],
         "max-iterations": 8}
    ]);
    let url = cluster.upload(&Input::scan(150_000, 13)).await;
    let id = cluster.submit(&workflow, &url).await;
    let smoothed =
        |record: &Json| steps(record).iter().any(|s| s["service"] == "laplacian-smoothing");
    cluster.under_way_until(&id, smoothed).await;
    holder.kill();

    let record = cluster.finished(&id).await;
    assert_eq!(record["status"], "failed", "{record:#}");
    let error = text(&record["error"]);
    let replacement = &cluster.hosts[0].url;
    assert!(
        error.contains(replacement.as_str())
            && error.contains("cannot rebuild it from the input")
            && error.contains("does not offer remove-smallest-components"),
        "{error}"
    );
    let smooth_only = json!([smoothing]);
    let bunny = Input::bunny();
    let after = cluster.run(&smooth_only, &cluster.upload(&bunny).await).await;
    assert_eq!(after["status"], "completed", "{}", after["error"]);
    assert_eq!(text(&after["result"]["hash"]), locally(&smooth_only, &bunny).hash());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn twenty_concurrent_runs_on_three_hosts_agree() {
    let cluster = Cluster::start(SPREAD).await;
    let (workflow, input) = (example("repair"), Input::bunny());
    let expected = locally(&workflow, &input);
    let url = cluster.upload(&input).await;
    let ids =
        futures_util::future::join_all((0..20).map(|_| cluster.submit(&workflow, &url))).await;
    assert_eq!(ids.iter().collect::<BTreeSet<_>>().len(), 20, "run ids are unique");
    let records = futures_util::future::join_all(ids.iter().map(|id| cluster.finished(id))).await;
    for record in &records {
        assert_eq!(record["status"], "completed", "{}", record["error"]);
        assert_eq!(text(&record["result"]["hash"]), expected.hash());
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn workflows_that_do_not_parse_or_fit_the_catalogue_are_refused_naming_the_step() {
    let cluster = Cluster::start(SPREAD).await;
    let url = cluster.upload(&Input::bunny()).await;
    let (status, answer) = cluster.post_run("{\"workflow\": [").await;
    assert_eq!((status, &answer["error"]["code"]), (400, &json!("bad-json")), "{answer}");

    let refusals = [
        (json!([{"run": "fill-holes"}, {"run": "no-such-service"}]), "steps[1]", "no-such-service"),
        (
            json!([{"run": "fill-holes"}, {"run": "laplacian-smoothing", "params": {"iterations": "many"}}]),
            "steps[1]",
            "iterations",
        ),
        (json!([{"run": "fill-holes"}, {"run": "is-manifold"}]), "steps[1]", "is a check"),
        (
            json!([{"run": "fill-holes"}, {
                "while": {"check": "normal-instability", "op": ">", "value": 1.0},
                "do": [{"run": "hole-count"}]
            }]),
            "steps[1].do[0]",
            "is a check",
        ),
    ];
    for (workflow, path, reason) in refusals {
        let (status, answer) =
            cluster.post_run(json!({"workflow": workflow, "input": url}).to_string()).await;
        let message = text(&answer["error"]["message"]);
        assert_eq!(status, 400, "{answer}");
        assert!(message.starts_with(path) && message.contains(reason), "{message}");
    }
    let runs: Json =
        cluster.http.get(cluster.url("/runs")).send().await.unwrap().json().await.unwrap();
    assert_eq!(runs, json!([]), "a refused workflow leaves no run behind");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn inputs_that_cannot_be_fetched_or_read_fail_the_run_clearly() {
    let closed_origin = {
        let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
        format!("http://{}", listener.local_addr().unwrap())
    };
    let cluster = Cluster::start_allowing(SPREAD, &[], std::slice::from_ref(&closed_origin)).await;
    let workflow = example("repair");
    let closed = format!("{closed_origin}/scan.ply");
    let not_a_mesh =
        Input { name: "notes.ply", bytes: b"shopping list\n".to_vec(), mesh: Default::default() };
    let uploaded = cluster.upload(&not_a_mesh).await;
    for (input, reason) in [(closed, "Connection refused"), (uploaded, "not a PLY file")] {
        let record = cluster.run(&workflow, &input).await;
        assert_eq!(record["status"], "failed", "{record:#}");
        let error = text(&record["error"]);
        assert!(error.contains(&input) && error.contains(reason), "{error}");
        assert!(steps(&record).is_empty(), "{record:#}");
        assert_eq!(record["result"], Json::Null);
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_failing_plugin_fails_its_run_naming_the_step_and_other_runs_carry_on() {
    let cluster = Cluster::start(SPREAD).await;
    let hostile = meshflow_builtin_plugins::fixture("hostile").to_vec();
    let host = &cluster.hosts[0].url;
    HostClient::new(host).upload_plugin(hostile, Some(TOKEN), false).await.unwrap();
    cluster.register(host).await;
    let input = Input::bunny();
    let url = cluster.upload(&input).await;
    let repair = example("repair");
    let expected = locally(&repair, &input);

    let failing = ["fail", "trap"].map(|service| {
        json!([{"run": "remove-smallest-components"}, {"run": service}, {"run": "fill-holes"}])
    });
    let runs = [&failing[0], &failing[1], &repair].map(|workflow| cluster.run(workflow, &url));
    let [fail, trap, good] = futures_util::future::join_all(runs).await.try_into().unwrap();
    for (record, service) in [(fail, "fail"), (trap, "trap")] {
        assert_eq!(record["status"], "failed", "{record:#}");
        let error = text(&record["error"]);
        assert!(error.starts_with("steps[1]") && error.contains(service), "{error}");
        assert_eq!(steps(&record).len(), 1, "nothing ran after the failed step");
    }
    assert_eq!(good["status"], "completed", "{}", good["error"]);
    assert_eq!(text(&good["result"]["hash"]), expected.hash());
    // The host is not blamed for its plugin: it stays in service.
    let hosts: Json =
        cluster.http.get(cluster.url("/hosts")).send().await.unwrap().json().await.unwrap();
    assert!(hosts.as_array().unwrap().iter().all(|h| h["up"] == true), "{hosts:#}");
    let after = cluster.run(&repair, &url).await;
    assert_eq!(text(&after["result"]["hash"]), expected.hash());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_while_that_stays_true_stops_at_max_iterations_with_a_warning() {
    let cluster = Cluster::start(SPREAD).await;
    let workflow = json!([{
        "while": {"check": "vertex-count", "op": ">", "value": 0},
        "do": [{"run": "laplacian-smoothing"}],
        "max-iterations": 3
    }]);
    let input = Input::bunny();
    let expected = locally(&workflow, &input);
    assert_eq!((expected.count("steps[0].do[0]"), expected.capped_whiles), (3, 1));
    let record = cluster.run(&workflow, &cluster.upload(&input).await).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(executed(&record), expected.steps);
    assert_eq!(text(&record["result"]["hash"]), expected.hash());
    let warnings = record["warnings"].as_array().unwrap();
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    let warning = text(&warnings[0]);
    assert!(warning.starts_with("steps[0]") && warning.contains("max-iterations = 3"), "{warning}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn host_registrations_that_are_not_host_urls_are_refused() {
    let cluster = Cluster::start(&[&["checks"]]).await;
    for bad in ["not a url at all", "file:///etc/passwd", "http://user:pw@127.0.0.1:1/"] {
        let answer = cluster.register(bad).await;
        assert_eq!(answer.status(), 400, "{bad}");
        let body: Json = answer.json().await.unwrap();
        assert_eq!(body["error"]["code"], "bad-url", "{bad}: {body}");
    }
    let hosts: Json =
        cluster.http.get(cluster.url("/hosts")).send().await.unwrap().json().await.unwrap();
    assert_eq!(hosts.as_array().map(Vec::len), Some(1), "{hosts}");
}

/// A host answer for a smoothing step on `input_hash`, as `laplacian-smoothing` would give
/// one, claiming the result `output_hash` at `full_url`.
fn claimed_filter(
    input_hash: &str,
    output_hash: &str,
    full_url: &str,
    correction_url: &str,
) -> Json {
    json!({
        "kind": "filter", "service": "laplacian-smoothing", "plugin": "e".repeat(64),
        "input_hash": input_hash, "output_hash": output_hash, "vertices": 1839,
        "triangles": 3674, "edits": 1839, "compute_ms": 1.0, "queue_ms": 0.0, "report": "",
        "correction": {"url": correction_url, "bytes": 100},
        "replay": {"url": correction_url.replace(".mfc", ".mfr"), "bytes": 150},
        "full": {"url": full_url, "hash": output_hash}
    })
}

/// A real host offering smoothing, and its `GET /services` for a fake to copy.
async fn smoothing_host(data: &Path) -> (HostHandle, Json) {
    let host = common::start_hosts(&[&["smoothing"]], data, &[]).await.remove(0);
    let client = HostClient::new(&host.url).with_token(common::CLUSTER_TOKEN);
    let services = client.services().await.unwrap();
    (host, json!(services))
}

/// `GET /hosts` entry of the host at `url`.
async fn host_entry(cluster: &Cluster, url: &str) -> Json {
    let hosts: Json =
        cluster.http.get(cluster.url("/hosts")).send().await.unwrap().json().await.unwrap();
    hosts.as_array().unwrap().iter().find(|h| h["url"] == url).cloned().expect("the host")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_whose_answers_cannot_be_true_is_suspect_and_its_step_moves_to_a_real_host() {
    let data = tempfile::tempdir().unwrap();
    let (real, services) = smoothing_host(data.path()).await;
    let input = Input::bunny();
    let hash = input.mesh.content_hash().to_hex();
    // The issue's fake: a hash that is none, its result on another origin, absurd counts.
    let mut lie = claimed_filter(
        &hash,
        "not-a-hash",
        "http://evil.example/r.mfm",
        "http://evil.example/r.mfc",
    );
    lie["vertices"] = json!(123_456_789);
    let fake = FakeHost::start(|_| Script {
        services,
        session: (hash.clone(), 1839, 3674),
        run: lie,
        blobs: Default::default(),
    })
    .await;
    let workflow = json!([{"run": "laplacian-smoothing"}]);

    // Registered first, the fake gets the step; its answer is refused, the step moves on.
    let cluster = Cluster::start_with(&[], &[fake.url.clone(), real.url.clone()]).await;
    let url = cluster.upload(&input).await;
    let id = cluster.submit(&workflow, &url).await;
    let record = cluster.finished(&id).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(fake.runs(), 1, "the plan did not try the fake");
    let step = &steps(&record)[0];
    assert_eq!(
        (text(&step["host"]), &step["failed_hosts"]),
        (real.url.as_str(), &json!([fake.url]))
    );
    let expected = locally(&workflow, &input).hash();
    assert_eq!(text(&record["result"]["hash"]), expected);
    assert_eq!(cluster.result(&id).await.content_hash().to_hex(), expected);
    let suspect = host_entry(&cluster, &fake.url).await["suspect"].clone();
    assert!(text(&suspect).contains(r#"output_hash "not-a-hash""#), "{suspect}");
    assert_eq!(host_entry(&cluster, &real.url).await["suspect"], Json::Null);
    // A suspect host is planned on no more.
    let again = cluster.run(&workflow, &url).await;
    assert_eq!(again["status"], "completed", "{}", again["error"]);
    assert_eq!(fake.runs(), 1, "the suspect host was asked again");

    // With no one else to turn to, the run fails, naming the host and what it claimed.
    let alone = Cluster::start_with(&[], std::slice::from_ref(&fake.url)).await;
    let record = alone.run(&workflow, &alone.upload(&input).await).await;
    let error = text(&record["error"]);
    assert_eq!(record["status"], "failed");
    assert!(error.contains(&fake.url) && error.contains("not a content hash"), "{error}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn submit_refuses_a_result_that_is_not_the_recorded_mesh_and_writes_nothing() {
    let data = tempfile::tempdir().unwrap();
    let (_real, services) = smoothing_host(data.path()).await;
    // A consistent liar: every claim well formed, but the mesh it serves is another one.
    let claimed = "b".repeat(64);
    let served = meshflow_codec::pack::encode(&Input::bunny().mesh).unwrap();
    let raw = raw_of(&Input::bunny().mesh);
    let fake = FakeHost::start(|me| Script {
        services,
        session: ("a".repeat(64), 1839, 3674),
        run: claimed_filter(
            &"a".repeat(64),
            &claimed,
            &format!("{me}/blobs/{claimed}.mfm"),
            &format!("{me}/blobs/{}.mfc", "c".repeat(64)),
        ),
        blobs: [(format!("{claimed}.mfm"), served.clone()), (format!("{claimed}.raw"), raw)].into(),
    })
    .await;
    let never_fetched = "http://127.0.0.1:9".to_owned();
    let cluster =
        Cluster::start_allowing(&[], std::slice::from_ref(&fake.url), &[never_fetched]).await;
    let workflow = data.path().join("smooth.json");
    std::fs::write(&workflow, r#"[{"run": "laplacian-smoothing"}]"#).unwrap();
    let output = data.path().join("result.ply");
    let engine = cluster.engine.url.clone();
    let args = [
        "submit",
        "--engine",
        &engine,
        workflow.to_str().unwrap(),
        "--input",
        "http://127.0.0.1:9/never-fetched.obj",
        "-o",
        output.to_str().unwrap(),
    ]
    .map(str::to_owned);
    let ran = tokio::task::spawn_blocking(move || {
        let mut submit = std::process::Command::new(env!("CARGO_BIN_EXE_meshflow"));
        submit.args(args).env("MESHFLOW_API_TOKEN", common::API_TOKEN).output().unwrap()
    })
    .await
    .unwrap();
    let stderr = String::from_utf8_lossy(&ran.stderr);
    assert!(!ran.status.success(), "submit took the fake's mesh: {stderr}");
    // The engine hashes the fake's raw arrays before serving any format (502 hash-mismatch);
    // were a mesh to get past it, the CLI checks it once more ("not the recorded").
    let refused = stderr.contains("hash-mismatch") || stderr.contains("not the recorded");
    assert!(refused && stderr.contains(&claimed), "{stderr}");
    assert!(!output.exists(), "a file was written");
    assert_eq!(fake.runs(), 1);
    // The viewer's raw arrays the engine hashes itself, and refuses.
    let runs: serde_json::Value =
        cluster.http.get(cluster.url("/runs")).send().await.unwrap().json().await.unwrap();
    let id = text(&runs[0]["id"]);
    let answer = cluster.http.get(cluster.url(&format!("/runs/{id}/result?format=raw"))).send();
    let answer = answer.await.unwrap();
    assert_eq!(answer.status(), 502);
    let body: serde_json::Value = answer.json().await.unwrap();
    assert_eq!(body["error"]["code"], "hash-mismatch", "{body}");
}

/// A mesh as the `raw` format (`meshflow_api::raw_mesh`).
fn raw_of(mesh: &meshflow_mesh::MeshData) -> Vec<u8> {
    let mut raw = meshflow_api::raw_mesh::MAGIC.to_vec();
    raw.extend((mesh.vertex_count() as u32).to_le_bytes());
    raw.extend((mesh.triangle_count() as u32).to_le_bytes());
    raw.extend(mesh.positions.iter().flat_map(|v| v.to_le_bytes()));
    raw.extend(mesh.triangles.iter().flat_map(|v| v.to_le_bytes()));
    raw
}

/// A smoothing step that one host runs on partitions (issue 33) reaches the hosts after it
/// as its edit log and as a replay they run whole, and every way gives the local,
/// whole-mesh result: partitioning is the host's business, not the result's.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_step_run_on_partitions_gives_hosts_that_run_it_whole_the_same_hash() {
    let cut = Limits { max_partition_triangles: Some(4_000), ..Limits::default() };
    let cluster =
        Cluster::start_with_limits(
            SPREAD,
            |i| if i == 0 { cut.clone() } else { Limits::default() },
        )
        .await;
    let input = Input::scan(25_000, 11);
    let workflow = example("repair");
    let expected = locally(&workflow, &input);
    run_in_modes(&cluster, &workflow, &input, &expected, &["correction", "replay"]).await;
    let id = cluster.submit(&workflow, &cluster.upload(&input).await).await;
    let record = cluster.finished(&id).await;
    let smoothing = steps(&record).iter().find(|s| s["service"] == "laplacian-smoothing").unwrap();
    assert_eq!(text(&smoothing["host"]), cluster.hosts[0].url, "{smoothing}");
    assert!(text(&smoothing["report"]).contains("partitions"), "{smoothing}");
}

/// Degenerate repair on a manifold mesh, else removing small components: a test and a
/// filter after the step before them.
fn repair_if_manifold() -> Json {
    json!({
        "if": {"check": "is-manifold", "op": "==", "value": true},
        "then": [{"run": "remove-degenerate-triangles"}],
        "else": [{"run": "remove-smallest-components"}]
    })
}

/// Code moves to the data (issue 34 item 3): after a long smoothing step, the WHILE test
/// planned on another host runs on the smoothing host instead, its plugin fetched there,
/// because the other host would first have to re-run the smoothing; its later rounds decide
/// again with the same plugin. The result is the local one, and the record says where the step was planned and
/// why it moved. A host started with `--no-foreign-plugins` is never moved to: then the run
/// keeps its plan.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_step_runs_where_the_mesh_is_when_bringing_the_mesh_over_would_take_longer() {
    let workflow = json!({
        "steps": [
            {"run": "taubin-smoothing", "params": {"iterations": 1000}},
            {
                "while": {"check": "vertex-count", "op": ">", "value": 0},
                "do": [{"run": "laplacian-smoothing"}],
                "max-iterations": 2
            },
            repair_if_manifold()
        ],
        "transfer": "replay"
    });
    let input = Input::scan(120_000, 21);
    let expected = locally(&workflow, &input);
    for foreign in [true, false] {
        let data = tempfile::tempdir().unwrap();
        let hosts = common::start_hosts_configured(
            &[&["smoothing"], &["checks", "cleanup"]],
            data.path(),
            |i, config| config.foreign_plugins = foreign || i != 0,
        )
        .await;
        let cluster = Cluster::around(hosts, data).await;
        let (smoothing, other) = (cluster.hosts[0].url.clone(), cluster.hosts[1].url.clone());
        let id = cluster.submit(&workflow, &cluster.upload(&input).await).await;
        let record = cluster.finished(&id).await;
        assert_eq!(record["status"], "completed", "{}", record["error"]);
        assert_eq!(executed(&record), expected.steps);
        assert_eq!(text(&record["result"]["hash"]), expected.hash());
        let steps = steps(&record);
        let smoothed = steps[0]["compute_ms"].as_f64().unwrap();
        assert!(smoothed > 1_000.0, "the smoothing must outlast a plugin's fetch: {smoothed} ms");
        let checks: Vec<&Json> =
            steps.iter().filter(|s| s["path"] == "steps[1].while.check").collect();
        assert_eq!(checks.len(), 3, "two rounds and the last test");
        match foreign {
            true => {
                // The first test would have waited for the Taubin step's replay: it moved.
                let moved = &checks[0]["moved"];
                assert_eq!(
                    (text(&checks[0]["host"]), text(&moved["planned"])),
                    (&*smoothing, &*other)
                );
                assert!(text(&moved["why"]).contains("holds the current mesh"), "{moved}");
                // Each later round decides again (the other host keeps taking the results:
                // it is still re-running the Taubin step): where the mesh is, the same plugin.
                for check in &checks[1..] {
                    let here = text(&check["host"]) == smoothing;
                    assert_eq!(here, !check["moved"].is_null(), "{check}");
                    assert_eq!(check["plugin"], checks[0]["plugin"], "{check}");
                }
            }
            false => {
                for step in steps.iter().filter(|s| s["kind"] == "check") {
                    assert_eq!(text(&step["host"]), other, "{step}");
                }
                assert!(steps.iter().all(|s| s["moved"].is_null()), "{steps:#?}");
            }
        }
    }
}

/// What the engine remembers of a host's fetched plugins is a hint, not a fact (a host that
/// restarted has lost them), and a learned step shape only decides what is prefetched: a
/// run whose prefetches were judged needless — the smoothing's shape, planted here, says
/// its replay is quick — still moves its test to the data once the replay turns out long,
/// and asks that host for the test's plugin first, though the engine believes it is there.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_move_to_the_data_asks_for_its_plugin_whatever_the_engine_remembers() {
    use meshflow_engine::measured::{StepShape, step_key};
    let smoothing = json!({"run": "taubin-smoothing", "params": {"iterations": 1000}});
    let workflow = json!({
        "steps": [
            smoothing,
            repair_if_manifold()
        ],
        "transfer": "replay"
    });
    let input = Input::scan(120_000, 21);
    let expected = locally(&workflow, &input);
    let cluster = Cluster::start(&[&["smoothing"], &["checks", "cleanup"]]).await;
    let (holder, other) = (cluster.hosts[0].url.clone(), cluster.hosts[1].url.clone());
    let measured = &cluster.engine.engine.registry.measured;
    for family in ["checks", "cleanup"] {
        measured.prefetched(&holder, &meshflow_runtime::digest(builtin(family)));
    }
    let quick = StepShape {
        correction_bytes_per_vertex: 0.0,
        full_bytes_per_vertex: 0.0,
        edits_per_vertex: 0.0,
        compute_ms_per_vertex: 0.0,
        replay_bytes: 0.0,
    };
    let params = smoothing["params"].as_object().unwrap();
    let digest = meshflow_runtime::digest(builtin("smoothing"));
    measured.learn_step(&step_key(&digest, "taubin-smoothing", params), quick);

    let record = cluster.run(&workflow, &cluster.upload(&input).await).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(executed(&record), expected.steps);
    assert_eq!(text(&record["result"]["hash"]), expected.hash());
    // The other host gets the smoothing to replay (the workflow asks for replays); the
    // smoothing host, judged not to need the test's plugin, is asked nothing up front.
    let asked = record["prefetches"].as_array().unwrap();
    assert!(asked.iter().all(|p| p["host"] != holder.as_str()), "{asked:#?}");
    let test = steps(&record).iter().find(|s| s["path"] == "steps[1].if.check").unwrap();
    assert_eq!((text(&test["host"]), text(&test["moved"]["planned"])), (&*holder, &*other));
}

/// A scan whose every vertex has its own colour (its index in red, green and blue) and a
/// quality: the repair keeps both through every way a result travels. Vertices that
/// survive keep their values bit for bit and their order; new ones come after them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn colours_and_quality_survive_the_repair_by_corrections_replays_and_full_meshes() {
    use meshflow_mesh::attributes::{Attribute, Domain, Values};
    let cluster = Cluster::start(SPREAD).await;
    let mut mesh = Input::scan(6_000, 7).mesh;
    let n = mesh.vertex_count();
    let colour = |v: usize| [(v >> 16) as u8, (v >> 8) as u8, v as u8, 255];
    let quality: Vec<f32> = (0..n).map(|v| (v as f32).sqrt()).collect();
    mesh.attributes
        .insert(Attribute::color((0..n).flat_map(colour).collect()), n, mesh.triangle_count())
        .unwrap();
    mesh.attributes.insert(Attribute::quality(quality.clone()), n, mesh.triangle_count()).unwrap();
    let mut bytes = Vec::new();
    meshflow_meshio::write_to(&mut bytes, &mesh, meshflow_meshio::Format::Ply).unwrap();
    let input = Input { name: "coloured.ply", bytes, mesh };
    assert_eq!(
        meshflow_meshio::load_bytes(&input.bytes, meshflow_meshio::Format::Ply, "c.ply").unwrap(),
        input.mesh,
        "PLY keeps colour and quality"
    );
    let workflow = example("repair");
    let expected = locally(&workflow, &input);
    run_in_modes(&cluster, &workflow, &input, &expected, &["auto", "correction", "replay", "full"])
        .await;

    let id = cluster.submit(&workflow, &cluster.upload(&input).await).await;
    let record = cluster.finished(&id).await;
    let result = cluster.result(&id).await;
    let Some(Values::U8(colours)) =
        result.attributes.get(Domain::Vertex, "color").map(|a| a.values.clone())
    else {
        panic!("the result lost its colours: {:?}", result.attributes.describe());
    };
    let Some(Values::F32(kept_quality)) =
        result.attributes.get(Domain::Vertex, "quality").map(|a| a.values.clone())
    else {
        panic!("the result lost its quality");
    };
    // A survivor's colour names its input vertex and its quality is that vertex's, bit for
    // bit; a vertex the repair made comes after the survivors, with a blend of its parents'
    // values. That blend may be one input vertex's exactly (fill-holes gives a vertex whose
    // only neighbour nearer the hole's boundary is one boundary vertex that vertex's
    // values), so a survivor is the first vertex to name its input vertex.
    let mut named = vec![false; n];
    let survivors: Vec<usize> = colours
        .chunks_exact(4)
        .zip(&kept_quality)
        .filter_map(|(c, q)| {
            let index = (usize::from(c[0]) << 16) | (usize::from(c[1]) << 8) | usize::from(c[2]);
            let first = index < n && !std::mem::replace(&mut named[index], true);
            (first && q.to_bits() == quality[index].to_bits()).then_some(index)
        })
        .collect();
    assert!(survivors.windows(2).all(|w| w[0] < w[1]), "survivors keep their order");
    let survivors = survivors.len();
    assert!(survivors > n * 9 / 10, "{survivors} of {n} input vertices recognised");
    assert!(survivors < result.vertex_count(), "fill-holes made vertices");
    // Every colour blends the input's, whose red is 0: none is the default white.
    assert!(colours.chunks_exact(4).all(|c| c[0] == 0 && c[3] == 255));
    let carried = record["steps"].as_array().unwrap().last().unwrap()["attributes"].to_string();
    assert!(carried.contains("vertex color") && carried.contains("vertex quality"), "{carried}");
}

/// The first task starts on its host as soon as that host holds the input: a host whose
/// load ends 1.5 s later (behind a proxy that says its session is ready only then) does not
/// hold it back, and still takes the first step's result and runs the second to the local
/// result.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_first_task_starts_while_a_slower_host_still_loads_the_input() {
    use common::proxy::{Lies, start_proxy};
    let workflow = json!({"steps": [
        {"run": "laplacian-smoothing", "params": {"iterations": 2}},
        {"run": "remove-degenerate-triangles"}
    ], "transfer": "correction"});
    let input = Input::scan(20_000, 5);
    let expected = locally(&workflow, &input);
    let data = tempfile::tempdir().unwrap();
    let cleanup = common::start_hosts(&[&["cleanup"]], data.path(), &[]).await;
    let slow = Lies { slow_ready: Some(std::time::Duration::from_millis(1500)), ..Lies::default() };
    let (slow_url, _proxy) = start_proxy(&cleanup[0].url, slow).await;
    let cluster = Cluster::start_with(&[&["smoothing"]], std::slice::from_ref(&slow_url)).await;
    let id = cluster.submit(&workflow, &cluster.upload(&input).await).await;
    let record = cluster.finished(&id).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(executed(&record), expected.steps);
    assert_eq!(text(&record["result"]["hash"]), expected.hash());
    let broadcast_ms = record["broadcast"]["ms"].as_f64().unwrap();
    assert!(broadcast_ms >= 1_500.0, "{broadcast_ms} ms");
    let steps = steps(&record);
    assert_eq!(text(&steps[0]["host"]), cluster.hosts[0].url);
    assert_eq!(text(&steps[1]["host"]), slow_url);
    let smoothing_started = steps[0]["started_ms"].as_f64().unwrap();
    assert!(
        smoothing_started + 1_000.0 < broadcast_ms,
        "the smoothing started at {smoothing_started} ms, the broadcast ended at {broadcast_ms} ms"
    );
}
