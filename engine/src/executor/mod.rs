//! The concurrent transfer protocol of DESIGN §5: broadcast the input to every host of the
//! plan in parallel, trigger each task as soon as its host is up to date, forward every
//! result in parallel to the hosts that still have work, and keep IF / WHILE on an active
//! task list. A host that fails is marked down and its task moves to another host; a host
//! whose answer cannot be true (`verify`) is marked suspect and its task moves the same way;
//! a busy host is asked again, then left for another (`busy`).

mod busy;
mod cost;
mod replica;
mod verify;

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

pub(crate) use verify::full_mesh_url;

use meshflow_api::host::{
    CreateSession, FilterResult, FullRef, GridSpec, InputRef, RunRequest, RunResult, SessionState,
    Transfer as Use, Update,
};
use meshflow_api::params::ValueType;
use meshflow_api::{ClientError, HostClient};
use serde_json::{Value as Json, json};

use crate::limits::{MAX_CORRECTION_BYTES, MAX_STEPS_PER_RUN};
use crate::plan::{Plan, offering_pinned, pick, placed_by_link};
use crate::record::{BroadcastRecord, HostLoad, InputRecord, ResultRecord, Status, StepRecord};
use crate::registry::{HostEntry, Registry};
use crate::run::Run;
use crate::workflow::{Condition, Step, Task, Transfer, Workflow};
use replica::Replica;

/// Runs `workflow` on the run's input and records everything in `run`; never panics on a
/// bad host or input, ends with the run completed or failed. The caller deletes the host
/// sessions the run opened (`Run::take_sessions`).
///
/// `resumed`: the engine restarted while the run was going. Its recorded steps are taken
/// as done (the control flow is walked again over their recorded results, no host is
/// asked), and the first new task's host fetches the current mesh from a host that held
/// it, or rebuilds it from the input. A resumed run that fails before finishing a new step
/// ends `interrupted` with the reason.
pub async fn execute(run: Arc<Run>, workflow: Workflow, registry: Arc<Registry>, resumed: bool) {
    let done = match resumed {
        true => recorded_steps(&run),
        false => VecDeque::new(),
    };
    let resuming_at = done.len();
    if resumed && done.is_empty() {
        // Nothing finished before the restart: start over.
        run.update("restart", |r| {
            let fresh = crate::record::RunRecord::new(r.id.clone(), r.transfer);
            let (workflow, rerun_of) = (std::mem::take(&mut r.workflow), r.rerun_of.take());
            *r = crate::record::RunRecord { workflow, rerun_of, ..fresh };
            json!(null)
        });
    }
    run.set_status(Status::Running, None);
    let input = run.input.clone();
    let mut executor = None;
    let outcome = match Plan::new(&workflow, &registry) {
        Ok(plan) => {
            let executor = executor.insert(Executor::new(run.clone(), registry, plan, &workflow));
            executor.execute(&workflow, &input, done).await
        }
        Err(error) => Err(error.to_string()),
    };
    let fresh_steps = run.record().steps.len() > resuming_at;
    match outcome {
        Ok(()) => run.set_status(Status::Completed, None),
        Err(error) if resumed && !fresh_steps => run.set_status(
            Status::Interrupted,
            Some(format!(
                "the engine restarted and could not resume after {resuming_at} step(s): {error}"
            )),
        ),
        Err(error) => run.set_status(Status::Failed, Some(error)),
    }
}

/// The steps of a stored record that count as done: all but a trailing check whose
/// condition was not yet recorded (it runs again); the record is cut to them.
fn recorded_steps(run: &Run) -> VecDeque<StepRecord> {
    let mut done = VecDeque::new();
    run.update("resume", |r| {
        while r.steps.last().is_some_and(|s| s.kind == "check" && s.condition.is_none()) {
            r.steps.pop();
        }
        r.result = None;
        r.error = None;
        done = r.steps.iter().cloned().collect();
        json!({"resumed_after_steps": r.steps.len()})
    });
    done
}

/// The mesh as of the last finished filter, and how to get it.
struct Current {
    hash: String,
    full: FullRef,
    correction: Option<meshflow_api::host::BlobRef>,
    vertices: u64,
    triangles: u64,
    /// The size of the last full mesh seen and its vertex count, from which the cost model
    /// estimates the current one's; shared with the forwarded updates, which see it first.
    last_full: LastFull,
    /// The host whose filter made this mesh (none for the input).
    producer: Option<String>,
    /// A quantised run's grid (step exponents), for hosts that join from this mesh.
    grid: Option<[i32; 3]>,
}

