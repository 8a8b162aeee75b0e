//! The end of a run: where the final mesh is and its packed size, the real sizes of the
//! edit logs written meanwhile, and the run's final status.

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
    /// Records where the final mesh is and its packed size: its host packs and stores it
    /// now, so the result outlives the run's sessions (and the host's memory of recent
    /// outputs).
    pub(super) async fn finish(&mut self) {
        // The result is packed while the last edit logs are still being written and while a
        // second host takes its copy: all three are the hosts' work at the end of a run, and
        // none needs another (a second host that falls back to the full mesh waits for the
        // producer's one packing, see the host's `pack_output`).
        let producer = self.current.producer.as_ref().map(|host| self.registry.client(host));
        let url = self.current.full.url.clone();
        let packed = async {
            match producer {
                Some(client) => client.packed_size(&url).await.ok(),
                None => None,
            }
        };
        let log_sizes = futures_util::future::join_all(std::mem::take(&mut self.log_sizes));
        // The result outlives its producer: a second host of the run keeps it packed too.
        let (bytes, _, copy) = tokio::join!(packed, log_sizes, self.second_copy());
        let copies = copy.into_iter().collect();
        let current = &self.current;
        let result = ResultRecord {
            url: current.full.url.clone(),
            hash: current.hash.clone(),
            bytes,
            vertices: current.vertices,
            triangles: current.triangles,
            copies,
        };
        self.run.update("result", |r| {
            let json = json!(result);
            r.result = Some(result);
            json
        });
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
