//! Half-edge ids and edge kinds: the vocabulary both [`EdgeBuckets`](crate::EdgeBuckets)
//! and [`HalfEdges`](crate::HalfEdges) answer in, needing no structure of their own.
//!
//! Half-edge `h = 3 * t + k` runs from corner `k` of triangle `t` to corner `(k + 1) % 3`.
//!
//! [`NONE`]: crate::NONE

/// The half-edge id of corner `k` (0, 1 or 2) of triangle `t`: `3 * t + k`. O(1).
#[inline]
pub fn half_edge(t: u32, k: u32) -> u32 {
    3 * t + k
}

/// The triangle a half-edge belongs to: `h / 3`. O(1).
#[inline]
pub fn triangle_of(h: u32) -> u32 {
    h / 3
}

/// The corner (0, 1 or 2) a half-edge starts at: `h % 3`. O(1).
#[inline]
pub fn corner_of(h: u32) -> u32 {
    h % 3
}

/// The next half-edge in the same triangle (it starts where `h` ends). O(1).
#[inline]
pub fn next(h: u32) -> u32 {
    if h % 3 == 2 { h - 2 } else { h + 1 }
}

/// The previous half-edge in the same triangle (it ends where `h` starts). O(1).
#[inline]
pub fn prev(h: u32) -> u32 {
    if h.is_multiple_of(3) { h + 2 } else { h - 1 }
}

/// The vertex `h` starts at. O(1). Panics if `h` is out of range.
#[inline]
pub fn origin(triangles: &[u32], h: u32) -> u32 {
    triangles[h as usize]
}

/// The vertex `h` ends at. O(1). Panics if `h` is out of range.
#[inline]
pub fn target(triangles: &[u32], h: u32) -> u32 {
    triangles[next(h) as usize]
}

/// The vertex opposite `h` in its triangle (the corner neither starting nor ending `h`). O(1).
#[inline]
pub fn opposite_vertex(triangles: &[u32], h: u32) -> u32 {
    triangles[prev(h) as usize]
}

/// What kind of undirected edge a half-edge lies on.
///
/// Only half-edges of proper triangles (three distinct in-range vertex ids) count; the
/// "number of half-edges on an edge" below counts those, whatever their direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum EdgeKind {
    /// The half-edge belongs to an improper triangle (repeated or out-of-range vertex id) and
    /// is not part of any edge.
    Degenerate = 0,
    /// The only half-edge on its edge.
    Boundary = 1,
    /// One of exactly two half-edges on its edge, and they run in opposite directions
    /// (manifold, consistently oriented).
    Interior = 2,
    /// One of exactly two half-edges on its edge, and both run in the same direction
    /// (manifold, but the two triangles disagree on orientation).
    InteriorInconsistent = 3,
    /// One of three or more half-edges on its edge.
    NonManifold = 4,
}

impl EdgeKind {
    /// The kind whose `repr(u8)` value is `code`, if any.
    #[inline]
    pub fn from_code(code: u8) -> Option<Self> {
        Some(match code {
            0 => Self::Degenerate,
            1 => Self::Boundary,
            2 => Self::Interior,
            3 => Self::InteriorInconsistent,
            4 => Self::NonManifold,
            _ => return None,
        })
    }

    /// `Interior` or `InteriorInconsistent`: a manifold edge with a twin.
    #[inline]
    pub fn is_interior(self) -> bool {
        matches!(self, Self::Interior | Self::InteriorInconsistent)
    }
}

/// Twin and edge-kind answers per half-edge, from either a [`HalfEdges`] (arrays built once,
/// O(1) per answer) or an [`EdgeBuckets`] (one bucket search per answer, no arrays): what
/// walks such as [`boundary_loops`](crate::boundary_loops) need.
pub trait EdgeLookup {
    /// The kind of edge `h` lies on (see [`HalfEdges::kind`]).
    fn kind(&self, h: u32) -> EdgeKind;
    /// The twin of `h` on a manifold-interior edge, else [`NONE`].
    fn opposite(&self, h: u32) -> u32;
    /// The boundary half-edges in ascending order.
    fn sorted_boundary_half_edges(&self) -> Vec<u32>;
    /// The number of half-edges, `3 * triangle_count`.
    fn half_edge_count(&self) -> usize;
}
