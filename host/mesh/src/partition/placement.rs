//! Placing a partition's edits in the whole mesh (issue 33). A local service that edits
//! connectivity (degenerate repair) runs on a region of the mesh around everything it
//! changes; its ops are then renamed to the whole mesh's ids: an element the partition has
//! by the id it has in the mesh, an element the ops append by the place it takes after the
//! mesh's own. A partition keeps the mesh's order of ids and the store appends in the order
//! ops create, so the same ops in the same order number what they make as a run on the
//! whole mesh does.

use crate::MeshData;
use crate::store::{MeshStore, Op, REMOVED};

/// An edit made on a partition that has no place in the whole mesh: one over every element
/// (`clear`, `transform`, `set-positions` beside connectivity edits), one over a component,
/// an attribute, or an element it adds attached to nothing of the partition.
#[derive(Clone, Copy, Debug, PartialEq, Eq, thiserror::Error)]
#[error("a `{edit}` edit on a partition has no place in the whole mesh")]
pub struct Unplaceable {
    /// The op's name.
    pub edit: &'static str,
}

/// Where a partition's elements are in the mesh it was cut from.
pub struct Placement<'a> {
    /// The mesh's id of each of the partition's vertices and triangles.
    vertices: &'a [u32],
    triangles: &'a [u32],
    /// The mesh, as the partition was cut from it.
    whole: &'a MeshData,
    /// The ids the partition's first added vertex and triangle take in the mesh.
    added_from: (u32, u32),
}

impl<'a> Placement<'a> {
    pub fn new(vertices: &'a [u32], triangles: &'a [u32], whole: &'a MeshData) -> Self {
        let added_from = (whole.vertex_count() as u32, whole.triangle_count() as u32);
        Self { vertices, triangles, whole, added_from }
    }

    /// The same, for edits placed after others that added elements: the partition's added
    /// elements follow the mesh's `vertex_slots` and `triangle_slots` as they are then.
    pub fn after(self, vertex_slots: u32, triangle_slots: u32) -> Self {
        Self { added_from: (vertex_slots, triangle_slots), ..self }
    }

    /// The mesh's vertices that the partition's edits (the store `edited`) changed: moved or
    /// removed, or a corner of a triangle whose corners changed, before or after, or of a
    /// triangle the edits added. Ascending. Refuses when a vertex the edits added is used by
    /// no triangle: it has no place in the mesh.
    pub fn changed_vertices(&self, edited: &MeshStore) -> Result<Vec<u32>, Unplaceable> {
        let own = self.vertices.len();
        let mut changed = Vec::new();
        let mut added_used = vec![false; (edited.vertex_slots() as usize).saturating_sub(own)];
        let mut mark = |v: u32| match (v as usize).checked_sub(own) {
            None => changed.push(self.vertices[v as usize]),
            Some(added) => {
                if let Some(used) = added_used.get_mut(added) {
                    *used = true;
                }
            }
        };
        let after = edited.triangles().chunks_exact(3);
        for (t, new) in after.enumerate() {
            let Some(&whole) = self.triangles.get(t) else {
                new.iter().copied().filter(|&v| v != REMOVED).for_each(&mut mark);
                continue;
            };
            let old = &self.whole.triangles[3 * whole as usize..][..3];
            if old.iter().zip(new).any(|(&o, &n)| n == REMOVED || self.vertex(n) != o) {
                new.iter().copied().filter(|&v| v != REMOVED).for_each(&mut mark);
                old.iter().map(|&w| self.local(w)).for_each(&mut mark);
            }
        }
        for (v, new) in edited.positions().chunks_exact(3).take(own).enumerate() {
            let old = &self.whole.positions[3 * self.vertices[v] as usize..][..3];
            let moved = old.iter().zip(new).any(|(a, b)| a.to_bits() != b.to_bits());
            if moved || !edited.is_vertex_live(v as u32) {
                changed.push(self.vertices[v]);
            }
        }
        let unattached = added_used
            .iter()
            .enumerate()
            .any(|(added, &used)| !used && edited.is_vertex_live((own + added) as u32));
        if unattached {
            return Err(Unplaceable { edit: "add-vertices" });
        }
        changed.sort_unstable();
        changed.dedup();
        Ok(changed)
    }

    /// `op`, made on the partition, in the mesh's ids (with the partition's earlier ops
    /// placed before it).
    pub fn to_whole(&self, op: Op) -> Result<Op, Unplaceable> {
        let vertices = |ids: Vec<u32>| ids.into_iter().map(|v| self.vertex(v)).collect();
        let triangles = |ids: Vec<u32>| ids.into_iter().map(|t| self.triangle(t)).collect();
        Ok(match op {
            Op::AddVertices { xyz } => Op::AddVertices { xyz },
            Op::MoveVertices { ids, xyz } => Op::MoveVertices { ids: vertices(ids), xyz },
            Op::RemoveVertices { ids } => Op::RemoveVertices { ids: vertices(ids) },
            Op::AddTriangles { abc } => Op::AddTriangles { abc: vertices(abc) },
            Op::RemoveTriangles { ids } => Op::RemoveTriangles { ids: triangles(ids) },
            Op::FlipTriangles { ids } => Op::FlipTriangles { ids: triangles(ids) },
            Op::SplitTriangle { triangle, at } => {
                Op::SplitTriangle { triangle: self.triangle(triangle), at }
            }
            Op::ExtendEdge { edge, vertex } => {
                Op::ExtendEdge { edge: self.edge(edge), vertex: self.vertex(vertex) }
            }
            Op::SplitEdge { edge, at } => Op::SplitEdge { edge: self.edge(edge), at },
            Op::SwapEdge { edge } => Op::SwapEdge { edge: self.edge(edge) },
            Op::CollapseEdge { edge } => Op::CollapseEdge { edge: self.edge(edge) },
            other => return Err(Unplaceable { edit: other.kind().name() }),
        })
    }

