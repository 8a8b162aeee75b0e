//! Safe to put on the internet (issue 13, DESIGN §10): tokens on every route, checked before a
//! body is read; what hosts fetch; servers that drop half-sent requests and refuse to listen
//! openly without tokens. Real HTTP on 127.0.0.1, every wait bounded.

// Shared with the other test binaries; this one uses part of it.
mod common;

use std::sync::Arc;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::{Duration, Instant};

use common::{API_TOKEN, CLUSTER_TOKEN, Cluster, Input, TOKEN, builtins, components_cache, text};
use meshflow_api::HostClient;
use meshflow_api::host::SessionState;
use meshflow_api::server::HEADER_READ_TIMEOUT;
use meshflow_host::{HostConfig, HostHandle};
use serde_json::{Value as Json, json};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::{TcpListener, TcpStream};

/// How long a refusal that reads no body may take.
const PROMPT: Duration = Duration::from_secs(5);

fn host_config(data: &std::path::Path) -> HostConfig {
    HostConfig {
        builtins: builtins(&["checks"]),
        artefact_cache: Some(components_cache()),
        token: Some(TOKEN.into()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        ..HostConfig::new(data)
    }
}

async fn start_host(config: HostConfig) -> HostHandle {
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    meshflow_host::start(config, listener).await.unwrap()
}

/// The status and error code of an answer.
async fn refusal(answer: reqwest::Response) -> (u16, Json) {
    let status = answer.status().as_u16();
    let body: Json = answer.json().await.unwrap_or(Json::Null);
    (status, body["error"]["code"].clone())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn engine_routes_need_the_api_token_and_registration_the_cluster_token() {
    let cluster = Cluster::start(&[&["cleanup"]]).await;
    let anonymous = reqwest::Client::new();
    let input = Input::bunny();
    let workflow = json!({"steps": [{"run": "remove-degenerate-triangles"}]});
    let attempts = [
        anonymous.post(cluster.url("/hosts")).json(&json!({"url": cluster.hosts[0].url})),
        anonymous.post(cluster.url("/runs")).json(&json!({"workflow": workflow})),
        anonymous.post(cluster.url("/inputs?name=bunny.obj")).body(input.bytes.clone()),
        anonymous.get(cluster.url("/runs")),
        anonymous.get(cluster.url("/hosts")),
        anonymous.get(cluster.url("/runs/x/events")),
        anonymous.get(cluster.url("/runs")).bearer_auth("wrong"),
        // The API token is not the cluster token: users cannot register hosts.
        anonymous.post(cluster.url("/hosts")).bearer_auth(API_TOKEN).json(&json!({"url": "x"})),
    ];
    for attempt in attempts {
        let (status, code) = refusal(attempt.send().await.unwrap()).await;
        assert_eq!((status, code), (401, json!("unauthorized")));
    }
    for open in ["/health", "/"] {
        assert_eq!(anonymous.get(cluster.url(open)).send().await.unwrap().status(), 200, "{open}");
    }

    // With the tokens, the same requests go through.
    assert_eq!(cluster.register(&cluster.hosts[0].url).await.status(), 201);
    let url = cluster.upload(&input).await;
    let inputs = url.clone();
    assert_eq!(anonymous.get(&inputs).send().await.unwrap().status(), 401);
    assert_eq!(
        anonymous.get(&inputs).bearer_auth(CLUSTER_TOKEN).send().await.unwrap().status(),
        200
    );
    let record = cluster.run(&workflow, &url).await;
    assert_eq!(record["status"], "completed", "{record:#}");
    let runs: Json =
        cluster.http.get(cluster.url("/runs")).send().await.unwrap().json().await.unwrap();
    assert_eq!(runs.as_array().map(Vec::len), Some(1), "{runs}");
    // The event stream also takes the token as a query (EventSource sends no headers).
    let events = format!("/runs/{}/events?token={API_TOKEN}", text(&record["id"]));
    assert_eq!(anonymous.get(cluster.url(&events)).send().await.unwrap().status(), 200);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn host_routes_need_the_cluster_token_but_health() {
    let dir = tempfile::tempdir().unwrap();
    let host = start_host(host_config(dir.path())).await;
    let anonymous = reqwest::Client::new();
    let url = |path: &str| format!("{}{path}", host.url);
    let attempts = [
        anonymous.get(url("/services")),
        anonymous.get(url("/plugins")),
        anonymous
            .post(url("/sessions"))
            .json(&json!({"input": {"url": "http://127.0.0.1:1/x.ply"}})),
        anonymous.get(url("/sessions/x")),
        anonymous.post(url("/sessions/x/run")).json(&json!({"service": "is-manifold"})),
        anonymous.get(url("/blobs/x.mfm")),
        anonymous
            .post(url("/meshes/convert"))
            .json(&json!({"hash": "0".repeat(64), "format": "ply"})),
        // A publisher's upload token lists plugins and services (issue 31), nothing more.
        anonymous.get(url("/sessions/x")).bearer_auth(TOKEN),
        anonymous.get(url("/blobs/x.mfm")).bearer_auth(TOKEN),
        // The cluster token does not publish plugins: that takes the upload token.
        anonymous.post(url("/plugins")).bearer_auth(CLUSTER_TOKEN).body(vec![0u8; 16]),
    ];
    for attempt in attempts {
        let (status, code) = refusal(attempt.send().await.unwrap()).await;
        assert_eq!((status, code), (401, json!("unauthorized")));
    }
    assert_eq!(anonymous.get(url("/health")).send().await.unwrap().status(), 200);
    for listing in ["/services", "/plugins"] {
        let publisher = anonymous.get(url(listing)).bearer_auth(TOKEN).send().await.unwrap();
        assert_eq!(publisher.status(), 200, "{listing} with the upload token");
    }
    let client = HostClient::new(&host.url).with_token(CLUSTER_TOKEN);
    assert!(client.services().await.unwrap().iter().any(|s| s.info.name == "is-manifold"));
}

/// Sends the head of a request announcing `length` body bytes and a few of them, then
/// nothing; the status line of the answer, or `None` if the connection closes first.
async fn stalled_request(address: &str, head: &str) -> Option<String> {
    let mut socket = TcpStream::connect(address).await.unwrap();
    socket.write_all(head.as_bytes()).await.unwrap();
    socket.write_all(&[0u8; 1024]).await.unwrap();
    let mut answer = vec![0u8; 1024];
    let read = socket.read(&mut answer).await.unwrap_or(0);
    let text = String::from_utf8_lossy(&answer[..read]).into_owned();
    text.lines().next().map(str::to_owned)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn anonymous_plugin_uploads_are_refused_before_their_bodies_are_read() {
    let dir = tempfile::tempdir().unwrap();
    let host = start_host(host_config(dir.path())).await;
    let address = host.url.trim_start_matches("http://").to_owned();
    let head = format!(
        "POST /plugins HTTP/1.1\r\nHost: {address}\r\nContent-Length: {}\r\n\r\n",
        60 << 20
    );
    // Forty at once, each announcing 60 MiB and sending 1 KiB: each is answered at once,
    // though no body will ever arrive.
    let started = Instant::now();
    let uploads = (0..40).map(|_| stalled_request(&address, &head));
    let answers = tokio::time::timeout(PROMPT, futures_util::future::join_all(uploads))
        .await
        .expect("an upload was waited on instead of refused");
    for answer in answers {
        assert_eq!(answer.as_deref(), Some("HTTP/1.1 401 Unauthorized"));
    }
    assert!(started.elapsed() < PROMPT);
    // With a wrong token likewise; with the right one the body is awaited (no answer yet).
    let wrong = head.replace("\r\n\r\n", "\r\nAuthorization: Bearer nope\r\n\r\n");
    let answer = tokio::time::timeout(PROMPT, stalled_request(&address, &wrong)).await.unwrap();
    assert_eq!(answer.as_deref(), Some("HTTP/1.1 401 Unauthorized"));
    let right = head.replace("\r\n\r\n", &format!("\r\nAuthorization: Bearer {TOKEN}\r\n\r\n"));
    let waiting = tokio::time::timeout(Duration::from_secs(1), stalled_request(&address, &right));
    assert!(waiting.await.is_err(), "an authorised upload should be waited for");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn hosts_refuse_link_local_metadata_and_file_inputs() {
    let dir = tempfile::tempdir().unwrap();
    let host = start_host(host_config(dir.path())).await;
    let client = HostClient::new(&host.url).with_token(CLUSTER_TOKEN);
    for url in [
        "http://169.254.169.254/latest/meta-data/iam/security-credentials/",
        "http://[fd00:ec2::254]/latest/",
        "http://metadata.google.internal/computeMetadata/v1/",
        "file:///etc/passwd",
        "http://127.0.0.1:9/not-a-peer.ply",
    ] {
        let refused = client.create_session(url, None).await.unwrap_err();
        assert!(
            matches!(&refused, meshflow_api::ClientError::Refused { status: 400, code, .. } if code == "url-not-allowed"),
            "{url}: {refused}"
        );
    }
}

/// A server that counts its requests and answers each with `answer`.
async fn serve(answer: axum::response::Response<String>) -> (String, Arc<AtomicUsize>) {
    let hits = Arc::new(AtomicUsize::new(0));
    let counted = hits.clone();
    let (status, headers, body) = {
        let (parts, body) = answer.into_parts();
        (parts.status, parts.headers, body)
    };
    let app = axum::Router::new().fallback(move || {
        counted.fetch_add(1, Ordering::SeqCst);
        let (headers, body) = (headers.clone(), body.clone());
        async move { (status, headers, body) }
    });
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let origin = format!("http://{}", listener.local_addr().unwrap());
    tokio::spawn(async move { axum::serve(listener, app).await });
    (origin, hits)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_redirect_out_of_the_allowed_origins_is_not_followed() {
    let (secret, secret_hits) = serve(axum::response::Response::new("TOP-SECRET".into())).await;
    let redirect = axum::response::Response::builder()
        .status(302)
        .header("location", format!("{secret}/secret"))
        .body(String::new())
        .unwrap();
    let (allowed, _) = serve(redirect).await;
    let dir = tempfile::tempdir().unwrap();
    let config = HostConfig { allow_input_from: vec![allowed.clone()], ..host_config(dir.path()) };
    let host = start_host(config).await;
    let client = HostClient::new(&host.url).with_token(CLUSTER_TOKEN);
    let created = client.create_session(&format!("{allowed}/scan.ply"), None).await.unwrap();
    let status = tokio::time::timeout(PROMPT * 4, client.wait_ready(&created.id)).await.unwrap();
    let status = status.unwrap();
    assert_eq!(status.state, SessionState::Failed);
    let error = status.error.unwrap_or_default();
    assert!(error.contains("origin is not one this server fetches from"), "{error}");
    assert!(!error.contains("TOP-SECRET"), "{error}");
    assert_eq!(secret_hits.load(Ordering::SeqCst), 0, "the redirect was followed");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn engines_refuse_inputs_from_origins_they_do_not_allow() {
    let cluster = Cluster::start(&[&["checks"]]).await;
    let workflow = json!({"steps": [{"run": "is-manifold"}]});
    for input in
        ["http://127.0.0.1:9/scan.ply", "http://169.254.169.254/x.ply", "file:///etc/passwd"]
    {
        let body = json!({"workflow": workflow, "input": input}).to_string();
        let (status, answer) = cluster.post_run(body).await;
        assert_eq!(status, 400, "{input}: {answer}");
        assert_eq!(answer["error"]["code"], "input-not-allowed", "{input}: {answer}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn half_sent_request_heads_are_cut_off() {
    let dir = tempfile::tempdir().unwrap();
    let host = start_host(host_config(dir.path())).await;
    let address = host.url.trim_start_matches("http://");
    let mut socket = TcpStream::connect(address).await.unwrap();
    socket.write_all(b"GET /health HTTP/1.1\r\nHost: x\r\n").await.unwrap();
    let started = Instant::now();
    let mut rest = Vec::new();
    let closed = tokio::time::timeout(HEADER_READ_TIMEOUT + PROMPT, socket.read_to_end(&mut rest));
    assert!(closed.await.is_ok(), "the connection stayed open");
    assert!(started.elapsed() >= HEADER_READ_TIMEOUT - Duration::from_secs(1));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn servers_without_tokens_listen_only_on_loopback() {
    let dir = tempfile::tempdir().unwrap();
    let open = HostConfig { cluster_token: None, ..host_config(dir.path()) };
    let listener = TcpListener::bind("0.0.0.0:0").await.unwrap();
    let error = meshflow_host::start(open.clone(), listener).await.err().expect("it started");
    assert!(error.to_string().contains("--insecure-no-auth"), "{error}");
    let insecure = HostConfig { insecure_no_auth: true, ..open };
    let host = meshflow_host::start(insecure, TcpListener::bind("0.0.0.0:0").await.unwrap());
    host.await.unwrap().shutdown().await.unwrap();

    let engine = |access| {
        let data = dir.path().join("engine");
        async move {
            let listener = TcpListener::bind("0.0.0.0:0").await.unwrap();
            meshflow_engine::start(data, None, &[], access, listener).await
        }
    };
    let cluster_only =
        meshflow_engine::Access { cluster_token: Some(CLUSTER_TOKEN.into()), ..Default::default() };
    let error = engine(cluster_only).await.err().expect("it started");
    assert!(error.to_string().contains("an API token"), "{error}");
    let both = meshflow_engine::Access {
        api_token: Some(API_TOKEN.into()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        ..Default::default()
    };
    engine(both).await.unwrap();
}
