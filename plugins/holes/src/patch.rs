//! The patch filling one hole, as a small half-edge mesh that refinement edits in place.
//!
//! Local vertex ids: `0..rim_len` are the hole's loop vertices (fixed, in loop order), later
//! ids are vertices the refinement added. Half-edge `3 * t + k` runs from corner `k` of
//! triangle `t` to corner `(k + 1) % 3`, as in the mesh. A half-edge on the hole's loop has
//! no twin: the triangle across it belongs to the mesh, and the patch never changes it.

use meshflow_plugin_sdk::geometry::{Vec3, angle_between, cross, dot, norm, sub};
use meshflow_plugin_sdk::topology::NONE;
use meshflow_plugin_sdk::topology::halfedge::{next, prev};

/// A triangulated hole: geometry, target edge lengths and connectivity.
pub struct Patch {
    /// Position of every local vertex.
    pub points: Vec<Vec3>,
    /// Liepa's scale attribute: the edge length the surroundings have near each vertex.
    pub sigma: Vec<f64>,
    /// Local vertex ids per triangle, oriented like the mesh around the hole.
    pub triangles: Vec<[u32; 3]>,
    twins: Vec<u32>,
    /// One half-edge leaving each vertex (for walking around it).
    outgoing: Vec<u32>,
    rim_len: usize,
}

impl Patch {
    /// A patch from the hole's loop (`points`/`sigma` of the loop vertices, in order) and a
    /// triangulation of it by loop indices.
    pub fn new(points: Vec<Vec3>, sigma: Vec<f64>, triangles: Vec<[u32; 3]>) -> Self {
        let rim_len = points.len();
        let mut patch = Patch {
            outgoing: vec![NONE; points.len()],
            points,
            sigma,
            twins: vec![NONE; 3 * triangles.len()],
            triangles,
            rim_len,
        };
        // Pair half-edges by their undirected edge: sort (min, max, half-edge).
        let mut keys: Vec<(u32, u32, u32)> = (0..3 * patch.triangles.len() as u32)
            .map(|h| {
                let (a, b) = (patch.origin(h), patch.target(h));
                (a.min(b), a.max(b), h)
            })
            .collect();
        keys.sort_unstable();
        for pair in keys.windows(2) {
            if pair[0].0 == pair[1].0 && pair[0].1 == pair[1].1 {
                patch.twins[pair[0].2 as usize] = pair[1].2;
                patch.twins[pair[1].2 as usize] = pair[0].2;
            }
        }
        for t in 0..patch.triangles.len() as u32 {
            patch.claim_corners(t);
        }
        patch
    }

    /// The number of loop vertices; they are the first local ids and never move.
    pub fn rim_len(&self) -> usize {
        self.rim_len
    }

    /// Whether local vertex `v` was added inside the hole.
    pub fn is_new(&self, v: u32) -> bool {
        v as usize >= self.rim_len
    }

    /// The number of half-edges (`3 * triangles`).
    pub fn half_edge_count(&self) -> u32 {
        3 * self.triangles.len() as u32
    }

    /// The twin of `h`, or [`NONE`] on the hole's loop.
    pub fn twin(&self, h: u32) -> u32 {
        self.twins[h as usize]
    }

    pub fn origin(&self, h: u32) -> u32 {
        self.triangles[h as usize / 3][h as usize % 3]
    }

    pub fn target(&self, h: u32) -> u32 {
        self.origin(next(h))
    }

    /// The corner of `h`'s triangle that `h` does not touch.
    fn apex(&self, h: u32) -> u32 {
        self.origin(prev(h))
    }

    fn point(&self, v: u32) -> Vec3 {
        self.points[v as usize]
    }

