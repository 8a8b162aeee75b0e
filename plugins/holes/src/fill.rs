//! The whole `fill-holes` pipeline over flat arrays: find the holes, decide which to fill,
//! and for each: triangulate, refine, fair. Returns the new vertices and triangles for the
//! caller to add in bulk.

use meshflow_plugin_sdk::geometry::{Vec3, distance, larger, point, smaller, triangle_unit_normal};
use meshflow_plugin_sdk::topology::boundary::{BoundaryLoop, boundary_loops};
use meshflow_plugin_sdk::topology::halfedge::{HalfEdges, triangle_of};

use crate::fair::{Ring, fair};
use crate::patch::Patch;
use crate::refine::refine;
use crate::surroundings::Surroundings;
use crate::triangulate::{Polygon, triangulate};

/// How to fill.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    /// Holes with more boundary edges stay open.
    pub max_hole_edges: usize,
    /// Whether to add vertices to match the surrounding density (else the triangulation only).
    pub refine: bool,
    /// Fairing steps on the new vertices (0: none).
    pub fairing_iterations: u32,
}

/// What filling produced: new vertices (ids from `vertex_count` on, in order) and triangles
/// (mesh vertex ids), and the account of every hole.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Filling {
    pub new_positions: Vec<f32>,
    pub new_triangles: Vec<u32>,
    pub filled: usize,
    /// Holes with more than `max_hole_edges` edges.
    pub too_large: usize,
    /// Loops through a non-manifold vertex or edge: visiting a vertex twice, not closed, or
    /// crossing an orientation seam.
    pub non_manifold: usize,
    /// Holes whose every triangulation would duplicate an edge the mesh already has.
    pub unfillable: usize,
    /// Per new vertex, in an order where parents come first: the vertices (boundary or new)
    /// its attribute values blend, with weights ([`crate::blend`]).
    pub blends: Vec<(u32, Vec<(u32, f64)>)>,
}

/// Fills the holes of the mesh `positions` / `triangles` (compact, as a run starts).
pub fn fill_holes(positions: &[f32], triangles: &[u32], settings: Settings) -> Filling {
    let vertex_count = positions.len() / 3;
    let half_edges = HalfEdges::new(vertex_count, triangles);
    let mut filling = Filling::default();
    let mut holes = Vec::new();
    for lp in boundary_loops(triangles, &half_edges) {
        if !is_simple(&lp) {
            filling.non_manifold += 1;
        } else if lp.len() > settings.max_hole_edges {
            filling.too_large += 1;
        } else {
            holes.push(lp);
        }
    }
    let rim_vertices = holes.iter().flat_map(|h| h.vertices.iter().copied());
    let mut surroundings = Surroundings::new(positions, triangles, &half_edges, rim_vertices);
    for hole in &holes {
        let rim_normals: Vec<Vec3> = hole
            .half_edges
            .iter()
            .map(|&h| {
                triangle_unit_normal(positions, triangles, triangle_of(h)).unwrap_or([0.0; 3])
            })
            .collect();
        let next_id = (vertex_count + filling.new_positions.len() / 3) as u32;
        match fill_one(positions, hole, &rim_normals, &surroundings, settings) {
            Some(patch) => {
                filling.filled += 1;
                append(&mut filling, &mut surroundings, hole, &patch, next_id);
            }
            None => filling.unfillable += 1,
        }
    }
    filling
}

/// A loop that can be filled by a disc: closed, consistently oriented, every vertex once.
fn is_simple(lp: &BoundaryLoop) -> bool {
    let mut sorted = lp.vertices.clone();
    sorted.sort_unstable();
    lp.closed && lp.consistent && lp.len() >= 3 && sorted.windows(2).all(|w| w[0] != w[1])
}

