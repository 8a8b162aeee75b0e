//! Where a filled hole's new vertices take their attribute values from (colours, quality,
//! texture coordinates; applied by the SDK's `blend_new_vertex_attributes`).
//!
//! The values spread inwards from the hole's boundary, breadth first over the patch's
//! edges: every new vertex blends its patch neighbours one ring nearer the boundary, each
//! weighed by the inverse of its distance. A value is so a convex combination of boundary
//! values (by induction over the rings), within their range per channel, and varies
//! smoothly from one side of the hole to the other, as the surface around it does.

use meshflow_plugin_sdk::geometry::distance;

use crate::patch::Patch;

/// The patch's new vertices in the order their values can be computed (ring by ring from
/// the boundary, ascending local ids within a ring), each with its parents and weights, in
/// `global` ids (the mesh's ids of the boundary vertices and of the new vertices as they
/// will be appended).
pub fn rim_first_blends(patch: &Patch, global: impl Fn(u32) -> u32) -> Vec<(u32, Vec<(u32, f64)>)> {
    let count = patch.points.len();
    let rim_len = patch.rim_len();
    let mut neighbours: Vec<Vec<u32>> = vec![Vec::new(); count];
    for t in &patch.triangles {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
        }
    }
    for list in &mut neighbours {
        list.sort_unstable();
        list.dedup();
    }
    // Rings: 0 on the boundary, then breadth first; `u32::MAX` where the patch does not
    // reach (a new vertex no triangle uses: it keeps its default).
    let mut ring = vec![u32::MAX; count];
    let mut front: Vec<u32> = (0..rim_len as u32).collect();
    front.iter().for_each(|&v| ring[v as usize] = 0);
    let mut order = Vec::with_capacity(count - rim_len);
    let mut level = 0;
    while !front.is_empty() {
        level += 1;
        let mut next: Vec<u32> = Vec::new();
        for &v in &front {
            for &w in &neighbours[v as usize] {
                if ring[w as usize] == u32::MAX {
                    ring[w as usize] = level;
                    next.push(w);
                }
            }
        }
        next.sort_unstable();
        order.extend_from_slice(&next);
        front = next;
    }
    order
        .into_iter()
        .map(|v| {
            let p = patch.points[v as usize];
            let parents = neighbours[v as usize]
                .iter()
                .filter(|&&w| ring[w as usize] < ring[v as usize])
                .map(|&w| {
                    let d = distance(p, patch.points[w as usize]);
                    let weight = if d > 0.0 && d.is_finite() { 1.0 / d } else { 1.0 };
                    (global(w), weight)
                })
                .collect();
            (global(v), parents)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn new_vertices_follow_the_rings_from_the_boundary_and_blend_the_ring_before() {
        // A square loop 0..4 with a centre vertex 4 split further at 5 (inside 0-1-4).
        let points = vec![[0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [2.0, 2.0, 0.0], [0.0, 2.0, 0.0]];
        let mut patch = Patch::new(points, vec![1.0; 4], vec![[0, 1, 2], [0, 2, 3]]);
        patch.split(0, [1.5, 0.5, 0.0], 1.0); // 4, in triangle 0 1 2
        patch.split(0, [1.0, 0.2, 0.0], 1.0); // 5, in the piece on edge 0 1
        let blends = rim_first_blends(&patch, |v| 100 + v);
        let ids: Vec<u32> = blends.iter().map(|(v, _)| *v).collect();
        // Vertex 4 touches 0, 1 and 2; vertex 5 touches 0, 1 and 4: both one ring in.
        assert_eq!(ids, vec![104, 105]);
        for (_, parents) in &blends {
            assert!(parents.iter().all(|&(p, w)| p < 104 && w > 0.0), "{parents:?}");
        }
        let parents_of_5: Vec<u32> = blends[1].1.iter().map(|&(p, _)| p).collect();
        assert_eq!(parents_of_5, vec![100, 101]);
    }
}
