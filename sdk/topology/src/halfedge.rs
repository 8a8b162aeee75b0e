//! Half-edges: twins and the classification of every edge.
//!
//! Half-edge `h = 3 * t + k` runs from corner `k` of triangle `t` to corner `(k + 1) % 3`.
//! The free functions ([`next`], [`prev`], [`origin`], …, re-exported from `half_edge_ids`)
//! need no structure at all;
//! [`HalfEdges`] adds the twin of every half-edge and what kind of edge it lies on.

pub use super::half_edge_ids::*;

use std::sync::atomic::Ordering::Relaxed;
use std::sync::atomic::{AtomicU8, AtomicU32};

use super::NONE;
use super::csr::Csr;
use super::edges::{EdgeBuckets, Members};

impl EdgeLookup for HalfEdges {
    fn kind(&self, h: u32) -> EdgeKind {
        HalfEdges::kind(self, h)
    }

    fn opposite(&self, h: u32) -> u32 {
        HalfEdges::opposite(self, h)
    }

    fn sorted_boundary_half_edges(&self) -> Vec<u32> {
        self.boundary_half_edges().collect()
    }

    fn half_edge_count(&self) -> usize {
        self.len()
    }
}

/// Twins and edge classification for every half-edge of a triangle array.
///
/// - `opposite(h)` is the other half-edge on the same undirected edge when the edge is
///   manifold-interior (exactly two half-edges, whichever directions), else [`NONE`]
///   (boundary, non-manifold and degenerate half-edges).
/// - `kind(h)` tells which of those cases applies, and for interior edges whether the two
///   triangles are consistently oriented.
/// - Non-manifold edges are listed with all their half-edges in
///   [`non_manifold_edges`](Self::non_manifold_edges).
///
/// Memory: 5 bytes per half-edge (15 per triangle) plus the non-manifold list; building
/// needs another 8 bytes per half-edge and 4 per vertex temporarily. Measured natively on a
/// 1M-vertex, 2M-triangle grid: ≈ 55 ms with local vertex order, ≈ 200 ms with randomly
/// permuted vertex ids (memory-latency bound).
#[derive(Clone, Debug, Default)]
pub struct HalfEdges {
    opposite: Vec<u32>,
    kinds: Vec<EdgeKind>,
    non_manifold: Csr,
    edge_count: usize,
    boundary_edges: usize,
    interior_edges: usize,
    inconsistent_edges: usize,
}

impl HalfEdges {
    /// Builds twins and kinds for `triangles` (ids `< vertex_count`; see the module docs for
    /// improper triangles). O(V + T log d) time with `d` the vertex degree (a bucket sort on
    /// the smaller endpoint, then a tiny sort per vertex); no hashing; deterministic.
    pub fn new(vertex_count: usize, triangles: &[u32]) -> Self {
        Self::from_buckets(&EdgeBuckets::new(vertex_count, triangles))
    }

    /// The same from edge buckets already built with [`EdgeBuckets::new`] (a check that
    /// looked at the edges first need not group them again).
    pub fn from_buckets(buckets: &EdgeBuckets) -> Self {
        Self::build(buckets, false, 1).0
    }

    /// The same, with every edge's smallest half-edge in the order the buckets visit the
    /// edges (what [`Connectivity`](crate::Connectivity) hands out), derived on `parts`
    /// threads when `parts > 1` (hosts only), each for a range of the buckets.
    pub(crate) fn with_edge_list(buckets: &EdgeBuckets, parts: usize) -> (Self, Vec<u32>) {
        Self::build(buckets, true, parts)
    }

    fn build(buckets: &EdgeBuckets, edge_list: bool, parts: usize) -> (Self, Vec<u32>) {
        assert!(buckets.members() == Members::ProperTriangles, "twins need proper triangles");
        let n = buckets.half_edge_count();
        let mut opposite = vec![NONE; n];
        let mut kinds = vec![EdgeKind::Degenerate; n];
        let ranges = buckets.parts(parts);
        let classified: Vec<Classified> = {
            let out = Out::new(&mut opposite, &mut kinds);
            let classify = |range| classify(buckets, range, &out, edge_list);
            if ranges.len() == 1 {
                ranges.into_iter().map(classify).collect()
            } else {
                std::thread::scope(|scope| {
                    let threads: Vec<_> =
                        ranges.into_iter().map(|r| scope.spawn(move || classify(r))).collect();
                    threads.into_iter().map(|t| t.join().expect("classifying panicked")).collect()
                })
            }
        };
        let mut parts = classified.into_iter();
        let mut all = parts.next().expect("at least one range of buckets");
        for part in parts {
            let shift = all.nm_items.len() as u32;
            all.nm_offsets.extend(part.nm_offsets[1..].iter().map(|o| o + shift));
            all.nm_items.extend(part.nm_items);
            all.edges.extend(part.edges);
            all.counts = [0, 1, 2, 3].map(|k| all.counts[k] + part.counts[k]);
        }
        let [edge_count, boundary, interior, inconsistent] = all.counts;
        let half_edges = Self {
            opposite,
            kinds,
            non_manifold: Csr::from_parts_unchecked(all.nm_offsets, all.nm_items),
            edge_count,
            boundary_edges: boundary,
            interior_edges: interior,
            inconsistent_edges: inconsistent,
        };
        (half_edges, all.edges)
    }

