//! The sandboxed plugin runtime: wasmtime configured for deterministic, bounded runs.
//!
//! A [`Runtime`] owns one engine. [`Runtime::load`] turns component bytes into a validated
//! [`Plugin`] (compiled once, cached on disk by digest); [`Runtime::run`] runs one service
//! of it on a mesh in a fresh `Store` with every limit of [`Limits`], and returns the edited
//! mesh with the log of every edit the plugin made. [`Runtime::invoke`] runs an
//! [`Invocation`], a service whose lookup and parameters were resolved once by the caller.
//!
//! [`Catalog`] says which loaded plugin offers a service. Service descriptions and values
//! are `meshflow-params` types; the WIT's bindgen types stay inside `bindings`. This crate
//! must not depend on codecs, file formats or HTTP.

mod array_reads;
mod bindings;
mod cache;
mod catalog;
mod connectivity_cache;
mod crash;
mod error;
mod footprint;
mod host_mesh;
mod invocation;
mod limits;
mod partitioned;
mod permits;
mod plugin;
mod several;
mod state;
mod work_queue;

pub use catalog::Catalog;
pub use connectivity_cache::CACHED_MESH_VERSIONS;
pub use error::{MemoryFit, PluginError, ResultError, RunError};
pub use invocation::Invocation;
pub use limits::*;
pub use meshflow_params::{
    ParamError, ParamInfo, ServiceInfo, ServiceKind, Value, ValueType, describe_params,
    resolve as resolve_params, type_name, value_text,
};
pub use partitioned::Partitions;
pub use plugin::{Plugin, digest};
pub use several::{CheckRun, ChecksError};

use std::path::Path;
use std::sync::Arc;
use std::time::{Duration, Instant};

use wasmtime::component::{HasSelf, Instance, Linker, Resource};
use wasmtime::{Config, Enabled, Engine, PoolingAllocationConfig, Store, Trap};

use bindings::Param;
use cache::ArtifactCache;
use meshflow_mesh::MeshData;
use meshflow_mesh::store::{MeshStore, Op};
use state::{MeshHandle, RunState};

/// What a successful run produced.
#[derive(Debug)]
pub struct RunOutput {
    /// The compacted result of a filter; `None` for a check.
    pub mesh: Option<MeshData>,
    /// Every edit the plugin made, in order.
    pub log: Vec<Op>,
    /// A check's value.
    pub value: Option<Value>,
    /// The plugin's own account of what it did.
    pub report: String,
    /// What the plugin printed (capped at [`OUTPUT_CAPTURE_BYTES`] each).
    pub stdout: String,
    pub stderr: String,
    /// The run itself, from instantiation to its result.
    pub duration: Duration,
    /// The time it waited for a run slot before that.
    pub queued: Duration,
    /// The largest the guest's linear memory grew (its initial size at least); for a run on
    /// partitions, the largest of theirs.
    pub guest_peak_bytes: usize,
    /// How the mesh was cut, when the service ran on partitions.
    pub partitions: Option<Partitions>,
}

pub struct Runtime {
    engine: Engine,
    linker: Linker<RunState>,
    limits: Limits,
    cache: Option<ArtifactCache>,
    permits: Arc<permits::Permits>,
    /// Derived once per mesh version, shared by the read-only runs that follow on it.
    connectivity: Arc<connectivity_cache::ConnectivityCache>,
    /// What each service needed of guest memory per triangle on earlier runs.
    footprints: footprint::Footprints,
}

/// What the instance asked to run a filter whole did: ran it, or was told by the service
/// that on a mesh this large it runs block by block, in blocks of this many triangles.
enum WholeCall {
    Ran(Result<bindings::meshflow::geometry::types::Outcome, String>),
    InBlocks(usize),
}

