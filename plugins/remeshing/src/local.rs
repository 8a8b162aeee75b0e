//! A plugin-side copy of the connectivity that applies splits, collapses and swaps with the
//! host store's exact id rules (host/mesh/src/store/edges.rs), so a filter can edit locally,
//! seeing each edit's result, and replay the recorded edits on the host with the same ids:
//! a split appends its vertex, then one triangle per split triangle in ascending order; a
//! collapse keeps the half-edge's start; a swap keeps both triangle ids.
//!
//! Each vertex's valence and whether it is on the boundary are kept up to date through the
//! edits, as the filters ask for them millions of times. That holds for collapses that
//! passed [`LocalMesh::collapse_keeps_topology`]: both filters collapse no others.

use std::cell::RefCell;

use meshflow_plugin_sdk::topology::edits::split_on_edge;
use meshflow_plugin_sdk::topology::{NONE, is_proper_triangle};

pub struct LocalMesh {
    /// Corners per triangle slot; removed and improper triangles read `NONE`.
    tris: Vec<[u32; 3]>,
    /// Live triangles around each vertex slot, ascending.
    around: Vec<Vec<u32>>,
    /// Distinct neighbours per vertex slot.
    valence: Vec<u32>,
    /// Whether some edge at the vertex has a single triangle.
    boundary: Vec<bool>,
    /// Per vertex, the last query that marked it (see `shared_neighbours`): a count of
    /// common neighbours without sorting or allocating.
    marks: RefCell<Marks>,
}

