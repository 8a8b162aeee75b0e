//! Cutting a mesh into partitions, for services whose result at a vertex depends only on a
//! bounded neighbourhood of it (DESIGN §11, issue 33): each partition owns a *core* of
//! vertices — every vertex of the mesh is in exactly one core — and carries the triangles
//! within the service's reach of its core, so that a run on the partition computes its
//! core vertices exactly as a run on the whole mesh would.
//!
//! Cores are runs of the vertices in Morton order of their positions, so they are compact in
//! space whatever order the file lists vertices in (range scans interleave components).
//! A partition keeps the relative order of the mesh's ids for its vertices and triangles:
//! code that visits neighbours or triangles in ascending id order (sums in a fixed order)
//! visits them in the same order on the partition, the condition for bit-identical results.

mod blocks;
mod placement;

use std::sync::OnceLock;

use meshflow_topology::geometry::{BoundingBox, bounding_box};

pub use blocks::{Block, Blocks};
pub use placement::{Placement, Unplaceable};

use crate::MeshData;

/// Bits of the Morton code per axis: 1024 cells along each side of the bounding box are
/// enough to keep cores compact; ties are broken by vertex id.
const MORTON_BITS: u32 = 10;

/// A mesh prepared for cutting: its cores and the triangles around each vertex.
pub struct Partitioning<'a> {
    mesh: &'a MeshData,
    /// The mesh's bounding box as [`Whole::bounds`] gives it.
    extent: Vec<f32>,
    /// Every vertex id, in Morton order; core `i` is `order[bounds[i]..bounds[i + 1]]`.
    order: Vec<u32>,
    bounds: Vec<usize>,
    /// The triangles around vertex `v`: `around[starts[v]..starts[v + 1]]`, ascending.
    /// Filled when a partition is first grown: blocks need only the counts (12 bytes a
    /// triangle saved: 720 MB at 60M).
    starts: Vec<u32>,
    around: OnceLock<Vec<u32>>,
}

/// What a partition is part of, as a service run on it reads it (WIT `whole-ids`,
/// `whole-bounds`): what keeps a local service's result independent of the cut.
#[derive(Clone, Debug, PartialEq)]
pub struct Whole {
    /// The whole mesh's id of each of the partition's vertex slots.
    pub ids: Vec<u32>,
    /// `min x, min y, min z, max x, max y, max z` over the whole mesh's positions (NaNs
    /// skipped); empty when no coordinate is a number.
    pub bounds: Vec<f32>,
}

/// One partition: a mesh of its own and where its elements come from.
#[derive(Debug)]
pub struct Partition {
    /// The partition's vertices and triangles, with the mesh's attributes restricted to them.
    pub mesh: MeshData,
    /// The mesh's id of each of the partition's vertices (ascending).
    pub vertices: Vec<u32>,
    /// The mesh's id of each of the partition's triangles (ascending).
    pub triangles: Vec<u32>,
    /// Which of the partition's vertices are its core (partition ids, ascending).
    pub core: Vec<u32>,
}

impl<'a> Partitioning<'a> {
    /// Cores of about `max_core_triangles` triangles each (counted as a third of the
    /// triangle corners at their vertices), at least one vertex each. O(V log V + T).
    pub fn new(mesh: &'a MeshData, max_core_triangles: usize) -> Self {
        let vertex_count = mesh.vertex_count();
        let starts = corner_starts(vertex_count, &mesh.triangles);
        let bbox = bounding_box(&mesh.positions);
        // Without a number among the coordinates every vertex falls in one cell: id order.
        let unplaced = BoundingBox { min: [0.0; 3], max: [0.0; 3] };
        let order = morton_order(&mesh.positions, bbox.unwrap_or(unplaced));
        let extent = bbox.map_or_else(Vec::new, |b| [b.min, b.max].concat());
        // A core closes when its vertices' corners reach 3 × the budget, or its vertex
        // count reaches the budget (a cloud of points with no triangles).
        let budget = max_core_triangles.max(1);
        let mut bounds = vec![0];
        let (mut corners, mut vertices) = (0usize, 0usize);
        for (i, &v) in order.iter().enumerate() {
            corners += (starts[v as usize + 1] - starts[v as usize]) as usize;
            vertices += 1;
            if corners >= 3 * budget || vertices >= budget {
                bounds.push(i + 1);
                (corners, vertices) = (0, 0);
            }
        }
        if *bounds.last().expect("starts with 0") != order.len() {
            bounds.push(order.len());
        }
        Self { mesh, extent, order, bounds, starts, around: OnceLock::new() }
    }

