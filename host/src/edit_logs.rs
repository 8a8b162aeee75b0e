//! Edit logs encoded after their step is answered (DESIGN §4).
//!
//! Encoding a global step's log is the largest thing a host does after the plugin returns
//! (about 45 ms per 200k moved vertices, with the codec's own prediction), yet receivers
//! mostly take the step's replay or its full mesh. So a step is answered as soon as its
//! result is hashed and named, and its log follows on a thread of its own. The log's name
//! comes from the step's base and result hashes, so its URL is in the answer, and a GET of
//! it waits until it is written (`routes/blobs.rs`).
//!
//! The answer carries the log's *estimated* size, from the bytes per edit the same kind of
//! step's last log took. Those rates are kept in the data folder (`edit-log-rates.json`),
//! so a restarted host estimates its first uniform smoothing as 1 KB, not as 6 bytes per
//! moved vertex (which sent receivers to replay a step whose log was tiny).
//!
//! A log that sets every position (a smoothing step's) is predicted from the neighbour
//! means of the mesh before it, most of its encode and of its apply. They depend on that
//! mesh alone, so they are gathered before the log exists ([`EditLogs::prepare`]): here while
//! the plugin runs, when the same kind of step set every position last time (kept with its
//! rate), and on a receiver while the log downloads (the answer says what the log does).

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use serde::{Deserialize, Serialize};
use tokio::sync::{OwnedSemaphorePermit, Semaphore, watch};
use tokio::task::JoinHandle;

use super::blobs::BlobStore;
use super::config::{
    DEFAULT_EDIT_LOG_BYTES_PER_EDIT, EDIT_LOG_WAIT, ENCODE_BEFORE_ANSWER_EDITS,
    MAX_EDIT_LOG_ESTIMATES, MAX_ENCODING_EDIT_LOGS, MAX_PREPARED_MEANS,
    MAX_PREPARED_MEANS_VERTICES, MIN_EDIT_LOG_BYTES, PREPARE_BELOW_BYTES_PER_EDIT,
};
use super::meshes;
use meshflow_codec::correction::{self, NeighbourMeans};
use meshflow_mesh::store::Op;
use meshflow_mesh::{ContentHash, MeshData};

/// A kind of step: the plugin's digest, the service and its resolved parameters (as JSON),
/// each of which keeps its own bytes per edit (cotangent smoothing costs 40 times uniform).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct StepKind(String);

impl StepKind {
    pub fn of(plugin: &str, service: &str, params: &str) -> Self {
        Self(format!("{plugin}/{service}/{}", blake3::hash(params.as_bytes()).to_hex()))
    }
}

/// A mesh's neighbour means being gathered on a blocking thread.
pub type PreparedMeans = JoinHandle<Prepared>;

/// A mesh's neighbour means, holding one of [`MAX_PREPARED_MEANS`] places until dropped.
pub struct Prepared {
    pub means: NeighbourMeans,
    _place: OwnedSemaphorePermit,
}

/// When means are gathered: beside a plugin's run (on one thread, not to slow it), or
/// while a log downloads (on two: nothing else is done meanwhile).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Beside {
    Run,
    Download,
}

/// What the gathering gave, if it is still wanted: a failed gathering only costs the time
/// to gather again.
pub async fn prepared(means: Option<PreparedMeans>) -> Option<Prepared> {
    means?.await.ok()
}

/// Whether a log starts by setting every position: what prepared means serve.
pub fn sets_positions(log: &[Op]) -> bool {
    matches!(log.first(), Some(Op::SetPositions { .. }))
}

/// A step whose edit log is still to be encoded.
pub struct StepLog {
    pub kind: StepKind,
    pub base: Arc<MeshData>,
    pub base_hash: ContentHash,
    pub log: Vec<Op>,
    pub result: Arc<MeshData>,
    pub result_hash: ContentHash,
    /// The base's neighbour means, if their gathering started while the plugin ran.
    pub prepared: Option<PreparedMeans>,
}

/// What a kind of step's last encoded log taught.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
struct Learned {
    /// Bytes per edit beyond the header: the next log's estimate.
    bytes_per_edit: f64,
    /// It started by setting every position: the next one's means are prepared.
    #[serde(default)]
    sets_positions: bool,
}

type LearnedTable = HashMap<String, Learned>;

