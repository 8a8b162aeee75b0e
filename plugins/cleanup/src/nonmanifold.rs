//! Making a mesh manifold: improper and duplicated triangles go, each non-manifold edge
//! keeps two of its triangles (an oppositely oriented pair where there is one), and each
//! vertex whose triangles form several fans is split into one vertex per fan.

use meshflow_plugin_sdk::topology::NONE;
use meshflow_plugin_sdk::topology::adjacency::VertexTriangles;
use meshflow_plugin_sdk::topology::halfedge::{HalfEdges, origin, target};
use meshflow_plugin_sdk::topology::manifold::non_manifold_vertices;
use meshflow_plugin_sdk::topology::{UnionFind, is_proper_triangle};

/// The edits that make a mesh manifold, in the order to apply them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Repair {
    /// Triangles removed outright (improper, duplicated, or extra on a non-manifold edge),
    /// ascending.
    pub removed: Vec<u32>,
    /// Triangles re-pointed to a vertex copy: removed, then added again as `readded`.
    pub repointed: Vec<u32>,
    /// The corners of the re-pointed triangles, in the same order, naming new vertices by the
    /// ids they get when `new_positions` is appended after the existing vertices.
    pub readded: Vec<u32>,
    /// `x y z` per new vertex (a copy of the split vertex).
    pub new_positions: Vec<f32>,
    /// Per new vertex: the vertex it copies (whose attributes it takes too).
    pub copied_from: Vec<u32>,
    pub improper: usize,
    pub duplicates: usize,
    pub non_manifold_edges: usize,
    pub non_manifold_vertices: usize,
}

/// What it takes to make `triangles` manifold. Unreferenced vertices are left alone.
/// O(V + T log d).
pub fn repair_non_manifold(positions: &[f32], triangles: &[u32]) -> Repair {
    repair_non_manifold_owned(positions, triangles.to_vec())
}

/// [`repair_non_manifold`] working in `triangles` itself rather than a copy of them, and
/// dropping each adjacency once it has served, so the guest holds the mesh once and one
/// adjacency at a time.
pub fn repair_non_manifold_owned(positions: &[f32], triangles: Vec<u32>) -> Repair {
    let vertex_count = positions.len() / 3;
    let tris = triangles.len() / 3;
    let mut repair = Repair::default();
    // The working copy, in which removed triangles read NONE (no half-edges, no incidence).
    let mut work = triangles;
    work.truncate(3 * tris);
    let mut removed = vec![false; tris];

    for t in 0..tris as u32 {
        // Only triangle `t` has been dropped when `t` is tested, so `work` answers as the
        // input would.
        if !is_proper_triangle(&work, vertex_count, t) {
            repair.improper += 1;
            drop_triangle(&mut removed, &mut work, t);
        }
    }

    // A copy is found among the triangles around its smallest corner; the first one stays.
    let around = VertexTriangles::new(vertex_count, &work);
    let sorted = |w: &[u32], t: u32| {
        let mut c = [w[3 * t as usize], w[3 * t as usize + 1], w[3 * t as usize + 2]];
        c.sort_unstable();
        c
    };
    for t in 0..tris as u32 {
        if removed[t as usize] {
            continue;
        }
        let key = sorted(&work, t);
        let earlier = around.of(key[0]).iter().take_while(|&&u| u < t);
        if earlier.filter(|&&u| !removed[u as usize]).any(|&u| sorted(&work, u) == key) {
            repair.duplicates += 1;
            drop_triangle(&mut removed, &mut work, t);
        }
    }
    drop(around);

    let half_edges = HalfEdges::new(vertex_count, &work);
    repair.non_manifold_edges = half_edges.non_manifold_edge_count();
    for group in half_edges.non_manifold_edges().rows() {
        let live: Vec<u32> = group.iter().copied().filter(|&h| !removed[h as usize / 3]).collect();
        let Some(&first) = live.first() else { continue };
        let runs_up = |h: u32| origin(&work, h) < target(&work, h);
        let partner = live[1..]
            .iter()
            .copied()
            .find(|&h| runs_up(h) != runs_up(first))
            .or(live.get(1).copied());
        for h in live {
            if h != first && Some(h) != partner {
                drop_triangle(&mut removed, &mut work, h / 3);
            }
        }
    }

    drop(half_edges);
    let half_edges = HalfEdges::new(vertex_count, &work);
    let bad = non_manifold_vertices(vertex_count, &work, &half_edges);
    repair.non_manifold_vertices = bad.len();
    let around = VertexTriangles::new(vertex_count, &work);
    let mut corners: Vec<[u32; 3]> = Vec::new();
    // Per triangle: its index in `repointed`, or NONE.
    let mut slot_of = vec![NONE; tris];
    let mut next_vertex = vertex_count as u32;
    for v in bad {
        let fan = around.of(v);
        let mut fans = UnionFind::new(fan.len());
        for (i, &t) in fan.iter().enumerate() {
            for h in 3 * t..3 * t + 3 {
                let twin = half_edges.opposite(h);
                let touches_v = origin(&work, h) == v || target(&work, h) == v;
                if twin != NONE && touches_v {
                    let j = fan.binary_search(&(twin / 3)).expect("the twin has v too");
                    fans.union(i as u32, j as u32);
                }
            }
        }
        // The fan of the first triangle keeps v; every other fan gets a copy.
        let mut copy_of_root: Vec<(u32, u32)> = vec![(fans.find(0), v)];
        let p = &positions[3 * v as usize..3 * v as usize + 3];
        for (i, &t) in fan.iter().enumerate() {
            let root = fans.find(i as u32);
            let copy = match copy_of_root.iter().find(|(r, _)| *r == root) {
                Some(&(_, copy)) => copy,
                None => {
                    repair.new_positions.extend_from_slice(p);
                    repair.copied_from.push(v);
                    copy_of_root.push((root, next_vertex));
                    next_vertex += 1;
                    next_vertex - 1
                }
            };
            if copy == v {
                continue;
            }
            let i = 3 * t as usize;
            if slot_of[t as usize] == NONE {
                slot_of[t as usize] = corners.len() as u32;
                repair.repointed.push(t);
                corners.push([work[i], work[i + 1], work[i + 2]]);
            }
            let slot = slot_of[t as usize] as usize;
            for c in &mut corners[slot] {
                if *c == v {
                    *c = copy;
                }
            }
        }
    }
    repair.readded = corners.into_iter().flatten().collect();
    repair.removed = (0..tris as u32).filter(|&t| removed[t as usize]).collect();
    repair
}

