//! The rules every reader applies while building a mesh, so all formats accept and reject
//! the same things with the same messages.

use super::error::{Invalid, Position, ReadResult};

/// Rejects a vertex with a NaN or infinite coordinate: no algorithm can use it, and it
/// would poison bounding boxes and hashes downstream.
#[inline]
pub(crate) fn check_finite(vertex: usize, p: [f32; 3], at: Position) -> ReadResult<()> {
    if p.iter().all(|c| c.is_finite()) {
        return Ok(());
    }
    let bad = p.iter().find(|c| !c.is_finite()).copied().unwrap_or_default();
    Err(Invalid::at(at, format!("vertex {vertex} has a non-finite coordinate ({bad})")))
}

/// Checks one face corner against the number of vertices and returns it as an id.
#[inline]
pub(crate) fn check_corner(
    face: usize,
    index: i64,
    vertices: u64,
    at: Position,
) -> ReadResult<u32> {
    if index >= 0 && (index as u64) < vertices {
        return Ok(index as u32);
    }
    Err(Invalid::at(at, out_of_range(face, index, vertices)))
}

/// The message for a corner that names no vertex.
pub(crate) fn out_of_range(face: usize, index: i64, vertices: u64) -> String {
    if index < 0 {
        format!("face {face} uses vertex {index}, but vertex indices cannot be negative")
    } else {
        format!("face {face} uses vertex {index}, but there are only {vertices} vertices")
    }
}

/// Rejects faces that cannot be triangulated. Repeated corners are kept: raw scans have
/// degenerate faces and loading must not change them.
#[inline]
pub(crate) fn check_arity(face: usize, corners: i64, at: Position) -> ReadResult<()> {
    if corners >= 3 {
        return Ok(());
    }
    Err(Invalid::at(at, format!("face {face} has {corners} corners, a face needs at least 3")))
}

/// Appends a polygon of at least 3 corners as a triangle fan `(c0, ci, ci+1)`. Exact for
/// convex polygons, which is what scanners and exporters write.
#[inline]
pub(crate) fn push_fan(triangles: &mut Vec<u32>, corners: &[u32]) {
    debug_assert!(corners.len() >= 3);
    let first = corners[0];
    for pair in corners[1..].windows(2) {
        triangles.extend_from_slice(&[first, pair[0], pair[1]]);
    }
}

/// A capacity hint from a count read in a file, capped by what the remaining bytes can hold
/// at `min_bytes` each, so a lying header cannot make us allocate more than the file size.
#[inline]
pub(crate) fn capacity(count: u64, remaining_bytes: usize, min_bytes: usize) -> usize {
    let plausible = remaining_bytes / min_bytes.max(1);
    usize::try_from(count).unwrap_or(usize::MAX).min(plausible)
}

/// Vertex ids are `u32`: a file with more vertices cannot be represented.
pub(crate) fn check_vertex_count(count: u64, at: Position) -> ReadResult<()> {
    if count <= u64::from(u32::MAX) {
        return Ok(());
    }
    Err(Invalid::at(at, format!("{count} vertices do not fit 32-bit vertex ids")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn polygons_become_fans_around_their_first_corner() {
        let mut triangles = vec![9, 9, 9];
        push_fan(&mut triangles, &[4, 5, 6]);
        push_fan(&mut triangles, &[0, 1, 2, 3, 7]);
        assert_eq!(triangles, [9, 9, 9, 4, 5, 6, 0, 1, 2, 0, 2, 3, 0, 3, 7]);
    }

    #[test]
    fn corners_and_arity_are_checked() {
        let at = Position::Line(3);
        assert_eq!(check_corner(0, 4, 5, at).unwrap(), 4);
        assert!(check_corner(0, 5, 5, at).unwrap_err().reason.contains("only 5 vertices"));
        assert!(check_corner(0, -1, 5, at).unwrap_err().reason.contains("negative"));
        assert!(check_arity(2, 3, at).is_ok());
        assert_eq!(
            check_arity(2, 2, at).unwrap_err().reason,
            "face 2 has 2 corners, a face needs at least 3"
        );
        assert!(check_finite(1, [0.0, f32::NAN, 1.0], at).unwrap_err().reason.contains("NaN"));
    }

    #[test]
    fn capacities_from_file_counts_are_capped_by_the_bytes_present() {
        assert_eq!(capacity(10, 1000, 12), 10);
        assert_eq!(capacity(4_000_000_000, 20, 12), 1);
        assert_eq!(capacity(u64::MAX, 0, 0), 0);
    }
}
