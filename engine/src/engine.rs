//! The engine's state: its runs (kept in memory and in the store), registered hosts,
//! uploaded inputs and run slots; submitting, re-running and resuming runs, and the
//! background tasks that drive each run and keep the store up to date.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use serde_json::Value as Json;
use tokio::sync::Notify;

use crate::auth::Access;
use crate::limits::{self, JANITOR_INTERVAL, KEPT_RUNS, PERSIST_INTERVAL, UNUSED_INPUT_TTL};
use crate::record::{RunRecord, Status};
use crate::registry::Registry;
use crate::run::{Run, RunParts};
use crate::store::{self, Store, StoreError, StoredRun};
use crate::users::{User, Users};
use crate::workflow::{Workflow, WorkflowError};
use crate::{admission, downloads, executor, inputs, rerun, validate};
use meshflow_api::engine::RerunRequest;

/// The engine's database, in its data folder.
pub(crate) const DATABASE: &str = "engine.sqlite3";

pub struct EngineConfig {
    /// Holds the database (`engine.sqlite3`) and uploaded inputs (`inputs/`); made
    /// readable by this user only.
    pub data_dir: PathBuf,
    /// The URL hosts use to reach this engine (for uploaded inputs).
    pub public_url: String,
    pub access: Access,
}

pub struct Engine {
    pub registry: Arc<Registry>,
    runs: Mutex<RunTable>,
    pub(crate) inputs: inputs::Inputs,
    pub(crate) store: Store,
    admission: admission::Admission,
    downloads: downloads::Downloads,
    /// Told of every change to a run, for the persister.
    changed: Arc<Notify>,
    pub(crate) public_url: String,
    pub(crate) access: Access,
    /// Who may use the API, by token (`--users`, `--api-token`).
    pub(crate) users: Users,
    /// The batches being driven, to cancel and count them.
    pub(crate) batch_drivers: crate::batch_drivers::Drivers,
}

/// Kept runs by id, in the order they were submitted.
#[derive(Default)]
struct RunTable {
    by_id: HashMap<String, Arc<Run>>,
    order: Vec<String>,
}

