//! Quadric edge-collapse decimation (Garland & Heckbert 1997).
//!
//! Each vertex carries the area-weighted sum of the squared-distance quadrics of its
//! triangles' planes; the edge whose merged quadric gives the smallest error at its best
//! point is collapsed first (a priority queue with lazy re-evaluation). A collapse is refused
//! when it would change the topology (link condition), create a valence-2 vertex, fold a
//! triangle over (its normal turning by more than [`MAX_NORMAL_TURN_COS`] allows), or — with
//! the boundary preserved — move a boundary vertex. Vertices on non-manifold edges, at
//! non-manifold vertices, and of improper or duplicated triangles never move.
//!
//! Collapses follow the host store's rule (the start of the half-edge survives, triangles
//! on the edge disappear, the end's other triangles turn to the start), so the recorded
//! edges replay exactly; survivors are moved to their final positions at the end. The work
//! is done in spatially ordered ids ([`crate::renumber`]), translated back at the end.

use std::cmp::{Ordering, Reverse};

use radix_heap::RadixHeapMap;

use crate::local::LocalMesh;
use crate::renumber::Renumbering;
use meshflow_plugin_sdk::geometry::{Vec3, add, cross, dot, norm, point, scale, sub};
use meshflow_plugin_sdk::topology::halfedge::{EdgeKind, HalfEdges, origin, prev};
use meshflow_plugin_sdk::topology::manifold::non_manifold_vertices;

/// A triangle whose unit normal would turn so that its dot product with the old one falls
/// below this is a fold-over (about 78°): the collapse is refused.
pub const MAX_NORMAL_TURN_COS: f64 = 0.2;
/// How strongly the planes through boundary edges hold an unpreserved boundary in place,
/// relative to the surface's own planes.
pub const BOUNDARY_WEIGHT: f64 = 1.0;
/// The best point is used only within this many edge lengths of the edge's midpoint; beyond
/// it (near-singular quadric) the better of the ends and the midpoint is taken.
const MAX_OPTIMUM_REACH: f64 = 2.0;
/// The collapse queue gives back its buckets' spare capacity after popping this fraction of
/// its entries.
const SHRINK_EVERY_FRACTION: usize = 64;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// Stop when at most this many triangles are left.
    pub target_triangles: usize,
    /// Boundary vertices stay where they are and boundary edges are not collapsed.
    pub preserve_boundary: bool,
    /// 0: pure quadric error; more: also penalise collapses that leave poorly shaped
    /// triangles (the error is multiplied by `1 + weight × (1 − worst shape)`).
    pub quality_weight: f64,
}

/// The collapses to replay and where their survivors end up.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Decimation {
    /// Half-edges to collapse with `collapse-edge`, in order (the start survives).
    pub collapses: Vec<u32>,
    /// Surviving vertices whose position changed, ascending, and their new `x y z`.
    pub moved: Vec<u32>,
    pub moved_positions: Vec<f32>,
    pub triangles_before: usize,
    pub triangles_after: usize,
    /// Vertices that could not move (non-manifold spots, improper or duplicated triangles).
    pub locked_vertices: usize,
}

/// Collapses edges of `triangles` until at most `settings.target_triangles` remain or no
/// allowed collapse is left. Removed triangles (all corners `NONE`) are skipped.
pub fn decimate(positions: &[f32], triangles: &[u32], settings: Settings) -> Decimation {
    let (ids, positions, triangles) = Renumbering::spatial(positions, triangles);
    translate(&ids, decimate_in_place(&positions, triangles, settings))
}

/// [`decimate`] of arrays it may drop once it has its working copy: the guest then holds
/// the mesh once, not twice, while it works.
pub fn decimate_owned(positions: Vec<f32>, triangles: Vec<u32>, settings: Settings) -> Decimation {
    let (ids, work_positions, work_triangles) = Renumbering::spatial(&positions, &triangles);
    drop((positions, triangles));
    translate(&ids, decimate_in_place(&work_positions, work_triangles, settings))
}

/// A decimation in working ids, in the host's.
fn translate(ids: &Renumbering, d: Decimation) -> Decimation {
    let mut order: Vec<usize> = (0..d.moved.len()).collect();
    order.sort_unstable_by_key(|&i| ids.vertex(d.moved[i]));
    Decimation {
        collapses: d.collapses.iter().map(|&h| ids.half_edge(h)).collect(),
        moved: order.iter().map(|&i| ids.vertex(d.moved[i])).collect(),
        moved_positions: order
            .iter()
            .flat_map(|&i| &d.moved_positions[3 * i..3 * i + 3])
            .copied()
            .collect(),
        ..d
    }
}

