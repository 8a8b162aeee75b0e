//! Operations over real HTTP on 127.0.0.1 (DESIGN §11): `/metrics` of the engine and of a
//! host read as Prometheus text and moving by exactly one run, `/ready` saying what is
//! missing, and `--log-format json` writing JSON lines. Who may scrape from elsewhere than
//! the loopback is unit-tested where the rule is (`metrics.rs` of the engine and the host).

mod common;

use std::collections::BTreeMap;
use std::io::BufRead;
use std::process::{Command, Stdio};
use std::time::Duration;

use common::{API_TOKEN, CLUSTER_TOKEN, Cluster, Input, builtins, components_cache, steps, text};
use meshflow_host::HostConfig;
use prometheus_parse::{Scrape, Value};
use serde_json::{Value as Json, json};
use tokio::net::TcpListener;

/// How long a counter may take to catch up with a run that has ended (the run's status is
/// set a moment before its last bookkeeping).
const SETTLE: Duration = Duration::from_secs(10);

/// `GET {base}/metrics` from the loopback, without any token: checked line by line, then
/// parsed.
async fn scrape(base: &str) -> Scrape {
    let answer = reqwest::get(format!("{base}/metrics")).await.unwrap();
    assert_eq!(answer.status(), 200, "{base}/metrics");
    let kind = answer.headers()["content-type"].to_str().unwrap().to_owned();
    assert!(kind.starts_with("text/plain; version=0.0.4"), "{kind}");
    let body = answer.text().await.unwrap();
    check_exposition(&body);
    Scrape::parse(body.lines().map(|line| Ok(line.to_owned()))).unwrap()
}

/// Every line is a `# HELP` or `# TYPE` comment of a `meshflow_` metric, or a sample
/// `name{label="value",…} value` with a valid float; every TYPE has its HELP.
fn check_exposition(body: &str) {
    let mut helped = Vec::new();
    for line in body.lines() {
        if let Some(rest) = line.strip_prefix("# HELP ") {
            let (name, help) = rest.split_once(' ').expect("a HELP line names a metric");
            assert!(name.starts_with("meshflow_") && !help.is_empty(), "{line}");
            helped.push(name.to_owned());
        } else if let Some(rest) = line.strip_prefix("# TYPE ") {
            let (name, kind) = rest.split_once(' ').expect("a TYPE line names a metric");
            assert!(helped.iter().any(|h| h == name), "TYPE before HELP: {line}");
            assert!(["counter", "gauge", "histogram"].contains(&kind), "{line}");
        } else {
            assert!(is_sample(line), "not a Prometheus sample: {line:?}");
        }
    }
    assert!(!helped.is_empty(), "no metrics:\n{body}");
}

fn is_sample(line: &str) -> bool {
    let Some((series, value)) = line.rsplit_once(' ') else { return false };
    let valid_value = value.parse::<f64>().is_ok() || ["+Inf", "-Inf", "NaN"].contains(&value);
    let (name, labels) = match series.split_once('{') {
        Some((name, rest)) => match rest.strip_suffix('}') {
            Some(labels) => (name, Some(labels)),
            None => return false,
        },
        None => (series, None),
    };
    let name_ok = name.starts_with("meshflow_")
        && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_' || c == ':');
    let labels_ok = labels.is_none_or(|labels| {
        labels.split(',').all(|pair| {
            pair.split_once('=').is_some_and(|(key, value)| {
                !key.is_empty()
                    && key.chars().all(|c| c.is_ascii_alphanumeric() || c == '_')
                    && value.len() >= 2
                    && value.starts_with('"')
                    && value.ends_with('"')
            })
        })
    });
    valid_value && name_ok && labels_ok
}

/// The sum of the samples of `metric` whose labels include `labels`.
fn value(scrape: &Scrape, metric: &str, labels: &[(&str, &str)]) -> f64 {
    let matching = scrape.samples.iter().filter(|sample| {
        sample.metric == metric && labels.iter().all(|(k, v)| sample.labels.get(k) == Some(*v))
    });
    matching
        .map(|sample| match &sample.value {
            Value::Counter(v) | Value::Gauge(v) | Value::Untyped(v) => *v,
            other => panic!("{metric} is not a single number: {other:?}"),
        })
        .sum()
}

