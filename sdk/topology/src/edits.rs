//! The host store's id rules for edge edits, per triangle: the store applies them, and
//! plugins that edit a local copy of the mesh apply the same functions, so both agree id for
//! id when the recorded edits are replayed on the host.

/// What `split-edge` of edge `a`–`b`, at the new vertex `v`, makes of a triangle on that
/// edge: it keeps its id and becomes `(x, v, o)`, and `(v, y, o)` is appended, where the
/// triangle runs the edge as `x -> y` and `o` is its third corner (so both keep its
/// winding). `None` if the triangle does not have the edge.
///
/// ```
/// use meshflow_topology::edits::split_on_edge;
/// assert_eq!(split_on_edge([0, 1, 2], 1, 0, 9), Some(([0, 9, 2], [9, 1, 2])));
/// assert_eq!(split_on_edge([0, 1, 2], 1, 3, 9), None);
/// ```
pub fn split_on_edge(corners: [u32; 3], a: u32, b: u32, v: u32) -> Option<([u32; 3], [u32; 3])> {
    let j = (0..3).find(|&j| {
        let (x, y) = (corners[j], corners[(j + 1) % 3]);
        (x, y) == (a, b) || (x, y) == (b, a)
    })?;
    let (y, o) = (corners[(j + 1) % 3], corners[(j + 2) % 3]);
    let mut kept = corners;
    kept[(j + 1) % 3] = v;
    Some((kept, [v, y, o]))
}
