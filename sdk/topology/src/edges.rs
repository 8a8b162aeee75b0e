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
        Self::of_in_parts(vertex_count, triangles, members, 1)
    }

    /// The same, built on `parts` threads when `parts > 1` (hosts only: a guest has no
    /// threads): each counts a share of the triangles, then fills and sorts the buckets of
    /// a range of vertices holding about `1 / parts` of the half-edges. The result is the
    /// same for every `parts`.
    pub fn of_in_parts(
        vertex_count: usize,
        triangles: &'a [u32],
        members: Members,
        parts: usize,
    ) -> Self {
        let parts = parts.max(1);
        // Bucket sizes, then `ends[a]` = where bucket `a` starts (and `ends[V]` the total).
        let mut ends = if parts == 1 {
            bucket_sizes(vertex_count, triangles, members)
        } else {
            let shares = triangles.chunks(3 * triangles.len().div_ceil(3 * parts).max(1));
            let sizes: Vec<Vec<u32>> = std::thread::scope(|scope| {
                let counting: Vec<_> = shares
                    .map(|share| scope.spawn(move || bucket_sizes(vertex_count, share, members)))
                    .collect();
                counting.into_iter().map(|c| c.join().expect("counting panicked")).collect()
            });
            let mut sizes = sizes.into_iter();
            let mut total = sizes.next().unwrap_or_else(|| vec![0; vertex_count + 1]);
            for share in sizes {
                total.iter_mut().zip(share).for_each(|(x, y)| *x += y);
            }
            total
        };
        let mut sum = 0u32;
        for x in ends.iter_mut() {
            sum += *x;
            *x = sum;
        }
        let mut sides = vec![Side(0); sum as usize];
        ends.pop();
        // Scattering advances each bucket's start to its end; each part fills and sorts its
        // own buckets, a disjoint piece of `ends` and of `sides`.
        let ranges = split(&ends, sum, parts);
        let mut pieces = Vec::with_capacity(ranges.len());
        let (mut rest_ends, mut rest_sides) = (&mut ends[..], &mut sides[..]);
        for range in &ranges {
            let (part_ends, more_ends) = rest_ends.split_at_mut(range.len());
            let part_len = match more_ends.first() {
                Some(&next_start) => next_start as usize - range_start(part_ends, sum),
                None => rest_sides.len(),
            };
            let (part_sides, more_sides) = rest_sides.split_at_mut(part_len);
            pieces.push((range.start as u32, part_ends, part_sides));
            (rest_ends, rest_sides) = (more_ends, more_sides);
        }
        let fill = |(first, ends, sides): (u32, &mut [u32], &mut [Side])| {
            let base = range_start(ends, sum);
            let last = first as usize + ends.len();
            for_each_half_edge(vertex_count, triangles, members, |a, b, h| {
                if (first as usize..last).contains(&(a as usize)) {
                    let slot = &mut ends[(a - first) as usize];
                    sides[*slot as usize - base] = Side((b as u64) << 32 | h as u64);
                    *slot += 1;
                }
            });
            let mut begin = 0;
            for &end in ends.iter() {
                sort_bucket(&mut sides[begin..end as usize - base]);
                begin = end as usize - base;
            }
        };
        if pieces.len() == 1 {
            pieces.into_iter().for_each(fill);
        } else {
            std::thread::scope(|scope| {
                for piece in pieces {
                    scope.spawn(|| fill(piece));
                }
            });
        }
        Self { triangles, members, ends, sides }
    }

    /// Consecutive ranges of buckets holding about `1 / parts` of the half-edges each (at
    /// least one range, none empty unless there are no vertices), for work split by
    /// vertex.
    pub fn parts(&self, parts: usize) -> Vec<std::ops::Range<usize>> {
        if parts <= 1 {
            // One range of every bucket, without copying the bucket bounds.
            let every = 0..self.ends.len();
            return vec![every];
        }
        // `ends` holds where each bucket ends; as starts: 0, then every end but the last.
        let starts: Vec<u32> =
            std::iter::once(0).chain(self.ends.iter().copied()).take(self.ends.len()).collect();
        split(&starts, self.sides.len() as u32, parts)
    }

    /// Calls `group(a, sides)` for every undirected edge `{a, b}` with `a < b`, in ascending
    /// `(a, b)` order, with its half-edges in ascending id order.
    pub fn for_each_edge(&self, group: impl FnMut(u32, &[Side])) {
        self.for_each_edge_in(0..self.ends.len(), group);
    }

    /// [`for_each_edge`](Self::for_each_edge) for the edges whose smaller endpoint is in
    /// `vertices`.
    pub fn for_each_edge_in(
        &self,
        vertices: std::ops::Range<usize>,
        mut group: impl FnMut(u32, &[Side]),
    ) {
        let mut begin = match vertices.start {
            0 => 0,
            a => self.ends[a - 1] as usize,
        };
        for a in vertices {
            let end = self.ends[a] as usize;
            let bucket = &self.sides[begin..end];
            begin = end;
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

/// Per vertex `a`, how many member half-edges have `a` as their smaller endpoint, at
/// `a + 1` (so that a running sum gives where each bucket starts).
fn bucket_sizes(vertex_count: usize, triangles: &[u32], members: Members) -> Vec<u32> {
    let mut sizes = vec![0u32; vertex_count + 1];
    for_each_half_edge(vertex_count, triangles, members, |a, _, _| sizes[a as usize + 1] += 1);
    sizes
}

/// Where the first bucket of `ends` (buckets' starts, or their ends once filled) starts:
/// a filled bucket's start is its predecessor's end, so both are read before filling.
fn range_start(starts: &[u32], total: u32) -> usize {
    starts.first().map_or(total, |&s| s) as usize
}

/// Consecutive bucket ranges covering `starts.len()` buckets, each starting near a multiple
/// of `total / parts` half-edges (at least one range; empty ranges dropped).
fn split(starts: &[u32], total: u32, parts: usize) -> Vec<std::ops::Range<usize>> {
    let parts = parts.max(1);
    let mut bounds: Vec<usize> = (0..parts)
        .map(|k| starts.partition_point(|&s| (s as u64) < total as u64 * k as u64 / parts as u64))
        .collect();
    bounds.push(starts.len());
    bounds.dedup();
    let mut ranges: Vec<_> = bounds.windows(2).map(|w| w[0]..w[1]).collect();
    if ranges.is_empty() {
        // No vertices: one empty range, so that callers need no case of their own.
        ranges.push(0..0);
    }
    ranges
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
