//! Resuming a run after an engine restart: its recorded steps are taken as done, in the
//! workflow's order, and the current mesh is restored from the record (the input, then
//! each recorded filter's output, held by its producer and the hosts that took it).

use std::collections::VecDeque;

use serde_json::json;

use super::Executor;
use super::broadcast::Loaded;
use super::current::Current;
use super::error::ExecError;
use crate::record::{RunRecord, StepRecord};
use crate::run::Run;
use crate::workflow::Task;

/// The steps of a stored record that count as done: all but a trailing check whose
/// condition was not yet recorded (it runs again); the record is cut to them.
pub(super) fn recorded_steps(run: &Run) -> VecDeque<StepRecord> {
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

/// Nothing finished before the restart: the record starts over (keeping the workflow, the
/// run it re-runs and its user).
pub(super) fn start_over(run: &Run) {
    run.update("restart", |r| {
        let fresh = RunRecord::new(r.id.clone(), r.transfer);
        let (workflow, rerun_of) = (std::mem::take(&mut r.workflow), r.rerun_of.take());
        *r = RunRecord { workflow, rerun_of, user: r.user.take(), ..fresh };
        json!(null)
    });
}

/// A resumed run starts from the input as recorded; no host holds it yet.
pub(super) fn restore_input(run: &Run) -> Result<Loaded, ExecError> {
    let input = run.record().input.ok_or(ExecError::NoRecordedInput)?;
    Ok(Loaded { current: Current::recorded(&run.input, input), replicas: Vec::new() })
}

impl Executor {
    /// The next step done before a restart, if any is left: it must be `task`.
    pub(super) fn take_done(
        &mut self,
        task: &Task,
        kind: &str,
    ) -> Result<Option<StepRecord>, ExecError> {
        let Some(step) = self.done.pop_front() else { return Ok(None) };
        if step.path != task.path || step.kind != kind {
            return Err(ExecError::RecordMismatch {
                recorded_kind: step.kind,
                recorded_path: step.path,
                kind: kind.to_owned(),
                path: task.path.clone(),
            });
        }
        Ok(Some(step))
    }

    /// A filter done before a restart: its output is the current mesh, held by its
    /// producer and by every host that took the update.
    pub(super) fn restore_filter(
        &mut self,
        task: &Task,
        step: &StepRecord,
    ) -> Result<(), ExecError> {
        let hash =
            step.output_hash.clone().ok_or_else(|| ExecError::NoOutputHash(step.path.clone()))?;
        self.history.push((task.clone(), hash.clone()));
        self.holders = std::iter::once(step.host.clone())
            .chain(step.transfers.iter().filter(|t| t.error.is_none()).map(|t| t.host.clone()))
            .collect();
        self.current.restore(step, hash);
        Ok(())
    }
}
