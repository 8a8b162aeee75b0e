//! The run's first task, started on its host as soon as that host holds the input, while
//! the broadcast still brings the input to the others (DESIGN §5: nothing waits that could
//! run beside it). Each host loads over its own link, so the first task's host is often not
//! the last to be done: at 5 Mbit/s the three loads of a 1.3 MB scan ended up to 90 ms
//! apart, and the first task waited for the last of them.

use std::sync::Arc;
use std::time::Duration;

use meshflow_api::ClientError;
use meshflow_api::host::{RunRequest, RunResult};
use tokio::task::JoinHandle;

use super::broadcast::InputHolders;
use super::busy;
use super::replica::Replica;
use super::task::run_request;
use crate::plan::Plan;
use crate::registry::HostEntry;
use crate::run::Run;
use crate::workflow::{Task, Workflow};

/// The first task's run, under way or done.
pub(super) struct EarlyStart {
    path: String,
    host: Arc<HostEntry>,
    /// `None` when its host never held the input (its load failed: the task runs where the
    /// plan moves it, as any other).
    started: JoinHandle<Option<Started>>,
}

/// The first task as its host ran it.
pub(super) struct Started {
    pub session: String,
    pub started_ms: f64,
    /// When the answer came (the run's clock), which may be before anyone took it.
    pub answered_ms: f64,
    pub request: RunRequest,
    /// The answer, and how long the host stayed busy before it took the task.
    pub outcome: (Result<RunResult, ClientError>, Duration),
}

impl EarlyStart {
    /// Starts `workflow`'s first task (its first step, or the condition of its first IF or
    /// WHILE) on its planned host once `holders` says that host holds the input.
    pub fn start(
        run: &Arc<Run>,
        workflow: &Workflow,
        plan: &Plan,
        holders: &InputHolders,
    ) -> Option<Self> {
        let task = *workflow.tasks().first()?;
        let host = plan.host(&task.path).clone();
        let request = run_request(task, plan.pin(&task.path));
        let held = holders.held_by(&host.url);
        let (run, runner) = (run.clone(), host.clone());
        let started = tokio::spawn(async move {
            let session = held.await?.session?;
            let started_ms = run.elapsed_ms();
            let _in_flight = runner.assign();
            let outcome = busy::run_when_free(&runner.client, &session, &request).await;
            let answered_ms = run.elapsed_ms();
            Some(Started { session, started_ms, answered_ms, request, outcome })
        });
        Some(Self { path: task.path.clone(), host, started })
    }

    /// The early run of `task` on `host` in its session `session`, if this was it. Any
    /// other early run is over once this returns: a filter it ran moved its host's session
    /// on from the input, so `replicas` forget what that session holds.
    pub async fn take(
        early: &mut Option<Self>,
        (task, host, session): (&Task, &Arc<HostEntry>, &str),
        replicas: &mut [Replica],
    ) -> Option<Started> {
        let Self { path, host: ran_on, started } = early.take()?;
        let started = started.await.ok().flatten()?;
        let ours = path == task.path && Arc::ptr_eq(&ran_on, host) && started.session == session;
        if ours {
            return Some(started);
        }
        if let Ok(RunResult::Filter(_)) = &started.outcome.0
            && let Some(replica) = replicas.iter_mut().find(|r| Arc::ptr_eq(&r.host, &ran_on))
        {
            replica.forget();
        }
        None
    }
}
