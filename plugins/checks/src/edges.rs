//! The half-edges of the proper triangles, grouped by undirected edge, lean in memory.
//!
//! Each check is its own sandboxed run, so nothing is shared between them and every byte a
//! check touches is a fresh page of the instance's memory: memory is time. This keeps one
//! `u32` per half-edge (bucketed by the smaller endpoint of its edge, a counting sort) plus
//! one per vertex, about a quarter of a full half-edge structure with twins and kinds. The
//! other endpoint is read back from the triangles, and each bucket (≈ 3 edges) is sorted in
//! a small reused buffer. No hashing; groups come in ascending `(a, b)` order.

use meshflow_sdk::topology::halfedge::next;

/// One half-edge of a group, as `other endpoint << 32 | half-edge id`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Side(u64);

impl Side {
    /// The half-edge id `3t + k`.
    #[inline]
    pub fn half_edge(self) -> u32 {
        self.0 as u32
    }

    /// The triangle the half-edge belongs to.
    #[inline]
    pub fn triangle(self) -> u32 {
        self.half_edge() / 3
    }
}

/// Which half-edges take part.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Members {
    /// Those of proper triangles (three distinct ids below the vertex count): what
    /// manifoldness, orientation and normals look at.
    ProperTriangles,
    /// Every half-edge with two distinct in-range endpoints, so a triangle `(a, a, b)` joins
    /// its neighbours through `{a, b}`: what connectivity looks at.
    AnyEdge,
}

/// Half-edges bucketed by the smaller endpoint of their edge.
pub struct EdgeBuckets<'a> {
    triangles: &'a [u32],
    /// `ends[a]`: one past the last entry of bucket `a` (bucket `a` starts at `ends[a - 1]`).
    ends: Vec<u32>,
    half_edges: Vec<u32>,
}

impl<'a> EdgeBuckets<'a> {
    /// Buckets the half-edges of proper triangles. O(V + T), 4 bytes per half-edge and per
    /// vertex.
    pub fn new(vertex_count: usize, triangles: &'a [u32]) -> Self {
        Self::of(vertex_count, triangles, Members::ProperTriangles)
    }

    /// Buckets the `members` half-edges of `triangles`. O(V + T).
    pub fn of(vertex_count: usize, triangles: &'a [u32], members: Members) -> Self {
        let mut ends = vec![0u32; vertex_count + 1];
        for_each_half_edge(vertex_count, triangles, members, |a, _| ends[a as usize + 1] += 1);
        let mut sum = 0u32;
        for x in ends.iter_mut() {
            sum += *x;
            *x = sum;
        }
        // ends[a] is now where bucket a starts; scattering advances it to where it ends.
        let mut half_edges = vec![0u32; sum as usize];
        for_each_half_edge(vertex_count, triangles, members, |a, h| {
            let slot = &mut ends[a as usize];
            half_edges[*slot as usize] = h;
            *slot += 1;
        });
        ends.pop();
        Self { triangles, ends, half_edges }
    }

    /// Calls `group(a, sides)` for every undirected edge `{a, b}` with `a < b`, in ascending
    /// `(a, b)` order, with its half-edges in ascending id order.
    pub fn for_each_edge(&self, mut group: impl FnMut(u32, &[Side])) {
        let mut sides: Vec<Side> = Vec::with_capacity(32);
        let mut begin = 0usize;
        for (a, &end) in self.ends.iter().enumerate() {
            let bucket = &self.half_edges[begin..end as usize];
            begin = end as usize;
            sides.clear();
            // Both endpoints of h, one of which is a: the xor leaves the other.
            sides.extend(bucket.iter().map(|&h| {
                let b = self.triangles[h as usize] ^ self.triangles[next(h) as usize] ^ a as u32;
                Side((b as u64) << 32 | h as u64)
            }));
            sides.sort_unstable();
            for edge in sides.chunk_by(|x, y| x.0 >> 32 == y.0 >> 32) {
                group(a as u32, edge);
            }
        }
    }

    /// Whether a half-edge of edge `{a, b}` (`a < b`) runs from `a` to `b`.
    #[inline]
    pub fn runs_up(&self, a: u32, side: Side) -> bool {
        self.triangles[side.half_edge() as usize] == a
    }
}

/// Calls `f(smaller endpoint, half-edge id)` for every member half-edge.
#[inline(always)]
fn for_each_half_edge(
    vertex_count: usize,
    triangles: &[u32],
    members: Members,
    mut f: impl FnMut(u32, u32),
) {
    let in_range = |v: u32| (v as usize) < vertex_count;
    for (t, c) in triangles.chunks_exact(3).enumerate() {
        let [x, y, z] = [c[0], c[1], c[2]];
        let h = 3 * t as u32;
        if x != y && y != z && x != z && in_range(x) && in_range(y) && in_range(z) {
            f(x.min(y), h);
            f(y.min(z), h + 1);
            f(z.min(x), h + 2);
        } else if members == Members::AnyEdge {
            for (k, (a, b)) in [(x, y), (y, z), (z, x)].into_iter().enumerate() {
                if a != b && in_range(a) && in_range(b) {
                    f(a.min(b), h + k as u32);
                }
            }
        }
    }
}