/// Why a run was not accepted.
#[derive(Debug, thiserror::Error)]
pub enum SubmitError {
    #[error(transparent)]
    Invalid(#[from] WorkflowError),
    #[error("the workflow has no input: give \"input\" in the workflow or with the request")]
    NoInput,
    #[error("input: {}{}", .0, allow_hint(.0))]
    InputRefused(#[from] meshflow_api::fetch_rules::Refusal),
    #[error(transparent)]
    Busy(#[from] admission::Busy),
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("this run cannot be re-run: {0}")]
    NotRerunnable(#[from] rerun::RerunError),
    /// Another user's upload: answered as if it did not exist.
    #[error("no input \"{0}\"")]
    NotYourInput(String),
    #[error("at most {0} batches of one user may be going at once: wait for one to end")]
    TooManyBatches(usize),
}

/// What to do about an input from an origin the engine does not fetch from.
fn allow_hint(refusal: &meshflow_api::fetch_rules::Refusal) -> &'static str {
    match refusal {
        meshflow_api::fetch_rules::Refusal::Origin(_) => {
            " (inputs come from uploads, registered hosts and the origins the engine was \
             started with --allow-input-from; upload the file, or start the engine and its \
             hosts with --allow-input-from <origin>)"
        }
        _ => "",
    }
}

impl Engine {
    /// Opens (or creates) the engine's state under `config.data_dir`. Runs that were in
    /// flight when the engine last stopped are returned to be resumed once hosts are known.
    pub(crate) fn open(
        config: EngineConfig,
    ) -> anyhow::Result<(Arc<Self>, Vec<StoredRun>, Vec<String>)> {
        crate::files::private_dir(&config.data_dir)?;
        let users =
            Users::open(config.access.users_file.as_deref(), config.access.api_token.clone())?;
        let store = Store::open(&config.data_dir.join(DATABASE))?;
        let (stored, hosts) = store.now(|c| Ok((store::load_runs(c)?, store::load_hosts(c)?)))?;
        let changed = Arc::new(Notify::new());
        let public_url = config.public_url.trim_end_matches('/').to_owned();
        let cluster = config.access.cluster_token.clone();
        let engine = Arc::new(Self {
            registry: Arc::new(Registry::new(&public_url, cluster, store.clone())?),
            runs: Mutex::default(),
            inputs: inputs::Inputs::new(config.data_dir.join("inputs"))?,
            store,
            admission: admission::Admission::default(),
            downloads: downloads::Downloads::spooling_in(config.data_dir.join("spool")),
            changed,
            public_url,
            access: config.access,
            users,
            batch_drivers: Default::default(),
        });
        let mut unfinished = Vec::new();
        for stored in stored {
            if stored.record.status.is_final() {
                engine.keep(engine.revive(&stored));
            } else {
                unfinished.push(stored);
            }
        }
        engine.registry.spawn_poller();
        tokio::spawn(persist(Arc::downgrade(&engine)));
        tokio::spawn(janitor(Arc::downgrade(&engine)));
        Ok((engine, unfinished, hosts))
    }

    /// A run object for a stored run.
    fn revive(&self, stored: &StoredRun) -> Arc<Run> {
        Arc::new(Run::new(RunParts {
            id: stored.id.clone(),
            user: stored.user.clone(),
            input: stored.input.clone(),
            record: stored.record.clone(),
            sessions: stored.sessions.clone(),
            changed: self.changed.clone(),
        }))
    }

    /// Validates the workflow against the catalogue, stores the run and starts it; returns
    /// at once. The run is `user`'s, and takes one of their run slots (see [`admission`]).
    pub async fn submit(
        self: &Arc<Self>,
        workflow_json: Json,
        input: Option<String>,
        user: &str,
    ) -> Result<Arc<Run>, SubmitError> {
        self.submit_as(workflow_json, input, user, None).await
    }

    /// Runs a kept run's workflow again with every task pinned to the plugin digest and
    /// the resolved parameters its record holds (or today's plugins, `unpinned`), on the
    /// recorded input or `request.input`; the new record names the run it re-runs.
    pub async fn rerun(
        self: &Arc<Self>,
        original: &Run,
        request: RerunRequest,
        user: &str,
    ) -> Result<Arc<Run>, SubmitError> {
        let record = original.record();
        let workflow = rerun::rerun_workflow(&record, !request.unpinned)?;
        let input = request.input.unwrap_or_else(|| original.input.clone());
        self.submit_as(workflow, Some(input), user, Some(record.id)).await
    }

    async fn submit_as(
        self: &Arc<Self>,
        workflow_json: Json,
        input: Option<String>,
        user: &str,
        rerun_of: Option<String>,
    ) -> Result<Arc<Run>, SubmitError> {
        // The input's origin first: a URL the engine will not fetch is refused whatever the
        // workflow says.
        let mut workflow = Workflow::from_json(&workflow_json)?;
        let input = input.or_else(|| workflow.input.clone()).ok_or(SubmitError::NoInput)?;
        let hosts = self.registry.hosts().into_iter().map(|host| host.url.clone());
        self.access.check_input(&input, &self.public_url, hosts)?;
        self.check_input_owner(&input, user).await?;
        validate::validate(&mut workflow, &*self.registry)?;
        let ticket = self.admission.admit(user)?;
        let id = new_run_id();
        let mut record = RunRecord::new(id.clone(), workflow.transfer);
        record.rerun_of = rerun_of;
        record.workflow = workflow_json;
        record.user = Some(user.to_owned());
        let stored = StoredRun { record, id, user: user.to_owned(), input, sessions: Vec::new() };
        let row = stored.clone();
        self.store.call(move |c| store::insert_run(c, &row)).await?;
        let run = self.revive(&stored);
        self.keep(run.clone());
        tokio::spawn(drive(self.clone(), run.clone(), workflow, ticket, false));
        Ok(run)
    }

    /// Resumes a run the engine was executing when it stopped (see [`executor::execute`]);
    /// one whose workflow no longer reads, or whose user is over their limit, ends
    /// interrupted.
    pub(crate) fn resume(self: &Arc<Self>, stored: StoredRun) {
        let run = self.revive(&stored);
        self.keep(run.clone());
        let interrupted = |reason: String| {
            run.set_status(Status::Interrupted, Some(format!("the engine restarted: {reason}")));
            self.registry.metrics.run_finished(Status::Interrupted);
        };
        match (Workflow::from_json(&stored.record.workflow), self.admission.admit(&stored.user)) {
            (Ok(workflow), Ok(ticket)) => {
                tokio::spawn(drive(self.clone(), run.clone(), workflow, ticket, true));
            }
            (Err(error), _) => interrupted(error.to_string()),
            (_, Err(busy)) => interrupted(busy.to_string()),
        }
    }

    /// Keeps the results of runs that completed just before the engine stopped, once their
    /// hosts are registered again (see [`executor::Keeping::from_record`]).
    pub(crate) fn settle_completed(self: &Arc<Self>) {
        for run in self.runs().into_iter().filter(|run| run.is_finished() && !run.is_settled()) {
            tokio::spawn(keep_after_restart(self.clone(), run));
        }
    }

    pub fn run(&self, id: &str) -> Option<Arc<Run>> {
        self.runs.lock().unwrap().by_id.get(id).cloned()
    }

    pub fn runs(&self) -> Vec<Arc<Run>> {
        let table = self.runs.lock().unwrap();
        table.order.iter().filter_map(|id| table.by_id.get(id).cloned()).collect()
    }

    /// Keeps `run`, forgetting the oldest settled runs beyond [`KEPT_RUNS`] (in memory
    /// here, in the database by the janitor).
    fn keep(&self, run: Arc<Run>) {
        let mut table = self.runs.lock().unwrap();
        while table.order.len() >= KEPT_RUNS {
            let RunTable { by_id, order } = &mut *table;
            let Some(position) = order.iter().position(|id| by_id[id].is_settled()) else {
                break;
            };
            let id = order.remove(position);
            by_id.remove(&id);
        }
        table.order.push(run.id.clone());
        table.by_id.insert(run.id.clone(), run);
    }

    /// Streams `user`'s uploaded input to disk and returns the URL hosts fetch it from.
    pub async fn put_input<E: std::fmt::Display>(
        &self,
        name: &str,
        body: impl futures_util::Stream<Item = Result<bytes::Bytes, E>>,
        user: &str,
    ) -> Result<(String, u64), inputs::InputError> {
        let stored = self.inputs.put(name, body, limits::MAX_INPUT_BYTES).await?;
        let (file, bytes, name) = (stored.file.clone(), stored.bytes, name.to_owned());
        let user = user.to_owned();
        let recorded =
            self.store.call(move |c| store::add_input(c, &file, &name, bytes, &user)).await;
        if let Err(error) = recorded {
            tracing::warn!("recording input {}: {error}", stored.file);
        }
        Ok((format!("{}/inputs/{}", self.public_url, stored.file), stored.bytes))
    }

    /// The stored input `file` if `user` may read it: one they uploaded (an admin: any).
    pub(crate) async fn input_of(&self, file: &str, user: &User) -> Option<std::path::PathBuf> {
        let path = self.inputs.path(file)?;
        if user.is_admin() {
            return Some(path);
        }
        let (file, name) = (file.to_owned(), user.name.clone());
        match self.store.call(move |c| store::input_is_users(c, &file, &name)).await {
            Ok(true) => Some(path),
            Ok(false) => None,
            Err(error) => {
                tracing::warn!("looking up whose input {}: {error}", path.display());
                None
            }
        }
    }

    /// A run may read an input uploaded here only if its user uploaded it (admins: any).
    async fn check_input_owner(&self, input: &str, user: &str) -> Result<(), SubmitError> {
        let prefix = format!("{}/inputs/", self.public_url);
        let Some(file) = input.strip_prefix(&prefix) else { return Ok(()) };
        let admin = self.users.role_of(user).is_some_and(|role| role == crate::users::Role::Admin);
        if admin || self.inputs.path(file).is_none() {
            return Ok(());
        }
        let (lookup, name) = (file.to_owned(), user.to_owned());
        match self.store.call(move |c| store::input_is_users(c, &lookup, &name)).await? {
            true => Ok(()),
            false => Err(SubmitError::NotYourInput(file.chars().take(100).collect())),
        }
    }

    /// Reads a workflow and checks it against the catalogue: what [`Engine::submit`] and
    /// `POST /workflows/validate` both do.
    pub fn check_workflow(&self, workflow_json: &Json) -> Result<Workflow, WorkflowError> {
        let mut workflow = Workflow::from_json(workflow_json)?;
        validate::validate(&mut workflow, &*self.registry)?;
        Ok(workflow)
    }

    /// One mesh of a run (its input, a step's output or its result) as `format`, checked
    /// against the run record's hash; named after the input the run was given.
    pub async fn download(
        &self,
        record: &RunRecord,
        which: downloads::Which,
        format: meshflow_api::host::MeshFileFormat,
    ) -> Result<downloads::Download, downloads::DownloadError> {
        let stem = downloads::stem_of(&self.input_name(record).await);
        self.downloads.mesh(record, which, format, &stem, &*self.registry).await
    }

    /// The name the run's input was uploaded under, else the last part of its URL.
    async fn input_name(&self, record: &RunRecord) -> String {
        let url = record.input.as_ref().map(|i| i.url.clone()).unwrap_or_default();
        self.input_name_of(&url).await
    }

    /// The name an input URL's file was uploaded under, else the URL's last segment.
    async fn input_name_of(&self, url: &str) -> String {
        let file = url.rsplit('/').next().unwrap_or_default().to_owned();
        let lookup = file.clone();
        match self.store.call(move |c| store::input_name(c, &lookup)).await {
            Ok(Some(name)) => name,
            Ok(None) => file,
            Err(error) => {
                tracing::warn!("looking up the name of input {file}: {error}");
                file
            }
        }
    }

    /// Deletes a run's host sessions (best effort: a host that is gone drops them itself).
    async fn close_sessions(&self, run: &Run) {
        let deletions = run.take_sessions().into_iter().map(|open| {
            let client = self.registry.client(&open.host);
            async move {
                if let Err(error) = client.delete_session(&open.session).await {
                    tracing::debug!("deleting session {} on {}: {error}", open.session, open.host);
                }
            }
        });
        futures_util::future::join_all(deletions).await;
    }
}

pub(crate) fn new_run_id() -> String {
    static COUNTER: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
    let count = COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let seed = format!("{:?}{count}{}", std::time::SystemTime::now(), std::process::id());
    blake3::hash(seed.as_bytes()).to_hex()[..16].to_owned()
}

/// Runs `run` once one of its client's slots is free, until it ends or is cancelled, then
/// deletes its host sessions.
async fn drive(
    engine: Arc<Engine>,
    run: Arc<Run>,
    workflow: Workflow,
    ticket: admission::Ticket,
    resumed: bool,
) {
    let cancelled = || run.set_status(Status::Cancelled, Some("cancelled on request".into()));
    let mut keeping = None;
    tokio::select! {
        slot = ticket.slot() => {
            tokio::select! {
                kept = executor::execute(run.clone(), workflow, engine.registry.clone(), resumed) => {
                    keeping = kept;
                }
                () = run.cancelled() => cancelled(),
            }
            drop(slot);
        }
        () = run.cancelled() => cancelled(),
    }
    engine.registry.metrics.run_finished(run.status());
    // The client's place is free once the run has ended; a completed run is past
    // cancelling, and its result is packed before its sessions go.
    drop(ticket);
    if let Some(keeping) = keeping {
        keeping.keep().await;
    }
    engine.close_sessions(&run).await;
}

/// Keeps the result of a run that completed just before the engine stopped (its sessions
/// were kept for that), then deletes its sessions.
async fn keep_after_restart(engine: Arc<Engine>, run: Arc<Run>) {
    match executor::Keeping::from_record(run.clone(), &engine.registry) {
        Some(keeping) => keeping.keep().await,
        None => run.settle(),
    }
    engine.close_sessions(&run).await;
}

/// Writes changed runs to the database, at most every [`PERSIST_INTERVAL`].
async fn persist(engine: std::sync::Weak<Engine>) {
    loop {
        let Some(changed) = engine.upgrade().map(|e| e.changed.clone()) else { return };
        changed.notified().await;
        tokio::time::sleep(PERSIST_INTERVAL).await;
        let Some(engine) = engine.upgrade() else { return };
        let changes: Vec<_> = engine.runs().iter().filter_map(|run| run.take_changes()).collect();
        if let Err(error) = engine.store.call(move |c| store::save_runs(c, &changes)).await {
            tracing::error!("saving runs: {error}");
        }
        if let Some(snapshot) = engine.registry.measured.take_snapshot() {
            let saved = engine.store.call(move |c| store::save_measurements(c, &snapshot)).await;
            if let Err(error) = saved {
                tracing::error!("saving link and speed measurements: {error}");
            }
        }
    }
}

/// Deletes from the database the runs no longer kept, and inputs no kept run names.
async fn janitor(engine: std::sync::Weak<Engine>) {
    loop {
        tokio::time::sleep(JANITOR_INTERVAL).await;
        let Some(engine) = engine.upgrade() else { return };
        engine.registry.forget_down_longer_than(limits::FORGET_DOWN_HOST_AFTER).await;
        let kept: std::collections::HashSet<String> =
            engine.runs().iter().map(|run| run.id.clone()).collect();
        let before = store::unix_now() - UNUSED_INPUT_TTL.as_secs() as i64;
        let swept = engine
            .store
            .call(move |c| {
                for id in store::run_ids(c)? {
                    if !kept.contains(&id) {
                        store::delete_run(c, &id)?;
                    }
                }
                store::take_unused_inputs(c, before)
            })
            .await;
        match swept {
            Ok(files) => files.iter().for_each(|file| engine.inputs.remove(file)),
            Err(error) => tracing::error!("sweeping old runs and inputs: {error}"),
        }
    }
}
