//! The engine HTTP API's bodies: what `POST /runs`, `POST /inputs`, `GET /runs`,
//! `GET /hosts` and `GET /runs/{id}` (the run record, DESIGN §5) carry, shared by the
//! engine server and [`EngineClient`](crate::EngineClient).

use serde::{Deserialize, Serialize};
use serde_json::{Map, Value as Json};

use meshflow_params::ServiceInfo;

/// How a step's result reaches the other hosts (a workflow's `"transfer"`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Transfer {
    /// Per receiving host, whichever of the edit log, the replay and the full mesh the
    /// cost model expects to be quickest.
    #[default]
    Auto,
    /// The edit log (`.mfc`).
    Correction,
    /// The step re-run on the receiver (`.mfr`), the edit log as fallback.
    Replay,
    Full,
}

impl Transfer {
    pub fn parse(text: &str) -> Option<Self> {
        match text {
            "auto" => Some(Self::Auto),
            "correction" => Some(Self::Correction),
            "replay" => Some(Self::Replay),
            "full" => Some(Self::Full),
            _ => None,
        }
    }
}

/// `POST /runs`: a workflow (its JSON as written) and, optionally, the input's URL.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SubmitRun {
    pub workflow: Json,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input: Option<String>,
}

/// `POST /runs/{id}/rerun`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RerunRequest {
    /// Another input than the recorded one (a URL the engine fetches from).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub input: Option<String>,
    /// Run today's plugins for each service (the recorded parameters still), instead of
    /// pinning every task to the digest that ran.
    #[serde(default)]
    pub unpinned: bool,
}

/// `GET /runs/{id}/comparison` and `meshflow rerun --json`: a re-run against its record.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// Same input, every step's output or value, and the same result.
    pub identical: bool,
    pub recorded_run: String,
    pub rerun: String,
    /// Whether the re-run's input had the recorded input's content hash.
    pub same_input: bool,
    /// The first place the two runs differ; none when identical.
    pub divergence: Option<Divergence>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Divergence {
    /// The step's position in execution order; none for the input or the result.
    pub index: Option<usize>,
    /// The task's path (`steps[1]`), `input` or `result`.
    pub path: String,
    pub service: Option<String>,
    /// What differs, in words.
    pub message: String,
}

/// One input's row of a batch's summary: what a paper's results table needs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SummaryRow {
    /// The input's file name (or URL).
    pub name: String,
    /// The run's status, or `failed` for an input that never became a run.
    pub status: String,
    pub error: Option<String>,
    pub vertices_in: Option<u64>,
    pub triangles_in: Option<u64>,
    pub vertices_out: Option<u64>,
    pub triangles_out: Option<u64>,
    pub result_hash: Option<String>,
    pub total_seconds: Option<f64>,
    /// Input broadcast plus every transfer between hosts.
    pub bytes_moved: u64,
    /// The last value of each check the workflow computed, by `<service> [<task path>]`.
    pub checks: std::collections::BTreeMap<String, Json>,
}

/// `POST /batches`: one workflow over many inputs (URLs; files are uploaded first with
/// `POST /inputs`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SubmitBatch {
    pub workflow: Json,
    pub inputs: Vec<String>,
    /// How many of its runs may go at once (default and most: the engine's
    /// `MAX_BATCH_RUNS_AT_ONCE`, 4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub concurrency: Option<usize>,
}

/// One input of a batch: its run once started, or why it never became one.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchEntry {
    pub input: String,
    pub run: Option<String>,
    pub error: Option<String>,
}

/// `GET /batches/{id}` (and the `POST /batches` answer, 202).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BatchStatus {
    pub id: String,
    /// `running` until every input's run has ended, then `completed` (whatever each run's
    /// own status).
    pub status: String,
    pub entries: Vec<BatchEntry>,
    /// The summary table: a row per input, in order.
    pub rows: Vec<SummaryRow>,
}

/// `POST /runs` answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSubmitted {
    pub id: String,
    pub status: Status,
}

/// One entry of `GET /runs`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunSummary {
    pub id: String,
    pub status: Status,
    pub steps: usize,
}

/// `POST /inputs?name=…` answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputUploaded {
    pub url: String,
    pub bytes: u64,
}

/// `POST /hosts` body.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RegisterHost {
    pub url: String,
}