    /// The number of half-edges, `3 * triangle_count`. O(1).
    #[inline]
    pub fn len(&self) -> usize {
        self.opposite.len()
    }

    /// Whether there are no half-edges. O(1).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.opposite.is_empty()
    }

    /// The twin of `h` on a manifold-interior edge, else [`NONE`]. O(1).
    #[inline]
    pub fn opposite(&self, h: u32) -> u32 {
        self.opposite[h as usize]
    }

    /// All twins, indexed by half-edge id ([`NONE`] where there is none).
    #[inline]
    pub fn opposites(&self) -> &[u32] {
        &self.opposite
    }

    /// The kind of edge `h` lies on. O(1).
    #[inline]
    pub fn kind(&self, h: u32) -> EdgeKind {
        self.kinds[h as usize]
    }

    /// All kinds, indexed by half-edge id.
    #[inline]
    pub fn kinds(&self) -> &[EdgeKind] {
        &self.kinds
    }

    /// All kinds as bytes (each its `repr(u8)` value), without a copy: what a host lowers
    /// into a plugin as `list<u8>`.
    #[inline]
    pub fn kind_codes(&self) -> &[u8] {
        // SAFETY: `EdgeKind` is `repr(u8)` without fields, so every value is a valid byte
        // and the slice has the same length, size and alignment as bytes.
        unsafe { std::slice::from_raw_parts(self.kinds.as_ptr().cast::<u8>(), self.kinds.len()) }
    }

    /// Whether `h` is the only half-edge on its edge. O(1).
    #[inline]
    pub fn is_boundary(&self, h: u32) -> bool {
        self.kinds[h as usize] == EdgeKind::Boundary
    }

    /// Whether `h` has a twin (manifold-interior edge, either orientation). O(1).
    #[inline]
    pub fn is_interior(&self, h: u32) -> bool {
        self.kinds[h as usize].is_interior()
    }

    /// Whether `h` has a twin running the opposite way. O(1).
    #[inline]
    pub fn is_consistent(&self, h: u32) -> bool {
        self.kinds[h as usize] == EdgeKind::Interior
    }

    /// Whether `h` lies on an edge with three or more half-edges. O(1).
    #[inline]
    pub fn is_non_manifold(&self, h: u32) -> bool {
        self.kinds[h as usize] == EdgeKind::NonManifold
    }

    /// The number of distinct undirected edges of proper triangles (the `edge-count`). O(1).
    #[inline]
    pub fn edge_count(&self) -> usize {
        self.edge_count
    }

    /// The number of boundary edges (= boundary half-edges). O(1).
    #[inline]
    pub fn boundary_edge_count(&self) -> usize {
        self.boundary_edges
    }

    /// The number of manifold-interior edges (each has two half-edges). O(1).
    #[inline]
    pub fn interior_edge_count(&self) -> usize {
        self.interior_edges
    }

    /// The number of interior edges whose two half-edges run the same way. O(1).
    #[inline]
    pub fn inconsistent_edge_count(&self) -> usize {
        self.inconsistent_edges
    }

    /// The number of edges with three or more half-edges. O(1).
    #[inline]
    pub fn non_manifold_edge_count(&self) -> usize {
        self.non_manifold.len()
    }

    /// The non-manifold edges: one row per edge holding all its half-edges (ascending), rows
    /// in ascending order of the edge's `(min vertex, max vertex)`.
    #[inline]
    pub fn non_manifold_edges(&self) -> &Csr {
        &self.non_manifold
    }

    /// Whether no edge is a boundary edge (there may still be non-manifold edges). O(1).
    #[inline]
    pub fn is_closed(&self) -> bool {
        self.boundary_edges == 0
    }

    /// The boundary half-edges in ascending order. O(H) to iterate.
    pub fn boundary_half_edges(&self) -> impl Iterator<Item = u32> + '_ {
        self.kinds
            .iter()
            .enumerate()
            .filter(|(_, k)| **k == EdgeKind::Boundary)
            .map(|(h, _)| h as u32)
    }

    /// Gives back the twin array (the form the host hands out). O(1).
    pub fn into_opposites(self) -> Vec<u32> {
        self.opposite
    }
}

