//! Any bytes as a workflow: whatever parses as JSON goes to `Workflow::from_json`, which
//! must answer with a workflow or a `WorkflowError` naming a place, never panic; a parsed
//! workflow lists its tasks with unique paths.
#![no_main]

use meshflow_engine::workflow::Workflow;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let Ok(json) = serde_json::from_slice::<serde_json::Value>(data) else { return };
    if let Ok(workflow) = Workflow::from_json(&json) {
        let mut paths: Vec<String> = workflow.tasks().into_iter().map(|t| t.path.clone()).collect();
        let count = paths.len();
        paths.sort();
        paths.dedup();
        assert_eq!(paths.len(), count, "two tasks share a path");
    }
});
