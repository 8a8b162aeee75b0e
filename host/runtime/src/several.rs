//! Several checks on one mesh ([`Runtime::run_checks`]), what `meshflow check --all` runs:
//! on as many instances as run slots are free (each check is read-only and deterministic,
//! so where it runs does not change its value), each instance serving the checks it takes
//! one after another: its memory is paged in by its first check and reset once, at its
//! end, and the mesh's derived connectivity serves them all.

use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use wasmtime::Store;
use wasmtime::component::Resource;

use super::bindings::{self, Param};
use super::state::RunState;
use super::work_queue::WorkQueue;
use super::{Plugin, RunError, Runtime, ServiceKind, Value, ticks};
use meshflow_mesh::MeshData;
use meshflow_params::{ServiceInfo, check_result};

/// Why [`Runtime::run_checks`] ran nothing, or stopped.
#[derive(Debug, thiserror::Error)]
pub enum ChecksError {
    #[error("`{0}` is a filter, not a check: several checks run read-only in one instance")]
    Filter(String),
    #[error("the plugin has no service `{0}`")]
    Unknown(String),
    #[error(transparent)]
    Run(#[from] RunError),
}

/// One check of [`Runtime::run_checks`]: its value, or why it gave none.
#[derive(Debug)]
pub struct CheckRun {
    pub service: String,
    pub value: Result<Value, RunError>,
    /// The check's own call, from the host's `run` to its result.
    pub duration: Duration,
}

impl Runtime {
    /// Runs the checks `services` of `plugin` on `mesh`, each with its parameters' defaults
    /// and a deadline of its own, in one instance and in one more per run slot that frees
    /// up while checks are left; the runs come back in the order of `services`. A check
    /// that fails (refuses the mesh, returns the wrong type) gives its error and the others
    /// still run; one that traps stops the run. Filters are refused before anything runs:
    /// the instances are read-only.
    pub fn run_checks(
        &self,
        plugin: &Plugin,
        services: &[&str],
        mesh: impl Into<Arc<MeshData>>,
    ) -> Result<Vec<CheckRun>, ChecksError> {
        let mut calls = Vec::with_capacity(services.len());
        for &service in services {
            let info = match plugin.service(service) {
                Some(info) if info.kind == ServiceKind::Check => info,
                Some(_) => return Err(ChecksError::Filter(service.to_owned())),
                None => return Err(ChecksError::Unknown(service.to_owned())),
            };
            let params: Vec<Param> = meshflow_params::resolve(info, &[])
                .map_err(RunError::from)?
                .into_iter()
                .map(|(name, value)| Param { name, value: value.into() })
                .collect();
            calls.push((info, params));
        }
        let label = services.join(", ");
        let mesh = mesh.into();
        let (slot, _) = self.acquire_slot(&label)?;
        let deadline = ticks(self.limits.deadline);
        let queue = WorkQueue::new(calls.len());
        let runs: Mutex<Vec<Option<CheckRun>>> =
            Mutex::new((0..calls.len()).map(|_| None).collect());
        let trapped = Mutex::new(None);
        // Each worker is one instance: its memory paged in by its first check and reset
        // once, at its end. A second one works from the other end of the list, so while the
        // first derives the connectivity (in the first check that reads it, typically near
        // the front: the checks plugin lists its topology checks first) the second runs
        // checks that do not wait for it.
        let workers = self.workers_for(calls.len());
        self.with_helpers(&slot, workers, &queue, |slot, end| {
            let instance = self.call(
                slot,
                &plugin.pre,
                &label,
                Arc::clone(&mesh),
                true,
                self.limits.deadline,
                |store, p, _, handle| {
                    while let Some(index) = queue.take(end) {
                        let (info, params) = &calls[index];
                        store.set_epoch_deadline(deadline);
                        let run = run_check(store, p, handle.rep(), info, params)?;
                        runs.lock().unwrap_or_else(|e| e.into_inner())[index] = Some(run);
                    }
                    Ok(())
                },
            );
            if let Err(error) = instance {
                queue.stop();
                trapped.lock().unwrap_or_else(|e| e.into_inner()).get_or_insert(error);
            }
        });
        if let Some(error) = trapped.into_inner().unwrap_or_else(|e| e.into_inner()) {
            return Err(error.into());
        }
        let runs = runs.into_inner().unwrap_or_else(|e| e.into_inner());
        Ok(runs.into_iter().map(|run| run.expect("every check ran: none trapped")).collect())
    }
}

/// One check's call in an instance: its value, or the error it gave; `Err` only when it
/// trapped, which ends the instance.
fn run_check(
    store: &mut Store<RunState>,
    plugin: &bindings::Plugin,
    mesh: u32,
    info: &ServiceInfo,
    params: &[Param],
) -> wasmtime::Result<CheckRun> {
    let started = Instant::now();
    let outcome = plugin.meshflow_geometry_service().call_run(
        &mut *store,
        &info.name,
        Resource::new_borrow(mesh),
        params,
    )?;
    let duration = started.elapsed();
    let service = info.name.clone();
    let value = outcome
        .map_err(|message| RunError::Failed { service: service.clone(), message })
        .and_then(|outcome| {
            let value = outcome.value.map(Value::from);
            check_result(info, value.as_ref())
                .map_err(|problem| RunError::BadResult { service: service.clone(), problem })?;
            Ok(value.expect("check_result refuses a check without a value"))
        });
    Ok(CheckRun { service, value, duration })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Limits;
    use meshflow_builtin_plugins::PLUGINS;

    fn load(runtime: &Runtime, name: &str) -> Plugin {
        let wasm = PLUGINS.iter().find(|p| p.name == name).expect("a built-in plugin").wasm;
        runtime.load(wasm).expect("it loads")
    }

    #[test]
    fn checks_share_an_instance_and_a_refusal_stops_only_its_own_check() {
        let runtime = Runtime::new(Limits::default(), None).expect("a runtime");
        let checks = load(&runtime, "checks");
        let (positions, triangles) = meshflow_topology::shapes::unit_cube();
        let cube = Arc::new(MeshData::new(positions.clone(), triangles.clone()));
        let services = ["edge-count", "volume", "hole-count", "is-oriented"];
        let runs = runtime.run_checks(&checks, &services, Arc::clone(&cube)).expect("runs");
        // Each as a run of its own gives the same, to the bit.
        for (run, service) in runs.iter().zip(services) {
            let alone = runtime.run(&checks, service, Arc::clone(&cube), &[]).expect("a run");
            assert_eq!(run.value.as_ref().ok(), alone.value.as_ref(), "{service}");
        }
        assert_eq!(runs[0].value.as_ref().ok(), Some(&Value::Integer(18)));
        assert_eq!(runs[3].value.as_ref().ok(), Some(&Value::Boolean(true)));
        // Without its top the cube encloses nothing: volume refuses, the rest still answer.
        let open = MeshData::new(positions, triangles[6..].to_vec());
        let runs = runtime.run_checks(&checks, &services, open).expect("runs");
        let refused = runs[1].value.as_ref().expect_err("an open mesh has no volume");
        assert!(refused.to_string().contains("no closed component"), "{refused}");
        assert_eq!(runs[2].value.as_ref().ok(), Some(&Value::Integer(1)));
    }

    #[test]
    fn a_check_that_traps_stops_the_run_on_every_instance_and_frees_their_slots() {
        let limits = Limits { concurrent_runs: 2, ..Limits::default() };
        let runtime = Runtime::new(limits, None).expect("a runtime");
        let hostile = runtime.load(meshflow_builtin_plugins::fixture("hostile")).unwrap();
        let cube = Arc::new(MeshData::new(vec![0.0; 9], vec![0, 1, 2]));
        let services = ["edit-in-check", "trap-in-check", "wrong-result-type", "edit-in-check"];
        for _ in 0..3 {
            let error = runtime.run_checks(&hostile, &services, Arc::clone(&cube)).unwrap_err();
            assert!(matches!(error, ChecksError::Run(RunError::Trap { .. })), "{error}");
        }
        // Both slots came back: two checks at once still run, each giving its own error.
        let calm = ["edit-in-check", "wrong-result-type"];
        let runs = runtime.run_checks(&hostile, &calm, cube).expect("runs");
        assert!(matches!(runs[0].value, Err(RunError::Failed { .. })), "{runs:?}");
        assert!(matches!(runs[1].value, Err(RunError::BadResult { .. })), "{runs:?}");
    }

    #[test]
    fn filters_and_unknown_names_are_refused_before_anything_runs() {
        let runtime = Runtime::new(Limits::default(), None).expect("a runtime");
        let cube = MeshData::new(vec![0.0; 9], vec![0, 1, 2]);
        let smoothing = load(&runtime, "smoothing");
        let error = runtime.run_checks(&smoothing, &["laplacian-smoothing"], cube.clone());
        assert!(matches!(error, Err(ChecksError::Filter(name)) if name == "laplacian-smoothing"));
        let checks = load(&runtime, "checks");
        let error = runtime.run_checks(&checks, &["edge-count", "edge-cuont"], cube);
        assert!(matches!(error, Err(ChecksError::Unknown(name)) if name == "edge-cuont"));
    }
}
