//! The sandbox's limits, in one place.

use std::time::Duration;
use wasmtime::ResourceLimiter;

/// Wall-clock time a run may take before it is interrupted.
pub const DEFAULT_DEADLINE: Duration = Duration::from_secs(60);
/// The longest deadline an operator may set: an hour of one run.
pub const MAX_DEADLINE: Duration = Duration::from_secs(3600);
/// Linear memory a plugin may grow to. A 1M-vertex mesh with adjacency needs ~200 MB.
pub const DEFAULT_MEMORY_BYTES: usize = 2 << 30;
/// The most an operator may allow (`--memory-cap`): everything a 32-bit guest can address,
/// which is also [`MEMORY_RESERVATION`], so a memory at the cap still needs no bounds checks.
pub const MAX_MEMORY_BYTES: usize = 4 << 30;
/// `--memory-cap` counts in MiB.
pub const MIB: usize = 1 << 20;
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
/// Threads deriving a mesh version's connectivity (twins, edge kinds, edge list): the
/// derivation is on the critical path of the first check after every filter, and with
/// two it took 0.6x the time on a 1M-vertex scan in arbitrary vertex order.
pub const DERIVATION_THREADS: usize = 2;
/// Without `--max-partition-triangles`, partitions (for services that declare themselves
/// local) have cores of the memory cap over this many triangles: 16M under the default
/// 2 GiB, where smoothing needs ~60 bytes a triangle. A larger mesh is cut only when the
/// service is known not to fit the cap whole, or has just stopped at it.
pub const AUTO_PARTITION_BYTES_PER_TRIANGLE: usize = 128;
/// A partition may grow with its overlap to this many times its core's triangles before
/// partitioning is given up and the service runs on the whole mesh (a reach so long that
/// every partition would hold most of the mesh).
pub const MAX_PARTITION_GROWTH: usize = 4;
/// The smallest block a service may declare (`blocks.block-triangles`): smaller ones would
/// cost a sandbox for every few triangles, so a declaration below it fails the step.
pub const MIN_BLOCK_TRIANGLES: usize = 1_000;
/// (plugin, service) pairs whose guest bytes per triangle a runtime remembers, for what a
/// refusal at the memory limit says; pairs beyond it are not learned.
pub const MAX_REMEMBERED_FOOTPRINTS: usize = 1024;
/// Runs that may wait for a slot; more are refused at once ([`RunError::Busy`]), so a
/// flood of requests cannot park threads (and their meshes) without end.
///
/// [`RunError::Busy`]: crate::RunError::Busy
pub const DEFAULT_QUEUED_RUNS: usize = 8;

// ---- the pooling instance allocator: one slot per concurrent run, reused run after run ----

/// Linear-memory bytes a pool slot keeps resident (zeroed in place) between runs, so the next
/// run does not page-fault on fresh zero pages: a 1M-vertex Laplacian step peaks at ~140 MiB
/// and faulting it in cost ~20 % of the run. Up to `concurrent_runs` times this stays in the
/// host's RSS while idle, below the `concurrent_runs * memory_bytes` it must allow anyway.
pub const LINEAR_MEMORY_KEEP_RESIDENT: usize = 512 << 20;
/// Same for tables (a slot holds at most [`TABLE_ELEMENTS`] 8-byte entries).
pub const TABLE_KEEP_RESIDENT: usize = 1 << 20;
/// Virtual address space reserved per linear memory. 4 GiB covers every 32-bit address, so
/// with the guard below cranelift drops the bounds checks and the base never moves.
pub const MEMORY_RESERVATION: u64 = 4 << 30;
/// Guard pages after a linear memory: loads with an offset below this need no check.
pub const MEMORY_GUARD_BYTES: u64 = 32 << 20;
/// Per run (one component instance): core instances, memories and tables it may have.
/// A component from `wasm32-wasip2` has a handful of core instances, one memory and a few
/// tables; a plugin beyond these fails to load with the pool's message.
pub const CORE_INSTANCES_PER_RUN: u32 = 32;
pub const MEMORIES_PER_RUN: u32 = 2;
pub const TABLES_PER_RUN: u32 = 16;
/// Elements a table may grow to (function pointers: vtables of a large plugin).
pub const TABLE_ELEMENTS: usize = 100_000;