impl Runtime {
    /// A runtime with the given limits; compiled components are cached in `cache_dir`
    /// when one is given.
    pub fn new(limits: Limits, cache_dir: Option<&Path>) -> Result<Self, PluginError> {
        limits.check()?;
        let engine = Engine::new(&engine_config(&limits))
            .map_err(|e| PluginError::Compile(e.to_string()))?;
        let mut linker = Linker::new(&engine);
        wasmtime_wasi::p2::add_to_linker_sync(&mut linker)
            .and_then(|()| bindings::Plugin::add_to_linker::<_, HasSelf<_>>(&mut linker, |s| s))
            .and_then(|()| array_reads::add_to_linker(&mut linker))
            .map_err(|e| PluginError::World(e.to_string()))?;
        start_epoch_ticker(&engine);
        let cache = cache_dir.map(|dir| ArtifactCache::new(dir, &engine)).transpose()?;
        let permits = Arc::new(permits::Permits::new(limits.concurrent_runs));
        let connectivity =
            Arc::new(connectivity_cache::ConnectivityCache::new(Arc::clone(&permits)));
        let footprints = footprint::Footprints::default();
        Ok(Self { engine, linker, limits, cache, permits, connectivity, footprints })
    }

    pub fn limits(&self) -> &Limits {
        &self.limits
    }

    /// Compiles (or loads from the cache), links and validates a component, and asks it to
    /// describe its services.
    pub fn load(&self, bytes: &[u8]) -> Result<Plugin, PluginError> {
        plugin::check_component_preamble(bytes)?;
        let digest = digest(bytes);
        let component = match &self.cache {
            Some(cache) => cache.load_or_compile(&self.engine, &digest, bytes)?,
            None => cache::compile(&self.engine, bytes)?,
        };
        let instance_pre = self
            .linker
            .instantiate_pre(&component)
            .map_err(|e| PluginError::World(format!("{e:#}")))?;
        let pre = bindings::PluginPre::new(instance_pre)
            .map_err(|e| PluginError::World(format!("{e:#}")))?;
        let reach = partitioned::reach_export(&component);
        let blocks = partitioned::blocks_export(&component);
        // A load waits for a slot however long the queue: uploads are few and need a token.
        let (slot, _) = self.permits.acquire(None).expect("an unbounded queue has room");
        let deadline = self.limits.deadline;
        let (services, reach_typed, blocks_typed) = self
            .call(&slot, &pre, "describe", Arc::default(), true, deadline, |store, p, i, _| {
                let services = p.meshflow_geometry_service().call_describe(&mut *store)?;
                let reach_typed = reach
                    .as_ref()
                    .map(|index| partitioned::declaration_func(store, i, index).map(|_| ()));
                let blocks_typed = blocks
                    .as_ref()
                    .map(|index| partitioned::declaration_func(store, i, index).map(|_| ()));
                Ok((services, reach_typed, blocks_typed))
            })
            .map(|((services, reach, blocks), _)| {
                (services.into_iter().map(ServiceInfo::from).collect::<Vec<_>>(), reach, blocks)
            })
            .map_err(|e| PluginError::Describe(Box::new(e)))?;
        if let Some(Err(e)) = reach_typed {
            return Err(PluginError::World(format!("its `locality` export: {e:#}")));
        }
        if let Some(Err(e)) = blocks_typed {
            return Err(PluginError::World(format!("its `blocks` export: {e:#}")));
        }
        plugin::validate_description(&services)?;
        Ok(Plugin { digest, services, pre, reach, blocks })
    }

    /// Runs `service` of `plugin` on `mesh`. Parameters are checked against the service's
    /// description first; a check runs read-only. A shared mesh (`Arc`) is copied only if
    /// the service edits it, so a check on a session's mesh copies nothing.
    pub fn run(
        &self,
        plugin: &Plugin,
        service: &str,
        mesh: impl Into<Arc<MeshData>>,
        params: &[(String, Value)],
    ) -> Result<RunOutput, RunError> {
        let info = plugin.service(service).ok_or_else(|| RunError::UnknownService {
            service: service.to_owned(),
            suggestion: meshflow_params::did_you_mean(
                service,
                plugin.services.iter().map(|s| s.name.as_str()),
            ),
            available: plugin
                .services
                .iter()
                .map(|s| s.name.as_str())
                .collect::<Vec<_>>()
                .join(", "),
        })?;
        let params = meshflow_params::resolve(info, params)?;
        self.run_resolved(plugin, info, mesh.into(), &params)
    }

    /// [`Runtime::run`] of a service already looked up, with its parameters already
    /// resolved: neither is done again.
    pub fn invoke(
        &self,
        invocation: &Invocation,
        mesh: impl Into<Arc<MeshData>>,
    ) -> Result<RunOutput, RunError> {
        let (plugin, info) = (invocation.plugin(), invocation.info());
        self.run_resolved(plugin, info, mesh.into(), invocation.params())
    }

