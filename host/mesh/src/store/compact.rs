//! Deterministic compaction: drop tombstones, keep the survivors' relative order.

use super::REMOVED;
use crate::MeshData;

/// Compacts `mesh` in place: its arrays are the store's own by now, and writing survivors
/// forward into them costs no second allocation of the mesh (whose fresh pages alone took
/// longer than the move).
pub(super) fn compact(mut mesh: MeshData, vertex_removed: &[bool]) -> MeshData {
    let new_id = renumber_vertices(&mut mesh.positions, vertex_removed);
    let triangles = &mut mesh.triangles;
    let mut kept = 0;
    for t in 0..triangles.len() / 3 {
        let i = 3 * t;
        if triangles[i] == REMOVED {
            continue;
        }
        for k in 0..3 {
            // The store removes a vertex's triangles with it, so every corner maps.
            let v = triangles[i + k];
            triangles[kept + k] = new_id.as_ref().map_or(v, |ids| ids[v as usize]);
        }
        kept += 3;
    }
    triangles.truncate(kept);
    debug_assert!(!triangles.contains(&REMOVED));
    mesh
}

/// Moves the live vertices' positions forward; returns the new id of every old one, or
/// `None` if no vertex was removed (every id stays).
fn renumber_vertices(positions: &mut Vec<f32>, vertex_removed: &[bool]) -> Option<Vec<u32>> {
    let first_removed = vertex_removed.iter().position(|&removed| removed)?;
    let mut new_id: Vec<u32> = (0..first_removed as u32).collect();
    new_id.resize(vertex_removed.len(), REMOVED);
    let mut next = first_removed;
    for v in first_removed..vertex_removed.len() {
        if !vertex_removed[v] {
            new_id[v] = next as u32;
            positions.copy_within(3 * v..3 * v + 3, 3 * next);
            next += 1;
        }
    }
    positions.truncate(3 * next);
    Some(new_id)
}