/// [`decimate`] in the ids it is given; `triangles` are dropped once the state is built.
fn decimate_in_place(positions: &[f32], triangles: Vec<u32>, settings: Settings) -> Decimation {
    let mut state = State::new(positions, &triangles, settings);
    drop(triangles);
    let before = state.live;
    let mut queue = state.first_queue();
    let mut pops_since_shrink = 0;
    while state.live > settings.target_triangles {
        // The heap's buckets keep the largest capacity they ever had while entries move
        // between them as the top rises: without this they held about four times the
        // entries in them. Order is untouched, so is the result; a shrink copies at most
        // the entries, once per 1/64 of them popped.
        pops_since_shrink += 1;
        if pops_since_shrink > queue.len() / SHRINK_EVERY_FRACTION {
            queue.shrink_to_fit();
            pops_since_shrink = 0;
        }
        let Some((Reverse(key), entry)) = queue.pop() else { break };
        let Candidate { a, b, .. } = entry;
        if !state.is_current(&entry) {
            continue;
        }
        match state.evaluate(a, b) {
            None => continue,
            Some(c) if cost_key(c.cost) > key => {
                queue.push(Reverse(cost_key(c.cost)), entry);
                continue;
            }
            Some(c) => {
                let survivor = state.collapse(c);
                for w in state.mesh.neighbours(survivor) {
                    state.push(&mut queue, survivor, w);
                }
            }
        }
    }
    state.finish(positions, before)
}

/// A planar squared-distance quadric: the symmetric 4×4 matrix `[A b; bᵀ c]` of
/// `(n·x + d)²`, stored as its upper triangle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Quadric([f64; 10]);

impl Quadric {
    fn plane(n: Vec3, d: f64, weight: f64) -> Self {
        let [a, b, c] = n;
        Quadric(
            [a * a, a * b, a * c, a * d, b * b, b * c, b * d, c * c, c * d, d * d]
                .map(|x| x * weight),
        )
    }

    fn add(&self, other: &Quadric) -> Quadric {
        Quadric(std::array::from_fn(|i| self.0[i] + other.0[i]))
    }

    fn error(&self, [x, y, z]: Vec3) -> f64 {
        let q = &self.0;
        q[0] * x * x
            + 2.0 * q[1] * x * y
            + 2.0 * q[2] * x * z
            + 2.0 * q[3] * x
            + q[4] * y * y
            + 2.0 * q[5] * y * z
            + 2.0 * q[6] * y
            + q[7] * z * z
            + 2.0 * q[8] * z
            + q[9]
    }

    /// The point of least error, if the 3×3 system is well conditioned.
    fn optimum(&self) -> Option<Vec3> {
        let q = &self.0;
        let m = [[q[0], q[1], q[2]], [q[1], q[4], q[5]], [q[2], q[5], q[7]]];
        let rhs = [-q[3], -q[6], -q[8]];
        let det = dot(m[0], cross(m[1], m[2]));
        let scale = (q[0] + q[4] + q[7]).powi(3);
        // Also refuses a NaN determinant.
        if det.abs().partial_cmp(&(1e-10 * scale)) != Some(Ordering::Greater) {
            return None;
        }
        // Cramer's rule (m is symmetric, so its columns are its rows).
        let solve = |k: usize| {
            let mut c = m;
            for row in 0..3 {
                c[row][k] = rhs[row];
            }
            dot(c[0], cross(c[1], c[2])) / det
        };
        Some([solve(0), solve(1), solve(2)])
    }
}

/// Collapses are taken cheapest first from a monotone radix heap: the queue holds millions of
/// entries, most of which go stale, and a binary heap's pops (each a walk down the tree
/// through cache misses) took half of all the time on a 1M-vertex scan. Keys are the costs'
/// `f32` bits (ordered like the costs, as these are never negative). A collapse may make a
/// neighbouring edge cheaper than the last one taken; it is queued at that last cost, so it
/// is taken next.
type Queue = RadixHeapMap<Reverse<u32>, Candidate>;

fn cost_key(cost: f64) -> u32 {
    let cost = cost as f32;
    // Also maps -0 and NaN to the cheapest key.
    if cost > 0.0 { cost.to_bits() } else { 0 }
}