/// Triangulates, refines and fairs one hole; `None` if it cannot be triangulated.
fn fill_one(
    positions: &[f32],
    hole: &BoundaryLoop,
    rim_normals: &[Vec3],
    surroundings: &Surroundings,
    settings: Settings,
) -> Option<Patch> {
    let ids = &hole.vertices;
    let points: Vec<Vec3> = ids.iter().map(|&v| point(positions, v)).collect();
    if points.iter().flatten().any(|c| !c.is_finite()) {
        return None;
    }
    let polygon = Polygon { points: &points, rim_normals };
    let tris = triangulate(&polygon, |i, k| surroundings.has_edge(ids[i], ids[k]))?;
    let n = ids.len();
    // A vertex without usable incident edges takes the mean loop edge length as its scale.
    let mean_edge =
        (0..n).map(|i| distance(points[i], points[(i + 1) % n])).sum::<f64>() / n as f64;
    let sigma = ids
        .iter()
        .map(|&v| match surroundings.scale(v) {
            s if s > 0.0 && s.is_finite() => s,
            _ => mean_edge,
        })
        .collect();
    let mut patch = Patch::new(points, sigma, tris);
    if settings.refine {
        // Far more than a round hole at the surrounding density needs (≈ 0.2 n²); bounds the
        // work where the surroundings are much denser than the hole's own edges.
        let max_triangles = 8 * n * n + 1024;
        let is_forbidden = |a: u32, b: u32| {
            (a as usize) < n
                && (b as usize) < n
                && surroundings.has_edge(ids[a as usize], ids[b as usize])
        };
        refine(&mut patch, max_triangles, is_forbidden);
    }
    if settings.fairing_iterations > 0 {
        let rings: Vec<Ring> = ids.iter().map(|&v| surroundings.ring(v)).collect();
        let mut faired = patch.points.clone();
        fair(&mut faired, &patch.triangles, &rings, settings.fairing_iterations);
        // Raw scans (non-finite or wildly distant neighbours, near-singular systems) can
        // throw the solve off: keep the refined positions unless all stay near the hole.
        let is_near = near_hole(&faired[..n]);
        if faired.iter().all(|&p| is_near(p)) {
            patch.points = faired;
        }
    }
    Some(patch)
}

/// Whether a point (as the `f32` it will be stored as) is finite and within the bounding
/// box of the loop `rim`, grown by the box's diagonal on every side.
fn near_hole(rim: &[Vec3]) -> impl Fn(Vec3) -> bool + use<> {
    let (mut lo, mut hi) = ([f64::MAX; 3], [f64::MIN; 3]);
    for q in rim {
        for k in 0..3 {
            (lo[k], hi[k]) = (smaller(lo[k], q[k]), larger(hi[k], q[k]));
        }
    }
    let margin = distance(lo, hi);
    move |p: Vec3| {
        (0..3)
            .all(|k| (p[k] as f32).is_finite() && p[k] >= lo[k] - margin && p[k] <= hi[k] + margin)
    }
}

/// Adds a filled patch to the result: its new vertices get ids from `first_new` on, and it
/// goes in [`Patch::walk_order`] (triangles and new vertices both).
fn append(
    filling: &mut Filling,
    surroundings: &mut Surroundings,
    hole: &BoundaryLoop,
    patch: &Patch,
    first_new: u32,
) {
    let rim_len = patch.rim_len() as u32;
    let (order, rank) = patch.walk_order();
    let global = |v: u32| match v.checked_sub(rim_len) {
        None => hole.vertices[v as usize],
        Some(new) => first_new + rank[new as usize],
    };
    let mut new_points = vec![[0.0f32; 3]; rank.len()];
    for (p, &r) in patch.points[patch.rim_len()..].iter().zip(&rank) {
        new_points[r as usize] = p.map(|c| c as f32);
    }
    filling.new_positions.extend(new_points.iter().flatten());
    filling.blends.extend(crate::blend::rim_first_blends(patch, global));
    for t in order.iter().map(|&t| &patch.triangles[t as usize]) {
        filling.new_triangles.extend(t.map(global));
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            if !patch.is_new(a) && !patch.is_new(b) {
                surroundings.add_edge(global(a), global(b));
            }
        }
    }
}
