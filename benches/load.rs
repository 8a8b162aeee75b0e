//! Load under failure, printed as a table: `cargo bench --bench load`.
//!
//! An engine and 4 hosts as separate `meshflow` processes on loopback (release build); 50
//! repair runs (RSC → LS(1) → HF → RDT) submitted at once on one generated 200k-vertex scan,
//! while a bounded chaos loop SIGKILLs a random host and starts it again on the same port
//! and data folder. Every run must complete with the hash of the same chain run locally;
//! the bench fails otherwise. It reports the wall time, the spread of run times, the kills,
//! and the peak resident memory of the engine and of each host process.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{Context, bail, ensure};
use meshflow_generate::{ScanSpec, scan};
use meshflow_meshio::{self as io, Format};
use meshflow_params::from_json as params_from_json;
use meshflow_runtime::{Catalog, Limits, Runtime};
use serde_json::{Value, json};

const RUNS: usize = 50;
const HOSTS: usize = 4;
const SCAN: ScanSpec =
    ScanSpec { vertices: 200_000, components: 30, holes: 60, noise: 0.1, seed: 5 };
const REPAIR: [&str; 4] = [
    "remove-smallest-components",
    "laplacian-smoothing",
    "fill-holes",
    "remove-degenerate-triangles",
];
/// The chaos loop stops after this many kills, or when every run has ended.
const MAX_KILLS: usize = 6;
const KILL_EVERY: Duration = Duration::from_secs(3);
const DOWN_FOR: Duration = Duration::from_secs(1);
const START_TIMEOUT: Duration = Duration::from_secs(120);
const RUN_TIMEOUT: Duration = Duration::from_secs(1200);

/// A `meshflow` server process, started again on the same arguments after a kill.
struct Server {
    url: String,
    args: Vec<String>,
    child: Child,
    /// The highest peak RSS of this server's processes so far, in KiB.
    peak_kib: u64,
}

impl Server {
    async fn start(args: Vec<String>, url: String) -> anyhow::Result<Self> {
        let child = spawn(&args)?;
        let server = Self { url, args, child, peak_kib: 0 };
        server.wait_healthy().await?;
        Ok(server)
    }

    fn spawn(&mut self) -> anyhow::Result<()> {
        self.child = spawn(&self.args)?;
        Ok(())
    }

    async fn wait_healthy(&self) -> anyhow::Result<()> {
        let deadline = Instant::now() + START_TIMEOUT;
        while reqwest::get(format!("{}/health", self.url)).await.is_err() {
            ensure!(Instant::now() < deadline, "{} did not start", self.url);
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        Ok(())
    }

    /// Reads the process's peak RSS, then SIGKILLs it.
    fn kill(&mut self) {
        self.peak_kib = self.peak_kib.max(peak_rss_kib(self.child.id()));
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.kill();
    }
}

fn spawn(args: &[String]) -> anyhow::Result<Child> {
    Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .context("starting meshflow")
}

/// `VmHWM` of a process, in KiB (0 when it cannot be read).
fn peak_rss_kib(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap_or("");
    line.split_whitespace().nth(1).and_then(|kib| kib.parse().ok()).unwrap_or(0)
}

fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

fn server_args(kind: &str, port: u16, data: &Path, extra: &[String]) -> Vec<String> {
    let mut args = vec![kind.to_owned(), "--listen".into(), format!("127.0.0.1:{port}")];
    args.extend(["--data".to_owned(), data.display().to_string()]);
    args.extend_from_slice(extra);
    args
}

/// The repair chain run in this process: the hash every run must reach.
fn local_hash(mesh: &meshflow_mesh::MeshData, cache: &Path) -> anyhow::Result<String> {
    let runtime = Runtime::new(Limits::default(), Some(cache))?;
    let mut catalog = Catalog::new();
    for builtin in meshflow_builtin_plugins::PLUGINS {
        catalog.add(runtime.load(builtin.wasm)?);
    }
    let mut mesh = mesh.clone();
    for service in REPAIR {
        let (plugin, info) = catalog.find(service).context("a built-in service")?;
        let params = params_from_json(info, &serde_json::Map::new())?;
        mesh = runtime.run(plugin, service, mesh, &params)?.mesh.context("a filter's mesh")?;
    }
    Ok(mesh.content_hash().to_hex())
}

struct Xorshift(u64);

impl Xorshift {
    fn below(&mut self, n: usize) -> usize {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 % n as u64) as usize
    }
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let mesh = scan(&SCAN);
    let mut ply = Vec::new();
    io::write_to(&mut ply, &mesh, Format::Ply)?;
    let mesh = io::load_bytes(&ply, Format::Ply, "scan.ply")?;
    let expected = local_hash(&mesh, &dir.path().join("cache"))?;
    println!(
        "mesh: generated scan, {} vertices, {} triangles",
        mesh.vertex_count(),
        mesh.triangle_count()
    );