    /// Splits triangle `t` at `point` into three; the new vertex gets scale `sigma`.
    /// Returns the three half-edges that were `t`'s sides (their ids change, their twins not).
    pub fn split(&mut self, t: u32, point: Vec3, sigma: f64) -> [u32; 3] {
        let c = self.points.len() as u32;
        self.points.push(point);
        self.sigma.push(sigma);
        self.outgoing.push(NONE);
        let [a, b, d] = self.triangles[t as usize];
        let (t1, t2) = (self.triangles.len() as u32, self.triangles.len() as u32 + 1);
        let [twin_bd, twin_da] = [self.twin(3 * t + 1), self.twin(3 * t + 2)];
        self.triangles[t as usize] = [a, b, c];
        self.triangles.push([b, d, c]);
        self.triangles.push([d, a, c]);
        self.twins.extend([NONE; 6]);
        self.link(3 * t1, twin_bd);
        self.link(3 * t2, twin_da);
        self.link(3 * t + 1, 3 * t1 + 2);
        self.link(3 * t1 + 1, 3 * t2 + 2);
        self.link(3 * t2 + 1, 3 * t + 2);
        for s in [t, t1, t2] {
            self.claim_corners(s);
        }
        [3 * t, 3 * t1, 3 * t2]
    }

    /// Whether edge `h` fails Liepa's relaxation test: the vertex across it lies inside the
    /// circumsphere of `h`'s triangle, i.e. the two angles facing the edge sum to more than
    /// π. Loop edges are never relaxed.
    pub fn needs_swap(&self, h: u32) -> bool {
        let g = self.twin(h);
        if g == NONE {
            return false;
        }
        let (a, b) = (self.point(self.origin(h)), self.point(self.target(h)));
        let (c, d) = (self.point(self.apex(h)), self.point(self.apex(g)));
        let (ca, cb, da, db) = (sub(a, c), sub(b, c), sub(a, d), sub(b, d));
        // With the facing angles α at c and β at d, sin(α + β) scaled by the four edge
        // lengths is `|ca × cb| (da · db) + (ca · cb) |da × db|`; away from zero its sign
        // alone says whether α + β > π, with no `atan2` (software in wasm, the hot spot).
        let sine = norm(cross(ca, cb)) * dot(da, db) + dot(ca, cb) * norm(cross(da, db));
        let lengths = (dot(ca, ca) * dot(cb, cb) * dot(da, da) * dot(db, db)).sqrt();
        if sine.abs() > 1e-6 * lengths {
            return sine < 0.0;
        }
        // Near π (or 2π), the angles themselves; the margin keeps cocircular quads (e.g.
        // squares) from swapping back and forth.
        angle_between(ca, cb) + angle_between(da, db) > std::f64::consts::PI + 1e-9
    }

    /// Replaces the two triangles on edge `h` by the two on the other diagonal, unless that
    /// diagonal already exists, is ruled out by `is_forbidden` (an edge the mesh has between
    /// two loop vertices), or would fold the patch. Returns whether it swapped.
    pub fn swap(&mut self, h: u32, is_forbidden: impl Fn(u32, u32) -> bool) -> bool {
        let g = self.twin(h);
        if g == NONE {
            return false;
        }
        let (a, b, c, d) = (self.origin(h), self.target(h), self.apex(h), self.apex(g));
        if c == d || self.has_edge(c, d) || is_forbidden(c, d) {
            return false;
        }
        let [pa, pb, pc, pd] = [a, b, c, d].map(|v| self.point(v));
        let (n0, n1) = (cross(sub(pd, pa), sub(pc, pa)), cross(sub(pb, pd), sub(pc, pd)));
        if dot(n0, n1) <= 0.0 {
            return false;
        }
        let (t0, t1) = (h / 3, g / 3);
        let [bc, ca, ad, db] = [next(h), prev(h), next(g), prev(g)].map(|e| self.twin(e));
        self.triangles[t0 as usize] = [a, d, c];
        self.triangles[t1 as usize] = [d, b, c];
        self.link(3 * t0, ad);
        self.link(3 * t0 + 2, ca);
        self.link(3 * t1, db);
        self.link(3 * t1 + 1, bc);
        self.link(3 * t0 + 1, 3 * t1 + 2);
        for s in [t0, t1] {
            self.claim_corners(s);
        }
        true
    }