/// The last full mesh size seen in the run, with the vertex count it had; shared by the
/// executor and its forwarded updates.
#[derive(Clone)]
pub(crate) struct LastFull(Arc<std::sync::Mutex<Option<(u64, u64)>>>);

impl LastFull {
    fn new(bytes: Option<u64>, vertices: u64) -> Self {
        Self(Arc::new(std::sync::Mutex::new(bytes.map(|b| (b, vertices)))))
    }

    pub(crate) fn seen(&self, bytes: u64, vertices: u64) {
        *self.0.lock().expect("last full lock") = Some((bytes, vertices));
    }

    /// The full size of a mesh of `vertices`, scaled from the last one seen (unknown: so
    /// large that a full transfer is never expected to be quickest).
    fn estimate(&self, vertices: u64) -> u64 {
        match *self.0.lock().expect("last full lock") {
            Some((bytes, seen)) if seen > 0 => {
                (bytes as f64 * vertices as f64 / seen as f64).round() as u64
            }
            Some((bytes, _)) => bytes,
            None => u64::MAX / 4,
        }
    }
}

/// Why a task could not run on its host.
enum Failure {
    /// The host is unreachable or broken: try another one.
    Host(String),
    /// The host's answer cannot be true: distrust it and try another one.
    Suspect(String),
    /// The host stayed busy (429) however often it was asked: try another one.
    Busy(String),
    /// The step itself failed (plugin error, bad parameters): the run ends.
    Step(String),
}

/// A host that cannot be reached, times out or breaks is down and the task moves on; so
/// does a busy one (without blame); a refused request is the step's own fault and would
/// fail the same way elsewhere.
impl From<ClientError> for Failure {
    fn from(error: ClientError) -> Self {
        match error {
            ClientError::Busy { .. } => Failure::Busy(error.to_string()),
            _ if error.is_host_failure() => Failure::Host(error.to_string()),
            _ => Failure::Step(error.to_string()),
        }
    }
}

impl From<verify::FalseClaim> for Failure {
    fn from(claim: verify::FalseClaim) -> Self {
        Failure::Suspect(claim.to_string())
    }
}

impl Failure {
    /// Marks `host` as this failure says — down, suspect, or (busy) neither — and returns
    /// what to tell about it; `Err` with the message for a step's own failure.
    fn set_aside(self, host: &HostEntry) -> Result<String, String> {
        match self {
            Failure::Host(message) => {
                tracing::warn!(host = %host.url, "marking host down: {message}");
                host.mark_down(message.clone());
                Ok(message)
            }
            Failure::Suspect(message) => {
                let message = format!("suspect: {message}");
                tracing::warn!(host = %host.url, "{message}");
                host.mark_suspect(message.clone());
                Ok(message)
            }
            Failure::Busy(message) => Ok(message),
            Failure::Step(message) => Err(message),
        }
    }
}

struct Executor {
    run: Arc<Run>,
    registry: Arc<Registry>,
    plan: Plan,
    transfer: Transfer,
    /// The workflow's `quantize`: bits per axis of the grid every session keeps.
    quantize: Option<u32>,
    replicas: Vec<Replica>,
    current: Option<Current>,
    /// The input's URL and every filter run since, with its output hash: a host that must
    /// take over when no copy of the current mesh survives replays them (services are
    /// deterministic, so the hashes must match).
    input: String,
    history: Vec<(Task, String)>,
    /// When the last host reply arrived, for the engine-overhead figure.
    last_reply: Instant,
    /// Steps done before an engine restart, taken in order instead of running them.
    done: VecDeque<StepRecord>,
    /// Hosts that held the current mesh when the engine stopped (a resumed run).
    holders: Vec<String>,
    /// Edit-log sizes asked of their producers, which encode the logs after answering;
    /// awaited before the run's result is recorded.
    log_sizes: Vec<tokio::task::JoinHandle<()>>,
}

/// An entry of the active task list: a step, and for a WHILE the rounds already done.
struct Active {
    step: Step,
    rounds: u32,
}

impl Executor {
    fn new(run: Arc<Run>, registry: Arc<Registry>, plan: Plan, workflow: &Workflow) -> Self {
        Self {
            run,
            registry,
            plan,
            transfer: workflow.transfer,
            quantize: workflow.quantize,
            replicas: Vec::new(),
            current: None,
            input: String::new(),
            history: Vec::new(),
            last_reply: Instant::now(),
            done: VecDeque::new(),
            holders: Vec::new(),
            log_sizes: Vec::new(),
        }
    }

