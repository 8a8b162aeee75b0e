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
    let mut v = first_removed;
    while v < vertex_removed.len() {
        if vertex_removed[v] {
            v += 1;
            continue;
        }
        // A run of live vertices moves in one copy: one call per run, not per vertex.
        let run = vertex_removed[v..]
            .iter()
            .position(|&removed| removed)
            .unwrap_or(vertex_removed.len() - v);
        for (offset, id) in new_id[v..v + run].iter_mut().enumerate() {
            *id = (next + offset) as u32;
        }
        positions.copy_within(3 * v..3 * (v + run), 3 * next);
        next += run;
        v += run;
    }
    positions.truncate(3 * next);
    Some(new_id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn runs_of_live_vertices_move_forward_in_order_and_corners_follow() {
        // Vertex v at (v, 0, 0); 0, 4, 5 and 9 removed, with the triangles using them.
        let positions: Vec<f32> = (0..10).flat_map(|v| [v as f32, 0.0, 0.0]).collect();
        let triangles = vec![1, 2, 3, REMOVED, REMOVED, REMOVED, 6, 7, 8, 3, 6, 1];
        let mut removed = vec![false; 10];
        for v in [0, 4, 5, 9] {
            removed[v] = true;
        }
        let mesh = compact(MeshData::new(positions, triangles), &removed);
        let xs: Vec<f32> = mesh.positions.chunks_exact(3).map(|p| p[0]).collect();
        assert_eq!(xs, [1.0, 2.0, 3.0, 6.0, 7.0, 8.0]);
        assert_eq!(mesh.triangles, [0, 1, 2, 3, 4, 5, 2, 3, 0]);
    }
}