/// Per-runtime limits; every field has a named default above.
#[derive(Clone, Debug)]
pub struct Limits {
    pub deadline: Duration,
    pub memory_bytes: usize,
    /// Wasm fuel per run; `None` turns fuel metering off (it costs ~40 % on tight loops,
    /// and the deadline already bounds time).
    pub fuel: Option<u64>,
    pub concurrent_runs: usize,
    /// Runs waiting for one of the `concurrent_runs` slots before more are refused.
    pub queued_runs: usize,
    /// Triangles of a partition's core when a local service runs on partitions; a mesh
    /// with more is cut. `None`: the memory cap over [`AUTO_PARTITION_BYTES_PER_TRIANGLE`],
    /// and a larger mesh is cut only where the service does not fit the cap whole.
    pub max_partition_triangles: Option<usize>,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            deadline: DEFAULT_DEADLINE,
            memory_bytes: DEFAULT_MEMORY_BYTES,
            fuel: None,
            concurrent_runs: DEFAULT_CONCURRENT_RUNS,
            queued_runs: DEFAULT_QUEUED_RUNS,
            max_partition_triangles: None,
        }
    }
}

/// A memory cap an operator gave that the sandbox cannot honour.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MemoryCapError {
    #[error("the memory cap must be at least 1 MiB")]
    Zero,
    #[error(
        "a memory cap of {mib} MiB is more than a 32-bit guest can address: at most {} MiB",
        MAX_MEMORY_BYTES / MIB
    )]
    TooLarge { mib: u64 },
}

/// The linear-memory limit in bytes for a cap of `mib` MiB, if the sandbox can give it.
pub fn memory_cap_bytes(mib: u64) -> Result<usize, MemoryCapError> {
    match mib {
        0 => Err(MemoryCapError::Zero),
        mib if mib > (MAX_MEMORY_BYTES / MIB) as u64 => Err(MemoryCapError::TooLarge { mib }),
        mib => Ok(mib as usize * MIB),
    }
}

impl Limits {
    /// Triangles of a partition's core: a local service on a larger mesh may be cut.
    pub fn partition_triangles(&self) -> usize {
        self.max_partition_triangles
            .unwrap_or(self.memory_bytes / AUTO_PARTITION_BYTES_PER_TRIANGLE)
            .max(1)
    }

    /// Refuses a memory limit the sandbox cannot honour (none, or beyond 32-bit addresses).
    pub fn check(&self) -> Result<(), MemoryCapError> {
        match self.memory_bytes {
            0 => Err(MemoryCapError::Zero),
            bytes if bytes > MAX_MEMORY_BYTES => {
                Err(MemoryCapError::TooLarge { mib: bytes.div_ceil(MIB) as u64 })
            }
            _ => Ok(()),
        }
    }
}

/// Caps linear memory and remembers that it did, so the error can say which limit hit,
/// and how large the guest's memory grew, so a run can report what it needed.
pub(crate) struct MemoryCap {
    max_bytes: usize,
    pub(crate) exceeded: bool,
    /// The largest size any of the run's memories was granted (its initial size included).
    pub(crate) peak_bytes: usize,
    /// A memory grew beyond its initial size: the peak then tells what the run needed.
    pub(crate) grew: bool,
}

impl MemoryCap {
    pub(crate) fn new(max_bytes: usize) -> Self {
        Self { max_bytes, exceeded: false, peak_bytes: 0, grew: false }
    }
}

impl ResourceLimiter for MemoryCap {
    fn memory_growing(
        &mut self,
        current: usize,
        desired: usize,
        _maximum: Option<usize>,
    ) -> wasmtime::Result<bool> {
        // Instantiation grants the initial size from 0; any later call is a `memory.grow`.
        self.grew |= current > 0;
        if desired > self.max_bytes {
            self.exceeded = true;
            wasmtime::bail!("memory limit of {} bytes exceeded", self.max_bytes);
        }
        self.peak_bytes = self.peak_bytes.max(desired);
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