/// One entry of the engine's `GET /services`: a service and the hosts that offer it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ServiceOffer {
    #[serde(flatten)]
    pub info: ServiceInfo,
    pub hosts: Vec<String>,
    /// The SHA-256 digests of the plugins that provide it, on any host, each once.
    #[serde(default)]
    pub plugins: Vec<String>,
}

/// One entry of `GET /hosts`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HostInfo {
    pub url: String,
    pub up: bool,
    pub running: u32,
    pub assigned: u32,
    pub last_error: Option<String>,
    pub services: Vec<String>,
    /// Why the engine distrusts the host (an answer that cannot be true); it is left out of
    /// plans while this is set.
    #[serde(default)]
    pub suspect: Option<String>,
    /// `trusted` (the default), `spot-check` or `untrusted`, as an admin set it.
    #[serde(default = "trusted")]
    pub trust: String,
}

fn trusted() -> String {
    "trusted".into()
}

/// `PATCH /hosts` body: an admin sets how far a host is trusted.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SetTrust {
    pub url: String,
    /// `trusted`, `spot-check` or `untrusted`.
    pub trust: String,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Status {
    /// Waiting for one of its client's run slots.
    Queued,
    Running,
    Completed,
    Failed,
    /// Stopped by `POST /runs/{id}/cancel`.
    Cancelled,
    /// The engine stopped while it ran and could not resume it; `error` says why.
    Interrupted,
}

impl Status {
    /// Whether the run has ended: its status no longer changes (a completed run's record
    /// still gains its result's packed sizes until it is settled, see `RunRecord::settled_ms`).
    pub fn is_final(self) -> bool {
        matches!(self, Self::Completed | Self::Failed | Self::Cancelled | Self::Interrupted)
    }
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunRecord {
    pub id: String,
    pub status: Status,
    /// Why the run failed, naming the step.
    pub error: Option<String>,
    /// Things the user should know about a run that completed (a WHILE cut at its cap).
    pub warnings: Vec<String>,
    pub transfer: Transfer,
    pub input: Option<InputRecord>,
    /// The input broadcast: the time until every host of the plan held the input.
    pub broadcast: Option<BroadcastRecord>,
    /// Plugins the hosts that may replay steps fetched and compiled while the input was
    /// broadcast, per host and plugin (older records have none).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub prefetches: Vec<PrefetchRecord>,
    pub steps: Vec<StepRecord>,
    pub result: Option<ResultRecord>,
    /// Milliseconds from submission to the end: for a completed run, until its result was
    /// held by two hosts (or by its only one), hash checked.
    pub total_ms: Option<f64>,
    /// Milliseconds from submission until nothing about the record changes any more: a
    /// completed run's result packed and stored on the hosts holding it, and every edit
    /// log's real size known (after `total_ms`, off the run's time). Any other end settles
    /// at once; records from before this field have none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub settled_ms: Option<f64>,
    /// The workflow as submitted, so a record alone is enough to run it again.
    #[serde(default)]
    pub workflow: Json,
    /// The run this one re-runs (`POST /runs/{id}/rerun`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rerun_of: Option<String>,
    /// The user whose run it is (engines with users; older records have none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub user: Option<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InputRecord {
    pub url: String,
    /// The hash of the mesh as the run holds it: on its grid, for a quantised run.
    pub hash: String,
    pub vertices: u64,
    pub triangles: u64,
    /// The step exponents of a quantised run's grid.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<[i32; 3]>,
    /// What the input file held that a mesh does not keep (colours, normals, quality, …),
    /// as the first host to load it found: the result has none of it.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_kept: Vec<String>,
    /// What the mesh carries beyond positions and triangles (`vertex color (4 × u8)`, …).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub attributes: Vec<String>,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BroadcastRecord {
    pub ms: f64,
    pub hosts: Vec<HostLoad>,
}

/// One host making ready a plugin it may replay steps of, before the run needs it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PrefetchRecord {
    pub host: String,
    pub plugin: String,
    /// The host it was to come from.
    pub from: String,
    /// `pending` (asked, no answer yet; a run that ends first keeps it so), `present`
    /// (already there), `loaded` (kept from an earlier replay), `fetched` (downloaded and
    /// compiled now) or `failed` (a replay fetches it when it needs it).
    pub outcome: String,
    /// The time the host took, as it says.
    pub ms: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bytes: Option<u64>,
    /// Since the run started: when the engine asked, and when the host answered.
    pub started_ms: f64,
    pub finished_ms: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// What the engine expected the plugin for there: a step's replay, or a task moving to
    /// the host after a step it produces.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub why: Vec<String>,
}

