//! Coherent orientation: every patch of triangles joined by manifold edges is made
//! consistently oriented, and a closed patch (no boundary or non-manifold edge) is turned
//! to enclose positive volume (normals outward).

use meshflow_plugin_sdk::geometry::{cross, dot, point};
use meshflow_plugin_sdk::topology::halfedge::{EdgeKind, HalfEdges};
use meshflow_plugin_sdk::topology::manifold::orientation_patches;

/// Which triangles to flip, and what stood in the way.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Orientation {
    /// Triangles to flip, ascending.
    pub flips: Vec<u32>,
    /// Patches (triangles joined by two-triangle edges).
    pub patches: usize,
    /// Closed patches turned so that their normals point outward.
    pub turned_outward: usize,
    /// Patches that cannot be oriented (Möbius-like); each keeps the orientation of a
    /// spanning tree from its first triangle, so some of its edges stay inconsistent.
    pub non_orientable: usize,
}

/// The flips that orient every patch coherently: outward for closed patches, and with the
/// fewest flips for open ones (ties: the patch's first triangle keeps its orientation).
/// Improper triangles are never flipped. O(V + T log d).
pub fn orient_consistently(positions: &[f32], triangles: &[u32]) -> Orientation {
    let half_edges = HalfEdges::new(positions.len() / 3, triangles);
    let mut result = Orientation::default();
    let flip = orientation_patches(&half_edges, |patch, flip| {
        let first = patch.triangles[0];
        if half_edges.kind(3 * first) == EdgeKind::Degenerate {
            return; // an improper triangle: no orientation to fix
        }
        result.patches += 1;
        result.non_orientable += !patch.orientable as usize;
        let turn = if patch.closed && patch.orientable {
            let outward = signed_volume(positions, triangles, patch.triangles, flip) >= 0.0;
            result.turned_outward += !outward as usize;
            !outward
        } else {
            let flipped = patch.triangles.iter().filter(|&&t| flip[t as usize]).count();
            2 * flipped > patch.triangles.len()
        };
        if turn {
            patch.triangles.iter().for_each(|&t| flip[t as usize] ^= true);
        }
    });
    result.flips = (0..flip.len() as u32).filter(|&t| flip[t as usize]).collect();
    result
}

/// Six times the volume enclosed by `patch` as it will be oriented (`flip` applied).
fn signed_volume(positions: &[f32], triangles: &[u32], patch: &[u32], flip: &[bool]) -> f64 {
    patch
        .iter()
        .map(|&t| {
            let i = 3 * t as usize;
            let [a, b, c] = [0, 1, 2].map(|k| point(positions, triangles[i + k]));
            let v = dot(a, cross(b, c));
            if flip[t as usize] { -v } else { v }
        })
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;
    use meshflow_plugin_sdk::topology::manifold::is_oriented;
    use meshflow_plugin_sdk::topology::shapes::unit_cube as cube;

    fn apply(triangles: &mut [u32], flips: &[u32]) {
        for &t in flips {
            triangles.swap(3 * t as usize + 1, 3 * t as usize + 2);
        }
    }

    fn volume(positions: &[f32], triangles: &[u32]) -> f64 {
        let all: Vec<u32> = (0..triangles.len() as u32 / 3).collect();
        signed_volume(positions, triangles, &all, &vec![false; all.len()]) / 6.0
    }

    #[test]
    fn an_outward_cube_needs_nothing() {
        let (p, t) = cube();
        assert!((volume(&p, &t) - 1.0).abs() < 1e-12);
        let o = orient_consistently(&p, &t);
        assert_eq!(o, Orientation { patches: 1, ..Orientation::default() });
    }

    #[test]
    fn flipped_faces_are_flipped_back_and_an_inside_out_cube_turned() {
        let (p, mut t) = cube();
        apply(&mut t, &[1, 4, 9]);
        let o = orient_consistently(&p, &t);
        assert_eq!(o.flips, vec![1, 4, 9]);
        apply(&mut t, &o.flips);
        assert!(is_oriented(&HalfEdges::new(8, &t)));
        assert!(volume(&p, &t) > 0.0);

        // Inside out: every triangle flips.
        let (p, mut t) = cube();
        apply(&mut t, &(0..12).collect::<Vec<_>>());
        let o = orient_consistently(&p, &t);
        assert_eq!(o.flips.len(), 12);
        assert_eq!(o.turned_outward, 1);
        apply(&mut t, &o.flips);
        assert!((volume(&p, &t) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn each_component_is_oriented_on_its_own() {
        // Two cubes, the second shifted, inside out, with its triangles interleaved.
        let (p, t) = cube();
        let mut positions = p.clone();
        positions.extend(p.chunks(3).flat_map(|c| [c[0] + 5.0, c[1], c[2]]));
        let mut triangles = Vec::new();
        for (i, f) in t.chunks(3).enumerate() {
            triangles.extend_from_slice(f);
            let shifted = [f[0] + 8, f[2] + 8, f[1] + 8];
            if i % 2 == 0 {
                triangles.extend(shifted)
            } else {
                triangles.extend([f[0] + 8, f[1] + 8, f[2] + 8])
            }
        }
        let o = orient_consistently(&positions, &triangles);
        assert_eq!(o.patches, 2);
        apply(&mut triangles, &o.flips);
        assert!(is_oriented(&HalfEdges::new(16, &triangles)));
        let (first, second): (Vec<u32>, Vec<u32>) = {
            let mut a = Vec::new();
            let mut b = Vec::new();
            for f in triangles.chunks(3) {
                if f[0] < 8 { a.extend_from_slice(f) } else { b.extend(f.iter().map(|v| v - 8)) }
            }
            (a, b)
        };
        assert!((volume(&p, &first) - 1.0).abs() < 1e-12);
        assert!((volume(&p, &second) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn an_open_strip_flips_its_minority_and_a_moebius_strip_is_reported() {
        // A strip of four quads; triangles 2 and 5 flipped.
        let positions: Vec<f32> =
            (0..10).flat_map(|i| [(i / 2) as f32, (i % 2) as f32, 0.0]).collect();
        let mut triangles = Vec::new();
        for q in 0..4u32 {
            let (a, b, c, d) = (2 * q, 2 * q + 2, 2 * q + 3, 2 * q + 1);
            triangles.extend([a, b, c, a, c, d]);
        }
        apply(&mut triangles, &[2, 5]);
        let o = orient_consistently(&positions, &triangles);
        assert_eq!(o.flips, vec![2, 5]);
        assert_eq!(o.non_orientable, 0);

        // Möbius: the last quad joins the first edge reversed.
        let mut moebius = triangles.clone();
        apply(&mut moebius, &o.flips);
        moebius.extend([8, 1, 0, 8, 0, 9]);
        let o = orient_consistently(&positions, &moebius);
        assert_eq!(o.non_orientable, 1);
    }

    #[test]
    fn degenerate_and_non_manifold_input_gets_a_result() {
        let positions =
            vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
        // Three triangles on edge 0-1, one repeating a vertex, one out of range.
        let triangles = vec![0, 1, 2, 1, 0, 3, 0, 1, 4, 2, 2, 3, 0, 1, 99];
        let o = orient_consistently(&positions, &triangles);
        assert!(o.flips.iter().all(|&t| t < 3));
        assert_eq!(o.patches, 3);
    }
}
