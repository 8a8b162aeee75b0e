//! Exact re-runs: a run's workflow again with every task pinned to the plugin digest and
//! the resolved parameters its record holds, and the comparison of a re-run with the
//! record, step by step.

use serde_json::{Map, Value as Json};

use crate::record::{Comparison, Divergence, RunRecord, StepRecord};

/// Why a record cannot be re-run.
#[derive(Debug, thiserror::Error)]
pub enum RerunError {
    #[error("the record holds no workflow (written by an engine before re-runs existed)")]
    NoWorkflow,
    #[error("the record's workflow is not a list of steps")]
    BadWorkflow,
}

/// The recorded workflow with every task that ran given the parameters it ran with
/// (defaults filled) and, when `pinned`, the plugin digest that ran it. Tasks that never
/// ran (a branch not taken) stay as written.
pub fn rerun_workflow(record: &RunRecord, pinned: bool) -> Result<Json, RerunError> {
    let mut workflow = match &record.workflow {
        Json::Null => return Err(RerunError::NoWorkflow),
        Json::Array(steps) => {
            Json::Object(Map::from_iter([("steps".into(), steps.clone().into())]))
        }
        other => other.clone(),
    };
    let object = workflow.as_object_mut().ok_or(RerunError::BadWorkflow)?;
    // The re-run names its input itself.
    object.remove("input");
    let steps =
        object.get_mut("steps").and_then(Json::as_array_mut).ok_or(RerunError::BadWorkflow)?;
    pin_steps(steps, "steps", &record.steps, pinned);
    Ok(workflow)
}

/// Walks the JSON steps naming each task as `workflow.rs` does (`steps[1].do[0]`,
/// `steps[2].if.check`).
fn pin_steps(steps: &mut [Json], path: &str, ran: &[StepRecord], pinned: bool) {
    for (i, step) in steps.iter_mut().enumerate() {
        let path = format!("{path}[{i}]");
        let Some(object) = step.as_object_mut() else { continue };
        if object.contains_key("run") {
            pin_task(object, &path, ran, pinned);
        }
        for (key, branch) in [("if", "then"), ("if", "else"), ("while", "do")] {
            if let Some(condition) = object.get_mut(key).and_then(Json::as_object_mut) {
                pin_task(condition, &format!("{path}.{key}.check"), ran, pinned);
            }
            if object.contains_key(key)
                && let Some(body) = object.get_mut(branch).and_then(Json::as_array_mut)
            {
                pin_steps(body, &format!("{path}.{branch}"), ran, pinned);
            }
        }
    }
}

fn pin_task(task: &mut Map<String, Json>, path: &str, ran: &[StepRecord], pinned: bool) {
    let Some(step) = ran.iter().find(|s| s.path == path) else { return };
    if !step.resolved_params.is_empty() {
        task.insert("params".into(), Json::Object(step.resolved_params.clone()));
    }
    if pinned && !step.plugin.is_empty() {
        task.insert("plugin".into(), step.plugin.clone().into());
    }
}

/// Compares a re-run with the recorded run: the input's hash, then step by step (each
/// task's path, a filter's output hash, a check's value), then the result.
pub fn compare(recorded: &RunRecord, rerun: &RunRecord) -> Comparison {
    let hash = |r: &RunRecord| r.input.as_ref().map(|i| i.hash.clone());
    let same_input = hash(recorded).is_some() && hash(recorded) == hash(rerun);
    let divergence = first_divergence(recorded, rerun, same_input);
    Comparison {
        identical: divergence.is_none(),
        recorded_run: recorded.id.clone(),
        rerun: rerun.id.clone(),
        same_input,
        divergence,
    }
}

