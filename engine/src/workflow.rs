//! The workflow language: a list of steps, each a service run, an IF or a WHILE over a check.
//!
//! Parsed by hand from JSON rather than with derived `Deserialize`, so that every error names
//! the path of the offending step (`steps[2].do[0]`), which serde's untagged enums cannot.

use serde::Serialize;
use serde_json::{Map, Value as Json};

use crate::limits::{MAX_ITERATIONS_CAP, MAX_NESTING, MAX_WORKFLOW_TASKS};

/// A WHILE without `max-iterations` stops after this many rounds.
pub const DEFAULT_MAX_ITERATIONS: u32 = 100;

#[derive(Debug, Clone, Serialize)]
pub struct Workflow {
    pub steps: Vec<Step>,
    /// The input mesh URL, when the workflow carries it.
    pub input: Option<String>,
    pub transfer: Transfer,
    /// Keep the mesh on a grid of at most `2^bits` cells per axis over the input's
    /// bounding box: the input is snapped at ingest, every step's result after it.
    pub quantize: Option<u32>,
    pub placement: Placement,
}

/// How hosts are chosen among those offering a service (a workflow's `"placement"`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Placement {
    /// The expected time to get the mesh there over the measured link plus the queue.
    #[default]
    Link,
    /// The least loaded (what the engine did before links were measured; for comparison).
    Load,
}

/// The grids a workflow may ask for, as `meshflow apply --quantize` takes them.
pub const QUANTIZE_BITS: std::ops::RangeInclusive<u64> = 1..=24;

#[derive(Debug, Clone, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Step {
    Run(Task),
    If { path: String, condition: Condition, then: Vec<Step>, otherwise: Vec<Step> },
    While { path: String, condition: Condition, body: Vec<Step>, max_iterations: u32 },
}

/// One run of a service; `path` names it in errors, records and the plan.
#[derive(Debug, Clone, Serialize)]
pub struct Task {
    pub path: String,
    pub service: String,
    pub params: Map<String, Json>,
    /// The plugin to run the service from: its SHA-256, or a unique prefix of at least
    /// [`MIN_PIN_DIGITS`] hex digits. Only hosts offering it are planned.
    pub plugin: Option<String>,
}

/// The shortest digest prefix a workflow may pin a plugin by: 48 bits, so a clash between
/// two plugins on one cluster is far-fetched (and refused as ambiguous if it happens).
pub const MIN_PIN_DIGITS: usize = 12;

#[derive(Debug, Clone, Serialize)]
pub struct Condition {
    /// The check, as a task at `<if or while path>.check`.
    pub check: Task,
    pub op: Comparison,
    pub value: Json,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Comparison {
    #[serde(rename = "<")]
    Less,
    #[serde(rename = "<=")]
    LessOrEqual,
    #[serde(rename = "==")]
    Equal,
    #[serde(rename = "!=")]
    NotEqual,
    #[serde(rename = ">=")]
    GreaterOrEqual,
    #[serde(rename = ">")]
    Greater,
}

pub use meshflow_api::engine::Transfer;

/// A workflow that does not parse or does not fit the catalogue: where and why.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{path}: {message}")]
pub struct WorkflowError {
    pub path: String,
    pub message: String,
}

impl WorkflowError {
    pub fn new(path: impl Into<String>, message: impl Into<String>) -> Self {
        Self { path: path.into(), message: message.into() }
    }
}

impl Comparison {
    fn parse(text: &str) -> Option<Self> {
        Some(match text {
            "<" => Self::Less,
            "<=" => Self::LessOrEqual,
            "==" => Self::Equal,
            "!=" => Self::NotEqual,
            ">=" => Self::GreaterOrEqual,
            ">" => Self::Greater,
            _ => return None,
        })
    }

    /// Whether `ordering` (of actual against expected) satisfies the comparison.
    pub fn holds(self, ordering: std::cmp::Ordering) -> bool {
        use std::cmp::Ordering::*;
        match self {
            Self::Less => ordering == Less,
            Self::LessOrEqual => ordering != Greater,
            Self::Equal => ordering == Equal,
            Self::NotEqual => ordering != Equal,
            Self::GreaterOrEqual => ordering != Less,
            Self::Greater => ordering == Greater,
        }
    }

