//! Manifoldness and orientation tests.
//!
//! The edge, vertex and orientation tests look only at proper triangles (three distinct
//! in-range vertex ids). [`is_manifold`] also refuses improper and duplicated triangles: a
//! triangle `1 1 1` repeated ten million times is no surface.

use super::NONE;
use super::halfedge::{EdgeKind, EdgeLookup, HalfEdges, next, origin, prev};

/// Whether no edge has three or more triangles. O(1).
#[inline]
pub fn is_edge_manifold(half_edges: &HalfEdges) -> bool {
    half_edges.non_manifold_edge_count() == 0
}

/// Whether every interior (two-triangle) edge is traversed in opposite directions by its two
/// half-edges. Boundary and non-manifold edges do not matter. O(1).
#[inline]
pub fn is_oriented(half_edges: &HalfEdges) -> bool {
    half_edges.inconsistent_edge_count() == 0
}

/// The vertices whose triangles do not form a single fan, ascending. O(V + T).
///
/// A vertex is manifold when its proper triangles are all connected to each other by
/// crossing *interior* (two-triangle) edges that contain the vertex — one open fan (a disk
/// touching the boundary) or one closed fan (a disk around the vertex). A bow-tie (two fans
/// meeting at the vertex) fails, as does every endpoint of a non-manifold edge (the sheets
/// meeting there are separate fans). Vertices without proper triangles (unreferenced, or
/// only in degenerate triangles) are manifold.
pub fn non_manifold_vertices(
    vertex_count: usize,
    triangles: &[u32],
    half_edges: &impl EdgeLookup,
) -> Vec<u32> {
    scan_vertices(vertex_count, triangles, half_edges, false)
}

/// Whether every vertex is manifold (see [`non_manifold_vertices`]); stops at the first
/// failure. O(V + T) with a [`HalfEdges`] or a [`HalfEdgeView`](crate::HalfEdgeView).
pub fn is_vertex_manifold(
    vertex_count: usize,
    triangles: &[u32],
    half_edges: &impl EdgeLookup,
) -> bool {
    scan_vertices(vertex_count, triangles, half_edges, true).is_empty()
}

/// The `is-manifold` check: every triangle proper, none duplicated, edge- and
/// vertex-manifold. O(V + T).
pub fn is_manifold(vertex_count: usize, triangles: &[u32], half_edges: &HalfEdges) -> bool {
    !has_improper_triangles(vertex_count, triangles)
        && is_edge_manifold(half_edges)
        && !has_duplicate_triangles(triangles, half_edges)
        && is_vertex_manifold(vertex_count, triangles, half_edges)
}

