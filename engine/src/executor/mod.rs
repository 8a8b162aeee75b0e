//! The concurrent transfer protocol of DESIGN §5: broadcast the input to every host of the
//! plan in parallel, trigger each task as soon as its host is up to date, forward every
//! result in parallel to the hosts that still have work, and keep IF / WHILE on an active
//! task list. A host that fails is marked down and its task moves to another host; a host
//! whose answer cannot be true (`verify`) is marked suspect and its task moves the same way;
//! a busy host is asked again, then left for another (`busy`).
//!
//! A run goes in two phases: the input is loaded on the plan's hosts (`broadcast`) or
//! restored from the record (`resume`), which gives the current mesh; then an [`Executor`]
//! holding it walks the workflow (`control`), running each task on its host or another one
//! (`task`, `failure`, `step_record`), forwarding each filter's result (`forward`), catching
//! up a host that fell behind or joins (`catch_up`), and records the result (`finish`).

mod arbitrate;
mod broadcast;
mod busy;
mod catch_up;
mod control;
mod copies;
mod cost;
mod current;
mod early;
mod error;
mod failure;
mod finish;
mod forward;
mod prefetch;
mod replica;
mod resume;
mod session;
mod step_record;
mod task;
mod to_data;
mod verify;
mod words;

use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Instant;

use error::ExecError;
pub use finish::Keeping;

use crate::plan::Plan;
use crate::record::{Status, StepRecord};
use crate::registry::Registry;
use crate::run::Run;
use crate::workflow::{Task, Transfer, Workflow};
use broadcast::Loaded;
use current::Current;
use replica::Replica;

/// Runs `workflow` on the run's input and records everything in `run`; never panics on a
/// bad host or input, ends with the run completed or failed. A completed run returns what
/// is left to keep its result ([`Keeping::keep`]), which the caller runs before it deletes
/// the host sessions the run opened (`Run::take_sessions`).
///
/// `resumed`: the engine restarted while the run was going. Its recorded steps are taken
/// as done (the control flow is walked again over their recorded results, no host is
/// asked), and the first new task's host fetches the current mesh from a host that held
/// it, or rebuilds it from the input. A resumed run that fails before finishing a new step
/// ends `interrupted` with the reason.
pub async fn execute(
    run: Arc<Run>,
    workflow: Workflow,
    registry: Arc<Registry>,
    resumed: bool,
) -> Option<Keeping> {
    let done = match resumed {
        true => resume::recorded_steps(&run),
        false => VecDeque::new(),
    };
    let resuming_at = done.len();
    if resumed && done.is_empty() {
        resume::start_over(&run);
    }
    run.set_status(Status::Running, None);
    let (outcome, keeping) = match run_workflow(&run, &workflow, registry, done).await {
        Ok(keeping) => (Ok(()), Some(keeping)),
        Err(error) => (Err(error), None),
    };
    finish::conclude(&run, outcome, resumed.then_some(resuming_at));
    keeping
}

/// Plans the run, loads (or restores) its input, then runs the workflow over it.
async fn run_workflow(
    run: &Arc<Run>,
    workflow: &Workflow,
    registry: Arc<Registry>,
    done: VecDeque<StepRecord>,
) -> Result<Keeping, ExecError> {
    let mut plan = Plan::new(workflow, &registry)?;
    // The plugins the plan's hosts may replay, fetched and compiled on each host once it
    // holds the input, while the others still load it and the first tasks run.
    let holders = broadcast::InputHolders::new();
    let prefetches = prefetch::Prefetches::start(run, &registry, &plan, workflow, &holders);
    let early = done.is_empty().then(|| early::EarlyStart::start(run, workflow, &plan, &holders));
    let loaded = match done.is_empty() {
        true => broadcast::broadcast(run, &registry, &mut plan, workflow.quantize, &holders).await,
        false => {
            holders.restored(run.record().input.map(|input| input.vertices));
            resume::restore_input(run)
        }
    };
    holders.over();
    let loaded = loaded?;
    let mut executor = Executor::new(run.clone(), registry, plan, workflow, loaded, done);
    executor.prefetches = prefetches;
    executor.early = early.flatten();
    executor.execute(workflow).await
}

/// A run whose input is loaded: the current mesh, the hosts holding copies of it, and what
/// is needed to rebuild it.
struct Executor {
    run: Arc<Run>,
    registry: Arc<Registry>,
    plan: Plan,
    transfer: Transfer,
    /// The workflow's `quantize`: bits per axis of the grid every session keeps.
    quantize: Option<u32>,
    replicas: Vec<Replica>,
    current: Current,
    /// Every filter run since the input (the run's `input` URL), with its output hash: a
    /// host that must take over when no copy of the current mesh survives replays them
    /// (services are deterministic, so the hashes must match).
    history: Vec<(Task, String)>,
    /// When the last host reply arrived, for the engine-overhead figure.
    last_reply: Instant,
    /// Steps done before an engine restart, taken in order instead of running them.
    done: VecDeque<StepRecord>,
    /// Hosts that held the current mesh when the engine stopped (a resumed run).
    holders: Vec<String>,
    /// Edit-log sizes asked of their producers, which encode the logs after answering;
    /// awaited before the run's result is recorded.
    log_sizes: Vec<tokio::task::JoinHandle<()>>,
    /// Disagreements receivers reported, settled by `arbitrate`.
    disputes: arbitrate::Disputes,
    /// What each step ran on, for a host that must replay it.
    step_inputs: Vec<arbitrate::StepInput>,
    /// Spot checks under way: each a contradiction found, or none.
    spot_checks: Vec<tokio::task::JoinHandle<Option<String>>>,
    /// Plugins the plan's hosts are making ready for the replays to come.
    prefetches: prefetch::Prefetches,
    /// The first task, started on its host before the broadcast ended.
    early: Option<early::EarlyStart>,
}

impl Executor {
    fn new(
        run: Arc<Run>,
        registry: Arc<Registry>,
        plan: Plan,
        workflow: &Workflow,
        loaded: Loaded,
        done: VecDeque<StepRecord>,
    ) -> Self {
        Self {
            run,
            registry,
            plan,
            transfer: workflow.transfer,
            quantize: workflow.quantize,
            replicas: loaded.replicas,
            current: loaded.current,
            history: Vec::new(),
            last_reply: Instant::now(),
            done,
            holders: Vec::new(),
            log_sizes: Vec::new(),
            disputes: Default::default(),
            step_inputs: Vec::new(),
            spot_checks: Vec::new(),
            prefetches: Default::default(),
            early: None,
        }
    }
}
