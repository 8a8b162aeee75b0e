//! Plugins a run will replay are fetched and compiled on each host once it holds the input
//! (issue 34 item 2): a host that lacks a step's plugin has it before the step's replay
//! reaches it, and a prefetch naming what it should not is refused without harming
//! anyone's run.

mod common;

use common::{CLUSTER_TOKEN, Cluster, Input, TOKEN, steps, text};
use meshflow_api::host::{PrefetchOutcome, WantedPlugin};
use meshflow_api::{ClientError, ClusterAccess, HostClient};
use serde_json::{Value as Json, json};

/// A cluster of two hosts: the first offers the uploaded `smoothing-v2` plugin (and the
/// cleanup built-ins), the second only the holes built-in. Its digest.
async fn cluster() -> (Cluster, String) {
    let cluster = Cluster::start(&[&["cleanup"], &["holes"]]).await;
    let v2 = meshflow_builtin_plugins::fixture("smoothing-v2").to_vec();
    let answer = cluster
        .http
        .post(cluster.url("/plugins"))
        .query(&[("host", cluster.hosts[0].url.as_str())])
        .header("X-Upload-Token", TOKEN)
        .body(v2.clone())
        .send()
        .await
        .unwrap();
    assert_eq!(answer.status(), 201, "{}", answer.text().await.unwrap());
    (cluster, meshflow_runtime::digest(&v2))
}

