//! Blobs: corrections and meshes stored under `DATA/blobs` by name (the route that serves
//! them is `routes/blobs.rs`); recent output meshes kept to pack on first request; the
//! total size held to a budget.

use std::collections::{HashMap, HashSet, VecDeque};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use super::meshes;
use meshflow_mesh::MeshData;
use meshflow_meshio as io;

/// Why a blob could not be read, stored or evicted.
#[derive(Debug, thiserror::Error)]
pub enum BlobError {
    #[error("blob {name}: {source}")]
    Read {
        name: String,
        #[source]
        source: std::io::Error,
    },
    #[error("storing blob {name}: {message}")]
    Store { name: String, message: String },
    #[error("evicting blobs: {0}")]
    Evict(String),
}

/// A blob just stored, safe from eviction while this lives (see [`BlobStore::put`]).
#[must_use = "drop it only once a session record names the blob"]
pub struct Stored<'a> {
    _gate: tokio::sync::RwLockReadGuard<'a, ()>,
}

pub struct BlobStore {
    dir: PathBuf,
    budget: u64,
    /// Recent output meshes by full-mesh blob name, newest last: packed only if asked for.
    recent: Mutex<VecDeque<(String, Arc<MeshData>)>>,
    recent_capacity: usize,
    /// What the recent outputs' arrays may take together (the newest is always kept).
    recent_bytes: usize,
    /// Held shared from storing a blob until a session record names it, and exclusively
    /// while evicting, so a blob is never evicted between being written and being needed.
    gate: tokio::sync::RwLock<()>,
    /// Outputs being packed, by blob name: a second request for one waits for the first's
    /// packing instead of packing the same mesh again (at a run's end the engine and a
    /// second host may ask at once).
    packing: Mutex<HashMap<String, Arc<tokio::sync::Mutex<()>>>>,
}

/// The right to pack one output (see [`BlobStore::packing`]); its entry goes with the last
/// holder or waiter.
pub struct Packing<'a> {
    store: &'a BlobStore,
    name: String,
    turn: Option<tokio::sync::OwnedMutexGuard<()>>,
}

impl Drop for Packing<'_> {
    fn drop(&mut self) {
        let mut packing = self.store.packing.lock().expect("packing lock");
        // Under the map's lock no one can take a new handle, so the count is exact.
        let turn = self.turn.take().expect("held until dropped");
        let lock = std::sync::Arc::clone(tokio::sync::OwnedMutexGuard::mutex(&turn));
        drop(turn);
        if Arc::strong_count(&lock) == 2 {
            packing.remove(&self.name);
        }
    }
}

impl BlobStore {
    /// A store in `dir` holding at most `budget` bytes of blobs on disk, and at most
    /// `recent_capacity` recent outputs taking `recent_bytes` in memory.
    pub fn new(dir: PathBuf, budget: u64, (recent_capacity, recent_bytes): (usize, usize)) -> Self {
        Self {
            dir,
            budget,
            recent: Mutex::default(),
            recent_capacity,
            recent_bytes,
            gate: tokio::sync::RwLock::new(()),
            packing: Mutex::default(),
        }
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Stores `bytes` as `name`, atomically; a blob already present is left as it is
    /// (names are hashes of the content, or for an edit log of the step it encodes).
    /// The answer keeps the blob safe from eviction until it is dropped: hold it until a
    /// session record names the blob. Taken only here, after any download, so no network
    /// transfer ever holds eviction (and with it every other writer) back.
    pub async fn put(&self, name: &str, bytes: Arc<Vec<u8>>) -> Result<Stored<'_>, BlobError> {
        let gate = self.gate.read().await;
        let path = self.path(name);
        let owned = name.to_owned();
        tokio::task::spawn_blocking(move || {
            if path.exists() {
                return Ok(());
            }
            io::write_private_file(&path, |out| out.write_all(&bytes))
                .map_err(|e| BlobError::Store { name: owned, message: e.to_string() })
        })
        .await
        .map_err(|e| BlobError::Store { name: name.to_owned(), message: e.to_string() })??;
        Ok(Stored { _gate: gate })
    }

    /// [`BlobStore::put`] for a download spooled into the blobs folder: the file is renamed
    /// into place (a blob already present is kept and the file deleted), not written again.
    pub async fn adopt(
        &self,
        name: &str,
        file: tempfile::TempPath,
    ) -> Result<Stored<'_>, BlobError> {
        let gate = self.gate.read().await;
        let path = self.path(name);
        let failed =
            |e: std::io::Error| BlobError::Store { name: name.to_owned(), message: e.to_string() };
        if !path.exists() {
            file.persist(&path).map_err(|e| failed(e.error))?;
        }
        Ok(Stored { _gate: gate })
    }

    pub async fn read(&self, name: &str) -> Result<Vec<u8>, BlobError> {
        tokio::fs::read(self.path(name))
            .await
            .map_err(|source| BlobError::Read { name: name.to_owned(), source })
    }

    /// Remembers an output mesh so its full blob can be made later; returns that name.
    /// The oldest are forgotten beyond the count or the bytes allowed (the newest stays).
    pub fn remember(&self, mesh: Arc<MeshData>, content_hash: &str) -> String {
        let name = meshes::full_mesh_name(content_hash);
        let mut recent = self.recent.lock().expect("recent outputs lock");
        recent.retain(|(n, _)| n != &name);
        recent.push_back((name.clone(), mesh));
        let mut bytes: usize = recent.iter().map(|(_, mesh)| mesh.array_bytes()).sum();
        while recent.len() > self.recent_capacity || (recent.len() > 1 && bytes > self.recent_bytes)
        {
            let (_, oldest) = recent.pop_front().expect("not empty");
            bytes -= oldest.array_bytes();
        }
        name
    }

    /// Waits for the turn to pack output `name`: one packing per name at a time, so whoever
    /// gets it after another should find the blob stored.
    pub async fn packing(&self, name: &str) -> Packing<'_> {
        let lock = {
            let mut packing = self.packing.lock().expect("packing lock");
            Arc::clone(packing.entry(name.to_owned()).or_default())
        };
        let turn = Some(lock.lock_owned().await);
        Packing { store: self, name: name.to_owned(), turn }
    }

    pub fn recent(&self, name: &str) -> Option<Arc<MeshData>> {
        let recent = self.recent.lock().expect("recent outputs lock");
        recent.iter().find(|(n, _)| n == name).map(|(_, mesh)| mesh.clone())
    }

    /// Deletes the oldest blobs not in `keep` until the total is within the budget.
    /// Returns the names deleted.
    pub async fn evict(&self, keep: HashSet<String>) -> Result<Vec<String>, BlobError> {
        let _exclusive = self.gate.write().await;
        let (dir, budget) = (self.dir.clone(), self.budget);
        tokio::task::spawn_blocking(move || evict_oldest(&dir, budget, &keep))
            .await
            .map_err(|e| BlobError::Evict(e.to_string()))?
            .map_err(|e| BlobError::Evict(e.to_string()))
    }
}

