//! One host's copy of the run's mesh (a session there), and the queue of updates that
//! brings it up to date: each forwarded result is applied after the one before it. A
//! receiver must end up with the announced mesh: one that answers another hash, or finds
//! the producer's mesh is not what it announced, or whose replay or edit log of the step
//! reaches another mesh, disagrees with the producer, and `arbitrate` settles who is right.

use std::sync::Arc;
use std::time::{Duration, Instant};

use meshflow_api::ClientError;
use meshflow_api::engine::TransferEstimates;
use meshflow_api::host::{Update, Updated};
use tokio::task::JoinHandle;

use super::arbitrate::{Dispute, Disputes, Position};
use super::cost::StepOutput;
use super::current::LastFull;
use crate::measured::Applied;
use crate::record::{HashClaim, TransferRecord};
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
    pub disputes: Disputes,
}

pub struct Replica {
    pub host: Arc<HostEntry>,
    pub session: String,
    /// The hash the session will hold once `pending` has finished.
    pub hash: String,
    /// The last update forwarded, which waits for the ones before it.
    pending: Option<JoinHandle<Result<Updated, ClientError>>>,
    /// When the cost model expects `pending` to be done (its chosen way's estimate after
    /// the updates before it).
    expected_done: Option<Instant>,
}

impl Replica {
    pub fn new(host: Arc<HostEntry>, session: String, hash: String) -> Self {
        Self { host, session, hash, pending: None, expected_done: None }
    }

    /// Queues an update (from `producer`, announcing mesh `hash`) after the updates already
    /// forwarded, expected to take `expected_ms` once they are done; the transfer is recorded
    /// under step `step` of `run`, and measured.
    pub fn forward(
        &mut self,
        run: &Arc<Run>,
        step: usize,
        forwarded: Forwarded,
        hash: &str,
        producer: &Arc<HostEntry>,
        expected_ms: f64,
    ) {
        let now = Instant::now();
        let after =
            self.expected_done.filter(|_| self.pending.is_some()).map_or(now, |t| t.max(now));
        // An estimate past any duration (a host's figures can make it so) expects nothing.
        self.expected_done = Duration::try_from_secs_f64(expected_ms.max(0.0) / 1e3)
            .ok()
            .and_then(|expected| after.checked_add(expected));
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
            let disputes = &forwarded.disputes;
            let outcome = judge(outcome, &announced, &receiver, &producer, step, disputes);
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

    /// Whether an update to `hash` is still on its way to the session.
    pub fn is_catching_up(&self, hash: &str) -> bool {
        self.hash == hash && self.pending.as_ref().is_some_and(|p| !p.is_finished())
    }

    /// How long until the session is expected to hold `hash`, as of `now`: 0 once its
    /// updates are done; `None` when no update of `hash` is on its way (the host must fetch
    /// the mesh whole, which the engine does not estimate here).
    pub fn expected_wait_ms(&self, hash: &str, now: Instant) -> Option<f64> {
        if self.hash != hash {
            return None;
        }
        match &self.pending {
            Some(pending) if !pending.is_finished() => {
                let done = self.expected_done?;
                Some(done.saturating_duration_since(now).as_secs_f64() * 1e3)
            }
            _ => Some(0.0),
        }
    }

    /// Waits for the forwarded updates; true when the session then holds `hash`.
    pub async fn settle(&mut self, hash: &str) -> bool {
        self.wait().await;
        self.hash == hash
    }

    /// Waits for the forwarded updates; a failed one leaves the session's mesh unknown.
    pub async fn wait(&mut self) {
        if let Some(pending) = self.pending.take() {
            let reached = matches!(pending.await, Ok(Ok(updated)) if updated.hash == self.hash);
            if !reached {
                self.hash.clear();
            }
        }
    }

    /// The session's mesh is not to be built on (a disagreement found it wrong).
    pub fn forget(&mut self) {
        self.hash.clear();
    }

    /// Another session of the host (an arbiter's replay) holds `hash`: it is the copy now.
    pub fn replace_session(&mut self, session: String, hash: String) {
        self.pending = None;
        self.session = session;
        self.hash = hash;
    }
}

/// Finds the disagreements an update's outcome shows, for `arbitrate` to settle: a
/// receiver that answers another mesh than the announced one (a failed update), one that
/// finds the producer's full mesh is not the announced one (`hash-mismatch`, `bad-mesh`),
/// and one whose replay or edit log reached another mesh before it took the full mesh.
fn judge(
    outcome: Result<Updated, ClientError>,
    announced: &str,
    receiver: &Arc<HostEntry>,
    producer: &Arc<HostEntry>,
    step: usize,
    disputes: &Disputes,
) -> Result<Updated, ClientError> {
    let dispute = |hash: Option<String>, message: String, position: Position| Dispute {
        step,
        producer: producer.clone(),
        receiver: receiver.clone(),
        announced: announced.to_owned(),
        claim: HashClaim { host: receiver.url.clone(), role: "received".into(), hash, message },
        position,
    };
    match outcome {
        Ok(updated) => match super::verify::updated(&updated, announced) {
            Ok(()) => {
                if let Some(reached) = &updated.disagreed {
                    let fallback = updated.fallback.as_deref().unwrap_or_default();
                    let message = format!("reached mesh {reached}, took the full mesh: {fallback}");
                    tracing::warn!(host = %receiver.url, "step {step}: {message}");
                    let found = dispute(None, message, Position::Neutral);
                    disputes.lock().unwrap().push(found);
                }
                Ok(updated)
            }
            Err(claim) => {
                let position = Position::Is(updated.hash.clone());
                let found = dispute(Some(updated.hash.clone()), claim.to_string(), position);
                disputes.lock().unwrap().push(found);
                Err(ClientError::Protocol { url: receiver.url.clone(), message: claim.to_string() })
            }
        },
        Err(ClientError::Refused { ref code, ref message, .. })
            if code == "hash-mismatch" || code == "bad-mesh" =>
        {
            tracing::warn!(host = %producer.url, "{} found mesh {announced} wrong", receiver.url);
            let position = Position::IsNot(announced.to_owned());
            let found = dispute(None, format!("{code}: {message}"), position);
            disputes.lock().unwrap().push(found);
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
            plugin_wait_ms: updated.plugin_wait_ms,
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
            plugin_wait_ms: None,
        },
    }
}

#[cfg(test)]
mod tests {
    use meshflow_api::host::{Transfer as Use, Updated};