    /// Whether an edge joins `a` and `b`, by walking around `a`. O(degree).
    pub fn has_edge(&self, a: u32, b: u32) -> bool {
        let start = self.outgoing[a as usize];
        if start == NONE {
            return false;
        }
        // Clockwise: leaving half-edge h -> twin(prev(h)) also leaves a.
        let mut h = start;
        loop {
            if self.target(h) == b || self.apex(h) == b {
                return true;
            }
            let back = self.twin(prev(h));
            if back == NONE || back == start {
                break;
            }
            h = back;
        }
        // The fan is open (a is on the loop): walk the other way too.
        let mut h = start;
        loop {
            let twin = self.twin(h);
            if twin == NONE || next(twin) == start {
                return false;
            }
            h = next(twin);
            if self.target(h) == b || self.apex(h) == b {
                return true;
            }
        }
    }

    /// The triangles in the order a depth-first walk across the patch's edges meets them
    /// (from triangle 0), and per new vertex (`v - rim_len`) its place in the order those
    /// triangles first name the new vertices. Refinement leaves both scattered; in this
    /// order consecutive triangles share vertices and each new vertex comes up as the next
    /// id, which is what an edit log codes cheaply (fill-holes' log: a third smaller).
    pub fn walk_order(&self) -> (Vec<u32>, Vec<u32>) {
        let count = self.triangles.len();
        let mut seen = vec![false; count];
        let mut order = Vec::with_capacity(count);
        let mut stack = Vec::new();
        for start in 0..count as u32 {
            if std::mem::replace(&mut seen[start as usize], true) {
                continue;
            }
            order.push(start);
            stack.push(start);
            while let Some(&t) = stack.last() {
                let across = (0..3)
                    .map(|k| self.twin(3 * t + k))
                    .filter(|&g| g != NONE)
                    .map(|g| g / 3)
                    .find(|&u| !seen[u as usize]);
                match across {
                    Some(u) => {
                        seen[u as usize] = true;
                        order.push(u);
                        stack.push(u);
                    }
                    None => {
                        stack.pop();
                    }
                }
            }
        }
        let mut rank = vec![NONE; self.points.len() - self.rim_len];
        let mut named = 0;
        let corners = order.iter().flat_map(|&t| self.triangles[t as usize]);
        // A new vertex no triangle names (none should be) goes last, in id order.
        let unnamed = self.rim_len as u32..self.points.len() as u32;
        for v in corners.filter(|&v| self.is_new(v)).chain(unnamed) {
            let slot = &mut rank[v as usize - self.rim_len];
            if *slot == NONE {
                *slot = named;
                named += 1;
            }
        }
        (order, rank)
    }

    fn link(&mut self, h: u32, g: u32) {
        self.twins[h as usize] = g;
        if g != NONE {
            self.twins[g as usize] = h;
        }
    }

    fn claim_corners(&mut self, t: u32) {
        for k in 0..3 {
            let v = self.triangles[t as usize][k as usize];
            self.outgoing[v as usize] = 3 * t + k;
        }
    }

