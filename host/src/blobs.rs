//! Blobs: corrections and meshes stored under `DATA/blobs` by name, served with
//! Content-Length and ETag; full output meshes packed on first request; the total size
//! held to a budget.

use std::collections::{HashSet, VecDeque};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};

use axum::body::Body;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, Method, StatusCode, header};
use axum::response::{IntoResponse, Response};

use super::error::ApiError;
use super::meshes::{self, PACKED};
use super::state::Host;
use meshflow_codec::pack;
use meshflow_mesh::MeshData;
use meshflow_meshio as io;

pub struct BlobStore {
    dir: PathBuf,
    budget: u64,
    /// Recent output meshes by full-mesh blob name, newest last: packed only if asked for.
    recent: Mutex<VecDeque<(String, Arc<MeshData>)>>,
    recent_capacity: usize,
    /// Held shared from storing a blob until a session record names it, and exclusively
    /// while evicting, so a blob is never evicted between being written and being needed.
    gate: tokio::sync::RwLock<()>,
}

impl BlobStore {
    pub fn new(dir: PathBuf, budget: u64, recent_capacity: usize) -> Self {
        Self {
            dir,
            budget,
            recent: Mutex::default(),
            recent_capacity,
            gate: tokio::sync::RwLock::new(()),
        }
    }

    pub fn path(&self, name: &str) -> PathBuf {
        self.dir.join(name)
    }

    /// Keeps blobs safe from eviction while held; see `gate`.
    pub async fn writing(&self) -> tokio::sync::RwLockReadGuard<'_, ()> {
        self.gate.read().await
    }

    /// Stores `bytes` as `name`, atomically; a blob already present is left as it is
    /// (names are hashes of the content).
    pub async fn put(&self, name: &str, bytes: Arc<Vec<u8>>) -> Result<(), ApiError> {
        let path = self.path(name);
        tokio::task::spawn_blocking(move || {
            if path.exists() {
                return Ok(());
            }
            io::write_file(&path, |out| out.write_all(&bytes))
        })
        .await?
        .map_err(ApiError::internal)
    }

    pub async fn read(&self, name: &str) -> Result<Vec<u8>, String> {
        tokio::fs::read(self.path(name)).await.map_err(|e| format!("blob {name}: {e}"))
    }

    /// Remembers an output mesh so its full blob can be made later; returns that name.
    pub fn remember(&self, mesh: Arc<MeshData>, content_hash: &str) -> String {
        let name = meshes::full_mesh_name(content_hash);
        let mut recent = self.recent.lock().expect("recent outputs lock");
        recent.retain(|(n, _)| n != &name);
        recent.push_back((name.clone(), mesh));
        while recent.len() > self.recent_capacity {
            recent.pop_front();
        }
        name
    }

    fn recent(&self, name: &str) -> Option<Arc<MeshData>> {
        let recent = self.recent.lock().expect("recent outputs lock");
        recent.iter().find(|(n, _)| n == name).map(|(_, mesh)| mesh.clone())
    }

    /// Deletes the oldest blobs not in `keep` until the total is within the budget.
    /// Returns the names deleted.
    pub async fn evict(&self, keep: HashSet<String>) -> Result<Vec<String>, ApiError> {
        let _exclusive = self.gate.write().await;
        let (dir, budget) = (self.dir.clone(), self.budget);
        tokio::task::spawn_blocking(move || evict_oldest(&dir, budget, &keep))
            .await?
            .map_err(|e| ApiError::internal(format!("evicting blobs: {e}")))
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

/// `GET` and `HEAD /blobs/{name}`.
pub async fn serve(
    State(host): State<Arc<Host>>,
    Path(name): Path<String>,
    method: Method,
    headers: HeaderMap,
) -> Result<Response, ApiError> {
    if !meshes::is_blob_name(&name) {
        return Err(ApiError::not_found("blob", &name));
    }
    let etag = format!("\"{name}\"");
    let path = host.blobs.path(&name);
    if !path.exists() {
        pack_full_mesh(&host, &name).await?;
    }
    let file = match tokio::fs::File::open(&path).await {
        Ok(file) => file,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(ApiError::not_found("blob", &name));
        }
        Err(e) => return Err(ApiError::internal(format!("blob {name}: {e}"))),
    };
    let unchanged = headers
        .get_all(header::IF_NONE_MATCH)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(','))
        .any(|tag| matches!(tag.trim(), "*") || tag.trim() == etag);
    if unchanged {
        return Ok((StatusCode::NOT_MODIFIED, [(header::ETAG, etag)]).into_response());
    }
    let length = file.metadata().await.map_err(ApiError::internal)?.len();
    let content_headers = [
        (header::ETAG, etag),
        (header::CONTENT_LENGTH, length.to_string()),
        (header::CONTENT_TYPE, "application/octet-stream".to_owned()),
        (header::CACHE_CONTROL, "public, max-age=31536000, immutable".to_owned()),
    ];
    let body = if method == Method::HEAD {
        Body::empty()
    } else {
        Body::from_stream(tokio_util::io::ReaderStream::new(file))
    };
    Ok((content_headers, body).into_response())
}

/// Makes the full blob of an output mesh this host still holds (a recent output or a
/// session's current mesh); does nothing for any other name.
async fn pack_full_mesh(host: &Host, name: &str) -> Result<(), ApiError> {
    let Some(hash) = name.strip_suffix(&format!(".{PACKED}")) else { return Ok(()) };
    let Some(mesh) = host.blobs.recent(name).or_else(|| host.sessions.mesh_with_hash(hash)) else {
        return Ok(());
    };
    let packed = tokio::task::spawn_blocking(move || pack::encode(&mesh))
        .await?
        .map_err(|e| ApiError::internal(format!("packing {name}: {e}")))?;
    let _writing = host.blobs.writing().await;
    host.blobs.put(name, Arc::new(packed)).await
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, SystemTime};

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
