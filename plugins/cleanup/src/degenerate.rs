//! Repairing degenerate triangles as MeshFix does: caps are split away, needles collapsed,
//! what cannot be repaired is removed, and so are duplicates and repeated-vertex triangles.
//!
//! A triangle is degenerate when its area is zero in `f64` (exactly collinear or coincident
//! corners), or, with `epsilon > 0`, when its height onto its longest edge is at most
//! `epsilon` times that edge ([`is_flat_within`]). It is a **needle** when its shortest
//! edge is at most [`NEEDLE_RATIO`] times its longest (two corners (nearly) coincide): that
//! edge is collapsed. Otherwise it is a **cap** (an angle of ~180° at the apex, opposite the
//! long edge): the long edge is split at the apex's projection, which splits the triangle
//! beyond it too, and the new vertex is merged into the apex, so the cap vanishes and its
//! neighbour is cut in two at the apex. A repair is only made where it keeps the mesh as
//! manifold as it was (the link condition); if neither repair applies the triangle is
//! removed. Repairs cascade (a collapse can flatten a neighbour), so the triangles around
//! every repaired spot are examined again, within a bound on the number of repairs.

use std::collections::VecDeque;

use meshflow_plugin_sdk::REMOVED;
use meshflow_plugin_sdk::geometry::{add, dot, is_flat_within, scale, sub};

use crate::mirror::MirrorMesh;

/// A degenerate triangle whose shortest edge is at most this fraction of its longest is a
/// needle, else a cap. Small enough that a cap is never collapsed across a visible distance.
pub const NEEDLE_RATIO: f64 = 1e-3;
/// Repairs allowed per degenerate triangle found at the start (cascades included) before
/// the rest are removed instead; plus a fixed allowance for small inputs.
const REPAIRS_PER_DEGENERATE: usize = 8;
const REPAIRS_MIN: usize = 64;
/// A repair that flattens a triangle whose corners have no around-list yet waits for the
/// next wave, which lists them in one pass over the mesh. After this many waves, degenerate
/// triangles still waiting are removed: a bound on passes for chains of cascading repairs.
const REPAIR_WAVES: usize = 16;
/// Triangles are filed for the duplicate search in partitions of about this many (at most
/// this many partitions), so that a partition's counts and keys stay in cache, and so do
/// the ends of all partitions while they are filled.
const KEYS_PER_PARTITION: usize = 8192;
const MAX_PARTITIONS: usize = 256;
/// Triangles sharing their smallest corner up to this many are compared pair by pair;
/// larger groups (fans) are sorted.
const PAIRWISE_GROUP: usize = 8;

/// What the repair did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RepairReport {
    /// Triangles using a vertex twice, removed.
    pub improper: usize,
    /// Triangles with the same vertex set as a triangle of smaller id, removed.
    pub duplicates: usize,
    /// Degenerate triangles found after those removals.
    pub degenerate: usize,
    /// Caps removed by a split of their long edge.
    pub caps: usize,
    /// Needles removed by an edge collapse.
    pub needles: usize,
    /// Degenerate triangles no repair applied to, removed.
    pub removed: usize,
}

impl std::fmt::Display for RepairReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "removed {} repeated-vertex and {} duplicate triangle(s); {} degenerate triangle(s): \
             split {} cap(s), collapsed {} needle(s), removed {} unrepairable triangle(s)",
            self.improper, self.duplicates, self.degenerate, self.caps, self.needles, self.removed
        )
    }
}

