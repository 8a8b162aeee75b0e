//! What a run records, per DESIGN §5: for every step the host, plugin, parameters, compute
//! time, correction and full-mesh bytes, each receiving host's transfer and update time, and
//! the hashes. Serialised as the run's status document.

use serde::Serialize;
use serde_json::{Map, Value as Json};

use crate::workflow::Transfer;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Status {
    Queued,
    Running,
    Completed,
    Failed,
}

#[derive(Debug, Clone, Serialize)]
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
    pub steps: Vec<StepRecord>,
    pub result: Option<ResultRecord>,
    pub total_ms: Option<f64>,
}

#[derive(Debug, Clone, Serialize)]
pub struct InputRecord {
    pub url: String,
    pub hash: String,
    pub vertices: u64,
    pub triangles: u64,
}

#[derive(Debug, Clone, Serialize)]
pub struct BroadcastRecord {
    pub ms: f64,
    pub hosts: Vec<HostLoad>,
}

/// One host's download and decoding of the input.
#[derive(Debug, Clone, Serialize)]
pub struct HostLoad {
    pub host: String,
    pub bytes: u64,
    pub download_ms: f64,
    pub load_ms: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct StepRecord {
    /// Position in execution order (a WHILE body appears once per iteration).
    pub index: usize,
    /// The task's place in the workflow, e.g. `steps[2].do[0]`.
    pub path: String,
    pub kind: &'static str,
    pub service: String,
    pub host: String,
    pub plugin: String,
    pub params: Map<String, Json>,
    /// Milliseconds since the run started.
    pub started_ms: f64,
    pub finished_ms: f64,
    /// The plugin's own run time on the host.
    pub compute_ms: f64,
    /// Time the step waited for its host to catch up with earlier results.
    pub wait_ms: f64,
    /// Engine time from the previous step's reply to this trigger, waiting excluded.
    pub overhead_ms: f64,
    pub input_hash: String,
    pub output_hash: Option<String>,
    pub vertices: Option<u64>,
    pub triangles: Option<u64>,
    pub edits: Option<u64>,
    pub correction_bytes: Option<u64>,
    /// Known when some host downloaded the full mesh (always with `transfer: full`).
    pub full_bytes: Option<u64>,
    /// A check's value and, for conditions, whether the comparison held.
    pub value: Option<Json>,
    pub condition: Option<bool>,
    pub report: String,
    /// Hosts that failed this step before it succeeded elsewhere.
    pub failed_hosts: Vec<String>,
    pub transfers: Vec<TransferRecord>,
}

/// One host bringing itself up to date with a step's result.
#[derive(Debug, Clone, Serialize)]
pub struct TransferRecord {
    pub host: String,
    /// `correction` or `full`; the one actually used.
    pub via: String,
    pub bytes: u64,
    pub download_ms: f64,
    pub apply_ms: f64,
    /// From the engine's forward to the host's reply.
    pub started_ms: f64,
    pub finished_ms: f64,
    /// Why a correction was not used although asked for, or why the update failed.
    pub fallback: Option<String>,
    pub error: Option<String>,
}

#[derive(Debug, Clone, Serialize)]
pub struct ResultRecord {
    /// Where the final mesh (packed `.mfm`) can be fetched.
    pub url: String,
    pub hash: String,
    pub bytes: Option<u64>,
    pub vertices: u64,
    pub triangles: u64,
}

impl RunRecord {
    pub fn new(id: String, transfer: Transfer) -> Self {
        Self {
            id,
            status: Status::Queued,
            error: None,
            warnings: Vec::new(),
            transfer,
            input: None,
            broadcast: None,
            steps: Vec::new(),
            result: None,
            total_ms: None,
        }
    }
}
