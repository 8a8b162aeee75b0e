//! Union-find over triangles with a parity bit per link: whether "same or opposite
//! orientation" constraints between triangles can all be met. (Plain connectivity uses the
//! SDK's [`UnionFind`](meshflow_plugin_sdk::topology::UnionFind).)

/// A disjoint-set forest whose links remember whether a node's orientation is the same as
/// (0) or opposite to (1) its parent's.
pub struct ParityForest {
    parent: Vec<u32>,
    parity: Vec<u8>,
}

impl ParityForest {
    /// `len` singletons.
    pub fn new(len: usize) -> Self {
        Self { parent: (0..len as u32).collect(), parity: vec![0; len] }
    }

    /// The root of `x` and `x`'s parity relative to it; compresses the path.
    pub fn find(&mut self, x: u32) -> (u32, u8) {
        let (mut root, mut parity) = (x, 0);
        while self.parent[root as usize] != root {
            parity ^= self.parity[root as usize];
            root = self.parent[root as usize];
        }
        // Point every node of the path at the root, with its parity to the root.
        let (mut node, mut to_root) = (x, parity);
        while self.parent[node as usize] != node {
            let (up, link) = (self.parent[node as usize], self.parity[node as usize]);
            self.parent[node as usize] = root;
            self.parity[node as usize] = to_root;
            to_root ^= link;
            node = up;
        }
        (root, parity)
    }

    /// Joins `a` and `b` with relative parity `relation`; `false` if they were already joined
    /// with the other parity (a contradiction).
    pub fn union(&mut self, a: u32, b: u32, relation: u8) -> bool {
        let ((ra, pa), (rb, pb)) = (self.find(a), self.find(b));
        if ra == rb {
            return pa ^ pb == relation;
        }
        // The larger root under the smaller keeps trees shallow on meshes stored in order.
        let (child, root) = if ra > rb { (ra, rb) } else { (rb, ra) };
        self.parent[child as usize] = root;
        self.parity[child as usize] = pa ^ pb ^ relation;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parities_compose_and_contradictions_are_found() {
        let mut forest = ParityForest::new(4);
        assert!(forest.union(0, 1, 1) && forest.union(1, 2, 1) && forest.union(3, 2, 0));
        assert_eq!(forest.find(3).0, forest.find(0).0, "one tree");
        assert!(forest.union(0, 2, 0), "opposite of opposite is the same");
        assert!(!forest.union(0, 3, 1), "3 is like 2, so like 0");
    }
}
