//! The derived connectivity of recent mesh versions, kept so that the services that follow
//! on one mesh (a workflow's checks, `check --all`) read it instead of each deriving it: on
//! a 1M-vertex scan the derivation costs about as much as a check did in all.
//!
//! A mesh version is one `Arc<MeshData>` allocation: a session's current mesh, shared by
//! every read-only run on it. Entries hold only a `Weak` to it, so the cache keeps no mesh
//! alive and an entry whose mesh is gone can never match again; the mesh cannot change
//! under its entry either (`Arc::get_mut` refuses while a `Weak` exists, so an editor
//! copies). Only read-only runs use the cache: a run that edits derives from its own state.

use std::sync::{Arc, Mutex, OnceLock, Weak};

use crate::DERIVATION_THREADS;
use crate::permits::Permits;
use meshflow_mesh::MeshData;
use meshflow_topology::Connectivity;

/// Mesh versions whose connectivity is kept (about 42 MB each for a 1M-vertex scan): the
/// current mesh of a few sessions at once.
pub const CACHED_MESH_VERSIONS: usize = 4;

struct Entry {
    mesh: Weak<MeshData>,
    /// Derived once, by the first run that asks; the others wait for it.
    connectivity: Arc<OnceLock<Arc<Connectivity>>>,
}

pub(crate) struct ConnectivityCache {
    /// Most recently used first.
    entries: Mutex<Vec<Entry>>,
    /// The runtime's run slots: a derivation takes more threads only when its run is the
    /// only one.
    permits: Arc<Permits>,
}

impl ConnectivityCache {
    pub(crate) fn new(permits: Arc<Permits>) -> Self {
        Self { entries: Mutex::default(), permits }
    }

    /// The connectivity of `mesh`, derived now unless a run on the same version already did.
    pub(crate) fn get(&self, mesh: &Arc<MeshData>) -> Arc<Connectivity> {
        let cell = {
            let mut entries = self.entries.lock().unwrap_or_else(|e| e.into_inner());
            entries.retain(|e| e.mesh.strong_count() > 0);
            let found =
                entries.iter().position(|e| std::ptr::eq(e.mesh.as_ptr(), Arc::as_ptr(mesh)));
            let entry = match found {
                Some(i) => entries.remove(i),
                None => Entry { mesh: Arc::downgrade(mesh), connectivity: Arc::default() },
            };
            let cell = Arc::clone(&entry.connectivity);
            entries.insert(0, entry);
            entries.truncate(CACHED_MESH_VERSIONS);
            cell
        };
        // Outside the lock: runs on other meshes need not wait for this derivation.
        Arc::clone(cell.get_or_init(|| Arc::new(self.derive(mesh))))
    }

    /// The connectivity of a mesh's slots as they are (a removed triangle is not proper),
    /// derived on [`DERIVATION_THREADS`] when no other run holds a slot, else on this
    /// thread: with another run busy (`check --all`'s second instance), more threads only
    /// take its core (0.9x the time of one thread on a 1M scan there).
    pub(crate) fn derive(&self, mesh: &MeshData) -> Connectivity {
        let parts = if self.permits.in_use() <= 1 { DERIVATION_THREADS } else { 1 };
        Connectivity::in_parts(mesh.positions.len() / 3, &mesh.triangles, parts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> MeshData {
        MeshData::new(vec![0.0; 12], vec![0, 1, 2, 0, 2, 3])
    }

    #[test]
    fn one_derivation_per_mesh_version_and_none_kept_for_a_dropped_mesh() {
        let cache = ConnectivityCache::new(Arc::new(Permits::new(1)));
        let mesh = Arc::new(quad());
        let first = cache.get(&mesh);
        assert!(Arc::ptr_eq(&first, &cache.get(&Arc::clone(&mesh))), "the same version");
        assert_eq!(first.edges().len(), 5);
        // Equal contents in another allocation are another version.
        let other = Arc::new(quad());
        assert!(!Arc::ptr_eq(&first, &cache.get(&other)));
        drop(mesh);
        let _ = cache.get(&other);
        assert_eq!(cache.entries.lock().unwrap().len(), 1, "the dropped mesh's entry is gone");
        let meshes: Vec<_> = (0..CACHED_MESH_VERSIONS + 2).map(|_| Arc::new(quad())).collect();
        meshes.iter().for_each(|m| drop(cache.get(m)));
        assert_eq!(cache.entries.lock().unwrap().len(), CACHED_MESH_VERSIONS);
    }
}
