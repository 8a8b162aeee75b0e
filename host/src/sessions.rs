//! Sessions: one mesh per session, its state, and the record that rebuilds it after a
//! restart (input blob + blobs applied since), kept as `DATA/sessions/<id>.json`. The
//! routes are `routes/sessions.rs`.

use std::collections::{HashMap, HashSet};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use serde::{Deserialize, Serialize};

use meshflow_api::host::{GridSpec, SessionState, SessionStatus};
use meshflow_codec::quantize::{Grid, Spacing};
use meshflow_mesh::MeshData;
use meshflow_meshio as io;

use super::meshes::CurrentMesh;
use tokio_util::sync::CancellationToken;

/// Why a session cannot be used or saved.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("no session `{0}`")]
    NotFound(String),
    #[error("session {0} is busy")]
    Busy(String),
    #[error("session {0} is still loading")]
    Loading(String),
    #[error("session {id} failed: {error}")]
    Failed { id: String, error: String },
    #[error("saving session {id}: {message}")]
    Save { id: String, message: String },
}

/// What rebuilds a session: where its input came from, the blob it was stored as, and
/// the blobs (corrections or full meshes) applied to it since, in order.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SessionRecord {
    pub input_url: String,
    pub input_hash: Option<String>,
    /// `None` until the input has been downloaded and stored.
    pub input: Option<String>,
    pub steps: Vec<String>,
    /// The cluster's origins the engine named with the input (see `Downloads::scope`).
    #[serde(default)]
    pub peers: Vec<String>,
    /// The grid the session keeps its mesh on, as asked.
    #[serde(default)]
    pub grid: Option<GridSpec>,
    /// Blobs this host made for other hosts to fetch (its steps' replays): kept as long
    /// as the session is, though the session itself does not need them.
    #[serde(default)]
    pub offered: Vec<String>,
}

/// How loading went, for the status.
#[derive(Clone, Default)]
pub struct LoadReport {
    pub download_ms: Option<f64>,
    pub load_ms: Option<f64>,
    pub input_bytes: Option<u64>,
    /// What the input file held that the mesh does not keep (`meshflow_meshio::Dropped`).
    pub not_kept: Vec<String>,
}

struct Session {
    state: SessionState,
    current: Option<CurrentMesh>,
    /// Every step's result is snapped back onto it.
    grid: Option<Grid>,
    error: Option<String>,
    times: LoadReport,
    record: SessionRecord,
    last_used: Instant,
    /// Cancelled when the session is deleted: its downloads stop at once.
    cancel: CancellationToken,
}

pub struct Sessions {
    dir: PathBuf,
    table: Mutex<HashMap<String, Session>>,
    /// Woken on every state change, for long polls.
    changed: tokio::sync::Notify,
}

impl Sessions {
    pub fn new(dir: PathBuf) -> Self {
        Self { dir, table: Mutex::default(), changed: tokio::sync::Notify::new() }
    }

