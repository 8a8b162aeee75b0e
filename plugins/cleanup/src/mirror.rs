//! A plugin-side copy of the mesh that applies local edits with exactly the host store's
//! semantics and records them, so an algorithm that needs to see the result of each edit
//! (repairs that cascade) can work locally and replay the edits on the host afterwards,
//! instead of reading the mesh back after every host call.
//!
//! The store's rules mirrored here (host/mesh/src/store/edges.rs, triangles.rs): new vertices
//! and triangles are appended; `split-edge` walks the live triangles on the edge in
//! ascending id order, each `(x, y, o)` keeping its id as `(x, v, o)` and appending
//! `(v, y, o)`; `collapse-edge` from `a` to `b` removes the triangles having both and turns
//! every other `b` into `a`, then removes `b`; removed triangles read `REMOVED`.

use std::collections::BTreeMap;

use meshflow_plugin_sdk::REMOVED;
use meshflow_plugin_sdk::topology::adjacency::VertexTriangles;
use meshflow_plugin_sdk::topology::edits::split_on_edge;
use meshflow_plugin_sdk::topology::halfedge::next;

/// One recorded edit, in the host's vocabulary.
#[derive(Clone, Debug, PartialEq)]
pub enum Edit {
    RemoveTriangles(Vec<u32>),
    /// `split-edge-at`; `vertex` is the id the host must return for the new vertex.
    SplitEdge {
        edge: u32,
        at: [f32; 3],
        vertex: u32,
    },
    CollapseEdge {
        edge: u32,
    },
}

/// The mesh with the triangles around each vertex. The around-lists of the input are one
/// CSR built at the start; a vertex whose list changes gets its own copy (copy on write),
/// so edits cost nothing for the untouched rest of a large mesh.
pub struct MirrorMesh {
    positions: Vec<f32>,
    triangles: Vec<u32>,
    vertex_removed: Vec<bool>,
    base: VertexTriangles,
    /// Rows changed since the start, ascending triangle ids.
    patched: BTreeMap<u32, Vec<u32>>,
    edits: Vec<Edit>,
}

impl MirrorMesh {
    /// Starts from a compact mesh as a run receives it (every triangle live, ids in range).
    pub fn new(positions: Vec<f32>, triangles: Vec<u32>) -> Self {
        let vertex_count = positions.len() / 3;
        let base = VertexTriangles::new(vertex_count, &triangles);
        Self {
            positions,
            triangles,
            vertex_removed: vec![false; vertex_count],
            base,
            patched: BTreeMap::new(),
            edits: Vec::new(),
        }
    }

    pub fn positions(&self) -> &[f32] {
        &self.positions
    }

    /// `a b c` per triangle slot; removed triangles read [`REMOVED`].
    pub fn triangles(&self) -> &[u32] {
        &self.triangles
    }

    pub fn triangle_slots(&self) -> u32 {
        (self.triangles.len() / 3) as u32
    }

    pub fn is_vertex_live(&self, v: u32) -> bool {
        self.vertex_removed.get(v as usize) == Some(&false)
    }

    pub fn is_triangle_live(&self, t: u32) -> bool {
        self.triangles.get(3 * t as usize).is_some_and(|&a| a != REMOVED)
    }

    pub fn corners(&self, t: u32) -> [u32; 3] {
        let i = 3 * t as usize;
        [self.triangles[i], self.triangles[i + 1], self.triangles[i + 2]]
    }

    /// The edits applied so far, consecutive removals merged.
    pub fn into_edits(self) -> Vec<Edit> {
        self.edits
    }

    /// Live triangles having `v` as a corner, ascending.
    pub fn around(&self, v: u32) -> &[u32] {
        match self.patched.get(&v) {
            Some(row) => row,
            None if (v as usize) < self.base.vertex_count() => self.base.of(v),
            None => &[],
        }
    }

    /// Live triangles having both `a` and `b` as corners, ascending.
    pub fn triangles_on_edge(&self, a: u32, b: u32) -> Vec<u32> {
        self.around(a).iter().copied().filter(|&t| self.corners(t).contains(&b)).collect()
    }

