//! A task's step in the run record, built in one place from what the engine saw of the
//! task (host, times, input) and what the host answered (a filter's mesh or a check's
//! value).

use super::words::bounded_words;
use std::sync::Arc;

use meshflow_api::engine::MovedToData;
use meshflow_api::host::{FilterResult, RunResult};
use serde_json::{Map, Value as Json};

use crate::record::StepRecord;
use crate::registry::HostEntry;
use crate::workflow::Task;

/// What filters and checks answer alike, and what only one of them answers.
pub(super) struct Answer<'a> {
    pub plugin: &'a str,
    resolved_params: &'a Map<String, Json>,
    compute_ms: f64,
    queue_ms: f64,
    report: &'a str,
    /// A filter's answer: its mesh.
    filter: Option<&'a FilterResult>,
    /// A check's answer: its value.
    value: Option<&'a Json>,
}

impl<'a> Answer<'a> {
    pub fn of(result: &'a RunResult) -> Self {
        match result {
            RunResult::Filter(f) => Self {
                plugin: &f.plugin,
                resolved_params: &f.resolved_params,
                compute_ms: f.compute_ms,
                queue_ms: f.queue_ms,
                report: &f.report,
                filter: Some(f),
                value: None,
            },
            RunResult::Check(c) => Self {
                plugin: &c.plugin,
                resolved_params: &c.resolved_params,
                compute_ms: c.compute_ms,
                queue_ms: c.queue_ms,
                report: &c.report,
                filter: None,
                value: Some(&c.value),
            },
        }
    }
}

/// What the engine saw of a task's run on its host.
pub(super) struct Ran<'a> {
    pub task: &'a Task,
    /// `filter` or `check`.
    pub kind: &'static str,
    pub host: &'a str,
    pub input_hash: String,
    pub started_ms: f64,
    pub finished_ms: f64,
    /// How long the host stayed busy (429) before it took the task.
    pub busy_ms: f64,
    /// How long bringing the host up to date took.
    pub wait_ms: f64,
    pub overhead_ms: f64,
    /// The hosts the task failed on before.
    pub failed: &'a [Arc<HostEntry>],
    /// Why it ran here and not on its planned host, if it moved to the data.
    pub moved: Option<MovedToData>,
}

impl Ran<'_> {
    /// The step as the record keeps it (its index is set when it is pushed). A filter's
    /// edit-log size is the producer's estimate until the log is written.
    pub fn record(self, answer: &Answer) -> StepRecord {
        let filter = answer.filter;
        StepRecord {
            index: 0,
            path: self.task.path.clone(),
            kind: self.kind.to_owned(),
            service: self.task.service.clone(),
            host: self.host.to_owned(),
            plugin: answer.plugin.to_owned(),
            params: self.task.params.clone(),
            resolved_params: answer.resolved_params.clone(),
            started_ms: self.started_ms,
            finished_ms: self.finished_ms,
            compute_ms: answer.compute_ms,
            queue_ms: self.busy_ms + answer.queue_ms,
            wait_ms: self.wait_ms,
            overhead_ms: self.overhead_ms,
            input_hash: self.input_hash,
            output_hash: filter.map(|f| f.output_hash.clone()),
            vertices: filter.map(|f| f.vertices as u64),
            triangles: filter.map(|f| f.triangles as u64),
            edits: filter.map(|f| f.edits as u64),
            attributes: filter.map(|f| bounded_words(&f.attributes)).unwrap_or_default(),
            correction_bytes: filter.map(|f| f.correction.bytes),
            correction_estimated: filter.is_some(),
            correction_estimate_bytes: None,
            replay_bytes: filter.map(|f| f.replay.bytes),
            full_bytes: None,
            value: answer.value.cloned(),
            condition: None,
            report: answer.report.to_owned(),
            failed_hosts: self.failed.iter().map(|h| h.url.clone()).collect(),
            transfers: Vec::new(),
            claims: Vec::new(),
            verdict: None,
            verified_by: Vec::new(),
            moved: self.moved,
        }
    }
}