fn first_divergence(
    recorded: &RunRecord,
    rerun: &RunRecord,
    same_input: bool,
) -> Option<Divergence> {
    let at = |index: Option<usize>, path: &str, service: Option<&str>, message: String| {
        Some(Divergence {
            index,
            path: path.to_owned(),
            service: service.map(str::to_owned),
            message,
        })
    };
    if !same_input {
        let hash = |r: &RunRecord| r.input.as_ref().map_or("none".into(), |i| i.hash.clone());
        let message =
            format!("the input is mesh {}, the recorded input was {}", hash(rerun), hash(recorded));
        return at(None, "input", None, message);
    }
    let count = recorded.steps.len().max(rerun.steps.len());
    for index in 0..count {
        match (recorded.steps.get(index), rerun.steps.get(index)) {
            (Some(old), Some(new)) => {
                if let Some(message) = step_difference(old, new) {
                    return at(Some(index), &old.path, Some(&old.service), message);
                }
            }
            (Some(old), None) => {
                let why = rerun.error.as_deref().unwrap_or("the re-run ended before it");
                let message = format!("the re-run has no step {index}: {why}");
                return at(Some(index), &old.path, Some(&old.service), message);
            }
            (None, Some(new)) => {
                let message =
                    format!("the re-run made step {index}, the recorded run ended before");
                return at(Some(index), &new.path, Some(&new.service), message);
            }
            (None, None) => unreachable!("index below both lengths' maximum"),
        }
    }
    let result = |r: &RunRecord| r.result.as_ref().map(|r| r.hash.clone());
    if result(recorded) != result(rerun) {
        let show = |hash: Option<String>| hash.unwrap_or_else(|| "no result".into());
        let message =
            format!("result {}, recorded {}", show(result(rerun)), show(result(recorded)));
        return at(None, "result", None, message);
    }
    None
}