/// Smoothing that only the first host offers, then hole filling that only the second
/// does: the second host must take the smoothing's result, here by replaying it.
fn workflow(transfer: &str) -> Json {
    json!({
        "transfer": transfer,
        "steps": [
            {"run": "laplacian-smoothing", "params": {"iterations": 40}},
            {"run": "fill-holes"}
        ]
    })
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_that_will_replay_a_step_has_its_plugin_before_the_replay_arrives() {
    let (cluster, digest) = cluster().await;
    let (producer, receiver) = (cluster.hosts[0].url.clone(), cluster.hosts[1].url.clone());
    let input = cluster.upload(&Input::scan(30_000, 7)).await;

    let record = cluster.run(&workflow("replay"), &input).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    let prefetches = record["prefetches"].as_array().cloned().unwrap_or_default();
    // The receiver lacks only the smoothing, to replay it; the producer lacks the hole
    // filler, which may move to it (where the mesh is) if the replay would take long.
    assert_eq!(prefetches.len(), 2, "{prefetches:#?}");
    let on = |host: &str| prefetches.iter().find(|p| p["host"] == host).expect(host);
    let prefetch = on(&receiver);
    let for_a_move = on(&producer);
    assert_eq!(text(&for_a_move["from"]), receiver);
    assert!(["fetched", "present", "loaded"].contains(&text(&for_a_move["outcome"])));
    assert_eq!(
        (text(&prefetch["host"]), text(&prefetch["plugin"]), text(&prefetch["from"])),
        (receiver.as_str(), digest.as_str(), producer.as_str())
    );
    assert_eq!(prefetch["outcome"], "fetched", "{prefetch:#}");
    assert_eq!(prefetch["why"], json!(["a replay of steps[0] (laplacian-smoothing)"]));
    assert_eq!(for_a_move["why"], json!(["steps[1] (fill-holes) moving here after steps[0]"]));
    // Asked only once the receiver held the input, so the plugin did not share its link
    // with the input (the broadcast began after the run did: its times are a lower bound).
    let loads = record["broadcast"]["hosts"].as_array().unwrap();
    let load = loads.iter().find(|l| l["host"] == receiver).expect("the receiver's load");
    let held_ms = load["download_ms"].as_f64().unwrap() + load["load_ms"].as_f64().unwrap();
    assert!(prefetch["started_ms"].as_f64().unwrap() >= held_ms, "{prefetch:#} {load:#}");
    let size = meshflow_builtin_plugins::fixture("smoothing-v2").len() as u64;
    assert_eq!(prefetch["bytes"].as_u64(), Some(size));
    let smoothing = &steps(&record)[0];
    assert_eq!((text(&smoothing["host"]), text(&smoothing["plugin"])), (&*producer, &*digest));
    let transfers = smoothing["transfers"].as_array().unwrap();
    assert_eq!(transfers.len(), 1, "{transfers:#?}");
    let replay = &transfers[0];
    assert_eq!((text(&replay["host"]), text(&replay["via"])), (&*receiver, "replay"), "{replay:#}");
    // The replay took the plugin the prefetch made ready: at once, or, when it came first
    // (the smoothing starts as soon as its host holds the input, which may be before the
    // receiver does), by waiting for that prefetch, whose answer came after the wait ended
    // (a fetch of its own would have ended its wait whenever it was done).
    let (ready_ms, forwarded_ms) = (&prefetch["finished_ms"], &replay["started_ms"]);
    let (ready_ms, forwarded_ms) = (ready_ms.as_f64().unwrap(), forwarded_ms.as_f64().unwrap());
    if let Some(wait_ms) = replay["plugin_wait_ms"].as_f64() {
        assert!(forwarded_ms + wait_ms <= ready_ms, "{record:#}");
    }

    // The same result as a run whose result travels as edit logs, which prefetches nothing.
    let logs = cluster.run(&workflow("correction"), &input).await;
    assert_eq!(logs["status"], "completed", "{}", logs["error"]);
    assert_eq!(text(&logs["result"]["hash"]), text(&record["result"]["hash"]));
    assert!(logs.get("prefetches").is_none(), "{:#}", logs["prefetches"]);
    assert_eq!(steps(&logs)[0]["transfers"][0]["via"], "correction");

    // A second replaying run finds the plugin already there. The hole filler is no longer
    // asked of the producer: the smoothing's shape, learned by the runs before, says its
    // replay on a mesh this size keeps the receiver waiting less than a move is worth.
    let again = cluster.run(&workflow("replay"), &input).await;
    assert_eq!(again["status"], "completed", "{}", again["error"]);
    let asked: Vec<(&str, &str)> = again["prefetches"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (text(&p["host"]), text(&p["outcome"])))
        .collect();
    assert_eq!(asked, [(receiver.as_str(), "present")], "{:#}", again["prefetches"]);
    assert_eq!(text(&again["result"]["hash"]), text(&record["result"]["hash"]));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_prefetch_of_what_a_host_should_not_fetch_is_refused_and_harms_no_run() {
    let (cluster, digest) = cluster().await;
    let (producer, receiver) = (cluster.hosts[0].url.clone(), cluster.hosts[1].url.clone());
    let access = ClusterAccess::new(Some(CLUSTER_TOKEN.into()));
    access.set_peers(vec![producer.clone()]);
    let client = HostClient::new(&receiver).with_access(access);
    let wanted =
        |digest: &str, from: &str| WantedPlugin { digest: digest.into(), from: from.into() };

    let answer = client
        .prefetch_plugins(vec![
            // The producer does not have it.
            wanted(&"e".repeat(64), &producer),
            // Not a host of the cluster (the engine vouched for the producer only).
            wanted(&digest, "http://127.0.0.1:9"),
            // Not a digest: never a file name.
            wanted("../../sessions/x", &producer),
            wanted(&digest.to_uppercase(), &producer),
        ])
        .await
        .unwrap();
    let outcomes: Vec<PrefetchOutcome> = answer.plugins.iter().map(|p| p.outcome).collect();
    assert_eq!(outcomes, [PrefetchOutcome::Failed; 4], "{answer:#?}");
    let errors: Vec<&str> = answer.plugins.iter().map(|p| p.error.as_deref().unwrap()).collect();
    assert!(errors[0].contains("404") || errors[0].contains("no plugin"), "{errors:?}");
    assert!(errors[1].contains("not the origin of a host of the cluster"), "{errors:?}");
    assert!(errors[2].contains("not 64 lowercase hex") && errors[3] == errors[2], "{errors:?}");

    // Too many at once, or without the cluster token: refused outright.
    let many = vec![wanted(&digest, &producer); meshflow_api::host::MAX_PREFETCH_PLUGINS + 1];
    match client.prefetch_plugins(many).await {
        Err(ClientError::Refused { status: 400, code, .. }) => assert_eq!(code, "too-many-plugins"),
        other => panic!("{other:?}"),
    }
    let stranger = HostClient::new(&receiver);
    match stranger.prefetch_plugins(vec![wanted(&digest, &producer)]).await {
        Err(ClientError::Refused { status: 401, .. }) => {}
        other => panic!("{other:?}"),
    }

    // Nothing was fetched: the run's own prefetch fetches the plugin, and the run is whole.
    let input = cluster.upload(&Input::bunny()).await;
    let record = cluster.run(&workflow("replay"), &input).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);
    assert_eq!(record["prefetches"][0]["outcome"], "fetched", "{:#}", record["prefetches"]);
    let replay = &steps(&record)[0]["transfers"][0];
    assert_eq!(replay["via"], "replay", "{replay:#}");
}

/// A host started with `--no-foreign-plugins` says so, and refuses to fetch a plugin it did
/// not load, even from a host of its cluster; its own plugins are still "present".
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_host_that_runs_only_its_own_plugins_refuses_to_fetch_others() {
    let data = tempfile::tempdir().unwrap();
    let hosts =
        common::start_hosts_configured(&[&["smoothing"], &["holes"]], data.path(), |i, c| {
            c.foreign_plugins = i != 1
        })
        .await;
    let (producer, closed) = (hosts[0].url.clone(), hosts[1].url.clone());
    let access = ClusterAccess::new(Some(CLUSTER_TOKEN.into()));
    access.set_peers(vec![producer.clone()]);
    let client = HostClient::new(&closed).with_access(access.clone());
    let other = HostClient::new(&producer).with_access(access);
    assert!(!client.health().await.unwrap().foreign_plugins);
    assert!(other.health().await.unwrap().foreign_plugins);
    let smoothing = other.services().await.unwrap()[0].plugin.clone();
    let holes = client.services().await.unwrap()[0].plugin.clone();
    let answer = client
        .prefetch_plugins(vec![
            WantedPlugin { digest: smoothing, from: producer.clone() },
            WantedPlugin { digest: holes, from: producer.clone() },
        ])
        .await
        .unwrap();
    let outcomes: Vec<PrefetchOutcome> = answer.plugins.iter().map(|p| p.outcome).collect();
    assert_eq!(outcomes, [PrefetchOutcome::Failed, PrefetchOutcome::Present], "{answer:#?}");
    let error = answer.plugins[0].error.as_deref().unwrap();
    assert!(error.contains("--no-foreign-plugins"), "{error}");
    drop(data);
}