/// One host's download and decoding of the input.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HostLoad {
    pub host: String,
    pub bytes: u64,
    pub download_ms: f64,
    pub load_ms: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StepRecord {
    /// Position in execution order (a WHILE body appears once per iteration).
    pub index: usize,
    /// The task's place in the workflow, e.g. `steps[2].do[0]`.
    pub path: String,
    /// `filter` or `check`.
    pub kind: String,
    pub service: String,
    pub host: String,
    /// The SHA-256 of the plugin that ran.
    pub plugin: String,
    /// The parameters as the workflow gave them.
    pub params: Map<String, Json>,
    /// Every parameter the plugin ran with, defaults filled in: a re-run sends these.
    #[serde(default)]
    pub resolved_params: Map<String, Json>,
    /// Milliseconds since the run started.
    pub started_ms: f64,
    pub finished_ms: f64,
    /// The plugin's own run time on the host, its wait for a run slot excluded.
    pub compute_ms: f64,
    /// The time the step waited on its host for a free run slot (and for a busy host to
    /// take it at all).
    #[serde(default)]
    pub queue_ms: f64,
    /// Time the step waited for its host to catch up with earlier results.
    pub wait_ms: f64,
    /// Engine time from the previous step's reply to this trigger, waiting excluded.
    pub overhead_ms: f64,
    pub input_hash: String,
    pub output_hash: Option<String>,
    pub vertices: Option<u64>,
    pub triangles: Option<u64>,
    pub edits: Option<u64>,
    /// What the step's output carries beyond positions and triangles.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub attributes: Vec<String>,
    /// The step's edit log (`.mfc`): the producer's estimate when the step is answered (logs
    /// are encoded after), its real size once the producer has written it.
    pub correction_bytes: Option<u64>,
    /// `correction_bytes` is the producer's estimate.
    #[serde(default)]
    pub correction_estimated: bool,
    /// The producer's estimate, kept once `correction_bytes` is the real size: what the
    /// engine chose transfers by, against what the log turned out to be.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub correction_estimate_bytes: Option<u64>,
    /// The size of the step's replay correction (`.mfr`).
    #[serde(default)]
    pub replay_bytes: Option<u64>,
    /// Known when some host downloaded the full mesh (always with `transfer: full`).
    pub full_bytes: Option<u64>,
    /// A check's value and, for conditions, whether the comparison held.
    pub value: Option<Json>,
    pub condition: Option<bool>,
    pub report: String,
    /// Hosts that failed this step before it succeeded elsewhere.
    pub failed_hosts: Vec<String>,
    pub transfers: Vec<TransferRecord>,
    /// When hosts disagreed about the step: what each claimed (the producer first).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub claims: Vec<HashClaim>,
    /// The outcome of the replay on an uninvolved host that settled the disagreement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub verdict: Option<Verdict>,
    /// Who checked the step's result and how (`replay`, `spot-check`, `arbitration`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub verified_by: Vec<Verification>,
    /// Set when the step ran on the host holding the mesh rather than the one planned (code
    /// moved to the data): which host was planned, and why it did not run there.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub moved: Option<MovedToData>,
}

/// A step run where the mesh was, its plugin fetched there, instead of on its planned host.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MovedToData {
    pub planned: String,
    pub why: String,
}

/// What one host claimed about a step: the mesh hash (a check's value as JSON text) it
/// announced or reached, or, for a receiver that refused the result, none.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HashClaim {
    pub host: String,
    /// `produced`, `received` (a receiver's answer or refusal) or `replayed`.
    pub role: String,
    pub hash: Option<String>,
    /// The claim in words (a receiver's refusal, a fallback).
    #[serde(default, skip_serializing_if = "String::is_empty")]
    pub message: String,
}

/// The replay that settled a disagreement: who ran it, what it reached, and whom it proved
/// wrong and right.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verdict {
    pub arbiter: String,
    pub hash: String,
    pub wrong: Vec<String>,
    pub right: Vec<String>,
}

