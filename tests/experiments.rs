//! Experiments (issue 16) end to end: plugin versions on a host, pinned steps, exact
//! re-runs and batches, on an engine and in-process hosts over real HTTP.

mod common;

use common::local::Local;
use common::{Cluster, Input, TOKEN, components_cache, executed, steps, text};
use meshflow_engine::workflow::Workflow;
use serde_json::{Value as Json, json};

fn smoothing_v2() -> Vec<u8> {
    meshflow_builtin_plugins::fixture("smoothing-v2").to_vec()
}

/// `POST /plugins?host=…` through the engine (which refreshes its catalogue at once).
async fn upload(cluster: &Cluster, host: &str, wasm: Vec<u8>, replace: bool) -> (u16, Json) {
    let answer = cluster
        .http
        .post(cluster.url("/plugins"))
        .query(&[("host", host), ("replace", if replace { "true" } else { "false" })])
        .header("X-Upload-Token", TOKEN)
        .body(wasm)
        .send()
        .await
        .unwrap();
    (answer.status().as_u16(), answer.json().await.unwrap())
}

/// The digests the engine's catalogue lists for `service`.
async fn digests(cluster: &Cluster, service: &str) -> Vec<String> {
    let services = cluster.services().await;
    let offer = services.as_array().unwrap().iter().find(|s| s["name"] == service).unwrap();
    offer["plugins"].as_array().unwrap().iter().map(|d| text(d).to_owned()).collect()
}

async fn post(cluster: &Cluster, path: &str, body: Json) -> (u16, Json) {
    let answer = cluster.http.post(cluster.url(path)).json(&body).send().await.unwrap();
    (answer.status().as_u16(), answer.json().await.unwrap())
}