    fn table(&self) -> std::sync::MutexGuard<'_, HashMap<String, Session>> {
        self.table.lock().expect("session table lock")
    }

    pub fn count(&self) -> usize {
        self.table().len()
    }

    /// Adds a session in state "loading" and saves its record.
    pub fn insert(&self, id: &str, record: SessionRecord) -> Result<(), SessionError> {
        self.save(id, &record)?;
        let session = Session {
            state: SessionState::Loading,
            current: None,
            grid: None,
            error: None,
            times: LoadReport::default(),
            record,
            last_used: Instant::now(),
            cancel: CancellationToken::new(),
        };
        if let Some(replaced) = self.table().insert(id.to_owned(), session) {
            replaced.cancel.cancel();
        }
        Ok(())
    }

    /// The records saved under `DATA/sessions`, to rebuild after a restart.
    pub fn saved_records(&self) -> Vec<(String, SessionRecord)> {
        let Ok(entries) = std::fs::read_dir(&self.dir) else { return Vec::new() };
        entries
            .flatten()
            .filter_map(|entry| {
                let path = entry.path();
                let id = path.file_name()?.to_str()?.strip_suffix(".json")?.to_owned();
                let text = std::fs::read(&path).ok()?;
                match serde_json::from_slice(&text) {
                    Ok(record) => Some((id, record)),
                    Err(e) => {
                        tracing::warn!(
                            "ignoring unreadable session record {}: {e}",
                            path.display()
                        );
                        None
                    }
                }
            })
            .collect()
    }

    /// The session's input is loaded and its steps replayed: it is ready.
    pub fn loaded(
        &self,
        id: &str,
        input: String,
        current: CurrentMesh,
        grid: Option<Grid>,
        times: LoadReport,
    ) {
        let mut table = self.table();
        let Some(session) = table.get_mut(id) else { return };
        session.grid = grid;
        session.record.input = Some(input);
        if let Err(e) = self.save(id, &session.record) {
            tracing::warn!("session {id}: {e}");
        }
        session.state = SessionState::Ready;
        session.current = Some(current);
        session.times = times;
        drop(table);
        self.changed.notify_waiters();
    }

    /// Loading failed for good: the session stays, failed, until deleted; its record goes,
    /// so a restart does not retry it.
    pub fn fail(&self, id: &str, error: String) {
        tracing::warn!("session {id} failed: {error}");
        let mut table = self.table();
        let Some(session) = table.get_mut(id) else { return };
        session.state = SessionState::Failed;
        session.error = Some(error);
        drop(table);
        let _ = std::fs::remove_file(self.record_path(id));
        self.changed.notify_waiters();
    }

    pub fn status(&self, id: &str) -> Option<SessionStatus> {
        let table = self.table();
        let session = table.get(id)?;
        let current = session.current.as_ref();
        Some(SessionStatus {
            id: id.to_owned(),
            state: session.state,
            hash: current.map(|c| c.hash.clone()),
            vertices: current.map(|c| c.mesh.vertex_count()),
            triangles: current.map(|c| c.mesh.triangle_count()),
            error: session.error.clone(),
            download_ms: session.times.download_ms,
            load_ms: session.times.load_ms,
            input_bytes: session.times.input_bytes,
            not_kept: session.times.not_kept.clone(),
            attributes: current.map(|c| c.mesh.attributes.describe()).unwrap_or_default(),
            grid: session.grid.and_then(|g| match g.spacing() {
                Spacing::Binary(exponents) => Some(exponents),
                Spacing::Decimal(_) => None,
            }),
        })
    }

    /// The status once the session is no longer loading, or when `timeout` is over.
    pub async fn wait_loaded(&self, id: &str, timeout: Duration) -> Option<SessionStatus> {
        let deadline = tokio::time::Instant::now() + timeout;
        loop {
            // Registered before the check, so a change in between is not missed.
            let changed = self.changed.notified();
            tokio::pin!(changed);
            changed.as_mut().enable();
            let status = self.status(id)?;
            if status.state != SessionState::Loading {
                return Some(status);
            }
            if tokio::time::timeout_at(deadline, changed).await.is_err() {
                return self.status(id);
            }
        }
    }

    /// Marks a ready session busy and hands out its mesh; the guard puts it back.
    pub fn begin(&self, id: &str) -> Result<BusyGuard<'_>, SessionError> {
        let mut table = self.table();
        let session = table.get_mut(id).ok_or_else(|| SessionError::NotFound(id.to_owned()))?;
        match session.state {
            SessionState::Ready => {}
            SessionState::Busy => return Err(SessionError::Busy(id.to_owned())),
            SessionState::Loading => return Err(SessionError::Loading(id.to_owned())),
            SessionState::Failed => {
                let error = session.error.clone().unwrap_or_default();
                return Err(SessionError::Failed { id: id.to_owned(), error });
            }
        }
        session.state = SessionState::Busy;
        session.last_used = Instant::now();
        let current = session.current.clone().expect("a ready session has a mesh");
        let grid = session.grid;
        let cancel = session.cancel.clone();
        Ok(BusyGuard { sessions: self, id: id.to_owned(), current, grid, cancel, done: false })
    }

    /// The token a session's downloads stop on; an already cancelled one for a session
    /// that is gone.
    pub fn cancel_token(&self, id: &str) -> CancellationToken {
        match self.table().get(id) {
            Some(session) => session.cancel.clone(),
            None => {
                let gone = CancellationToken::new();
                gone.cancel();
                gone
            }
        }
    }

    /// Deletes a session; its downloads stop at once.
    pub fn remove(&self, id: &str) -> bool {
        // Only ids of the table reach the file system: a request's id is never a path.
        let removed = self.table().remove(id).inspect(|s| s.cancel.cancel()).is_some();
        if removed {
            let _ = std::fs::remove_file(self.record_path(id));
            self.changed.notify_waiters();
        }
        removed
    }

    /// Sessions neither loading nor busy that nobody used for longer than `ttl`.
    pub fn idle_longer_than(&self, ttl: Duration) -> Vec<String> {
        let table = self.table();
        table
            .iter()
            .filter(|(_, s)| !matches!(s.state, SessionState::Loading | SessionState::Busy))
            .filter(|(_, s)| s.last_used.elapsed() > ttl)
            .map(|(id, _)| id.clone())
            .collect()
    }

    /// Every blob some session needs to be rebuilt.
    pub fn needed_blobs(&self) -> HashSet<String> {
        let table = self.table();
        let records = table.values().map(|s| &s.record);
        records.flat_map(|r| r.input.iter().chain(&r.steps).chain(&r.offered).cloned()).collect()
    }

    /// A session's current mesh with this content hash, to pack on request.
    pub fn mesh_with_hash(&self, hash: &str) -> Option<Arc<MeshData>> {
        let table = self.table();
        let mut currents = table.values().filter_map(|s| s.current.as_ref());
        currents.find(|c| c.hash == hash).map(|c| c.mesh.clone())
    }

    fn record_path(&self, id: &str) -> PathBuf {
        self.dir.join(format!("{id}.json"))
    }

    fn save(&self, id: &str, record: &SessionRecord) -> Result<(), SessionError> {
        let fail = |message: String| SessionError::Save { id: id.to_owned(), message };
        let json = serde_json::to_vec_pretty(record).map_err(|e| fail(e.to_string()))?;
        io::write_private_file(&self.record_path(id), |out| out.write_all(&json))
            .map_err(|e| fail(e.to_string()))
    }
}