    /// What a partition of this cut is part of, given its [`Partition::vertices`].
    pub fn whole(&self, vertices: Vec<u32>) -> Whole {
        Whole { ids: vertices, bounds: self.extent.clone() }
    }

    /// How many partitions the mesh is cut into.
    pub fn len(&self) -> usize {
        self.bounds.len() - 1
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Partition `index`: its core, every triangle that has a vertex at most `rings - 1`
    /// edges from a core vertex, and the vertices of those triangles; `None` once it holds
    /// more than `max_triangles`. `rings == 0` gives the core alone. Panics if
    /// `index >= self.len()`.
    pub fn partition(&self, index: usize, rings: u32, max_triangles: usize) -> Option<Partition> {
        let core = self.order[self.bounds[index]..self.bounds[index + 1]].to_vec();
        self.grown(core, rings, max_triangles)
    }

    /// A partition whose core is the first `vertices` of partition `index`'s core (in
    /// Morton order: a compact patch of it), grown by `rings`: a small piece to run again
    /// and compare with what partition `index` gave its vertices.
    pub fn sample(&self, index: usize, vertices: usize, rings: u32) -> Partition {
        let start = self.bounds[index];
        let end = self.bounds[index + 1].min(start + vertices.max(1));
        self.grown(self.order[start..end].to_vec(), rings, usize::MAX)
            .expect("no bound on its triangles")
    }

    /// The partition whose core is `vertices` (any of the mesh's vertex ids, ascending),
    /// grown by `rings` as [`partition`](Self::partition) grows a core; `None` once it holds
    /// more than `max_triangles`. Where a service's edits are replayed together.
    pub fn region(
        &self,
        vertices: Vec<u32>,
        rings: u32,
        max_triangles: usize,
    ) -> Option<Partition> {
        self.grown(vertices, rings, max_triangles)
    }

    /// `vertices` and every corner of their triangles, ascending: what lies within one edge
    /// of them (a region's check of its own edits). Builds no mesh.
    pub fn neighbourhood(&self, vertices: &[u32]) -> Vec<u32> {
        let around = self.around();
        let mut within = Bits::new(self.mesh.vertex_count());
        for &v in vertices {
            within.insert(v);
            for &t in
                &around[self.starts[v as usize] as usize..self.starts[v as usize + 1] as usize]
            {
                for &w in &self.mesh.triangles[3 * t as usize..3 * t as usize + 3] {
                    within.insert(w);
                }
            }
        }
        within.ranked().ascending()
    }

    /// The triangles around every vertex, filled on first use.
    fn around(&self) -> &[u32] {
        self.around.get_or_init(|| fill_around(&self.starts, &self.mesh.triangles))
    }

    /// The partition with `core` (any vertex ids) grown by `rings`. Membership is kept as
    /// bits over the whole mesh and local ids are ranks among them: no search or sort per
    /// element (the searches took 2.6 s for a 10M-triangle partition of a 20M scan).
    fn grown(&self, core: Vec<u32>, rings: u32, max_triangles: usize) -> Option<Partition> {
        let mut vertices = Bits::new(self.mesh.vertex_count());
        let mut triangles = Bits::new(self.mesh.triangles.len() / 3);
        let mut triangle_count = 0;
        for &v in &core {
            vertices.insert(v);
        }
        let mut frontier = core.clone();
        let all_around =
            self.around.get_or_init(|| fill_around(&self.starts, &self.mesh.triangles));
        for _ in 0..rings {
            let mut reached = Vec::new();
            for &v in &frontier {
                let around = self.starts[v as usize] as usize..self.starts[v as usize + 1] as usize;
                for &t in &all_around[around] {
                    if !triangles.insert(t) {
                        continue;
                    }
                    triangle_count += 1;
                    if triangle_count > max_triangles {
                        return None;
                    }
                    for &w in &self.mesh.triangles[3 * t as usize..3 * t as usize + 3] {
                        if vertices.insert(w) {
                            reached.push(w);
                        }
                    }
                }
            }
            if reached.is_empty() {
                break;
            }
            frontier = reached;
        }
        let vertices = vertices.ranked();
        let triangle_ids = triangles.ranked().ascending();
        let (mesh, vertex_ids) = self.extract(&vertices, &triangle_ids);
        let mut core_local: Vec<u32> = core.iter().map(|&v| vertices.rank(v)).collect();
        core_local.sort_unstable();
        Some(Partition { mesh, vertices: vertex_ids, triangles: triangle_ids, core: core_local })
    }

    /// The mesh of triangles `triangle_ids` (ascending) over `vertices` (a superset of their
    /// corners), local ids as ranks, the mesh's attributes restricted to them; and the mesh's
    /// id of each of its vertices.
    fn extract(&self, vertices: &Ranked, triangle_ids: &[u32]) -> (MeshData, Vec<u32>) {
        let corners = triangle_ids
            .iter()
            .flat_map(|&t| &self.mesh.triangles[3 * t as usize..3 * t as usize + 3])
            .map(|&v| vertices.rank(v))
            .collect();
        let vertex_ids = vertices.ascending();
        let positions = vertex_ids
            .iter()
            .flat_map(|&v| &self.mesh.positions[3 * v as usize..3 * v as usize + 3])
            .copied()
            .collect();
        let attributes = self.mesh.attributes.gather(&vertex_ids, triangle_ids);
        (MeshData { positions, triangles: corners, attributes }, vertex_ids)
    }
}

/// A set of ids below a bound, as bits.
struct Bits {
    words: Vec<u64>,
}

impl Bits {
    fn new(len: usize) -> Self {
        Self { words: vec![0; len.div_ceil(64)] }
    }