    async fn execute(
        &mut self,
        workflow: &Workflow,
        input: &str,
        done: VecDeque<StepRecord>,
    ) -> Result<(), String> {
        self.input = input.to_owned();
        if done.is_empty() {
            self.broadcast(input).await?;
        } else {
            self.restore_input()?;
            self.done = done;
        }
        let mut active: VecDeque<Active> =
            workflow.steps.iter().map(|step| Active { step: step.clone(), rounds: 0 }).collect();
        while let Some(Active { step, rounds }) = active.pop_front() {
            match step {
                Step::Run(task) => {
                    let receivers = self.hosts_of(&active);
                    self.run_filter(&task, &receivers).await?;
                }
                Step::If { condition, then, otherwise, .. } => {
                    let branch = if self.evaluate(&condition).await? { then } else { otherwise };
                    for step in branch.into_iter().rev() {
                        active.push_front(Active { step, rounds: 0 });
                    }
                }
                Step::While { ref path, ref condition, ref body, max_iterations } => {
                    if !self.evaluate(condition).await? {
                        continue;
                    }
                    if rounds == max_iterations {
                        let warning = format!(
                            "{path}: stopped after max-iterations = {max_iterations} rounds with \
                             its condition still true"
                        );
                        // A resumed run walks past it again: warn once.
                        self.run.update("warning", |r| {
                            if !r.warnings.contains(&warning) {
                                r.warnings.push(warning.clone());
                            }
                            json!(warning)
                        });
                        continue;
                    }
                    let body = body.clone();
                    active.push_front(Active { step, rounds: rounds + 1 });
                    for step in body.into_iter().rev() {
                        active.push_front(Active { step, rounds: 0 });
                    }
                }
            }
        }
        self.finish().await
    }

    /// Sends the input to every host of the plan at once and waits until all hold it.
    async fn broadcast(&mut self, input: &str) -> Result<(), String> {
        let started = Instant::now();
        let mut hosts = self.plan.hosts();
        let mut loads = Vec::new();
        let mut excluded = Vec::new();
        while !hosts.is_empty() {
            let run = &self.run;
            let grid = self.quantize.map(GridSpec::Bits);
            let attempts =
                hosts.iter().map(|host| load_input(run, host.clone(), input, None, grid));
            let outcomes = futures_util::future::join_all(attempts).await;
            let mut retry = Vec::new();
            for (host, outcome) in hosts.iter().zip(outcomes) {
                match outcome {
                    Ok((session, status)) => {
                        let hash = status.hash.clone().unwrap_or_default();
                        let load = HostLoad {
                            host: host.url.clone(),
                            bytes: status.input_bytes.unwrap_or(0),
                            download_ms: status.download_ms.unwrap_or(0.0),
                            load_ms: status.load_ms.unwrap_or(0.0),
                        };
                        // What the link into this host is worth, until pairs are measured.
                        let measured = &self.registry.measured;
                        measured.downloaded(None, &host.url, load.bytes, load.download_ms);
                        loads.push(load);
                        self.set_input(input, &status);
                        self.replicas.push(Replica::new(host.clone(), session, hash));
                    }
                    Err(failure) => {
                        failure
                            .set_aside(host)
                            .map_err(|message| format!("input {input}: {message}"))?;
                        excluded.push(host.clone());
                        retry.extend(self.replace(host, &excluded)?);
                    }
                }
            }
            hosts = retry;
        }
        let hashes: std::collections::BTreeSet<&str> =
            self.replicas.iter().map(|r| r.hash.as_str()).collect();
        if hashes.len() > 1 {
            return Err(format!("input {input}: hosts decoded it differently ({hashes:?})"));
        }
        let ms = started.elapsed().as_secs_f64() * 1e3;
        self.run.update("broadcast", |r| {
            let record = BroadcastRecord { ms, hosts: loads };
            let json = json!(record);
            r.broadcast = Some(record);
            json
        });
        self.last_reply = Instant::now();
        Ok(())
    }

    fn set_input(&mut self, url: &str, status: &meshflow_api::host::SessionStatus) {
        if self.current.is_some() {
            return;
        }
        let hash = status.hash.clone().unwrap_or_default();
        let (vertices, triangles) =
            (status.vertices.unwrap_or(0) as u64, status.triangles.unwrap_or(0) as u64);
        self.current = Some(Current {
            full: FullRef { url: url.to_owned(), hash: hash.clone() },
            hash: hash.clone(),
            correction: None,
            vertices,
            triangles,
            last_full: LastFull::new(status.input_bytes, vertices),
            producer: None,
            grid: status.grid,
        });
        self.run.update("input", |r| {
            let grid = status.grid;
            let record = InputRecord { url: url.to_owned(), hash, vertices, triangles, grid };
            let json = json!(record);
            r.input = Some(record);
            json
        });
    }

