//! Choosing the small connected components to remove, from the host's list of them: the
//! plugin never reads the mesh for this service, so it takes meshes of any size the host
//! holds (the host finds the components and removes each chosen one with the vertices it
//! leaves unused).

use meshflow_plugin_sdk::Component;

/// Which components go: every one but the largest, or every one below a size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Keep {
    /// Keep only the largest component by triangle count (ties: the one holding the smallest
    /// triangle id).
    Largest,
    /// Keep every component with at least this many triangles.
    AtLeast(u32),
}

/// The first triangles of the components (as the host lists them: ascending by first
/// triangle) that `keep` does not keep, ascending.
pub fn to_remove(components: &[Component], keep: Keep) -> Vec<u32> {
    let largest = largest(components);
    let kept = |i: usize, c: &Component| match keep {
        Keep::Largest => Some(i) == largest,
        Keep::AtLeast(min) => c.triangles >= min,
    };
    let removed = components.iter().enumerate().filter(|&(i, c)| !kept(i, c));
    removed.map(|(_, c)| c.first_triangle).collect()
}

/// The index of the component with the most triangles, the first among equals.
fn largest(components: &[Component]) -> Option<usize> {
    let mut best: Option<usize> = None;
    for (i, c) in components.iter().enumerate() {
        if best.is_none_or(|b| c.triangles > components[b].triangles) {
            best = Some(i);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    fn listed(sizes: &[(u32, u32)]) -> Vec<Component> {
        sizes
            .iter()
            .map(|&(first_triangle, triangles)| Component { first_triangle, triangles })
            .collect()
    }

    #[test]
    fn keeping_the_largest_removes_every_other_component() {
        let found = listed(&[(0, 2), (2, 5), (3, 1)]);
        assert_eq!(to_remove(&found, Keep::Largest), [0, 3]);
    }

    #[test]
    fn a_minimum_size_removes_only_smaller_components() {
        let found = listed(&[(0, 2), (2, 1), (3, 1)]);
        assert_eq!(to_remove(&found, Keep::AtLeast(2)), [2, 3]);
        assert_eq!(to_remove(&found, Keep::AtLeast(1)), [0u32; 0]);
        assert_eq!(to_remove(&found, Keep::AtLeast(3)), [0, 2, 3]);
    }

    #[test]
    fn ties_keep_the_component_with_the_smallest_triangle_id() {
        let found = listed(&[(0, 1), (1, 1)]);
        assert_eq!(to_remove(&found, Keep::Largest), [1]);
        assert_eq!(to_remove(&[], Keep::Largest), [0u32; 0]);
    }
}