/// Repairs the degenerate triangles of a compact mesh (as a run receives it). Returns the
/// edited mirror, whose edits replay the repair on the host, and what was done. Afterwards
/// no live triangle is degenerate (by the same `epsilon`), repeats a vertex or duplicates
/// another.
pub fn repair_degenerate(
    positions: Vec<f32>,
    triangles: Vec<u32>,
    epsilon: f64,
) -> (MirrorMesh, RepairReport) {
    let scan = scan_input(&positions, &triangles, epsilon);
    let duplicates = duplicates(&triangles, &scan.keys, scan.key);
    let flat: Vec<u32> =
        scan.flat.into_iter().filter(|t| duplicates.binary_search(t).is_err()).collect();
    let mut report = RepairReport {
        improper: scan.improper.len(),
        duplicates: duplicates.len(),
        degenerate: flat.len(),
        ..RepairReport::default()
    };

    let mut mesh = MirrorMesh::new(positions, triangles);
    let mut doomed = [scan.improper, duplicates].concat();
    doomed.sort_unstable();
    mesh.remove_triangles(&doomed);
    let is_flat = |mesh: &MirrorMesh, t: u32| {
        mesh.is_triangle_live(t) && is_flat_within(&mesh.triangle_points(t), epsilon)
    };

    let mut budget = REPAIRS_PER_DEGENERATE * flat.len() + REPAIRS_MIN;
    let mut waiting = flat;
    for wave in 0.. {
        if waiting.is_empty() {
            break;
        }
        // A triangle two repairs flattened waits twice: list it once, so its corners are
        // indexed once and a removal names it once (the store refuses an id twice).
        waiting.sort_unstable();
        waiting.dedup();
        if wave == REPAIR_WAVES {
            let left: Vec<u32> = waiting.into_iter().filter(|&t| is_flat(&mesh, t)).collect();
            report.removed += left.len();
            mesh.remove_triangles(&left);
            break;
        }
        let corners: Vec<u32> = waiting.iter().flat_map(|&t| mesh.corners(t)).collect();
        mesh.index(corners.into_iter().filter(|&v| v != REMOVED));
        let mut queue = VecDeque::from(std::mem::take(&mut waiting));
        while let Some(t) = queue.pop_front() {
            if !is_flat(&mesh, t) {
                continue;
            }
            if !mesh.corners(t).iter().all(|&v| mesh.is_indexed(v)) {
                waiting.push(t);
                continue;
            }
            let repaired = if budget == 0 { None } else { repair_one(&mut mesh, t) };
            budget = budget.saturating_sub(1);
            match repaired {
                Some((kind, spot)) => {
                    match kind {
                        Kind::Cap => report.caps += 1,
                        Kind::Needle => report.needles += 1,
                    }
                    queue.extend(mesh.around(spot));
                }
                None => {
                    mesh.remove_triangles(&[t]);
                    report.removed += 1;
                }
            }
        }
    }
    (mesh, report)
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Cap,
    Needle,
}

/// What one pass over the input finds.
struct InputScan {
    /// Triangles repeating a vertex, ascending.
    improper: Vec<u32>,
    /// The other triangles that are flat, ascending.
    flat: Vec<u32>,
    /// The [`DuplicateKey`] and id of every proper triangle, partitioned by the range its
    /// smallest corner falls in, ids ascending within a partition.
    keys: Vec<Vec<(u32, u32)>>,
    key: DuplicateKey,
}

/// The corners of a triangle in ascending order. By minima and maxima, not comparisons
/// and branches: corners come in any order, and mispredicted branches here cost more than
/// the rest of a triangle's test.
fn sorted_corners(c: &[u32]) -> [u32; 3] {
    let (lo, hi) = (c[0].min(c[1]), c[0].max(c[1]));
    let (low, rest) = (lo.min(c[2]), lo.max(c[2]));
    [low, rest.min(hi), rest.max(hi)]
}

/// How a proper triangle is filed for the duplicate search: in the partition of the range
/// its smallest corner falls in, under a 32-bit key whose high bits are that corner's place
/// in the range and whose low bits hash the other two. Equal vertex sets get equal keys;
/// unequal ones with the same smallest corner rarely do, and repeats are checked exactly.
#[derive(Clone, Copy)]
struct DuplicateKey {
    /// log2 of the vertices per partition.
    shift: u32,
}

impl DuplicateKey {
    // Shifts in u64: `shift` may be 32 (one partition of every possible id).
    fn partition(self, [a, _, _]: [u32; 3]) -> usize {
        (u64::from(a) >> self.shift) as usize
    }

    fn key(self, [a, b, c]: [u32; 3]) -> u32 {
        let offset = u64::from(a) & ((1 << self.shift) - 1);
        let h = b.wrapping_mul(0x9e37_79b1) ^ c.wrapping_mul(0x85eb_ca77);
        let h = (h ^ (h >> 15)).wrapping_mul(0x2c1b_3c6d);
        ((offset << (32 - self.shift)) | (u64::from(h) >> self.shift)) as u32
    }