#[derive(Default)]
struct Marks {
    stamp: Vec<u32>,
    next: u32,
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
        let mut mesh = LocalMesh {
            tris,
            around,
            valence: Vec::new(),
            boundary: Vec::new(),
            marks: RefCell::new(Marks { stamp: vec![0; vertex_count], next: 0 }),
        };
        let mut ring = Vec::new();
        for v in 0..vertex_count as u32 {
            mesh.ring(v, &mut ring);
            mesh.boundary.push(ring.chunk_by(|x, y| x == y).any(|run| run.len() == 1));
            ring.dedup();
            mesh.valence.push(ring.len() as u32);
        }
        mesh
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
    pub fn on_edge(&self, a: u32, b: u32) -> impl Iterator<Item = u32> + '_ {
        self.around(a).iter().copied().filter(move |&t| self.corners(t).contains(&b))
    }

    /// The other corners of `v`'s triangles, ascending, each as often as it shares a
    /// triangle with `v` (the number of triangles on that edge).
    fn ring(&self, v: u32, out: &mut Vec<u32>) {
        out.clear();
        for &t in self.around(v) {
            out.extend(self.corners(t).into_iter().filter(|&w| w != v));
        }
        out.sort_unstable();
    }

    /// The vertices sharing a live triangle with `v`, ascending.
    pub fn neighbours(&self, v: u32) -> Vec<u32> {
        let mut out = Vec::new();
        self.neighbours_into(v, &mut out);
        out
    }

    /// [`LocalMesh::neighbours`] into `out`, whose allocation is reused.
    pub fn neighbours_into(&self, v: u32, out: &mut Vec<u32>) {
        self.ring(v, out);
        out.dedup();
    }

    /// How many vertices share a live triangle with `v`.
    pub fn valence(&self, v: u32) -> usize {
        self.valence[v as usize] as usize
    }

    /// Whether some edge at `v` has a single triangle.
    pub fn is_boundary(&self, v: u32) -> bool {
        self.boundary[v as usize]
    }

    /// How many vertices are neighbours of both `a` and `b`.
    pub fn shared_neighbours(&self, a: u32, b: u32) -> usize {
        let Marks { stamp, next } = &mut *self.marks.borrow_mut();
        if *next > u32::MAX - 2 {
            stamp.fill(0);
            *next = 0;
        }
        // `ours` marks a's neighbours, `counted` those of b already counted.
        let (ours, counted) = (*next + 1, *next + 2);
        *next = counted;
        for &t in self.around(a) {
            for w in self.corners(t) {
                stamp[w as usize] = ours;
            }
        }
        stamp[a as usize] = 0;
        let mut shared = 0;
        for &t in self.around(b) {
            for w in self.corners(t) {
                if stamp[w as usize] == ours && w != b {
                    stamp[w as usize] = counted;
                    shared += 1;
                }
            }
        }
        shared
    }

    /// The triangles on edge `a`–`b` (one or two) if collapsing it keeps the surface's
    /// topology: the ends share exactly the apexes of those triangles (the link condition),
    /// no apex drops below three neighbours (four inside: a closed fan of two is a doubled
    /// triangle), and the merged vertex keeps at least three.
    pub fn collapse_keeps_topology(&self, a: u32, b: u32) -> Option<EdgeTriangles> {
        let mut on_edge = self.on_edge(a, b);
        let first = on_edge.next()?;
        let triangles = match (on_edge.next(), on_edge.next()) {
            (None, _) => EdgeTriangles { first, second: None },
            (Some(second), None) => EdgeTriangles { first, second: Some(second) },
            (Some(_), Some(_)) => return None,
        };
        let shared = self.shared_neighbours(a, b);
        if shared != triangles.count() {
            return None;
        }
        for t in triangles.iter() {
            let apex = self.corners(t).into_iter().find(|&v| v != a && v != b)?;
            let least = if self.is_boundary(apex) { 3 } else { 4 };
            if self.valence(apex) < least {
                return None;
            }
        }
        if self.valence(a) + self.valence(b) - 2 - shared < 3 {
            return None;
        }
        Some(triangles)
    }

    /// The half-edge `a -> b` of a live triangle, if there is one.
    pub fn half_edge(&self, a: u32, b: u32) -> Option<u32> {
        self.around(a).iter().find_map(|&t| {
            let c = self.corners(t);
            (0..3).find(|&k| c[k] == a && c[(k + 1) % 3] == b).map(|k| 3 * t + k as u32)
        })
    }

    /// Every live edge once, smaller id first, in the order of the lowest triangle on it
    /// (no sort: the filters list the edges several times per pass).
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut out = Vec::with_capacity(self.tris.len() * 3 / 2);
        for (t, c) in (0..).zip(&self.tris) {
            if c[0] == NONE {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (c[k], c[(k + 1) % 3]);
                if self.on_edge(a, b).next() == Some(t) {
                    out.push(edge(a, b));
                }
            }
        }
        out
    }

    /// The store's split of the live edge `a`–`b`: each triangle `(x, y, o)` on it, ascending,
    /// becomes `(x, v, o)` and appends `(v, y, o)`. Returns the half-edge to record and `v`.
    pub fn split(&mut self, a: u32, b: u32) -> (u32, u32) {
        let on_edge: Vec<u32> = self.on_edge(a, b).collect();
        let first = on_edge[0];
        let slot = |c: [u32; 3]| {
            (0..3).find(|&j| edge(c[j], c[(j + 1) % 3]) == edge(a, b)).expect("the edge")
        };
        let recorded = 3 * first + slot(self.corners(first)) as u32;
        let v = self.around.len() as u32;
        self.around.push(Vec::new());
        let on_edge_count = on_edge.len();
        let mut apexes = Vec::with_capacity(on_edge_count);
        for t in on_edge {
            let (kept, appended) = split_on_edge(self.corners(t), a, b, v).expect("on the edge");
            let [_, y, o] = appended;
            apexes.push(o);
            self.tris[t as usize] = kept;
            self.around[y as usize].retain(|&u| u != t);
            self.around[v as usize].push(t);
            let new = self.tris.len() as u32;
            self.tris.push(appended);
            for w in appended {
                self.around[w as usize].push(new);
            }
        }
        self.around[v as usize].sort_unstable();
        self.marks.get_mut().stamp.push(0);
        // v's neighbours are a, b and the apexes; each apex gains v, a and b swap b for v.
        self.valence.push(2 + apexes.len() as u32);
        for o in apexes {
            self.valence[o as usize] += 1;
        }
        self.boundary.push(on_edge_count == 1);
        (recorded, v)
    }

    /// The store's collapse of half-edge `h`: triangles with both ends go, the end's other
    /// triangles turn to the start. Returns the survivor, the removed vertex and how many
    /// triangles went.
    pub fn collapse(&mut self, h: u32) -> (u32, u32, usize) {
        let c = self.corners(h / 3);
        let (s, r) = (c[h as usize % 3], c[(h as usize + 1) % 3]);
        let shared = self.shared_neighbours(s, r) as u32;
        self.valence[s as usize] = self.valence[s as usize] + self.valence[r as usize] - 2 - shared;
        self.valence[r as usize] = 0;
        self.boundary[s as usize] |= self.boundary[r as usize];
        let mut removed = 0;
        for t in std::mem::take(&mut self.around[r as usize]) {
            let corners = self.corners(t);
            if corners.contains(&s) {
                for v in corners {
                    if v != r {
                        self.around[v as usize].retain(|&u| u != t);
                    }
                    if v != r && v != s {
                        // The apex had both ends as neighbours; now it has one.
                        self.valence[v as usize] -= 1;
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
        self.valence[a as usize] -= 1;
        self.valence[b as usize] -= 1;
        self.valence[c as usize] += 1;
        self.valence[d as usize] += 1;
    }
}

fn insert_sorted(list: &mut Vec<u32>, t: u32) {
    let at = list.partition_point(|&x| x < t);
    list.insert(at, t);
}

/// The one or two triangles on a manifold edge.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EdgeTriangles {
    pub first: u32,
    pub second: Option<u32>,
}

impl EdgeTriangles {
    pub fn count(&self) -> usize {
        1 + self.second.is_some() as usize
    }

    pub fn iter(&self) -> impl Iterator<Item = u32> {
        std::iter::once(self.first).chain(self.second)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use meshflow_plugin_sdk::topology::shapes::uv_sphere;

    /// The valence and boundary flags kept through edits, against the mesh rebuilt from its
    /// triangles after every edit.
    fn assert_bookkeeping_exact(mesh: &LocalMesh) {
        let flat: Vec<u32> = mesh.tris.iter().flatten().copied().collect();
        let fresh = LocalMesh::new(mesh.vertex_slots(), &flat);
        for v in 0..mesh.vertex_slots() as u32 {
            if !mesh.around(v).is_empty() {
                assert_eq!(mesh.valence(v), fresh.valence(v), "valence of {v}");
                assert_eq!(mesh.is_boundary(v), fresh.is_boundary(v), "boundary of {v}");
            }
        }
    }

    #[test]
    fn valence_and_boundary_stay_exact_through_splits_collapses_and_swaps() {
        // A sphere with a cap cut off: a closed part and a boundary loop.
        let (p, mut t) = uv_sphere(8, 16);
        let top = (0..p.len() / 3).filter(|&v| p[3 * v + 2] > 0.8).map(|v| v as u32);
        let cap: Vec<u32> = top.collect();
        for c in t.chunks_exact_mut(3) {
            if c.iter().any(|v| cap.contains(v)) {
                c.fill(NONE);
            }
        }
        let mut mesh = LocalMesh::new(p.len() / 3, &t);
        assert!((0..mesh.vertex_slots() as u32).any(|v| mesh.is_boundary(v)));
        // A deterministic walk over edges: split, collapse or swap in turn where allowed.
        let (mut splits, mut collapses, mut swaps) = (0, 0, 0);
        for step in 0..300usize {
            let edges = mesh.edges();
            let (a, b) = edges[(step * 7919) % edges.len()];
            match step % 3 {
                0 => {
                    mesh.split(a, b);
                    splits += 1;
                }
                1 => {
                    if mesh.collapse_keeps_topology(a, b).is_some() {
                        let h = mesh.half_edge(a, b).or(mesh.half_edge(b, a)).unwrap();
                        mesh.collapse(h);
                        collapses += 1;
                    }
                }
                _ => {
                    let (Some(h), Some(g)) = (mesh.half_edge(a, b), mesh.half_edge(b, a)) else {
                        continue;
                    };
                    let apex = |t: u32| mesh.corners(t).into_iter().find(|&v| v != a && v != b);
                    let (c, d) = (apex(h / 3).unwrap(), apex(g / 3).unwrap());
                    if c != d && mesh.on_edge(c, d).next().is_none() {
                        mesh.swap(h, g / 3);
                        swaps += 1;
                    }
                }
            }
            assert_bookkeeping_exact(&mesh);
        }
        assert!(splits > 50 && collapses > 20 && swaps > 20, "{splits} {collapses} {swaps}");
    }
}
