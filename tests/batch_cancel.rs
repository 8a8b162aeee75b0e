//! `POST /batches/{id}/cancel`, the limit on a user's active batches, and error bodies in
//! the JSON envelope on both servers (issue 30 items 6 and 8).

mod common;

use std::time::Duration;

use common::Cluster;
use serde_json::{Value as Json, json};

/// A server whose every answer is 200 with headers and then nothing, for a long time: the
/// runs on its inputs stay loading.
async fn hanging_server() -> String {
    let app = axum::Router::new().route(
        "/{file}",
        axum::routing::get(|| async {
            let stream = futures_util::stream::once(async {
                tokio::time::sleep(Duration::from_secs(600)).await;
                Ok::<_, std::io::Error>(axum::body::Bytes::from_static(b"x"))
            });
            axum::body::Body::from_stream(stream)
        }),
    );
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let origin = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move { axum::serve(listener, app).await });
    origin
}

async fn post(cluster: &Cluster, path: &str, body: Json) -> (u16, Json) {
    let answer = cluster.http.post(cluster.url(path)).json(&body).send().await.unwrap();
    let status = answer.status().as_u16();
    (status, answer.json().await.unwrap())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_cancelled_batch_starts_no_more_runs_and_cancels_those_going() {
    let origin = hanging_server().await;
    let cluster =
        Cluster::start_allowing(&[&["smoothing"]], &[], std::slice::from_ref(&origin)).await;
    let workflow = json!([{"run": "laplacian-smoothing"}]);
    let inputs: Vec<String> = (0..5).map(|i| format!("{origin}/in-{i}.ply")).collect();
    let body = json!({"workflow": workflow, "inputs": inputs, "concurrency": 2});
    let (status, batch) = post(&cluster, "/batches", body.clone()).await;
    assert_eq!(status, 202, "{batch}");
    let id = batch["id"].as_str().unwrap().to_owned();
    assert!(id.starts_with("b-"), "batch ids tell themselves from run ids: {id}");
    // Two runs going, the others waiting for them.
    let mut started = Vec::new();
    for _ in 0..200 {
        let batch: Json = cluster
            .http
            .get(cluster.url(&format!("/batches/{id}")))
            .send()
            .await
            .unwrap()
            .json()
            .await
            .unwrap();
        started = batch["entries"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|e| e["run"].as_str().map(str::to_owned))
            .collect();
        if started.len() == 2 {
            break;
        }
        tokio::time::sleep(Duration::from_millis(25)).await;
    }
    assert_eq!(started.len(), 2);

    let (status, cancelled) = post(&cluster, &format!("/batches/{id}/cancel"), json!({})).await;
    assert_eq!(status, 200, "{cancelled}");
    assert_eq!(cancelled["status"], "cancelled", "{cancelled}");
    let rows = cancelled["rows"].as_array().unwrap();
    assert!(rows.iter().all(|row| row["status"] == "cancelled"), "{cancelled}");
    for run in &started {
        assert_eq!(cluster.record(run).await["status"], "cancelled");
    }
    // No more start later.
    tokio::time::sleep(Duration::from_millis(600)).await;
    let runs: Json =
        cluster.http.get(cluster.url("/runs")).send().await.unwrap().json().await.unwrap();
    assert_eq!(runs.as_array().unwrap().len(), 2, "{runs}");
    let (status, _) = post(&cluster, "/batches/b-nothing/cancel", json!({})).await;
    assert_eq!(status, 404);

    // A user has at most 16 batches going; the 17th is refused until one ends.
    let one = json!({"workflow": workflow, "inputs": [format!("{origin}/x.ply")]});
    let mut going = Vec::new();
    for _ in 0..16 {
        let (status, batch) = post(&cluster, "/batches", one.clone()).await;
        assert_eq!(status, 202, "{batch}");
        going.push(batch["id"].as_str().unwrap().to_owned());
    }
    let (status, refused) = post(&cluster, "/batches", one.clone()).await;
    assert_eq!((status, refused["error"]["code"].as_str()), (429, Some("too-many-batches")));
    post(&cluster, &format!("/batches/{}/cancel", going[0]), json!({})).await;
    let (status, batch) = post(&cluster, "/batches", one.clone()).await;
    assert_eq!(status, 202, "{batch}");
    going.push(batch["id"].as_str().unwrap().to_owned());
    for id in &going[1..] {
        post(&cluster, &format!("/batches/{id}/cancel"), json!({})).await;
    }
}

#[tokio::test]
async fn rejections_of_both_servers_are_json_and_echo_little() {
    let cluster = Cluster::start(&[&["smoothing"]]).await;
    // The engine: a path segment that does not parse.
    let answer = cluster.http.get(cluster.url("/runs/x/steps/not-a-number/output")).send().await;
    let answer = answer.unwrap();
    assert_eq!(answer.status(), 400);
    let body: Json = answer.json().await.unwrap();
    assert!(body["error"]["code"].is_string() && body["error"]["message"].is_string(), "{body}");
    // A 500 KB parameter is not echoed in full.
    let long = "x".repeat(500_000);
    let workflow = json!([{"run": "laplacian-smoothing", "params": {"iterations": long}}]);
    let answer = cluster
        .http
        .post(cluster.url("/workflows/validate"))
        .json(&json!({"workflow": workflow}))
        .send()
        .await
        .unwrap();
    let text = answer.text().await.unwrap();
    assert!(text.len() < 2000, "{} bytes echoed", text.len());
    // The host: a body over its limit.
    let host = &cluster.hosts[0].url;
    let big = vec![b" "[0]; 3 << 20];
    let answer = common::bearer_client(common::CLUSTER_TOKEN)
        .post(format!("{host}/sessions"))
        .header("content-type", "application/json")
        .body(big)
        .send()
        .await
        .unwrap();
    assert_eq!(answer.status(), 413);
    let body: Json = answer.json().await.unwrap();
    assert_eq!(body["error"]["code"], "too-large", "{body}");
}
