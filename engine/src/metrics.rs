//! What the engine tells Prometheus (`GET /metrics`, DESIGN §11): runs by status and as they
//! end, step and transfer durations, bytes moved between hosts, and the hosts' states.
//!
//! Counters and histograms are fed where things happen (the executor, `drive`); gauges are
//! read from the engine's state when scraped. Every series of a known label value exists
//! from the start, at zero, so `rate()` and alerts see it before the first event.
//! Who may scrape is `meshflow_api::server::may_scrape`.

use std::time::Duration;

use meshflow_api::host::Transfer;
use prometheus_client::encoding::prometheus_text;
use prometheus_client::metrics::counter::Counter;
use prometheus_client::metrics::family::Family;
use prometheus_client::metrics::gauge::Gauge;
use prometheus_client::metrics::histogram::{Histogram, exponential_buckets};
use prometheus_client::registry::{Registry, Unit};

use crate::record::Status;
use crate::registry::HostEntry;

/// One label: its name and value.
type Label = [(&'static str, &'static str); 1];
type Histograms = Family<Label, Histogram, fn() -> Histogram>;

/// Every run status, as the API spells it.
const STATUSES: [(Status, &str); 6] = [
    (Status::Queued, "queued"),
    (Status::Running, "running"),
    (Status::Completed, "completed"),
    (Status::Failed, "failed"),
    (Status::Cancelled, "cancelled"),
    (Status::Interrupted, "interrupted"),
];
/// How a step's result reaches another host, as the metrics name it.
const WAYS: [&str; 3] = ["edit-log", "replay", "full"];
/// What a host's state counts as: `suspect` whether up or not.
const HOST_STATES: [&str; 3] = ["up", "down", "suspect"];

/// Durations from 5 ms to about 5.5 min, doubling.
fn duration_buckets() -> Histogram {
    Histogram::new(exponential_buckets(0.005, 2.0, 17))
}

pub struct Metrics {
    registry: Registry,
    runs: Family<Label, Gauge>,
    runs_finished: Family<Label, Counter>,
    steps: Histograms,
    transfers: Histograms,
    transfer_failures: Family<Label, Counter>,
    moved: Family<Label, Counter>,
    hosts: Family<Label, Gauge>,
}

impl Default for Metrics {
    fn default() -> Self {
        let mut registry = Registry::with_prefix("meshflow_engine");
        let runs = Family::<Label, Gauge>::default();
        registry.register(
            "runs",
            "Runs the engine keeps, by status (queued and running: the queue depths)",
            runs.clone(),
        );
        let runs_finished = Family::<Label, Counter>::default();
        registry.register(
            "runs_finished",
            "Runs that ended since the engine started, by final status",
            runs_finished.clone(),
        );
        let steps = Histograms::new_with_constructor(duration_buckets);
        registry.register_with_unit(
            "step_duration",
            "Time from asking a host to run a task to its checked answer, by kind (filter or \
             check)",
            Unit::Seconds,
            steps.clone(),
        );
        let transfers = Histograms::new_with_constructor(duration_buckets);
        registry.register_with_unit(
            "transfer_duration",
            "Time a host took to take another host's step (download and apply), by the way it \
             used (edit-log, replay or full)",
            Unit::Seconds,
            transfers.clone(),
        );
        let transfer_failures = Family::<Label, Counter>::default();
        registry.register(
            "transfer_failures",
            "Updates a host failed to take, by the way asked for",
            transfer_failures.clone(),
        );
        let moved = Family::<Label, Counter>::default();
        registry.register_with_unit(
            "transferred",
            "Bytes hosts downloaded from each other to take steps, by way (edit-log, replay or \
             full)",
            Unit::Bytes,
            moved.clone(),
        );
        let hosts = Family::<Label, Gauge>::default();
        registry.register(
            "hosts",
            "Registered hosts by state: up, down, or suspect (a false answer, whether up or not)",
            hosts.clone(),
        );
        for (_, status) in STATUSES {
            runs.get_or_create_owned(&[("status", status)]);
            if status != "queued" && status != "running" {
                runs_finished.get_or_create_owned(&[("status", status)]);
            }
        }
        for kind in ["filter", "check"] {
            steps.get_or_create_owned(&[("kind", kind)]);
        }
        for way in WAYS {
            transfers.get_or_create_owned(&[("way", way)]);
            transfer_failures.get_or_create_owned(&[("way", way)]);
            moved.get_or_create_owned(&[("way", way)]);
        }
        for state in HOST_STATES {
            hosts.get_or_create_owned(&[("state", state)]);
        }
        Self { registry, runs, runs_finished, steps, transfers, transfer_failures, moved, hosts }
    }
}

