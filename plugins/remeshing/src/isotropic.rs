//! Isotropic remeshing (Botsch & Kobbelt 2004): per iteration, split edges longer than
//! 4/3 of the target length, collapse edges shorter than 4/5 of it, flip edges toward
//! valence 6 (4 on the boundary), relax vertices tangentially and project them back onto
//! the input surface.
//!
//! Feature edges (dihedral angle above the threshold), boundary edges and inconsistently
//! oriented edges are kept: never flipped or collapsed, only split along themselves; their
//! vertices do not move. Vertices where fans meet are held too.
//!
//! Every split, collapse and flip is applied locally with the host store's exact id rules
//! (host/mesh/src/store/edges.rs) and recorded, so the edits replay on the host with the
//! same ids; the final positions follow as one move of all vertices. The work is done in
//! spatially ordered ids ([`crate::renumber`]), translated back to the host's at the end.

use std::collections::HashSet;
use std::fmt;

use meshflow_plugin_sdk::geometry::{
    Vec3, add, angle_between, cross, dot, norm, point, scale, sub,
};
use meshflow_plugin_sdk::topology::halfedge::{EdgeKind, HalfEdges, origin, target};
use meshflow_plugin_sdk::topology::manifold::non_manifold_vertices;

use crate::closest::Surface;
use crate::input::{InputDefect, manifold_edges};
use crate::local::{LocalMesh, edge};
use crate::renumber::Renumbering;

/// Split passes per iteration at most: each halves the longest edges, so a coarse input
/// reaches the target within a few.
const MAX_SPLIT_PASSES: usize = 8;
/// A flip or collapse is refused if a triangle's normal would turn by more than this
/// (its dot product with the old unit normal falling below it).
const MIN_NORMAL_COS: f64 = 0.5;
/// The most vertices remeshing may create, relative to the input's triangles.
pub const MAX_GROWTH: usize = 64;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// The edge length to reach.
    pub target_length: f64,
    pub iterations: u32,
    /// Edges whose triangles' normals differ by more than this many degrees are features.
    pub feature_angle_degrees: f64,
}

/// One recorded edit, in the host's vocabulary.
#[derive(Clone, Debug, PartialEq)]
pub enum Edit {
    SplitEdge { edge: u32, at: [f32; 3] },
    CollapseEdge { edge: u32 },
    SwapEdge { edge: u32 },
}

/// Why a mesh cannot be remeshed.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Refusal {
    Input(InputDefect),
    TooFine { vertices: usize },
}

impl fmt::Display for Refusal {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Refusal::Input(defect) => defect.fmt(f),
            Refusal::TooFine { vertices } => write!(
                f,
                "the target edge length would need about {vertices} vertices, more than \
                 {MAX_GROWTH}× the input's triangles; choose a longer one"
            ),
        }
    }
}

/// The edits, in order, and the final position of every vertex slot (`x y z` each).
#[derive(Clone, Debug, PartialEq)]
pub struct Remeshed {
    pub edits: Vec<Edit>,
    pub positions: Vec<f32>,
    pub splits: usize,
    pub collapses: usize,
    pub flips: usize,
}

/// Remeshes a mesh whose triangles are proper and edges have at most two triangles.
pub fn remesh(
    positions: &[f32],
    triangles: &[u32],
    settings: Settings,
) -> Result<Remeshed, Refusal> {
    let (ids, positions, triangles) = Renumbering::spatial(positions, triangles);
    remesh_working(ids, positions, triangles, settings)
}

/// [`remesh`] of arrays it may drop once it has its working copy: the guest then holds the
/// input once, not twice, while it works.
pub fn remesh_owned(
    positions: Vec<f32>,
    triangles: Vec<u32>,
    settings: Settings,
) -> Result<Remeshed, Refusal> {
    let (ids, work_positions, work_triangles) = Renumbering::spatial(&positions, &triangles);
    drop((positions, triangles));
    remesh_working(ids, work_positions, work_triangles, settings)
}

