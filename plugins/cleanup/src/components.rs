//! Choosing the small connected components to remove.

use meshflow_plugin_sdk::topology::components::TriangleComponents;

/// Which components go: every one but the largest, or every one below a size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// Keep only the largest component by triangle count (ties: the one holding the smallest
    /// triangle id).
    Largest,
    /// Keep every component with at least this many triangles.
    AtLeast(u32),
}

/// What removing the small components takes away.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Removal {
    /// Triangles of the removed components, ascending.
    pub triangles: Vec<u32>,
    /// Vertices that only removed triangles used, ascending. Vertices no triangle used in the
    /// first place are not listed: they belong to no component.
    pub vertices: Vec<u32>,
    /// How many components are removed.
    pub components: usize,
    /// How many components there were.
    pub components_before: usize,
}

/// The triangles and vertices to remove so that only the components chosen by `keep`
/// remain. Components are edge-connected ([`TriangleComponents::new`]): pieces touching at a
/// single vertex are separate, and a vertex shared by a kept and a removed piece stays.
/// O(V + T log d).
pub fn small_components(vertex_count: usize, triangles: &[u32], keep: Keep) -> Removal {
    let components = TriangleComponents::new(vertex_count, triangles);
    let sizes = components.sizes();
    let kept: Vec<bool> = match keep {
        Keep::Largest => {
            let largest = components.largest();
            (0..sizes.len() as u32).map(|l| Some(l) == largest).collect()
        }
        Keep::AtLeast(min) => sizes.iter().map(|&s| s >= min).collect(),
    };
    let removed_components = kept.iter().filter(|&&k| !k).count();
    if removed_components == 0 {
        return Removal { components_before: sizes.len(), ..Removal::default() };
    }

    let mut removed_triangles = Vec::new();
    // Per vertex: used by a kept triangle, used by a removed one.
    let mut used_by_kept = vec![false; vertex_count];
    let mut used_by_removed = vec![false; vertex_count];
    for (t, corners) in triangles.chunks_exact(3).enumerate() {
        let is_kept = kept[components.label(t as u32) as usize];
        if !is_kept {
            removed_triangles.push(t as u32);
        }
        let used = if is_kept { &mut used_by_kept } else { &mut used_by_removed };
        for &v in corners {
            if let Some(u) = used.get_mut(v as usize) {
                *u = true;
            }
        }
    }
    let vertices = (0..vertex_count as u32)
        .filter(|&v| used_by_removed[v as usize] && !used_by_kept[v as usize])
        .collect();
    Removal {
        triangles: removed_triangles,
        vertices,
        components: removed_components,
        components_before: sizes.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A quad (2 triangles, vertices 0-3), a single triangle (4-6), and a bow-tie partner of
    /// the quad sharing vertex 0 only (0, 7, 8); vertex 9 is unreferenced.
    const TRIANGLES: [u32; 12] = [0, 1, 2, 0, 2, 3, 4, 5, 6, 0, 7, 8];
    const VERTICES: usize = 10;

    #[test]
    fn keeping_the_largest_removes_the_rest_and_their_own_vertices() {
        let removal = small_components(VERTICES, &TRIANGLES, Keep::Largest);
        assert_eq!(removal.triangles, [2, 3]);
        // Vertex 0 is shared with the kept quad; 9 was never used.
        assert_eq!(removal.vertices, [4, 5, 6, 7, 8]);
        assert_eq!((removal.components, removal.components_before), (2, 3));
    }

    #[test]
    fn a_minimum_size_removes_only_smaller_components() {
        let removal = small_components(VERTICES, &TRIANGLES, Keep::AtLeast(2));
        assert_eq!(removal.triangles, [2, 3]);
        let removal = small_components(VERTICES, &TRIANGLES, Keep::AtLeast(1));
        assert_eq!(removal, Removal { components_before: 3, ..Removal::default() });
        let removal = small_components(VERTICES, &TRIANGLES, Keep::AtLeast(3));
        assert_eq!(removal.triangles, [0, 1, 2, 3]);
        assert_eq!(removal.vertices, [0, 1, 2, 3, 4, 5, 6, 7, 8]);
    }

    #[test]
    fn ties_keep_the_component_with_the_smallest_triangle_id() {
        // Two single triangles: the first stays.
        let removal = small_components(6, &[3, 4, 5, 0, 1, 2], Keep::Largest);
        assert_eq!((removal.triangles, removal.vertices), (vec![1], vec![0, 1, 2]));
    }

    #[test]
    fn empty_and_degenerate_input_do_not_panic() {
        assert_eq!(small_components(0, &[], Keep::Largest), Removal::default());
        // A triangle with a repeated id joins through its one real edge.
        let removal = small_components(4, &[0, 1, 2, 1, 1, 2, 3, 3, 3], Keep::Largest);
        assert_eq!((removal.triangles, removal.vertices), (vec![2], vec![3]));
    }
}
