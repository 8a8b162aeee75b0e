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

use std::collections::HashMap;

use meshflow_plugin_sdk::REMOVED;
use meshflow_plugin_sdk::geometry::{Vec3, point};
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

/// The mesh, with the triangles around the vertices an algorithm works at.
///
/// Repairs touch a few spots of a large mesh, so nothing is built for the rest of it: the
/// around-list of a vertex exists once [`index`](Self::index) was asked for it (one pass
/// over the triangles for any number of vertices) and is kept current by every edit after
/// that. Elements that edits append live in small arrays of their own, so the input arrays
/// are never reallocated (growing a 24 MB array took longer than the whole repair).
pub struct MirrorMesh {
    /// The input's positions and triangle slots; triangles are edited in place.
    positions: Vec<f32>,
    triangles: Vec<u32>,
    /// Appended vertices and triangles, ids following the input's.
    added_positions: Vec<f32>,
    added_triangles: Vec<u32>,
    /// Live triangles around each indexed vertex, ascending.
    rows: HashMap<u32, Vec<u32>>,
    edits: Vec<Edit>,
}

impl MirrorMesh {
    /// Starts from a compact mesh as a run receives it (every triangle live, ids in range).
    /// No vertex is indexed yet.
    pub fn new(positions: Vec<f32>, triangles: Vec<u32>) -> Self {
        Self {
            positions,
            triangles,
            added_positions: Vec::new(),
            added_triangles: Vec::new(),
            rows: HashMap::new(),
            edits: Vec::new(),
        }
    }

    fn input_vertices(&self) -> u32 {
        (self.positions.len() / 3) as u32
    }

    fn input_slots(&self) -> u32 {
        (self.triangles.len() / 3) as u32
    }

    pub fn triangle_slots(&self) -> u32 {
        self.input_slots() + (self.added_triangles.len() / 3) as u32
    }

    pub fn is_triangle_live(&self, t: u32) -> bool {
        t < self.triangle_slots() && self.corners(t)[0] != REMOVED
    }

    /// Corners of slot `t`; a removed triangle reads [`REMOVED`] three times.
    pub fn corners(&self, t: u32) -> [u32; 3] {
        let (array, i) = match t.checked_sub(self.input_slots()) {
            None => (&self.triangles, 3 * t as usize),
            Some(added) => (&self.added_triangles, 3 * added as usize),
        };
        [array[i], array[i + 1], array[i + 2]]
    }

    pub fn point(&self, v: u32) -> Vec3 {
        match v.checked_sub(self.input_vertices()) {
            None => point(&self.positions, v),
            Some(added) => point(&self.added_positions, added),
        }
    }

    /// The corners' positions of live triangle `t`.
    pub fn triangle_points(&self, t: u32) -> [Vec3; 3] {
        self.corners(t).map(|v| self.point(v))
    }

    /// Positions and triangle slots as the host's store holds them after the same edits.
    pub fn to_arrays(&self) -> (Vec<f32>, Vec<u32>) {
        (
            [&self.positions[..], &self.added_positions].concat(),
            [&self.triangles[..], &self.added_triangles].concat(),
        )
    }

    /// The edits applied so far, consecutive removals merged.
    pub fn into_edits(self) -> Vec<Edit> {
        self.edits
    }

    // ---- around-lists --------------------------------------------------------------------

    /// Builds the around-lists of those of `vertices` that have none, in one pass over the
    /// triangles (none if all have one).
    pub fn index(&mut self, vertices: impl IntoIterator<Item = u32>) {
        // Appended vertices get their list when they are made.
        let mut new: Vec<u32> =
            vertices.into_iter().filter(|v| !self.rows.contains_key(v)).collect();
        if new.is_empty() {
            return;
        }
        new.sort_unstable();
        new.dedup();
        // One bit per input vertex: small enough to stay in cache while every corner of a
        // mesh in any vertex order is looked up.
        let mut wanted = vec![0u64; (self.input_vertices() as usize).div_ceil(64)];
        for &v in &new {
            wanted[v as usize / 64] |= 1 << (v % 64);
        }
        for &v in &new {
            // An unreferenced vertex has an empty list.
            self.rows.insert(v, Vec::new());
        }
        let mut hits = Vec::new();
        triangles_touching(&self.triangles, 0, &wanted, &mut hits);
        triangles_touching(&self.added_triangles, self.input_slots(), &wanted, &mut hits);
        for t in hits {
            let c = self.corners(t);
            for (k, &v) in c.iter().enumerate() {
                if is_marked(&wanted, v) && !c[..k].contains(&v) {
                    self.rows.get_mut(&v).expect("listed above").push(t);
                }
            }
        }
    }

    pub fn is_indexed(&self, v: u32) -> bool {
        self.rows.contains_key(&v)
    }

    /// Live triangles having `v` as a corner, ascending. Panics unless `v` is indexed.
    pub fn around(&self, v: u32) -> &[u32] {
        self.rows.get(&v).unwrap_or_else(|| panic!("vertex {v} was never indexed"))
    }

    /// Live triangles having both `a` and `b` as corners, ascending (`a` indexed).
    pub fn triangles_on_edge(&self, a: u32, b: u32) -> Vec<u32> {
        self.around(a).iter().copied().filter(|&t| self.corners(t).contains(&b)).collect()
    }

