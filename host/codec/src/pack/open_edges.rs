//! The open half-edges of the triangles coded so far: those whose reverse no triangle has
//! used yet, listed at both their endpoints.
//!
//! A list per vertex, linked through one node pool with a free list: 4 bytes per vertex
//! plus two nodes per open half-edge, no hashing. Lists are short (a few open edges at the
//! front of the coded region), so every query scans them.

const NONE: u32 = u32::MAX;

#[derive(Clone, Copy)]
struct Node {
    /// The half-edge's other endpoint.
    other: u32,
    /// Whether the half-edge runs from `other` to this list's vertex.
    incoming: bool,
    next: u32,
}

pub(super) struct OpenEdges {
    head: Vec<u32>,
    nodes: Vec<Node>,
    free: u32,
}

impl OpenEdges {
    pub(super) fn new(vertex_count: usize) -> Self {
        Self { head: vec![NONE; vertex_count], nodes: Vec::new(), free: NONE }
    }

    /// Whether half-edge `from → to` is open.
    pub(super) fn contains(&self, from: u32, to: u32) -> bool {
        self.list(from).any(|n| n.other == to && !n.incoming)
    }

    /// Sets `out` to the `w` of every open `w → v`, ascending (with repeats for repeated
    /// half-edges).
    pub(super) fn sources_into(&self, v: u32, out: &mut Vec<u32>) {
        self.ends(v, true, out);
    }

    /// For a triangle `u → v → x`: sets `both` to the `x` that would close the fan on both
    /// sides (open `x → v` and `u → x`), `one` to those on one side only, each ascending.
    /// `scratch` is working space.
    pub(super) fn fan_closers(
        &self,
        (u, v): (u32, u32),
        both: &mut Vec<u32>,
        one: &mut Vec<u32>,
        scratch: &mut Vec<u32>,
    ) {
        self.ends(v, true, one);
        self.ends(u, false, scratch);
        both.clear();
        both.extend(one.iter().copied().filter(|x| scratch.contains(x)));
        one.extend_from_slice(scratch);
        one.retain(|x| !both.contains(x));
        one.sort_unstable();
    }

    /// Records a coded triangle: each half-edge closes its open reverse, or opens.
    pub(super) fn add_triangle(&mut self, t: [u32; 3]) {
        for k in 0..3 {
            let (from, to) = (t[k], t[(k + 1) % 3]);
            if from == to {
                continue;
            }
            if self.contains(to, from) {
                self.unlink(to, from, false);
                self.unlink(from, to, true);
            } else {
                self.link(from, to, false);
                self.link(to, from, true);
            }
        }
    }

    fn ends(&self, v: u32, incoming: bool, out: &mut Vec<u32>) {
        out.clear();
        out.extend(self.list(v).filter(|n| n.incoming == incoming).map(|n| n.other));
        out.sort_unstable();
    }

    fn list(&self, v: u32) -> impl Iterator<Item = Node> + '_ {
        let mut at = self.head[v as usize];
        std::iter::from_fn(move || {
            let node = *self.nodes.get(at as usize)?;
            at = node.next;
            Some(node)
        })
    }

    fn link(&mut self, v: u32, other: u32, incoming: bool) {
        let node = Node { other, incoming, next: self.head[v as usize] };
        let id = match self.free {
            NONE => {
                self.nodes.push(node);
                self.nodes.len() as u32 - 1
            }
            id => {
                self.free = self.nodes[id as usize].next;
                self.nodes[id as usize] = node;
                id
            }
        };
        self.head[v as usize] = id;
    }

    /// Removes one `(other, incoming)` node from `v`'s list (it must be there).
    fn unlink(&mut self, v: u32, other: u32, incoming: bool) {
        let (mut previous, mut at) = (NONE, self.head[v as usize]);
        while at != NONE {
            let node = self.nodes[at as usize];
            if node.other == other && node.incoming == incoming {
                match previous {
                    NONE => self.head[v as usize] = node.next,
                    p => self.nodes[p as usize].next = node.next,
                }
                self.nodes[at as usize].next = self.free;
                self.free = at;
                return;
            }
            (previous, at) = (at, node.next);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sources(open: &OpenEdges, v: u32) -> Vec<u32> {
        let mut out = Vec::new();
        open.sources_into(v, &mut out);
        out
    }

    fn closers(open: &OpenEdges, u: u32, v: u32) -> (Vec<u32>, Vec<u32>) {
        let (mut both, mut one, mut scratch) = (Vec::new(), Vec::new(), Vec::new());
        open.fan_closers((u, v), &mut both, &mut one, &mut scratch);
        (both, one)
    }

    #[test]
    fn half_edges_open_and_close_with_their_reverse() {
        let mut open = OpenEdges::new(5);
        open.add_triangle([0, 1, 2]);
        assert!(open.contains(0, 1) && open.contains(1, 2) && open.contains(2, 0));
        assert_eq!(sources(&open, 1), [0]);
        // Across 1 → 2, the triangle 2 → 1 → x: x = 0 has open 0 → 1 and 2 → 0.
        assert_eq!(closers(&open, 2, 1), (vec![0], vec![]));
        open.add_triangle([2, 1, 3]);
        assert!(!open.contains(1, 2) && open.contains(1, 3) && open.contains(3, 2));
        // For the triangle 0 → 3 → x, x = 1 has both open 1 → 3 and 0 → 1.
        assert_eq!(closers(&open, 0, 3), (vec![1], vec![]));
        open.add_triangle([0, 3, 1]);
        assert!(!open.contains(0, 1) && !open.contains(1, 3));
        assert_eq!(sources(&open, 0), [2]);
        assert_eq!(sources(&open, 1), Vec::<u32>::new());
    }
}