pub struct EditLogs {
    pending: Pending,
    /// What each kind of step's last encoded log taught.
    learned: Arc<Mutex<LearnedTable>>,
    /// Where the rates are kept across restarts; none in tests.
    rates_file: Option<PathBuf>,
    /// Each encoding holds a base and a result mesh: a step waits for a slot before its
    /// answer rather than letting them pile up.
    slots: Arc<Semaphore>,
    /// Means gathered ahead and not yet used; none are gathered ahead beyond these (the
    /// encode or apply gathers its own as it goes).
    gatherings: Arc<Semaphore>,
}

impl Default for EditLogs {
    fn default() -> Self {
        Self {
            pending: Pending::default(),
            learned: Arc::default(),
            rates_file: None,
            slots: Arc::new(Semaphore::new(MAX_ENCODING_EDIT_LOGS)),
            gatherings: Arc::new(Semaphore::new(MAX_PREPARED_MEANS)),
        }
    }
}

/// Names being encoded, each with a receiver that closes once its log is written or has
/// failed.
#[derive(Clone, Default)]
struct Pending(Arc<Mutex<HashMap<String, watch::Receiver<()>>>>);

/// A name being encoded: removed from the table however its encoding ends, and dropping
/// the sender then wakes everyone waiting for it.
struct Encoding {
    table: Pending,
    name: String,
    done: watch::Sender<()>,
}

impl Drop for Encoding {
    fn drop(&mut self) {
        // Two sessions taking the same step from the same mesh encode under one name: only
        // this encoding's own entry goes.
        let mut table = self.table.lock();
        if table.get(&self.name).is_some_and(|r| r.same_channel(&self.done.subscribe())) {
            table.remove(&self.name);
        }
    }
}

impl Pending {
    fn lock(&self) -> std::sync::MutexGuard<'_, HashMap<String, watch::Receiver<()>>> {
        self.0.lock().expect("pending edit logs lock")
    }

    fn begin(&self, name: &str) -> Encoding {
        let (done, waiting) = watch::channel(());
        self.lock().insert(name.to_owned(), waiting);
        Encoding { table: self.clone(), name: name.to_owned(), done }
    }

    async fn wait_for(&self, name: &str, limit: Duration) {
        let Some(mut waiting) = self.lock().get(name).cloned() else { return };
        // Only the sender's drop ends the wait: `changed` then reports it closed.
        let _ = tokio::time::timeout(limit, waiting.changed()).await;
    }
}

impl EditLogs {
    /// Edit logs whose rates are kept in `file`, starting from what it holds. A file that
    /// is missing, unreadable or not a table of finite positive rates starts empty (with a
    /// warning for the last two): estimates are only estimates.
    pub fn kept_in(file: PathBuf) -> Self {
        let learned = match std::fs::read(&file) {
            Ok(bytes) => read_learned(&bytes).unwrap_or_else(|| {
                tracing::warn!("ignoring {}: not a table of edit-log rates", file.display());
                HashMap::new()
            }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => HashMap::new(),
            Err(e) => {
                tracing::warn!("ignoring {}: {e}", file.display());
                HashMap::new()
            }
        };
        Self { learned: Arc::new(Mutex::new(learned)), rates_file: Some(file), ..Self::default() }
    }

    fn learned(&self) -> std::sync::MutexGuard<'_, LearnedTable> {
        lock_learned(&self.learned)
    }

    /// Starts gathering `base`'s neighbour means for a step of `kind` about to run, if the
    /// last such step here set every position in a log small enough for receivers to take
    /// it (and so to wait for its encode): a larger one is replayed or sent whole, and its
    /// encode, after the answer, keeps no one waiting, whereas gathering beside the run
    /// slows the run on a busy machine.
    pub fn prepare_for(
        &self,
        kind: &StepKind,
        base: &Arc<MeshData>,
        hash: ContentHash,
    ) -> Option<PreparedMeans> {
        let expected = self
            .learned()
            .get(&kind.0)
            .is_some_and(|l| l.sets_positions && l.bytes_per_edit < PREPARE_BELOW_BYTES_PER_EDIT);
        expected.then(|| self.prepare(base, hash, Beside::Run)).flatten()
    }

