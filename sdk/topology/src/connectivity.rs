//! Connectivity derived once per mesh version and handed out in bulk: what a host gives
//! plugins through the WIT mesh's `half-edge-opposites`, `half-edge-kinds` and `edges` (as
//! geometry-central caches its quantities, so the services that follow do not derive them
//! again), and [`HalfEdgeView`], which answers from those arrays once a plugin holds them.

use std::fmt;

use super::edges::{EdgeBuckets, Members};
use super::halfedge::{EdgeKind, EdgeLookup, HalfEdges};

/// Twins, edge kinds and the edge list of one mesh version, all derived in one pass over
/// the edge buckets. Memory: 5 bytes per half-edge and 4 per edge.
#[derive(Clone, Debug)]
pub struct Connectivity {
    half_edges: HalfEdges,
    edges: Vec<u32>,
}

impl Connectivity {
    /// Derives everything from `triangles` (ids `< vertex_count`; improper triangles as the
    /// crate docs say). O(V + T log d); no hashing; deterministic, so every host hands out
    /// the same arrays for the same mesh.
    pub fn new(vertex_count: usize, triangles: &[u32]) -> Self {
        Self::in_parts(vertex_count, triangles, 1)
    }

    /// The same, derived on `parts` threads when `parts > 1` (hosts only: a guest has no
    /// threads), each for the edges of a range of vertices. The same arrays for every
    /// `parts`.
    pub fn in_parts(vertex_count: usize, triangles: &[u32], parts: usize) -> Self {
        let buckets =
            EdgeBuckets::of_in_parts(vertex_count, triangles, Members::ProperTriangles, parts);
        let (half_edges, edges) = HalfEdges::with_edge_list(&buckets, parts);
        Self { half_edges, edges }
    }

    pub fn half_edges(&self) -> &HalfEdges {
        &self.half_edges
    }

    /// Per half-edge: its twin on a manifold-interior edge, else [`NONE`](crate::NONE).
    pub fn opposites(&self) -> &[u32] {
        self.half_edges.opposites()
    }

    /// Per half-edge: its [`EdgeKind`] as a byte (the enum's `repr(u8)` value).
    pub fn kind_codes(&self) -> &[u8] {
        self.half_edges.kind_codes()
    }

    /// Every undirected edge of the proper triangles once, in ascending `(smaller, larger)`
    /// vertex order, as its smallest half-edge id: the order
    /// [`EdgeBuckets::for_each_edge`] visits them in. Its length is the edge count.
    pub fn edges(&self) -> &[u32] {
        &self.edges
    }

    /// Twin and kind answers over the arrays.
    pub fn view(&self) -> HalfEdgeView<'_> {
        HalfEdgeView { opposites: self.opposites(), kinds: self.half_edges.kinds() }
    }
}

/// [`EdgeLookup`] over a twin array and a kind array, as a plugin receives them from the
/// host: O(1) per answer, nothing built. The arrays are trusted to come from one
/// [`Connectivity`]: inconsistent ones give wrong answers or an index panic, nothing worse.
#[derive(Clone, Copy, Debug)]
pub struct HalfEdgeView<'a> {
    opposites: &'a [u32],
    kinds: &'a [EdgeKind],
}

impl<'a> HalfEdgeView<'a> {
    /// A view of `opposites` and `kinds`, one entry per half-edge each.
    pub fn new(opposites: &'a [u32], kinds: &'a [EdgeKind]) -> Result<Self, ConnectivityError> {
        if opposites.len() != kinds.len() {
            return Err(ConnectivityError::Lengths {
                opposites: opposites.len(),
                kinds: kinds.len(),
            });
        }
        Ok(Self { opposites, kinds })
    }

    pub fn opposites(&self) -> &'a [u32] {
        self.opposites
    }

    pub fn kinds(&self) -> &'a [EdgeKind] {
        self.kinds
    }
}

impl EdgeLookup for HalfEdgeView<'_> {
    #[inline]
    fn kind(&self, h: u32) -> EdgeKind {
        self.kinds[h as usize]
    }

    #[inline]
    fn opposite(&self, h: u32) -> u32 {
        self.opposites[h as usize]
    }

    fn sorted_boundary_half_edges(&self) -> Vec<u32> {
        (0..self.kinds.len() as u32)
            .filter(|&h| self.kinds[h as usize] == EdgeKind::Boundary)
            .collect()
    }

    #[inline]
    fn half_edge_count(&self) -> usize {
        self.kinds.len()
    }
}

