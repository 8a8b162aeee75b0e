//! Half-edges grouped by undirected edge, lean in memory: the base of [`HalfEdges`], and
//! enough on its own for one pass over the edges or for a few twin lookups.
//!
//! In a sandboxed run every byte touched is a fresh page of the instance's memory, so memory
//! is time. This keeps one `u64` per half-edge (its other endpoint and id, bucketed by the
//! smaller endpoint of its edge, a counting sort) plus one `u32` per vertex, and no twin or
//! kind arrays. Storing the other endpoint costs 4 bytes per half-edge but measured faster
//! than reading it back from the triangles on every pass; each bucket (≈ 6 half-edges) is
//! sorted once, in place. No hashing; groups come in ascending `(a, b)` order.
//!
//! [`HalfEdges`]: super::HalfEdges

use super::NONE;
use super::half_edge_ids::{EdgeKind, EdgeLookup, next};

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
    members: Members,
    /// `ends[a]`: one past the last entry of bucket `a` (bucket `a` starts at `ends[a - 1]`).
    ends: Vec<u32>,
    /// Per bucket, sorted: grouped by edge, half-edges ascending within a group.
    sides: Vec<Side>,
}

impl<'a> EdgeBuckets<'a> {
    /// Buckets the half-edges of proper triangles. O(V + T), 8 bytes per half-edge and 4 per
    /// vertex.
    pub fn new(vertex_count: usize, triangles: &'a [u32]) -> Self {
        Self::of(vertex_count, triangles, Members::ProperTriangles)
    }

    /// Buckets the `members` half-edges of `triangles`. O(V + T).
    pub fn of(vertex_count: usize, triangles: &'a [u32], members: Members) -> Self {
        let mut ends = vec![0u32; vertex_count + 1];
        for_each_half_edge(vertex_count, triangles, members, |a, _, _| ends[a as usize + 1] += 1);
        let mut sum = 0u32;
        for x in ends.iter_mut() {
            sum += *x;
            *x = sum;
        }
        // ends[a] is now where bucket a starts; scattering advances it to where it ends.
        let mut sides = vec![Side(0); sum as usize];
        for_each_half_edge(vertex_count, triangles, members, |a, b, h| {
            let slot = &mut ends[a as usize];
            sides[*slot as usize] = Side((b as u64) << 32 | h as u64);
            *slot += 1;
        });
        ends.pop();
        let mut begin = 0;
        for &end in &ends {
            sort_bucket(&mut sides[begin..end as usize]);
            begin = end as usize;
        }
        Self { triangles, members, ends, sides }
    }

    /// Calls `group(a, sides)` for every undirected edge `{a, b}` with `a < b`, in ascending
    /// `(a, b)` order, with its half-edges in ascending id order.
    pub fn for_each_edge(&self, mut group: impl FnMut(u32, &[Side])) {
        let mut begin = 0usize;
        for (a, &end) in self.ends.iter().enumerate() {
            let bucket = &self.sides[begin..end as usize];
            begin = end as usize;
            for edge in bucket.chunk_by(|x, y| x.0 >> 32 == y.0 >> 32) {
                group(a as u32, edge);
            }
        }
    }

    /// Which half-edges take part.
    pub fn members(&self) -> Members {
        self.members
    }

    /// Whether a half-edge of edge `{a, b}` (`a < b`) runs from `a` to `b`.
    #[inline]
    pub fn runs_up(&self, a: u32, side: Side) -> bool {
        self.triangles[side.half_edge() as usize] == a
    }

    /// The member half-edges on edge `{a, b}` (either order), ascending; empty if none. A
    /// search of one bucket: O(log d).
    pub fn sides(&self, a: u32, b: u32) -> &[Side] {
        let (a, b) = (a.min(b), a.max(b));
        let Some(&end) = self.ends.get(a as usize) else { return &[] };
        let begin = if a == 0 { 0 } else { self.ends[a as usize - 1] as usize };
        let bucket = &self.sides[begin..end as usize];
        let first = bucket.partition_point(|s| (s.0 >> 32) < u64::from(b));
        let count = bucket[first..].iter().take_while(|s| (s.0 >> 32) == u64::from(b)).count();
        &bucket[first..first + count]
    }