    /// Starts gathering `mesh`'s neighbour means, unless it has more than
    /// [`MAX_PREPARED_MEANS_VERTICES`] vertices (25 bytes a vertex, held beside a run or a
    /// download) or [`MAX_PREPARED_MEANS`] are held already: memory stays bounded, and a
    /// log's encode or apply gathers what it needs as it goes, as without.
    pub fn prepare(
        &self,
        mesh: &Arc<MeshData>,
        hash: ContentHash,
        beside: Beside,
    ) -> Option<PreparedMeans> {
        if mesh.vertex_count() > MAX_PREPARED_MEANS_VERTICES {
            return None;
        }
        let place = self.gatherings.clone().try_acquire_owned().ok()?;
        let mesh = mesh.clone();
        Some(tokio::task::spawn_blocking(move || {
            let means = match beside {
                Beside::Run => NeighbourMeans::beside(&mesh, hash),
                Beside::Download => NeighbourMeans::of(&mesh, hash),
            };
            Prepared { means, _place: place }
        }))
    }

    /// Starts encoding `step`'s edit log in the background, once a slot is free, and then
    /// stores it in `blobs`. Returns the log's blob name and its size: the real one for a
    /// step of at most [`ENCODE_BEFORE_ANSWER_EDITS`] edits (whose encode takes a few
    /// milliseconds: less than a wrong estimate costs the receivers), else the estimate.
    pub async fn encode_later(&self, blobs: &Arc<BlobStore>, step: StepLog) -> (String, u64) {
        let permit = self.slots.clone().acquire_owned().await.expect("the slots are never closed");
        let name = meshes::edit_log_name(step.base_hash, step.result_hash);
        let edits: usize = step.log.iter().map(Op::edit_count).sum();
        let estimate = self.estimate(&step.kind, edits);
        let encoding = self.pending.begin(&name);
        let (learned, blobs) = (self.learned.clone(), blobs.clone());
        let rates_file = self.rates_file.clone();
        let job = tokio::spawn(async move {
            let _permit = permit;
            let StepLog { kind, base, base_hash, log, result, result_hash, prepared: means } = step;
            let means = prepared(means).await;
            let encoded = tokio::task::spawn_blocking(move || {
                let means = means.as_ref().map(|p| &p.means);
                let bytes =
                    correction::encode_known(base, base_hash, &log, &result, result_hash, means);
                if let Ok(bytes) = &bytes {
                    let taught = Learned::from(&log, edits, bytes.len());
                    if let Some(kept) = learn(&mut lock_learned(&learned), &kind, edits, taught)
                        && let Some(file) = rates_file
                    {
                        keep_learned(&file, &kept);
                    }
                }
                bytes
            })
            .await;
            let encoded = encoded.map_err(|e| e.to_string());
            let bytes = match encoded.and_then(|r| r.map_err(|e| e.to_string())) {
                Ok(bytes) => bytes,
                Err(e) => {
                    // Receivers asking for it get a 404 and fall back to the full mesh.
                    tracing::warn!("encoding edit log {}: {e}", encoding.name);
                    return None;
                }
            };
            let size = bytes.len() as u64;
            // The session record already names the log: nothing to hold against eviction.
            match blobs.put(&encoding.name, Arc::new(bytes)).await {
                Ok(stored) => drop(stored),
                Err(e) => tracing::warn!("{e}"),
            }
            Some(size)
        });
        if edits > ENCODE_BEFORE_ANSWER_EDITS {
            return (name, estimate);
        }
        // Awaiting the task, not the encode itself: an answer given up on (a caller that
        // hung up) leaves the log to be written all the same.
        let size = job.await.ok().flatten();
        (name, size.unwrap_or(estimate))
    }

    /// Waits, up to [`EDIT_LOG_WAIT`], until every edit log being encoded is written: a host
    /// that stops must not leave a session record naming a log it never wrote.
    pub async fn finish_all(&self) {
        let all = self.slots.acquire_many(MAX_ENCODING_EDIT_LOGS as u32);
        if tokio::time::timeout(EDIT_LOG_WAIT, all).await.is_err() {
            tracing::warn!("stopping with edit logs still being encoded");
        }
    }

    /// Waits, up to [`EDIT_LOG_WAIT`], for the edit log `name` if it is being encoded.
    pub async fn wait_for(&self, name: &str) {
        self.pending.wait_for(name, EDIT_LOG_WAIT).await
    }

    /// A header and the step's last bytes per edit, or a moved vertex's typical cost.
    fn estimate(&self, kind: &StepKind, edits: usize) -> u64 {
        let rate = self
            .learned()
            .get(&kind.0)
            .map_or(DEFAULT_EDIT_LOG_BYTES_PER_EDIT, |l| l.bytes_per_edit);
        MIN_EDIT_LOG_BYTES + (edits as f64 * rate).round() as u64
    }

