//! What a single run's `Store` holds: the mesh being edited and the empty sandbox around it.

use std::sync::Arc;
use std::time::Duration;

use wasmtime::component::ResourceTable;
use wasmtime_wasi::p2::pipe::MemoryOutputPipe;
use wasmtime_wasi::{HostMonotonicClock, HostWallClock, WasiCtx, WasiCtxView, WasiView};

use super::connectivity_cache::ConnectivityCache;
use super::limits::{MemoryCap, OUTPUT_CAPTURE_BYTES};
use meshflow_mesh::store::MeshStore;

/// The guest's handle to the run's mesh. A run has exactly one mesh, kept in [`RunState`].
pub struct MeshHandle;

pub(crate) struct RunState {
    pub(crate) mesh: MeshStore,
    /// The runtime's derived connectivity of recent mesh versions.
    pub(crate) connectivity: Arc<ConnectivityCache>,
    /// Checks may read but not edit.
    pub(crate) read_only: bool,
    /// Elements the guest may still pass to edit calls before the run is stopped.
    pub(crate) edit_budget: u64,
    pub(crate) edit_budget_exceeded: bool,
    pub(crate) memory: MemoryCap,
    pub(crate) stdout: MemoryOutputPipe,
    pub(crate) stderr: MemoryOutputPipe,
    wasi: WasiCtx,
    table: ResourceTable,
}

impl RunState {
    pub(crate) fn new(
        mesh: MeshStore,
        connectivity: Arc<ConnectivityCache>,
        read_only: bool,
        edit_budget: u64,
        memory_bytes: usize,
    ) -> Self {
        let stdout = MemoryOutputPipe::new(OUTPUT_CAPTURE_BYTES);
        let stderr = MemoryOutputPipe::new(OUTPUT_CAPTURE_BYTES);
        Self {
            mesh,
            connectivity,
            read_only,
            edit_budget,
            edit_budget_exceeded: false,
            memory: MemoryCap::new(memory_bytes),
            wasi: sandbox(stdout.clone(), stderr.clone()),
            stdout,
            stderr,
            table: ResourceTable::new(),
        }
    }

    pub(crate) fn table(&mut self) -> &mut ResourceTable {
        &mut self.table
    }
}

impl WasiView for RunState {
    fn ctx(&mut self) -> WasiCtxView<'_> {
        WasiCtxView { ctx: &mut self.wasi, table: &mut self.table }
    }
}

/// An empty WASI world: no files, sockets, environment or arguments; clocks stopped at
/// zero and "randomness" a fixed stream, so a plugin is a deterministic function of its
/// inputs even if it (or its standard library) asks for time or entropy.
fn sandbox(stdout: MemoryOutputPipe, stderr: MemoryOutputPipe) -> WasiCtx {
    WasiCtx::builder()
        .stdout(stdout)
        .stderr(stderr)
        .wall_clock(FrozenClock)
        .monotonic_clock(FrozenClock)
        .secure_random(wasmtime_wasi::Deterministic::new(vec![0x5a, 0x17, 0xc3, 0x8e]))
        .insecure_random(wasmtime_wasi::Deterministic::new(vec![0x2b, 0x91, 0x4f, 0xd6]))
        .insecure_random_seed(0)
        .build()
}

struct FrozenClock;

impl HostWallClock for FrozenClock {
    fn resolution(&self) -> Duration {
        Duration::from_secs(1)
    }

    fn now(&self) -> Duration {
        Duration::ZERO
    }
}

impl HostMonotonicClock for FrozenClock {
    fn resolution(&self) -> u64 {
        1_000_000_000
    }

    fn now(&self) -> u64 {
        0
    }
}
