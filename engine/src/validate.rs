//! Checking a workflow against the catalogue before anything runs: every service exists,
//! filters run as steps and checks as conditions, parameters have the declared types and
//! ranges, and each condition compares with a value of the check's result type.

use meshflow_api::params::from_json as params_from_json;
use meshflow_api::params::{ServiceInfo, ServiceKind, ValueType};
use serde_json::Value as Json;

use crate::workflow::{Condition, Step, Task, Workflow, WorkflowError};

/// Validates `workflow`; `find` looks a service up in the catalogue.
pub fn validate(
    workflow: &Workflow,
    find: &dyn Fn(&str) -> Option<ServiceInfo>,
) -> Result<(), WorkflowError> {
    validate_steps(&workflow.steps, find)
}

fn validate_steps(
    steps: &[Step],
    find: &dyn Fn(&str) -> Option<ServiceInfo>,
) -> Result<(), WorkflowError> {
    for step in steps {
        match step {
            Step::Run(task) => {
                validate_task(task, ServiceKind::Filter, find)?;
            }
            Step::If { condition, then, otherwise, .. } => {
                validate_condition(condition, find)?;
                validate_steps(then, find)?;
                validate_steps(otherwise, find)?;
            }
            Step::While { condition, body, .. } => {
                validate_condition(condition, find)?;
                validate_steps(body, find)?;
            }
        }
    }
    Ok(())
}

fn validate_task(
    task: &Task,
    kind: ServiceKind,
    find: &dyn Fn(&str) -> Option<ServiceInfo>,
) -> Result<ServiceInfo, WorkflowError> {
    let info = find(&task.service).ok_or_else(|| {
        WorkflowError::new(&task.path, format!("unknown service \"{}\"", task.service))
    })?;
    if info.kind != kind {
        let (is, wanted) = match kind {
            ServiceKind::Filter => ("a check", "as a step (use it in an IF or WHILE condition)"),
            ServiceKind::Check => ("a filter", "in a condition (only checks return values)"),
        };
        return Err(WorkflowError::new(
            &task.path,
            format!("\"{}\" is {is} and cannot be used {wanted}", task.service),
        ));
    }
    params_from_json(&info, &task.params)
        .map_err(|e| WorkflowError::new(format!("{}.params", task.path), e.to_string()))?;
    Ok(info)
}

fn validate_condition(
    condition: &Condition,
    find: &dyn Fn(&str) -> Option<ServiceInfo>,
) -> Result<(), WorkflowError> {
    let info = validate_task(&condition.check, ServiceKind::Check, find)?;
    let path = condition.check.path.trim_end_matches(".check");
    let result_type = info.result_type.unwrap_or(ValueType::Text);
    let type_name = value_type_name(result_type);
    if !json_fits(result_type, &condition.value) {
        return Err(WorkflowError::new(
            format!("{path}.value"),
            format!(
                "\"{}\" returns {type_name}, not {}",
                info.name,
                json_type_name(&condition.value)
            ),
        ));
    }
    let ordered = matches!(result_type, ValueType::Integer | ValueType::Real);
    if !ordered && !condition.op.is_equality() {
        return Err(WorkflowError::new(
            format!("{path}.op"),
            format!("\"{}\" returns {type_name}: compare it with == or !=", info.name),
        ));
    }
    Ok(())
}

/// Whether a JSON value is a value of type `ty` as the APIs carry it.
pub fn json_fits(ty: ValueType, value: &Json) -> bool {
    match ty {
        ValueType::Integer => value.is_i64(),
        ValueType::Real => value.is_number(),
        ValueType::Boolean => value.is_boolean(),
        ValueType::Text => value.is_string(),
    }
}

pub fn value_type_name(ty: ValueType) -> &'static str {
    match ty {
        ValueType::Boolean => "a boolean",
        ValueType::Integer => "an integer",
        ValueType::Real => "a real number",
        ValueType::Text => "text",
    }
}

pub fn json_type_name(value: &Json) -> &'static str {
    match value {
        Json::Null => "null",
        Json::Bool(_) => "a boolean",
        Json::Number(n) if n.is_i64() || n.is_u64() => "an integer",
        Json::Number(_) => "a real number",
        Json::String(_) => "text",
        Json::Array(_) => "a list",
        Json::Object(_) => "an object",
    }
}

#[cfg(test)]
mod tests {
    use meshflow_api::params::{ParamInfo, Value};
    use serde_json::json;

    use super::*;

    fn catalogue(name: &str) -> Option<ServiceInfo> {
        let iterations = ParamInfo {
            name: "iterations".into(),
            doc: String::new(),
            ty: ValueType::Integer,
            default: Value::Integer(1),
            min: Some(0.0),
            max: Some(100.0),
            choices: vec![],
        };
        let (kind, params, result_type) = match name {
            "smooth" => (ServiceKind::Filter, vec![iterations], None),
            "is-manifold" => (ServiceKind::Check, vec![], Some(ValueType::Boolean)),
            "instability" => (ServiceKind::Check, vec![], Some(ValueType::Real)),
            _ => return None,
        };
        Some(ServiceInfo { name: name.into(), kind, doc: String::new(), params, result_type })
    }

    fn check(workflow: serde_json::Value) -> Result<(), String> {
        let workflow = Workflow::from_json(&workflow).map_err(|e| e.to_string())?;
        validate(&workflow, &catalogue).map_err(|e| e.to_string())
    }

    #[test]
    fn a_valid_workflow_passes() {
        check(json!([
            {"run": "smooth", "params": {"iterations": 3}},
            {"while": {"check": "instability", "op": ">", "value": 4}, "do": [{"run": "smooth"}]},
            {"if": {"check": "is-manifold", "op": "==", "value": true}, "then": [{"run": "smooth"}]}
        ]))
        .unwrap();
    }

    #[test]
    fn errors_name_the_step_and_the_reason() {
        let error = |w| check(w).unwrap_err();
        assert_eq!(
            error(json!([{"run": "smooth"}, {"run": "sharpen"}])),
            "steps[1]: unknown service \"sharpen\""
        );
        assert!(
            error(json!([{"run": "is-manifold"}]))
                .starts_with("steps[0]: \"is-manifold\" is a check and cannot be used as a step")
        );
        assert!(
            error(json!([{"if": {"check": "smooth", "op": "==", "value": 1}}]))
                .starts_with("steps[0].if.check: \"smooth\" is a filter")
        );
        let wrong_type = error(json!([{"run": "smooth", "params": {"iterations": "many"}}]));
        assert!(wrong_type.starts_with("steps[0].params: "), "{wrong_type}");
        assert!(wrong_type.contains("iterations"), "{wrong_type}");
        assert_eq!(
            error(json!([{"while": {"check": "is-manifold", "op": "==", "value": 1}, "do": []}])),
            "steps[0].while.value: \"is-manifold\" returns a boolean, not an integer"
        );
        assert_eq!(
            error(json!([{"while": {"check": "is-manifold", "op": "<", "value": true}, "do": []}])),
            "steps[0].while.op: \"is-manifold\" returns a boolean: compare it with == or !="
        );
    }
}
