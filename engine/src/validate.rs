//! Checking a workflow against the catalogue before anything runs: every service exists,
//! filters run as steps and checks as conditions, parameters have the declared types and
//! ranges, each condition compares with a value of the check's result type, and every
//! pinned plugin is offered (its digest prefix made whole).

use meshflow_api::params::from_json as params_from_json;
use meshflow_api::params::{ServiceInfo, ServiceKind, ValueType, did_you_mean};
use serde_json::Value as Json;

use crate::workflow::{Condition, Step, Task, Workflow, WorkflowError};

/// What validation asks of the catalogue (the registry's, or a test's).
pub trait Catalogue {
    /// The description of `service`; from the plugin whose digest starts with `pin`, if
    /// given.
    fn describe(&self, service: &str, pin: Option<&str>) -> Option<ServiceInfo>;
    /// The digests of every plugin offering `service`.
    fn digests(&self, service: &str) -> Vec<String>;
    /// Every service on offer, for did-you-mean suggestions.
    fn names(&self) -> Vec<String>;
}

/// Validates `workflow` and replaces each pinned digest prefix with the whole digest.
pub fn validate(workflow: &mut Workflow, catalogue: &dyn Catalogue) -> Result<(), WorkflowError> {
    for task in workflow.tasks_mut() {
        resolve_pin(task, catalogue)?;
    }
    validate_steps(&workflow.steps, catalogue)
}

/// A pin must name exactly one plugin that offers the task's service.
fn resolve_pin(task: &mut Task, catalogue: &dyn Catalogue) -> Result<(), WorkflowError> {
    let Some(pin) = &task.plugin else { return Ok(()) };
    let digests = catalogue.digests(&task.service);
    if digests.is_empty() {
        // An unknown service: validate_task says so.
        return Ok(());
    }
    let matching: Vec<&String> = digests.iter().filter(|d| d.starts_with(pin.as_str())).collect();
    let path = format!("{}.plugin", task.path);
    match matching.as_slice() {
        [digest] => {
            task.plugin = Some((*digest).clone());
            Ok(())
        }
        [] => Err(WorkflowError::new(
            path,
            format!(
                "no host offers \"{}\" from plugin {pin}; plugins offering it: {}",
                task.service,
                digests.join(", ")
            ),
        )),
        _ => Err(WorkflowError::new(
            path,
            format!("{pin} is the start of several plugins' digests; give more digits"),
        )),
    }
}

fn validate_steps(steps: &[Step], catalogue: &dyn Catalogue) -> Result<(), WorkflowError> {
    for step in steps {
        match step {
            Step::Run(task) => {
                validate_task(task, ServiceKind::Filter, catalogue)?;
            }
            Step::If { condition, then, otherwise, .. } => {
                validate_condition(condition, catalogue)?;
                validate_steps(then, catalogue)?;
                validate_steps(otherwise, catalogue)?;
            }
            Step::While { condition, body, .. } => {
                validate_condition(condition, catalogue)?;
                validate_steps(body, catalogue)?;
            }
        }
    }
    Ok(())
}

fn validate_task(
    task: &Task,
    kind: ServiceKind,
    catalogue: &dyn Catalogue,
) -> Result<ServiceInfo, WorkflowError> {
    let info = catalogue.describe(&task.service, task.plugin.as_deref()).ok_or_else(|| {
        let names = catalogue.names();
        let hint = did_you_mean(&task.service, names.iter().map(String::as_str));
        let service = meshflow_api::params::clip(&task.service);
        WorkflowError::new(&task.path, format!("unknown service \"{service}\"{hint}"))
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
    catalogue: &dyn Catalogue,
) -> Result<(), WorkflowError> {
    let info = validate_task(&condition.check, ServiceKind::Check, catalogue)?;
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

    /// Two plugins offer "smooth"; the others come from one each.
    struct Test;

    const SMOOTH_V1: &str = "aaaaaaaaaaaa1111";
    const SMOOTH_V2: &str = "aaaaaaaaaaaa2222";

    impl Catalogue for Test {
        fn describe(&self, service: &str, pin: Option<&str>) -> Option<ServiceInfo> {
            let offered = self.digests(service);
            pin.is_none_or(|pin| offered.iter().any(|d| d.starts_with(pin)))
                .then(|| catalogue(service))?
        }
        fn digests(&self, service: &str) -> Vec<String> {
            match service {
                "smooth" => vec![SMOOTH_V1.into(), SMOOTH_V2.into()],
                _ if catalogue(service).is_some() => vec!["bbbbbbbbbbbbbbbb".into()],
                _ => vec![],
            }
        }
        fn names(&self) -> Vec<String> {
            ["smooth", "is-manifold", "instability"].map(String::from).to_vec()
        }
    }

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
        pinned(workflow).map(drop)
    }

    /// The validated workflow's pins, task by task.
    fn pinned(workflow: serde_json::Value) -> Result<Vec<Option<String>>, String> {
        let mut workflow = Workflow::from_json(&workflow).map_err(|e| e.to_string())?;
        validate(&mut workflow, &Test).map_err(|e| e.to_string())?;
        Ok(workflow.tasks().iter().map(|t| t.plugin.clone()).collect())
    }

    #[test]
    fn a_pin_names_one_plugin_offering_the_service_and_is_made_whole() {
        let pins = pinned(json!([
            {"run": "smooth", "plugin": "aaaaaaaaaaaa2"},
            {"if": {"check": "is-manifold", "op": "==", "value": true, "plugin": "bbbbbbbbbbbb"},
             "then": [{"run": "smooth"}]}
        ]))
        .unwrap();
        assert_eq!(pins, [Some(SMOOTH_V2.into()), Some("bbbbbbbbbbbbbbbb".into()), None]);
        let error = |w| check(w).unwrap_err();
        assert_eq!(
            error(json!([{"run": "smooth"}, {"run": "smooth", "plugin": "cccccccccccc"}])),
            format!(
                "steps[1].plugin: no host offers \"smooth\" from plugin cccccccccccc; \
                 plugins offering it: {SMOOTH_V1}, {SMOOTH_V2}"
            )
        );
        assert!(
            error(json!([{"run": "smooth", "plugin": "aaaaaaaaaaaa"}]))
                .starts_with("steps[0].plugin: aaaaaaaaaaaa is the start of several"),
        );
        // A digest that offers other services but not this one.
        assert!(
            error(json!([{"run": "smooth", "plugin": "bbbbbbbbbbbb"}]))
                .starts_with("steps[0].plugin: no host offers \"smooth\""),
        );
    }

    #[test]
    fn misspelt_services_and_parameters_get_a_suggestion() {
        assert_eq!(
            check(json!([{"run": "smoth"}])).unwrap_err(),
            "steps[0]: unknown service \"smoth\"; did you mean \"smooth\"?"
        );
        let error = check(json!([{"run": "smooth", "params": {"iteratons": 2}}])).unwrap_err();
        assert!(
            error.contains("unknown parameter `iteratons`; did you mean \"iterations\"?"),
            "{error}"
        );
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
