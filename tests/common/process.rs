//! Hosts and engines as separate `meshflow` processes, so a test can kill one outright.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Duration;

use meshflow_api::HostClient;

/// How long a fresh host may take to compile its plugins and answer.
const START_TIMEOUT: Duration = Duration::from_secs(60);

/// A `meshflow host` child process; killed when dropped.
pub struct HostProcess {
    pub url: String,
    child: Child,
}

impl HostProcess {
    /// Starts `meshflow host` on a free loopback port with its data under `data`, offering
    /// the built-in plugin `families` (all of them when empty), and waits until it answers
    /// `/health`.
    pub async fn start(data: &Path, families: &[&str]) -> Self {
        let port = free_port();
        let mut command = Command::new(env!("CARGO_BIN_EXE_meshflow"));
        command.args(["host", "--listen", &format!("127.0.0.1:{port}"), "--data"]).arg(data);
        command.env("MESHFLOW_CLUSTER_TOKEN", super::CLUSTER_TOKEN);
        if !families.is_empty() {
            command.args(["--builtin", &families.join(",")]);
        }
        let child = command
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting meshflow host");
        let host = Self { url: format!("http://127.0.0.1:{port}"), child };
        let client = HostClient::new(&host.url);
        let deadline = tokio::time::Instant::now() + START_TIMEOUT;
        while client.health().await.is_err() {
            assert!(tokio::time::Instant::now() < deadline, "{} did not start", host.url);
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
        host
    }

    /// SIGKILL: the host vanishes mid-request, as on a crash.
    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for HostProcess {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A `meshflow engine` child process on a fixed port and data folder, so it can be killed
/// and started again where it was; killed when dropped.
pub struct EngineProcess {
    pub url: String,
    port: u16,
    data: std::path::PathBuf,
    /// What a restart is started with (no `--host`: it must know them from before).
    args: Vec<String>,
    child: Child,
}

impl EngineProcess {
    /// Starts `meshflow engine` with its state under `data`, the given `--host`s and inputs
    /// also allowed from `origins`, and waits until it answers `/health`.
    pub async fn start(data: &Path, hosts: &[String], origins: &[String]) -> Self {
        let port = free_port();
        let allow: Vec<String> =
            origins.iter().flat_map(|o| ["--allow-input-from".into(), o.clone()]).collect();
        let named = hosts.iter().flat_map(|h| ["--host".into(), h.clone()]);
        let child = Self::spawn(port, data, &named.chain(allow.clone()).collect::<Vec<_>>());
        let url = format!("http://127.0.0.1:{port}");
        let engine = Self { url, port, data: data.into(), args: allow, child };
        engine.wait_healthy().await;
        engine
    }

    /// SIGKILL, then a new engine on the same port and data, knowing no host but what it
    /// stored.
    pub async fn kill_and_restart(&mut self) {
        self.kill();
        self.restart().await;
    }

    /// A new engine on the same port and data (after [`kill`](Self::kill)).
    pub async fn restart(&mut self) {
        self.child = Self::spawn(self.port, &self.data, &self.args);
        self.wait_healthy().await;
    }

    fn spawn(port: u16, data: &Path, args: &[String]) -> Child {
        let mut command = Command::new(env!("CARGO_BIN_EXE_meshflow"));
        command.args(["engine", "--listen", &format!("127.0.0.1:{port}"), "--data"]).arg(data);
        command.args(args);
        // Tokens travel in the environment, never on a command line.
        command.env("MESHFLOW_API_TOKEN", super::API_TOKEN);
        command.env("MESHFLOW_CLUSTER_TOKEN", super::CLUSTER_TOKEN);
        command.stdout(Stdio::null()).stderr(Stdio::null()).spawn().expect("starting the engine")
    }

    async fn wait_healthy(&self) {
        let health = format!("{}/health", self.url);
        let deadline = tokio::time::Instant::now() + START_TIMEOUT;
        while reqwest::get(&health).await.is_err() {
            assert!(tokio::time::Instant::now() < deadline, "{} did not start", self.url);
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }

    pub fn kill(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Drop for EngineProcess {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A port nobody listens on right now (the OS hands out ephemeral ports in turn, so it is
/// very unlikely to be taken again before the host binds it).
fn free_port() -> u16 {
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.local_addr().unwrap().port()
}

/// A `meshflow up` child process and what it printed up to its last hint; killed when
/// dropped.
pub struct UpProcess {
    child: Child,
    /// Everything `up` printed: the engine's and hosts' URLs, the tokens, the CA.
    pub printed: String,
}

impl UpProcess {
    /// Starts `meshflow up ARGS` with no tokens from the environment (so it makes fresh
    /// ones) and reads its output until the last hint, in bounded time.
    pub fn start(args: &[&str]) -> Self {
        use std::io::BufRead;
        let mut child = Command::new(env!("CARGO_BIN_EXE_meshflow"))
            .arg("up")
            .args(args)
            .env("MESHFLOW_CACHE_DIR", super::components_cache())
            .env_remove("MESHFLOW_API_TOKEN")
            .env_remove("MESHFLOW_CLUSTER_TOKEN")
            .env_remove("MESHFLOW_UPLOAD_TOKEN")
            .env_remove("MESHFLOW_CA_FILE")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("starting meshflow up");
        let stdout = child.stdout.take().unwrap();
        let (lines, printed) = std::sync::mpsc::channel();
        // Read to the end: a reader that stopped would close the pipe, and `up` would die of
        // the broken pipe at the next line it prints.
        std::thread::spawn(move || {
            for line in std::io::BufReader::new(stdout).lines().map_while(Result::ok) {
                let _ = lines.send(line);
            }
        });
        let mut up = Self { child, printed: String::new() };
        while !up.printed.contains("MESHFLOW_UPLOAD_TOKEN") {
            let line = printed.recv_timeout(Duration::from_secs(120)).expect("up printed");
            up.printed.push_str(&line);
            up.printed.push('\n');
        }
        up
    }

    /// The rest of the first printed line that contains `prefix`, after it.
    pub fn field(&self, prefix: &str) -> String {
        let line = self.printed.lines().find_map(|l| l.split_once(prefix)).map(|(_, rest)| rest);
        line.unwrap_or_else(|| panic!("no {prefix:?} in {}", self.printed)).trim().to_owned()
    }

    /// The hosts' URLs, as printed.
    pub fn hosts(&self) -> Vec<String> {
        let hosts = self.printed.lines().filter_map(|l| l.strip_prefix("host:"));
        hosts.map(|url| url.trim().to_owned()).collect()
    }
}

impl Drop for UpProcess {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Runs `meshflow ARGS` here, sharing the tests' compiled components.
pub fn meshflow(args: &[&str]) -> std::process::Output {
    meshflow_in(Path::new("."), args)
}

/// The standard output of `meshflow ARGS`, which must succeed.
pub fn ok(args: &[&str]) -> String {
    let out = meshflow(args);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "meshflow {args:?} failed: {stderr}");
    String::from_utf8(out.stdout).expect("utf-8 output")
}

/// The standard error of `meshflow ARGS`, which must fail.
pub fn failure(args: &[&str]) -> String {
    let out = meshflow(args);
    assert!(!out.status.success(), "meshflow {args:?} should fail");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs `meshflow ARGS` in `dir`, sharing the tests' compiled components.
pub fn meshflow_in(dir: &Path, args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .current_dir(dir)
        .args(args)
        .env("MESHFLOW_CACHE_DIR", super::components_cache())
        .output()
        .expect("running meshflow")
}