    #[cfg(test)]
    fn learn(&self, kind: &StepKind, edits: usize, bytes: usize) {
        learn(&mut self.learned(), kind, edits, Learned::from(&[], edits, bytes));
    }
}

impl Learned {
    /// What log `log` of `edits` edits, encoded in `bytes`, teaches.
    fn from(log: &[Op], edits: usize, bytes: usize) -> Self {
        let beyond_header = (bytes as u64).saturating_sub(MIN_EDIT_LOG_BYTES);
        let bytes_per_edit = if edits == 0 { 0.0 } else { beyond_header as f64 / edits as f64 };
        Self { bytes_per_edit, sets_positions: sets_positions(log) }
    }
}

fn lock_learned(learned: &Mutex<LearnedTable>) -> std::sync::MutexGuard<'_, LearnedTable> {
    learned.lock().expect("edit log estimates lock")
}

/// Keeps what `kind`'s last log of `edits` edits taught, within [`MAX_EDIT_LOG_ESTIMATES`]
/// kinds; returns the table as it now is, to be written out without the lock. A log without
/// edits teaches nothing: a hole filler's 143-byte log on a mesh without holes, taken as
/// 143 bytes an edit, later estimated its 58,000 edits on a scan at 8.3 MB (the log was
/// 271 KB) and sent the receiver to replay it.
fn learn(
    table: &mut LearnedTable,
    kind: &StepKind,
    edits: usize,
    taught: Learned,
) -> Option<LearnedTable> {
    if edits == 0 {
        return None;
    }
    if table.len() >= MAX_EDIT_LOG_ESTIMATES && !table.contains_key(&kind.0) {
        table.clear();
    }
    table.insert(kind.0.clone(), taught);
    Some(table.clone())
}

/// A kept table, if it is one: at most [`MAX_EDIT_LOG_ESTIMATES`] kinds with finite rates
/// of at least zero (a log no larger than its header).
fn read_learned(bytes: &[u8]) -> Option<LearnedTable> {
    let table: LearnedTable = serde_json::from_slice(bytes).ok()?;
    let sane = table.len() <= MAX_EDIT_LOG_ESTIMATES
        && table.values().all(|l| l.bytes_per_edit.is_finite() && l.bytes_per_edit >= 0.0);
    sane.then_some(table)
}

