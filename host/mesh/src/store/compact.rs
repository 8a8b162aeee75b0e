//! Deterministic compaction: drop tombstones, keep the survivors' relative order.

use super::REMOVED;
use crate::MeshData;

pub(super) fn compact(positions: &[f32], triangles: &[u32], vertex_removed: &[bool]) -> MeshData {
    let mut new_id = vec![REMOVED; vertex_removed.len()];
    let mut kept_positions = Vec::with_capacity(positions.len());
    let mut next = 0u32;
    for (v, removed) in vertex_removed.iter().enumerate() {
        if !removed {
            new_id[v] = next;
            next += 1;
            kept_positions.extend_from_slice(&positions[3 * v..3 * v + 3]);
        }
    }
    let mut kept_triangles = Vec::with_capacity(triangles.len());
    for corners in triangles.chunks_exact(3).filter(|c| c[0] != REMOVED) {
        // The store removes a vertex's triangles with it, so every corner maps.
        kept_triangles.extend(corners.iter().map(|&v| new_id[v as usize]));
    }
    debug_assert!(!kept_triangles.contains(&REMOVED));
    MeshData::new(kept_positions, kept_triangles)
}
