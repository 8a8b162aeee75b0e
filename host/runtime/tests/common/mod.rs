//! What the runtime's test files share: a runtime with default limits, a built-in plugin
//! loaded into it, and one service run on a mesh.
#![allow(dead_code)] // each test file uses what it needs

use meshflow_builtin_plugins::PLUGINS;
use meshflow_mesh::MeshData;
use meshflow_runtime::{Limits, Plugin, RunOutput, Runtime, Value};

pub fn runtime() -> Runtime {
    Runtime::new(Limits::default(), None).expect("a runtime")
}

pub fn builtin(runtime: &Runtime, name: &str) -> Plugin {
    let wasm = PLUGINS.iter().find(|p| p.name == name).expect("a built-in plugin").wasm;
    runtime.load(wasm).expect("built-in plugins load")
}

/// `service` of the built-in `plugin` on `mesh`; a refused run fails the test, naming it.
pub fn run(plugin: &str, service: &str, mesh: &MeshData, params: &[(&str, Value)]) -> RunOutput {
    let runtime = runtime();
    let plugin = builtin(&runtime, plugin);
    let params: Vec<(String, Value)> =
        params.iter().map(|(name, value)| (name.to_string(), value.clone())).collect();
    runtime
        .run(&plugin, service, mesh.clone(), &params)
        .unwrap_or_else(|e| panic!("{service}: {e}"))
}