    use super::*;

    #[tokio::test]
    async fn a_receiver_answering_another_mesh_or_finding_the_producers_wrong_disagrees() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, _) = crate::registry::test_registry(dir.path());
        let receiver = registry.register("http://127.0.0.1:9/receiver").await.unwrap();
        let producer = registry.register("http://127.0.0.1:9/producer").await.unwrap();
        let (announced, other) = ("a".repeat(64), "b".repeat(64));
        let updated = |hash: &str, fallback: Option<&str>| Updated {
            hash: hash.to_owned(),
            via: Use::Correction,
            bytes: 1,
            download_ms: 0.0,
            apply_ms: 0.0,
            fallback: fallback.map(str::to_owned),
            disagreed: fallback.map(|_| "b".repeat(64)),
            plugin_wait_ms: None,
        };
        let disputes = Disputes::default();
        let judged = |outcome| judge(outcome, &announced, &receiver, &producer, 3, &disputes);
        assert!(judged(Ok(updated(&announced, None))).is_ok());
        assert!(disputes.lock().unwrap().is_empty());
        // Another mesh than announced: a failed update, and a disagreement.
        assert!(judged(Ok(updated(&other, None))).is_err());
        // The producer's full mesh is not what it announced.
        let refused = ClientError::Refused {
            url: receiver.url.clone(),
            status: 422,
            code: "hash-mismatch".into(),
            message: "the mesh has content hash …".into(),
        };
        assert!(judged(Err(refused)).is_err());
        // The edit log reached another mesh; the full mesh was the announced one.
        let fell_back = "correction: replaying the correction gave mesh b, not the expected a";
        assert!(judged(Ok(updated(&announced, Some(fell_back)))).is_ok());
        let found = disputes.lock().unwrap();
        let positions: Vec<bool> = found.iter().map(|d| d.position == Position::Neutral).collect();
        assert_eq!(positions, [false, false, true]);
        assert_eq!(found[0].claim.hash.as_deref(), Some(other.as_str()));
        assert!(found.iter().all(|d| d.step == 3 && d.announced == announced));
        // Nobody is suspect until a third host has replayed the step.
        assert!(!receiver.is_suspect() && !producer.is_suspect());
    }
}
