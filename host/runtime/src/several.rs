//! Several checks on one mesh in one instance ([`Runtime::run_checks`]): the instance, its
//! memory (paged in by the first check, reset once at the end rather than after each) and
//! the mesh's derived connectivity serve them all. What `meshflow check --all` runs.

use std::sync::Arc;
use std::time::{Duration, Instant};

use wasmtime::component::Resource;

use super::bindings::Param;
use super::{Plugin, RunError, Runtime, ServiceKind, Value, check_value, ticks};
use meshflow_mesh::MeshData;

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
    /// Runs the checks `services` of `plugin` on `mesh`, one after another in one instance,
    /// each with its parameters' defaults and a deadline of its own. A check that fails
    /// (refuses the mesh, returns the wrong type) gives its error and the others still
    /// run; one that traps stops the instance, and with it the run. Filters are refused
    /// before anything runs: the instance is read-only.
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
        let (slot, _) =
            self.permits.acquire(Some(self.limits.queued_runs)).map_err(|_| RunError::Busy {
                service: label.clone(),
                slots: self.limits.concurrent_runs,
                queued: self.limits.queued_runs,
            })?;
        let deadline = ticks(self.limits.deadline);
        let (runs, _) =
            self.call(&slot, &plugin.pre, &label, mesh.into(), true, |store, p, mesh| {
                let mut runs = Vec::with_capacity(calls.len());
                for (info, params) in &calls {
                    store.set_epoch_deadline(deadline);
                    let started = Instant::now();
                    let borrowed = Resource::new_borrow(mesh.rep());
                    let outcome = p.meshflow_geometry_service().call_run(
                        &mut *store,
                        &info.name,
                        borrowed,
                        params,
                    )?;
                    let duration = started.elapsed();
                    let service = info.name.clone();
                    let value = outcome
                        .map_err(|message| RunError::Failed { service: service.clone(), message })
                        .and_then(|outcome| {
                            let value = outcome.value.map(Value::from);
                            check_value(info, value.as_ref()).map_err(|problem| {
                                RunError::BadResult { service: service.clone(), problem }
                            })?;
                            Ok(value.expect("check_value refuses a check without a value"))
                        });
                    runs.push(CheckRun { service, value, duration });
                }
                Ok(runs)
            })?;
        Ok(runs)
    }
}
