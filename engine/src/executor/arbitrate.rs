//! When hosts disagree about a step, a third host decides (DESIGN §10). A disagreement is
//! a receiver whose edit log or replay of a step reaches another mesh than the producer
//! announced, a receiver that answers another hash or refuses the producer's mesh
//! (`hash-mismatch`, `bad-mesh`), or (an `untrusted` or spot-checked producer) a replay on
//! another host reaching another result. A host that took no part, and offers the step's
//! plugin, opens a session from the step's input and runs the step pinned to that plugin:
//! its result decides. Whoever claimed otherwise is suspect (kept in the store), whoever
//! claimed it is cleared; the claims and the verdict go in the step's record. If the
//! producer was wrong the run goes on from the arbiter's result; with nobody left to
//! replay, the step fails naming both claims.

use std::sync::{Arc, Mutex};

use meshflow_api::host::{GridSpec, RunRequest, RunResult};
use serde_json::json;

use super::error::ExecError;
use super::failure::Failure;
use super::replica::Replica;
use super::session::load_input;
use super::{Executor, busy, verify};
use crate::record::{HashClaim, Verdict, Verification};
use crate::registry::{HostEntry, Registry};
use crate::run::Run;
use crate::trust::{Trust, spot_checked};
use crate::workflow::Task;

/// A step's input and what ran on it: enough for another host to replay it.
#[derive(Clone)]
pub(super) struct StepInput {
    pub index: usize,
    pub task: Task,
    pub plugin: String,
    /// The input mesh, its counts, where it can be fetched whole, and a quantised run's grid.
    pub hash: String,
    pub counts: (u64, u64),
    pub sources: Vec<String>,
    pub grid: Option<[i32; 3]>,
}

/// A receiver's disagreement with a producer over step `step`, found while it applied the
/// step's result.
pub(crate) struct Dispute {
    pub step: usize,
    pub producer: Arc<HostEntry>,
    pub receiver: Arc<HostEntry>,
    pub announced: String,
    pub claim: HashClaim,
    pub position: Position,
}

pub(crate) type Disputes = Arc<Mutex<Vec<Dispute>>>;

/// What a party to a disagreement holds the step's outcome to be.
#[derive(Clone, PartialEq)]
pub(crate) enum Position {
    /// This outcome.
    Is(String),
    /// Not this one (a receiver that refused the announced mesh).
    IsNot(String),
    /// Nothing either way (a receiver that only fell back to the full mesh).
    Neutral,
}

impl Position {
    fn wrong(&self, truth: &str) -> bool {
        match self {
            Position::Is(claimed) => claimed != truth,
            Position::IsNot(denied) => denied == truth,
            Position::Neutral => false,
        }
    }

    fn right(&self, truth: &str) -> bool {
        match self {
            Position::Is(claimed) => claimed == truth,
            Position::IsNot(denied) => denied != truth,
            Position::Neutral => false,
        }
    }
}

struct Party {
    host: Arc<HostEntry>,
    claim: HashClaim,
    position: Position,
}

/// What a step came to: a filter's output hash, a check's value as JSON text.
pub(super) fn outcome(result: &RunResult) -> String {
    match result {
        RunResult::Filter(filter) => filter.output_hash.clone(),
        RunResult::Check(check) => check.value.to_string(),
    }
}

fn claim(host: &HostEntry, role: &str, hash: Option<String>, message: String) -> HashClaim {
    HashClaim { host: host.url.clone(), role: role.to_owned(), hash, message }
}

/// Replays step `input` on `host`: a session from the step's input, the task run pinned to
/// the plugin that ran it; the session and the (well-formed) answer.
async fn replay_on(
    run: &Run,
    host: &Arc<HostEntry>,
    input: &StepInput,
) -> Result<(String, RunResult), Failure> {
    let grid = input.grid.map(GridSpec::Exponents);
    let mut refusals = Vec::new();
    let mut session = None;
    for url in &input.sources {
        match load_input(run, host.clone(), url, Some(input.hash.clone()), grid).await {
            Ok((id, _)) => {
                session = Some(id);
                break;
            }
            Err(Failure::Step(error)) => refusals.push(format!("{url}: {error}")),
            Err(failure) => return Err(failure),
        }
    }
    let session = session.ok_or_else(|| {
        Failure::Step(format!("could not get mesh {}: {}", input.hash, refusals.join("; ")))
    })?;
    let request = RunRequest {
        service: input.task.service.clone(),
        params: input.task.params.clone(),
        plugin: Some(input.plugin.clone()),
    };
    let result = {
        let _in_flight = host.assign();
        busy::run_when_free(&host.client, &session, &request).await.0?
    };
    let asked = verify::Asked {
        host: &host.url,
        service: &input.task.service,
        input_hash: &input.hash,
        input_counts: input.counts,
    };
    if let RunResult::Filter(filter) = &result {
        asked.filter(filter)?;
    }
    let plugin = match &result {
        RunResult::Filter(filter) => &filter.plugin,
        RunResult::Check(check) => &check.plugin,
    };
    verify::ran_pinned(plugin, Some(&input.plugin))?;
    Ok((session, result))
}

