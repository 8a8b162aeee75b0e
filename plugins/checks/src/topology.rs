//! Manifoldness and orientation, as yes/no answers, from the host's derived connectivity.
//!
//! Orientation looks only at proper triangles (three distinct in-range vertex ids): a
//! triangle with a repeated or out-of-range id neither breaks nor establishes it. Such a
//! triangle, or a duplicated one, does make the mesh non-manifold. Zero-area triangles with
//! distinct ids are proper and count like any other.

use meshflow_plugin_sdk::Result;
use meshflow_plugin_sdk::topology::{EdgeKind, NONE, contains_kind, manifold};

use crate::arrays::MeshArrays;
use crate::forest::ParityForest;

/// Whether every triangle is proper and none duplicated, the mesh is edge-manifold (no edge
/// has three or more triangles) and vertex-manifold (the triangles around every vertex form
/// a single fan, so no bow-tie). One pass over the kinds settles a non-manifold edge; the
/// rest is O(V + T).
pub fn is_manifold(mesh: &MeshArrays) -> Result<bool> {
    if contains_kind(mesh.kinds()?, EdgeKind::NonManifold) {
        return Ok(false);
    }
    let (vertex_count, triangles) = (mesh.vertex_slots(), mesh.triangles());
    if manifold::has_improper_triangles(vertex_count, triangles) {
        return Ok(false);
    }
    let half_edges = mesh.view()?;
    Ok(!manifold::has_duplicate_triangles(triangles, &half_edges)
        && manifold::is_vertex_manifold(vertex_count, triangles, &half_edges))
}

/// Whether every interior (two-triangle) edge is traversed in opposite directions by its two
/// triangles. Boundary and non-manifold edges impose nothing. One pass over the kinds.
pub fn is_oriented(mesh: &MeshArrays) -> Result<bool> {
    Ok(!contains_kind(mesh.kinds()?, EdgeKind::InteriorInconsistent))
}

/// Whether flipping some triangles would make the mesh oriented (false for a Möbius strip).
/// O(T); an oriented mesh is its own witness, so the union-find runs only on others.
pub fn is_orientable(mesh: &MeshArrays) -> Result<bool> {
    if is_oriented(mesh)? {
        return Ok(true);
    }
    let kinds = mesh.kinds()?;
    // Two triangles running along their edge the same way must end up flipped relative to
    // each other (parity 1); a cycle of constraints with odd parity cannot be met.
    let mut forest = ParityForest::new(kinds.len() / 3);
    for (h, &twin) in mesh.opposites().iter().enumerate() {
        if twin != NONE && twin as usize > h {
            let relation = (kinds[h] == EdgeKind::InteriorInconsistent) as u8;
            if !forest.union(h as u32 / 3, twin / 3, relation) {
                return Ok(false);
            }
        }
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::*;

    /// `(manifold, oriented, orientable)` of a fixture.
    fn answers(mesh: &Fixture) -> (bool, bool, bool) {
        let arrays = MeshArrays::native(&mesh.positions, &mesh.triangles);
        (
            is_manifold(&arrays).unwrap(),
            is_oriented(&arrays).unwrap(),
            is_orientable(&arrays).unwrap(),
        )
    }

    fn manifold(positions: &[f32], triangles: &[u32]) -> bool {
        is_manifold(&MeshArrays::native(positions, triangles)).unwrap()
    }

    #[test]
    fn closed_and_open_surfaces_are_manifold_and_oriented() {
        assert_eq!(answers(&cube()), (true, true, true));
        assert_eq!(answers(&tetrahedron()), (true, true, true));
        assert_eq!(answers(&open_cube()), (true, true, true));
    }

    #[test]
    fn one_flipped_triangle_is_not_oriented_but_orientable() {
        assert_eq!(answers(&flipped_cube()), (true, false, true));
    }

    #[test]
    fn a_mobius_strip_is_manifold_but_not_orientable() {
        assert_eq!(answers(&mobius_strip(6)), (true, false, false));
    }

    #[test]
    fn sheets_sharing_an_edge_are_not_manifold() {
        // The shared edge has four triangles; no edge has exactly two, so nothing to orient.
        assert_eq!(answers(&two_sheets()), (false, true, true));
    }

    #[test]
    fn a_bow_tie_vertex_is_not_manifold() {
        assert_eq!(answers(&bow_tie()), (false, true, true));
    }

    #[test]
    fn degenerate_triangles_are_not_manifold_but_do_not_affect_orientation() {
        assert_eq!(answers(&degenerate_only()), (false, true, true));
        // A repeated-id triangle glued onto the tetrahedron breaks only manifoldness.
        let mut mesh = tetrahedron();
        mesh.triangles.extend([0, 0, 1, 2, 3, 2]);
        assert_eq!(answers(&mesh), (false, true, true));
        // The case: one triangle `1 1 1`, many times.
        assert!(!manifold(&[0.0; 9], &[1, 1, 1].repeat(10_000)));
    }

    #[test]
    fn duplicated_triangles_are_not_manifold() {
        // Two copies, either orientation: each edge has exactly two triangles.
        for copy in [[0, 1, 2], [0, 2, 1]] {
            let mut mesh = vec![0, 1, 2];
            mesh.extend(copy);
            assert!(!manifold(&[0.0; 9], &mesh), "{copy:?}");
        }
        // A duplicate inside a closed surface.
        let mut mesh = tetrahedron();
        let first: Vec<u32> = mesh.triangles[..3].to_vec();
        mesh.triangles.extend(first);
        assert!(!manifold(&mesh.positions, &mesh.triangles));
        // Removed triangles (as a plugin sees them mid-run) are absent.
        let mut mesh = tetrahedron();
        mesh.triangles.extend([u32::MAX; 3]);
        assert!(manifold(&mesh.positions, &mesh.triangles));
    }
}