    /// Moves every task planned on the failed `host` to other hosts; returns the hosts that
    /// are new to the plan.
    fn replace(
        &mut self,
        host: &Arc<HostEntry>,
        excluded: &[Arc<HostEntry>],
    ) -> Result<Vec<Arc<HostEntry>>, String> {
        let before = self.plan.hosts();
        for path in self.plan.tasks_on(host) {
            let service = self.plan.service(&path).to_owned();
            let pin = self.plan.pin(&path);
            let candidates = offering_pinned(&self.registry.hosts(), &service, pin);
            let measured = placed_by_link(self.plan.placement(), &self.registry);
            let replacement =
                pick(&candidates, &before, &service, excluded, measured).ok_or_else(|| {
                    format!(
                        "{path}: host {} failed and no other host offers \"{service}\"",
                        host.url
                    )
                })?;
            self.plan.assign(&path, replacement);
        }
        let after = self.plan.hosts();
        Ok(after.into_iter().filter(|h| !before.iter().any(|b| Arc::ptr_eq(b, h))).collect())
    }

    /// The hosts of every task still on the active list, bodies of IF and WHILE included.
    fn hosts_of(&self, active: &VecDeque<Active>) -> Vec<Arc<HostEntry>> {
        let steps: Vec<Step> = active.iter().map(|a| a.step.clone()).collect();
        let workflow = Workflow {
            steps,
            input: None,
            transfer: self.transfer,
            quantize: None,
            placement: self.plan.placement(),
        };
        let mut hosts: Vec<Arc<HostEntry>> = Vec::new();
        for task in workflow.tasks() {
            let host = self.plan.host(&task.path);
            if !hosts.iter().any(|h| Arc::ptr_eq(h, host)) {
                hosts.push(host.clone());
            }
        }
        hosts
    }

    async fn run_filter(
        &mut self,
        task: &Task,
        receivers: &[Arc<HostEntry>],
    ) -> Result<(), String> {
        if let Some(step) = self.take_done(task, "filter")? {
            return self.restore_filter(task, &step);
        }
        let (index, result, host) = self.run_task(task, "filter").await?;
        let RunResult::Filter(filter) = result else {
            return Err(format!(
                "{}: {} returned a check value, not a mesh",
                task.path, task.service
            ));
        };
        let url = filter.correction.url.clone();
        self.log_sizes.push(record_log_size(self.run.clone(), host.client.clone(), index, url));
        self.advance(&filter, &host);
        self.history.push((task.clone(), filter.output_hash.clone()));
        let current = self.current.as_ref().expect("the input is loaded");
        let output = cost::StepOutput {
            correction_bytes: filter.correction.bytes,
            replay_bytes: filter.replay.bytes,
            full_bytes: current.last_full.estimate(filter.vertices as u64),
            edits: filter.edits as u64,
            vertices: filter.vertices as u64,
            compute_ms: filter.compute_ms,
        };
        let hash = current.hash.clone();
        let last_full = current.last_full.clone();
        let measured = &self.registry.measured;
        for replica in &mut self.replicas {
            let wanted = receivers.iter().any(|h| Arc::ptr_eq(h, &replica.host));
            if !wanted || Arc::ptr_eq(&replica.host, &host) {
                continue;
            }
            let receiver = &replica.host;
            let has_plugin = receiver.has_plugin(&filter.plugin)
                || measured.has_fetched(&receiver.url, &filter.plugin);
            let estimates = cost::estimate(
                &output,
                &cost::Receiver {
                    link: measured.link(&host.url, &receiver.url),
                    speed: measured.speed(&receiver.url),
                    has_plugin,
                    load: receiver.load(),
                },
            );
            let update = Update {
                correction: Some(filter.correction.clone()),
                replay: Some(filter.replay.clone()),
                full: filter.full.clone(),
                use_: cost::choose(self.transfer, &estimates),
            };
            let forwarded = replica::Forwarded {
                update,
                plugin: filter.plugin.clone(),
                had_plugin: has_plugin,
                estimates: (self.transfer == Transfer::Auto).then_some(estimates),
                output,
                last_full: last_full.clone(),
                registry: self.registry.clone(),
            };
            replica.forward(&self.run, index, forwarded, &hash, &host);
        }
        Ok(())
    }

    /// The filter's output becomes the current mesh; the producer already holds it.
    fn advance(&mut self, filter: &FilterResult, producer: &Arc<HostEntry>) {
        self.holders.clear();
        let current = self.current.as_mut().expect("the input is loaded");
        current.hash = filter.output_hash.clone();
        current.producer = Some(producer.url.clone());
        current.full = filter.full.clone();
        current.correction = Some(filter.correction.clone());
        current.vertices = filter.vertices as u64;
        current.triangles = filter.triangles as u64;
        if let Some(replica) = self.replicas.iter_mut().find(|r| Arc::ptr_eq(&r.host, producer)) {
            replica.hash = filter.output_hash.clone();
        }
    }

