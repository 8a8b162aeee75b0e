//! The end of a run: where the final mesh is, the run's final status, and after it the
//! result's packing and the real sizes of the edit logs written meanwhile.

use std::sync::Arc;

use meshflow_api::HostClient;
use serde_json::json;

use super::Executor;
use super::cost::StepOutput;
use super::error::ExecError;
use crate::limits::MAX_CORRECTION_BYTES;
use crate::record::{ResultRecord, Status};
use crate::registry::Registry;
use crate::run::Run;

impl Executor {
    /// Records the result once it is held: by its producer and, where the run has another
    /// host that can take it, by a second one (hash checked); the packing and the edit logs'
    /// real sizes are left to the returned [`Keeping`], after the run's end.
    pub(super) async fn finish(&mut self) -> Keeping {
        let producer = self.current.producer.as_ref().map(|host| self.registry.client(host));
        let url = self.current.full.url.clone();
        let copy = self.second_copy().await;
        let current = &self.current;
        let result = ResultRecord {
            url: url.clone(),
            hash: current.hash.clone(),
            bytes: None,
            vertices: current.vertices,
            triangles: current.triangles,
            copies: copy.iter().map(|(_, url)| url.clone()).collect(),
        };
        self.run.update("result", |r| {
            let json = json!(result);
            r.result = Some(result);
            json
        });
        Keeping {
            run: self.run.clone(),
            producer: producer.map(|client| (client, url)),
            copy,
            log_sizes: std::mem::take(&mut self.log_sizes),
        }
    }
}

/// What a completed run still does after its end, off its time: its result packed and
/// stored by the hosts holding it, so it outlives the run's sessions (and the hosts' memory
/// of recent outputs), and the real sizes of the edit logs written meanwhile; then the run
/// is settled (`RunRecord::settled_ms`). The engine deletes the run's sessions after it.
pub struct Keeping {
    run: Arc<Run>,
    /// The producer and the URL of the result packed there.
    producer: Option<(HostClient, String)>,
    /// The second host holding the result, and its URL there.
    copy: Option<(HostClient, String)>,
    log_sizes: Vec<tokio::task::JoinHandle<()>>,
}

impl Keeping {
    /// Keeping for a completed run the engine found unsettled at a restart, if its result
    /// was not packed yet: its holders from the record (their sessions outlive the engine),
    /// each only if it is a registered host (the cluster token goes to no other server).
    pub fn from_record(run: Arc<Run>, registry: &Registry) -> Option<Self> {
        let result = run.record().result.filter(|result| result.bytes.is_none())?;
        let holder = |url: &str| Some((registry.registered(url)?, url.to_owned()));
        let producer = holder(&result.url);
        let copy = result.copies.first().and_then(|url| holder(url));
        Some(Self { run, producer, copy, log_sizes: Vec::new() })
    }

    /// Packs the result on its holders (both at once) while the last edit logs' sizes come
    /// in, records the packed size, drops a copy that could not be packed, and settles.
    pub async fn keep(self) {
        let pack = |holder: Option<(HostClient, String)>| async move {
            let (client, url) = holder?;
            match client.packed_size(&url).await {
                Ok(bytes) => Some(bytes),
                Err(error) => {
                    tracing::warn!("packing the result at {url}: {error}");
                    None
                }
            }
        };
        let log_sizes = futures_util::future::join_all(self.log_sizes);
        let (bytes, copied, _) = tokio::join!(pack(self.producer), pack(self.copy), log_sizes);
        self.run.update("result", |r| {
            let Some(result) = r.result.as_mut() else { return json!(null) };
            result.bytes = bytes;
            if copied.is_none() {
                result.copies.clear();
            }
            json!(result)
        });
        self.run.settle();
    }
}

/// Ends the run as `outcome` says; the error is put in words here, for the record. A
/// resumed run (`resumed_at`: the steps it had) that failed before a new step is
/// interrupted rather than failed.
pub(super) fn conclude(run: &Run, outcome: Result<(), ExecError>, resumed_at: Option<usize>) {
    match (outcome, resumed_at) {
        (Ok(()), _) => run.set_status(Status::Completed, None),
        (Err(error), Some(resuming_at)) if run.step_count() <= resuming_at => run.set_status(
            Status::Interrupted,
            Some(format!(
                "the engine restarted and could not resume after {resuming_at} step(s): {error}"
            )),
        ),
        (Err(error), _) => run.set_status(Status::Failed, Some(error.to_string())),
    }
}

/// Replaces step `index`'s estimated edit-log size by the real one once its producer has
/// written the log (a HEAD of `url` at `producer` waits for that), and learns the step's
/// shape (`measured::StepShape`) under `key` with it; an answer that does not come leaves
/// the estimate and teaches nothing.
pub(super) fn record_log_size(
    run: Arc<Run>,
    (producer, url): (HostClient, String),
    index: usize,
    (registry, key, output): (Arc<Registry>, String, StepOutput),
) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let Ok(bytes) = producer.blob_size(&url).await else { return };
        // A host's answer is a claim: a size no edit log can have leaves the estimate.
        if bytes > MAX_CORRECTION_BYTES {
            tracing::warn!("{url}: an edit log of {bytes} bytes is not believed");
            return;
        }
        if let Some(shape) = (StepOutput { correction_bytes: bytes, ..output }).shape() {
            registry.measured.learn_step(&key, shape);
        }
        run.update_step("correction", index, |step| {
            if step.correction_estimated {
                step.correction_estimate_bytes = step.correction_bytes;
            }
            step.correction_bytes = Some(bytes);
            step.correction_estimated = false;
            json!({"step": index, "correction_bytes": bytes, "estimate_bytes": step.correction_estimate_bytes})
        });
    })
}