/// Whether some triangle repeats a corner or names a vertex `>= vertex_count`. A removed
/// triangle (all three corners [`NONE`], as a plugin sees it mid-run) is absent, not
/// improper. O(T).
pub fn has_improper_triangles(vertex_count: usize, triangles: &[u32]) -> bool {
    triangles.chunks_exact(3).any(|t| {
        let removed = t.iter().all(|&c| c == NONE);
        let in_range = t.iter().all(|&c| (c as usize) < vertex_count);
        !removed && (!in_range || t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
    })
}

/// Whether two proper triangles have the same three corners, in any order. Only meaningful
/// when no edge is non-manifold (three or more copies make one): then two copies share each
/// edge as its only two triangles, and the corners opposite that edge are the same. O(T).
pub fn has_duplicate_triangles(triangles: &[u32], half_edges: &impl EdgeLookup) -> bool {
    let opposite_corner = |h: u32| origin(triangles, prev(h));
    (0..half_edges.half_edge_count() as u32).any(|h| {
        half_edges.kind(h).is_interior()
            && opposite_corner(h) == opposite_corner(half_edges.opposite(h))
    })
}

fn scan_vertices(
    vertex_count: usize,
    triangles: &[u32],
    half_edges: &impl EdgeLookup,
    first_only: bool,
) -> Vec<u32> {
    // Per vertex: how many proper triangles surround it. Each vertex's fan walk starts at its
    // first half-edge (marked in `starts`), and walks run in half-edge order, so they touch
    // neighbouring triangles even when vertex ids have no locality.
    let mut around = vec![0u32; vertex_count];
    let half_edge_count = half_edges.half_edge_count();
    let mut starts = vec![0u64; half_edge_count.div_ceil(64)];
    for h in 0..half_edge_count as u32 {
        if half_edges.kind(h) != EdgeKind::Degenerate {
            let n = &mut around[origin(triangles, h) as usize];
            if *n == 0 {
                starts[h as usize / 64] |= 1 << (h % 64);
            }
            *n += 1;
        }
    }
    let mut bad = Vec::new();
    for (word, &bits) in starts.iter().enumerate() {
        let mut bits = bits;
        while bits != 0 {
            let h = (64 * word) as u32 + bits.trailing_zeros();
            bits &= bits - 1;
            let v = origin(triangles, h);
            let n = around[v as usize];
            if n > 1 && fan_size(triangles, half_edges, h, n) != n {
                bad.push(v);
                if first_only {
                    return bad;
                }
            }
        }
    }
    bad.sort_unstable();
    bad
}

/// The number of triangles in the fan around `origin(h)` that contains `h`'s triangle,
/// walking both ways over interior edges; stops early beyond `limit`.
fn fan_size(triangles: &[u32], half_edges: &impl EdgeLookup, h: u32, limit: u32) -> u32 {
    let v = origin(triangles, h);
    let start = h / 3;
    let other_at = |g: u32| {
        if origin(triangles, g) == v { prev(g) } else { next(g) }
    };
    let mut count = 1;
    // Turn one way across h's edge, then (if the fan is open) the other way across prev(h).
    for first in [h, prev(h)] {
        let mut e = first;
        while half_edges.kind(e).is_interior() {
            let g = half_edges.opposite(e);
            if g / 3 == start {
                return count; // closed fan
            }
            count += 1;
            if count > limit {
                return count;
            }
            e = other_at(g);
        }
    }
    count
}

/// Which triangles to flip to make the mesh oriented, or `None` if it is not orientable.
/// O(T) time and memory.
///
/// Triangles are 2-coloured by breadth-first search over interior (two-triangle) edges; the
/// mesh is orientable when no interior edge demands a contradiction (a Möbius strip does).
/// Non-manifold edges impose nothing. Within each interior-edge-connected patch the smaller
/// side is flipped (on a tie, the side without the patch's smallest triangle), so an
/// oriented mesh yields all `false`. Degenerate triangles are never flipped.
pub fn orientation_flips(half_edges: &HalfEdges) -> Option<Vec<bool>> {
    let mut orientable = true;
    let flip = orientation_patches(half_edges, |patch, flip| {
        orientable &= patch.orientable;
        let flipped = patch.triangles.iter().filter(|&&t| flip[t as usize]).count();
        if 2 * flipped > patch.triangles.len() {
            patch.triangles.iter().for_each(|&t| flip[t as usize] ^= true);
        }
    });
    orientable.then_some(flip)
}

/// A set of triangles joined by interior (two-triangle) edges, as
/// [`orientation_patches`] hands it over.
pub struct OrientationPatch<'a> {
    /// In breadth-first order from the patch's smallest triangle.
    pub triangles: &'a [u32],
    /// No edge of the patch is a boundary, non-manifold or degenerate one.
    pub closed: bool,
    /// No interior edge contradicts the colouring (a Möbius strip does).
    pub orientable: bool,
}

/// 2-colours every patch of triangles joined by interior edges by breadth-first search from
/// its smallest triangle (`true`: flip it to agree with that triangle), calls `visit` with
/// each patch and the colouring so far (it may invert the patch's own entries, to choose the
/// other side), and returns the colouring. O(T) time and memory.
pub fn orientation_patches(
    half_edges: &HalfEdges,
    mut visit: impl FnMut(OrientationPatch, &mut [bool]),
) -> Vec<bool> {
    let tris = half_edges.len() / 3;
    let mut flip = vec![false; tris];
    let mut seen = vec![false; tris];
    let mut queue: Vec<u32> = Vec::new();
    for root in 0..tris as u32 {
        if seen[root as usize] {
            continue;
        }
        seen[root as usize] = true;
        queue.clear();
        queue.push(root);
        let (mut head, mut closed, mut orientable) = (0, true, true);
        while head < queue.len() {
            let t = queue[head];
            head += 1;
            for h in 3 * t..3 * t + 3 {
                let kind = half_edges.kind(h);
                if !kind.is_interior() {
                    closed = false;
                    continue;
                }
                let u = half_edges.opposite(h) / 3;
                let want = flip[t as usize] ^ (kind == EdgeKind::InteriorInconsistent);
                if !seen[u as usize] {
                    seen[u as usize] = true;
                    flip[u as usize] = want;
                    queue.push(u);
                } else if flip[u as usize] != want {
                    orientable = false;
                }
            }
        }
        visit(OrientationPatch { triangles: &queue, closed, orientable }, &mut flip);
    }
    flip
}

/// Whether some choice of triangle flips makes every interior edge consistently oriented
/// (see [`orientation_flips`]; a Möbius strip is not orientable). O(T).
pub fn is_orientable(half_edges: &HalfEdges) -> bool {
    orientation_flips(half_edges).is_some()
}