    /// Runs service `info` of `plugin` with `params`, every one resolved.
    fn run_resolved(
        &self,
        plugin: &Plugin,
        info: &ServiceInfo,
        mesh: Arc<MeshData>,
        params: &[(String, Value)],
    ) -> Result<RunOutput, RunError> {
        let service = info.name.as_str();
        let params: Vec<Param> = params
            .iter()
            .map(|(name, value)| Param { name: name.clone(), value: value.clone().into() })
            .collect();
        let is_check = info.kind == ServiceKind::Check;
        let triangles = mesh.triangle_count();
        // A local filter on a mesh over the partition size is cut at once where the size was
        // forced or the service is known not to fit the memory cap; else it runs whole (the
        // faster where it fits: cutting costs a sort and a copy), and is cut only once it
        // stops at the limit, from the input kept for that.
        let may_cut =
            !is_check && plugin.reach.is_some() && triangles > self.limits.partition_triangles();
        // Asked only of such a filter: a check or a small mesh pays no lookup.
        let cut_first = may_cut
            && (self.limits.max_partition_triangles.is_some()
                || self.footprints.known_not_to_fit(
                    &plugin.digest,
                    service,
                    triangles,
                    self.limits.memory_bytes,
                ));
        if cut_first && let Some(output) = self.run_partitioned(plugin, info, &mesh, &params)? {
            return Ok(output);
        }
        let kept = (may_cut && !cut_first).then(|| Arc::clone(&mesh));
        let (slot, queued) = self.acquire_slot(service)?;
        let started = Instant::now();
        // A filter that runs block by block says so, with these parameters, in the instance
        // that would run it whole.
        let blocks = if is_check { None } else { plugin.blocks.as_ref() };
        let whole = self.call(
            &slot,
            &plugin.pre,
            service,
            mesh,
            is_check,
            self.limits.deadline,
            |store, p, instance, mesh| {
                if let Some(index) = blocks {
                    let declared = partitioned::declaration_func(store, instance, index)?
                        .call(&mut *store, (service.to_owned(), params.clone()))?
                        .0;
                    if let Some(size) = declared.filter(|&size| triangles > size as usize) {
                        return Ok(WholeCall::InBlocks(size as usize));
                    }
                }
                let ran = p.meshflow_geometry_service().call_run(store, service, mesh, &params)?;
                Ok(WholeCall::Ran(ran))
            },
        );
        let (outcome, state) = match (whole, kept) {
            (Ok((WholeCall::Ran(outcome), state)), _) => (outcome, state),
            (Ok((WholeCall::InBlocks(size), state)), _) => {
                // Nothing was edited: the store still shares the input.
                let input = state.mesh.shared_slots();
                drop((state, slot));
                return self.run_in_blocks(plugin, service, &input, &params, size);
            }
            (Err(error @ RunError::Memory { .. }), Some(input)) => {
                drop(slot);
                self.footprints.stopped(&plugin.digest, service, triangles);
                return match self.run_partitioned(plugin, info, &input, &params)? {
                    Some(output) => Ok(output),
                    None => Err(self.footprints.explain(error, &plugin.digest, service)),
                };
            }
            (Err(error), _) => return Err(self.footprints.explain(error, &plugin.digest, service)),
        };
        if state.memory.grew {
            self.footprints.learn(&plugin.digest, service, state.memory.peak_bytes, triangles);
        }
        // The store is gone: the next run may have the slot while this one compacts.
        drop(slot);
        let outcome =
            outcome.map_err(|message| RunError::Failed { service: service.to_owned(), message })?;
        let value = outcome.value.map(Value::from);
        meshflow_params::check_result(info, value.as_ref())
            .map_err(|problem| RunError::BadResult { service: service.to_owned(), problem })?;
        let report = meshflow_mesh::calls::with_defaulted_note(outcome.report, &state.mesh);
        // A check edits nothing and gives no mesh: finishing its store would only copy the
        // caller's shared mesh (36 MB, 4-7 ms on a 1M scan) to drop it.
        let (mesh, log) = match is_check {
            true => (None, Vec::new()),
            false => {
                let (edited, log) = state.mesh.finish();
                (Some(edited), log)
            }
        };
        Ok(RunOutput {
            mesh,
            log,
            value,
            report,
            stdout: captured(&state.stdout),
            stderr: captured(&state.stderr),
            duration: started.elapsed(),
            queued,
            guest_peak_bytes: state.memory.peak_bytes,
            partitions: None,
        })
    }