    /// Equality tests are the only ones that make sense on booleans and text.
    pub fn is_equality(self) -> bool {
        matches!(self, Self::Equal | Self::NotEqual)
    }
}

impl Workflow {
    /// Parses a workflow: either `{"steps": [...], "input"?, "transfer"?}` or a bare list
    /// of steps.
    pub fn from_json(json: &Json) -> Result<Self, WorkflowError> {
        let (steps, object) = match json {
            Json::Array(steps) => (steps, None),
            Json::Object(object) => {
                let known = ["steps", "input", "transfer", "quantize", "placement"];
                known_keys(object, "workflow", &known)?;
                let steps = object
                    .get("steps")
                    .and_then(Json::as_array)
                    .ok_or_else(|| WorkflowError::new("workflow", "needs \"steps\": [...]"))?;
                (steps, Some(object))
            }
            _ => {
                return Err(WorkflowError::new("workflow", "must be an object or a list of steps"));
            }
        };
        let field = |name| object.and_then(|o| o.get(name));
        let input = match field("input") {
            None | Some(Json::Null) => None,
            Some(Json::String(url)) => Some(url.clone()),
            Some(_) => return Err(WorkflowError::new("input", "must be a URL string")),
        };
        let transfer = match field("transfer") {
            None => Transfer::default(),
            Some(value) => value.as_str().and_then(Transfer::parse).ok_or_else(|| {
                WorkflowError::new(
                    "transfer",
                    "must be \"auto\", \"correction\", \"replay\" or \"full\"",
                )
            })?,
        };
        let quantize = match field("quantize") {
            None | Some(Json::Null) => None,
            Some(value) => match value.as_u64().filter(|bits| QUANTIZE_BITS.contains(bits)) {
                Some(bits) => Some(bits as u32),
                None => {
                    return Err(WorkflowError::new(
                        "quantize",
                        "must be a number of bits per axis from 1 to 24",
                    ));
                }
            },
        };
        if steps.is_empty() {
            return Err(WorkflowError::new("steps", "a workflow needs at least one step"));
        }
        let placement = match field("placement").map(|v| v.as_str()) {
            None => Placement::default(),
            Some(Some("link")) => Placement::Link,
            Some(Some("load")) => Placement::Load,
            Some(_) => {
                return Err(WorkflowError::new("placement", "must be \"link\" or \"load\""));
            }
        };
        let steps = parse_steps(steps, "steps", 0)?;
        let workflow = Self { steps, input, transfer, quantize, placement };
        let tasks = workflow.tasks().len();
        if tasks > MAX_WORKFLOW_TASKS {
            return Err(WorkflowError::new(
                "steps",
                format!("{tasks} tasks; a workflow may have at most {MAX_WORKFLOW_TASKS}"),
            ));
        }
        Ok(workflow)
    }

    /// Every task of the workflow, IF and WHILE conditions and bodies included, in order.
    pub fn tasks(&self) -> Vec<&Task> {
        let mut tasks = Vec::new();
        collect_tasks(&self.steps, &mut tasks);
        tasks
    }

    /// Every task, in the same order as [`Workflow::tasks`], to change.
    pub fn tasks_mut(&mut self) -> Vec<&mut Task> {
        let mut tasks = Vec::new();
        collect_tasks_mut(&mut self.steps, &mut tasks);
        tasks
    }
}

fn collect_tasks_mut<'a>(steps: &'a mut [Step], out: &mut Vec<&'a mut Task>) {
    for step in steps {
        match step {
            Step::Run(task) => out.push(task),
            Step::If { condition, then, otherwise, .. } => {
                out.push(&mut condition.check);
                collect_tasks_mut(then, out);
                collect_tasks_mut(otherwise, out);
            }
            Step::While { condition, body, .. } => {
                out.push(&mut condition.check);
                collect_tasks_mut(body, out);
            }
        }
    }
}

