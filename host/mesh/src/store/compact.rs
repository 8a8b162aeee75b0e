//! Deterministic compaction: drop tombstones, keep the survivors' relative order.

use super::REMOVED;
use crate::MeshData;
use crate::attributes::Domain;

/// Compacts `mesh` in place: its arrays are the store's own by now, and writing survivors
/// forward into them costs no second allocation of the mesh (whose fresh pages alone took
/// longer than the move).
pub(super) fn compact(mut mesh: MeshData, vertex_removed: &[bool]) -> MeshData {
    if !mesh.attributes.is_empty() {
        keep_live_attributes(&mut mesh, vertex_removed);
    }
    let new_ids = move_live_vertices(&mut mesh.positions, vertex_removed);
    // One loop per way of finding new ids, so the choice is not made again for every corner.
    match new_ids {
        None => keep_live_triangles(&mut mesh.triangles, |v| v),
        Some(NewIds::Sparse { removed, below_block }) => {
            keep_live_triangles(&mut mesh.triangles, |v| sparse_new_id(&removed, &below_block, v))
        }
        Some(NewIds::Table(table)) => {
            keep_live_triangles(&mut mesh.triangles, |v| table[v as usize])
        }
    }
    mesh
}

/// Drops the values of removed vertices, triangles and their corners, keeping order.
fn keep_live_attributes(mesh: &mut MeshData, vertex_removed: &[bool]) {
    let vertex_live: Vec<bool> = vertex_removed.iter().map(|&removed| !removed).collect();
    let face_live: Vec<bool> = mesh.triangles.chunks_exact(3).map(|c| c[0] != REMOVED).collect();
    for domain in [Domain::Vertex, Domain::Face, Domain::Corner] {
        for a in mesh.attributes.of_domain_mut(domain) {
            let (keep, per) = match domain {
                Domain::Vertex => (&vertex_live, usize::from(a.components)),
                Domain::Face => (&face_live, usize::from(a.components)),
                // A triangle's three corners are one run of 3 × components numbers.
                Domain::Corner => (&face_live, 3 * usize::from(a.components)),
            };
            a.values.retain_elements(per, keep);
        }
    }
}

/// Moves the live triangles forward, their corners renamed by `new_id`.
fn keep_live_triangles(triangles: &mut Vec<u32>, new_id: impl Fn(u32) -> u32) {
    let mut kept = 0;
    for t in 0..triangles.len() / 3 {
        let i = 3 * t;
        let corners = [triangles[i], triangles[i + 1], triangles[i + 2]];
        if corners[0] == REMOVED {
            continue;
        }
        // The store removes a vertex's triangles with it, so every corner maps.
        triangles[kept] = new_id(corners[0]);
        triangles[kept + 1] = new_id(corners[1]);
        triangles[kept + 2] = new_id(corners[2]);
        kept += 3;
    }
    triangles.truncate(kept);
    debug_assert!(!triangles.contains(&REMOVED));
}

/// Moves the live vertices' positions forward, a run of live vertices in one copy; returns
/// their new ids, or `None` if no vertex was removed (every id stays).
fn move_live_vertices(positions: &mut Vec<f32>, vertex_removed: &[bool]) -> Option<NewIds> {
    let first_removed = vertex_removed.iter().position(|&removed| removed)?;
    let mut next = first_removed;
    let mut v = first_removed;
    while v < vertex_removed.len() {
        if vertex_removed[v] {
            v += 1;
            continue;
        }
        let run = vertex_removed[v..]
            .iter()
            .position(|&removed| removed)
            .unwrap_or(vertex_removed.len() - v);
        positions.copy_within(3 * v..3 * (v + run), 3 * next);
        next += run;
        v += run;
    }
    positions.truncate(3 * next);
    Some(NewIds::new(vertex_removed))
}

/// Ids per block of [`NewIds::Sparse`].
const SPARSE_BLOCK_BITS: u32 = 8;
/// Removals are sparse when at most one id in this many is removed.
const SPARSE_RATIO: usize = 4096;
/// Marks a block of [`NewIds::Sparse`] holding a removed id.
const HOLDS_REMOVED: u32 = 1 << 31;