    /// A run slot for `service`, after waiting behind at most `queued_runs` others.
    fn acquire_slot(&self, service: &str) -> Result<(permits::Permit<'_>, Duration), RunError> {
        self.permits.acquire(Some(self.limits.queued_runs)).map_err(|_| RunError::Busy {
            service: service.to_owned(),
            slots: self.limits.concurrent_runs,
            queued: self.limits.queued_runs,
        })
    }

    /// Instantiates the component in a fresh store around `mesh`, calls `f` (given the
    /// world's bindings and the instance itself, for optional exports) within `deadline`,
    /// and turns traps into errors that say which limit was hit. The `_slot` proves a run
    /// slot is held: the pool has one instance slot per run slot.
    #[allow(clippy::too_many_arguments)]
    fn call<R>(
        &self,
        _slot: &permits::Permit<'_>,
        pre: &bindings::PluginPre<RunState>,
        service: &str,
        mesh: Arc<MeshData>,
        read_only: bool,
        deadline: Duration,
        f: impl FnOnce(
            &mut Store<RunState>,
            &bindings::Plugin,
            &Instance,
            Resource<MeshHandle>,
        ) -> wasmtime::Result<R>,
    ) -> Result<(R, RunState), RunError> {
        let input_elements = (mesh.positions.len() + mesh.triangles.len()) as u64;
        let triangles = mesh.triangles.len() / 3;
        let budget = BASE_EDIT_BUDGET + EDIT_BUDGET_PER_INPUT_ELEMENT * input_elements;
        // A `set-attribute` may carry the largest attribute the mesh could hold whole (four
        // f64 per corner, as the input's triangles count them): on top of the mesh's allowance.
        let attribute_bytes = 4 * 8 * mesh.triangles.len().max(mesh.positions.len() / 3);
        let state = RunState::new(
            MeshStore::new(mesh),
            Arc::clone(&self.connectivity),
            read_only,
            budget,
            self.limits.memory_bytes,
        );
        let mut store = Store::new(&self.engine, state);
        store.limiter(|s| &mut s.memory);
        store
            .set_hostcall_fuel(BASE_HOSTCALL_BYTES + 8 * input_elements as usize + attribute_bytes);
        store.set_epoch_deadline(ticks(deadline));
        store.epoch_deadline_trap();
        if let Some(fuel) = self.limits.fuel {
            store.set_fuel(fuel).expect("fuel is enabled in the engine config when set");
        }
        let instantiated = pre
            .instance_pre()
            .instantiate(&mut store)
            .and_then(|instance| Ok((bindings::Plugin::new(&mut store, &instance)?, instance)));
        let (plugin, instance) = match instantiated {
            Ok(instantiated) => instantiated,
            // The cap is below the plugin's initial memory.
            Err(_) if store.data().memory.exceeded => {
                return Err(self.memory_error(service, triangles));
            }
            Err(e) => {
                let message = format!("{e:#}");
                return Err(RunError::Instantiate { service: service.to_owned(), message });
            }
        };
        let handle = store.data_mut().table().push(MeshHandle).map_err(|e| {
            RunError::Instantiate { service: service.to_owned(), message: e.to_string() }
        })?;
        match f(&mut store, &plugin, &instance, handle) {
            Ok(result) => Ok((result, store.into_data())),
            Err(error) => Err(self.classify(service, error, store.data(), triangles)),
        }
    }

    /// The run on a mesh of `triangles` stopped at the memory limit.
    fn memory_error(&self, service: &str, triangles: usize) -> RunError {
        RunError::Memory {
            service: service.to_owned(),
            limit_mib: self.limits.memory_bytes / MIB,
            fit: Some(MemoryFit { triangles, learned_bytes_per_triangle: None }),
        }
    }

