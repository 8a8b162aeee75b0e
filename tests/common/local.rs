//! The reference the distributed runs are held to: the same workflow interpreted in this
//! process, each service run by the local runtime in sequence, IF and WHILE decided on the
//! local checks' values.

use std::cmp::Ordering;
use std::path::Path;

use meshflow_codec::quantize::{self, Grid};
use meshflow_engine::workflow::{Condition, Step, Task, Workflow};
use meshflow_mesh::MeshData;
use meshflow_params::{from_json as params_from_json, value_json};
use meshflow_runtime::{Catalog, Runtime};
use meshflow_runtime::{Limits, RunOutput};
use serde_json::Value as Json;

/// What a local run did: every task in execution order with its outcome (a filter's output
/// hash, a check's value), the final mesh, and how many WHILEs hit their cap.
pub struct Trace {
    pub mesh: MeshData,
    pub steps: Vec<(String, Json)>,
    pub capped_whiles: usize,
    /// A quantised workflow's grid.
    pub grid: Option<Grid>,
}

impl Trace {
    pub fn hash(&self) -> String {
        self.mesh.content_hash().to_hex()
    }

    /// How many times the task at `path` ran.
    pub fn count(&self, path: &str) -> usize {
        self.steps.iter().filter(|(p, _)| p == path).count()
    }
}

pub struct Local {
    runtime: Runtime,
    catalog: Catalog,
}

impl Local {
    /// Every built-in plugin, compiled components cached in `cache`.
    pub fn new(cache: &Path) -> Self {
        let runtime = Runtime::new(Limits::default(), Some(cache)).expect("a runtime");
        let mut catalog = Catalog::new();
        for builtin in meshflow_builtin_plugins::PLUGINS {
            catalog.add(runtime.load(builtin.wasm).expect("a built-in plugin loads"));
        }
        Self { runtime, catalog }
    }

    pub fn run(&self, workflow: &Workflow, mut input: MeshData) -> Trace {
        // A quantised workflow: the input on its grid, every step's result snapped back.
        let grid = workflow.quantize.map(|bits| quantize::quantize(&mut input, bits).unwrap());
        let mut trace = Trace { mesh: input, steps: Vec::new(), capped_whiles: 0, grid };
        self.steps(&workflow.steps, &mut trace);
        trace
    }

    /// A check's value on `mesh`.
    pub fn check(&self, service: &str, mesh: &MeshData) -> Json {
        let task = Task {
            path: "check".into(),
            service: service.into(),
            params: Default::default(),
            plugin: None,
        };
        value_json(&self.service(&task, mesh).value.expect("a check returns a value"))
    }

    fn steps(&self, steps: &[Step], trace: &mut Trace) {
        for step in steps {
            match step {
                Step::Run(task) => {
                    let output = self.service(task, &trace.mesh);
                    let result = output.mesh.expect("a filter returns a mesh");
                    trace.mesh = match &trace.grid {
                        Some(grid) => {
                            quantize::snap_step(grid, &trace.mesh, result, output.log)
                                .expect("the step snaps onto the grid")
                                .0
                        }
                        None => result,
                    };
                    trace.steps.push((task.path.clone(), Json::from(trace.hash())));
                }
                Step::If { condition, then, otherwise, .. } => {
                    let branch = if self.holds(condition, trace) { then } else { otherwise };
                    self.steps(branch, trace);
                }
                Step::While { condition, body, max_iterations, .. } => {
                    let mut rounds = 0;
                    while self.holds(condition, trace) {
                        if rounds == *max_iterations {
                            trace.capped_whiles += 1;
                            break;
                        }
                        self.steps(body, trace);
                        rounds += 1;
                    }
                }
            }
        }
    }

    fn holds(&self, condition: &Condition, trace: &mut Trace) -> bool {
        let value = value_json(
            &self.service(&condition.check, &trace.mesh).value.expect("a check returns a value"),
        );
        trace.steps.push((condition.check.path.clone(), value.clone()));
        condition.op.holds(compare(&value, &condition.value))
    }

    fn service(&self, task: &Task, mesh: &MeshData) -> RunOutput {
        let (plugin, info) = self.catalog.find(&task.service).expect("a built-in service");
        let params = params_from_json(info, &task.params).expect("valid parameters");
        self.runtime.run(plugin, &task.service, mesh.clone(), &params).expect("the service runs")
    }
}

/// How a check's value compares with a condition's: numbers as reals, booleans and text as
/// themselves.
fn compare(actual: &Json, expected: &Json) -> Ordering {
    match (actual, expected) {
        (Json::Number(a), Json::Number(b)) => {
            a.as_f64().unwrap().partial_cmp(&b.as_f64().unwrap()).expect("comparable numbers")
        }
        (Json::Bool(a), Json::Bool(b)) => a.cmp(b),
        (Json::String(a), Json::String(b)) => a.cmp(b),
        _ => panic!("cannot compare {actual} with {expected}"),
    }
}