fn step_difference(old: &StepRecord, new: &StepRecord) -> Option<String> {
    let plugins = || {
        if old.plugin == new.plugin {
            format!("plugin {}", old.plugin)
        } else {
            format!("plugin {} (recorded {})", new.plugin, old.plugin)
        }
    };
    if old.path != new.path {
        return Some(format!(
            "the re-run ran {} ({}) where the record has this step",
            new.path, new.service
        ));
    }
    if old.output_hash != new.output_hash {
        let show = |h: &Option<String>| h.clone().unwrap_or_else(|| "none".into());
        return Some(format!(
            "output mesh {}, recorded {}; {}",
            show(&new.output_hash),
            show(&old.output_hash),
            plugins()
        ));
    }
    if old.value != new.value {
        let show = |v: &Option<Json>| v.as_ref().map_or("none".into(), Json::to_string);
        return Some(format!(
            "value {}, recorded {}; {}",
            show(&new.value),
            show(&old.value),
            plugins()
        ));
    }
    None
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;
    use crate::record::{InputRecord, ResultRecord, Status, Transfer};
    use crate::workflow::Workflow;

    fn step(index: usize, path: &str, service: &str, output: &str) -> StepRecord {
        serde_json::from_value(json!({
            "index": index, "path": path, "kind": "filter", "service": service,
            "host": "http://h", "plugin": format!("{index:064}"), "params": {},
            "resolved_params": {"iterations": index + 1, "weights": "uniform"},
            "started_ms": 0.0, "finished_ms": 1.0, "compute_ms": 1.0, "wait_ms": 0.0,
            "overhead_ms": 0.0, "input_hash": "i", "output_hash": output, "vertices": 3,
            "triangles": 1, "edits": 1, "correction_bytes": 10, "full_bytes": null,
            "value": null, "condition": null, "report": "", "failed_hosts": [], "transfers": []
        }))
        .unwrap()
    }

    fn record(id: &str, outputs: &[(&str, &str)]) -> RunRecord {
        let mut record = RunRecord::new(id.into(), Transfer::Auto);
        record.status = Status::Completed;
        record.workflow = json!({"input": "http://old/in.ply", "steps": [
            {"run": "smooth"},
            {"while": {"check": "holes", "op": ">", "value": 0}, "do": [{"run": "fill"}]},
            {"if": {"check": "ok", "op": "==", "value": true}, "then": [{"run": "never"}]}
        ]});
        record.input = Some(InputRecord {
            url: "u".into(),
            hash: "in".into(),
            vertices: 3,
            triangles: 1,
            grid: None,
            not_kept: Vec::new(),
            attributes: Vec::new(),
        });
        record.steps = outputs
            .iter()
            .enumerate()
            .map(|(i, (path, output))| step(i, path, "svc", output))
            .collect();
        let last = outputs.last().map(|(_, o)| o.to_string()).unwrap_or_default();
        record.result = Some(ResultRecord {
            url: "r".into(),
            hash: last,
            bytes: Some(1),
            vertices: 3,
            triangles: 1,
            copies: Vec::new(),
        });
        record
    }

    #[test]
    fn a_rerun_workflow_pins_every_task_that_ran_with_its_resolved_parameters() {
        let recorded = record(
            "r-1",
            &[("steps[0]", "a"), ("steps[1].while.check", "a"), ("steps[1].do[0]", "b")],
        );
        let workflow = rerun_workflow(&recorded, true).unwrap();
        assert_eq!(workflow.get("input"), None);
        let steps = &workflow["steps"];
        assert_eq!(steps[0]["plugin"], json!(format!("{:064}", 0)));
        assert_eq!(steps[0]["params"], json!({"iterations": 1, "weights": "uniform"}));
        assert_eq!(steps[1]["while"]["plugin"], json!(format!("{:064}", 1)));
        assert_eq!(steps[1]["do"][0]["plugin"], json!(format!("{:064}", 2)));
        // The branch never taken stays as written.
        assert_eq!(steps[2]["then"][0], json!({"run": "never"}));
        assert_eq!(steps[2]["if"].get("plugin"), None);
        // It is a workflow the engine reads.
        let parsed = Workflow::from_json(&workflow).unwrap();
        assert_eq!(parsed.tasks()[0].plugin.as_deref(), Some(format!("{:064}", 0).as_str()));

        let unpinned = rerun_workflow(&recorded, false).unwrap();
        assert_eq!(unpinned["steps"][0].get("plugin"), None);
        assert_eq!(unpinned["steps"][0]["params"]["iterations"], json!(1));

        let mut old = recorded.clone();
        old.workflow = Json::Null;
        assert!(matches!(rerun_workflow(&old, true), Err(RerunError::NoWorkflow)));
    }

    #[test]
    fn the_comparison_names_the_first_step_that_diverged() {
        let recorded =
            record("r-1", &[("steps[0]", "a"), ("steps[1].do[0]", "b"), ("steps[2]", "c")]);
        let same = compare(
            &recorded,
            &record("r-2", &[("steps[0]", "a"), ("steps[1].do[0]", "b"), ("steps[2]", "c")]),
        );
        assert!(same.identical && same.same_input && same.divergence.is_none());

        let changed =
            record("r-3", &[("steps[0]", "a"), ("steps[1].do[0]", "x"), ("steps[2]", "y")]);
        let verdict = compare(&recorded, &changed);
        assert!(!verdict.identical);
        let divergence = verdict.divergence.unwrap();
        assert_eq!((divergence.index, divergence.path.as_str()), (Some(1), "steps[1].do[0]"));
        assert!(
            divergence.message.starts_with("output mesh x, recorded b"),
            "{}",
            divergence.message
        );

        let mut short = record("r-4", &[("steps[0]", "a")]);
        short.error = Some("steps[1].do[0]: no host".into());
        let divergence = compare(&recorded, &short).divergence.unwrap();
        assert_eq!(divergence.index, Some(1));
        assert!(divergence.message.contains("no host"), "{}", divergence.message);

        let mut other_input = changed.clone();
        other_input.input.as_mut().unwrap().hash = "other".into();
        let verdict = compare(&recorded, &other_input);
        assert!(!verdict.same_input);
        assert_eq!(verdict.divergence.unwrap().path, "input");
    }
}
