//! One host's copy of the run's mesh (a session there), and the queue of updates that
//! brings it up to date: each forwarded result is applied after the one before it. A
//! receiver must end up with the announced mesh: one that answers another hash is suspect,
//! and so is a producer whose full mesh a receiver finds is not what it announced.

use std::sync::Arc;

use meshflow_api::ClientError;
use meshflow_api::engine::TransferEstimates;
use meshflow_api::host::{Update, Updated};
use tokio::task::JoinHandle;

use super::cost::StepOutput;
use super::current::LastFull;
use crate::measured::Applied;
use crate::record::TransferRecord;
use crate::registry::{HostEntry, Registry};
use crate::run::Run;

/// One step's result on its way to one receiver, with what the cost model expected and
/// what the outcome teaches it.
pub struct Forwarded {
    pub update: Update,
    /// The digest of the plugin that made the step, and whether the receiver had it.
    pub plugin: String,
    pub had_plugin: bool,
    /// Recorded when the model chose (`transfer: auto`).
    pub estimates: Option<TransferEstimates>,
    pub output: StepOutput,
    pub last_full: LastFull,
    pub registry: Arc<Registry>,
}

pub struct Replica {
    pub host: Arc<HostEntry>,
    pub session: String,
    /// The hash the session will hold once `pending` has finished.
    pub hash: String,
    /// The last update forwarded, which waits for the ones before it.
    pending: Option<JoinHandle<Result<Updated, ClientError>>>,
}

impl Replica {
    pub fn new(host: Arc<HostEntry>, session: String, hash: String) -> Self {
        Self { host, session, hash, pending: None }
    }

    /// Queues an update (from `producer`, announcing mesh `hash`) after the updates already
    /// forwarded; the transfer is recorded under step `step` of `run`, and measured.
    pub fn forward(
        &mut self,
        run: &Arc<Run>,
        step: usize,
        forwarded: Forwarded,
        hash: &str,
        producer: &Arc<HostEntry>,
    ) {
        let previous = self.pending.take();
        let (run, receiver, producer) = (run.clone(), self.host.clone(), producer.clone());
        let (session, announced) = (self.session.clone(), hash.to_owned());
        self.pending = Some(tokio::spawn(async move {
            if let Some(previous) = previous {
                // A failed predecessor leaves the session behind; this update's correction
                // then does not fit its base and the host falls back to the full mesh.
                let _ = previous.await;
            }
            let started_ms = run.elapsed_ms();
            let started = std::time::Instant::now();
            let outcome = receiver.client.update(&session, &forwarded.update).await;
            let outcome = judge(outcome, &announced, &receiver, &producer);
            let metrics = &forwarded.registry.metrics;
            match &outcome {
                Ok(updated) => {
                    metrics.transferred(updated.via, updated.bytes, started.elapsed());
                    learn(&forwarded, updated, &producer.url, &receiver.url);
                }
                Err(_) => metrics.transfer_failed(forwarded.update.use_),
            }
            let url = receiver.url.clone();
            let mut record =
                transfer_record(url, started_ms, run.elapsed_ms(), &forwarded.update, &outcome);
            record.estimates = forwarded.estimates;
            run.update_step("transfer", step, |s| {
                let json = serde_json::json!({"step": step, "transfer": record});
                // A full-mesh download tells the step's full-mesh size.
                if record.via == "full" && record.error.is_none() {
                    s.full_bytes = Some(record.bytes);
                }
                s.transfers.push(record);
                json
            });
            outcome
        }));
        self.hash = hash.to_owned();
    }

    /// Waits for the forwarded updates; true when the session then holds `hash`.
    pub async fn settle(&mut self, hash: &str) -> bool {
        match self.pending.take() {
            None => self.hash == hash,
            Some(pending) => {
                matches!(pending.await, Ok(Ok(updated)) if updated.hash == hash)
                    && self.hash == hash
            }
        }
    }
}

