//! A finished run's result is held by two hosts, and downloads fall back to the second
//! when the producer is gone (issue 30 item 5).

mod common;

use common::{Cluster, Input};
use serde_json::json;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_result_downloads_while_its_producer_is_stopped() {
    let mut cluster = Cluster::start(&[&["smoothing"], &["holes"]]).await;
    let input = cluster.upload(&Input::bunny()).await;
    let workflow = json!([
        {"run": "fill-holes"},
        {"run": "laplacian-smoothing", "params": {"iterations": 2}}
    ]);
    let record = cluster.run(&workflow, &input).await;
    assert_eq!(record["status"], "completed", "{record}");
    let result = &record["result"];
    // Completed once both held it; settled once both had packed it.
    assert!(record["settled_ms"].as_f64().unwrap() >= record["total_ms"].as_f64().unwrap());
    assert!(result["bytes"].as_u64().is_some_and(|b| b > 0), "{result}");
    let copies = result["copies"].as_array().cloned().unwrap_or_default();
    assert_eq!(copies.len(), 1, "the result has a second holder: {result}");
    let producer = result["url"].as_str().unwrap().to_owned();
    let expected = cluster.result(record["id"].as_str().unwrap()).await;

    // Stop the producer: the copy serves the result, checked as ever.
    let index = cluster.hosts.iter().position(|h| producer.starts_with(&h.url)).unwrap();
    assert!(!copies[0].as_str().unwrap().starts_with(&cluster.hosts[index].url));
    cluster.hosts.remove(index).shutdown().await.unwrap();
    let id = record["id"].as_str().unwrap();
    let served = cluster.result(id).await;
    assert_eq!(served.content_hash(), expected.content_hash());
    let ply = cluster.http.get(cluster.url(&format!("/runs/{id}/result?format=ply"))).send().await;
    assert_eq!(ply.unwrap().status(), 200);
}