/// [`remesh`] in working ids; each array is dropped as soon as nothing needs it.
fn remesh_working(
    ids: Renumbering,
    positions: Vec<f32>,
    triangles: Vec<u32>,
    settings: Settings,
) -> Result<Remeshed, Refusal> {
    let n = positions.len() / 3;
    let half_edges = manifold_edges(n, &triangles).map_err(Refusal::Input)?;
    let area: f64 = triangles
        .chunks_exact(3)
        .map(|c| {
            0.5 * norm(cross(
                sub(point(&positions, c[1]), point(&positions, c[0])),
                sub(point(&positions, c[2]), point(&positions, c[0])),
            ))
        })
        .sum();
    // An equilateral triangle of side L has area √3/4 L², and there are about 2 per vertex.
    let needed = area / (3f64.sqrt() / 4.0 * settings.target_length.powi(2)) / 2.0;
    if needed > (MAX_GROWTH * (triangles.len() / 3)).max(1_000) as f64 {
        return Err(Refusal::TooFine { vertices: needed as usize });
    }

    let mut mesh =
        Local::new(&positions, &triangles, &half_edges, settings.feature_angle_degrees, ids);
    drop(half_edges);
    let corners: Vec<[u32; 3]> = triangles.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    drop(triangles);
    let surface = Surface::from_owned(positions, corners, settings.target_length);
    let long = 4.0 / 3.0 * settings.target_length;
    let short = 4.0 / 5.0 * settings.target_length;
    for _ in 0..settings.iterations {
        for _ in 0..MAX_SPLIT_PASSES {
            if mesh.split_long_edges(long) == 0 {
                break;
            }
        }
        mesh.collapse_short_edges(short, long);
        mesh.flip_toward_valence_six();
        mesh.relax_and_project(&surface);
    }
    drop(surface);
    let positions: Vec<f32> = mesh.pos.iter().flat_map(|p| p.map(|x| x as f32)).collect();
    let ids = &mesh.ids;
    let edits = mesh.edits.iter().map(|edit| match *edit {
        Edit::SplitEdge { edge, at } => Edit::SplitEdge { edge: ids.half_edge(edge), at },
        Edit::CollapseEdge { edge } => Edit::CollapseEdge { edge: ids.half_edge(edge) },
        Edit::SwapEdge { edge } => Edit::SwapEdge { edge: ids.half_edge(edge) },
    });
    Ok(Remeshed {
        edits: edits.collect(),
        positions: ids.positions_to_host(&positions),
        splits: mesh.splits,
        collapses: mesh.collapses,
        flips: mesh.flips,
    })
}

/// The mesh being remeshed, with the store's id rules, in working ids.
struct Local {
    pos: Vec<Vec3>,
    mesh: LocalMesh,
    ids: Renumbering,
    alive: Vec<bool>,
    /// Vertices that never move or disappear.
    fixed: Vec<bool>,
    /// Edges (smaller id first) that are never flipped or collapsed.
    features: HashSet<(u32, u32)>,
    edits: Vec<Edit>,
    splits: usize,
    collapses: usize,
    flips: usize,
}

impl Local {
    fn new(
        positions: &[f32],
        triangles: &[u32],
        half_edges: &HalfEdges,
        feature_angle: f64,
        ids: Renumbering,
    ) -> Self {
        let n = positions.len() / 3;
        let mesh = LocalMesh::new(n, triangles);
        let threshold = feature_angle.to_radians();
        let normal = |t: u32| {
            let c = mesh.corners(t).map(|v| point(positions, v));
            cross(sub(c[1], c[0]), sub(c[2], c[0]))
        };
        let mut features = HashSet::new();
        let mut fixed = vec![false; n];
        for h in 0..half_edges.len() as u32 {
            let key = edge(origin(triangles, h), target(triangles, h));
            let sharp = match half_edges.kind(h) {
                // Each interior edge once: from its lower half-edge.
                EdgeKind::Interior if half_edges.opposite(h) < h => continue,
                EdgeKind::Interior => {
                    let (n0, n1) = (normal(h / 3), normal(half_edges.opposite(h) / 3));
                    n0 != [0.0; 3] && n1 != [0.0; 3] && angle_between(n0, n1) > threshold
                }
                _ => true,
            };
            if sharp {
                features.insert(key);
                fixed[key.0 as usize] = true;
                fixed[key.1 as usize] = true;
            }
        }
        for v in non_manifold_vertices(n, triangles, half_edges) {
            fixed[v as usize] = true;
        }
        Local {
            pos: (0..n as u32).map(|v| point(positions, v)).collect(),
            mesh,
            ids,
            alive: vec![true; n],
            fixed,
            features,
            edits: Vec::new(),
            splits: 0,
            collapses: 0,
            flips: 0,
        }
    }

    /// Both ends of a feature edge are fixed, so most edges are told apart without a lookup.
    fn is_feature(&self, a: u32, b: u32) -> bool {
        self.fixed[a as usize] && self.fixed[b as usize] && self.features.contains(&edge(a, b))
    }

    fn length(&self, a: u32, b: u32) -> f64 {
        norm(sub(self.pos[a as usize], self.pos[b as usize]))
    }