/// What classifying one range of buckets found besides the per-half-edge arrays.
struct Classified {
    /// Each edge's smallest half-edge, in bucket order (when asked for).
    edges: Vec<u32>,
    nm_offsets: Vec<u32>,
    nm_items: Vec<u32>,
    /// Edges, boundary edges, interior edges, inconsistent interior edges.
    counts: [usize; 4],
}

/// The twin and kind arrays, written by several threads at once: every half-edge lies in
/// exactly one bucket, so each entry is written by the one thread classifying that bucket
/// (relaxed atomic stores are plain stores).
struct Out<'a> {
    opposite: &'a [AtomicU32],
    kinds: &'a [AtomicU8],
}

impl<'a> Out<'a> {
    fn new(opposite: &'a mut [u32], kinds: &'a mut [EdgeKind]) -> Self {
        const { assert!(align_of::<AtomicU32>() == align_of::<u32>()) };
        // SAFETY: `AtomicU32` and `AtomicU8` have the size, bit validity and (asserted above
        // for `u32`) alignment of `u32` and `u8`; `EdgeKind` is a fieldless `repr(u8)` enum,
        // and only its codes are stored. The exclusive borrows guarantee no other access.
        let opposite = unsafe { &*(opposite as *mut [u32] as *const [AtomicU32]) };
        let kinds = unsafe { &*(kinds as *mut [EdgeKind] as *const [AtomicU8]) };
        Self { opposite, kinds }
    }

    #[inline]
    fn set(&self, h: u32, opposite: Option<u32>, kind: EdgeKind) {
        if let Some(twin) = opposite {
            self.opposite[h as usize].store(twin, Relaxed);
        }
        self.kinds[h as usize].store(kind as u8, Relaxed);
    }
}

/// Classifies the edges of the buckets `range`, writing their half-edges' twins and kinds.
fn classify(
    buckets: &EdgeBuckets,
    range: std::ops::Range<usize>,
    out: &Out<'_>,
    edge_list: bool,
) -> Classified {
    let mut found =
        Classified { edges: Vec::new(), nm_offsets: vec![0], nm_items: Vec::new(), counts: [0; 4] };
    let [edges, boundary, interior, inconsistent] = &mut found.counts;
    buckets.for_each_edge_in(range, |a, group| {
        *edges += 1;
        if edge_list {
            found.edges.push(group[0].half_edge());
        }
        match *group {
            [e] => {
                out.set(e.half_edge(), None, EdgeKind::Boundary);
                *boundary += 1;
            }
            [e, f] => {
                let (g, h) = (e.half_edge(), f.half_edge());
                let kind = if buckets.runs_up(a, e) != buckets.runs_up(a, f) {
                    EdgeKind::Interior
                } else {
                    *inconsistent += 1;
                    EdgeKind::InteriorInconsistent
                };
                out.set(g, Some(h), kind);
                out.set(h, Some(g), kind);
                *interior += 1;
            }
            _ => {
                for e in group {
                    out.set(e.half_edge(), None, EdgeKind::NonManifold);
                    found.nm_items.push(e.half_edge());
                }
                found.nm_offsets.push(found.nm_items.len() as u32);
            }
        }
    });
    found
}

/// The undirected edge of `h` as `(min vertex, max vertex)`. O(1).
#[inline]
pub fn edge_key(triangles: &[u32], h: u32) -> (u32, u32) {
    let (a, b) = (origin(triangles, h), target(triangles, h));
    (a.min(b), a.max(b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn navigation() {
        assert_eq!([next(0), next(1), next(2), next(5)], [1, 2, 0, 3]);
        assert_eq!([prev(0), prev(1), prev(2), prev(3)], [2, 0, 1, 5]);
        let t = [7, 8, 9, 1, 2, 3];
        assert_eq!((origin(&t, 5), target(&t, 5), opposite_vertex(&t, 5)), (3, 1, 2));
        assert_eq!(edge_key(&t, 2), (7, 9));
        assert_eq!((triangle_of(4), corner_of(4), half_edge(1, 1)), (1, 1, 4));
    }

    #[test]
    fn two_triangles() {
        let t = [0, 1, 2, 2, 1, 3];
        let he = HalfEdges::new(4, &t);
        assert_eq!(he.opposite(1), 3);
        assert_eq!(he.opposite(3), 1);
        assert_eq!(he.kind(1), EdgeKind::Interior);
        assert_eq!(he.edge_count(), 5);
        assert_eq!(he.boundary_edge_count(), 4);
        assert_eq!(he.boundary_half_edges().collect::<Vec<_>>(), [0, 2, 4, 5]);
    }

    #[test]
    fn empty_and_trailing() {
        let he = HalfEdges::new(0, &[]);
        assert!(he.is_empty() && he.is_closed());
        let he = HalfEdges::new(3, &[0, 1, 2, 0]);
        assert_eq!(he.len(), 3);
        assert_eq!(he.edge_count(), 3);
    }
}