    async fn evaluate(&mut self, condition: &Condition) -> Result<bool, String> {
        if let Some(step) = self.take_done(&condition.check, "check")? {
            return step.condition.ok_or_else(|| format!("{}: no recorded outcome", step.path));
        }
        let (index, result, _) = self.run_task(&condition.check, "check").await?;
        let RunResult::Check(check) = result else {
            return Err(format!(
                "{}: {} is not a check",
                condition.check.path, condition.check.service
            ));
        };
        let holds = compare(&check.value, condition)
            .map_err(|message| format!("{}: {message}", condition.check.path))?;
        self.run.update_step("condition", index, |step| {
            step.condition = Some(holds);
            json!({"step": index, "condition": holds})
        });
        Ok(holds)
    }

    /// Runs one task on its planned host, or on another one if that host fails; records it.
    async fn run_task(
        &mut self,
        task: &Task,
        kind: &'static str,
    ) -> Result<(usize, RunResult, Arc<HostEntry>), String> {
        if self.run.step_count() >= MAX_STEPS_PER_RUN {
            return Err(format!(
                "{}: the run has executed {MAX_STEPS_PER_RUN} steps, the most one run may",
                task.path
            ));
        }
        let mut failed: Vec<Arc<HostEntry>> = Vec::new();
        // What went wrong on each failed host, for the error if none is left.
        let mut reasons: Vec<String> = Vec::new();
        loop {
            let host = self.plan.host(&task.path).clone();
            let known = failed.iter().any(|h| Arc::ptr_eq(h, &host));
            if !known && (!host.is_up() || host.is_suspect()) {
                let why = host.suspicion().unwrap_or_else(|| "down".into());
                reasons.push(format!("{}: {why}", host.url));
                failed.push(host.clone());
            }
            if failed.iter().any(|h| Arc::ptr_eq(h, &host)) {
                let candidates =
                    offering_pinned(&self.registry.hosts(), &task.service, task.plugin.as_deref());
                let replacement = pick(
                    &candidates,
                    &self.plan.hosts(),
                    &task.service,
                    &failed,
                    placed_by_link(self.plan.placement(), &self.registry),
                )
                .ok_or_else(|| {
                    format!(
                        "{}: no host left for \"{}\" (failed: {})",
                        task.path,
                        task.service,
                        reasons.join("; ")
                    )
                })?;
                self.plan.assign(&task.path, replacement);
                continue;
            }
            match self.attempt(task, kind, &host, &failed).await {
                Ok((index, result)) => return Ok((index, result, host)),
                Err(failure) => {
                    let busy = matches!(failure, Failure::Busy(_));
                    let message = failure.set_aside(&host).map_err(|message| {
                        format!("{} ({} on {}): {message}", task.path, task.service, host.url)
                    })?;
                    // A busy host keeps its copy of the mesh for its later tasks.
                    if !busy {
                        self.replicas.retain(|r| !Arc::ptr_eq(&r.host, &host));
                    }
                    reasons.push(format!("{}: {message}", host.url));
                    failed.push(host);
                }
            }
        }
    }