fn drop_triangle(removed: &mut [bool], work: &mut [u32], t: u32) {
    removed[t as usize] = true;
    work[3 * t as usize..3 * t as usize + 3].fill(NONE);
}

#[cfg(test)]
mod tests {
    use super::*;
    use meshflow_plugin_sdk::topology::manifold::is_manifold;

    /// The repaired triangle array (removed and re-pointed triangles out, re-added ones
    /// appended) and the vertex count.
    fn applied(positions: &[f32], triangles: &[u32], repair: &Repair) -> (Vec<u32>, usize) {
        let gone: Vec<u32> = repair.removed.iter().chain(&repair.repointed).copied().collect();
        let mut out: Vec<u32> = triangles
            .chunks_exact(3)
            .enumerate()
            .filter(|(t, _)| !gone.contains(&(*t as u32)))
            .flat_map(|(_, c)| c.to_vec())
            .collect();
        out.extend_from_slice(&repair.readded);
        (out, (positions.len() + repair.new_positions.len()) / 3)
    }

    fn manifold(positions: &[f32], triangles: &[u32]) -> bool {
        let n = positions.len() / 3;
        is_manifold(n, triangles, &HalfEdges::new(n, triangles))
    }

    fn grid_positions(n: u32) -> Vec<f32> {
        (0..n * n).flat_map(|i| [(i % n) as f32, (i / n) as f32, 0.0]).collect()
    }

    #[test]
    fn a_bow_tie_is_split_into_two_vertices() {
        // Two triangles touching only at vertex 2.
        let positions = grid_positions(3);
        let triangles = vec![0, 1, 2, 2, 5, 4];
        assert!(!manifold(&positions, &triangles));
        let repair = repair_non_manifold(&positions, &triangles);
        assert_eq!(repair.non_manifold_vertices, 1);
        assert_eq!(repair.removed, Vec::<u32>::new());
        assert_eq!(repair.repointed, vec![1]);
        assert_eq!(repair.readded, vec![9, 5, 4]);
        assert_eq!(repair.new_positions, vec![2.0, 0.0, 0.0]);
        let (fixed, n) = applied(&positions, &triangles, &repair);
        let mut all = positions.clone();
        all.extend_from_slice(&repair.new_positions);
        assert_eq!(n, 10);
        assert!(manifold(&all, &fixed));
    }

    #[test]
    fn a_fin_on_an_edge_is_removed_and_an_oriented_pair_kept() {
        // Edge 0-1 has three triangles: 0 and 2 run it oppositely, 1 the same way as 0.
        let positions = [grid_positions(3), vec![0.5, 0.5, 1.0]].concat();
        let triangles = vec![0, 1, 4, 0, 1, 9, 1, 0, 3];
        let repair = repair_non_manifold(&positions, &triangles);
        assert_eq!(repair.non_manifold_edges, 1);
        assert_eq!(repair.removed, vec![1]);
        let (fixed, _) = applied(&positions, &triangles, &repair);
        assert!(manifold(&positions, &fixed));
    }

    #[test]
    fn improper_and_duplicate_triangles_go_and_unreferenced_vertices_stay() {
        let positions = grid_positions(3);
        let triangles = vec![0, 1, 4, 4, 1, 0, 1, 1, 2, 0, 1, 77, 1, 2, 5, 1, 5, 4];
        let repair = repair_non_manifold(&positions, &triangles);
        assert_eq!((repair.improper, repair.duplicates), (2, 1));
        assert_eq!(repair.removed, vec![1, 2, 3]);
        let (fixed, n) = applied(&positions, &triangles, &repair);
        assert_eq!(n, 9);
        assert!(manifold(&positions, &fixed));
    }

    #[test]
    fn three_sheets_on_one_edge_become_manifold_with_split_vertices() {
        // Three quads hinged on edge 0-1 (a book with three pages), plus a bow-tie at 0.
        let mut positions = vec![0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        for page in 0..3 {
            let a = page as f32 * 2.0;
            positions.extend([a.cos(), 0.0, a.sin(), a.cos(), 1.0, a.sin()]);
        }
        positions.extend([-1.0, -1.0, 0.0, -1.0, -1.5, 0.0]);
        let mut triangles = Vec::new();
        for page in 0..3u32 {
            let (c, d) = (2 + 2 * page, 3 + 2 * page);
            triangles.extend([0, c, d, 0, d, 1]);
        }
        triangles.extend([0, 8, 9]);
        let repair = repair_non_manifold(&positions, &triangles);
        let (fixed, _) = applied(&positions, &triangles, &repair);
        let mut all = positions.clone();
        all.extend_from_slice(&repair.new_positions);
        assert!(manifold(&all, &fixed), "{repair:?}");
        // One page loses its hinge triangle and hangs on at vertex 0 through its other one.
        assert_eq!(repair.removed.len(), 1);
        assert!(!repair.new_positions.is_empty());
    }
}