/// Polls the engine's metrics until `reached` holds (bounded by [`SETTLE`]).
async fn scrape_until(base: &str, reached: impl Fn(&Scrape) -> bool) -> Scrape {
    let deadline = tokio::time::Instant::now() + SETTLE;
    loop {
        let scraped = scrape(base).await;
        if reached(&scraped) {
            return scraped;
        }
        assert!(tokio::time::Instant::now() < deadline, "{base}/metrics never got there");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn metrics_move_by_exactly_one_run() {
    let cluster = Cluster::start(&[&["cleanup"], &["smoothing"]]).await;
    let engine = cluster.engine.url.clone();
    let hosts: Vec<String> = cluster.hosts.iter().map(|h| h.url.clone()).collect();
    let url = cluster.upload(&Input::bunny()).await;

    let engine_before = scrape(&engine).await;
    let mut hosts_before = BTreeMap::new();
    for host in &hosts {
        hosts_before.insert(host.clone(), scrape(host).await);
    }
    assert_eq!(value(&engine_before, "meshflow_engine_hosts", &[("state", "up")]), 2.0);
    let finished =
        |s: &Scrape| value(s, "meshflow_engine_runs_finished_total", &[("status", "completed")]);

    // A step on each host: the smoothing host takes the cleanup's edit log.
    let workflow = json!({
        "steps": [{"run": "remove-smallest-components"}, {"run": "laplacian-smoothing"}],
        "transfer": "correction",
    });
    let id = cluster.submit(&workflow, &url).await;
    let record = cluster.finished(&id).await;
    assert_eq!(record["status"], "completed", "{}", record["error"]);

    let engine_after = scrape_until(&engine, |s| finished(s) > finished(&engine_before)).await;
    let delta = |metric: &str, labels: &[(&str, &str)]| {
        value(&engine_after, metric, labels) - value(&engine_before, metric, labels)
    };
    assert_eq!(delta("meshflow_engine_runs_finished_total", &[("status", "completed")]), 1.0);
    assert_eq!(delta("meshflow_engine_runs_finished_total", &[]), 1.0, "one run ended");
    assert_eq!(delta("meshflow_engine_runs", &[("status", "completed")]), 1.0);
    assert_eq!(value(&engine_after, "meshflow_engine_runs", &[("status", "running")]), 0.0);
    assert_eq!(value(&engine_after, "meshflow_engine_runs", &[("status", "queued")]), 0.0);
    let filters = [("kind", "filter")];
    assert_eq!(delta("meshflow_engine_step_duration_seconds_count", &filters), 2.0);
    assert!(delta("meshflow_engine_step_duration_seconds_sum", &filters) > 0.0);
    let moved = delta("meshflow_engine_transferred_bytes_total", &[]);
    let recorded: u64 = steps(&record)
        .iter()
        .flat_map(|step| step["transfers"].as_array().unwrap())
        .map(|transfer| transfer["bytes"].as_u64().unwrap())
        .sum();
    assert!(moved > 0.0, "no bytes moved between hosts");
    assert_eq!(moved, recorded as f64, "the bytes moved are the record's transfers'");
    assert_eq!(delta("meshflow_engine_transfer_duration_seconds_count", &[]), {
        let transfers = steps(&record).iter().map(|s| s["transfers"].as_array().unwrap().len());
        transfers.sum::<usize>() as f64
    });

    for host in &hosts {
        let after = scrape(host).await;
        let before = &hosts_before[host];
        let delta = |metric: &str, labels: &[(&str, &str)]| {
            value(&after, metric, labels) - value(before, metric, labels)
        };
        let ran = steps(&record).iter().filter(|step| text(&step["host"]) == host).count();
        assert_eq!(ran, 1, "{host} ran one step: {record:#}");
        let runs = "meshflow_host_sandbox_runs_total";
        assert_eq!(delta(runs, &[]), ran as f64, "{host}");
        assert_eq!(delta(runs, &[("outcome", "ok")]), ran as f64, "{host}");
        let durations = "meshflow_host_sandbox_run_duration_seconds_count";
        assert_eq!(delta(durations, &[("kind", "filter")]), ran as f64, "{host}");
        assert!(delta("meshflow_host_downloaded_bytes_total", &[]) > 0.0, "{host}: the input");
        assert!(value(&after, "meshflow_host_blobs_stored_bytes", &[]) > 0.0, "{host}");
        assert!(after.samples.iter().any(|s| s.metric == "meshflow_host_sessions"), "{host}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn ready_says_what_is_missing_and_needs_no_token() {
    let data = tempfile::tempdir().unwrap();
    let access = meshflow_engine::Access {
        api_token: Some(API_TOKEN.into()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        ..Default::default()
    };
    let listener = TcpListener::bind("127.0.0.1:0").await.unwrap();
    let engine = meshflow_engine::start(data.path().join("engine"), None, &[], access, listener)
        .await
        .unwrap();
    let get = |path: &str| reqwest::get(format!("{}{path}", engine.url));

    // Open without a token, unlike the API.
    assert_eq!(get("/runs").await.unwrap().status(), 401);
    assert_eq!(get("/health").await.unwrap().status(), 200);
    let not_ready = get("/ready").await.unwrap();
    assert_eq!(not_ready.status(), 503);
    let body: Json = not_ready.json().await.unwrap();
    assert_eq!(body["error"]["code"], "not-ready", "{body}");
    assert!(text(&body["error"]["message"]).contains("no host"), "{body}");
    let metrics = scrape(&engine.url).await;
    assert_eq!(value(&metrics, "meshflow_engine_hosts", &[]), 0.0);

    // A host with no plugin is alive but not ready.
    let bare = HostConfig {
        artefact_cache: Some(components_cache()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        ..HostConfig::new(data.path().join("bare"))
    };
    let bare =
        meshflow_host::start(bare, TcpListener::bind("127.0.0.1:0").await.unwrap()).await.unwrap();
    let answer = reqwest::get(format!("{}/ready", bare.url)).await.unwrap();
    assert_eq!(answer.status(), 503);
    let body: Json = answer.json().await.unwrap();
    assert!(text(&body["error"]["message"]).contains("no plugin"), "{body}");

    let config = HostConfig {
        builtins: builtins(&["checks"]),
        artefact_cache: Some(components_cache()),
        cluster_token: Some(CLUSTER_TOKEN.into()),
        ..HostConfig::new(data.path().join("host"))
    };
    let host = meshflow_host::start(config, TcpListener::bind("127.0.0.1:0").await.unwrap())
        .await
        .unwrap();
    assert_eq!(reqwest::get(format!("{}/ready", host.url)).await.unwrap().status(), 200);
    assert_eq!(reqwest::get(format!("{}/sessions/x", host.url)).await.unwrap().status(), 401);
    scrape(&host.url).await;

    let registered = reqwest::Client::new()
        .post(format!("{}/hosts", engine.url))
        .bearer_auth(CLUSTER_TOKEN)
        .json(&json!({"url": host.url}))
        .send()
        .await
        .unwrap();
    assert!(registered.status().is_success(), "{}", registered.text().await.unwrap());
    let ready = get("/ready").await.unwrap();
    assert_eq!(ready.status(), 200);
    assert_eq!(ready.json::<Json>().await.unwrap()["hosts_up"], 1);
    host.shutdown().await.unwrap();
    bare.shutdown().await.unwrap();
}

#[test]
fn json_logs_are_one_object_a_line() {
    let data = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_meshflow"))
        .args(["host", "--listen", "127.0.0.1:0", "--builtin", "checks", "--log-format", "json"])
        .arg("--data")
        .arg(data.path())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("starting meshflow host");
    let stderr = child.stderr.take().unwrap();
    let (sender, lines) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        for line in std::io::BufReader::new(stderr).lines() {
            if sender.send(line).is_err() {
                return;
            }
        }
    });
    let first = lines.recv_timeout(Duration::from_secs(60));
    let _ = child.kill();
    let _ = child.wait();
    let first = first.expect("a log line within a minute").unwrap();
    let line: Json = serde_json::from_str(&first)
        .unwrap_or_else(|error| panic!("not JSON ({error}): {first:?}"));
    for key in ["timestamp", "level", "message"] {
        assert!(line[key].is_string(), "no {key}: {line}");
    }
    assert_eq!(line["level"], "INFO", "{line}");
    assert!(text(&line["message"]).contains("listening"), "{line}");
}