fn evict_oldest(
    dir: &std::path::Path,
    budget: u64,
    keep: &HashSet<String>,
) -> std::io::Result<Vec<String>> {
    let mut blobs = Vec::new();
    for entry in std::fs::read_dir(dir)? {
        let entry = entry?;
        let name = entry.file_name().to_string_lossy().into_owned();
        if !meshes::is_blob_name(&name) {
            continue;
        }
        let meta = entry.metadata()?;
        blobs.push((meta.modified()?, meta.len(), name));
    }
    let mut total: u64 = blobs.iter().map(|(_, size, _)| size).sum();
    blobs.sort();
    let mut evicted = Vec::new();
    for (_, size, name) in blobs {
        if total <= budget {
            break;
        }
        if keep.contains(&name) {
            continue;
        }
        match std::fs::remove_file(dir.join(&name)) {
            Ok(()) => {}
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => return Err(e),
        }
        total -= size;
        evicted.push(name);
    }
    Ok(evicted)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, SystemTime};

    #[tokio::test]
    async fn one_packing_per_output_at_a_time_and_no_entry_left_behind() {
        let dir = tempfile::tempdir().unwrap();
        let store = BlobStore::new(dir.path().to_owned(), u64::MAX, (4, usize::MAX));
        let first = store.packing("a.mfm").await;
        let other = store.packing("b.mfm").await;
        let second = store.packing("a.mfm");
        tokio::pin!(second);
        // The second request for "a" waits while the first packs; "b" is not held up.
        let waited = tokio::time::timeout(Duration::from_millis(50), &mut second).await;
        assert!(waited.is_err(), "a second packing of the same output started");
        drop(first);
        let second = tokio::time::timeout(Duration::from_secs(5), second).await.unwrap();
        assert_eq!(store.packing.lock().unwrap().len(), 2);
        drop((second, other));
        assert!(store.packing.lock().unwrap().is_empty());
    }

    #[test]
    fn recent_outputs_are_kept_within_their_count_and_bytes_the_newest_always() {
        let dir = tempfile::tempdir().unwrap();
        // Room for two meshes of 3 vertices and 1 triangle (48 bytes each), or 3 of them.
        let store = BlobStore::new(dir.path().to_owned(), u64::MAX, (3, 100));
        let mesh = |x: f32| Arc::new(MeshData::new(vec![x; 9], vec![0, 1, 2]));
        let names: Vec<String> =
            (0..3u8).map(|i| store.remember(mesh(f32::from(i)), &hex::encode([i; 32]))).collect();
        assert!(store.recent(&names[0]).is_none(), "three outputs of 48 bytes in 100");
        assert!(store.recent(&names[1]).is_some() && store.recent(&names[2]).is_some());
        // An output larger than the whole allowance is still kept while it is the newest.
        let large = Arc::new(MeshData::new(vec![0.0; 300], vec![0, 1, 2]));
        let name = store.remember(large, &hex::encode([9; 32]));
        assert!(store.recent(&name).is_some());
        assert!(store.recent(&names[2]).is_none());
    }

    #[test]
    fn eviction_takes_the_oldest_unneeded_blobs_until_the_budget_holds() {
        let dir = tempfile::tempdir().unwrap();
        let name = |i: u8| format!("{}.mfc", hex::encode([i; 32]));
        let epoch = SystemTime::UNIX_EPOCH + Duration::from_secs(1_000_000);
        for i in 0..4u8 {
            let path = dir.path().join(name(i));
            std::fs::write(&path, [0u8; 100]).unwrap();
            let file = std::fs::File::options().write(true).open(&path).unwrap();
            file.set_modified(epoch + Duration::from_secs(i as u64)).unwrap();
        }
        std::fs::write(dir.path().join(".meshflow-partial.tmp"), [0u8; 1000]).unwrap();
        // Blob 0 is the oldest but needed; 1 and 2 go, and then 200 bytes remain.
        let keep = HashSet::from([name(0)]);
        let evicted = evict_oldest(dir.path(), 250, &keep).unwrap();
        assert_eq!(evicted, vec![name(1), name(2)]);
        assert!(dir.path().join(name(0)).exists() && dir.path().join(name(3)).exists());
        assert!(dir.path().join(".meshflow-partial.tmp").exists());
    }
}
