//! A plugin-side copy of the connectivity that applies splits, collapses and swaps with the
//! host store's exact id rules (host/mesh/src/store/edges.rs), so a filter can edit locally,
//! seeing each edit's result, and replay the recorded edits on the host with the same ids:
//! a split appends its vertex, then one triangle per split triangle in ascending order; a
//! collapse keeps the half-edge's start; a swap keeps both triangle ids.

use meshflow_plugin_sdk::topology::{NONE, is_proper_triangle};

pub struct LocalMesh {
    /// Corners per triangle slot; removed and improper triangles read `NONE`.
    tris: Vec<[u32; 3]>,
    /// Live triangles around each vertex slot, ascending.
    around: Vec<Vec<u32>>,
}

/// The undirected edge `a`–`b`, smaller id first.
pub fn edge(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

impl LocalMesh {
    /// Improper triangles (a repeated or out-of-range corner, or removed) take no part.
    pub fn new(vertex_count: usize, triangles: &[u32]) -> Self {
        let mut tris = Vec::with_capacity(triangles.len() / 3);
        let mut around = vec![Vec::new(); vertex_count];
        for (t, c) in triangles.chunks_exact(3).enumerate() {
            if is_proper_triangle(triangles, vertex_count, t as u32) {
                for &v in c {
                    around[v as usize].push(t as u32);
                }
                tris.push([c[0], c[1], c[2]]);
            } else {
                tris.push([NONE; 3]);
            }
        }
        LocalMesh { tris, around }
    }

    pub fn vertex_slots(&self) -> usize {
        self.around.len()
    }

    pub fn corners(&self, t: u32) -> [u32; 3] {
        self.tris[t as usize]
    }

    pub fn is_live(&self, t: u32) -> bool {
        self.tris[t as usize][0] != NONE
    }

    /// Live triangles having `v`, ascending.
    pub fn around(&self, v: u32) -> &[u32] {
        &self.around[v as usize]
    }

    /// Live triangles having both `a` and `b`, ascending.
    pub fn on_edge(&self, a: u32, b: u32) -> Vec<u32> {
        self.around(a).iter().copied().filter(|&t| self.corners(t).contains(&b)).collect()
    }

    /// The vertices sharing a live triangle with `v`, ascending.
    pub fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out: Vec<u32> =
            self.around(v).iter().flat_map(|&t| self.corners(t)).filter(|&w| w != v).collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Whether some edge at `v` has a single triangle.
    pub fn is_boundary(&self, v: u32) -> bool {
        self.neighbours(v).into_iter().any(|w| self.on_edge(v, w).len() == 1)
    }

    /// The half-edge `a -> b` of a live triangle, if there is one.
    pub fn half_edge(&self, a: u32, b: u32) -> Option<u32> {
        self.around(a).iter().find_map(|&t| {
            let c = self.corners(t);
            (0..3).find(|&k| c[k] == a && c[(k + 1) % 3] == b).map(|k| 3 * t + k as u32)
        })
    }

    /// Every live edge, smaller id first, sorted.
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut out: Vec<(u32, u32)> = self
            .tris
            .iter()
            .filter(|c| c[0] != NONE)
            .flat_map(|c| [edge(c[0], c[1]), edge(c[1], c[2]), edge(c[2], c[0])])
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The store's split of the live edge `a`–`b`: each triangle `(x, y, o)` on it, ascending,
    /// becomes `(x, v, o)` and appends `(v, y, o)`. Returns the half-edge to record and `v`.
    pub fn split(&mut self, a: u32, b: u32) -> (u32, u32) {
        let on_edge = self.on_edge(a, b);
        let first = on_edge[0];
        let slot = |c: [u32; 3]| {
            (0..3).find(|&j| edge(c[j], c[(j + 1) % 3]) == edge(a, b)).expect("the edge")
        };
        let recorded = 3 * first + slot(self.corners(first)) as u32;
        let v = self.around.len() as u32;
        self.around.push(Vec::new());
        for t in on_edge {
            let corners = self.corners(t);
            let j = slot(corners);
            let (y, o) = (corners[(j + 1) % 3], corners[(j + 2) % 3]);
            self.tris[t as usize][(j + 1) % 3] = v;
            self.around[y as usize].retain(|&u| u != t);
            self.around[v as usize].push(t);
            let new = self.tris.len() as u32;
            self.tris.push([v, y, o]);
            for w in [v, y, o] {
                self.around[w as usize].push(new);
            }
        }
        self.around[v as usize].sort_unstable();
        (recorded, v)
    }

    /// The store's collapse of half-edge `h`: triangles with both ends go, the end's other
    /// triangles turn to the start. Returns the survivor, the removed vertex and how many
    /// triangles went.
    pub fn collapse(&mut self, h: u32) -> (u32, u32, usize) {
        let c = self.corners(h / 3);
        let (s, r) = (c[h as usize % 3], c[(h as usize + 1) % 3]);
        let mut removed = 0;
        for t in std::mem::take(&mut self.around[r as usize]) {
            let corners = self.corners(t);
            if corners.contains(&s) {
                for v in corners {
                    if v != r {
                        self.around[v as usize].retain(|&u| u != t);
                    }
                }
                self.tris[t as usize] = [NONE; 3];
                removed += 1;
            } else {
                self.tris[t as usize] = corners.map(|v| if v == r { s } else { v });
                self.around[s as usize].push(t);
            }
        }
        self.around[s as usize].sort_unstable();
        (s, r, removed)
    }

    /// The store's swap of half-edge `h` = `a -> b` in `(a, b, c)` with `(b, a, d)` in triangle
    /// `u`: they become `(a, d, c)` and `(b, c, d)`, each keeping its id and corner slots.
    pub fn swap(&mut self, h: u32, u: u32) {
        let t = h / 3;
        let k = h as usize % 3;
        let tc = self.corners(t);
        let uc = self.corners(u);
        let (a, b, c) = (tc[k], tc[(k + 1) % 3], tc[(k + 2) % 3]);
        let m = (0..3).find(|&m| uc[m] == b && uc[(m + 1) % 3] == a).expect("b -> a in u");
        let d = uc[(m + 2) % 3];
        self.tris[t as usize][(k + 1) % 3] = d;
        self.tris[u as usize][(m + 1) % 3] = c;
        self.around[b as usize].retain(|&x| x != t);
        self.around[a as usize].retain(|&x| x != u);
        insert_sorted(&mut self.around[d as usize], t);
        insert_sorted(&mut self.around[c as usize], u);
    }
}

fn insert_sorted(list: &mut Vec<u32>, t: u32) {
    let at = list.partition_point(|&x| x < t);
    list.insert(at, t);
}