/// A queued collapse of edge `a`–`b`, valid while both vertices keep their versions.
/// Versions wrap, which at worst lets a stale entry be evaluated again (the collapse is
/// evaluated afresh when popped).
#[derive(Clone, Copy, Debug)]
struct Candidate {
    a: u32,
    b: u32,
    version_a: u16,
    version_b: u16,
}

/// A collapse that passed every test: keep `from`'s start, place it at `at`.
struct Collapse {
    half_edge: u32,
    survivor: u32,
    removed: u32,
    at: Vec3,
    cost: f64,
}

struct State {
    pos: Vec<Vec3>,
    mesh: LocalMesh,
    quadrics: Vec<Quadric>,
    version: Vec<u16>,
    alive: Vec<bool>,
    locked: Vec<bool>,
    live: usize,
    settings: Settings,
    collapses: Vec<u32>,
    locked_count: usize,
}

impl State {
    fn new(positions: &[f32], triangles: &[u32], settings: Settings) -> Self {
        let n = positions.len() / 3;
        let pos: Vec<Vec3> = (0..n as u32).map(|v| point(positions, v)).collect();
        let half_edges = HalfEdges::new(n, triangles);
        let mut locked = vec![false; n];
        let mesh = LocalMesh::new(n, triangles);
        let mut live = 0;
        for (t, c) in triangles.chunks_exact(3).enumerate() {
            if mesh.is_live(t as u32) {
                live += 1;
            } else {
                // Improper: its in-range corners stay put; it takes no part.
                for &v in c.iter().filter(|&&v| (v as usize) < n) {
                    locked[v as usize] = true;
                }
            }
        }
        let apex = |h: u32| origin(triangles, prev(h));
        for h in 0..half_edges.len() as u32 {
            let kind = half_edges.kind(h);
            let duplicate = kind.is_interior() && apex(half_edges.opposite(h)) == apex(h);
            if kind == EdgeKind::NonManifold || duplicate {
                for v in mesh.corners(h / 3) {
                    locked[v as usize] = true;
                }
            }
        }
        for v in non_manifold_vertices(n, triangles, &half_edges) {
            locked[v as usize] = true;
        }

        let mut quadrics = vec![Quadric::default(); n];
        for t in (0..triangles.len() as u32 / 3).filter(|&t| mesh.is_live(t)) {
            let c = mesh.corners(t);
            let p = c.map(|v| pos[v as usize]);
            let normal = cross(sub(p[1], p[0]), sub(p[2], p[0]));
            let double_area = norm(normal);
            if double_area > 0.0 {
                let unit = scale(normal, 1.0 / double_area);
                let q = Quadric::plane(unit, -dot(unit, p[0]), 0.5 * double_area);
                for v in c {
                    quadrics[v as usize] = quadrics[v as usize].add(&q);
                }
            }
            for k in 0..3 {
                let h = 3 * t + k as u32;
                let edge = sub(p[(k + 1) % 3], p[k]);
                if !settings.preserve_boundary && half_edges.kind(h) == EdgeKind::Boundary {
                    // A plane through the edge, perpendicular to the triangle.
                    if let Some(m) = unit(cross(edge, normal)) {
                        let weight = BOUNDARY_WEIGHT * dot(edge, edge);
                        let q = Quadric::plane(m, -dot(m, p[k]), weight);
                        for v in [c[k], c[(k + 1) % 3]] {
                            quadrics[v as usize] = quadrics[v as usize].add(&q);
                        }
                    }
                }
            }
        }
        let locked_count = locked.iter().filter(|&&l| l).count();
        State {
            pos,
            mesh,
            quadrics,
            version: vec![0; n],
            alive: vec![true; n],
            locked,
            live,
            settings,
            collapses: Vec::new(),
            locked_count,
        }
    }

    /// Every edge queued once, in the order of its smaller vertex, then the larger.
    ///
    /// The heap is made with its top already at the cheapest of them: a heap without a top
    /// first gathers its entries in a list of their own and moves each to its bucket at
    /// the first pop, holding every entry twice (two thirds of the filter's memory went
    /// to that). The buckets then receive the same entries in the same order, so every pop
    /// is the same (ties included) and so is the result. That costs a first pass for the
    /// cheapest cost.
    fn first_queue(&self) -> Queue {
        let mut cheapest: Option<u32> = None;
        self.for_each_edge(|a, b| {
            if let Some(cost) = self.cost(a, b) {
                let key = cost_key(cost);
                cheapest = Some(cheapest.map_or(key, |c| c.min(key)));
            }
        });
        let Some(cheapest) = cheapest else { return Queue::new() };
        let mut queue = Queue::new_at(Reverse(cheapest));
        self.for_each_edge(|a, b| self.push(&mut queue, a, b));
        queue
    }

