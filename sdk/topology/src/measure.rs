//! Whole-mesh measures: enclosed volume per closed component.

use crate::geometry::{Vec3, cross, dot, point, sub};
use crate::{EdgeKind, HalfEdges, TriangleComponents, proper};

/// The volume enclosed by one closed component and how it was found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ComponentVolume {
    /// A triangle of the component (its lowest id).
    pub seed: u32,
    /// Signed: positive when the triangles wind counter-clockwise seen from outside.
    pub volume: f64,
}

/// The signed volume of every closed edge-connected component (no boundary edge among its
/// proper triangles), by the divergence theorem: `Σ a · (b × c) / 6` over its triangles,
/// taken relative to the component's first vertex so large coordinates lose no precision.
/// Open components have no inside and are left out; improper triangles (repeated or
/// out-of-range corners, removed ones) add nothing. Components are listed by their lowest
/// triangle. O(V + T log d).
pub fn closed_component_volumes(positions: &[f32], triangles: &[u32]) -> Vec<ComponentVolume> {
    let vertex_count = positions.len() / 3;
    let half_edges = HalfEdges::new(vertex_count, triangles);
    let components = TriangleComponents::new(vertex_count, triangles);
    closed_component_volumes_of(
        vertex_count,
        || positions,
        triangles,
        &components,
        half_edges.kinds(),
    )
}

/// [`closed_component_volumes`] with the components ([`TriangleComponents::new`]'s, or the
/// same labels from [`TriangleComponents::from_forest`]) and the half-edges' kinds already
/// derived, as a host holds them for the checks that follow: the same values, bit for bit.
/// The positions (`vertex_count` vertices) are read only if some component is closed, and
/// only the closed components' triangles are measured. O(T).
pub fn closed_component_volumes_of<'p>(
    vertex_count: usize,
    positions: impl FnOnce() -> &'p [f32],
    triangles: &[u32],
    components: &TriangleComponents,
    kinds: &[EdgeKind],
) -> Vec<ComponentVolume> {
    let count = components.count();
    let mut seed = vec![u32::MAX; count];
    let mut open = vec![false; count];
    for (t, c) in triangles.chunks_exact(3).enumerate() {
        if !proper([c[0], c[1], c[2]], vertex_count) {
            continue;
        }
        let label = components.label(t as u32) as usize;
        seed[label] = seed[label].min(t as u32);
        let h = 3 * t;
        open[label] |= kinds[h..h + 3].contains(&EdgeKind::Boundary);
    }
    let closed = |l: usize| !open[l] && seed[l] != u32::MAX;
    if !(0..count).any(closed) {
        return Vec::new();
    }
    let positions = positions();
    let mut origin: Vec<Option<Vec3>> = vec![None; count];
    let mut volume = vec![0.0f64; count];
    for (t, c) in triangles.chunks_exact(3).enumerate() {
        let c = [c[0], c[1], c[2]];
        let label = components.label(t as u32) as usize;
        if !closed(label) || !proper(c, vertex_count) {
            continue;
        }
        let o = *origin[label].get_or_insert_with(|| point(positions, c[0]));
        let [a, b, d] = c.map(|v| sub(point(positions, v), o));
        volume[label] += dot(a, cross(b, d)) / 6.0;
    }
    (0..count)
        .filter(|&l| closed(l))
        .map(|l| ComponentVolume { seed: seed[l], volume: volume[l] })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The unit cube, 12 triangles wound outward, shifted by `offset`.
    pub(crate) fn cube(offset: f32) -> (Vec<f32>, Vec<u32>) {
        let (positions, triangles) = crate::shapes::unit_cube();
        (positions.into_iter().map(|c| c + offset).collect(), triangles)
    }

    #[test]
    fn the_unit_cube_encloses_one_far_from_the_origin_too() {
        for offset in [0.0, 1000.0] {
            let (positions, triangles) = cube(offset);
            let v = closed_component_volumes(&positions, &triangles);
            assert_eq!(v.len(), 1);
            assert!((v[0].volume - 1.0).abs() < 1e-9, "{v:?}");
        }
    }

    #[test]
    fn inverted_winding_is_negative_and_open_components_are_left_out() {
        let (positions, mut triangles) = cube(0.0);
        for t in triangles.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
        assert!((closed_component_volumes(&positions, &triangles)[0].volume + 1.0).abs() < 1e-9);
        triangles.truncate(33); // one face missing: open
        assert!(closed_component_volumes(&positions, &triangles).is_empty());
    }

    #[test]
    fn two_cubes_are_two_components_and_removed_triangles_add_nothing() {
        let (mut positions, mut triangles) = cube(0.0);
        let (far, far_triangles) = cube(5.0);
        positions.extend(far);
        triangles.extend(far_triangles.iter().map(|v| v + 8));
        triangles.extend([u32::MAX; 3]);
        let v = closed_component_volumes(&positions, &triangles);
        assert_eq!(v.iter().map(|c| c.seed).collect::<Vec<_>>(), [0, 12]);
        assert!(v.iter().all(|c| (c.volume - 1.0).abs() < 1e-9));
    }
}