/// Unique among this host's sessions, also across restarts.
pub fn new_id() -> String {
    use std::sync::atomic::{AtomicU64, Ordering};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut hasher = blake3::Hasher::new();
    let now =
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    hasher.update(&now.as_nanos().to_le_bytes());
    hasher.update(&COUNTER.fetch_add(1, Ordering::Relaxed).to_le_bytes());
    hasher.update(&std::process::id().to_le_bytes());
    hasher.finalize().to_hex()[..16].to_owned()
}

/// A session marked busy; unless [`BusyGuard::commit`] is called it goes back to ready
/// with its mesh unchanged.
pub struct BusyGuard<'a> {
    sessions: &'a Sessions,
    id: String,
    pub current: CurrentMesh,
    pub grid: Option<Grid>,
    /// The session's: cancelled if it is deleted meanwhile.
    pub cancel: CancellationToken,
    done: bool,
}

impl BusyGuard<'_> {
    /// The session's mesh becomes `next`, reached by applying blob `step`.
    pub fn commit(self, next: CurrentMesh, step: String) -> Result<(), SessionError> {
        self.commit_offering(next, step, None)
    }

    /// [`BusyGuard::commit`], keeping blob `offered` for other hosts as long as the session.
    pub fn commit_offering(
        mut self,
        next: CurrentMesh,
        step: String,
        offered: Option<String>,
    ) -> Result<(), SessionError> {
        self.done = true;
        let mut table = self.sessions.table();
        // Deleted while busy: nothing to keep.
        let Some(session) = table.get_mut(&self.id) else { return Ok(()) };
        session.record.steps.push(step);
        session.record.offered.extend(offered);
        session.current = Some(next);
        session.state = SessionState::Ready;
        session.last_used = Instant::now();
        let saved = self.sessions.save(&self.id, &session.record);
        drop(table);
        self.sessions.changed.notify_waiters();
        saved
    }
}

impl Drop for BusyGuard<'_> {
    fn drop(&mut self) {
        if self.done {
            return;
        }
        if let Some(session) = self.sessions.table().get_mut(&self.id) {
            session.state = SessionState::Ready;
            session.last_used = Instant::now();
        }
        self.sessions.changed.notify_waiters();
    }
}