/// Replays step `input` on the first host that can — up, not suspect, offering the step's
/// plugin, not `excluded` — least loaded first; a host failing meanwhile is set aside.
async fn replay_elsewhere(
    run: &Run,
    registry: &Registry,
    input: &StepInput,
    excluded: &[Arc<HostEntry>],
) -> Option<(Arc<HostEntry>, String, RunResult)> {
    let mut hosts: Vec<Arc<HostEntry>> = registry
        .hosts()
        .into_iter()
        .filter(|h| h.offers_plugin(&input.task.service, &input.plugin))
        .filter(|h| !excluded.iter().any(|e| Arc::ptr_eq(e, h)))
        .collect();
    hosts.sort_by_key(|h| h.load());
    for host in hosts {
        match replay_on(run, &host, input).await {
            Ok((session, result)) => return Some((host, session, result)),
            Err(failure) => {
                let message = match failure.set_aside(&host) {
                    Ok(message) => message,
                    Err(step) => step.0,
                };
                tracing::warn!(host = %host.url, "could not replay {}: {message}", input.task.path);
            }
        }
    }
    None
}

impl Executor {
    /// What step `index` (task `task`, answered `result`) ran on: the current mesh, before
    /// the step's result becomes it.
    pub(super) fn step_input(&self, index: usize, task: &Task, result: &RunResult) -> StepInput {
        let current = &self.current;
        let plugin = match result {
            RunResult::Filter(filter) => filter.plugin.clone(),
            RunResult::Check(check) => check.plugin.clone(),
        };
        let mut sources = vec![current.full.url.clone()];
        let holders = self.replicas.iter().filter(|r| r.hash == current.hash).map(|r| &r.host.url);
        for host in holders.chain(&self.holders) {
            let url = verify::full_mesh_url(host, &current.hash);
            if !sources.contains(&url) {
                sources.push(url);
            }
        }
        StepInput {
            index,
            task: task.clone(),
            plugin,
            hash: current.hash.clone(),
            counts: (current.vertices, current.triangles),
            sources,
            grid: current.grid,
        }
    }

    /// A step's result as far as its producer's trust level says: an `untrusted` host's is
    /// replayed on another host first (and arbitrated if that host disagrees), a
    /// `spot-check` host's is replayed in the background for a share of steps. The result
    /// to go on from, and its host (the arbiter's when the producer was proven wrong).
    pub(super) async fn vouch(
        &mut self,
        input: &StepInput,
        result: RunResult,
        producer: Arc<HostEntry>,
    ) -> Result<(RunResult, Arc<HostEntry>), ExecError> {
        self.step_inputs.push(input.clone());
        match producer.trust() {
            Trust::Trusted => Ok((result, producer)),
            Trust::SpotCheck => {
                let share = self.registry.spot_check_share();
                if spot_checked(&self.run.id, input.index, share) {
                    self.spot_check(input.clone(), outcome(&result), producer.clone());
                }
                Ok((result, producer))
            }
            Trust::Untrusted => self.replayed(input, result, producer).await,
        }
    }