    /// A partition's element by its id in the mesh; one its edits appended after the
    /// mesh's own (an id past both stays past both, for the store to refuse).
    fn rename(own: &[u32], added_from: u32, id: u32) -> u32 {
        match own.get(id as usize) {
            Some(&named) => named,
            None => added_from.saturating_add(id - own.len() as u32),
        }
    }

    /// The partition's id of the mesh's vertex `w`, which it has.
    fn local(&self, w: u32) -> u32 {
        self.vertices.binary_search(&w).expect("a partition has its triangles' corners") as u32
    }

    fn vertex(&self, v: u32) -> u32 {
        Self::rename(self.vertices, self.added_from.0, v)
    }

    fn triangle(&self, t: u32) -> u32 {
        Self::rename(self.triangles, self.added_from.1, t)
    }

    /// Half-edge `3t + k` is corner `k`'s edge of triangle `t`.
    fn edge(&self, e: u32) -> u32 {
        self.triangle(e / 3).saturating_mul(3).saturating_add(e % 3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::partition::Partitioning;

    /// A strip of `n` quads, two triangles each, along x.
    fn strip(n: u32) -> MeshData {
        let positions = (0..=n).flat_map(|i| [[i as f32, 0.0, 0.0], [i as f32, 1.0, 0.0]]);
        let triangles = (0..n).flat_map(|i| {
            let (a, b, c, d) = (2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3);
            [a, c, b, b, c, d]
        });
        MeshData::new(positions.flatten().collect(), triangles.collect())
    }

    #[test]
    fn edits_on_a_region_placed_in_the_whole_mesh_give_the_whole_mesh_result() {
        let mesh = strip(40);
        let cut = Partitioning::new(&mesh, 10);
        // Around vertices 30 and 31 (quad 15), with room for what the edits touch.
        let region = cut.region(vec![30, 31], 3, usize::MAX).expect("no bound");
        let local = |v: u32| region.vertices.binary_search(&v).unwrap() as u32;
        let local_triangle = |t: u32| region.triangles.binary_search(&t).unwrap() as u32;
        let ops_on = |vertex: &dyn Fn(u32) -> u32, triangle: &dyn Fn(u32) -> u32| {
            vec![
                // Splits the diagonal of quad 15 (triangle 30's corner 1: 32 -> 31).
                Op::SplitEdge { edge: 3 * triangle(30) + 1, at: None },
                Op::RemoveTriangles { ids: vec![triangle(28)] },
                Op::MoveVertices { ids: vec![vertex(29)], xyz: vec![14.0, 2.0, 0.0] },
                // Collapses quad 16's bottom edge 32 -> 34 (triangle 32's corner 0).
                Op::CollapseEdge { edge: 3 * triangle(32) },
            ]
        };
        let mut partition = MeshStore::new(region.mesh.clone());
        for op in ops_on(&local, &local_triangle) {
            partition.apply(op).unwrap();
        }
        let placement = Placement::new(&region.vertices, &region.triangles, &mesh);
        let mut placed = MeshStore::new(mesh.clone());
        for op in partition.log().to_vec() {
            placed.apply(placement.to_whole(op).unwrap()).unwrap();
        }
        let mut whole = MeshStore::new(mesh.clone());
        for op in ops_on(&|v| v, &|t| t) {
            whole.apply(op).unwrap();
        }
        let changed = placement.changed_vertices(&partition).unwrap();
        // The split's quad (29..=32 with the removed triangle's 28), the moved 29, and the
        // collapse's triangles (32..=36).
        assert_eq!(changed, [28, 29, 30, 31, 32, 33, 34, 35, 36]);
        assert_eq!(placed.finish().0.content_hash(), whole.finish().0.content_hash());
    }

    #[test]
    fn edits_over_the_whole_partition_or_a_vertex_attached_to_nothing_have_no_place() {
        let mesh = strip(8);
        let region = Partitioning::new(&mesh, 4).region(vec![4], 1, usize::MAX).unwrap();
        let placement = Placement::new(&region.vertices, &region.triangles, &mesh);
        for op in [Op::Clear, Op::SetPositions { xyz: region.mesh.positions.clone() }] {
            let name = op.kind().name();
            assert_eq!(placement.to_whole(op), Err(Unplaceable { edit: name }));
        }
        let mut edited = MeshStore::new(region.mesh.clone());
        edited.apply(Op::AddVertices { xyz: vec![0.0, 0.0, 2.0] }).unwrap();
        let error = placement.changed_vertices(&edited).unwrap_err();
        assert_eq!(error, Unplaceable { edit: "add-vertices" });
        // Attached by a triangle, it has a place: by the partition's vertices 0 and 1.
        let v = edited.vertex_slots() - 1;
        edited.apply(Op::AddTriangles { abc: vec![0, 1, v] }).unwrap();
        assert_eq!(placement.changed_vertices(&edited).unwrap(), [2, 3]);
    }
}