    async fn attempt(
        &mut self,
        task: &Task,
        kind: &'static str,
        host: &Arc<HostEntry>,
        failed: &[Arc<HostEntry>],
    ) -> Result<(usize, RunResult), Failure> {
        let waiting = Instant::now();
        let session = self.bring_up_to_date(host).await?;
        let wait_ms = waiting.elapsed().as_secs_f64() * 1e3;
        let overhead_ms = (self.last_reply.elapsed().as_secs_f64() * 1e3 - wait_ms).max(0.0);
        let request = RunRequest {
            service: task.service.clone(),
            params: task.params.clone(),
            plugin: task.plugin.clone(),
        };
        let started_ms = self.run.elapsed_ms();
        let (result, busy) = {
            let _in_flight = host.assign();
            busy::run_when_free(&host.client, &session, &request).await
        };
        let result = result?;
        self.last_reply = Instant::now();
        let current = self.current.as_ref().expect("the input is loaded");
        let input_hash = current.hash.clone();
        let asked = verify::Asked {
            host: &host.url,
            service: &task.service,
            input_hash: &input_hash,
            input_counts: (current.vertices, current.triangles),
        };
        match &result {
            RunResult::Filter(filter) => asked.filter(filter)?,
            RunResult::Check(check) => asked.check(check, declared_type(host, &task.service)?)?,
        }
        let ran = match &result {
            RunResult::Filter(filter) => &filter.plugin,
            RunResult::Check(check) => &check.plugin,
        };
        verify::ran_pinned(ran, task.plugin.as_deref())?;
        let mut record = StepRecord {
            index: 0,
            path: task.path.clone(),
            kind: kind.to_owned(),
            service: task.service.clone(),
            host: host.url.clone(),
            plugin: String::new(),
            params: task.params.clone(),
            resolved_params: Default::default(),
            started_ms,
            finished_ms: self.run.elapsed_ms(),
            compute_ms: 0.0,
            queue_ms: busy.as_secs_f64() * 1e3,
            wait_ms,
            overhead_ms,
            input_hash,
            output_hash: None,
            vertices: None,
            triangles: None,
            edits: None,
            correction_bytes: None,
            correction_estimated: false,
            replay_bytes: None,
            full_bytes: None,
            value: None,
            condition: None,
            report: String::new(),
            failed_hosts: failed.iter().map(|h| h.url.clone()).collect(),
            transfers: Vec::new(),
        };
        match &result {
            RunResult::Filter(f) => {
                record.plugin = f.plugin.clone();
                record.resolved_params = f.resolved_params.clone();
                record.compute_ms = f.compute_ms;
                record.queue_ms += f.queue_ms;
                record.report = f.report.clone();
                record.output_hash = Some(f.output_hash.clone());
                record.vertices = Some(f.vertices as u64);
                record.triangles = Some(f.triangles as u64);
                record.edits = Some(f.edits as u64);
                record.correction_bytes = Some(f.correction.bytes);
                record.correction_estimated = true;
                record.replay_bytes = Some(f.replay.bytes);
            }
            RunResult::Check(c) => {
                record.plugin = c.plugin.clone();
                record.resolved_params = c.resolved_params.clone();
                record.compute_ms = c.compute_ms;
                record.queue_ms += c.queue_ms;
                record.report = c.report.clone();
                record.value = Some(c.value.clone());
            }
        }
        let index = self.run.push_step(record);
        Ok((index, result))
    }

    /// The session on `host` holding the current mesh: waits for forwarded updates, sends
    /// the full mesh to a host that fell behind, and opens a session on a host new to the
    /// run (a replacement) from the current full mesh.
    async fn bring_up_to_date(&mut self, host: &Arc<HostEntry>) -> Result<String, Failure> {
        let hash = self.current.as_ref().expect("the input is loaded").hash.clone();
        let sources = self.full_sources(host);
        // Why each copy could not be used, for the error if nothing else works either.
        let mut refusals: Vec<String> = Vec::new();
        if let Some(index) = self.replicas.iter().position(|r| Arc::ptr_eq(&r.host, host)) {
            let replica = &mut self.replicas[index];
            if replica.settle(&hash).await {
                return Ok(replica.session.clone());
            }
            for url in &sources {
                let full = FullRef { url: url.clone(), hash: hash.clone() };
                let update = Update { correction: None, replay: None, full, use_: Use::Full };
                match host.client.update(&replica.session, &update).await {
                    Ok(updated) => {
                        verify::updated(&updated, &hash)?;
                        replica.hash = hash;
                        return Ok(replica.session.clone());
                    }
                    Err(error) if error.is_host_failure() => return Err(error.into()),
                    Err(error) => refusals.push(format!("update from {url}: {error}")),
                }
            }
            self.replicas.remove(index);
        }
        let grid = self.current.as_ref().and_then(|c| c.grid).map(GridSpec::Exponents);
        for url in &sources {
            match load_input(&self.run, host.clone(), url, Some(hash.clone()), grid).await {
                Ok((session, _)) => {
                    self.replicas.push(Replica::new(host.clone(), session.clone(), hash));
                    return Ok(session);
                }
                Err(Failure::Step(error)) => refusals.push(format!("load of {url}: {error}")),
                Err(host_failure) => return Err(host_failure),
            }
        }
        for message in &refusals {
            tracing::warn!(host = %host.url, "no copy of mesh {hash}: {message}");
        }
        let missing: Vec<&str> = self
            .history
            .iter()
            .map(|(task, _)| task.service.as_str())
            .filter(|service| !host.offers(service))
            .collect();
        if !missing.is_empty() {
            return Err(Failure::Step(format!(
                "{} could not get mesh {hash} ({}) and cannot rebuild it from the input: it does \
                 not offer {}",
                host.url,
                refusals.join("; "),
                missing.join(", ")
            )));
        }
        self.replay_from_input(host).await
    }

