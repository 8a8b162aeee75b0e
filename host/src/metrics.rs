//! What a host tells Prometheus (`GET /metrics`, DESIGN §11): service runs in the sandbox by
//! outcome and their durations, open sessions, bytes stored as blobs and bytes downloaded.
//!
//! Counters and histograms are fed where things happen (`steps.rs`, `downloads.rs`); gauges
//! are read from the host's state when scraped. Every series of a known label value exists
//! from the start, at zero. Who may scrape is `meshflow_api::server::may_scrape`.

use std::path::Path;
use std::time::Duration;

use meshflow_runtime::{RunError, ServiceKind};
use prometheus_client::encoding::prometheus_text;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::{Registry, Unit};

/// One label: its name and value.
type Label = [(&'static str, &'static str); 1];

/// How a sandbox run ended: `error` is every other failure (a trap, fuel, the edit budget,
/// too much output, a plugin's own error or a result that breaks its description).
const OUTCOMES: [&str; 4] = ["ok", "error", "deadline", "memory"];
const KINDS: [&str; 2] = ["filter", "check"];

/// The `Content-Type` of [`Metrics::render`]'s text.
pub const CONTENT_TYPE: &str = prometheus_text::CONTENT_TYPE;

/// Durations from 1 ms to about 65 s, doubling.
fn duration_buckets() -> Histogram {
    Histogram::new(exponential_buckets(0.001, 2.0, 17))
}

pub struct Metrics {
    registry: Registry,
    sandbox_runs: Family<Label, Counter>,
    run_duration: Family<Label, Histogram, fn() -> Histogram>,
    sessions: Gauge,
    running: Gauge,
    blobs: Gauge,
}

impl Metrics {
    /// The host's metrics; `downloaded` is the counter its downloads add their bytes to.
    pub fn new(downloaded: Counter) -> Self {
        let mut registry = Registry::with_prefix("meshflow_host");
        let sandbox_runs = Family::<Label, Counter>::default();
        registry.register(
            "sandbox_runs",
            "Service runs in the sandbox for POST /sessions/{id}/run, by outcome (ok, error, \
             deadline, memory); replays of other hosts' steps are not counted",
            sandbox_runs.clone(),
        );
        let run_duration: Family<Label, Histogram, fn() -> Histogram> =
            Family::new_with_constructor(duration_buckets);
        registry.register_with_unit(
            "sandbox_run_duration",
            "Time a service run took in the sandbox, by kind (filter or check)",
            Unit::Seconds,
            run_duration.clone(),
        );
        let sessions = Gauge::default();
        registry.register("sessions", "Sessions open (loading, ready or failed)", sessions.clone());
        let running = Gauge::default();
        registry.register("runs_in_progress", "Service runs in progress", running.clone());
        let blobs = Gauge::default();
        registry.register_with_unit(
            "blobs_stored",
            "Bytes of the blobs (edit logs, replays, full meshes, inputs) stored on disk",
            Unit::Bytes,
            blobs.clone(),
        );
        registry.register_with_unit(
            "downloaded",
            "Bytes downloaded: inputs, edit logs, replays and full meshes from the engine and \
             other hosts",
            Unit::Bytes,
            downloaded,
        );
        for outcome in OUTCOMES {
            sandbox_runs.get_or_create_owned(&[("outcome", outcome)]);
        }
        for kind in KINDS {
            run_duration.get_or_create_owned(&[("kind", kind)]);
        }
        Self { registry, sandbox_runs, run_duration, sessions, running, blobs }
    }

    /// A service of `kind` ran in the sandbox: it answered after `Ok(took)`, or failed. A
    /// run refused for want of a slot (`Busy`) never ran and is not counted.
    pub fn sandbox_run(&self, kind: ServiceKind, outcome: Result<Duration, &RunError>) {
        let outcome = match outcome {
            Ok(took) => {
                let kind = match kind {
                    ServiceKind::Filter => "filter",
                    ServiceKind::Check => "check",
                };
                self.run_duration.get_or_create(&[("kind", kind)]).observe(took.as_secs_f64());
                "ok"
            }
            Err(RunError::Busy { .. }) => return,
            Err(RunError::Deadline { .. }) => "deadline",
            Err(RunError::Memory { .. }) => "memory",
            Err(_) => "error",
        };
        self.sandbox_runs.get_or_create(&[("outcome", outcome)]).inc();
    }

    /// The metrics in the Prometheus text format, with the gauges set from the host's
    /// `sessions`, `running` runs and the blobs under `blob_dir`.
    pub async fn render(&self, sessions: usize, running: usize, blob_dir: &Path) -> String {
        self.sessions.set(i64::try_from(sessions).unwrap_or(i64::MAX));
        self.running.set(i64::try_from(running).unwrap_or(i64::MAX));
        let dir = blob_dir.to_owned();
        match tokio::task::spawn_blocking(move || stored_bytes(&dir)).await {
            Ok(Ok(bytes)) => {
                self.blobs.set(i64::try_from(bytes).unwrap_or(i64::MAX));
            }
            Ok(Err(error)) => tracing::warn!("measuring the blobs for /metrics: {error}"),
            Err(error) => tracing::warn!("measuring the blobs for /metrics: {error}"),
        }
        let mut text = String::new();
        prometheus_text::encode(&mut text, &self.registry).expect("writing to a String");
        text
    }
}

/// The total size of the files in `dir`.
fn stored_bytes(dir: &Path) -> std::io::Result<u64> {
    let mut total = 0;
    for entry in std::fs::read_dir(dir)? {
        let meta = entry?.metadata()?;
        if meta.is_file() {
            total += meta.len();
        }
    }
    Ok(total)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn runs_count_by_outcome_and_busy_ones_not_at_all() {
        let downloaded = Counter::default();
        let metrics = Metrics::new(downloaded.clone());
        metrics.sandbox_run(ServiceKind::Filter, Ok(Duration::from_millis(3)));
        let deadline = RunError::Deadline { service: "s".into(), deadline: Duration::from_secs(1) };
        metrics.sandbox_run(ServiceKind::Filter, Err(&deadline));
        let busy = RunError::Busy { service: "s".into(), slots: 1, queued: 0 };
        metrics.sandbox_run(ServiceKind::Check, Err(&busy));
        downloaded.inc_by(512);
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("a.mfc"), [0u8; 100]).unwrap();
        let text = metrics.render(2, 0, dir.path()).await;
        for line in [
            "meshflow_host_sandbox_runs_total{outcome=\"ok\"} 1",
            "meshflow_host_sandbox_runs_total{outcome=\"deadline\"} 1",
            "meshflow_host_sandbox_runs_total{outcome=\"memory\"} 0",
            "meshflow_host_sandbox_runs_total{outcome=\"error\"} 0",
            "meshflow_host_sandbox_run_duration_seconds_count{kind=\"filter\"} 1",
            "meshflow_host_sessions 2",
            "meshflow_host_blobs_stored_bytes 100",
            "meshflow_host_downloaded_bytes_total 512",
        ] {
            assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
        }
    }
}
