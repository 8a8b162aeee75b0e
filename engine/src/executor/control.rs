//! The workflow's control flow: an active task list walked in order, IF choosing a branch
//! and WHILE repeating its body while its condition holds (up to `max-iterations`), and
//! the conditions themselves: a check's value compared with the condition's.

use std::collections::VecDeque;
use std::sync::Arc;

use meshflow_api::host::RunResult;
use serde_json::{Value as Json, json};

use super::Executor;
use super::error::{CompareError, ExecError};
use super::finish::Keeping;
use crate::registry::HostEntry;
use crate::workflow::{Condition, Step, Workflow};

/// An entry of the active task list: a step, and for a WHILE the rounds already done.
struct Active {
    step: Step,
    rounds: u32,
}

impl Executor {
    /// Walks the workflow from the current mesh, then records the result once it is held.
    pub(super) async fn execute(&mut self, workflow: &Workflow) -> Result<Keeping, ExecError> {
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
        self.settle_trust().await?;
        Ok(self.finish().await)
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

    /// Runs the condition's check (or takes its recorded outcome) and records whether the
    /// condition holds.
    async fn evaluate(&mut self, condition: &Condition) -> Result<bool, ExecError> {
        if let Some(step) = self.take_done(&condition.check, "check")? {
            return step.condition.ok_or(ExecError::NoRecordedOutcome(step.path));
        }
        let (index, result, host) = self.run_task(&condition.check, "check").await?;
        let input = self.step_input(index, &condition.check, &result);
        let (result, _) = self.vouch(&input, result, host).await?;
        let RunResult::Check(check) = result else {
            return Err(ExecError::NotACheck {
                path: condition.check.path.clone(),
                service: condition.check.service.clone(),
            });
        };
        let holds = compare(&check.value, condition).map_err(|source| ExecError::Condition {
            path: condition.check.path.clone(),
            source,
        })?;
        self.run.update_step("condition", index, |step| {
            step.condition = Some(holds);
            json!({"step": index, "condition": holds})
        });
        Ok(holds)
    }
}

/// Whether a check's value satisfies the condition.
fn compare(value: &Json, condition: &Condition) -> Result<bool, CompareError> {
    let ordering = match (value, &condition.value) {
        (Json::Number(a), Json::Number(b)) => {
            let (a, b) = (a.as_f64().unwrap_or(f64::NAN), b.as_f64().unwrap_or(f64::NAN));
            a.partial_cmp(&b).ok_or(CompareError::Unordered(a, b))?
        }
        (Json::Bool(a), Json::Bool(b)) => a.cmp(b),
        (Json::String(a), Json::String(b)) => a.cmp(b),
        (actual, expected) => {
            return Err(CompareError::Mismatch {
                actual: actual.clone(),
                expected: expected.clone(),
            });
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
        let mismatch = compare(&json!(true), &condition("==", json!(1))).unwrap_err().to_string();
        assert_eq!(mismatch, "the check returned true, which cannot be compared with 1");
    }
}