impl Metrics {
    /// A run ended with `status` (a final one).
    pub fn run_finished(&self, status: Status) {
        if let Some(name) = status_name(status).filter(|_| status.is_final()) {
            self.runs_finished.get_or_create(&[("status", name)]).inc();
        }
    }

    /// A task (`filter` or `check`) answered after `took`.
    pub fn step(&self, kind: &'static str, took: Duration) {
        self.steps.get_or_create(&[("kind", kind)]).observe(took.as_secs_f64());
    }

    /// A host took a step `via` a way, downloading `bytes`, in `took`.
    pub fn transferred(&self, via: Transfer, bytes: u64, took: Duration) {
        let way = [("way", way_name(via))];
        self.transfers.get_or_create(&way).observe(took.as_secs_f64());
        self.moved.get_or_create(&way).inc_by(bytes);
    }

    /// A host failed to take a step it was asked to take `via` a way.
    pub fn transfer_failed(&self, via: Transfer) {
        self.transfer_failures.get_or_create(&[("way", way_name(via))]).inc();
    }

    /// The metrics in the Prometheus text format, with the gauges set from `runs` (the
    /// statuses of the kept runs) and `hosts`.
    pub fn render(
        &self,
        runs: impl IntoIterator<Item = Status>,
        hosts: &[std::sync::Arc<HostEntry>],
    ) -> String {
        let mut counts = [0i64; STATUSES.len()];
        for status in runs {
            if let Some(index) = STATUSES.iter().position(|(s, _)| *s == status) {
                counts[index] += 1;
            }
        }
        for ((_, name), count) in STATUSES.iter().zip(counts) {
            self.runs.get_or_create(&[("status", name)]).set(count);
        }
        let mut states = [0i64; HOST_STATES.len()];
        for host in hosts {
            let state = match (host.is_suspect(), host.is_up()) {
                (true, _) => 2,
                (false, true) => 0,
                (false, false) => 1,
            };
            states[state] += 1;
        }
        for (state, count) in HOST_STATES.iter().zip(states) {
            self.hosts.get_or_create(&[("state", state)]).set(count);
        }
        let mut text = String::new();
        prometheus_text::encode(&mut text, &self.registry).expect("writing to a String");
        text
    }
}

/// The `Content-Type` of [`Metrics::render`]'s text.
pub const CONTENT_TYPE: &str = prometheus_text::CONTENT_TYPE;

fn status_name(status: Status) -> Option<&'static str> {
    STATUSES.iter().find(|(s, _)| *s == status).map(|(_, name)| *name)
}

fn way_name(via: Transfer) -> &'static str {
    match via {
        Transfer::Correction => "edit-log",
        Transfer::Replay => "replay",
        Transfer::Full => "full",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_series_is_there_from_the_start_with_help_and_units() {
        let metrics = Metrics::default();
        metrics.run_finished(Status::Completed);
        metrics.run_finished(Status::Running);
        metrics.step("filter", Duration::from_millis(30));
        metrics.transferred(Transfer::Correction, 1200, Duration::from_millis(8));
        let text = metrics.render([Status::Running, Status::Completed, Status::Completed], &[]);
        for line in [
            "meshflow_engine_runs{status=\"completed\"} 2",
            "meshflow_engine_runs{status=\"queued\"} 0",
            "meshflow_engine_runs_finished_total{status=\"completed\"} 1",
            "meshflow_engine_runs_finished_total{status=\"failed\"} 0",
            "meshflow_engine_step_duration_seconds_count{kind=\"filter\"} 1",
            "meshflow_engine_step_duration_seconds_count{kind=\"check\"} 0",
            "meshflow_engine_transferred_bytes_total{way=\"edit-log\"} 1200",
            "meshflow_engine_transfer_duration_seconds_count{way=\"full\"} 0",
            "meshflow_engine_hosts{state=\"up\"} 0",
        ] {
            assert!(text.lines().any(|l| l == line), "no {line:?} in\n{text}");
        }
        assert!(!text.contains("finished_total{status=\"running\"}"), "{text}");
        assert!(text.contains("# HELP meshflow_engine_transferred_bytes_total "), "{text}");
    }
}