/// A live vertex's new id: its old id less the removed ids below it.
enum NewIds {
    /// Few removed (a repair here and there): per block of ids, how many were removed
    /// below it, flagged if the block holds one, which is then counted in `removed`. A few
    /// kilobytes, so they stay in cache while the corners of a mesh whose ids come in no
    /// particular order are looked up, where a table of every id (4 bytes a vertex) does not.
    Sparse { removed: Vec<u32>, below_block: Vec<u32> },
    /// Many removed: every new id.
    Table(Vec<u32>),
}

impl NewIds {
    fn new(vertex_removed: &[bool]) -> Self {
        // Listed only up to one past the sparse limit: many removals take the table, and
        // listing them all would be work thrown away. Sparse counts stay far below the flag
        // bit: at most 2^32 / SPARSE_RATIO.
        let sparse_limit = vertex_removed.len() / SPARSE_RATIO;
        let removed: Vec<u32> = (0u32..)
            .zip(vertex_removed)
            .filter(|&(_, &gone)| gone)
            .map(|(v, _)| v)
            .take(sparse_limit + 1)
            .collect();
        if removed.len() > sparse_limit {
            let mut next = 0;
            let table = vertex_removed
                .iter()
                .map(|&gone| {
                    next += u32::from(!gone);
                    if gone { REMOVED } else { next - 1 }
                })
                .collect();
            return Self::Table(table);
        }
        let blocks = (vertex_removed.len() >> SPARSE_BLOCK_BITS) + 1;
        let mut below_block = vec![0; blocks];
        let mut gone = removed.iter().peekable();
        for (block, entry) in below_block.iter_mut().enumerate() {
            let start = (block as u32) << SPARSE_BLOCK_BITS;
            let end = start + (1 << SPARSE_BLOCK_BITS);
            let below = removed.len() - gone.len();
            let mut holds = false;
            while gone.next_if(|&&r| r < end).is_some() {
                holds = true;
            }
            *entry = below as u32 | if holds { HOLDS_REMOVED } else { 0 };
        }
        Self::Sparse { removed, below_block }
    }
}

/// [`NewIds::Sparse`]'s new id of live vertex `v`.
fn sparse_new_id(removed: &[u32], below_block: &[u32], v: u32) -> u32 {
    let entry = below_block[(v >> SPARSE_BLOCK_BITS) as usize];
    if entry & HOLDS_REMOVED == 0 {
        v - entry
    } else {
        v - removed.partition_point(|&r| r < v) as u32
    }
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

    #[test]
    fn new_ids_agree_with_counting_whether_removals_are_few_or_many() {
        for step in [5000, 3] {
            let removed: Vec<bool> = (0..20_000).map(|v| v % step == 1).collect();
            let ids = NewIds::new(&removed);
            assert_eq!(matches!(ids, NewIds::Sparse { .. }), step == 5000);
            // Corners naming the live vertices in a scattered order, as a real mesh's do.
            let live: Vec<u32> =
                (0u32..).zip(&removed).filter(|(_, gone)| !**gone).map(|(v, _)| v).collect();
            let expected_id = |v: u32| live.binary_search(&v).unwrap() as u32;
            let order: Vec<u32> = (0..live.len() as u32 / 3 * 3)
                .map(|i| live[(i as usize * 7919) % live.len()])
                .collect();
            let positions = (0..removed.len()).flat_map(|v| [v as f32, 0.0, 0.0]).collect();
            let mesh = compact(MeshData::new(positions, order.clone()), &removed);
            let renamed: Vec<u32> = order.iter().map(|&v| expected_id(v)).collect();
            assert_eq!(mesh.triangles, renamed, "one in {step} removed");
            for (new, &old) in live.iter().enumerate() {
                assert_eq!(mesh.positions[3 * new], old as f32);
            }
        }
    }
}