    /// The group of half-edge `h`, if `h` is a member.
    fn group_of(&self, h: u32) -> Option<&[Side]> {
        let (a, b) = (*self.triangles.get(h as usize)?, self.triangles[next(h) as usize]);
        let group = self.sides(a, b);
        group.iter().any(|s| s.half_edge() == h).then_some(group)
    }
}

/// Twins and kinds looked up per half-edge (the same answers as [`HalfEdges`] when built with
/// [`Members::ProperTriangles`]): for walks that visit few edges, such as boundary loops,
/// without building the per-half-edge arrays.
///
/// [`HalfEdges`]: super::HalfEdges
impl EdgeLookup for EdgeBuckets<'_> {
    fn kind(&self, h: u32) -> EdgeKind {
        match self.group_of(h) {
            None => EdgeKind::Degenerate,
            Some([_]) => EdgeKind::Boundary,
            Some([x, y]) => {
                let a = self.triangles[h as usize].min(self.triangles[next(h) as usize]);
                if self.runs_up(a, *x) != self.runs_up(a, *y) {
                    EdgeKind::Interior
                } else {
                    EdgeKind::InteriorInconsistent
                }
            }
            Some(_) => EdgeKind::NonManifold,
        }
    }

    fn opposite(&self, h: u32) -> u32 {
        match self.group_of(h) {
            Some([x, y]) => {
                if x.half_edge() == h {
                    y.half_edge()
                } else {
                    x.half_edge()
                }
            }
            _ => NONE,
        }
    }

    fn sorted_boundary_half_edges(&self) -> Vec<u32> {
        let mut boundary = Vec::new();
        self.for_each_edge(|_, sides| {
            if let [x] = sides {
                boundary.push(x.half_edge());
            }
        });
        boundary.sort_unstable();
        boundary
    }

    fn half_edge_count(&self) -> usize {
        self.triangles.len() / 3 * 3
    }
}

/// Buckets this short (most are: about six half-edges around a vertex) are sorted by
/// insertion inline; a call of the general sort per bucket cost a quarter of the grouping.
const INSERTION_SORT_MAX: usize = 16;

/// Sorts one bucket ascending, as `sort_unstable` would (keys are distinct).
#[inline]
fn sort_bucket(bucket: &mut [Side]) {
    if bucket.len() > INSERTION_SORT_MAX {
        bucket.sort_unstable();
        return;
    }
    for i in 1..bucket.len() {
        let item = bucket[i];
        let mut j = i;
        while j > 0 && bucket[j - 1] > item {
            bucket[j] = bucket[j - 1];
            j -= 1;
        }
        bucket[j] = item;
    }
}

/// Calls `f(smaller endpoint, larger endpoint, half-edge id)` for every member half-edge.
#[inline(always)]
fn for_each_half_edge(
    vertex_count: usize,
    triangles: &[u32],
    members: Members,
    mut f: impl FnMut(u32, u32, u32),
) {
    let in_range = |v: u32| (v as usize) < vertex_count;
    for (t, c) in triangles.chunks_exact(3).enumerate() {
        let [x, y, z] = [c[0], c[1], c[2]];
        let h = 3 * t as u32;
        if super::proper([x, y, z], vertex_count) {
            f(x.min(y), x.max(y), h);
            f(y.min(z), y.max(z), h + 1);
            f(z.min(x), z.max(x), h + 2);
        } else if members == Members::AnyEdge {
            for (k, (a, b)) in [(x, y), (y, z), (z, x)].into_iter().enumerate() {
                if a != b && in_range(a) && in_range(b) {
                    f(a.min(b), a.max(b), h + k as u32);
                }
            }
        }
    }
}
