//! A run as the API sees it: its record, updated as the executor goes, a stream of progress
//! events for whoever watches, the host sessions it holds, and its cancellation.

use std::collections::BTreeSet;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

use serde::Serialize;
use serde_json::Value as Json;
use tokio::sync::{Notify, broadcast};
use tokio_util::sync::CancellationToken;

use crate::record::{RunRecord, Status, StepRecord};

/// Events kept for a subscriber that lags; a slower one misses some and catches up from
/// the record.
const EVENT_BUFFER: usize = 1024;

/// A host session a run opened, to be deleted when the run ends (even after a restart).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct OpenSession {
    pub host: String,
    pub session: String,
}

#[derive(Debug, Clone, Serialize)]
pub struct Event {
    /// `status`, `broadcast`, `step`, `transfer`, ..., `settled` last.
    pub kind: &'static str,
    pub data: Json,
}

pub struct Run {
    pub id: String,
    /// The user who submitted it (`default` on an engine without users).
    pub user: String,
    /// The input URL the run reads, kept to resume the run. The workflow as submitted is
    /// the record's (`RunRecord::workflow`, see [`Run::workflow`]).
    pub input: String,
    started: Instant,
    /// Time the run had taken before this process took it over (a resumed run).
    earlier_ms: f64,
    record: Mutex<RunRecord>,
    events: broadcast::Sender<Event>,
    cancel: CancellationToken,
    /// Host sessions opened for the run and not yet deleted.
    sessions: Mutex<Vec<OpenSession>>,
    /// Set by every change; the engine's persister clears it when it writes the record.
    dirty: AtomicBool,
    /// Steps changed since the persister last wrote them (a record's steps are written
    /// one by one, so a long run's writes stay small).
    dirty_steps: Mutex<BTreeSet<usize>>,
    changed: Arc<Notify>,
}

/// What changed in a run since the last [`Run::take_changes`]: the record without its
/// steps, the changed steps, how many steps there are now, and the open sessions.
pub struct Changes {
    pub head: RunRecord,
    pub steps: Vec<StepRecord>,
    pub step_count: usize,
    pub sessions: Vec<OpenSession>,
}

/// What a run is made of; `changed` is told of every change (the engine's persister). The
/// record holds the workflow as submitted.
pub struct RunParts {
    pub id: String,
    pub user: String,
    pub input: String,
    pub record: RunRecord,
    pub sessions: Vec<OpenSession>,
    pub changed: Arc<Notify>,
}

impl Run {
    pub fn new(parts: RunParts) -> Self {
        let (events, _) = broadcast::channel(EVENT_BUFFER);
        let earlier_ms = parts
            .record
            .total_ms
            .or_else(|| parts.record.steps.last().map(|s| s.finished_ms))
            .unwrap_or(0.0);
        Self {
            id: parts.id,
            user: parts.user,
            input: parts.input,
            started: Instant::now(),
            earlier_ms,
            record: Mutex::new(parts.record),
            events,
            cancel: CancellationToken::new(),
            sessions: Mutex::new(parts.sessions),
            dirty: AtomicBool::new(false),
            dirty_steps: Mutex::default(),
            changed: parts.changed,
        }
    }

    /// Milliseconds since the run was created (across engine restarts, approximately).
    pub fn elapsed_ms(&self) -> f64 {
        self.earlier_ms + self.started.elapsed().as_secs_f64() * 1e3
    }

    pub fn record(&self) -> RunRecord {
        self.record.lock().unwrap().clone()
    }

    /// The workflow as submitted (without copying the rest of the record).
    pub fn workflow(&self) -> Json {
        self.record.lock().unwrap().workflow.clone()
    }

    /// Steps recorded so far (without copying the record).
    pub fn step_count(&self) -> usize {
        self.record.lock().unwrap().steps.len()
    }

    pub fn status(&self) -> Status {
        self.record.lock().unwrap().status
    }

    pub fn is_finished(&self) -> bool {
        self.status().is_final()
    }

    pub fn subscribe(&self) -> broadcast::Receiver<Event> {
        self.events.subscribe()
    }

    /// Whether nothing about the run changes any more (see [`Run::settle`]).
    pub fn is_settled(&self) -> bool {
        self.record.lock().unwrap().is_settled()
    }