    fn for_each_edge(&self, mut f: impl FnMut(u32, u32)) {
        let mut ring = Vec::new();
        for v in 0..self.pos.len() as u32 {
            self.mesh.neighbours_into(v, &mut ring);
            for &w in &ring {
                if v < w {
                    f(v, w);
                }
            }
        }
    }

    /// What collapsing edge `a`–`b` costs, if its ends may merge.
    fn cost(&self, a: u32, b: u32) -> Option<f64> {
        if self.settings.quality_weight > 0.0 {
            // The shape penalty needs the fan anyway.
            self.evaluate(a, b).map(|c| c.cost)
        } else {
            self.placement(a, b).map(|(_, error, _)| error)
        }
    }

    /// Queues edge `a`–`b` by its cost. Whether it keeps the topology and folds nothing is
    /// checked when it is popped: most queued entries go stale before that.
    fn push(&self, queue: &mut Queue, a: u32, b: u32) {
        if let Some(cost) = self.cost(a, b) {
            let (version_a, version_b) = (self.version[a as usize], self.version[b as usize]);
            let last = queue.top().map_or(0, |Reverse(key)| key);
            let key = cost_key(cost).max(last);
            queue.push(Reverse(key), Candidate { a, b, version_a, version_b });
        }
    }

    fn is_current(&self, c: &Candidate) -> bool {
        let (a, b) = (c.a as usize, c.b as usize);
        self.alive[a]
            && self.alive[b]
            && self.version[a] == c.version_a
            && self.version[b] == c.version_b
    }

    /// Where edge `a`–`b` would merge to and its quadric error there, if no end is locked
    /// and a preserved boundary allows it; and the end a preserved boundary pins.
    fn placement(&self, a: u32, b: u32) -> Option<(Vec3, f64, Option<u32>)> {
        if self.locked[a as usize] || self.locked[b as usize] {
            return None;
        }
        let (boundary_a, boundary_b) = (self.mesh.is_boundary(a), self.mesh.is_boundary(b));
        // Which end a preserved boundary pins (the other merges into it).
        let keep = match (self.settings.preserve_boundary, boundary_a, boundary_b) {
            (false, _, _) | (true, false, false) => None,
            (true, true, true) => return None,
            (true, true, false) => Some(a),
            (true, false, true) => Some(b),
        };
        let quadric = self.quadrics[a as usize].add(&self.quadrics[b as usize]);
        let (pa, pb) = (self.pos[a as usize], self.pos[b as usize]);
        let at = match keep {
            Some(v) => self.pos[v as usize],
            None => self.best_point(&quadric, pa, pb),
        };
        let at = at.map(|x| x as f32 as f64);
        Some((at, quadric.error(at).max(0.0), keep))
    }

    /// Whether and how edge `a`–`b` may collapse, with its cost.
    fn evaluate(&self, a: u32, b: u32) -> Option<Collapse> {
        let (at, error, keep) = self.placement(a, b)?;
        let on_edge = self.mesh.collapse_keeps_topology(a, b)?;
        // Two boundary vertices joined across the inside: collapsing would pinch the surface.
        let edge_on_boundary = on_edge.count() == 1;
        if self.mesh.is_boundary(a) && self.mesh.is_boundary(b) && !edge_on_boundary {
            return None;
        }
        let worst_shape = self.check_fan(a, b, at)?;
        let penalty = 1.0 + self.settings.quality_weight * (1.0 - worst_shape);
        let cost = error * penalty;
        // A pinned boundary vertex must survive as itself (the half-edge's start), not only
        // at its place: run in blocks, its id is what the neighbouring block shares.
        let runs = |c: [u32; 3], k: usize| match keep {
            Some(kept) => c[k] == kept && c[(k + 1) % 3] == if kept == a { b } else { a },
            None => c[k] == a && c[(k + 1) % 3] == b || c[k] == b && c[(k + 1) % 3] == a,
        };
        let half_edge = on_edge.iter().find_map(|t| {
            let c = self.mesh.corners(t);
            (0..3).find(|&k| runs(c, k)).map(|k| 3 * t + k as u32)
        })?;
        let start = self.mesh.corners(half_edge / 3)[half_edge as usize % 3];
        let removed = if start == a { b } else { a };
        Some(Collapse { half_edge, survivor: start, removed, at, cost })
    }

