//! The replay of recorded edits with the host store's rules, shared by
//! the unit tests.

use meshflow_plugin_sdk::topology::NONE;

use crate::isotropic::Edit;
use crate::local::edge;

/// Replays `edits` on `triangles` (over `vertex_count` vertices) with the host store's
/// rules, then gives the live vertices their `positions` (3 per vertex slot after the
/// edits) and compacts, as the host does after a run.
pub fn replay(
    vertex_count: usize,
    triangles: &[u32],
    edits: &[Edit],
    positions: &[f32],
) -> (Vec<f32>, Vec<u32>) {
    let mut tris: Vec<[u32; 3]> = triangles.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let mut alive = vec![true; vertex_count];
    for e in edits {
        match *e {
            Edit::SplitEdge { edge: h, .. } => {
                let c = tris[h as usize / 3];
                let (a, b) = (c[h as usize % 3], c[(h as usize + 1) % 3]);
                let v = alive.len() as u32;
                alive.push(true);
                for t in 0..tris.len() {
                    let c = tris[t];
                    if c.contains(&a) && c.contains(&b) {
                        let j = (0..3).find(|&j| edge(c[j], c[(j + 1) % 3]) == edge(a, b)).unwrap();
                        let (y, o) = (c[(j + 1) % 3], c[(j + 2) % 3]);
                        tris[t][(j + 1) % 3] = v;
                        tris.push([v, y, o]);
                    }
                }
            }
            Edit::CollapseEdge { edge: h } => {
                let c = tris[h as usize / 3];
                let (a, b) = (c[h as usize % 3], c[(h as usize + 1) % 3]);
                for c in tris.iter_mut() {
                    if c.contains(&a) && c.contains(&b) {
                        *c = [NONE; 3];
                    } else {
                        c.iter_mut().filter(|v| **v == b).for_each(|v| *v = a);
                    }
                }
                alive[b as usize] = false;
            }
            Edit::SwapEdge { edge: h } => {
                let t = h as usize / 3;
                let k = h as usize % 3;
                let c = tris[t];
                let (a, b) = (c[k], c[(k + 1) % 3]);
                let u = (0..tris.len())
                    .find(|&u| {
                        u != t && (0..3).any(|m| tris[u][m] == b && tris[u][(m + 1) % 3] == a)
                    })
                    .unwrap();
                let m = (0..3).find(|&m| tris[u][m] == b && tris[u][(m + 1) % 3] == a).unwrap();
                let (cc, d) = (c[(k + 2) % 3], tris[u][(m + 2) % 3]);
                tris[t][(k + 1) % 3] = d;
                tris[u][(m + 1) % 3] = cc;
            }
        }
    }
    let mut new_id = vec![NONE; alive.len()];
    let mut out = Vec::new();
    for v in 0..alive.len() {
        if alive[v] {
            new_id[v] = (out.len() / 3) as u32;
            out.extend_from_slice(&positions[3 * v..3 * v + 3]);
        }
    }
    let t =
        tris.iter().filter(|c| c[0] != NONE).flat_map(|c| c.map(|v| new_id[v as usize])).collect();
    (out, t)
}