    /// The smallest corner's place in its partition.
    fn offset(self, key: u32) -> usize {
        (u64::from(key) >> (32 - self.shift)) as usize
    }
}

/// One pass over the triangles: repeated vertices, flatness, and the keys that
/// [`duplicates`] looks for repeats in (so the mesh is read once for all three).
///
/// The corners' positions of a block of triangles are gathered first, in a loop that does
/// nothing else: on a mesh whose vertex ids come in no particular order every read is a
/// cache miss, and a short loop keeps many of them in flight at once.
fn scan_input(positions: &[f32], triangles: &[u32], epsilon: f64) -> InputScan {
    const BLOCK: usize = 256;
    let (points, _) = positions.as_chunks::<3>();
    let triangle_count = triangles.len() / 3;
    // Duplicates share their smallest corner: partitions by its range keep them together,
    // and follow the mesh's order where its ids have one.
    let wanted = (triangle_count / KEYS_PER_PARTITION).clamp(1, MAX_PARTITIONS);
    let key =
        DuplicateKey { shift: points.len().div_ceil(wanted).next_power_of_two().trailing_zeros() };
    let partitions = (points.len() >> key.shift) + 1;
    let mut scan = InputScan {
        improper: Vec::new(),
        flat: Vec::new(),
        // Grown as filled: capacity reserved up front and never written cost the sandbox a
        // page fault per page in every run.
        keys: vec![Vec::new(); partitions],
        key,
    };
    let mut gathered = [[0f32; 3]; 3 * BLOCK];
    for (first, block) in (0u32..).step_by(BLOCK).zip(triangles.chunks(3 * BLOCK)) {
        gather(points, block, &mut gathered);
        scan.add(first, block, &gathered, epsilon);
    }
    scan
}

impl InputScan {
    /// Adds triangles `first..` with their corners' points. Not inlined, as [`gather`].
    #[inline(never)]
    fn add(&mut self, first: u32, triangles: &[u32], points: &[[f32; 3]], epsilon: f64) {
        for ((t, c), p) in (first..).zip(triangles.chunks_exact(3)).zip(points.chunks_exact(3)) {
            let set = sorted_corners(c);
            if set[0] == set[1] || set[1] == set[2] {
                self.improper.push(t);
                continue;
            }
            self.keys[self.key.partition(set)].push((self.key.key(set), t));
            // Spelled out: `array::map` here ran 5x slower in the sandbox.
            let corner = |k: usize| {
                let [x, y, z] = p[k];
                [f64::from(x), f64::from(y), f64::from(z)]
            };
            if is_flat_within(&[corner(0), corner(1), corner(2)], epsilon) {
                self.flat.push(t);
            }
        }
    }
}

/// Copies the points `corners` name into `out`, four per loop turn.
///
/// Not inlined: in a function of its own the sandbox's compiler keeps the loop's few
/// values in registers, and with fewer instructions per read the processor keeps more
/// reads in flight (in a large function this loop spilled, and ran at half the speed).
#[inline(never)]
fn gather(points: &[[f32; 3]], corners: &[u32], out: &mut [[f32; 3]]) {
    let (quads, rest) = corners.as_chunks::<4>();
    let (out_quads, out_rest) = out[..corners.len()].as_chunks_mut::<4>();
    for (o, &[a, b, c, d]) in out_quads.iter_mut().zip(quads) {
        *o = [points[a as usize], points[b as usize], points[c as usize], points[d as usize]];
    }
    for (o, &v) in out_rest.iter_mut().zip(rest) {
        *o = points[v as usize];
    }
}