    /// The vertices sharing a live triangle with `v`, ascending.
    pub fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> =
            self.around(v).iter().flat_map(|&t| self.corners(t)).filter(|&w| w != v).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether some edge at `v` does not have exactly two triangles (a boundary or
    /// non-manifold edge).
    pub fn is_border_vertex(&self, v: u32) -> bool {
        self.neighbours(v).into_iter().any(|w| self.triangles_on_edge(v, w).len() != 2)
    }

    // ---- edits -----------------------------------------------------------------------------

    /// Removes live triangles; their vertices stay.
    pub fn remove_triangles(&mut self, ids: &[u32]) {
        if ids.is_empty() {
            return;
        }
        for &t in ids {
            self.kill_triangle(t);
        }
        match self.edits.last_mut() {
            Some(Edit::RemoveTriangles(previous)) => previous.extend_from_slice(ids),
            _ => self.edits.push(Edit::RemoveTriangles(ids.to_vec())),
        }
    }

    /// Splits the edge of half-edge `edge` (of a live triangle, no triangle with a repeated
    /// corner on the edge) at `at`. Returns the new vertex and, per triangle that was on the
    /// edge, `(that triangle, the triangle appended for its other half)`.
    pub fn split_edge_at(&mut self, edge: u32, at: [f32; 3]) -> (u32, Vec<(u32, u32)>) {
        let (a, b) = self.ends(edge);
        let on_edge = self.triangles_on_edge(a, b);
        let v = (self.positions.len() / 3) as u32;
        self.positions.extend_from_slice(&at);
        self.vertex_removed.push(false);
        let mut halves = Vec::with_capacity(on_edge.len());
        for t in on_edge {
            let (kept, appended) = split_on_edge(self.corners(t), a, b, v)
                .expect("a triangle with distinct corners containing both ends has the edge");
            self.set_corners(t, kept);
            halves.push((t, self.push_triangle(appended)));
        }
        self.edits.push(Edit::SplitEdge { edge, at, vertex: v });
        (v, halves)
    }

    /// Merges the end of half-edge `edge` into its start.
    pub fn collapse_edge(&mut self, edge: u32) {
        let (a, b) = self.ends(edge);
        for t in self.around(b).to_vec() {
            let corners = self.corners(t);
            if corners.contains(&a) {
                self.kill_triangle(t);
            } else {
                self.set_corners(t, corners.map(|v| if v == b { a } else { v }));
            }
        }
        self.vertex_removed[b as usize] = true;
        self.edits.push(Edit::CollapseEdge { edge });
    }

    fn ends(&self, edge: u32) -> (u32, u32) {
        (self.triangles[edge as usize], self.triangles[next(edge) as usize])
    }

    fn row_mut(&mut self, v: u32) -> &mut Vec<u32> {
        let base = &self.base;
        self.patched.entry(v).or_insert_with(|| {
            if (v as usize) < base.vertex_count() { base.of(v).to_vec() } else { Vec::new() }
        })
    }

    fn unlink(&mut self, t: u32, corners: [u32; 3]) {
        for (k, &v) in corners.iter().enumerate() {
            if !corners[..k].contains(&v) {
                let row = self.row_mut(v);
                if let Ok(i) = row.binary_search(&t) {
                    row.remove(i);
                }
            }
        }
    }

    fn link(&mut self, t: u32, corners: [u32; 3]) {
        for (k, &v) in corners.iter().enumerate() {
            if !corners[..k].contains(&v) {
                let row = self.row_mut(v);
                if let Err(i) = row.binary_search(&t) {
                    row.insert(i, t);
                }
            }
        }
    }

    fn set_corners(&mut self, t: u32, corners: [u32; 3]) {
        self.unlink(t, self.corners(t));
        self.link(t, corners);
        let i = 3 * t as usize;
        self.triangles[i..i + 3].copy_from_slice(&corners);
    }

    fn push_triangle(&mut self, corners: [u32; 3]) -> u32 {
        let t = self.triangle_slots();
        self.triangles.extend_from_slice(&corners);
        self.link(t, corners);
        t
    }

    fn kill_triangle(&mut self, t: u32) {
        self.unlink(t, self.corners(t));
        let i = 3 * t as usize;
        self.triangles[i..i + 3].fill(REMOVED);
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use meshflow_mesh::MeshData;
    use meshflow_mesh::store::{MeshStore, Op};

    /// Replays the recorded edits through the host's store and checks that every slot of
    /// the result matches the mirror's.
    pub(crate) fn assert_store_agrees(start: &MeshData, mirror: MirrorMesh) {
        let (positions, triangles) = (mirror.positions.clone(), mirror.triangles.clone());
        let mut store = MeshStore::new(start.clone());
        for edit in mirror.into_edits() {
            let op = match edit {
                Edit::RemoveTriangles(ids) => Op::RemoveTriangles { ids },
                Edit::SplitEdge { edge, at, .. } => Op::SplitEdge { edge, at: Some(at) },
                Edit::CollapseEdge { edge } => Op::CollapseEdge { edge },
            };
            store.apply(op).expect("the store accepts every mirrored edit");
        }
        assert_eq!(store.triangles(), &triangles[..]);
        assert_eq!(store.positions(), &positions[..]);
    }

    /// Two triangles on the diagonal 1-2 of a unit square, and a third on edge 0-1 below.
    fn mesh() -> MeshData {
        MeshData::new(
            vec![0., 0., 0., 1., 0., 0., 0., 1., 0., 1., 1., 0., 0.5, -1., 0.],
            vec![0, 1, 2, 2, 1, 3, 1, 0, 4],
        )
    }

    #[test]
    fn splits_collapses_and_removals_match_the_store() {
        let start = mesh();
        let mut mirror = MirrorMesh::new(start.positions.clone(), start.triangles.clone());
        let (v, halves) = mirror.split_edge_at(1, [0.5, 0.5, 0.0]);
        assert_eq!((v, halves), (5, vec![(0, 3), (1, 4)]));
        assert_eq!(mirror.around(5), [0, 1, 3, 4]);
        assert_eq!(mirror.neighbours(5), [0, 1, 2, 3]);
        assert!(!mirror.is_border_vertex(5) && mirror.is_border_vertex(0));
        // Merge vertex 5 into 0: corner 2 of triangle 3 (5, 2, 0) runs 0 -> 5.
        assert_eq!(mirror.corners(3), [5, 2, 0]);
        mirror.collapse_edge(3 * 3 + 2);
        assert!(!mirror.is_vertex_live(5));
        assert_eq!(mirror.triangles_on_edge(0, 3), [1, 4]);
        mirror.remove_triangles(&[2]);
        mirror.remove_triangles(&[4]);
        assert_eq!(mirror.around(0), [1]);
        assert_store_agrees(&start, mirror);
    }
}
