//! A run as the API sees it: its record, updated as the executor goes, and a stream of
//! progress events for whoever watches.

use std::sync::Mutex;
use std::time::Instant;

use serde::Serialize;
use serde_json::Value as Json;
use tokio::sync::broadcast;

use crate::record::{RunRecord, Status};
use crate::workflow::Transfer;

/// Events kept for a subscriber that lags; a slower one misses some and catches up from
/// the record.
const EVENT_BUFFER: usize = 1024;

#[derive(Debug, Clone, Serialize)]
pub struct Event {
    /// `status`, `broadcast`, `step` or `transfer`.
    pub kind: &'static str,
    pub data: Json,
}

pub struct Run {
    pub id: String,
    started: Instant,
    record: Mutex<RunRecord>,
    events: broadcast::Sender<Event>,
}

impl Run {
    pub fn new(id: String, transfer: Transfer) -> Self {
        let (events, _) = broadcast::channel(EVENT_BUFFER);
        Self {
            record: Mutex::new(RunRecord::new(id.clone(), transfer)),
            id,
            started: Instant::now(),
            events,
        }
    }

    /// Milliseconds since the run was created.
    pub fn elapsed_ms(&self) -> f64 {
        self.started.elapsed().as_secs_f64() * 1e3
    }

    pub fn record(&self) -> RunRecord {
        self.record.lock().unwrap().clone()
    }

    pub fn is_finished(&self) -> bool {
        matches!(self.record.lock().unwrap().status, Status::Completed | Status::Failed)
    }

    pub fn subscribe(&self) -> broadcast::Receiver<Event> {
        self.events.subscribe()
    }

    /// Changes the record and tells subscribers what changed.
    pub fn update(&self, kind: &'static str, change: impl FnOnce(&mut RunRecord) -> Json) {
        let data = change(&mut self.record.lock().unwrap());
        // No subscriber is fine: the record keeps everything.
        let _ = self.events.send(Event { kind, data });
    }

    pub fn set_status(&self, status: Status, error: Option<String>) {
        let total_ms = self.elapsed_ms();
        self.update("status", |record| {
            record.status = status;
            record.error = error;
            if matches!(status, Status::Completed | Status::Failed) {
                record.total_ms = Some(total_ms);
            }
            serde_json::json!({"status": status, "error": record.error, "total_ms": record.total_ms})
        });
    }
}