    /// Whether `id` was not in yet.
    fn insert(&mut self, id: u32) -> bool {
        let (word, bit) = (&mut self.words[id as usize / 64], 1u64 << (id % 64));
        let new = *word & bit == 0;
        *word |= bit;
        new
    }

    fn contains(&self, id: u32) -> bool {
        self.words[id as usize / 64] & (1u64 << (id % 64)) != 0
    }

    /// With the count of ids below each word, to rank in O(1).
    fn ranked(self) -> Ranked {
        let mut below = Vec::with_capacity(self.words.len());
        let mut count = 0;
        for word in &self.words {
            below.push(count);
            count += word.count_ones();
        }
        Ranked { words: self.words, below, len: count as usize }
    }
}

/// [`Bits`] with ranks: an id's place among the ids in the set, ascending.
struct Ranked {
    words: Vec<u64>,
    below: Vec<u32>,
    len: usize,
}

impl Ranked {
    /// The place of `id` (which is in the set) among the set's ids.
    fn rank(&self, id: u32) -> u32 {
        let (word, bit) = (id as usize / 64, id % 64);
        self.below[word] + (self.words[word] & ((1u64 << bit) - 1)).count_ones()
    }

    fn ascending(&self) -> Vec<u32> {
        let mut ids = Vec::with_capacity(self.len);
        for (w, &word) in self.words.iter().enumerate() {
            let mut rest = word;
            while rest != 0 {
                ids.push((64 * w) as u32 + rest.trailing_zeros());
                rest &= rest - 1;
            }
        }
        ids
    }
}

/// Where each vertex's list of triangles starts (a triangle with a repeated corner is
/// listed once at that vertex); `starts[v + 1] - starts[v]` triangles at `v`.
fn corner_starts(vertex_count: usize, triangles: &[u32]) -> Vec<u32> {
    let mut starts = vec![0u32; vertex_count + 1];
    for c in triangles.chunks_exact(3) {
        for k in 0..3 {
            if distinct(c, k) {
                starts[c[k] as usize + 1] += 1;
            }
        }
    }
    for v in 0..vertex_count {
        starts[v + 1] += starts[v];
    }
    starts
}

/// The triangles at each vertex, each vertex's list ascending, laid out by `starts`.
fn fill_around(starts: &[u32], triangles: &[u32]) -> Vec<u32> {
    let mut next = starts.to_vec();
    let mut around = vec![0u32; *starts.last().expect("one more than the vertices") as usize];
    for (t, c) in triangles.chunks_exact(3).enumerate() {
        for k in 0..3 {
            if distinct(c, k) {
                let slot = &mut next[c[k] as usize];
                around[*slot as usize] = t as u32;
                *slot += 1;
            }
        }
    }
    around
}

/// Whether corner `k` of `c` differs from the corners before it.
fn distinct(c: &[u32], k: usize) -> bool {
    !c[..k].contains(&c[k])
}

/// Vertex ids sorted by the Morton code of their cell in the bounding box `bbox`, then by id.
fn morton_order(positions: &[f32], bbox: BoundingBox) -> Vec<u32> {
    let (points, _) = positions.as_chunks::<3>();
    let BoundingBox { min: lo, max: hi } = bbox;
    let cells = (1u32 << MORTON_BITS) as f32;
    let scale = [0, 1, 2].map(|k| {
        let extent = hi[k] - lo[k];
        if extent > 0.0 { (cells - 1.0) / extent } else { 0.0 }
    });
    let mut keys: Vec<u64> = points
        .iter()
        .enumerate()
        .map(|(v, p)| {
            let cell =
                [0, 1, 2].map(|k| (((p[k] - lo[k]) * scale[k]) as u32).min((1 << MORTON_BITS) - 1));
            (u64::from(interleave(cell)) << 32) | v as u64
        })
        .collect();
    keys.sort_unstable();
    keys.into_iter().map(|key| key as u32).collect()
}

/// The bits of three 10-bit cell coordinates interleaved (x lowest).
fn interleave(cell: [u32; 3]) -> u32 {
    let mut code = 0;
    for bit in 0..MORTON_BITS {
        for (k, &c) in cell.iter().enumerate() {
            code |= ((c >> bit) & 1) << (3 * bit + k as u32);
        }
    }
    code
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attributes::{Attribute, Attributes};

    /// A strip of `n` quads (2n triangles) along x, vertices listed in a scrambled order.
    fn strip(n: u32) -> MeshData {
        let count = 2 * (n + 1);
        // Vertex at grid (i, j) gets id perm(2i + j): a fixed shuffle.
        let perm = |g: u32| (g * 7919) % count;
        let mut positions = vec![0.0; 3 * count as usize];
        for i in 0..=n {
            for j in 0..2 {
                let v = perm(2 * i + j) as usize;
                positions[3 * v..3 * v + 3].copy_from_slice(&[i as f32, j as f32, 0.0]);
            }
        }
        let mut triangles = Vec::new();
        for i in 0..n {
            let [a, b, c, d] = [2 * i, 2 * i + 1, 2 * i + 2, 2 * i + 3].map(perm);
            triangles.extend_from_slice(&[a, c, b, b, c, d]);
        }
        MeshData::new(positions, triangles)
    }

    #[test]
    fn every_vertex_is_in_exactly_one_core_and_partitions_keep_the_mesh_order() {
        let mesh = strip(50);
        let cut = Partitioning::new(&mesh, 10);
        assert!(cut.len() >= 8, "{} partitions", cut.len());
        let mut owned = vec![0; mesh.vertex_count()];
        for i in 0..cut.len() {
            let part = cut.partition(i, 2, usize::MAX).unwrap();
            assert!(part.vertices.windows(2).all(|w| w[0] < w[1]));
            for &c in &part.core {
                owned[part.vertices[c as usize] as usize] += 1;
            }
            // Positions and corners are the mesh's, through the id map.
            for (l, &g) in part.vertices.iter().enumerate() {
                assert_eq!(
                    part.mesh.positions[3 * l..3 * l + 3],
                    mesh.positions[3 * g as usize..3 * g as usize + 3]
                );
            }
            let global: Vec<[u32; 3]> = part
                .mesh
                .triangles
                .chunks_exact(3)
                .map(|c| [0, 1, 2].map(|k| part.vertices[c[k] as usize]))
                .collect();
            let in_mesh: Vec<[u32; 3]> =
                mesh.triangles.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let indices: Vec<usize> =
                global.iter().map(|t| in_mesh.iter().position(|m| m == t).unwrap()).collect();
            assert!(indices.windows(2).all(|w| w[0] < w[1]), "triangles keep their order");
        }
        assert!(owned.iter().all(|&n| n == 1), "{owned:?}");
    }

    #[test]
    fn a_partition_knows_its_whole_mesh_and_coordinates_without_numbers_still_get_a_core() {
        let mut mesh = strip(30);
        let cut = Partitioning::new(&mesh, 8);
        let part = cut.partition(2, 1, usize::MAX).unwrap();
        let whole = cut.whole(part.vertices.clone());
        assert_eq!(whole.ids, part.vertices);
        assert_eq!(whole.bounds, [0.0, 0.0, 0.0, 30.0, 1.0, 0.0]);
        // A hostile file: no coordinate is a number. Every vertex is still in one core.
        mesh.positions.fill(f32::NAN);
        let cut = Partitioning::new(&mesh, 8);
        let cores: usize = (0..cut.len()).map(|i| cut.partition(i, 0, 0).unwrap().core.len()).sum();
        assert_eq!(cores, mesh.vertex_count());
        assert!(cut.whole(cut.partition(0, 0, 0).unwrap().vertices).bounds.is_empty());
    }

    #[test]
    fn a_neighbourhood_is_the_vertices_and_their_triangles_corners() {
        let mesh = strip(6);
        let cut = Partitioning::new(&mesh, 4);
        let one_ring = cut.region(vec![5], 1, usize::MAX).unwrap().vertices;
        assert_eq!(cut.neighbourhood(&[5]), one_ring);
        assert_eq!(cut.neighbourhood(&[]), Vec::<u32>::new());
    }

    #[test]
    fn a_partition_holds_every_triangle_within_its_reach_and_no_more() {
        let mesh = strip(40);
        let cut = Partitioning::new(&mesh, 12);
        let part = cut.partition(1, 3, usize::MAX).unwrap();
        // Distance in edges from the core, by breadth-first search over the whole mesh.
        let n = mesh.vertex_count();
        let mut distance = vec![u32::MAX; n];
        let mut queue: std::collections::VecDeque<u32> =
            part.core.iter().map(|&c| part.vertices[c as usize]).collect();
        for &v in &queue {
            distance[v as usize] = 0;
        }
        while let Some(v) = queue.pop_front() {
            for c in mesh.triangles.chunks_exact(3).filter(|c| c.contains(&v)) {
                for &w in c {
                    if distance[w as usize] == u32::MAX {
                        distance[w as usize] = distance[v as usize] + 1;
                        queue.push_back(w);
                    }
                }
            }
        }
        let expected = mesh
            .triangles
            .chunks_exact(3)
            .filter(|c| c.iter().any(|&v| distance[v as usize] <= 2))
            .count();
        assert_eq!(part.mesh.triangle_count(), expected);
        assert!(part.mesh.triangle_count() < mesh.triangle_count());
        // A sample of the core: its first vertices, grown the same way.
        let sample = cut.sample(1, 3, 2);
        assert_eq!(sample.core.len(), 3);
        assert!(sample.core.iter().all(|&c| part.vertices.contains(&sample.vertices[c as usize])));
        // Without rings, the core alone.
        let bare = cut.partition(1, 0, usize::MAX).unwrap();
        assert!(cut.partition(1, 3, expected - 1).is_none(), "over its bound");
        assert_eq!(bare.mesh.triangle_count(), 0);
        assert_eq!(bare.vertices.len(), bare.core.len());
    }

    #[test]
    fn attributes_follow_their_elements_and_unreferenced_vertices_have_a_core() {
        let mut mesh = strip(20);
        // Two vertices no triangle uses.
        mesh.positions.extend_from_slice(&[5.0, 5.0, 5.0, -1.0, 0.0, 0.0]);
        let n = mesh.vertex_count();
        let quality: Vec<f32> = (0..n).map(|v| v as f32).collect();
        let mut attributes = Attributes::default();
        attributes.insert(Attribute::quality(quality), n, mesh.triangle_count()).unwrap();
        let mesh = mesh.with_attributes(attributes).unwrap();
        let cut = Partitioning::new(&mesh, 8);
        let mut seen = vec![false; n];
        for i in 0..cut.len() {
            let part = cut.partition(i, 1, usize::MAX).unwrap();
            let q = part.mesh.attributes.iter().next().unwrap();
            for (l, &g) in part.vertices.iter().enumerate() {
                assert_eq!(q.values.get(l), g as f64);
            }
            for &c in &part.core {
                seen[part.vertices[c as usize] as usize] = true;
            }
        }
        assert!(seen.iter().all(|&s| s));
    }
}
