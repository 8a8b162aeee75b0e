//! One task on one host, and its failover: the task runs on its planned host once that
//! host holds the current mesh; a host that fails, lies or stays busy is set aside and the
//! task moves to another host offering the service, until one answers or none is left.

use std::sync::Arc;
use std::time::{Duration, Instant};

use meshflow_api::host::{RunRequest, RunResult};
use meshflow_api::params::ValueType;

use super::early::EarlyStart;
use super::error::ExecError;
use super::failure::{Failure, StepFailed};
use super::step_record::{Answer, Ran};
use super::to_data::Move;
use super::{Executor, busy, verify};
use crate::limits::MAX_STEPS_PER_RUN;
use crate::plan::{offering_pinned, pick, placed_by_link};
use crate::registry::HostEntry;
use crate::workflow::Task;

impl Executor {
    /// Runs one task on its planned host, or on another one if that host fails; records it.
    pub(super) async fn run_task(
        &mut self,
        task: &Task,
        kind: &'static str,
    ) -> Result<(usize, RunResult, Arc<HostEntry>), ExecError> {
        if self.run.step_count() >= MAX_STEPS_PER_RUN {
            return Err(ExecError::TooManySteps { path: task.path.clone() });
        }
        let mut failed: Vec<Arc<HostEntry>> = Vec::new();
        // What went wrong on each failed host, for the error if none is left.
        let mut reasons: Vec<String> = Vec::new();
        // Tried first, once: the host holding the mesh, when it is expected much sooner.
        let planned = self.plan.host(&task.path).clone();
        let mut moved = self.move_to_data(task, &planned).await;
        loop {
            let host = match &moved {
                Some(moved) => moved.host.clone(),
                None => self.plan.host(&task.path).clone(),
            };
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
                .ok_or_else(|| ExecError::NoHostLeft {
                    path: task.path.clone(),
                    service: task.service.clone(),
                    reasons: reasons.join("; "),
                })?;
                self.plan.assign(&task.path, replacement);
                continue;
            }
            match self.attempt(task, kind, &host, &failed, moved.as_ref()).await {
                // The plan stays: the planned host keeps taking the results (it holds the
                // run's second copy at its end), and a later round decides afresh.
                Ok((index, result)) => return Ok((index, result, host)),
                // Moving was the engine's idea: a step that fails where the mesh is (a plugin
                // it could not get there after all) runs where it was planned, whose answer
                // decides for the run; the host holding the mesh keeps its copy.
                Err(Failure::Step(message)) if moved.is_some() => {
                    tracing::info!(host = %host.url, "{}: moved to the data, failed: {message}", task.path);
                    reasons.push(format!("{} (moved to the data): {message}", host.url));
                    moved = None;
                }
                Err(failure) => {
                    let busy = matches!(failure, Failure::Busy(_));
                    let message = failure.set_aside(&host).map_err(|StepFailed(message)| {
                        ExecError::Step {
                            path: task.path.clone(),
                            service: task.service.clone(),
                            host: host.url.clone(),
                            message,
                        }
                    })?;
                    // A busy host keeps its copy of the mesh for its later tasks.
                    if !busy {
                        self.replicas.retain(|r| !Arc::ptr_eq(&r.host, &host));
                    }
                    reasons.push(format!("{}: {message}", host.url));
                    failed.push(host);
                    moved = None;
                }
            }
        }
    }

    /// Runs the task on `host` once its session holds the current mesh, checks the answer
    /// and records the step; its index and the answer. A task `moved` to the data runs the
    /// plugin its planned host would have.
    async fn attempt(
        &mut self,
        task: &Task,
        kind: &'static str,
        host: &Arc<HostEntry>,
        failed: &[Arc<HostEntry>],
        moved: Option<&Move>,
    ) -> Result<(usize, RunResult), Failure> {
        let waiting = Instant::now();
        let session = self.bring_up_to_date(host).await?;
        let wait_ms = waiting.elapsed().as_secs_f64() * 1e3;
        let overhead_ms = (self.last_reply.elapsed().as_secs_f64() * 1e3 - wait_ms).max(0.0);
        let early = (task, host, session.as_str());
        let early = EarlyStart::take(&mut self.early, early, &mut self.replicas).await;
        let (started_ms, answered_ms, request, (result, busy)) = match early {
            Some(early) => {
                (early.started_ms, Some(early.answered_ms), early.request, early.outcome)
            }
            None => {
                // The workflow's pin, or the plugin a task moved to the data runs.
                let plugin = moved.map(|m| m.plugin.as_str()).or(self.plan.pin(&task.path));
                let request = run_request(task, plugin);
                let started_ms = self.run.elapsed_ms();
                let _in_flight = host.assign();
                let outcome = busy::run_when_free(&host.client, &session, &request).await;
                (started_ms, None, request, outcome)
            }
        };
        let result = result?;
        self.last_reply = Instant::now();
        let asked = verify::Asked {
            host: &host.url,
            service: &task.service,
            input_hash: &self.current.hash,
            input_counts: (self.current.vertices, self.current.triangles),
        };
        match &result {
            RunResult::Filter(filter) => asked.filter(filter)?,
            RunResult::Check(check) => {
                let declared = self.declared_type(host, &check.plugin, &task.service)?;
                asked.check(check, declared)?
            }
        }
        let answer = Answer::of(&result);
        verify::ran_pinned(answer.plugin, task.plugin.as_deref())?;
        verify::ran_pinned(answer.plugin, request.plugin.as_deref())?;
        let ran = Ran {
            task,
            kind,
            host: &host.url,
            input_hash: self.current.hash.clone(),
            started_ms,
            finished_ms: answered_ms.unwrap_or_else(|| self.run.elapsed_ms()),
            busy_ms: busy.as_secs_f64() * 1e3,
            wait_ms,
            overhead_ms,
            failed,
            moved: moved.map(|m| m.record.clone()),
        };
        let took = Duration::from_secs_f64((ran.finished_ms - ran.started_ms).max(0.0) / 1e3);
        self.registry.metrics.step(kind, took);
        let index = self.run.push_step(ran.record(&answer));
        Ok((index, result))
    }
}

/// What a host is asked to run for `task`, from `plugin` if one is named.
pub(super) fn run_request(task: &Task, plugin: Option<&str>) -> RunRequest {
    RunRequest {
        service: task.service.clone(),
        params: task.params.clone(),
        plugin: plugin.map(str::to_owned),
    }
}

impl Executor {
    /// The result type of the check `service` of plugin `digest`, as declared by `host` or,
    /// for a plugin it fetched (a task moved to the data), by a host that offers that plugin:
    /// a description is the component's own, the same wherever it loads. A host answering a
    /// check nobody declares is not to be believed.
    fn declared_type(
        &self,
        host: &HostEntry,
        digest: &str,
        service: &str,
    ) -> Result<ValueType, Failure> {
        let declared = |h: &HostEntry| {
            let services = h.state().services;
            let entry = services.iter().find(|s| s.info.name == service && s.plugin == digest);
            entry.and_then(|s| s.info.result_type)
        };
        declared(host)
            .or_else(|| self.registry.hosts().iter().find_map(|h| declared(h)))
            .ok_or_else(|| {
                Failure::Suspect(format!(
                    "answered the check {service:?}, which no host declares for plugin {digest:.12}"
                ))
            })
    }
}