    /// Consistency of the half-edge structure (for tests): twins are mutual and opposite,
    /// and every vertex's outgoing half-edge leaves it.
    #[cfg(test)]
    pub fn assert_valid(&self) {
        for h in 0..self.half_edge_count() {
            let g = self.twin(h);
            if g != NONE {
                assert_eq!(self.twin(g), h);
                assert_eq!((self.origin(g), self.target(g)), (self.target(h), self.origin(h)));
            }
        }
        for (v, &h) in self.outgoing.iter().enumerate() {
            assert!(h == NONE || self.origin(h) == v as u32);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit square hole (loop clockwise from +z) split into two triangles along 0-2.
    fn square() -> Patch {
        let points = vec![[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0], [1.0, 0.0, 0.0]];
        Patch::new(points, vec![1.0; 4], vec![[2, 1, 0], [0, 3, 2]])
    }

    #[test]
    fn split_and_swap_keep_the_structure_valid() {
        let mut patch = square();
        patch.assert_valid();
        assert!(patch.has_edge(0, 2) && !patch.has_edge(1, 3));
        let sides = patch.split(0, [0.6, 0.6, 0.0], 0.5);
        patch.assert_valid();
        assert_eq!(patch.triangles.len(), 4);
        assert!(patch.has_edge(4, 0) && patch.has_edge(1, 4) && patch.has_edge(2, 4));
        assert!(!patch.has_edge(3, 4));
        // One side of the split triangle is the diagonal 0-2, with a twin.
        let diagonal = sides.into_iter().find(|&h| patch.twin(h) != NONE).unwrap();
        assert!(patch.swap(diagonal, |_, _| false));
        patch.assert_valid();
        assert!(patch.has_edge(3, 4) && !patch.has_edge(0, 2));
        // Loop edges (2 -> 1 is side 0) have no twin and never swap.
        assert_eq!((patch.origin(sides[0]), patch.twin(sides[0])), (2, NONE));
        assert!(!patch.needs_swap(sides[0]) && !patch.swap(sides[0], |_, _| false));
    }

    #[test]
    fn the_walk_meets_every_triangle_once_across_edges_and_names_new_vertices_in_order() {
        let mut patch = square();
        patch.split(0, [0.6, 0.6, 0.0], 0.5);
        patch.split(1, [0.4, 0.2, 0.0], 0.5);
        patch.split(3, [0.2, 0.5, 0.0], 0.5);
        patch.assert_valid();
        let (order, rank) = patch.walk_order();
        let mut sorted = order.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..patch.triangles.len() as u32).collect::<Vec<_>>());
        assert_eq!(order[0], 0);
        // Each triangle after the first shares an edge with one met before it.
        for (i, &t) in order.iter().enumerate().skip(1) {
            let shares = (0..3).any(|k| {
                let g = patch.twin(3 * t + k);
                g != NONE && order[..i].contains(&(g / 3))
            });
            assert!(shares, "triangle {t} is not across an edge from an earlier one");
        }
        // New vertices are ranked 0, 1, 2 in the order the walk's corners first name them.
        let firsts: Vec<u32> = order
            .iter()
            .flat_map(|&t| patch.triangles[t as usize])
            .filter(|&v| patch.is_new(v))
            .fold(Vec::new(), |mut seen, v| {
                if !seen.contains(&v) {
                    seen.push(v);
                }
                seen
            });
        let ranked: Vec<u32> = firsts.iter().map(|&v| rank[v as usize - patch.rim_len()]).collect();
        assert_eq!(ranked, vec![0, 1, 2]);
    }

    #[test]
    fn swaps_respect_existing_and_forbidden_edges() {
        let mut patch = square();
        let diagonal = (0..6).find(|&h| patch.twin(h) != NONE).unwrap();
        assert!(!patch.swap(diagonal, |a, b| (a.min(b), a.max(b)) == (1, 3)));
        assert!(patch.swap(diagonal, |_, _| false));
        assert!(patch.has_edge(1, 3));
        patch.assert_valid();
    }

    #[test]
    fn the_relaxation_test_is_the_circumcircle_test() {
        // A flat rhombus with the long diagonal: the short one is Delaunay.
        let points = vec![[0.0, 0.0, 0.0], [-0.3, 1.0, 0.0], [0.0, 2.0, 0.0], [0.3, 1.0, 0.0]];
        let long = Patch::new(points.clone(), vec![1.0; 4], vec![[2, 1, 0], [0, 3, 2]]);
        let h = (0..6).find(|&h| long.twin(h) != NONE).unwrap();
        assert!(long.needs_swap(h));
        let short = Patch::new(points, vec![1.0; 4], vec![[3, 1, 0], [3, 2, 1]]);
        let h = (0..6).find(|&h| short.twin(h) != NONE).unwrap();
        assert!(!short.needs_swap(h));
    }
}