    fn classify(
        &self,
        service: &str,
        error: wasmtime::Error,
        state: &RunState,
        triangles: usize,
    ) -> RunError {
        let service = service.to_owned();
        if state.memory.exceeded {
            return self.memory_error(&service, triangles);
        }
        if state.edit_budget_exceeded {
            return RunError::EditBudget { service };
        }
        if [&state.stdout, &state.stderr].iter().any(|p| p.contents().len() >= OUTPUT_CAPTURE_BYTES)
        {
            return RunError::Output { service, limit_kib: OUTPUT_CAPTURE_BYTES >> 10 };
        }
        match error.downcast_ref::<Trap>() {
            Some(Trap::Interrupt) => RunError::Deadline { service, deadline: self.limits.deadline },
            Some(Trap::OutOfFuel) => {
                RunError::Fuel { service, fuel: self.limits.fuel.unwrap_or(0) }
            }
            _ => {
                let message = crash::crash_message(&error, &captured(&state.stderr));
                RunError::Trap { service, message }
            }
        }
    }
}

fn engine_config(limits: &Limits) -> Config {
    let mut config = Config::new();
    // Synchronous calls only: halves the cost of a host call (~190 ns -> ~95 ns).
    config.concurrency_support(false);
    config.epoch_interruption(true);
    config.consume_fuel(limits.fuel.is_some());
    // Off (DESIGN §8): it cost 10-40 % on float-heavy services. Determinism is checked
    // instead: the store refuses non-finite coordinates in every edit, and every correction
    // and replay is verified against its result hash.
    config.cranelift_nan_canonicalization(false);
    config.max_wasm_stack(MAX_WASM_STACK_BYTES);
    // A 4 GiB reservation with guard pages: no bounds checks in the compiled code, and the
    // memory never has to move, which lets cranelift keep its base pointer in a register.
    config.memory_reservation(MEMORY_RESERVATION);
    config.memory_guard_size(MEMORY_GUARD_BYTES);
    config.memory_may_move(false);
    config.allocation_strategy(pool(limits));
    config
}

/// The pooling allocator: a store's memories and tables come from slots reserved once, and
/// a slot is reset in place when the store drops, keeping its pages resident (see
/// [`LINEAR_MEMORY_KEEP_RESIDENT`]). Slots are sized from the limits: every instantiation
/// holds a permit (see [`Runtime::call`]), so `concurrent_runs` slots always suffice.
fn pool(limits: &Limits) -> PoolingAllocationConfig {
    let runs = limits.concurrent_runs.max(1) as u32;
    let mut pool = PoolingAllocationConfig::new();
    pool.total_component_instances(runs)
        .total_core_instances(runs * CORE_INSTANCES_PER_RUN)
        .max_core_instances_per_component(CORE_INSTANCES_PER_RUN)
        .total_memories(runs * MEMORIES_PER_RUN)
        .max_memories_per_component(MEMORIES_PER_RUN)
        .total_tables(runs * TABLES_PER_RUN)
        .max_tables_per_component(TABLES_PER_RUN)
        .max_tables_per_module(TABLES_PER_RUN)
        .table_elements(TABLE_ELEMENTS)
        // The pool allows what any cap may; the `MemoryCap` limiter holds each run to the
        // operator's cap with a clear error, even a cap below a plugin's initial memory.
        .max_memory_size(MAX_MEMORY_BYTES)
        .linear_memory_keep_resident(LINEAR_MEMORY_KEEP_RESIDENT)
        .table_keep_resident(TABLE_KEEP_RESIDENT)
        // Where the kernel can tell (Linux >= 6.7), zero only the pages a run dirtied.
        .pagemap_scan(Enabled::Auto);
    pool
}

fn ticks(deadline: Duration) -> u64 {
    (deadline.as_millis() / EPOCH_TICK.as_millis()).max(1) as u64
}

/// Advances the engine's epoch every tick, for as long as the engine lives.
fn start_epoch_ticker(engine: &Engine) {
    let weak = engine.weak();
    std::thread::Builder::new()
        .name("meshflow-epoch".into())
        .spawn(move || {
            while let Some(engine) = weak.upgrade() {
                engine.increment_epoch();
                drop(engine);
                std::thread::sleep(EPOCH_TICK);
            }
        })
        .expect("spawning the epoch ticker thread");
}

fn captured(pipe: &wasmtime_wasi::p2::pipe::MemoryOutputPipe) -> String {
    String::from_utf8_lossy(&pipe.contents()).into_owned()
}