    let mut hosts = Vec::new();
    for index in 0..HOSTS {
        let port = free_port();
        let data: PathBuf = dir.path().join(format!("host-{index}"));
        let args = server_args("host", port, &data, &[]);
        hosts.push(Server::start(args, format!("http://127.0.0.1:{port}")).await?);
    }
    let port = free_port();
    let host_flags: Vec<String> =
        hosts.iter().flat_map(|h| ["--host".to_owned(), h.url.clone()]).collect();
    let engine_args = server_args("engine", port, &dir.path().join("engine"), &host_flags);
    let mut engine = Server::start(engine_args, format!("http://127.0.0.1:{port}")).await?;

    let http = reqwest::Client::new();
    let uploaded: Value = http
        .post(format!("{}/inputs?name=scan.ply", engine.url))
        .body(ply)
        .send()
        .await?
        .error_for_status()?
        .json()
        .await?;
    let input = uploaded["url"].as_str().context("an input URL")?.to_owned();
    let workflow: Vec<Value> = REPAIR.iter().map(|s| json!({"run": s})).collect();
    let body = json!({"workflow": workflow, "input": input});

    let started = Instant::now();
    let mut ids = Vec::new();
    for _ in 0..RUNS {
        let answer: Value =
            http.post(format!("{}/runs", engine.url)).json(&body).send().await?.json().await?;
        ids.push(answer["id"].as_str().with_context(|| format!("refused: {answer}"))?.to_owned());
    }

    let mut random = Xorshift(0x9E37_79B9_7F4A_7C15);
    let mut kills = 0;
    let mut next_kill = Instant::now() + KILL_EVERY;
    let mut ended: Vec<Option<(Value, Duration)>> = vec![None; RUNS];
    while ended.iter().any(Option::is_none) {
        ensure!(started.elapsed() < RUN_TIMEOUT, "runs still going after {RUN_TIMEOUT:?}");
        for (id, end) in ids.iter().zip(&mut ended).filter(|(_, e)| e.is_none()) {
            let record: Value =
                http.get(format!("{}/runs/{id}", engine.url)).send().await?.json().await?;
            if !matches!(record["status"].as_str(), Some("queued" | "running")) {
                *end = Some((record, started.elapsed()));
            }
        }
        if kills < MAX_KILLS && Instant::now() >= next_kill {
            let host = &mut hosts[random.below(HOSTS)];
            host.kill();
            tokio::time::sleep(DOWN_FOR).await;
            host.spawn()?;
            host.wait_healthy().await?;
            kills += 1;
            next_kill = Instant::now() + KILL_EVERY;
        }
        tokio::time::sleep(Duration::from_millis(250)).await;
    }
    let wall = started.elapsed();

    let mut times = Vec::new();
    let mut failed_over = 0;
    for (record, time) in ended.into_iter().flatten() {
        if record["status"] != "completed" || record["result"]["hash"] != expected.as_str() {
            bail!(
                "run {} ended {}: {} (result {})",
                record["id"],
                record["status"],
                record["error"],
                record["result"]["hash"]
            );
        }
        failed_over += record["steps"]
            .as_array()
            .into_iter()
            .flatten()
            .filter(|s| s["failed_hosts"].as_array().is_some_and(|f| !f.is_empty()))
            .count();
        times.push(time.as_secs_f64());
    }
    times.sort_by(f64::total_cmp);
    engine.kill();
    hosts.iter_mut().for_each(Server::kill);
    println!(
        "\n| runs | hosts | kills | steps moved to another host | wall s | run s (min / median / max) | engine peak RSS MiB | host peak RSS MiB (max) |"
    );
    println!("|---:|---:|---:|---:|---:|---|---:|---:|");
    println!(
        "| {RUNS} | {HOSTS} | {kills} | {failed_over} | {:.1} | {:.1} / {:.1} / {:.1} | {:.0} | {:.0} |",
        wall.as_secs_f64(),
        times[0],
        times[times.len() / 2],
        times[times.len() - 1],
        engine.peak_kib as f64 / 1024.0,
        hosts.iter().map(|h| h.peak_kib).max().unwrap_or(0) as f64 / 1024.0,
    );
    println!("\nEvery run completed with the local chain's hash {expected}.");
    Ok(())
}