    /// An untrusted host's result, replayed on another host before anyone builds on it.
    async fn replayed(
        &mut self,
        input: &StepInput,
        result: RunResult,
        producer: Arc<HostEntry>,
    ) -> Result<(RunResult, Arc<HostEntry>), ExecError> {
        let claimed = outcome(&result);
        let excluded = [producer.clone()];
        let Some((verifier, _, check)) =
            replay_elsewhere(&self.run, &self.registry, input, &excluded).await
        else {
            return Err(ExecError::Unverified {
                path: input.task.path.clone(),
                host: producer.url.clone(),
                claimed,
            });
        };
        let reached = outcome(&check);
        if reached == claimed {
            self.verified(input.index, &verifier.url, "replay", &reached);
            return Ok((result, producer));
        }
        let parties = vec![
            Party {
                claim: claim(&producer, "produced", Some(claimed.clone()), String::new()),
                host: producer.clone(),
                position: Position::Is(claimed.clone()),
            },
            Party {
                claim: claim(&verifier, "replayed", Some(reached.clone()), String::new()),
                host: verifier,
                position: Position::Is(reached),
            },
        ];
        let (arbiter, session, truth) = self.arbitrate(input, &parties).await?;
        if outcome(&truth) == claimed {
            return Ok((result, producer));
        }
        self.adopt(&arbiter, session, &truth);
        Ok((truth, arbiter))
    }

    /// Has an uninvolved host replay the step; judges the parties by its outcome and
    /// records claims and verdict. The arbiter, its session and its answer.
    async fn arbitrate(
        &mut self,
        input: &StepInput,
        parties: &[Party],
    ) -> Result<(Arc<HostEntry>, String, RunResult), ExecError> {
        let involved: Vec<Arc<HostEntry>> = parties.iter().map(|p| p.host.clone()).collect();
        let claims: Vec<HashClaim> = parties.iter().map(|p| p.claim.clone()).collect();
        let Some((arbiter, session, result)) =
            replay_elsewhere(&self.run, &self.registry, input, &involved).await
        else {
            let described: Vec<String> = claims
                .iter()
                .map(|c| {
                    let what = c.hash.as_deref().unwrap_or("another mesh than announced");
                    format!("{} ({}) {what} {}", c.host, c.role, c.message).trim_end().to_owned()
                })
                .collect();
            self.run.update_step("verdict", input.index, |s| {
                s.claims = claims.clone();
                json!({"step": input.index, "claims": claims})
            });
            return Err(ExecError::Unsettled {
                path: input.task.path.clone(),
                claims: described.join("; "),
            });
        };
        let truth = outcome(&result);
        let (mut wrong, mut right) = (Vec::new(), Vec::new());
        for party in parties {
            let because = format!(
                "{}: a replay on {} reached {truth}, {} claimed {}",
                input.task.path,
                arbiter.url,
                party.host.url,
                party.claim.hash.as_deref().unwrap_or("otherwise")
            );
            if party.position.wrong(&truth) {
                tracing::warn!(host = %party.host.url, "proven wrong: {because}");
                party.host.mark_suspect(format!("suspect: {because}"));
                for replica in
                    self.replicas.iter_mut().filter(|r| Arc::ptr_eq(&r.host, &party.host))
                {
                    replica.forget();
                }
                wrong.push(party.host.url.clone());
            } else if party.position.right(&truth) {
                party.host.clear_suspicion(because);
                right.push(party.host.url.clone());
            }
        }
        let verdict = Verdict { arbiter: arbiter.url.clone(), hash: truth.clone(), wrong, right };
        let check = Verification {
            host: arbiter.url.clone(),
            how: "arbitration".into(),
            hash: truth.clone(),
        };
        let produced_wrong = parties.first().is_some_and(|p| p.position.wrong(&truth));
        self.run.update_step("verdict", input.index, |s| {
            s.claims = claims.clone();
            s.verdict = Some(verdict.clone());
            s.verified_by.push(check);
            if produced_wrong {
                match &result {
                    RunResult::Filter(filter) => {
                        s.output_hash = Some(filter.output_hash.clone());
                        s.vertices = Some(filter.vertices as u64);
                        s.triangles = Some(filter.triangles as u64);
                    }
                    RunResult::Check(check) => s.value = Some(check.value.clone()),
                }
            }
            json!({"step": input.index, "claims": claims, "verdict": verdict})
        });
        Ok((arbiter, session, result))
    }

    /// The arbiter's session holds the true result of a filter: it becomes that host's copy
    /// of the run's mesh.
    fn adopt(&mut self, arbiter: &Arc<HostEntry>, session: String, truth: &RunResult) {
        let RunResult::Filter(filter) = truth else { return };
        let hash = filter.output_hash.clone();
        match self.replicas.iter_mut().find(|r| Arc::ptr_eq(&r.host, arbiter)) {
            Some(replica) => replica.replace_session(session, hash),
            None => self.replicas.push(Replica::new(arbiter.clone(), session, hash)),
        }
    }

