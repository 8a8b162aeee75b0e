//! A host's downloads are streamed to disk, not memory, and stop at once when their run is
//! cancelled (its sessions deleted): issue 30 item 4.

mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use axum::body::{Body, Bytes};
use common::Cluster;
use serde_json::json;

/// The body the slow server announces and would send: 1 GiB of junk.
const BODY_BYTES: u64 = 1 << 30;
const CHUNK: usize = 256 << 10;
/// One chunk per this pause (or more: timers are coarse): tens of MB/s per download, far
/// above the hosts' floor rate.
const PAUSE: Duration = Duration::from_millis(2);

/// Counts the body streams open: the count drops when the host closes the connection.
struct Open(Arc<AtomicUsize>);

impl Drop for Open {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::SeqCst);
    }
}

/// Bytes the slow server has sent, all streams together.
static SENT: AtomicUsize = AtomicUsize::new(0);

/// A server answering any GET with 200 and a slow 1 GiB body; the streams open now, and
/// every one ever opened.
async fn slow_server() -> (String, Arc<AtomicUsize>, Arc<AtomicUsize>) {
    let (open, started) = (Arc::new(AtomicUsize::new(0)), Arc::new(AtomicUsize::new(0)));
    let (open_, started_) = (open.clone(), started.clone());
    let app = axum::Router::new().route(
        "/{file}",
        axum::routing::get(move || {
            let (open, started) = (open_.clone(), started_.clone());
            async move {
                open.fetch_add(1, Ordering::SeqCst);
                started.fetch_add(1, Ordering::SeqCst);
                let guard = Open(open);
                let junk = Bytes::from(vec![b'x'; CHUNK]);
                let chunks = BODY_BYTES / CHUNK as u64;
                let stream = futures_util::stream::unfold((0u64, guard), move |(i, guard)| {
                    let junk = junk.clone();
                    async move {
                        if i == chunks {
                            return None;
                        }
                        tokio::time::sleep(PAUSE).await;
                        SENT.fetch_add(CHUNK, Ordering::SeqCst);
                        Some((Ok::<_, std::io::Error>(junk), (i + 1, guard)))
                    }
                });
                let headers = [(axum::http::header::CONTENT_LENGTH, BODY_BYTES.to_string())];
                (headers, Body::from_stream(stream))
            }
        }),
    );
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let origin = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move { axum::serve(listener, app).await });
    (origin, open, started)
}

/// This process's resident set in bytes (the host runs in it).
fn rss() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    let kb: u64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
    kb * 1024
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn cancelled_runs_stop_their_hosts_slow_large_downloads_at_once_in_bounded_memory() {
    let (origin, open, started) = slow_server().await;
    let cluster =
        Cluster::start_allowing(&[&["smoothing"]], &[], std::slice::from_ref(&origin)).await;
    let before = rss();
    let workflow = json!([{"run": "laplacian-smoothing"}]);
    let mut runs = Vec::new();
    for i in 0..3 {
        runs.push(cluster.submit(&workflow, &format!("{origin}/big-{i}.ply")).await);
    }
    let deadline = Instant::now() + Duration::from_secs(10);
    while started.load(Ordering::SeqCst) < 3 {
        assert!(Instant::now() < deadline, "the host did not start the three downloads");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    // Some hundreds of MB arrive meanwhile: on disk, not in memory.
    tokio::time::sleep(Duration::from_secs(3)).await;
    let during = rss();
    let sent = SENT.load(Ordering::SeqCst) as u64;
    for id in &runs {
        let answer = cluster.http.post(cluster.url(&format!("/runs/{id}/cancel"))).send().await;
        let answer: serde_json::Value = answer.unwrap().json().await.unwrap();
        assert_eq!(answer["status"], "cancelled", "{answer}");
    }
    let cancelled = Instant::now();
    while open.load(Ordering::SeqCst) > 0 {
        assert!(
            cancelled.elapsed() < Duration::from_secs(2),
            "{} upstream downloads still open 2 s after the cancel",
            open.load(Ordering::SeqCst)
        );
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
    let closed_ms = cancelled.elapsed().as_millis();
    let after = rss();
    let mb = |bytes: u64| bytes as f64 / (1 << 20) as f64;
    eprintln!(
        "{:.0} MB sent; RSS before {:.0} MB, while downloading {:.0} MB, after {:.0} MB; \
         upstreams closed {} ms after the cancels",
        mb(sent),
        mb(before),
        mb(during),
        mb(after),
        closed_ms
    );
    // Held in memory, this much would have shown.
    assert!(sent > 300 << 20, "only {:.0} MB were sent", mb(sent));
    assert!(during.saturating_sub(before) < 300 << 20, "RSS grew by {:.0} MB", mb(during - before));
    assert!(after.saturating_sub(before) < 300 << 20, "RSS grew by {:.0} MB", mb(after - before));
}