fn collect_tasks<'a>(steps: &'a [Step], out: &mut Vec<&'a Task>) {
    for step in steps {
        match step {
            Step::Run(task) => out.push(task),
            Step::If { condition, then, otherwise, .. } => {
                out.push(&condition.check);
                collect_tasks(then, out);
                collect_tasks(otherwise, out);
            }
            Step::While { condition, body, .. } => {
                out.push(&condition.check);
                collect_tasks(body, out);
            }
        }
    }
}

/// Parses a list of steps nested `depth` IF / WHILE blocks deep.
fn parse_steps(steps: &[Json], path: &str, depth: usize) -> Result<Vec<Step>, WorkflowError> {
    if depth > MAX_NESTING {
        return Err(WorkflowError::new(
            path,
            format!("IF and WHILE blocks nest at most {MAX_NESTING} deep"),
        ));
    }
    // Checked before parsing, so a huge list costs no more than the cap's worth of work.
    if steps.len() > MAX_WORKFLOW_TASKS {
        return Err(WorkflowError::new(
            path,
            format!("{} steps; a workflow may have at most {MAX_WORKFLOW_TASKS}", steps.len()),
        ));
    }
    let parse = |(i, step)| parse_step(step, &format!("{path}[{i}]"), depth);
    steps.iter().enumerate().map(parse).collect()
}

fn parse_step(json: &Json, path: &str, depth: usize) -> Result<Step, WorkflowError> {
    let object = json.as_object().ok_or_else(|| WorkflowError::new(path, "a step is an object"))?;
    if object.contains_key("run") {
        known_keys(object, path, &["run", "params", "plugin"])?;
        Ok(Step::Run(parse_task(object, "run", path)?))
    } else if object.contains_key("if") {
        known_keys(object, path, &["if", "then", "else"])?;
        let branch = |key: &str| match object.get(key) {
            None => Ok(Vec::new()),
            Some(Json::Array(steps)) => parse_steps(steps, &format!("{path}.{key}"), depth + 1),
            Some(_) => Err(WorkflowError::new(format!("{path}.{key}"), "must be a list of steps")),
        };
        Ok(Step::If {
            path: path.to_owned(),
            condition: parse_condition(&object["if"], &format!("{path}.if"))?,
            then: branch("then")?,
            otherwise: branch("else")?,
        })
    } else if object.contains_key("while") {
        known_keys(object, path, &["while", "do", "max-iterations"])?;
        let body = match object.get("do") {
            Some(Json::Array(steps)) => parse_steps(steps, &format!("{path}.do"), depth + 1)?,
            _ => return Err(WorkflowError::new(path, "a WHILE needs \"do\": [steps]")),
        };
        let max_iterations = match object.get("max-iterations") {
            None => DEFAULT_MAX_ITERATIONS,
            Some(n) => {
                n.as_u64().filter(|&n| n <= u64::from(MAX_ITERATIONS_CAP)).ok_or_else(|| {
                    WorkflowError::new(
                        format!("{path}.max-iterations"),
                        format!("must be a whole number from 0 to {MAX_ITERATIONS_CAP}"),
                    )
                })? as u32
            }
        };
        Ok(Step::While {
            path: path.to_owned(),
            condition: parse_condition(&object["while"], &format!("{path}.while"))?,
            body,
            max_iterations,
        })
    } else {
        Err(WorkflowError::new(path, "a step is {\"run\": ...}, {\"if\": ...} or {\"while\": ...}"))
    }
}

fn parse_condition(json: &Json, path: &str) -> Result<Condition, WorkflowError> {
    let object = json.as_object().ok_or_else(|| {
        WorkflowError::new(path, "a condition is {\"check\", \"params\"?, \"op\", \"value\"}")
    })?;
    known_keys(object, path, &["check", "params", "op", "value", "plugin"])?;
    let op =
        object.get("op").and_then(Json::as_str).and_then(Comparison::parse).ok_or_else(|| {
            WorkflowError::new(format!("{path}.op"), "must be one of < <= == != >= >")
        })?;
    let value = object
        .get("value")
        .cloned()
        .ok_or_else(|| WorkflowError::new(path, "needs the \"value\" to compare with"))?;
    Ok(Condition { check: parse_task(object, "check", path)?, op, value })
}

