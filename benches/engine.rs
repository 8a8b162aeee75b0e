//! Engine benchmarks (issue 5), printed as a table. Run with `cargo bench --bench engine`.
//!
//! Two hosts and an engine on loopback, real HTTP. Host A offers the smoothing family, host B
//! the cleanup family, so a workflow alternating LS(1) and RDT forwards every result from
//! one host to the other. On the 1M-vertex scan it reports, from the run's own record:
//! - the engine's overhead per step: from a host's reply to the next trigger, waiting for
//!   transfers excluded (goal ≤ 5 ms);
//! - downloading and applying each LS correction on the other host (goal ≤ 0.2 s);
//! - the same with `transfer: full`, side by side;
//! - all of it without tokens, with all three, and with all three over TLS (a throwaway CA
//!   trusted by this process), side by side: what the bearer checks and the fetch rules add
//!   per step, and what TLS adds on top of them per step and per MB moved.

mod common;

use meshflow_api::server::{TlsFiles, throwaway};
use meshflow_api::tls::ClientPolicy;
use meshflow_builtin_plugins::PLUGINS;
use meshflow_generate::scan;
use meshflow_host::{HostConfig, start};
use serde_json::{Value, json};
use tokio::net::TcpListener;

const ROUNDS: usize = 4;

fn family(name: &str) -> Vec<&'static [u8]> {
    PLUGINS.iter().filter(|p| p.name == name).map(|p| p.wasm).collect()
}

/// Two hosts (smoothing, cleanup) and an engine on loopback, with or without tokens, over
/// TLS when `tls` is given.
async fn cluster(
    dir: &std::path::Path,
    tokens: bool,
    tls: Option<&TlsFiles>,
) -> anyhow::Result<(meshflow_engine::EngineHandle, Vec<meshflow_host::HostHandle>)> {
    let token = |name: &str| tokens.then(|| format!("bench-{name}-token-0123"));
    let mut hosts = Vec::new();
    for (i, builtins) in [family("smoothing"), family("cleanup")].into_iter().enumerate() {
        let config = HostConfig {
            builtins,
            cluster_token: token("cluster"),
            tls: tls.cloned(),
            ..HostConfig::new(dir.join(format!("host-{i}")))
        };
        hosts.push(start(config, TcpListener::bind("127.0.0.1:0").await?).await?);
    }
    let urls: Vec<String> = hosts.iter().map(|h| h.url.clone()).collect();
    let access = meshflow_engine::Access {
        api_token: token("api"),
        cluster_token: token("cluster"),
        tls: tls.cloned(),
        ..Default::default()
    };
    let listener = TcpListener::bind("127.0.0.1:0").await?;
    let engine = meshflow_engine::start(dir.join("engine"), None, &urls, access, listener).await?;
    Ok((engine, hosts))
}

#[tokio::main]
async fn main() -> anyhow::Result<()> {
    let dir = tempfile::tempdir()?;
    let mesh = scan(&common::SCAN_1M);
    let input = dir.path().join("scan.mfm");
    std::fs::write(&input, meshflow_codec::pack::encode(&mesh)?)?;
    println!(
        "mesh: generated scan, {} vertices, {} triangles\n",
        mesh.vertex_count(),
        mesh.triangle_count()
    );

    let steps: Vec<Value> = (0..ROUNDS)
        .flat_map(|_| {
            [
                json!({"run": "laplacian-smoothing", "params": {"iterations": 1}}),
                json!({"run": "remove-degenerate-triangles"}),
            ]
        })
        .collect();
    println!(
        "| security | transfer | step | service | compute ms | engine overhead ms | sent as | KB | download ms | apply ms |"
    );
    println!("|---|---|---|---|---:|---:|---|---:|---:|---:|");
    let mut totals = Vec::new();
    // The same cluster twice, without tokens and with all three (every request's bearer
    // checked, every download under the fetch rules): what the checks cost per step.
    let pki = throwaway::make(&dir.path().join("pki"), "bench")?;
    ClientPolicy::installed().with_ca_file(&pki.ca)?.install();
    for (security, tokens, tls) in
        [("open", false, None), ("tokens", true, None), ("tokens+tls", true, Some(&pki.server))]
    {
        let (engine, _hosts) = cluster(&dir.path().join(security), tokens, tls).await?;
        let bytes = axum::body::Bytes::from(std::fs::read(&input)?);
        let body = futures_util::stream::once(async { Ok::<_, String>(bytes) });
        let (input_url, _) = engine.engine.put_input("scan.mfm", body, "bench").await?;
        for transfer in ["auto", "full"] {
            let workflow = json!({"steps": steps, "transfer": transfer});
            let run = engine.engine.submit(workflow, Some(input_url.clone()), "bench").await?;
            while !run.is_finished() {
                tokio::time::sleep(std::time::Duration::from_millis(20)).await;
            }
            let record = serde_json::to_value(run.record())?;
            anyhow::ensure!(record["status"] == "completed", "the run failed: {}", record["error"]);
            for step in record["steps"].as_array().into_iter().flatten() {
                for t in step["transfers"].as_array().into_iter().flatten() {
                    println!(
                        "| {security} | {transfer} | {} | {} | {:.0} | {:.2} | {} | {:.1} | {:.0} | {:.0} |",
                        step["index"],
                        step["service"].as_str().unwrap_or(""),
                        step["compute_ms"].as_f64().unwrap_or(0.0),
                        step["overhead_ms"].as_f64().unwrap_or(0.0),
                        t["via"].as_str().unwrap_or(""),
                        t["bytes"].as_f64().unwrap_or(0.0) / 1024.0,
                        t["download_ms"].as_f64().unwrap_or(0.0),
                        t["apply_ms"].as_f64().unwrap_or(0.0),
                    );
                }
            }
            let overheads: Vec<f64> = record["steps"]
                .as_array()
                .into_iter()
                .flatten()
                .skip(1)
                .filter_map(|s| s["overhead_ms"].as_f64())
                .collect();
            let worst = overheads.iter().cloned().fold(0.0, f64::max);
            let mean = overheads.iter().sum::<f64>() / overheads.len().max(1) as f64;
            let transfers = record["steps"]
                .as_array()
                .into_iter()
                .flatten()
                .flat_map(|s| s["transfers"].as_array().into_iter().flatten());
            let (mut moved, mut download_ms) = (0.0, 0.0);
            for t in transfers {
                moved += t["bytes"].as_f64().unwrap_or(0.0);
                download_ms += t["download_ms"].as_f64().unwrap_or(0.0);
            }
            let per_mb = download_ms / (moved / 1e6).max(1e-9);
            totals.push(format!(
            "{security}, {transfer}: total {:.2} s; engine overhead per step mean {mean:.2} ms, worst {worst:.2} ms (goal ≤ 5 ms); {:.1} MB moved, {per_mb:.1} ms per MB downloaded",
            record["total_ms"].as_f64().unwrap_or(0.0) / 1e3,
            moved / 1e6
        ));
        }
    }
    println!();
    for line in totals {
        println!("{line}");
    }
    println!(
        "goal: an LS correction of a 1M-vertex mesh downloaded and applied in ≤ 200 ms (rows 'auto', laplacian-smoothing)"
    );
    Ok(())
}