    /// The vertices sharing a live triangle with indexed `v`, ascending.
    pub fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> =
            self.around(v).iter().flat_map(|&t| self.corners(t)).filter(|&w| w != v).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether some edge at indexed `v` does not have exactly two triangles (a boundary or
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
            self.set_corners(t, [REMOVED; 3]);
        }
        match self.edits.last_mut() {
            Some(Edit::RemoveTriangles(previous)) => previous.extend_from_slice(ids),
            _ => self.edits.push(Edit::RemoveTriangles(ids.to_vec())),
        }
    }

    /// Splits the edge of half-edge `edge` (of a live triangle, no triangle with a repeated
    /// corner on the edge, its start indexed) at `at`. Returns the new vertex and, per
    /// triangle that was on the edge, `(that triangle, the triangle appended for its other
    /// half)`.
    pub fn split_edge_at(&mut self, edge: u32, at: [f32; 3]) -> (u32, Vec<(u32, u32)>) {
        let (a, b) = self.ends(edge);
        let on_edge = self.triangles_on_edge(a, b);
        let v = self.input_vertices() + (self.added_positions.len() / 3) as u32;
        self.added_positions.extend_from_slice(&at);
        self.rows.insert(v, Vec::new());
        let mut halves = Vec::with_capacity(on_edge.len());
        for t in on_edge {
            let (kept, appended) = split_on_edge(self.corners(t), a, b, v)
                .expect("a triangle with distinct corners containing both ends has the edge");
            self.set_corners(t, kept);
            let added = self.triangle_slots();
            self.added_triangles.extend_from_slice(&appended);
            self.link(added, appended);
            halves.push((t, added));
        }
        self.edits.push(Edit::SplitEdge { edge, at, vertex: v });
        (v, halves)
    }

    /// Merges the end of half-edge `edge` into its start (the end indexed).
    pub fn collapse_edge(&mut self, edge: u32) {
        let (a, b) = self.ends(edge);
        for t in self.around(b).to_vec() {
            let corners = self.corners(t);
            let merged = if corners.contains(&a) {
                [REMOVED; 3]
            } else {
                corners.map(|v| if v == b { a } else { v })
            };
            self.set_corners(t, merged);
        }
        self.edits.push(Edit::CollapseEdge { edge });
    }

    fn ends(&self, edge: u32) -> (u32, u32) {
        let c = self.corners(edge / 3);
        (c[(edge % 3) as usize], c[(next(edge) % 3) as usize])
    }

    /// Rewrites slot `t` (`REMOVED` corners remove it), keeping the indexed lists current.
    fn set_corners(&mut self, t: u32, corners: [u32; 3]) {
        self.unlink(t, self.corners(t));
        if corners[0] != REMOVED {
            self.link(t, corners);
        }
        let (array, i) = match t.checked_sub(self.input_slots()) {
            None => (&mut self.triangles, 3 * t as usize),
            Some(added) => (&mut self.added_triangles, 3 * added as usize),
        };
        array[i..i + 3].copy_from_slice(&corners);
    }

    fn unlink(&mut self, t: u32, corners: [u32; 3]) {
        for v in corners {
            if let Some(row) = self.rows.get_mut(&v)
                && let Ok(i) = row.binary_search(&t)
            {
                row.remove(i);
            }
        }
    }

    fn link(&mut self, t: u32, corners: [u32; 3]) {
        for v in corners {
            if let Some(row) = self.rows.get_mut(&v)
                && let Err(i) = row.binary_search(&t)
            {
                row.insert(i, t);
            }
        }
    }
}

/// Whether bit `v` is set; ids beyond the bits (REMOVED, appended vertices) are not.
fn is_marked(bits: &[u64], v: u32) -> bool {
    bits.get(v as usize / 64).is_some_and(|word| word >> (v % 64) & 1 == 1)
}

/// Appends `first + i` for every triangle `i` of `triangles` with a corner marked in
/// `wanted`. The one loop that sees every triangle: `|`, not `||`, so no branch per corner,
/// and not inlined, so the sandbox's compiler keeps its values in registers.
#[inline(never)]
fn triangles_touching(triangles: &[u32], first: u32, wanted: &[u64], out: &mut Vec<u32>) {
    for (t, c) in (first..).zip(triangles.chunks_exact(3)) {
        if is_marked(wanted, c[0]) | is_marked(wanted, c[1]) | is_marked(wanted, c[2]) {
            out.push(t);
        }
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
        let (positions, triangles) = mirror.to_arrays();
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
        mirror.index([0, 1]);
        assert!(mirror.is_indexed(0) && !mirror.is_indexed(2));
        let (v, halves) = mirror.split_edge_at(1, [0.5, 0.5, 0.0]);
        assert_eq!((v, halves), (5, vec![(0, 3), (1, 4)]));
        assert_eq!(mirror.around(5), [0, 1, 3, 4]);
        assert_eq!(mirror.neighbours(5), [0, 1, 2, 3]);
        assert!(!mirror.is_border_vertex(5) && mirror.is_border_vertex(0));
        // Merge vertex 5 into 0: corner 2 of triangle 3 (5, 2, 0) runs 0 -> 5.
        assert_eq!(mirror.corners(3), [5, 2, 0]);
        mirror.collapse_edge(3 * 3 + 2);
        assert!(mirror.around(5).is_empty());
        // Vertex 3 was not indexed before the edits: its list comes from the edited slots.
        mirror.index([3]);
        assert_eq!(mirror.triangles_on_edge(3, 0), [1, 4]);
        mirror.remove_triangles(&[2]);
        mirror.remove_triangles(&[4]);
        assert_eq!(mirror.around(0), [1]);
        assert_eq!(mirror.around(3), [1]);
        assert_store_agrees(&start, mirror);
    }
}
