//! What can go wrong loading a plugin or running a service, said so a user can act on it.

use std::time::Duration;

pub use meshflow_params::{ParamError, ResultError};

use crate::limits::{MAX_MEMORY_BYTES, MIB, MemoryCapError};

#[derive(Debug, thiserror::Error)]
pub enum PluginError {
    #[error("not a WebAssembly file (it does not start with `\\0asm`)")]
    NotWasm,
    #[error(
        "this is a core WebAssembly module, not a component: build a Rust plugin with \
         `cargo build --release --target wasm32-wasip2` (a cdylib built for that target is a \
         component), or turn a wasm32-wasip1 module (C, C++) into one with \
         `meshflow plugin componentize CORE.wasm -o PLUGIN.wasm`"
    )]
    CoreModule,
    #[error("not a valid WebAssembly component: {0}")]
    Compile(String),
    #[error("the component does not fit the meshflow:geometry/plugin world: {0}")]
    World(String),
    #[error("the component's describe() failed: {0}")]
    Describe(Box<RunError>),
    #[error("the component describes its services wrongly: {0}")]
    Description(String),
    #[error("artefact cache {path}: {source}")]
    Cache { path: String, source: std::io::Error },
    /// The runtime was asked for a memory limit it cannot give.
    #[error(transparent)]
    MemoryCap(#[from] MemoryCapError),
}

#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error("unknown service `{service}`{suggestion}; available services: {available}")]
    UnknownService { service: String, suggestion: String, available: String },
    #[error(transparent)]
    Params(#[from] ParamError),
    #[error("{service}: stopped at the deadline of {deadline:?} (infinite loop or too slow?)")]
    Deadline { service: String, deadline: Duration },
    #[error(
        "{service}: stopped at the memory limit of {limit_mib} MiB{}{}",
        fit.map_or(String::new(), |fit| fit.say(*limit_mib)),
        raise_hint(*limit_mib)
    )]
    Memory { service: String, limit_mib: usize, fit: Option<MemoryFit> },
    #[error("{service}: ran out of fuel ({fuel} units)")]
    Fuel { service: String, fuel: u64 },
    #[error("{service}: stopped after exhausting its edit budget (it kept editing without end?)")]
    EditBudget { service: String },
    #[error("{service}: stopped for printing more than {limit_kib} KiB")]
    Output { service: String, limit_kib: usize },
    #[error("{service}: the plugin crashed: {message}")]
    Trap { service: String, message: String },
    #[error("{service}: {message}")]
    Failed { service: String, message: String },
    #[error("{service}: invalid result: {problem}")]
    BadResult {
        service: String,
        #[source]
        problem: ResultError,
    },
    #[error("{service}: could not start: {message}")]
    Instantiate { service: String, message: String },
    /// A service that declared itself local made an edit on a partition that has no place
    /// in the whole mesh (over every element, a component or an attribute, or adding a
    /// vertex attached to nothing): its result cannot be merged (the declaration is wrong).
    #[error(
        "{service}: declared itself local but made a `{edit}` edit on a partition, which has \
         no place in the whole mesh; run it on a mesh of at most the partition size, or ask \
         its author to fix its `locality.reach`"
    )]
    NotLocal { service: String, edit: &'static str },
    /// A service that declared itself local gave a partition's core another result when
    /// the partition had one ring more: its result reaches further than it declared.
    #[error(
        "{service}: declared a reach of {rings} rings, but a partition's result changed with \
         one ring more, so it depends on more of the mesh than it says; run it on a mesh of \
         at most the partition size, or ask its author to fix its `locality.reach`"
    )]
    ReachExceeded { service: String, rings: u32 },
    /// Every run slot is taken and the queue is full: try again later or elsewhere.
    #[error("{service}: all {slots} run slots are taken and {queued} runs wait already")]
    Busy { service: String, slots: usize, queued: usize },
}

/// What a run stopped at the memory limit tells about the largest mesh its service takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MemoryFit {
    /// Triangles of the mesh it stopped on.
    pub triangles: usize,
    /// Guest bytes per input triangle the service needed on this runtime's earlier runs
    /// that grew its memory (the most of them), if any.
    pub learned_bytes_per_triangle: Option<f64>,
}

impl MemoryFit {
    fn say(&self, limit_mib: usize) -> String {
        if self.triangles == 0 {
            return String::new();
        }
        let limit = (limit_mib * MIB) as f64;
        let mut said = format!(
            ": on this mesh's {} triangles it needed more than {:.0} bytes a triangle",
            self.triangles,
            limit / self.triangles as f64
        );
        if let Some(bytes) = self.learned_bytes_per_triangle {
            let fits = |limit: f64| (limit / bytes) as u64;
            said += &format!(
                "; on earlier runs here it needed {bytes:.0} bytes a triangle, so it takes \
                 meshes of up to about {} triangles under this limit and {} under {} MiB",
                fits(limit),
                fits(MAX_MEMORY_BYTES as f64),
                MAX_MEMORY_BYTES / MIB
            );
        }
        said
    }
}

/// What an operator can do about the memory limit: raise it, up to what a 32-bit guest can
/// address.
fn raise_hint(limit_mib: usize) -> String {
    let max_mib = MAX_MEMORY_BYTES / MIB;
    match limit_mib < max_mib {
        true => format!(" (raise it with --memory-cap, at most {max_mib})"),
        false => " (the most a 32-bit guest can address)".to_owned(),
    }
}