/// A host that replayed the step from its input and reached `hash` (a check: its value as
/// JSON text).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Verification {
    pub host: String,
    /// `replay` (an untrusted host's step, before anyone built on it), `spot-check` or
    /// `arbitration`.
    pub how: String,
    pub hash: String,
}

/// One host bringing itself up to date with a step's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TransferRecord {
    pub host: String,
    /// `correction`, `replay` or `full`: what the engine asked for.
    #[serde(default)]
    pub asked: String,
    /// `correction`, `replay` or `full`: the one actually used.
    pub via: String,
    /// What the cost model expected each way to take, when it chose (`transfer: auto`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub estimates: Option<TransferEstimates>,
    pub bytes: u64,
    pub download_ms: f64,
    pub apply_ms: f64,
    /// From the engine's forward to the host's reply.
    pub started_ms: f64,
    pub finished_ms: f64,
    /// Why a correction was not used although asked for, or why the update failed.
    pub fallback: Option<String>,
    pub error: Option<String>,
    /// A replay that had to wait for its plugin on the receiver (fetched and compiled
    /// inside the transfer, or a prefetch not yet done): how long, within `apply_ms`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin_wait_ms: Option<f64>,
}

/// Expected milliseconds for one receiver to take one step's result each way: transfer over
/// the measured link plus applying, re-running or unpacking there.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TransferEstimates {
    pub correction_ms: f64,
    pub replay_ms: f64,
    pub full_ms: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ResultRecord {
    /// Where the final mesh (packed `.mfm`) can be fetched.
    pub url: String,
    pub hash: String,
    pub bytes: Option<u64>,
    pub vertices: u64,
    pub triangles: u64,
    /// The same packed mesh on other hosts of the run, which downloads fall back to when
    /// the producer is gone.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub copies: Vec<String>,
}

impl RunRecord {
    /// Whether nothing about the run changes any more: settled, or ended otherwise than
    /// completed (records from before `settled_ms` have none).
    pub fn is_settled(&self) -> bool {
        self.settled_ms.is_some() || (self.status.is_final() && self.status != Status::Completed)
    }

    pub fn new(id: String, transfer: Transfer) -> Self {
        Self {
            id,
            status: Status::Queued,
            error: None,
            warnings: Vec::new(),
            transfer,
            input: None,
            broadcast: None,
            prefetches: Vec::new(),
            steps: Vec::new(),
            result: None,
            total_ms: None,
            settled_ms: None,
            workflow: Json::Null,
            rerun_of: None,
            user: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_run_record_reads_back_as_written() {
        let mut record = RunRecord::new("r-1".into(), Transfer::Full);
        record.status = Status::Completed;
        record.steps.push(StepRecord {
            index: 0,
            path: "steps[0]".into(),
            kind: "filter".into(),
            service: "laplacian-smoothing".into(),
            host: "http://127.0.0.1:7101".into(),
            plugin: "ab".repeat(32),
            params: serde_json::from_str(r#"{"iterations": 2}"#).unwrap(),
            resolved_params: serde_json::from_str(r#"{"iterations": 2, "weights": "uniform"}"#)
                .unwrap(),
            started_ms: 1.5,
            finished_ms: 9.25,
            compute_ms: 7.0,
            queue_ms: 0.5,
            wait_ms: 0.0,
            overhead_ms: 0.75,
            input_hash: "cd".repeat(32),
            output_hash: Some("ef".repeat(32)),
            vertices: Some(1839),
            triangles: Some(3674),
            edits: Some(1839),
            attributes: Vec::new(),
            correction_bytes: Some(152),
            correction_estimated: false,
            correction_estimate_bytes: Some(300),
            replay_bytes: Some(180),
            full_bytes: None,
            value: None,
            condition: None,
            report: "smoothed".into(),
            failed_hosts: vec![],
            transfers: vec![],
            claims: vec![],
            verdict: None,
            verified_by: vec![],
            moved: None,
        });
        let json = serde_json::to_value(&record).unwrap();
        assert_eq!(json["transfer"], "full");
        assert_eq!(json["status"], "completed");
        assert_eq!(serde_json::from_value::<RunRecord>(json).unwrap(), record);
    }
}