/// Proper triangles whose vertex set a proper triangle of smaller id has (either
/// orientation), ascending. Duplicates share their smallest corner, so they share a
/// partition and the high bits of their [`DuplicateKey`]: a counting sort by those bits,
/// within a partition small enough to stay in cache whatever the order of the mesh's ids,
/// groups the triangles sharing a smallest corner, and only triangles whose key repeats in
/// a group are compared exactly. O(T) for groups of bounded size, O(T log T) at worst
/// (fans are sorted).
fn duplicates(triangles: &[u32], partitions: &[Vec<(u32, u32)>], key: DuplicateKey) -> Vec<u32> {
    let mut found = Vec::new();
    let mut group_ends = Vec::new();
    let mut grouped = Vec::new();
    for partition in partitions {
        let repeated = repeated_keys(partition, key, &mut group_ends, &mut grouped);
        if repeated.is_empty() {
            continue;
        }
        // By vertex set, then id: all but the first of a set are duplicates.
        let mut candidates: Vec<([u32; 3], u32)> = partition
            .iter()
            .filter(|&&(k, _)| repeated.binary_search(&k).is_ok())
            .map(|&(_, t)| (sorted_corners(&triangles[3 * t as usize..][..3]), t))
            .collect();
        candidates.sort_unstable();
        found.extend(candidates.windows(2).filter(|w| w[0].0 == w[1].0).map(|w| w[1].1));
    }
    found.sort_unstable();
    found
}

/// The keys that occur more than once in a partition, ascending: its keys grouped by the
/// smallest corner (a counting sort into `grouped`, with `group_ends` as scratch space),
/// then each group compared within itself.
fn repeated_keys(
    partition: &[(u32, u32)],
    key: DuplicateKey,
    group_ends: &mut Vec<u32>,
    grouped: &mut Vec<u32>,
) -> Vec<u32> {
    group_ends.clear();
    group_ends.resize((1 << key.shift) + 1, 0);
    for &(k, _) in partition {
        group_ends[key.offset(k) + 1] += 1;
    }
    for i in 1..group_ends.len() {
        group_ends[i] += group_ends[i - 1];
    }
    grouped.clear();
    grouped.resize(partition.len(), 0);
    // group_ends[i] is group i's write cursor; afterwards, where group i ends.
    for &(k, _) in partition {
        let cursor = &mut group_ends[key.offset(k)];
        grouped[*cursor as usize] = k;
        *cursor += 1;
    }
    let mut repeated = Vec::new();
    let mut start = 0;
    for &end in &group_ends[..group_ends.len() - 1] {
        let group = &mut grouped[start as usize..end as usize];
        start = end;
        match group.len() {
            0 | 1 => {}
            2..=PAIRWISE_GROUP => {
                for i in 1..group.len() {
                    if group[..i].contains(&group[i]) {
                        repeated.push(group[i]);
                    }
                }
            }
            _ => {
                group.sort_unstable();
                repeated.extend(group.windows(2).filter(|w| w[0] == w[1]).map(|w| w[0]));
            }
        }
    }
    repeated.sort_unstable();
    repeated.dedup();
    repeated
}

/// Repairs one degenerate triangle: the repair its shape calls for, else the other one.
/// Returns the kind applied and the vertex around which the mesh changed.
fn repair_one(mesh: &mut MirrorMesh, t: u32) -> Option<(Kind, u32)> {
    let p = mesh.triangle_points(t);
    let length2 = [0, 1, 2].map(|k| {
        let d = sub(p[(k + 1) % 3], p[k]);
        dot(d, d)
    });
    let shortest = (0..3).min_by(|&i, &j| length2[i].total_cmp(&length2[j])).expect("3 edges");
    let longest = (0..3).max_by(|&i, &j| length2[i].total_cmp(&length2[j])).expect("3 edges");
    let is_needle = length2[shortest] <= NEEDLE_RATIO * NEEDLE_RATIO * length2[longest];
    let needle = |mesh: &mut MirrorMesh| collapse_needle(mesh, 3 * t + shortest as u32);
    let cap = |mesh: &mut MirrorMesh| split_cap(mesh, t, longest as u32);
    if is_needle {
        needle(mesh).map(|v| (Kind::Needle, v)).or_else(|| cap(mesh).map(|v| (Kind::Cap, v)))
    } else {
        cap(mesh).map(|v| (Kind::Cap, v)).or_else(|| needle(mesh).map(|v| (Kind::Needle, v)))
    }
}