    fn best_point(&self, quadric: &Quadric, pa: Vec3, pb: Vec3) -> Vec3 {
        let mid = scale(add(pa, pb), 0.5);
        let reach = MAX_OPTIMUM_REACH * norm(sub(pa, pb));
        match quadric.optimum() {
            Some(p) if norm(sub(p, mid)) <= reach => p,
            _ => [pa, pb, mid]
                .into_iter()
                .min_by(|x, y| quadric.error(*x).total_cmp(&quadric.error(*y)))
                .expect("three candidates"),
        }
    }

    /// The worst shape (1 equilateral, 0 flat) of the triangles around `a` and `b` that
    /// survive the collapse with the merged vertex at `at`, or `None` if one folds over or
    /// becomes flat.
    fn check_fan(&self, a: u32, b: u32, at: Vec3) -> Option<f64> {
        let mut worst: f64 = 1.0;
        for &v in &[a, b] {
            for &t in self.mesh.around(v) {
                let c = self.mesh.corners(t);
                if c.contains(&a) && c.contains(&b) {
                    continue;
                }
                let old = c.map(|w| self.pos[w as usize]);
                let new = c.map(|w| if w == a || w == b { at } else { self.pos[w as usize] });
                let n_old = cross(sub(old[1], old[0]), sub(old[2], old[0]));
                let n_new = cross(sub(new[1], new[0]), sub(new[2], new[0]));
                let (l_old, l_new) = (norm(n_old), norm(n_new));
                let folds = l_new == 0.0 || dot(n_old, n_new) < MAX_NORMAL_TURN_COS * l_old * l_new;
                if l_old > 0.0 && folds {
                    return None;
                }
                if self.settings.quality_weight > 0.0 {
                    worst = worst.min(shape(&new));
                }
            }
        }
        Some(worst)
    }

    fn collapse(&mut self, c: Collapse) -> u32 {
        let (s, r, removed) = self.mesh.collapse(c.half_edge);
        debug_assert_eq!((s, r), (c.survivor, c.removed));
        self.live -= removed;
        self.quadrics[s as usize] = self.quadrics[s as usize].add(&self.quadrics[r as usize]);
        self.pos[s as usize] = c.at;
        self.alive[r as usize] = false;
        self.version[s as usize] = self.version[s as usize].wrapping_add(1);
        self.version[r as usize] = self.version[r as usize].wrapping_add(1);
        self.collapses.push(c.half_edge);
        s
    }

    fn finish(self, positions: &[f32], before: usize) -> Decimation {
        let mut moved = Vec::new();
        let mut moved_positions = Vec::new();
        for (v, p) in self.pos.iter().enumerate() {
            let new = p.map(|x| x as f32);
            if self.alive[v] && new[..] != positions[3 * v..3 * v + 3] {
                moved.push(v as u32);
                moved_positions.extend(new);
            }
        }
        Decimation {
            collapses: self.collapses,
            moved,
            moved_positions,
            triangles_before: before,
            triangles_after: self.live,
            locked_vertices: self.locked_count,
        }
    }
}

fn unit(v: Vec3) -> Option<Vec3> {
    let l = norm(v);
    (l > 0.0).then(|| scale(v, 1.0 / l))
}