    /// The last resort when no copy of the current mesh is reachable: load the input on
    /// `host` (which offers every service run so far) and run every filter since, checking
    /// each output hash against the record.
    async fn replay_from_input(&mut self, host: &Arc<HostEntry>) -> Result<String, Failure> {
        let input_hash = self.run.record().input.map(|i| i.hash);
        let grid = self.quantize.map(GridSpec::Bits);
        let (session, _) =
            load_input(&self.run, host.clone(), &self.input, input_hash, grid).await?;
        for (task, expected) in &self.history {
            let request = RunRequest {
                service: task.service.clone(),
                params: task.params.clone(),
                plugin: task.plugin.clone(),
            };
            let output = match busy::run_when_free(&host.client, &session, &request).await.0? {
                RunResult::Filter(filter) => filter.output_hash,
                RunResult::Check(_) => String::new(),
            };
            if &output != expected {
                return Err(Failure::Step(format!(
                    "replaying {} on {} gave mesh {output}, the run had {expected}",
                    task.path, host.url
                )));
            }
        }
        let warning = format!(
            "no copy of the current mesh survived; {} replayed {} filter step(s) from the input",
            host.url,
            self.history.len()
        );
        self.run.update("warning", |r| {
            r.warnings.push(warning.clone());
            json!(warning)
        });
        let hash = self.current.as_ref().expect("the input is loaded").hash.clone();
        self.replicas.push(Replica::new(host.clone(), session.clone(), hash));
        Ok(session)
    }

    /// Where the current mesh can be fetched whole: the producer's full-mesh URL, then every
    /// other host whose session holds (or is about to hold) it — hosts pack a session's
    /// mesh on request — in case the producer is gone.
    fn full_sources(&self, except: &Arc<HostEntry>) -> Vec<String> {
        let current = self.current.as_ref().expect("the input is loaded");
        let mut sources = vec![current.full.url.clone()];
        let holders = self.replicas.iter().filter(|r| r.hash == current.hash).map(|r| &r.host.url);
        for host in holders.chain(&self.holders) {
            let url = full_mesh_url(host, &current.hash);
            if *host != except.url && !sources.contains(&url) {
                sources.push(url);
            }
        }
        sources
    }

    /// The next step done before a restart, if any is left: it must be `task`.
    fn take_done(&mut self, task: &Task, kind: &str) -> Result<Option<StepRecord>, String> {
        let Some(step) = self.done.pop_front() else { return Ok(None) };
        if step.path != task.path || step.kind != kind {
            return Err(format!(
                "the record has {} {} where the workflow has {kind} {}",
                step.kind, step.path, task.path
            ));
        }
        Ok(Some(step))
    }

    /// A resumed run starts from the input as recorded.
    fn restore_input(&mut self) -> Result<(), String> {
        let input = self.run.record().input.ok_or("the record has steps but no input")?;
        self.current = Some(Current {
            full: FullRef { url: self.input.clone(), hash: input.hash.clone() },
            hash: input.hash,
            correction: None,
            vertices: input.vertices,
            triangles: input.triangles,
            last_full: LastFull::new(None, input.vertices),
            producer: None,
            grid: input.grid,
        });
        Ok(())
    }

    /// A filter done before a restart: its output is the current mesh, held by its
    /// producer and by every host that took the update.
    fn restore_filter(&mut self, task: &Task, step: &StepRecord) -> Result<(), String> {
        let hash =
            step.output_hash.clone().ok_or_else(|| format!("{}: no output hash", step.path))?;
        self.history.push((task.clone(), hash.clone()));
        self.holders = std::iter::once(step.host.clone())
            .chain(step.transfers.iter().filter(|t| t.error.is_none()).map(|t| t.host.clone()))
            .collect();
        let current = self.current.as_mut().expect("the input is restored first");
        current.full = FullRef { url: full_mesh_url(&step.host, &hash), hash: hash.clone() };
        current.hash = hash;
        current.producer = Some(step.host.clone());
        current.correction = None;
        current.vertices = step.vertices.unwrap_or(0);
        current.triangles = step.triangles.unwrap_or(0);
        if let (Some(bytes), Some(vertices)) = (step.full_bytes, step.vertices) {
            current.last_full.seen(bytes, vertices);
        }
        Ok(())
    }

    /// Records where the final mesh is and its packed size: its host packs and stores it
    /// now, so the result outlives the run's sessions (and the host's memory of recent
    /// outputs).
    async fn finish(&mut self) -> Result<(), String> {
        let current = self.current.as_ref().expect("the input is loaded");
        // The result is packed while the last edit logs are still being written: both are
        // the hosts' work at the end of a run, and neither needs the other.
        let packed = async {
            match &current.producer {
                Some(host) => self.registry.client(host).packed_size(&current.full.url).await.ok(),
                None => None,
            }
        };
        let log_sizes = futures_util::future::join_all(self.log_sizes.drain(..));
        let (bytes, _) = tokio::join!(packed, log_sizes);
        let result = ResultRecord {
            url: current.full.url.clone(),
            hash: current.hash.clone(),
            bytes,
            vertices: current.vertices,
            triangles: current.triangles,
        };
        self.run.update("result", |r| {
            let json = json!(result);
            r.result = Some(result);
            json
        });
        Ok(())
    }
}