    fn verified(&self, index: usize, host: &str, how: &str, hash: &str) {
        verified(&self.run, index, host, how, hash);
    }

    /// Replays the step on another host in the background; a mismatch makes the producer
    /// suspect, is recorded as a warning, and fails the run if it has not completed.
    fn spot_check(&mut self, input: StepInput, claimed: String, producer: Arc<HostEntry>) {
        let (run, registry) = (self.run.clone(), self.registry.clone());
        self.spot_checks.push(tokio::spawn(async move {
            let excluded = [producer.clone()];
            let (checker, _, result) = replay_elsewhere(&run, &registry, &input, &excluded).await?;
            let reached = outcome(&result);
            if reached == claimed {
                verified(&run, input.index, &checker.url, "spot-check", &reached);
                return None;
            }
            let message = format!(
                "{}: a spot check on {} reached {reached}, {} announced {claimed}",
                input.task.path, checker.url, producer.url
            );
            producer.mark_suspect(format!("suspect: {message}"));
            run.update("warning", |r| {
                r.warnings.push(message.clone());
                json!(message)
            });
            Some(message)
        }));
    }

    /// Settles the disagreements receivers have reported so far. A producer proven wrong
    /// about the latest filter is replaced by the arbiter's result; about an earlier one,
    /// on which later steps were built, the run fails.
    pub(super) async fn resolve_disputes(&mut self) -> Result<(), ExecError> {
        loop {
            let disputes: Vec<Dispute> = std::mem::take(&mut *self.disputes.lock().unwrap());
            let Some(step) = disputes.first().map(|d| d.step) else { return Ok(()) };
            let (these, later): (Vec<Dispute>, Vec<Dispute>) =
                disputes.into_iter().partition(|d| d.step == step);
            self.disputes.lock().unwrap().extend(later);
            let Some(input) = self.step_inputs.iter().find(|i| i.index == step).cloned() else {
                tracing::warn!("a dispute over step {step}, which this engine did not run");
                continue;
            };
            let first = &these[0];
            let (producer, announced) = (first.producer.clone(), first.announced.clone());
            let mut parties = vec![Party {
                claim: claim(&producer, "produced", Some(announced.clone()), String::new()),
                host: producer.clone(),
                position: Position::Is(announced.clone()),
            }];
            for dispute in these {
                if !parties.iter().any(|p| Arc::ptr_eq(&p.host, &dispute.receiver)) {
                    parties.push(Party {
                        host: dispute.receiver,
                        claim: dispute.claim,
                        position: dispute.position,
                    });
                }
            }
            let (arbiter, session, truth) = self.arbitrate(&input, &parties).await?;
            let RunResult::Filter(filter) = &truth else { continue };
            if filter.output_hash == announced {
                continue;
            }
            let is_latest = self.current.hash == announced
                && self.history.last().is_some_and(|(_, hash)| *hash == announced);
            if !is_latest {
                return Err(ExecError::Contradicted {
                    path: input.task.path.clone(),
                    message: format!(
                        "{} announced {announced}, a replay on {} reached {}, and later steps \
                         were built on it",
                        producer.url, arbiter.url, filter.output_hash
                    ),
                });
            }
            for replica in &mut self.replicas {
                replica.forget();
            }
            self.holders.clear();
            self.current.advance(filter, &arbiter.url);
            if let Some(last) = self.history.last_mut() {
                last.1 = filter.output_hash.clone();
            }
            self.adopt(&arbiter, session, &truth);
        }
    }

    /// Before a run's result: every forwarded update has been answered, every disagreement
    /// settled, every spot check back.
    pub(super) async fn settle_trust(&mut self) -> Result<(), ExecError> {
        for replica in &mut self.replicas {
            replica.wait().await;
        }
        self.resolve_disputes().await?;
        let checks = futures_util::future::join_all(self.spot_checks.drain(..)).await;
        match checks.into_iter().find_map(|c| c.ok().flatten()) {
            Some(message) => Err(ExecError::SpotCheck(message)),
            None => Ok(()),
        }
    }
}

fn verified(run: &Run, index: usize, host: &str, how: &str, hash: &str) {
    let check = Verification { host: host.to_owned(), how: how.to_owned(), hash: hash.to_owned() };
    run.update_step("verified", index, |s| {
        s.verified_by.push(check.clone());
        json!({"step": index, "verified_by": check})
    });
}