/// Blames whoever an update's outcome shows to be wrong: a receiver that answers another
/// mesh than the announced one, or a producer whose full mesh does not decode to the mesh
/// it announced (the receiver's `hash-mismatch` or `bad-mesh`). A wrong answer counts as a
/// failed update.
fn judge(
    outcome: Result<Updated, ClientError>,
    announced: &str,
    receiver: &HostEntry,
    producer: &HostEntry,
) -> Result<Updated, ClientError> {
    match outcome {
        Ok(updated) => match super::verify::updated(&updated, announced) {
            Ok(()) => Ok(updated),
            Err(claim) => {
                receiver.mark_suspect(format!("suspect: {claim}"));
                Err(ClientError::Protocol { url: receiver.url.clone(), message: claim.to_string() })
            }
        },
        Err(ClientError::Refused { ref code, ref message, .. })
            if code == "hash-mismatch" || code == "bad-mesh" =>
        {
            let why =
                format!("suspect: {} found its mesh {announced} wrong: {message}", receiver.url);
            tracing::warn!(host = %producer.url, "{why}");
            producer.mark_suspect(why);
            outcome
        }
        Err(error) => Err(error),
    }
}

/// What an update's answer tells the cost model: the link's speed (a full mesh or a large
/// correction measures bandwidth, small ones latency), the receiver's speed at the way it
/// used, and a full mesh's size.
fn learn(forwarded: &Forwarded, updated: &Updated, producer: &str, receiver: &str) {
    let measured = &forwarded.registry.measured;
    measured.downloaded(Some(producer), receiver, updated.bytes, updated.download_ms);
    let output = &forwarded.output;
    let applied = Applied {
        via: updated.via,
        apply_ms: updated.apply_ms,
        edits: output.edits,
        vertices: output.vertices,
        producer_compute_ms: output.compute_ms,
        had_plugin: forwarded.had_plugin,
    };
    measured.applied(receiver, &forwarded.plugin, &applied);
    if updated.via == meshflow_api::host::Transfer::Full && updated.fallback.is_none() {
        forwarded.last_full.seen(updated.bytes, output.vertices);
    }
}

fn transfer_record(
    host: String,
    started_ms: f64,
    finished_ms: f64,
    update: &Update,
    outcome: &Result<Updated, ClientError>,
) -> TransferRecord {
    let asked = update.use_.name().to_owned();
    match outcome {
        Ok(updated) => TransferRecord {
            host,
            asked,
            via: updated.via.name().to_owned(),
            estimates: None,
            bytes: updated.bytes,
            download_ms: updated.download_ms,
            apply_ms: updated.apply_ms,
            started_ms,
            finished_ms,
            fallback: updated.fallback.clone(),
            error: None,
        },
        Err(error) => TransferRecord {
            host,
            via: asked.clone(),
            asked,
            estimates: None,
            bytes: 0,
            download_ms: 0.0,
            apply_ms: 0.0,
            started_ms,
            finished_ms,
            fallback: None,
            error: Some(error.to_string()),
        },
    }
}

#[cfg(test)]
mod tests {
    use meshflow_api::host::{Transfer as Use, Updated};

    use super::*;

    #[tokio::test]
    async fn a_receiver_answering_another_mesh_or_finding_the_producers_wrong_is_believed_so() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, _) = crate::registry::test_registry(dir.path());
        let receiver = registry.register("http://127.0.0.1:9/receiver").await.unwrap();
        let producer = registry.register("http://127.0.0.1:9/producer").await.unwrap();
        let (announced, other) = ("a".repeat(64), "b".repeat(64));
        let updated = |hash: &str| Updated {
            hash: hash.to_owned(),
            via: Use::Correction,
            bytes: 1,
            download_ms: 0.0,
            apply_ms: 0.0,
            fallback: None,
        };
        assert!(judge(Ok(updated(&announced)), &announced, &receiver, &producer).is_ok());
        assert!(!receiver.is_suspect() && !producer.is_suspect());
        // Another mesh than announced: the receiver's answer cannot be true.
        assert!(judge(Ok(updated(&other)), &announced, &receiver, &producer).is_err());
        assert!(receiver.suspicion().unwrap().contains(&other));
        assert!(!producer.is_suspect());
        // The producer's full mesh is not what it announced: the producer is suspect.
        let refused = ClientError::Refused {
            url: receiver.url.clone(),
            status: 422,
            code: "hash-mismatch".into(),
            message: "the mesh has content hash …".into(),
        };
        assert!(judge(Err(refused), &announced, &receiver, &producer).is_err());
        assert!(producer.suspicion().unwrap().contains(&receiver.url));
    }
}