fn parse_task(object: &Map<String, Json>, key: &str, path: &str) -> Result<Task, WorkflowError> {
    let service = object
        .get(key)
        .and_then(Json::as_str)
        .ok_or_else(|| WorkflowError::new(format!("{path}.{key}"), "must be a service name"))?;
    let params = match object.get("params") {
        None => Map::new(),
        Some(Json::Object(params)) => params.clone(),
        Some(_) => return Err(WorkflowError::new(format!("{path}.params"), "must be an object")),
    };
    let plugin = match object.get("plugin") {
        None => None,
        Some(Json::String(digest)) if is_pin(digest) => Some(digest.to_ascii_lowercase()),
        Some(_) => {
            return Err(WorkflowError::new(
                format!("{path}.plugin"),
                format!(
                    "must be a plugin's SHA-256 in hex, or a prefix of it of at least \
                     {MIN_PIN_DIGITS} digits"
                ),
            ));
        }
    };
    let path = if key == "check" { format!("{path}.check") } else { path.to_owned() };
    Ok(Task { path, service: service.to_owned(), params, plugin })
}

/// Whether `text` can name a plugin: hex digits, from [`MIN_PIN_DIGITS`] to a whole SHA-256.
fn is_pin(text: &str) -> bool {
    (MIN_PIN_DIGITS..=64).contains(&text.len()) && text.chars().all(|c| c.is_ascii_hexdigit())
}

