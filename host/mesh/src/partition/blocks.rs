//! Blocks (issue 33): the mesh's triangles split into disjoint sets of about a given size,
//! for a service whose result on a large mesh is defined block by block (WIT `blocks`). A
//! triangle goes to the first core (in Morton order, as [`Partitioning`] cuts them) holding
//! one of its corners, so a block is compact in space whatever the mesh's order of ids. A
//! vertex used by triangles of two or more blocks is *shared*: it lies on the border of each
//! of those blocks, and each must keep it, so that the blocks' edits never meet.

use super::{Bits, Partitioning};
use crate::MeshData;

/// The mesh's triangles by block, and which vertices blocks share.
pub struct Blocks<'a> {
    cut: &'a Partitioning<'a>,
    /// Triangle ids by block, ascending within one: block `i` is
    /// `triangles[bounds[i]..bounds[i + 1]]`.
    triangles: Vec<u32>,
    bounds: Vec<usize>,
    /// Vertices used by triangles of two or more blocks.
    shared: Bits,
}

/// One block: a mesh of its own and where its elements come from.
#[derive(Debug)]
pub struct Block {
    /// The block's triangles and their vertices, the mesh's attributes restricted to them.
    pub mesh: MeshData,
    /// The mesh's id of each of the block's vertices and triangles (ascending).
    pub vertices: Vec<u32>,
    pub triangles: Vec<u32>,
    /// The block's vertices (its own ids, ascending) that another block uses too.
    pub shared: Vec<u32>,
}

impl<'a> Partitioning<'a> {
    /// The blocks of this cut: one per core, each the triangles whose first core (by
    /// index) among their corners' is it. Blocks may be empty (a core of unreferenced
    /// vertices). O(V + T), 8 bytes a vertex and 8 a triangle while cutting.
    pub fn blocks(&'a self) -> Blocks<'a> {
        let mesh = self.mesh;
        let mut core_of = vec![0u32; mesh.vertex_count()];
        for (core, range) in self.bounds.windows(2).enumerate() {
            for &v in &self.order[range[0]..range[1]] {
                core_of[v as usize] = core as u32;
            }
        }
        let block_of: Vec<u32> = mesh
            .triangles
            .chunks_exact(3)
            .map(|c| c.iter().map(|&v| core_of[v as usize]).min().expect("three corners"))
            .collect();
        // Shared: a vertex whose triangles are in more than one block.
        let mut first = core_of;
        first.fill(u32::MAX);
        let mut shared = Bits::new(mesh.vertex_count());
        for (corners, &block) in mesh.triangles.chunks_exact(3).zip(&block_of) {
            for &v in corners {
                let seen = &mut first[v as usize];
                if *seen == u32::MAX {
                    *seen = block;
                } else if *seen != block {
                    shared.insert(v);
                }
            }
        }
        // A counting sort by block keeps ids ascending within each.
        let mut bounds = vec![0usize; self.len() + 1];
        for &block in &block_of {
            bounds[block as usize + 1] += 1;
        }
        for i in 0..self.len() {
            bounds[i + 1] += bounds[i];
        }
        let mut next = bounds.clone();
        let mut triangles = vec![0u32; block_of.len()];
        for (t, &block) in block_of.iter().enumerate() {
            triangles[next[block as usize]] = t as u32;
            next[block as usize] += 1;
        }
        Blocks { cut: self, triangles, bounds, shared }
    }
}

impl Blocks<'_> {
    pub fn len(&self) -> usize {
        self.bounds.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// How many vertices two or more blocks use.
    pub fn shared_count(&self) -> usize {
        self.shared.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// Triangles of block `index`.
    pub fn triangle_count(&self, index: usize) -> usize {
        self.bounds[index + 1] - self.bounds[index]
    }

    /// Block `index` as a mesh of its own. Panics if `index >= self.len()`.
    pub fn block(&self, index: usize) -> Block {
        let mesh = self.cut.mesh;
        let triangles = self.triangles[self.bounds[index]..self.bounds[index + 1]].to_vec();
        let mut vertices = Bits::new(mesh.vertex_count());
        for &t in &triangles {
            for &v in &mesh.triangles[3 * t as usize..3 * t as usize + 3] {
                vertices.insert(v);
            }
        }
        let vertices = vertices.ranked();
        let (block, ids) = self.cut.extract(&vertices, &triangles);
        let shared = ids.iter().zip(0u32..).filter(|&(&v, _)| self.shared.contains(v));
        let shared = shared.map(|(_, local)| local).collect();
        Block { mesh: block, vertices: ids, triangles, shared }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A square grid of `n` × `n` quads, two triangles each, in row order.
    fn grid(n: u32) -> MeshData {
        let w = n + 1;
        let positions = (0..w * w).flat_map(|v| [(v % w) as f32, (v / w) as f32, 0.0]).collect();
        let triangles = (0..n * n)
            .flat_map(|q| {
                let v = (q / n) * w + q % n;
                [v, v + 1, v + w + 1, v, v + w + 1, v + w]
            })
            .collect();
        MeshData::new(positions, triangles)
    }

    #[test]
    fn every_triangle_is_in_one_block_and_blocks_share_only_border_vertices() {
        let mesh = grid(40);
        let cut = Partitioning::new(&mesh, 300);
        let blocks = cut.blocks();
        assert!(blocks.len() >= 8, "{}", blocks.len());
        let mut owner = vec![usize::MAX; mesh.triangle_count()];
        let mut users = vec![Vec::new(); mesh.vertex_count()];
        for index in 0..blocks.len() {
            let block = blocks.block(index);
            assert_eq!(block.triangles.len(), blocks.triangle_count(index));
            assert!(block.triangles.is_sorted() && block.vertices.is_sorted());
            for (k, &t) in block.triangles.iter().enumerate() {
                assert_eq!(owner[t as usize], usize::MAX, "triangle {t} in two blocks");
                owner[t as usize] = index;
                let local = &block.mesh.triangles[3 * k..3 * k + 3];
                let whole = &mesh.triangles[3 * t as usize..3 * t as usize + 3];
                let named: Vec<u32> = local.iter().map(|&v| block.vertices[v as usize]).collect();
                assert_eq!(named, whole);
            }
            for (local, &v) in block.vertices.iter().enumerate() {
                users[v as usize].push(index);
                assert_eq!(block.mesh.positions[3 * local], mesh.positions[3 * v as usize]);
                let is_shared = block.shared.binary_search(&(local as u32)).is_ok();
                assert_eq!(is_shared, blocks.shared.contains(v));
            }
        }
        assert!(owner.iter().all(|&b| b != usize::MAX));
        // Shared means used by two blocks, and there is a border between them.
        let shared: Vec<usize> = (0..users.len()).filter(|&v| users[v].len() > 1).collect();
        assert!(!shared.is_empty());
        assert!(shared.iter().all(|&v| blocks.shared.contains(v as u32)));
        assert!(shared.len() < mesh.vertex_count() / 3, "blocks are compact: {}", shared.len());
    }
}
