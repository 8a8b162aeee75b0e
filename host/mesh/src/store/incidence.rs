//! The triangles around each vertex, built on the first topological edit of a step and kept
//! up to date after it, so steps that only move vertices never pay for it.

/// Live triangles per vertex slot, in one flat array: each vertex's list is a span of it.
/// Lists are unordered; callers that need a canonical order (anything that appends new
/// elements) sort what they take. One array, not a `Vec` per vertex: on a 1M-vertex scan
/// the million small allocations (and their frees) were most of the cost of building it,
/// which every edit log replaying a removal pays.
#[derive(Default)]
pub(crate) struct Incidence {
    spans: Vec<Span>,
    flat: Vec<u32>,
}

/// A vertex's list: `flat[start..start + len]`, with room up to `start + capacity`.
#[derive(Clone, Copy, Default)]
struct Span {
    start: usize,
    len: u32,
    capacity: u32,
}

impl Incidence {
    pub(crate) fn build(vertex_slots: usize, triangles: &[u32]) -> Self {
        let mut spans = vec![Span::default(); vertex_slots];
        for corners in triangles.chunks_exact(3).filter(|c| c[0] != super::REMOVED) {
            for (k, &v) in corners.iter().enumerate() {
                // A degenerate input triangle lists its repeated vertex once.
                if !corners[..k].contains(&v) {
                    spans[v as usize].capacity += 1;
                }
            }
        }
        let mut start = 0;
        for span in &mut spans {
            span.start = start;
            start += span.capacity as usize;
        }
        let mut flat = vec![0; start];
        for (t, corners) in triangles.chunks_exact(3).enumerate() {
            if corners[0] == super::REMOVED {
                continue;
            }
            for (k, &v) in corners.iter().enumerate() {
                if !corners[..k].contains(&v) {
                    let span = &mut spans[v as usize];
                    flat[span.start + span.len as usize] = t as u32;
                    span.len += 1;
                }
            }
        }
        Self { spans, flat }
    }

    pub(crate) fn around(&self, vertex: u32) -> &[u32] {
        let span = self.spans[vertex as usize];
        &self.flat[span.start..span.start + span.len as usize]
    }

    pub(crate) fn add_vertex(&mut self) {
        self.spans.push(Span { start: self.flat.len(), len: 0, capacity: 0 });
    }

    pub(crate) fn add_triangle(&mut self, t: u32, corners: [u32; 3]) {
        for (k, &v) in corners.iter().enumerate() {
            if !corners[..k].contains(&v) {
                self.push(v, t);
            }
        }
    }

    pub(crate) fn remove_triangle(&mut self, t: u32, corners: [u32; 3]) {
        for v in corners {
            let span = &mut self.spans[v as usize];
            let list = &mut self.flat[span.start..span.start + span.len as usize];
            if let Some(i) = list.iter().position(|&x| x == t) {
                list.swap(i, list.len() - 1);
                span.len -= 1;
            }
        }
    }

    /// Appends `t` to `v`'s list; a full list moves to the end of the array with twice the
    /// room (the space it leaves is not reused: edits touch few vertices).
    fn push(&mut self, v: u32, t: u32) {
        let span = &mut self.spans[v as usize];
        if span.len == span.capacity {
            let capacity = (span.capacity * 2).max(4);
            let start = self.flat.len();
            self.flat.extend_from_within(span.start..span.start + span.len as usize);
            self.flat.resize(start + capacity as usize, 0);
            *span = Span { start, len: span.len, capacity };
        }
        self.flat[span.start + span.len as usize] = t;
        span.len += 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// What the index stood for before it was one array: a `Vec` per vertex, the same
    /// pushes and swap-removes.
    fn lists(vertex_slots: usize, triangles: &[u32]) -> Vec<Vec<u32>> {
        let mut lists = vec![Vec::new(); vertex_slots];
        for (t, c) in triangles.chunks_exact(3).enumerate() {
            for (k, &v) in c.iter().enumerate() {
                if c[0] != super::super::REMOVED && !c[..k].contains(&v) {
                    lists[v as usize].push(t as u32);
                }
            }
        }
        lists
    }

    proptest! {
        /// Every list, in the same order as per-vertex vectors given the same edits: the
        /// order is what callers see before they sort.
        #[test]
        fn lists_keep_the_order_of_per_vertex_vectors(
            corners in prop::collection::vec(0u32..12, 3..60),
            edits in prop::collection::vec((any::<bool>(), 0u32..20, prop::array::uniform3(0u32..14)), 0..80),
        ) {
            let mut triangles: Vec<u32> = corners[..corners.len() / 3 * 3].to_vec();
            let mut index = Incidence::build(12, &triangles);
            let mut model = lists(12, &triangles);
            let mut vertices = 12u32;
            for (add, t, c) in edits {
                if add {
                    // Two new vertices now and then, so new lists start empty and grow.
                    if c[0] % 5 == 0 {
                        index.add_vertex();
                        model.push(Vec::new());
                        vertices += 1;
                    }
                    let c = c.map(|v| v % vertices);
                    let id = (triangles.len() / 3) as u32;
                    triangles.extend_from_slice(&c);
                    index.add_triangle(id, c);
                    for (k, &v) in c.iter().enumerate() {
                        if !c[..k].contains(&v) {
                            model[v as usize].push(id);
                        }
                    }
                } else if (t as usize) < triangles.len() / 3 {
                    let c: [u32; 3] = triangles[3 * t as usize..3 * t as usize + 3].try_into().unwrap();
                    index.remove_triangle(t, c);
                    for v in c {
                        if let Some(i) = model[v as usize].iter().position(|&x| x == t) {
                            model[v as usize].swap_remove(i);
                        }
                    }
                }
            }
            for (v, list) in model.iter().enumerate() {
                prop_assert_eq!(index.around(v as u32), &list[..]);
            }
        }
    }
}