/// `4√3 · area / Σ edge²`: 1 for an equilateral triangle, 0 for a flat one.
fn shape(p: &[Vec3; 3]) -> f64 {
    let area = 0.5 * norm(cross(sub(p[1], p[0]), sub(p[2], p[0])));
    let squares: f64 =
        (0..3).map(|k| dot(sub(p[(k + 1) % 3], p[k]), sub(p[(k + 1) % 3], p[k]))).sum();
    if squares > 0.0 { 4.0 * 3f64.sqrt() * area / squares } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures;
    use crate::isotropic::Edit;
    use meshflow_plugin_sdk::topology::manifold::{is_manifold, is_oriented};
    use meshflow_plugin_sdk::topology::shapes::{square_grid, uv_sphere};

    /// The decimated mesh as the host holds it after the run.
    fn replay(positions: &[f32], triangles: &[u32], d: &Decimation) -> (Vec<f32>, Vec<u32>) {
        let edits: Vec<Edit> =
            d.collapses.iter().map(|&edge| Edit::CollapseEdge { edge }).collect();
        let mut moved = positions.to_vec();
        for (i, &v) in d.moved.iter().enumerate() {
            moved[3 * v as usize..3 * v as usize + 3]
                .copy_from_slice(&d.moved_positions[3 * i..3 * i + 3]);
        }
        fixtures::replay(positions.len() / 3, triangles, &edits, &moved)
    }

    fn settings(target: usize) -> Settings {
        Settings { target_triangles: target, preserve_boundary: true, quality_weight: 0.0 }
    }

    fn manifold_and_oriented(p: &[f32], t: &[u32]) -> bool {
        let he = HalfEdges::new(p.len() / 3, t);
        is_manifold(p.len() / 3, t, &he) && is_oriented(&he)
    }

    #[test]
    fn a_sphere_reaches_the_target_and_stays_a_closed_oriented_sphere() {
        let (p, t) = uv_sphere(30, 60);
        let d = decimate(&p, &t, settings(500));
        assert!(d.triangles_after <= 500 && d.triangles_after >= 498, "{}", d.triangles_after);
        let (p2, t2) = replay(&p, &t, &d);
        assert_eq!(t2.len() / 3, d.triangles_after);
        assert!(manifold_and_oriented(&p2, &t2));
        // Closed genus 0: V − E + F = 2, i.e. F = 2V − 4.
        assert_eq!(t2.len() / 3, 2 * (p2.len() / 3) - 4);
        // The vertices stay near the unit sphere.
        for v in p2.chunks(3) {
            let r = (v[0] as f64).hypot(v[1] as f64).hypot(v[2] as f64);
            assert!((r - 1.0).abs() < 0.05, "radius {r}");
        }
    }

    #[test]
    fn a_flat_grid_keeps_its_boundary_and_stays_flat() {
        let n = 20u32;
        let (p, t) = square_grid(n - 1);
        let d = decimate(&p, &t, settings(100));
        let (p2, t2) = replay(&p, &t, &d);
        assert!(manifold_and_oriented(&p2, &t2));
        assert!(p2.chunks(3).all(|v| v[2] == 0.0));
        // Every boundary vertex of the input is still there, unmoved.
        let border = |v: &[f32]| v[0] == 0.0 || v[1] == 0.0 || v[0] == 19.0 || v[1] == 19.0;
        let kept = p2.chunks(3).filter(|v| border(v)).count();
        assert_eq!(kept, 4 * (n as usize - 1));
        // The area is unchanged: nothing folded.
        let area: f64 = t2
            .chunks(3)
            .map(|c| {
                let q = c.iter().map(|&v| point(&p2, v)).collect::<Vec<_>>();
                0.5 * cross(sub(q[1], q[0]), sub(q[2], q[0]))[2]
            })
            .sum();
        assert!((area - 361.0).abs() < 1e-6, "area {area}");
    }

    #[test]
    fn a_tetrahedron_cannot_collapse_and_non_manifold_spots_stay_put() {
        let p = vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0];
        let t = vec![0, 2, 1, 0, 1, 3, 1, 2, 3, 0, 3, 2];
        let d = decimate(&p, &t, settings(1));
        assert!(d.collapses.is_empty());
        assert_eq!(d.triangles_after, 4);

        // A sphere with a fin on one edge and a degenerate triangle: both spots are locked.
        let (mut p, mut t) = uv_sphere(12, 24);
        let extra = (p.len() / 3) as u32;
        p.extend([3.0, 3.0, 3.0]);
        t.extend([t[0], t[1], extra, 5, 5, 6]);
        let d = decimate(&p, &t, settings(100));
        assert!(d.locked_vertices >= 4);
        let (p2, t2) = replay(&p, &t, &d);
        assert!(t2.len() / 3 < t.len() / 3 / 2);
        assert!(p2.chunks(3).any(|v| v == [3.0, 3.0, 3.0]));
    }

    #[test]
    fn quality_weight_gives_better_shaped_triangles() {
        let (p, t) = uv_sphere(30, 60);
        let worst = |w: f64| {
            let d = decimate(&p, &t, Settings { quality_weight: w, ..settings(600) });
            let (p2, t2) = replay(&p, &t, &d);
            let shapes: Vec<f64> =
                t2.chunks(3).map(|c| shape(&[0, 1, 2].map(|k| point(&p2, c[k])))).collect();
            shapes.iter().sum::<f64>() / shapes.len() as f64
        };
        let (plain, weighted) = (worst(0.0), worst(1.0));
        assert!(weighted > plain + 0.01, "mean shape {weighted} with the weight, {plain} without");
    }
}