    /// Changes the record and tells subscribers what changed. A settled run's record no
    /// longer changes (a cancelled run's last host answers are dropped); a completed one
    /// still takes its result's packed sizes and its edit logs' real sizes.
    pub fn update(&self, kind: &'static str, change: impl FnOnce(&mut RunRecord) -> Json) {
        let data = {
            let mut record = self.record.lock().unwrap();
            if record.is_settled() {
                return;
            }
            change(&mut record)
        };
        self.mark_changed();
        // No subscriber is fine: the record keeps everything.
        let _ = self.events.send(Event { kind, data });
    }

    /// Changes step `index` of the record (it must exist) and tells subscribers.
    pub fn update_step(
        &self,
        kind: &'static str,
        index: usize,
        change: impl FnOnce(&mut StepRecord) -> Json,
    ) {
        self.update(kind, |record| {
            self.dirty_steps.lock().unwrap().insert(index);
            change(&mut record.steps[index])
        });
    }

    /// Appends a step to the record (setting its index) and tells subscribers; its index.
    pub fn push_step(&self, mut step: StepRecord) -> usize {
        let mut index = 0;
        self.update("step", |record| {
            index = record.steps.len();
            step.index = index;
            self.dirty_steps.lock().unwrap().insert(index);
            let json = serde_json::json!(step);
            record.steps.push(step);
            json
        });
        index
    }

    /// Sets the status; a run that has ended keeps the status it ended with. Every end but
    /// completion settles the run at once.
    pub fn set_status(&self, status: Status, error: Option<String>) {
        if self.is_finished() {
            return;
        }
        let total_ms = self.elapsed_ms();
        self.update("status", |record| {
            record.status = status;
            record.error = error;
            if status.is_final() {
                record.total_ms = Some(total_ms);
            }
            if status.is_final() && status != Status::Completed {
                record.settled_ms = Some(total_ms);
            }
            serde_json::json!({"status": status, "error": record.error, "total_ms": record.total_ms})
        });
    }

    /// Marks a completed run's record as final: its result is packed where it will be
    /// served and its edit logs' sizes are in (`RunRecord::settled_ms`).
    pub fn settle(&self) {
        let settled_ms = self.elapsed_ms();
        self.update("settled", |record| {
            record.settled_ms = Some(settled_ms);
            serde_json::json!({"settled_ms": settled_ms, "result": record.result})
        });
    }

    /// Asks the run to stop; its driver ends it as cancelled and frees its sessions.
    pub fn cancel(&self) {
        self.cancel.cancel();
    }

    pub async fn cancelled(&self) {
        self.cancel.cancelled().await
    }

    pub fn session_opened(&self, host: &str, session: &str) {
        let opened = OpenSession { host: host.to_owned(), session: session.to_owned() };
        self.sessions.lock().unwrap().push(opened);
        self.mark_changed();
    }

    /// The sessions still open, which the caller deletes on their hosts.
    pub fn take_sessions(&self) -> Vec<OpenSession> {
        let sessions = std::mem::take(&mut *self.sessions.lock().unwrap());
        self.mark_changed();
        sessions
    }

    /// What to write, if anything changed since the last call.
    pub fn take_changes(&self) -> Option<Changes> {
        if !self.dirty.swap(false, Ordering::AcqRel) {
            return None;
        }
        let record = self.record.lock().unwrap();
        let changed = std::mem::take(&mut *self.dirty_steps.lock().unwrap());
        let steps = changed.into_iter().filter_map(|i| record.steps.get(i).cloned()).collect();
        let head = RunRecord {
            id: record.id.clone(),
            status: record.status,
            error: record.error.clone(),
            warnings: record.warnings.clone(),
            transfer: record.transfer,
            input: record.input.clone(),
            broadcast: record.broadcast.clone(),
            prefetches: record.prefetches.clone(),
            steps: Vec::new(),
            result: record.result.clone(),
            total_ms: record.total_ms,
            settled_ms: record.settled_ms,
            // The store keeps the workflow in a column of its own, not in every record write.
            workflow: serde_json::Value::Null,
            rerun_of: record.rerun_of.clone(),
            user: record.user.clone(),
        };
        let sessions = self.sessions.lock().unwrap().clone();
        Some(Changes { head, steps, step_count: record.steps.len(), sessions })
    }

    fn mark_changed(&self) {
        self.dirty.store(true, Ordering::Release);
        self.changed.notify_one();
    }
}