/// The kinds of [`Connectivity::kind_codes`] back as [`EdgeKind`]s, without a copy (one
/// pass that vectorises checks every byte), or the first byte that names no kind.
pub fn kinds_from_codes(codes: Vec<u8>) -> Result<Vec<EdgeKind>, ConnectivityError> {
    let largest = codes.iter().fold(0u8, |m, &c| m.max(c));
    if largest > EdgeKind::NonManifold as u8 {
        let half_edge = codes.iter().position(|&c| EdgeKind::from_code(c).is_none());
        let half_edge = half_edge.expect("a byte above the largest kind");
        return Err(ConnectivityError::Kind { half_edge, code: codes[half_edge] });
    }
    let mut codes = std::mem::ManuallyDrop::new(codes);
    let (ptr, len, capacity) = (codes.as_mut_ptr(), codes.len(), codes.capacity());
    // SAFETY: every byte is a valid `EdgeKind` (checked above), which is `repr(u8)`: the
    // same size and alignment as `u8`, so the allocation is the same allocation.
    Ok(unsafe { Vec::from_raw_parts(ptr.cast::<EdgeKind>(), len, capacity) })
}

/// Whether some half-edge is of `kind`: one pass the compiler vectorises (a short-circuiting
/// search is not), a few milliseconds fewer per check in the sandbox.
pub fn contains_kind(kinds: &[EdgeKind], kind: EdgeKind) -> bool {
    kinds.iter().fold(false, |found, &k| found | (k == kind))
}

/// Derived arrays that cannot be used.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ConnectivityError {
    /// A byte that is no [`EdgeKind`].
    Kind { half_edge: usize, code: u8 },
    /// Twin and kind arrays of different lengths.
    Lengths { opposites: usize, kinds: usize },
}

impl fmt::Display for ConnectivityError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Kind { half_edge, code } => {
                write!(f, "half-edge {half_edge} has edge kind {code}, which names no kind")
            }
            Self::Lengths { opposites, kinds } => {
                write!(f, "{opposites} twins but {kinds} edge kinds: one each per half-edge")
            }
        }
    }
}

impl std::error::Error for ConnectivityError {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::NONE;

    #[test]
    fn the_arrays_match_the_buckets_and_round_trip() {
        // Two triangles sharing edge {1, 2}, a third glued the same way (inconsistent), and
        // a repeated-id one.
        let t = [0, 1, 2, 2, 1, 3, 1, 2, 4, 0, 0, 1];
        let c = Connectivity::new(5, &t);
        let mut expected = Vec::new();
        EdgeBuckets::new(5, &t).for_each_edge(|_, sides| expected.push(sides[0].half_edge()));
        assert_eq!(c.edges(), expected);
        assert_eq!(c.edges().len(), c.half_edges().edge_count());
        assert_eq!(c.kind_codes()[9..], [0, 0, 0]);
        assert_eq!(c.kind_codes()[1], EdgeKind::NonManifold as u8);
        let kinds = kinds_from_codes(c.kind_codes().to_vec()).unwrap();
        assert_eq!(kinds, c.half_edges().kinds());
        let view = HalfEdgeView::new(c.opposites(), &kinds).unwrap();
        for h in 0..t.len() as u32 {
            assert_eq!(view.kind(h), c.half_edges().kind(h));
            assert_eq!(view.opposite(h), c.half_edges().opposite(h));
        }
        assert_eq!(view.sorted_boundary_half_edges(), c.half_edges().sorted_boundary_half_edges());
        assert_eq!(c.opposites()[0], NONE);
    }

    #[test]
    fn kinds_are_searched_whole() {
        let kinds = [EdgeKind::Boundary, EdgeKind::Interior, EdgeKind::Interior];
        assert!(contains_kind(&kinds, EdgeKind::Interior));
        assert!(
            !contains_kind(&kinds, EdgeKind::NonManifold)
                && !contains_kind(&[], EdgeKind::Boundary)
        );
    }

    #[test]
    fn unusable_arrays_are_refused() {
        assert_eq!(
            kinds_from_codes(vec![1, 2, 9]),
            Err(ConnectivityError::Kind { half_edge: 2, code: 9 })
        );
        let error = HalfEdgeView::new(&[NONE; 3], &[EdgeKind::Boundary; 2]).unwrap_err();
        assert!(error.to_string().contains("3 twins but 2 edge kinds"), "{error}");
    }
}