/// Writes the table atomically; a failure costs only the next restart's estimates.
fn keep_learned(file: &Path, table: &LearnedTable) {
    let written = meshflow_meshio::write_private_file(file, |out| {
        out.write_all(&serde_json::to_vec(table).expect("a table of numbers serialises"))
    });
    if let Err(e) = written {
        tracing::warn!("keeping edit-log rates in {}: {e}", file.display());
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind(name: &str) -> StepKind {
        StepKind(name.to_owned())
    }

    #[test]
    fn what_logs_taught_is_kept_in_the_data_folder_and_bad_files_are_ignored() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("edit-log-rates.json");
        // Uniform smoothing of 200k vertices: a 1 KB log, 0.005 bytes per moved vertex.
        let smoothing = kind("p/laplacian/u");
        let xyz = vec![0.0; 3 * 200_000];
        let taught = Learned::from(&[Op::SetPositions { xyz }], 200_000, 1_000);
        let learned = learn(&mut HashMap::new(), &smoothing, 200_000, taught).unwrap();
        keep_learned(&file, &learned);
        let restarted = EditLogs::kept_in(file.clone());
        assert_eq!(restarted.estimate(&smoothing, 200_000), 1_000);
        assert_eq!(
            restarted.estimate(&kind("p/other/x"), 1_000),
            MIN_EDIT_LOG_BYTES + (1_000.0 * DEFAULT_EDIT_LOG_BYTES_PER_EDIT) as u64
        );
        // A smoothing step again, after the restart: its means are gathered while it runs;
        // not so for a step of another kind, or for a mesh too large to hold them beside it.
        let runtime = tokio::runtime::Builder::new_current_thread().build().unwrap();
        let _entered = runtime.enter();
        let gathered = |means| runtime.block_on(prepared(means)).expect("gathered");
        let mesh = Arc::new(MeshData::new(vec![0.0; 9], vec![0, 1, 2]));
        let hash = mesh.content_hash();
        drop(gathered(restarted.prepare_for(&smoothing, &mesh, hash)));
        assert!(restarted.prepare_for(&kind("p/other/x"), &mesh, hash).is_none());
        // Cotangent smoothing: every position set, 4.6 bytes a vertex; receivers replay it.
        let cotangent = kind("p/laplacian/c");
        let taught = Learned::from(&[Op::SetPositions { xyz: vec![] }], 200_000, 920_000);
        learn(&mut restarted.learned(), &cotangent, 200_000, taught);
        assert!(restarted.prepare_for(&cotangent, &mesh, hash).is_none());
        let large =
            Arc::new(MeshData::new(vec![0.0; 3 * (MAX_PREPARED_MEANS_VERTICES + 1)], vec![]));
        assert!(restarted.prepare_for(&smoothing, &large, hash).is_none());
        // At most MAX_PREPARED_MEANS held at once; a place comes back once its means go.
        let mut held: Vec<Prepared> = (0..MAX_PREPARED_MEANS)
            .map(|_| gathered(restarted.prepare(&mesh, hash, Beside::Download)))
            .collect();
        assert!(restarted.prepare(&mesh, hash, Beside::Download).is_none());
        held.pop();
        assert!(restarted.prepare(&mesh, hash, Beside::Download).is_some());
        for hostile in [
            &b"not json"[..],
            b"{\"k\": {\"bytes_per_edit\": -1.0}}",
            b"{\"k\": {\"bytes_per_edit\": \"x\"}}",
            b"{\"k\": 0.5}",
            b"[1, 2]",
        ] {
            std::fs::write(&file, hostile).unwrap();
            assert!(EditLogs::kept_in(file.clone()).learned().is_empty(), "{hostile:?}");
        }
        let too_many: LearnedTable = (0..=MAX_EDIT_LOG_ESTIMATES)
            .map(|i| (i.to_string(), Learned { bytes_per_edit: 1.0, sets_positions: false }))
            .collect();
        std::fs::write(&file, serde_json::to_vec(&too_many).unwrap()).unwrap();
        assert!(EditLogs::kept_in(file).learned().is_empty());
    }

    #[tokio::test]
    async fn a_wait_for_a_log_being_encoded_ends_when_its_encoding_does() {
        let pending = Pending::default();
        let encoding = pending.begin("log.mfc");
        let waiter = tokio::spawn({
            let pending = pending.clone();
            async move { pending.wait_for("log.mfc", Duration::from_secs(60)).await }
        });
        tokio::time::sleep(Duration::from_millis(50)).await;
        assert!(!waiter.is_finished(), "the wait ended while the log was being encoded");
        drop(encoding);
        tokio::time::timeout(Duration::from_secs(10), waiter).await.unwrap().unwrap();
        assert!(pending.lock().is_empty());
        // The same step encoded for two sessions: the first to end leaves the other's wait.
        let (first, second) = (pending.begin("same.mfc"), pending.begin("same.mfc"));
        drop(first);
        assert!(pending.lock().contains_key("same.mfc"));
        drop(second);
        assert!(pending.lock().is_empty());
        // A name nobody is encoding is not waited for.
        let unknown = pending.wait_for("other.mfc", Duration::from_secs(60));
        tokio::time::timeout(Duration::from_secs(10), unknown).await.unwrap();
    }

    #[test]
    fn estimates_follow_each_plugins_last_log_and_never_go_below_a_header() {
        let logs = EditLogs::default();
        let unknown =
            |edits| MIN_EDIT_LOG_BYTES + (edits as f64 * DEFAULT_EDIT_LOG_BYTES_PER_EDIT) as u64;
        let (a, holes) = (kind("a"), kind("holes"));
        assert_eq!(logs.estimate(&a, 1000), unknown(1000));
        assert_eq!(logs.estimate(&a, 0), MIN_EDIT_LOG_BYTES);
        // 150 bytes beyond the header for 1000 edits.
        logs.learn(&a, 1000, 250);
        assert_eq!(logs.estimate(&a, 4000), 700);
        assert_eq!(logs.estimate(&kind("b"), 1000), unknown(1000));
        // The hole filler on a mesh without holes: its header alone teaches nothing about
        // the 58,000 edits of the next scan's holes.
        logs.learn(&holes, 0, 143);
        assert_eq!(logs.estimate(&holes, 57_898), unknown(57_898));
        logs.learn(&holes, 57_898, 270_916);
        assert!(logs.estimate(&holes, 57_898).abs_diff(270_916) <= 1);
        for i in 0..MAX_EDIT_LOG_ESTIMATES + 1 {
            logs.learn(&kind(&i.to_string()), 1, 1);
        }
        assert!(logs.learned().len() <= MAX_EDIT_LOG_ESTIMATES);
    }
}
