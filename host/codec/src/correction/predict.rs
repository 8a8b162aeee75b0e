//! Predictions both sides compute from the mesh state before an op, so that only the
//! difference between prediction and truth is coded.

use meshflow_topology::VertexTriangles;

use crate::quantize::Grid;
use meshflow_mesh::store::MeshStore;

/// `(a + b + c) / 3` of a live triangle, `None` for an invalid id (the store will refuse it).
pub(crate) fn centroid(store: &MeshStore, triangle: u32) -> Option<[f32; 3]> {
    let [a, b, c] = store.triangle(triangle).ok()?;
    let (a, b, c) = (point(store, a), point(store, b), point(store, c));
    Some(std::array::from_fn(|k| (a[k] + b[k] + c[k]) / 3.0))
}

/// The midpoint of a half-edge of a live triangle.
pub(crate) fn midpoint(store: &MeshStore, edge: u32) -> Option<[f32; 3]> {
    let corners = store.triangle(edge / 3).ok()?;
    let k = (edge % 3) as usize;
    let (a, b) = (point(store, corners[k]), point(store, corners[(k + 1) % 3]));
    Some(std::array::from_fn(|i| (a[i] + b[i]) * 0.5))
}

/// A vertex slot's position (removed slots keep their last one); the origin out of range.
pub(crate) fn point(store: &MeshStore, v: u32) -> [f32; 3] {
    let i = 3 * v as usize;
    match store.positions().get(i..i + 3) {
        Some(p) => [p[0], p[1], p[2]],
        None => [0.0; 3],
    }
}

/// The mean of some points, summed in f64 in the given order.
pub(crate) fn mean(points: impl Iterator<Item = [f32; 3]>) -> Option<[f32; 3]> {
    let (mut sum, mut n) = ([0.0f64; 3], 0u32);
    for p in points {
        for k in 0..3 {
            sum[k] += f64::from(p[k]);
        }
        n += 1;
    }
    (n > 0).then(|| sum.map(|s| (s / f64::from(n)) as f32))
}

/// Each vertex's distinct neighbours, gathered from its triangles when asked for, not
/// stored: lists for every vertex would be several times the size of the mesh, and
/// allocating them (page faults included) cost more than the gathering.
pub(crate) struct Neighbours<'a> {
    triangles: &'a [u32],
    around: VertexTriangles,
}

impl<'a> Neighbours<'a> {
    /// Over triangle slots: removed triangles hold
    /// [`REMOVED`](meshflow_mesh::store::REMOVED), an id past every slot, and are left out.
    pub(crate) fn new(vertex_slots: u32, triangles: &'a [u32]) -> Self {
        Self { triangles, around: VertexTriangles::new(vertex_slots as usize, triangles) }
    }

    /// The f64 mean of `v`'s distinct neighbours in `positions`, summed in ascending id
    /// order as `laplacian-smoothing` does (so its bits are predicted exactly), `None`
    /// without neighbours. `around` is working space, reused from call to call.
    pub(crate) fn mean(
        &self,
        positions: &[f32],
        v: u32,
        around: &mut Vec<u32>,
    ) -> Option<[f64; 3]> {
        around.clear();
        for &t in self.around.of(v) {
            let i = 3 * t as usize;
            // A degenerate triangle may name the vertex itself: not a neighbour.
            around.extend(self.triangles[i..i + 3].iter().filter(|&&n| n != v));
        }
        around.sort_unstable();
        around.dedup();
        if around.is_empty() {
            return None;
        }
        let mut sum = [0.0f64; 3];
        for &n in around.iter() {
            let p = &positions[3 * n as usize..3 * n as usize + 3];
            for k in 0..3 {
                sum[k] += f64::from(p[k]);
            }
        }
        // Divided, not multiplied by a reciprocal: the bits `laplacian-smoothing` produces.
        let n = around.len() as f64;
        Some(sum.map(|s| s / n))
    }
}

/// One step of uniform Laplacian smoothing as both sides predict `set-positions`: a live
/// vertex at `p` with neighbour mean `mean` goes to `λ·mean + (1−λ)·p` per axis in f64 (for
/// λ = 1 exactly the neighbour mean, the bits `laplacian-smoothing` produces), snapped to
/// the grid if any; a vertex without neighbours is predicted to stay.
pub(crate) fn smoothed(
    p: [f32; 3],
    mean: Option<[f64; 3]>,
    lambda: f32,
    grid: Option<Grid>,
) -> [f32; 3] {
    let Some(mean) = mean else { return p };
    let l = f64::from(lambda);
    let q: [f32; 3] = std::array::from_fn(|k| (mean[k] * l + f64::from(p[k]) * (1.0 - l)) as f32);
    match &grid {
        None => q,
        Some(grid) => std::array::from_fn(|k| grid.snap(k, q[k])),
    }
}

/// For each of `count` new vertices (ids `first..first + count`), the other corners of the
/// triangles of `abc` that use it: added triangles tell where added vertices lie.
pub(crate) struct NewVertexNeighbours {
    first: u32,
    start: Vec<u32>,
    ids: Vec<u32>,
}

impl NewVertexNeighbours {
    pub(crate) fn new(first: u32, count: usize, abc: &[u32]) -> Self {
        let new_index = |v: u32| v.checked_sub(first).map(|i| i as usize).filter(|&i| i < count);
        let mut start = vec![0u32; count + 1];
        for t in abc.chunks_exact(3) {
            for &v in t {
                if let Some(i) = new_index(v) {
                    start[i + 1] += 2;
                }
            }
        }
        for i in 0..count {
            start[i + 1] += start[i];
        }
        let mut fill = start.clone();
        let mut ids = vec![0u32; start[count] as usize];
        for t in abc.chunks_exact(3) {
            for k in 0..3 {
                if let Some(i) = new_index(t[k]) {
                    let at = fill[i] as usize;
                    ids[at] = t[(k + 1) % 3];
                    ids[at + 1] = t[(k + 2) % 3];
                    fill[i] += 2;
                }
            }
        }
        Self { first, start, ids }
    }

    /// The predicted position of new vertex `j`: the mean of its neighbours known so far
    /// (old vertices, and new ones before it in `placed`), else the previous new vertex,
    /// else the last old vertex.
    pub(crate) fn predict(&self, store: &MeshStore, placed: &[f32], j: usize) -> [f32; 3] {
        let around = &self.ids[self.start[j] as usize..self.start[j + 1] as usize];
        let known = around.iter().filter_map(|&n| match n.checked_sub(self.first) {
            None => Some(point(store, n)),
            Some(i) if (i as usize) < j => {
                let i = 3 * i as usize;
                Some([placed[i], placed[i + 1], placed[i + 2]])
            }
            Some(_) => None,
        });
        mean(known).unwrap_or_else(|| match j {
            0 => point(store, self.first.wrapping_sub(1)),
            _ => [placed[3 * j - 3], placed[3 * j - 2], placed[3 * j - 1]],
        })
    }
}
