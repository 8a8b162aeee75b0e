//! The sandbox's limits, in one place.

use std::time::Duration;
use wasmtime::ResourceLimiter;

/// Wall-clock time a run may take before it is interrupted.
pub const DEFAULT_DEADLINE: Duration = Duration::from_secs(60);
/// Linear memory a plugin may grow to. A 1M-vertex mesh with adjacency needs ~200 MB.
pub const DEFAULT_MEMORY_BYTES: usize = 2 << 30;
/// Captured stdout and stderr, each. Writing more traps the plugin.
pub const OUTPUT_CAPTURE_BYTES: usize = 64 << 10;
/// Granularity of the deadline: the epoch ticker's period.
pub const EPOCH_TICK: Duration = Duration::from_millis(10);
/// Wasm stack a plugin may use.
pub const MAX_WASM_STACK_BYTES: usize = 2 << 20;
/// Bytes a single guest-to-host call may transfer, on top of the mesh-sized allowance
/// (a bulk `set-positions` carries the whole position array).
pub const BASE_HOSTCALL_BYTES: usize = 64 << 20;
/// Elements (coordinates, ids) a run may pass to edit calls in total, beyond a multiple of
/// the input's size: stops a plugin from growing the host's memory without bound.
pub const BASE_EDIT_BUDGET: u64 = 16 << 20;
/// The edit budget grows by this multiple of the input's element count.
pub const EDIT_BUDGET_PER_INPUT_ELEMENT: u64 = 64;
/// Runs executing at once in one runtime.
pub const DEFAULT_CONCURRENT_RUNS: usize = 4;

/// Per-runtime limits; every field has a named default above.
#[derive(Clone, Debug)]
pub struct Limits {
    pub deadline: Duration,
    pub memory_bytes: usize,
    /// Wasm fuel per run; `None` turns fuel metering off (it costs ~40 % on tight loops,
    /// and the deadline already bounds time).
    pub fuel: Option<u64>,
    pub concurrent_runs: usize,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            deadline: DEFAULT_DEADLINE,
            memory_bytes: DEFAULT_MEMORY_BYTES,
            fuel: None,
            concurrent_runs: DEFAULT_CONCURRENT_RUNS,
        }
    }
}

/// Caps linear memory and remembers that it did, so the error can say which limit hit.
pub(crate) struct MemoryCap {
    max_bytes: usize,
    pub(crate) exceeded: bool,
}

impl MemoryCap {
    pub(crate) fn new(max_bytes: usize) -> Self {
        Self { max_bytes, exceeded: false }
    }
}

impl ResourceLimiter for MemoryCap {
    fn memory_growing(
        &mut self,
        _current: usize,
        desired: usize,
        _maximum: Option<usize>,
    ) -> wasmtime::Result<bool> {
        if desired > self.max_bytes {
            self.exceeded = true;
            wasmtime::bail!("memory limit of {} bytes exceeded", self.max_bytes);
        }
        Ok(true)
    }

    fn table_growing(
        &mut self,
        _current: usize,
        desired: usize,
        _maximum: Option<usize>,
    ) -> wasmtime::Result<bool> {
        // A table entry is a pointer: hold tables to the same byte budget.
        Ok(desired.saturating_mul(8) <= self.max_bytes)
    }
}