/// Collapses the (short) edge of half-edge `h`, keeping a boundary end where only one end is
/// on the boundary so the border keeps its shape. Returns the kept vertex.
fn collapse_needle(mesh: &mut MirrorMesh, h: u32) -> Option<u32> {
    let t = h / 3;
    let c = mesh.corners(t);
    let (p, q) = (c[(h % 3) as usize], c[(h % 3 + 1) as usize % 3]);
    if !can_collapse(mesh, p, q) {
        return None;
    }
    let order = if mesh.is_border_vertex(q) && !mesh.is_border_vertex(p) {
        [(q, p), (p, q)]
    } else {
        [(p, q), (q, p)]
    };
    // The store merges a half-edge's end into its start: find one running keep -> gone (an
    // inconsistently oriented pair of triangles may only have one direction).
    order.into_iter().find_map(|(keep, gone)| {
        let edge = mesh.triangles_on_edge(keep, gone).into_iter().find_map(|u| {
            let cu = mesh.corners(u);
            (0..3).find(|&j| cu[j] == keep && cu[(j + 1) % 3] == gone).map(|j| 3 * u + j as u32)
        })?;
        mesh.collapse_edge(edge);
        Some(keep)
    })
}

/// Whether merging `gone` into `keep` (either way round: the test is symmetric) keeps the neighbourhood manifold: the edge has one or
/// two triangles, the two vertices share no neighbour but the apexes of those triangles (the
/// link condition), and an interior edge does not join two boundary vertices (which would
/// pinch the boundary).
fn can_collapse(mesh: &MirrorMesh, keep: u32, gone: u32) -> bool {
    let on_edge = mesh.triangles_on_edge(keep, gone);
    if on_edge.is_empty() || on_edge.len() > 2 {
        return false;
    }
    let mut apexes: Vec<u32> =
        on_edge.iter().flat_map(|&u| mesh.corners(u)).filter(|&v| v != keep && v != gone).collect();
    apexes.sort_unstable();
    let (around_keep, around_gone) = (mesh.neighbours(keep), mesh.neighbours(gone));
    let common: Vec<u32> =
        around_keep.into_iter().filter(|v| around_gone.binary_search(v).is_ok()).collect();
    if common != apexes {
        return false;
    }
    on_edge.len() == 1 || !(mesh.is_border_vertex(keep) && mesh.is_border_vertex(gone))
}