    fn normal(&self, c: [u32; 3], moved: Option<(u32, Vec3)>) -> Vec3 {
        let p = c.map(|v| match moved {
            Some((m, at)) if m == v => at,
            _ => self.pos[v as usize],
        });
        cross(sub(p[1], p[0]), sub(p[2], p[0]))
    }

    // ---- split -------------------------------------------------------------------------------

    fn split_long_edges(&mut self, long: f64) -> usize {
        let mut count = 0;
        for (a, b) in self.mesh.edges() {
            if self.length(a, b) > long {
                self.split(a, b);
                count += 1;
            }
        }
        self.splits += count;
        count
    }

    /// Splits at the midpoint; halves of a feature edge stay features.
    fn split(&mut self, a: u32, b: u32) {
        let at =
            scale(add(self.pos[a as usize], self.pos[b as usize]), 0.5).map(|x| x as f32 as f64);
        let parents: Vec<u32> = self.mesh.on_edge(a, b).collect();
        let (h, v) = self.mesh.split(a, b);
        self.ids.split(&parents);
        self.pos.push(at);
        self.alive.push(true);
        let feature = self.is_feature(a, b);
        self.fixed.push(feature);
        if feature {
            self.features.remove(&edge(a, b));
            self.features.insert(edge(a, v));
            self.features.insert(edge(v, b));
        }
        self.edits.push(Edit::SplitEdge { edge: h, at: at.map(|x| x as f32) });
    }

    // ---- collapse ----------------------------------------------------------------------------

    fn collapse_short_edges(&mut self, short: f64, long: f64) {
        for (a, b) in self.mesh.edges() {
            if !(self.alive[a as usize] && self.alive[b as usize]) || self.length(a, b) >= short {
                continue;
            }
            if let Some((h, at)) = self.collapsible(a, b, long) {
                self.collapse(h, at);
            }
        }
    }

    /// The half-edge to collapse (its start survives) and where the survivor goes.
    fn collapsible(&self, a: u32, b: u32, long: f64) -> Option<(u32, Vec3)> {
        // A feature edge has both ends fixed, refused just below.
        let (keep, remove, at) = match (self.fixed[a as usize], self.fixed[b as usize]) {
            (true, true) => return None,
            (true, false) => (a, b, self.pos[a as usize]),
            (false, true) => (b, a, self.pos[b as usize]),
            (false, false) => {
                let mid = scale(add(self.pos[a as usize], self.pos[b as usize]), 0.5);
                (a, b, mid.map(|x| x as f32 as f64))
            }
        };
        if self.mesh.collapse_keeps_topology(a, b)?.count() != 2 {
            return None;
        }
        // No new edge may be long, and no triangle may fold.
        for v in [a, b] {
            for &t in self.mesh.around(v) {
                if self
                    .mesh
                    .corners(t)
                    .into_iter()
                    .any(|w| norm(sub(self.pos[w as usize], at)) > long)
                {
                    return None;
                }
            }
        }
        for v in [a, b] {
            for &t in self.mesh.around(v) {
                let c = self.mesh.corners(t);
                if c.contains(&a) && c.contains(&b) {
                    continue;
                }
                let old = self.normal(c, None);
                let new =
                    self.normal(c.map(|w| if w == remove { keep } else { w }), Some((keep, at)));
                if !turns_little(old, new) {
                    return None;
                }
            }
        }
        Some((self.mesh.half_edge(keep, remove)?, at))
    }

    fn collapse(&mut self, h: u32, at: Vec3) {
        let (s, r, _) = self.mesh.collapse(h);
        self.pos[s as usize] = at;
        self.alive[r as usize] = false;
        self.collapses += 1;
        self.edits.push(Edit::CollapseEdge { edge: h });
    }

    // ---- flip --------------------------------------------------------------------------------

