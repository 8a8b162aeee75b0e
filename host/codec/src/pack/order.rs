//! The order in which vertex positions are coded: derived from the connectivity alone (the
//! decoder has it before the first position), so it costs nothing to transmit.
//!
//! Meshes from other tools number their vertices in no useful order (the bunny's OBJ: a
//! vertex's nearest id among its neighbours is a median 42 away), so in id order 38 % of the
//! bunny's vertices had no parallelogram to be predicted by (10 % not even a decoded
//! neighbour); in this order all but a handful have one. Here the next vertex is always
//! one with the most triangles whose two other corners are already decoded — each such
//! triangle gives a parallelogram prediction or at least known neighbours — growing each
//! connected piece from its lowest id like a front.

use meshflow_topology::VertexTriangles;

/// Scores above this are not told apart: a vertex with that many known triangles is
/// predicted as well as it will be.
const MAX_SCORE: usize = 7;

/// Yields every vertex id once, in coding order, for `triangles` (ids below the vertex count
/// of `around`). A vertex counts as decoded from the next call on, so between calls the
/// caller codes the vertex just yielded from the [`decoded`](Self::decoded) ones. Ties go to
/// the vertex that reached its score last.
pub(super) struct CodingOrder<'a> {
    around: &'a VertexTriangles,
    triangles: &'a [u32],
    decoded: Vec<bool>,
    /// 0: no decoded neighbour; else 1 + triangles with both other corners decoded (capped).
    score: Vec<u8>,
    /// Vertices by the score they had when pushed; stale entries are skipped when popped.
    waiting: [Vec<u32>; MAX_SCORE + 1],
    lowest_unseen: usize,
    /// The vertex yielded last, not yet marked decoded.
    pending: Option<u32>,
}

impl<'a> CodingOrder<'a> {
    pub(super) fn new(around: &'a VertexTriangles, triangles: &'a [u32]) -> Self {
        let vertex_count = around.vertex_count();
        Self {
            around,
            triangles,
            decoded: vec![false; vertex_count],
            score: vec![0; vertex_count],
            waiting: Default::default(),
            lowest_unseen: 0,
            pending: None,
        }
    }

    /// Which vertices are decoded: all those yielded before the last one.
    pub(super) fn decoded(&self) -> &[bool] {
        &self.decoded
    }

    /// Marks `v` decoded and raises the scores of its undecoded neighbours.
    fn mark_decoded(&mut self, v: u32) {
        self.decoded[v as usize] = true;
        for &t in self.around.of(v) {
            let c = &self.triangles[3 * t as usize..3 * t as usize + 3];
            for k in 0..3 {
                let (w, a, b) = (c[k], c[(k + 1) % 3], c[(k + 2) % 3]);
                if w == v || self.decoded[w as usize] {
                    continue;
                }
                // `t` now gives `w` a known neighbour, and a known triangle if its corner
                // besides `v` and `w` was decoded before.
                let other = if a == v { b } else { a };
                let known_triangle = a != b && other != w && self.decoded[other as usize];
                let old = usize::from(self.score[w as usize]);
                let new = (old.max(1) + usize::from(known_triangle)).min(MAX_SCORE);
                if new != old {
                    self.score[w as usize] = new as u8;
                    self.waiting[new].push(w);
                }
            }
        }
    }

    fn best_waiting(&mut self) -> Option<u32> {
        for s in (1..=MAX_SCORE).rev() {
            while let Some(v) = self.waiting[s].pop() {
                if !self.decoded[v as usize] && usize::from(self.score[v as usize]) == s {
                    return Some(v);
                }
            }
        }
        None
    }
}

impl Iterator for CodingOrder<'_> {
    type Item = u32;

    fn next(&mut self) -> Option<u32> {
        if let Some(v) = self.pending.take() {
            self.mark_decoded(v);
        }
        let v = self.best_waiting().or_else(|| {
            // A new piece (or an unreferenced vertex): start from its lowest id.
            while self.decoded.get(self.lowest_unseen) == Some(&true) {
                self.lowest_unseen += 1;
            }
            (self.lowest_unseen < self.decoded.len()).then_some(self.lowest_unseen as u32)
        })?;
        self.pending = Some(v);
        Some(v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn order(vertex_count: usize, triangles: &[u32]) -> Vec<u32> {
        let around = VertexTriangles::new(vertex_count, triangles);
        let mut order = CodingOrder::new(&around, triangles);
        let mut coded = Vec::new();
        while let Some(v) = order.next() {
            // Only the vertices yielded before count as decoded.
            let decoded: Vec<u32> =
                (0..vertex_count as u32).filter(|&u| order.decoded()[u as usize]).collect();
            let mut before = coded.clone();
            before.sort_unstable();
            assert_eq!(decoded, before);
            coded.push(v);
        }
        coded
    }

    #[test]
    fn every_vertex_comes_once_even_unreferenced_and_in_degenerate_triangles() {
        let triangles = [0, 5, 3, 3, 5, 1, 1, 1, 6, 7, 7, 7];
        let mut seen = order(9, &triangles);
        seen.sort_unstable();
        assert_eq!(seen, (0..9).collect::<Vec<_>>());
    }

    #[test]
    fn a_strip_numbered_at_random_is_coded_along_the_strip() {
        // A strip of quads whose vertices are numbered out of order: after the first
        // triangle each vertex coded has a triangle with two known corners.
        let ids = [9, 2, 7, 0, 5, 11, 3, 8, 1, 10, 4, 6];
        let mut triangles = Vec::new();
        for i in 0..5 {
            let (a, b, c, d) = (ids[2 * i], ids[2 * i + 1], ids[2 * i + 2], ids[2 * i + 3]);
            triangles.extend([a, b, c, c, b, d]);
        }
        let order = order(12, &triangles);
        let position = |v: u32| order.iter().position(|&x| x == v).unwrap();
        // Coding starts at the lowest id; from the third vertex on, each one coded has a
        // triangle whose two other corners were coded before it.
        assert_eq!(order[0], 0);
        for (i, &v) in order.iter().enumerate().skip(2) {
            let predicted = triangles
                .chunks_exact(3)
                .any(|t| t.contains(&v) && t.iter().all(|&u| u == v || position(u) < i));
            assert!(predicted, "vertex {v} (coded {i}th) has no known triangle");
        }
    }
}
