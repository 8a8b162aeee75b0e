//! Memory under the attacks of issue 13, printed as a table: `cargo bench --bench attacks`.
//!
//! An engine and a host as separate `meshflow` processes on loopback, both with tokens, and
//! a hostile HTTP server in this process. Each attack runs in turn; after each the table
//! gives the peak resident memory (`VmHWM`) of the engine and of the host, and whether the
//! servers still answered everyone else at once. Peaks only grow, so each row is the most
//! either process has held up to then.

use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, ensure};
use axum::Router;
use axum::body::Body;
use axum::http::StatusCode;
use axum::routing::get;
use futures_util::StreamExt;
use meshflow_api::HostClient;
use tokio::io::AsyncWriteExt;

const API_TOKEN: &str = "attacks-api-token-0001";
const CLUSTER_TOKEN: &str = "attacks-cluster-token-01";
const UPLOAD_TOKEN: &str = "attacks-upload-token-001";
const GIB: u64 = 1 << 30;
const MIB: u64 = 1 << 20;
/// The host's download cap in this bench (its default is 2 GiB).
const HOST_DOWNLOAD_CAP_MIB: u64 = 256;

struct Server {
    child: Child,
    url: String,
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Server {
    fn peak_mib(&self) -> f64 {
        let status = std::fs::read_to_string(format!("/proc/{}/status", self.child.id()))
            .unwrap_or_default();
        let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap_or("");
        let kib: f64 = line.split_whitespace().nth(1).and_then(|k| k.parse().ok()).unwrap_or(0.0);
        kib / 1024.0
    }

    /// Whether `/health` answers within a second (the server still serves others).
    async fn answers(&self) -> bool {
        let health = reqwest::Client::new().get(format!("{}/health", self.url));
        matches!(health.timeout(Duration::from_secs(1)).send().await, Ok(r) if r.status().is_success())
    }
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

async fn start(args: &[String], url: String) -> anyhow::Result<Server> {
    let child = Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(args)
        .env("MESHFLOW_API_TOKEN", API_TOKEN)
        .env("MESHFLOW_CLUSTER_TOKEN", CLUSTER_TOKEN)
        .env("MESHFLOW_UPLOAD_TOKEN", UPLOAD_TOKEN)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .context("starting meshflow")?;
    let server = Server { child, url };
    let deadline = Instant::now() + Duration::from_secs(120);
    while !server.answers().await {
        ensure!(Instant::now() < deadline, "{} did not start", server.url);
        tokio::time::sleep(Duration::from_millis(100)).await;
    }
    Ok(server)
}

/// `bytes` of zeros as a stream of 1 MiB chunks, never held whole.
fn zeros(
    bytes: u64,
) -> impl futures_util::Stream<Item = Result<axum::body::Bytes, std::io::Error>> + Send + 'static {
    const CHUNK: usize = 1 << 20;
    futures_util::stream::iter(0..bytes.div_ceil(CHUNK as u64)).map(move |i| {
        let len = CHUNK.min((bytes - i * CHUNK as u64) as usize);
        Ok(axum::body::Bytes::from(vec![0u8; len]))
    })
}

/// The same as a request body.
fn upload(bytes: u64) -> reqwest::Body {
    reqwest::Body::wrap_stream(zeros(bytes))
}

/// The hostile server: `/error` answers 500 with 1 GiB, `/huge.ply` 200 with 1 GiB.
async fn hostile() -> anyhow::Result<String> {
    let app = Router::new()
        .route(
            "/error",
            get(|| async { (StatusCode::INTERNAL_SERVER_ERROR, Body::from_stream(zeros(GIB))) }),
        )
        .route("/huge.ply", get(|| async { (StatusCode::OK, Body::from_stream(zeros(GIB))) }));
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await?;
    let url = format!("http://{}", listener.local_addr()?);
    tokio::spawn(async move { axum::serve(listener, app).await });
    Ok(url)
}

/// Opens a session on `url` and waits until the host gave up on it; the host's error.
async fn session_error(host: &HostClient, url: &str) -> anyhow::Result<String> {
    let created = host.create_session(url, None).await?;
    let status = host.wait_ready(&created.id).await?;
    Ok(status.error.unwrap_or_default())
}

/// 40 anonymous uploads that each announce 60 MiB, send a little and stall.
async fn stalled_uploads(host: &str) -> anyhow::Result<usize> {
    let address = host.trim_start_matches("http://").to_owned();
    let mut refused = 0;
    let attempts = (0..40).map(|_| {
        let address = address.clone();
        async move {
            let mut stream = tokio::net::TcpStream::connect(&address).await?;
            let head = format!(
                "POST /plugins HTTP/1.1\r\nhost: {address}\r\ncontent-length: {}\r\n\r\n",
                60 * MIB
            );
            stream.write_all(head.as_bytes()).await?;
            stream.write_all(&vec![0u8; 64 << 10]).await?;
            let mut answer = [0u8; 12];
            tokio::time::timeout(
                Duration::from_secs(10),
                tokio::io::AsyncReadExt::read_exact(&mut stream, &mut answer),
            )
            .await??;
            Ok::<_, anyhow::Error>(answer.starts_with(b"HTTP/1.1 401"))
        }
    });
    for outcome in futures_util::future::join_all(attempts).await {
        refused += usize::from(outcome.unwrap_or(false));
    }
    Ok(refused)
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let hostile = hostile().await?;
    let (engine_port, host_port) = (free_port(), free_port());
    let engine_url = format!("http://127.0.0.1:{engine_port}");
    let data = |name: &str| dir.path().join(name).display().to_string();
    let host_args: Vec<String> = [
        "host",
        "--listen",
        &format!("127.0.0.1:{host_port}"),
        "--data",
        &data("host"),
        "--engine",
        &engine_url,
        "--allow-input-from",
        &hostile,
        "--max-download-mib",
        &HOST_DOWNLOAD_CAP_MIB.to_string(),
    ]
    .map(str::to_owned)
    .to_vec();
    let host = start(&host_args, format!("http://127.0.0.1:{host_port}")).await?;
    let engine_args: Vec<String> = [
        "engine",
        "--listen",
        &format!("127.0.0.1:{engine_port}"),
        "--data",
        &data("engine"),
        "--host",
        &host.url,
    ]
    .map(str::to_owned)
    .to_vec();
    let engine = start(&engine_args, engine_url.clone()).await?;
    let client = HostClient::new(&host.url).with_token(CLUSTER_TOKEN);
    let http = reqwest::Client::new();

    let mut rows =
        vec![("started".to_owned(), String::new(), engine.peak_mib(), host.peak_mib(), true)];
    let row = |attack: &str, outcome: String, rows: &mut Vec<_>, up: bool| {
        rows.push((attack.to_owned(), outcome, engine.peak_mib(), host.peak_mib(), up));
    };

    // 1. A 3 GiB anonymous upload: refused before its body is read.
    let started = Instant::now();
    let answer =
        http.post(format!("{engine_url}/inputs?name=a.ply")).body(upload(3 * GIB)).send().await;
    let outcome = match answer {
        Ok(answer) => format!("{} in {:.2} s", answer.status(), started.elapsed().as_secs_f64()),
        Err(error) => format!("closed in {:.2} s ({error})", started.elapsed().as_secs_f64()),
    };
    let up = engine.answers().await;
    row("3 GiB anonymous POST /inputs", outcome, &mut rows, up);

    // 2. A 3 GiB upload with the API token: streamed to disk, then swept with its runs.
    let started = Instant::now();
    let answer = http
        .post(format!("{engine_url}/inputs?name=a.ply"))
        .bearer_auth(API_TOKEN)
        .body(upload(3 * GIB))
        .send()
        .await?;
    let outcome = format!("{} in {:.1} s", answer.status(), started.elapsed().as_secs_f64());
    let up = engine.answers().await;
    row("3 GiB POST /inputs with the token", outcome, &mut rows, up);

    // 3. 40 stalled anonymous 60 MiB plugin uploads.
    let refused = stalled_uploads(&host.url).await?;
    let up = host.answers().await;
    row(
        "40 stalled anonymous 60 MiB uploads",
        format!("{refused} of 40 answered 401"),
        &mut rows,
        up,
    );

    // 4. An input answering 500 with a 1 GiB body.
    let error = session_error(&client, &format!("{hostile}/error")).await?;
    let up = host.answers().await;
    row("input answering 500 with 1 GiB", error.chars().take(60).collect(), &mut rows, up);

    // 5. An input of 1 GiB, over the host's download cap.
    let error = session_error(&client, &format!("{hostile}/huge.ply")).await?;
    let up = host.answers().await;
    row("1 GiB input over a 256 MiB cap", error.chars().take(60).collect(), &mut rows, up);

    println!("\n| after | outcome | engine peak RSS MiB | host peak RSS MiB | both still answer |");
    println!("|---|---|---:|---:|---|");
    for (attack, outcome, engine_mib, host_mib, up) in &rows {
        println!(
            "| {attack} | {outcome} | {engine_mib:.0} | {host_mib:.0} | {} |",
            if *up { "yes" } else { "NO" }
        );
    }
    ensure!(rows.iter().all(|r| r.4), "a server stopped answering");
    Ok(())
}
