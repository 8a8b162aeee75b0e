//! Vertex adjacency as CSR arrays: triangles around a vertex, neighbours of a vertex.

use super::csr::Csr;

/// The triangles around each vertex, as CSR: row `v` lists the ids of the triangles that
/// have `v` as a corner, ascending, each once (a triangle with a repeated corner `v` is listed
/// once). Corners `>= vertex_count` are ignored. Unreferenced vertices have empty rows.
///
/// Memory: `4 (V + 1) + 4 × (3T)` bytes.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VertexTriangles {
    csr: Csr,
}

impl VertexTriangles {
    /// Builds the lists by counting sort. O(V + T) time, no allocation besides the result.
    pub fn new(vertex_count: usize, triangles: &[u32]) -> Self {
        let tris = triangles.chunks_exact(3);
        // Corner k of c counts unless it is out of range or repeats an earlier corner.
        let counts =
            |c: &[u32], k: usize| (c[k] as usize) < vertex_count && !c[..k].contains(&c[k]);
        let mut offsets = vec![0u32; vertex_count + 1];
        for c in tris.clone() {
            for k in 0..3 {
                if counts(c, k) {
                    offsets[c[k] as usize + 1] += 1;
                }
            }
        }
        for v in 0..vertex_count {
            offsets[v + 1] += offsets[v];
        }
        let mut items = vec![0u32; offsets[vertex_count] as usize];
        // offsets[v] serves as the write cursor of row v, ending at the start of row v + 1.
        for (t, c) in tris.enumerate() {
            for k in 0..3 {
                if counts(c, k) {
                    let slot = &mut offsets[c[k] as usize];
                    items[*slot as usize] = t as u32;
                    *slot += 1;
                }
            }
        }
        offsets.copy_within(0..vertex_count, 1);
        offsets[0] = 0;
        Self { csr: Csr::from_parts_unchecked(offsets, items) }
    }

    /// The triangles around `v`, ascending. O(1). Panics if `v >= vertex_count`.
    #[inline]
    pub fn of(&self, v: u32) -> &[u32] {
        self.csr.row(v as usize)
    }

    /// The number of vertices (rows). O(1).
    #[inline]
    pub fn vertex_count(&self) -> usize {
        self.csr.len()
    }

    /// The offsets array (`vertex_count + 1` entries).
    #[inline]
    pub fn offsets(&self) -> &[u32] {
        self.csr.offsets()
    }

    /// All triangle ids, row after row.
    #[inline]
    pub fn triangles(&self) -> &[u32] {
        self.csr.items()
    }

    /// The underlying CSR.
    #[inline]
    pub fn csr(&self) -> &Csr {
        &self.csr
    }

    /// Gives back the underlying CSR.
    pub fn into_csr(self) -> Csr {
        self.csr
    }
}

/// The distinct neighbours of each vertex, as CSR: row `v` lists, ascending and without
/// duplicates, every vertex `w != v` sharing a triangle edge with `v`. Since every two corners
/// of a triangle are joined by an edge, that is every other in-range corner of every triangle
/// around `v` (a degenerate triangle `(a, a, b)` joins `a` and `b`; it adds no self-loop).
///
/// Memory: `4 (V + 1) + 4 × Σ degree` bytes (about `4 V + 24 V` on a closed scan).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct VertexNeighbours {
    csr: Csr,
}

impl VertexNeighbours {
    /// Builds the neighbour lists. O(V + T log d) time with `d` the vertex degree; builds a
    /// [`VertexTriangles`] on the way (use [`Self::from_vertex_triangles`] if you have one).
    pub fn new(vertex_count: usize, triangles: &[u32]) -> Self {
        Self::from_vertex_triangles(&VertexTriangles::new(vertex_count, triangles), triangles)
    }

    /// Builds the neighbour lists from the triangles around each vertex (which must have been
    /// built from the same `triangles`). O(V + T log d), one small scratch buffer.
    pub fn from_vertex_triangles(vertex_triangles: &VertexTriangles, triangles: &[u32]) -> Self {
        let vertex_count = vertex_triangles.vertex_count();
        let mut offsets = Vec::with_capacity(vertex_count + 1);
        offsets.push(0u32);
        let around = vertex_triangles.triangles().len();
        let mut items = Vec::with_capacity(around + around / 8);
        let mut scratch = Vec::with_capacity(32);
        for v in 0..vertex_count as u32 {
            scratch.clear();
            for &t in vertex_triangles.of(v) {
                let i = 3 * t as usize;
                for &w in &triangles[i..i + 3] {
                    if w != v && (w as usize) < vertex_count {
                        scratch.push(w);
                    }
                }
            }
            scratch.sort_unstable();
            scratch.dedup();
            items.extend_from_slice(&scratch);
            offsets.push(items.len() as u32);
        }
        Self { csr: Csr::from_parts_unchecked(offsets, items) }
    }

    /// The neighbours of `v`, ascending. O(1). Panics if `v >= vertex_count`.
    #[inline]
    pub fn of(&self, v: u32) -> &[u32] {
        self.csr.row(v as usize)
    }

    /// Whether `a` and `b` share an edge. O(log d) (binary search). Panics if `a` is out of
    /// range.
    #[inline]
    pub fn contains(&self, a: u32, b: u32) -> bool {
        self.of(a).binary_search(&b).is_ok()
    }

    /// The number of distinct neighbours of `v`. O(1).
    #[inline]
    pub fn degree(&self, v: u32) -> usize {
        self.csr.row_len(v as usize)
    }

    /// The number of vertices (rows). O(1).
    #[inline]
    pub fn vertex_count(&self) -> usize {
        self.csr.len()
    }

    /// The offsets array (`vertex_count + 1` entries).
    #[inline]
    pub fn offsets(&self) -> &[u32] {
        self.csr.offsets()
    }

    /// All neighbour ids, row after row.
    #[inline]
    pub fn neighbours(&self) -> &[u32] {
        self.csr.items()
    }

    /// The underlying CSR.
    #[inline]
    pub fn csr(&self) -> &Csr {
        &self.csr
    }

    /// Gives back the underlying CSR.
    pub fn into_csr(self) -> Csr {
        self.csr
    }
}

/// The vertices `< vertex_count` that no triangle references, ascending. O(V + T).
pub fn unreferenced_vertices(vertex_count: usize, triangles: &[u32]) -> Vec<u32> {
    let mut used = vec![false; vertex_count];
    for &v in &triangles[..triangles.len() / 3 * 3] {
        if let Some(u) = used.get_mut(v as usize) {
            *u = true;
        }
    }
    (0..vertex_count as u32).filter(|&v| !used[v as usize]).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fan_with_defects() {
        // Two triangles, one degenerate (2, 2, 3), one with an out-of-range corner, vertex 5 unused.
        let t = [0, 1, 2, 2, 1, 3, 2, 2, 3, 4, 0, 9];
        let vt = VertexTriangles::new(6, &t);
        assert_eq!(vt.of(0), [0, 3]);
        assert_eq!(vt.of(2), [0, 1, 2]);
        assert_eq!(vt.of(3), [1, 2]);
        assert_eq!(vt.of(5), [] as [u32; 0]);
        assert_eq!(vt.offsets().len(), 7);
        let vn = VertexNeighbours::new(6, &t);
        assert_eq!(vn.of(0), [1, 2, 4]);
        assert_eq!(vn.of(2), [0, 1, 3]);
        assert_eq!(vn.of(4), [0]);
        assert!(vn.contains(3, 2) && !vn.contains(3, 0));
        assert_eq!(unreferenced_vertices(6, &t), [5]);
    }
}