async fn get(cluster: &Cluster, path: &str) -> (u16, Json) {
    let answer = cluster.http.get(cluster.url(path)).send().await.unwrap();
    (answer.status().as_u16(), answer.json().await.unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_pinned_step_runs_only_where_its_plugin_is_and_a_wrong_digest_is_a_400() {
    let cluster = Cluster::start(&[&["smoothing", "checks"], &["smoothing", "checks"]]).await;
    let (first, second) = (cluster.hosts[0].url.clone(), cluster.hosts[1].url.clone());
    let builtin = digests(&cluster, "laplacian-smoothing").await;
    assert_eq!(builtin.len(), 1);

    // Another laplacian-smoothing on the second host is refused without replace.
    let (status, refused) = upload(&cluster, &second, smoothing_v2(), false).await;
    assert_eq!(status, 409, "{refused}");
    assert!(text(&refused["error"]["message"]).contains("laplacian-smoothing"), "{refused}");
    let (status, uploaded) = upload(&cluster, &second, smoothing_v2(), true).await;
    assert_eq!(status, 201, "{uploaded}");
    assert_eq!(uploaded["replaced"], json!(["laplacian-smoothing"]));
    let v2 = text(&uploaded["digest"]).to_owned();
    let mut both = digests(&cluster, "laplacian-smoothing").await;
    both.sort();
    let mut expected = vec![builtin[0].clone(), v2.clone()];
    expected.sort();
    assert_eq!(both, expected, "the catalogue shows every digest of the service");

    let input = Input::scan(3_000, 3);
    let url = cluster.upload(&input).await;
    let checks = meshflow_runtime::digest(common::builtin("checks"));
    let pinned = |digest: &str| {
        json!([
            {"run": "laplacian-smoothing", "plugin": digest, "params": {"iterations": 2}},
            {"if": {"check": "vertex-count", "op": ">", "value": 0, "plugin": &checks[..16]},
             "then": [{"run": "laplacian-smoothing", "plugin": &digest[..12]}]}
        ])
    };
    let record = cluster.run(&pinned(&v2), &url).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    for step in steps(&record).iter().filter(|s| s["service"] == "laplacian-smoothing") {
        assert_eq!((text(&step["host"]), text(&step["plugin"])), (second.as_str(), v2.as_str()));
    }
    assert_eq!(
        steps(&record)[0]["resolved_params"],
        json!({"iterations": 2, "keep-boundary": true, "weights": "uniform"}),
        "the record keeps every parameter that ran, defaults filled in"
    );
    // The built-in is pinned-only on the second host, so the first one may run it too.
    let record = cluster.run(&pinned(&builtin[0]), &url).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(text(&steps(&record)[0]["plugin"]), builtin[0]);
    assert!([first.as_str(), second.as_str()].contains(&text(&steps(&record)[0]["host"])));

    let (status, refused) = cluster
        .post_run(json!({"workflow": pinned("0123456789abcdef"), "input": url}).to_string())
        .await;
    assert_eq!(status, 400, "{refused}");
    let message = text(&refused["error"]["message"]);
    assert!(
        message.starts_with("steps[0].plugin: no host offers \"laplacian-smoothing\""),
        "{message}"
    );
    let (status, refused) = cluster
        .post_run(json!({"workflow": [{"run": "laplacian-smoothng"}], "input": url}).to_string())
        .await;
    assert_eq!(status, 400);
    assert!(
        text(&refused["error"]["message"]).contains("did you mean \"laplacian-smoothing\"?"),
        "{refused}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_rerun_is_bit_identical_and_an_unpinned_one_after_a_replacement_names_the_diverging_step()
{
    let cluster = Cluster::start(&[&["smoothing", "checks"]]).await;
    let host = cluster.hosts[0].url.clone();
    let input = Input::scan(3_000, 5);
    let url = cluster.upload(&input).await;
    let workflow = json!([
        {"if": {"check": "vertex-count", "op": ">", "value": 0}, "then": [{"run": "add-noise"}]},
        {"run": "laplacian-smoothing", "params": {"iterations": 2}}
    ]);
    let original = cluster.run(&workflow, &url).await;
    assert_eq!(original["status"], "completed", "{}", original["error"]);
    let id = text(&original["id"]).to_owned();

    let rerun = |body: Json| {
        let (cluster, id) = (&cluster, id.clone());
        async move {
            let (status, started) = post(cluster, &format!("/runs/{id}/rerun"), body).await;
            assert_eq!(status, 202, "{started}");
            let record = cluster.finished(text(&started["id"])).await;
            assert_eq!(record["rerun_of"], json!(id));
            let (status, comparison) =
                get(cluster, &format!("/runs/{}/comparison", text(&record["id"]))).await;
            assert_eq!(status, 200, "{comparison}");
            (record, comparison)
        }
    };
    let (again, comparison) = rerun(json!({})).await;
    assert_eq!(comparison["identical"], json!(true), "{comparison}");
    assert_eq!(executed(&again), executed(&original));
    for step in steps(&again) {
        assert!(step["params"] == step["resolved_params"], "pinned with every parameter: {step}");
    }

    let (status, uploaded) = upload(&cluster, &host, smoothing_v2(), true).await;
    assert_eq!(status, 201, "{uploaded}");
    // Pinned, the re-run still gets the recorded plugin, kept for pinned runs.
    let (_, comparison) = rerun(json!({})).await;
    assert_eq!(comparison["identical"], json!(true), "{comparison}");
    let (changed, comparison) = rerun(json!({"unpinned": true})).await;
    assert_eq!(changed["status"], "completed", "{}", changed["error"]);
    assert_eq!(comparison["identical"], json!(false));
    let divergence = &comparison["divergence"];
    assert_eq!((divergence["index"].clone(), text(&divergence["path"])), (json!(2), "steps[1]"));
    assert!(text(&divergence["message"]).contains(text(&uploaded["digest"])), "{divergence}");

    // On another input, the comparison says so first.
    let other = cluster.upload(&Input::scan(3_000, 6)).await;
    let (_, comparison) = rerun(json!({"input": other})).await;
    assert_eq!(
        (comparison["same_input"].clone(), text(&comparison["divergence"]["path"])),
        (json!(false), "input")
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_batch_of_twelve_with_one_unreadable_mesh_gives_eleven_local_results_and_one_failure() {
    let cluster = Cluster::start(&[&["smoothing", "cleanup"], &["holes", "checks"]]).await;
    let workflow = json!([
        {"run": "remove-smallest-components"},
        {"while": {"check": "hole-count", "op": ">", "value": 0}, "max-iterations": 2,
         "do": [{"run": "fill-holes"}]},
        {"run": "laplacian-smoothing"}
    ]);
    let local = Local::new(&components_cache());
    let parsed = Workflow::from_json(&workflow).unwrap();
    let mut inputs = Vec::new();
    let mut expected = Vec::new();
    for seed in 0..12u64 {
        if seed == 7 {
            let garbage = Input {
                name: "broken.ply",
                bytes: b"ply\nnot really\n".to_vec(),
                mesh: Input::scan(100, 0).mesh,
            };
            inputs.push(cluster.upload(&garbage).await);
            expected.push(None);
            continue;
        }
        let input = Input::scan(1_500, seed);
        expected.push(Some(local.run(&parsed, input.mesh.clone())));
        inputs.push(cluster.upload(&input).await);
    }
    let (status, started) =
        post(&cluster, "/batches", json!({"workflow": workflow, "inputs": inputs})).await;
    assert_eq!(status, 202, "{started}");
    let id = text(&started["id"]).to_owned();
    let deadline = tokio::time::Instant::now() + std::time::Duration::from_secs(300);
    let batch = loop {
        let (status, batch) = get(&cluster, &format!("/batches/{id}")).await;
        assert_eq!(status, 200, "{batch}");
        if batch["status"] == "completed" {
            break batch;
        }
        assert!(tokio::time::Instant::now() < deadline, "{batch:#}");
        tokio::time::sleep(std::time::Duration::from_millis(200)).await;
    };
    let rows = batch["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 12);
    for (row, expected) in rows.iter().zip(&expected) {
        match expected {
            Some(trace) => {
                assert_eq!(row["status"], "completed", "{row}");
                assert_eq!(text(&row["result_hash"]), trace.hash(), "{row}");
                assert!(row["checks"]["hole-count [steps[1].while]"].is_i64(), "{row}");
                assert!(row["bytes_moved"].as_u64().unwrap() > 0);
            }
            None => {
                assert_eq!(
                    (text(&row["status"]), text(&row["name"])),
                    ("failed", "broken.ply"),
                    "{row}"
                );
                assert!(!text(&row["error"]).is_empty());
            }
        }
    }
    let (status, _) = get(&cluster, "/batches/b-unknown").await;
    assert_eq!(status, 404);
}
