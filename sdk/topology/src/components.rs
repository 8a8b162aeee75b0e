//! Connected components of triangles.

use super::edges::{EdgeBuckets, Members};

/// A component label for every triangle, plus the size of every component.
///
/// Labels are numbered `0..count` in order of each component's smallest triangle id, so
/// triangle 0 (if any) is in component 0 and the result is deterministic. Components are
/// components of *triangles*: vertices referenced by no triangle belong to none and are not
/// counted. Memory: 4 bytes per triangle plus 4 per component.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TriangleComponents {
    labels: Vec<u32>,
    sizes: Vec<u32>,
}

impl TriangleComponents {
    /// Edge-connected components (the `component-count`): two triangles are connected when
    /// they share an undirected edge `{a, b}` (`a != b`, both `< vertex_count`), whether that
    /// edge is manifold or not and whatever the orientations. Triangles touching only at a
    /// vertex (a bow-tie) are separate components. A degenerate triangle `(a, a, b)` joins
    /// through its edge `{a, b}`; a triangle without such an edge (`(a, a, a)`, out-of-range
    /// ids) is a component of its own.
    ///
    /// O(V + T log d) (edge grouping by bucket sort, then union-find with path halving).
    pub fn new(vertex_count: usize, triangles: &[u32]) -> Self {
        let mut forest = UnionFind::edge_connected(vertex_count, triangles);
        Self::from_roots(triangles.len() / 3, |t| forest.find(t))
    }

    /// Vertex-connected components: two triangles are connected when they share a vertex
    /// `< vertex_count` (a bow-tie is one component). Out-of-range ids connect nothing.
    /// O(V + T) with union-find over vertices.
    pub fn vertex_connected(vertex_count: usize, triangles: &[u32]) -> Self {
        let mut forest = UnionFind::new(vertex_count);
        let in_range = |v: u32| (v as usize) < vertex_count;
        for c in triangles.chunks_exact(3) {
            let mut corners = c.iter().copied().filter(|&v| in_range(v));
            if let Some(first) = corners.next() {
                for v in corners {
                    forest.union(first, v);
                }
            }
        }
        // A triangle with no in-range corner gets a private key past the vertex range.
        let tris = triangles.len() / 3;
        Self::from_roots(tris, |t| {
            let c = &triangles[3 * t as usize..3 * t as usize + 3];
            match c.iter().copied().find(|&v| in_range(v)) {
                Some(v) => forest.find(v),
                None => (vertex_count + t as usize) as u32,
            }
        })
    }

    /// The sets of a union-find over the triangles (as [`UnionFind::edge_connected`] groups
    /// them, or the same grouping from a derived connectivity), labelled as [`Self::new`]
    /// labels them: in order of each component's smallest triangle id. O(T).
    pub fn from_forest(forest: &mut UnionFind) -> Self {
        let tris = forest.parent.len();
        Self::from_roots(tris, |t| forest.find(t))
    }

    /// Relabels arbitrary per-triangle root keys to 0.. in order of first appearance.
    fn from_roots(tris: usize, mut root: impl FnMut(u32) -> u32) -> Self {
        // Label of the component whose root key is k, if seen; keys are < vertex_count + tris
        // or < tris, so a vector indexed by key is enough, grown on demand.
        let mut label_of: Vec<u32> = Vec::new();
        let mut labels = Vec::with_capacity(tris);
        let mut sizes: Vec<u32> = Vec::new();
        for t in 0..tris as u32 {
            let k = root(t) as usize;
            if k >= label_of.len() {
                label_of.resize(k + 1, u32::MAX);
            }
            if label_of[k] == u32::MAX {
                label_of[k] = sizes.len() as u32;
                sizes.push(0);
            }
            let l = label_of[k];
            sizes[l as usize] += 1;
            labels.push(l);
        }
        Self { labels, sizes }
    }

    /// The number of components. O(1).
    #[inline]
    pub fn count(&self) -> usize {
        self.sizes.len()
    }

    /// The component of triangle `t`. O(1).
    #[inline]
    pub fn label(&self, t: u32) -> u32 {
        self.labels[t as usize]
    }

    /// The component of every triangle.
    #[inline]
    pub fn labels(&self) -> &[u32] {
        &self.labels
    }

    /// The number of triangles in each component, indexed by label.
    #[inline]
    pub fn sizes(&self) -> &[u32] {
        &self.sizes
    }

    /// The largest component by triangle count (the smallest label among equals), or `None`
    /// without triangles. O(count).
    pub fn largest(&self) -> Option<u32> {
        let mut best: Option<(u32, u32)> = None;
        for (l, &s) in self.sizes.iter().enumerate() {
            if best.is_none_or(|(_, bs)| s > bs) {
                best = Some((l as u32, s));
            }
        }
        best.map(|(l, _)| l)
    }

    /// The triangles of component `label`, ascending. O(T).
    pub fn triangles_of(&self, label: u32) -> Vec<u32> {
        (0..self.labels.len() as u32).filter(|&t| self.labels[t as usize] == label).collect()
    }

    /// Gives back `(labels, sizes)`.
    pub fn into_parts(self) -> (Vec<u32>, Vec<u32>) {
        (self.labels, self.sizes)
    }
}

/// Union-find over `0..n` with path halving; the smaller root wins a union, so on meshes
/// stored in order trees stay shallow and roots are each set's smallest member.
pub struct UnionFind {
    parent: Vec<u32>,
}

impl UnionFind {
    /// `n` singletons.
    pub fn new(n: usize) -> Self {
        Self { parent: (0..n as u32).collect() }
    }

    /// The triangles of `triangles`, joined through every edge they share, as
    /// [`TriangleComponents::new`] defines it (which labels the sets; this only groups them,
    /// enough to count them). O(V + T log d).
    pub fn edge_connected(vertex_count: usize, triangles: &[u32]) -> Self {
        let mut forest = Self::new(triangles.len() / 3);
        EdgeBuckets::of(vertex_count, triangles, Members::AnyEdge).for_each_edge(|_, group| {
            for w in group.windows(2) {
                forest.union(w[0].triangle(), w[1].triangle());
            }
        });
        forest
    }

    /// The root of `x`'s set.
    pub fn find(&mut self, mut x: u32) -> u32 {
        while self.parent[x as usize] != x {
            let grand = self.parent[self.parent[x as usize] as usize];
            self.parent[x as usize] = grand;
            x = grand;
        }
        x
    }

    /// Joins the sets of `a` and `b`.
    pub fn union(&mut self, a: u32, b: u32) {
        let (ra, rb) = (self.find(a), self.find(b));
        if ra != rb {
            let (lo, hi) = if ra < rb { (ra, rb) } else { (rb, ra) };
            self.parent[hi as usize] = lo;
        }
    }

    /// The number of sets.
    pub fn sets(&self) -> usize {
        self.parent.iter().enumerate().filter(|&(i, &p)| p == i as u32).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bow_tie() {
        let t = [0, 1, 2, 0, 3, 4];
        let c = TriangleComponents::new(5, &t);
        assert_eq!((c.count(), c.labels(), c.sizes()), (2, &[0, 1][..], &[1, 1][..]));
        assert_eq!(c.largest(), Some(0));
        assert_eq!(TriangleComponents::from_forest(&mut UnionFind::edge_connected(5, &t)), c);
        let v = TriangleComponents::vertex_connected(5, &t);
        assert_eq!(v.count(), 1);
        assert_eq!(TriangleComponents::new(0, &[]).largest(), None);
    }
}