fn known_keys(object: &Map<String, Json>, path: &str, known: &[&str]) -> Result<(), WorkflowError> {
    match object.keys().find(|k| !known.contains(&k.as_str())) {
        None => Ok(()),
        Some(key) => Err(WorkflowError::new(
            path,
            format!("unknown key \"{key}\" (expected {})", known.join(", ")),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn parses_runs_ifs_and_whiles_with_paths() {
        let workflow = Workflow::from_json(&json!({
            "steps": [
                {"run": "laplacian-smoothing", "params": {"iterations": 2}},
                {"if": {"check": "is-manifold", "op": "==", "value": true},
                 "then": [{"run": "fill-holes"}], "else": [{"run": "remove-degenerate-triangles"}]},
                {"while": {"check": "normal-instability", "op": ">", "value": 5.0},
                 "do": [{"run": "laplacian-smoothing"}], "max-iterations": 7}
            ],
            "transfer": "full"
        }))
        .unwrap();
        assert_eq!(workflow.transfer, Transfer::Full);
        let paths: Vec<_> = workflow.tasks().iter().map(|t| t.path.clone()).collect();
        assert_eq!(
            paths,
            [
                "steps[0]",
                "steps[1].if.check",
                "steps[1].then[0]",
                "steps[1].else[0]",
                "steps[2].while.check",
                "steps[2].do[0]"
            ]
        );
        let Step::While { max_iterations, condition, .. } = &workflow.steps[2] else { panic!() };
        assert_eq!((*max_iterations, condition.op), (7, Comparison::Greater));
    }

    #[test]
    fn errors_name_the_offending_step() {
        let error = |json| Workflow::from_json(&json).unwrap_err().to_string();
        assert_eq!(
            error(
                json!([{"run": "a"}, {"while": {"check": "c", "op": "~", "value": 1}, "do": []}])
            ),
            "steps[1].while.op: must be one of < <= == != >= >"
        );
        assert_eq!(
            error(
                json!({"steps": [{"if": {"check": "c", "op": "==", "value": 1}, "then": [{"runn": "x"}]}]})
            ),
            "steps[0].then[0]: a step is {\"run\": ...}, {\"if\": ...} or {\"while\": ...}"
        );
        assert_eq!(
            error(json!({"steps": [], "transfer": "fast"})),
            "transfer: must be \"auto\", \"correction\", \"replay\" or \"full\""
        );
        assert_eq!(
            error(json!([{"run": "a", "param": {}}])),
            "steps[0]: unknown key \"param\" (expected run, params, plugin)"
        );
        assert_eq!(
            error(
                json!([{"while": {"check": "c", "op": "<", "value": 1}, "do": [], "max-iterations": -1}])
            ),
            "steps[0].max-iterations: must be a whole number from 0 to 10000"
        );
        assert_eq!(
            error(
                json!([{"while": {"check": "c", "op": "<", "value": 1}, "do": [], "max-iterations": 1e9}])
            ),
            "steps[0].max-iterations: must be a whole number from 0 to 10000"
        );
        assert_eq!(error(json!({"steps": []})), "steps: a workflow needs at least one step");
    }

    #[test]
    fn workflows_are_bounded_in_size_and_nesting() {
        let error = |json| Workflow::from_json(&json).unwrap_err().to_string();
        let many: Vec<Json> = (0..=MAX_WORKFLOW_TASKS).map(|_| json!({"run": "s"})).collect();
        assert_eq!(error(json!(many)), "steps: 1001 steps; a workflow may have at most 1000");
        // 600 IFs of two tasks each: every list is short, the whole is too large.
        let pair = json!({"if": {"check": "c", "op": "<", "value": 1}, "then": [{"run": "s"}]});
        let pairs: Vec<Json> = (0..600).map(|_| pair.clone()).collect();
        assert_eq!(error(json!(pairs)), "steps: 1200 tasks; a workflow may have at most 1000");
        let mut nested = json!([{"run": "s"}]);
        for _ in 0..=MAX_NESTING {
            nested = json!([{"while": {"check": "c", "op": "<", "value": 1}, "do": nested}]);
        }
        assert!(error(nested).ends_with("IF and WHILE blocks nest at most 16 deep"));
    }

    #[test]
    fn steps_and_conditions_pin_plugins_by_digest_prefixes() {
        let digest = "AB".repeat(32);
        let workflow = Workflow::from_json(&json!([
            {"run": "smooth", "plugin": digest},
            {"while": {"check": "c", "op": "<", "value": 1, "plugin": "0123456789ab"},
             "do": [{"run": "s"}]}
        ]))
        .unwrap();
        let pins: Vec<_> = workflow.tasks().iter().map(|t| t.plugin.clone()).collect();
        assert_eq!(pins, [Some("ab".repeat(32)), Some("0123456789ab".into()), None]);
        let error = |json| Workflow::from_json(&json).unwrap_err().to_string();
        for bad in [json!("0123456789a"), json!("smoothing@1"), json!(7), json!("g".repeat(64))] {
            assert!(
                error(json!([{"run": "s", "plugin": bad}]))
                    .starts_with("steps[0].plugin: must be a plugin's SHA-256"),
                "{bad}"
            );
        }
    }

    #[test]
    fn transfer_quantize_and_placement_are_read_and_checked() {
        let workflow = Workflow::from_json(&json!({
            "steps": [{"run": "s"}], "transfer": "replay", "quantize": 16, "placement": "load"
        }))
        .unwrap();
        assert_eq!(
            (workflow.transfer, workflow.quantize, workflow.placement),
            (Transfer::Replay, Some(16), Placement::Load)
        );
        let defaults = Workflow::from_json(&json!([{"run": "s"}])).unwrap();
        assert_eq!((defaults.quantize, defaults.placement), (None, Placement::Link));
        let error = |extra: (&str, Json)| {
            let mut workflow = json!({"steps": [{"run": "s"}]});
            workflow[extra.0] = extra.1;
            Workflow::from_json(&workflow).unwrap_err().to_string()
        };
        for bad in [json!(0), json!(25), json!(-3), json!(12.5), json!("16")] {
            assert!(error(("quantize", bad.clone())).starts_with("quantize: "), "{bad}");
        }
        assert!(error(("placement", json!("fastest"))).starts_with("placement: "));
        assert!(error(("transfer", json!("teleport"))).contains("\"replay\""));
    }

    #[test]
    fn a_while_defaults_to_the_iteration_cap() {
        let workflow = Workflow::from_json(
            &json!([{"while": {"check": "c", "op": "<", "value": 1}, "do": [{"run": "s"}]}]),
        )
        .unwrap();
        let Step::While { max_iterations, .. } = &workflow.steps[0] else { panic!() };
        assert_eq!(*max_iterations, DEFAULT_MAX_ITERATIONS);
    }
}