/// Replaces step `index`'s estimated edit-log size by the real one once its producer has
/// written the log (a HEAD of it waits for that); an answer that does not come leaves the
/// estimate.
fn record_log_size(
    run: Arc<Run>,
    producer: HostClient,
    index: usize,
    url: String,
) -> tokio::task::JoinHandle<()> {
    tokio::spawn(async move {
        let Ok(bytes) = producer.blob_size(&url).await else { return };
        // A host's answer is a claim: a size no edit log can have leaves the estimate.
        if bytes > MAX_CORRECTION_BYTES {
            tracing::warn!("{url}: an edit log of {bytes} bytes is not believed");
            return;
        }
        run.update_step("correction", index, |step| {
            step.correction_bytes = Some(bytes);
            step.correction_estimated = false;
            json!({"step": index, "correction_bytes": bytes})
        });
    })
}

/// Opens a session on `host` from `url` (the run deletes it when it ends) and waits until
/// it is loaded.
async fn load_input(
    run: &Run,
    host: Arc<HostEntry>,
    url: &str,
    hash: Option<String>,
    grid: Option<GridSpec>,
) -> Result<(String, meshflow_api::host::SessionStatus), Failure> {
    let input = InputRef { url: url.to_owned(), hash: hash.clone() };
    let created = host.client.create_session_with(CreateSession { input, grid }).await?;
    run.session_opened(&host.url, &created.id);
    let status = host.client.wait_ready(&created.id).await?;
    match status.state {
        SessionState::Failed => Err(Failure::Step(
            status.error.unwrap_or_else(|| "the host could not load it".to_owned()),
        )),
        _ => {
            verify::loaded(&status, hash.as_deref())?;
            Ok((created.id, status))
        }
    }
}

/// The result type `host` declares for the check `service`; a host answering a check it
/// does not declare is not to be believed.
fn declared_type(host: &HostEntry, service: &str) -> Result<ValueType, Failure> {
    let services = host.state().services;
    let declared = services.iter().find(|s| s.info.name == service);
    declared.and_then(|s| s.info.result_type).ok_or_else(|| {
        Failure::Suspect(format!("answered the check {service:?}, which it does not declare"))
    })
}

/// Whether a check's value satisfies the condition.
fn compare(value: &Json, condition: &Condition) -> Result<bool, String> {
    let ordering = match (value, &condition.value) {
        (Json::Number(a), Json::Number(b)) => {
            let (a, b) = (a.as_f64().unwrap_or(f64::NAN), b.as_f64().unwrap_or(f64::NAN));
            a.partial_cmp(&b).ok_or_else(|| format!("cannot compare {a} with {b}"))?
        }
        (Json::Bool(a), Json::Bool(b)) => a.cmp(b),
        (Json::String(a), Json::String(b)) => a.cmp(b),
        (actual, expected) => {
            return Err(format!(
                "the check returned {actual}, which cannot be compared with {expected}"
            ));
        }
    };
    Ok(condition.op.holds(ordering))
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;
    use crate::workflow::Workflow;

    fn condition(op: &str, value: Json) -> Condition {
        let workflow = Workflow::from_json(&json!([
            {"while": {"check": "c", "op": op, "value": value}, "do": []}
        ]))
        .unwrap();
        match workflow.steps.into_iter().next() {
            Some(Step::While { condition, .. }) => condition,
            _ => unreachable!(),
        }
    }

    #[test]
    fn conditions_compare_numbers_booleans_and_text() {
        assert!(compare(&json!(12.5), &condition(">", json!(12))).unwrap());
        assert!(!compare(&json!(12), &condition(">", json!(12))).unwrap());
        assert!(compare(&json!(12), &condition(">=", json!(12.0))).unwrap());
        assert!(compare(&json!(3), &condition("!=", json!(4))).unwrap());
        assert!(compare(&json!(true), &condition("==", json!(true))).unwrap());
        assert!(compare(&json!("a"), &condition("<", json!("b"))).unwrap());
        let mismatch = compare(&json!(true), &condition("==", json!(1))).unwrap_err();
        assert_eq!(mismatch, "the check returned true, which cannot be compared with 1");
    }
}