    fn flip_toward_valence_six(&mut self) {
        let mut valence: Vec<i32> =
            (0..self.pos.len() as u32).map(|v| self.mesh.valence(v) as i32).collect();
        let ideal: Vec<i32> = (0..self.pos.len() as u32)
            .map(|v| if self.mesh.is_boundary(v) { 4 } else { 6 })
            .collect();
        for (a, b) in self.mesh.edges() {
            if self.is_feature(a, b) {
                continue;
            }
            if self.mesh.on_edge(a, b).count() != 2 {
                continue;
            }
            let (Some(h), Some(g)) = (self.mesh.half_edge(a, b), self.mesh.half_edge(b, a)) else {
                continue;
            };
            let (t, u) = (h / 3, g / 3);
            let c = self.mesh.corners(t).into_iter().find(|&v| v != a && v != b).expect("an apex");
            let d = self.mesh.corners(u).into_iter().find(|&v| v != a && v != b).expect("an apex");
            if c == d || self.mesh.half_edge(c, d).is_some() || self.mesh.half_edge(d, c).is_some()
            {
                continue;
            }
            let deviation =
                |v: u32, delta: i32| (valence[v as usize] + delta - ideal[v as usize]).abs();
            let before = deviation(a, 0) + deviation(b, 0) + deviation(c, 0) + deviation(d, 0);
            let after = deviation(a, -1) + deviation(b, -1) + deviation(c, 1) + deviation(d, 1);
            if after >= before {
                continue;
            }
            // The store's swap: (a, b, c) and (b, a, d) become (a, d, c) and (b, c, d).
            let (old_t, old_u) =
                (self.normal(self.mesh.corners(t), None), self.normal(self.mesh.corners(u), None));
            let (new_t, new_u) = (self.normal([a, d, c], None), self.normal([b, c, d], None));
            let reference = add(old_t, old_u);
            if !turns_little(reference, new_t) || !turns_little(reference, new_u) {
                continue;
            }
            self.mesh.swap(h, u);
            for (v, delta) in [(a, -1), (b, -1), (c, 1), (d, 1)] {
                valence[v as usize] += delta;
            }
            self.flips += 1;
            self.edits.push(Edit::SwapEdge { edge: h });
        }
    }

    // ---- smooth ------------------------------------------------------------------------------

    fn relax_and_project(&mut self, surface: &Surface) {
        let mut moved = self.pos.clone();
        for v in 0..self.pos.len() as u32 {
            if !self.alive[v as usize] || self.fixed[v as usize] || self.mesh.around(v).is_empty() {
                continue;
            }
            // A moving vertex is inside a closed fan, so each neighbour is the other corner
            // of exactly two of its triangles: summing over triangles weighs all alike.
            let around = self.mesh.around(v);
            let sum = around
                .iter()
                .flat_map(|&t| self.mesh.corners(t))
                .filter(|&w| w != v)
                .fold([0.0; 3], |s, w| add(s, self.pos[w as usize]));
            let centroid = scale(sum, 1.0 / (2 * around.len()) as f64);
            let normal = self
                .mesh
                .around(v)
                .iter()
                .fold([0.0; 3], |s, &t| add(s, self.normal(self.mesh.corners(t), None)));
            let p = self.pos[v as usize];
            let step = sub(centroid, p);
            let tangential = match unit(normal) {
                Some(n) => sub(step, scale(n, dot(step, n))),
                None => step,
            };
            let relaxed = add(p, tangential);
            let projected = surface.closest(relaxed).unwrap_or(relaxed);
            moved[v as usize] = projected.map(|x| x as f32 as f64);
        }
        self.pos = moved;
    }
}

fn unit(v: Vec3) -> Option<Vec3> {
    let l = norm(v);
    (l > 0.0).then(|| scale(v, 1.0 / l))
}