/// Splits the long edge (corner `k` of `t`) at the apex's projection and merges the new
/// vertex into the apex. Returns the apex.
fn split_cap(mesh: &mut MirrorMesh, t: u32, k: u32) -> Option<u32> {
    let c = mesh.corners(t);
    let (a, b, apex) = (c[k as usize], c[(k as usize + 1) % 3], c[(k as usize + 2) % 3]);
    let on_edge = mesh.triangles_on_edge(a, b);
    if on_edge.len() > 2 {
        return None;
    }
    // After the merge the apex is joined to the far corner of the triangle beyond the edge:
    // that must not be an edge already (the link condition of the merge).
    let around_apex = mesh.neighbours(apex);
    for &u in on_edge.iter().filter(|&&u| u != t) {
        let far = mesh.corners(u).into_iter().find(|&v| v != a && v != b).expect("proper");
        if far == apex || around_apex.binary_search(&far).is_ok() {
            return None;
        }
    }
    // On a boundary edge the new vertex is a boundary vertex: merging it into a boundary
    // apex would pinch the boundary.
    if on_edge.len() == 1 && mesh.is_border_vertex(apex) {
        return None;
    }
    let [pa, pb, pc] = [a, b, apex].map(|v| mesh.point(v));
    let ab = sub(pb, pa);
    let length2 = dot(ab, ab);
    if length2 == 0.0 {
        return None;
    }
    let s = (dot(sub(pc, pa), ab) / length2).clamp(0.0, 1.0);
    let at = add(pa, scale(ab, s)).map(|x| x as f32);
    let (_, halves) = mesh.split_edge_at(3 * t + k, at);
    let (_, half) = *halves.iter().find(|(old, _)| *old == t).expect("t lies on its own edge");
    // The appended half is (new vertex, b, apex): its corner 2 runs apex -> new vertex.
    mesh.collapse_edge(3 * half + 2);
    Some(apex)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mirror::Edit;
    use crate::mirror::tests::assert_store_agrees;
    use meshflow_mesh::MeshData;
    use meshflow_plugin_sdk::geometry::is_degenerate_within;
    use meshflow_plugin_sdk::topology::{HalfEdges, boundary_loops, is_manifold};

    /// The live triangles of slots (vertex ids unchanged: enough for topology checks).
    fn live(slots: &[u32]) -> Vec<u32> {
        slots.chunks_exact(3).filter(|c| c[0] != REMOVED).flatten().copied().collect()
    }

    fn loop_count(vertex_count: usize, triangles: &[u32]) -> usize {
        boundary_loops(triangles, &HalfEdges::new(vertex_count, triangles)).len()
    }

    /// Repairs, then checks that nothing degenerate is left and that the host's store
    /// replays the edits to the same slots.
    fn repair(mesh: &MeshData, epsilon: f64) -> (Vec<f32>, Vec<u32>, RepairReport) {
        let (mirror, report) =
            repair_degenerate(mesh.positions.clone(), mesh.triangles.clone(), epsilon);
        let (positions, slots) = mirror.to_arrays();
        let triangles = live(&slots);
        for t in 0..(triangles.len() / 3) as u32 {
            assert!(!is_degenerate_within(&positions, &triangles, t, epsilon), "{t} is flat");
        }
        assert_store_agrees(mesh, mirror);
        (positions, triangles, report)
    }

    /// A 4x4 grid of unit squares: vertex `5y + x` at (x, y); square `v` (its lower left
    /// corner) is split into (v, v+1, v+6) and (v, v+6, v+5).
    fn grid() -> MeshData {
        let (positions, triangles) = meshflow_plugin_sdk::topology::shapes::square_grid(4);
        MeshData::new(positions, triangles)
    }

    fn place(mesh: &mut MeshData, v: usize, x: f32, y: f32) {
        mesh.positions[3 * v..3 * v + 2].copy_from_slice(&[x, y]);
    }

    /// The grid with two caps (one on the border), two needles sharing an edge, a reversed
    /// duplicate and a repeated-vertex triangle; no triangle is inverted by the moves.
    fn damaged_grid() -> MeshData {
        let mut mesh = grid();
        place(&mut mesh, 6, 0.5, 0.0); // (0, 1, 6): cap on the border edge 0-1
        place(&mut mesh, 17, 1.0, 2.5); // (11, 17, 16): cap on the interior edge 11-16
        place(&mut mesh, 13, 3.0, 1.0); // onto vertex 8: needles (7, 8, 13), (8, 14, 13)
        mesh.triangles.extend([18, 13, 12, 3, 3, 9]);
        mesh
    }

    #[test]
    fn caps_are_split_needles_collapsed_and_the_border_kept() {
        let mesh = damaged_grid();
        let (positions, triangles, report) = repair(&mesh, 0.0);
        let expected = RepairReport {
            improper: 1,
            duplicates: 1,
            degenerate: 4,
            caps: 2,
            needles: 1,
            removed: 0,
        };
        assert_eq!(report, expected);
        let vertex_count = positions.len() / 3;
        assert_eq!(loop_count(vertex_count, &triangles), 1);
        assert!(is_manifold(vertex_count, &triangles, &HalfEdges::new(vertex_count, &triangles)));
        // 32 triangles: the two needles go, the caps are traded for halves of their
        // neighbours except on the border, where the cap just goes.
        assert_eq!(triangles.len() / 3, 32 - 2 - 1);
    }

    #[test]
    fn nearly_flat_triangles_count_only_with_a_tolerance() {
        let mut mesh = grid();
        place(&mut mesh, 17, 1.0001, 2.5);
        assert_eq!(repair(&mesh, 0.0).2, RepairReport::default());
        let report = repair(&mesh, 1e-3).2;
        assert_eq!((report.degenerate, report.caps), (1, 1));
    }

    #[test]
    fn a_cap_whose_repair_would_fold_the_surface_is_removed() {
        // Cap (a, b, c) with c between a and b; beyond a-b lies (b, a, d), and c-d is
        // already an edge, so neither splitting a-b nor collapsing a short edge applies.
        let mesh = MeshData::new(
            vec![0., 0., 0., 2., 0., 0., 1., 0., 0., 1., -1., 0., 2., -1., 0.],
            vec![0, 1, 2, 1, 0, 3, 2, 3, 4],
        );
        let (_, triangles, report) = repair(&mesh, 0.0);
        assert_eq!((report.degenerate, report.removed), (1, 1));
        assert_eq!(triangles, [1, 0, 3, 2, 3, 4]);
    }

    #[test]
    fn duplicates_around_a_fan_centre_are_found_whatever_their_orientation() {
        // Twelve triangles around vertex 0 (more than are compared pair by pair), then a
        // reversed copy, a rotated copy and a triangle repeating a vertex.
        let mut positions = vec![0.0, 0.0, 0.0];
        for i in 0..12 {
            let angle = i as f32 * std::f32::consts::TAU / 12.0;
            positions.extend([angle.cos(), angle.sin(), 0.0]);
        }
        let mut triangles: Vec<u32> = (1..=12).flat_map(|i| [0, i, i % 12 + 1]).collect();
        triangles.extend([4, 3, 0, 6, 0, 5, 0, 7, 7]);
        let (mirror, report) = repair_degenerate(positions, triangles, 0.0);
        assert_eq!((report.improper, report.duplicates, report.degenerate), (1, 2, 0));
        assert_eq!(mirror.into_edits(), [Edit::RemoveTriangles(vec![12, 13, 14])]);
    }

    #[test]
    fn duplicates_are_found_in_a_large_mesh_of_no_particular_order() {
        // 60k random triangles on 20k vertices (many partitions), then copies of random
        // ones, rotated or reversed, at random places; against a plain set of vertex sets.
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: u32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % u64::from(n)) as u32
        };
        let vertices = 20_000;
        let mut triangles: Vec<u32> = (0..3 * 60_000).map(|_| next(vertices)).collect();
        for _ in 0..500 {
            let from = 3 * next(triangles.len() as u32 / 3) as usize;
            let [a, b, c] = [triangles[from], triangles[from + 1], triangles[from + 2]];
            let copy = if next(2) == 0 { [b, c, a] } else { [c, b, a] };
            let at = 3 * next(triangles.len() as u32 / 3) as usize;
            triangles.splice(at..at, copy);
        }
        let mut seen = std::collections::HashSet::new();
        let expected: Vec<u32> = (0u32..)
            .zip(triangles.chunks_exact(3))
            .filter(|(_, c)| {
                let set = sorted_corners(c);
                set[0] != set[1] && set[1] != set[2] && !seen.insert(set)
            })
            .map(|(t, _)| t)
            .collect();
        assert!(expected.len() >= 500);
        let positions = vec![0.0; 3 * vertices as usize];
        let scan = scan_input(&positions, &triangles, 0.0);
        assert!(scan.keys.len() > 1);
        assert_eq!(duplicates(&triangles, &scan.keys, scan.key), expected);
    }

    #[test]
    fn a_repair_that_flattens_a_triangle_further_away_is_followed_there() {
        // The needle (k, g, r) stands on x = 0 with |kg| = 1e-4. Merging g into k moves the
        // corner g of (g, x, y) onto the line from x to y: that triangle turns flat, and
        // neither x nor y was a corner of anything flat at the start.
        let mesh = MeshData::new(
            vec![0., 0., 0., 0., 1e-4, 0., 0., 1., 0., -1., 0., 0., 1., 0., 0.],
            vec![0, 1, 2, 1, 3, 4],
        );
        let (_, triangles, report) = repair(&mesh, 0.0);
        assert_eq!((report.degenerate, report.needles + report.caps + report.removed), (1, 2));
        assert!(triangles.is_empty());
    }

    #[test]
    fn coincident_corners_and_empty_meshes_do_not_panic() {
        // All three corners at one point, alone: collapsed away.
        let point = MeshData::new(vec![1.0; 9], vec![0, 1, 2]);
        let (_, triangles, report) = repair(&point, 0.0);
        assert!(triangles.is_empty());
        assert_eq!(report.needles + report.removed, 1);
        assert_eq!(repair(&MeshData::default(), 0.0).2, RepairReport::default());
    }
}