/// Whether a triangle with normal `old` may take normal `new` (not flat, not folded).
fn turns_little(old: Vec3, new: Vec3) -> bool {
    let (lo, ln) = (norm(old), norm(new));
    if lo == 0.0 {
        return true;
    }
    ln > 0.0 && dot(old, new) >= MIN_NORMAL_COS * lo * ln
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fixtures::replay;
    use meshflow_plugin_sdk::geometry::corner_angles_degrees;
    use meshflow_plugin_sdk::topology::NONE;
    use meshflow_plugin_sdk::topology::manifold::{is_manifold, is_oriented};
    use meshflow_plugin_sdk::topology::shapes::uv_sphere;

    /// Edge lengths within ±25 % for 95 %, min angle ≥ 25° for 99 %, all vertices within
    /// `tolerance` of the input surface.
    fn assert_isotropic(p0: &[f32], t0: &[u32], p: &[f32], t: &[u32], length: f64, tolerance: f64) {
        let he = HalfEdges::new(p.len() / 3, t);
        assert!(is_manifold(p.len() / 3, t, &he) && is_oriented(&he));
        let lengths: Vec<f64> = (0..t.len() as u32)
            .filter(|&h| he.opposite(h) == NONE || he.opposite(h) > h)
            .map(|h| norm(sub(point(p, origin(t, h)), point(p, target(t, h)))))
            .collect();
        let within = lengths.iter().filter(|&&l| (l - length).abs() <= 0.25 * length).count();
        assert!(
            within as f64 >= 0.95 * lengths.len() as f64,
            "{within} of {} edges within ±25 %",
            lengths.len()
        );
        let tris = t.len() / 3;
        let good = (0..tris as u32)
            .filter(|&i| corner_angles_degrees(p, t, i).iter().all(|&a| a >= 25.0))
            .count();
        assert!(
            good as f64 >= 0.99 * tris as f64,
            "{good} of {tris} triangles with every angle ≥ 25°"
        );
        for v in 0..p.len() as u32 / 3 {
            let q = point(p, v);
            let d = t0
                .chunks_exact(3)
                .map(|c| {
                    norm(sub(
                        q,
                        meshflow_plugin_sdk::geometry::closest_point_on_triangle(
                            q,
                            [c[0], c[1], c[2]].map(|w| point(p0, w)),
                        ),
                    ))
                })
                .fold(f64::INFINITY, f64::min);
            assert!(d <= tolerance, "vertex {v} is {d} from the input");
        }
    }

    #[test]
    fn a_sphere_becomes_isotropic_at_the_target_length() {
        let (p, t) = uv_sphere(16, 24);
        let settings =
            Settings { target_length: 0.12, iterations: 10, feature_angle_degrees: 60.0 };
        let r = remesh(&p, &t, settings).unwrap();
        assert!(r.splits > 0 && r.collapses > 0 && r.flips > 0);
        let (p2, t2) = replay(p.len() / 3, &t, &r.edits, &r.positions);
        // Closed genus 0 still.
        assert_eq!(t2.len() / 3, 2 * (p2.len() / 3) - 4);
        assert_isotropic(&p, &t, &p2, &t2, 0.12, 0.01 * 2.0 * 3f64.sqrt());
    }

    #[test]
    fn a_cube_keeps_its_sharp_edges_and_corners() {
        // A unit cube of 4×4 quads per face: split into triangles, shared vertices welded.
        let n = 4;
        let mut positions: Vec<f32> = Vec::new();
        let mut index = std::collections::HashMap::new();
        let mut triangles = Vec::new();
        let mut vertex = |p: [i32; 3], positions: &mut Vec<f32>| {
            *index.entry(p).or_insert_with(|| {
                positions.extend(p.map(|x| x as f32 / n as f32));
                (positions.len() / 3 - 1) as u32
            })
        };
        for axis in 0..3 {
            for side in [0, n] {
                for i in 0..n {
                    for j in 0..n {
                        let at = |di: i32, dj: i32| {
                            let mut p = [0; 3];
                            p[axis] = side;
                            p[(axis + 1) % 3] = i + di;
                            p[(axis + 2) % 3] = j + dj;
                            p
                        };
                        let q = [at(0, 0), at(1, 0), at(1, 1), at(0, 1)]
                            .map(|p| vertex(p, &mut positions));
                        if side == n {
                            triangles.extend([q[0], q[1], q[2], q[0], q[2], q[3]]);
                        } else {
                            triangles.extend([q[0], q[2], q[1], q[0], q[3], q[2]]);
                        }
                    }
                }
            }
        }
        let settings = Settings { target_length: 0.1, iterations: 5, feature_angle_degrees: 45.0 };
        let r = remesh(&positions, &triangles, settings).unwrap();
        let (p2, t2) = replay(positions.len() / 3, &triangles, &r.edits, &r.positions);
        let he = HalfEdges::new(p2.len() / 3, &t2);
        assert!(is_manifold(p2.len() / 3, &t2, &he) && is_oriented(&he));
        // Every vertex stays on the cube's surface, the eight corners included.
        for v in p2.chunks(3) {
            let on_face = v.iter().any(|&x| x == 0.0 || x == 1.0);
            let inside = v.iter().all(|&x| (0.0..=1.0).contains(&x));
            assert!(on_face && inside, "{v:?}");
        }
        let corners = p2.chunks(3).filter(|v| v.iter().all(|&x| x == 0.0 || x == 1.0)).count();
        assert_eq!(corners, 8);
    }

    #[test]
    fn bad_input_is_refused_by_name() {
        let p = vec![0.0; 15];
        let fin = vec![0, 1, 2, 1, 0, 3, 0, 1, 4];
        let s = Settings { target_length: 1.0, iterations: 1, feature_angle_degrees: 45.0 };
        assert_eq!(remesh(&p, &fin, s), Err(Refusal::Input(InputDefect::NonManifoldEdges(1))));
        assert_eq!(
            remesh(&p, &[0, 0, 1], s),
            Err(Refusal::Input(InputDefect::ImproperTriangles(1)))
        );
        let (p, t) = uv_sphere(8, 8);
        let tiny = Settings { target_length: 1e-5, ..s };
        assert!(matches!(remesh(&p, &t, tiny), Err(Refusal::TooFine { .. })));
    }
}
