//! The checks as they were computed before the host derived the connectivity: each built
//! its own edge buckets from the triangles. Kept for the tests, which hold the new ones to
//! exactly the same values on meshes with every kind of defect.

pub mod counts {
    use meshflow_plugin_sdk::topology::{EdgeBuckets, UnionFind, boundary_loops};

    /// The number of distinct undirected edges `{a, b}` of the proper triangles (three distinct
    /// in-range vertex ids); an edge shared by any number of triangles counts once. O(V + T).
    pub fn edge_count(vertex_count: usize, triangles: &[u32]) -> usize {
        let mut edges = 0;
        EdgeBuckets::new(vertex_count, triangles).for_each_edge(|_, _| edges += 1);
        edges
    }

    /// The number of edge-connected components of triangles: triangles sharing an edge (manifold
    /// or not, whatever their orientations) are connected; triangles touching only at a vertex
    /// are not. Unreferenced vertices form no component. O(V + T).
    pub fn component_count(vertex_count: usize, triangles: &[u32]) -> usize {
        UnionFind::edge_connected(vertex_count, triangles).sets()
    }

    /// The number of boundary loops (holes, the outer border of an open surface included); a
    /// closed surface has none. Loops are separated at bow-tie vertices, so two holes touching
    /// at a vertex count twice. O(V + T); the loop walk looks twins up in the edge buckets, as
    /// it visits only the boundary, rather than building every half-edge's twin.
    pub fn hole_count(vertex_count: usize, triangles: &[u32]) -> usize {
        boundary_loops(triangles, &EdgeBuckets::new(vertex_count, triangles)).len()
    }
}

pub mod topology {
    use meshflow_plugin_sdk::topology::{EdgeBuckets, HalfEdges, manifold};

    use crate::forest::ParityForest;

    /// Whether every triangle is proper and none duplicated, the mesh is edge-manifold (no edge
    /// has three or more triangles) and vertex-manifold (the triangles around every vertex form
    /// a single fan, so no bow-tie). O(V + T); twins are built only when every edge is manifold.
    pub fn is_manifold(vertex_count: usize, triangles: &[u32]) -> bool {
        if manifold::has_improper_triangles(vertex_count, triangles) {
            return false;
        }
        let edges = EdgeBuckets::new(vertex_count, triangles);
        let mut edge_manifold = true;
        edges.for_each_edge(|_, sides| edge_manifold &= sides.len() <= 2);
        if !edge_manifold {
            return false;
        }
        let half_edges = HalfEdges::from_buckets(&edges);
        !manifold::has_duplicate_triangles(triangles, &half_edges)
            && manifold::is_vertex_manifold(vertex_count, triangles, &half_edges)
    }

    /// Whether every interior (two-triangle) edge is traversed in opposite directions by its two
    /// triangles. Boundary and non-manifold edges impose nothing. O(V + T).
    pub fn is_oriented(vertex_count: usize, triangles: &[u32]) -> bool {
        oriented(&EdgeBuckets::new(vertex_count, triangles))
    }

    fn oriented(edges: &EdgeBuckets) -> bool {
        let mut oriented = true;
        edges.for_each_edge(|a, sides| {
            if let [x, y] = sides {
                oriented &= edges.runs_up(a, *x) != edges.runs_up(a, *y);
            }
        });
        oriented
    }

    /// Whether flipping some triangles would make the mesh oriented (false for a Möbius strip).
    /// O(V + T); an oriented mesh is its own witness, so the union-find runs only on others.
    pub fn is_orientable(vertex_count: usize, triangles: &[u32]) -> bool {
        let edges = EdgeBuckets::new(vertex_count, triangles);
        if oriented(&edges) {
            return true;
        }
        // Two triangles running along their edge the same way must end up flipped relative to
        // each other (parity 1); a cycle of constraints with odd parity cannot be met.
        let mut forest = ParityForest::new(triangles.len() / 3);
        let mut orientable = true;
        edges.for_each_edge(|a, sides| {
            if orientable && let [x, y] = sides {
                let relation = (edges.runs_up(a, *x) == edges.runs_up(a, *y)) as u8;
                orientable = forest.union(x.triangle(), y.triangle(), relation);
            }
        });
        orientable
    }
}

pub mod normals {
    use meshflow_plugin_sdk::geometry::{
        Vec3, angle_between, dot, normalize, sub, triangle_normal,
    };
    use meshflow_plugin_sdk::topology::{EdgeBuckets, is_proper_triangle};

    /// The mean angle in degrees between the normals of the two triangles of each interior
    /// manifold edge (an edge with exactly two triangles), or 0 if there is no such edge.
    ///
    /// Normals are taken as the triangles are stored, so the check sees orientation defects: a
    /// flipped triangle contributes about 180° on its edges to consistently oriented neighbours,
    /// and the seam of a non-orientable strip does too. Edges next to a zero-area triangle are
    /// skipped (it has no normal). Each triangle's unit normal is computed once in `f64` (rather
    /// than for each of its three edges: the 24 bytes per triangle cost less), and each angle
    /// without `atan2` where possible, to about 1e-15 relative (see [`small_angles_sum`]). The
    /// sum is `f64` in a fixed order (ascending edges, small angles in batches), so the result is
    /// deterministic. O(V + T).
    pub fn normal_instability(positions: &[f32], triangles: &[u32]) -> f64 {
        let normals = unit_normals(positions, triangles);
        let (mut sum, mut edges) = (0.0f64, 0u64);
        // Small angles wait in a batch and are summed by a loop the compiler vectorises.
        let mut small = Vec::with_capacity(BATCH);
        EdgeBuckets::new(positions.len() / 3, triangles).for_each_edge(|_, sides| {
            if let [x, y] = sides {
                let (u, v) = (normals[x.triangle() as usize], normals[y.triangle() as usize]);
                if !u[0].is_nan() && !v[0].is_nan() {
                    let d = sub(u, v);
                    let half_chord_squared = 0.25 * dot(d, d);
                    if half_chord_squared <= SERIES_LIMIT {
                        small.push(half_chord_squared);
                        if small.len() == BATCH {
                            sum += small_angles_sum(&small);
                            small.clear();
                        }
                    } else {
                        sum += angle_between(u, v);
                    }
                    edges += 1;
                }
            }
        });
        sum += small_angles_sum(&small);
        if edges == 0 { 0.0 } else { (sum / edges as f64).to_degrees() }
    }

    /// Small angles summed per batch.
    const BATCH: usize = 1024;

    /// The unit normal of every triangle, or NaNs where it has none: an improper triangle (never
    /// on an edge of [`EdgeBuckets::new`]), zero area, or a non-finite corner.
    fn unit_normals(positions: &[f32], triangles: &[u32]) -> Vec<Vec3> {
        let vertex_count = positions.len() / 3;
        (0..triangles.len() as u32 / 3)
            .map(|t| {
                is_proper_triangle(triangles, vertex_count, t)
                    .then(|| normalize(triangle_normal(positions, triangles, t)))
                    .flatten()
                    .unwrap_or([f64::NAN; 3])
            })
            .collect()
    }

    /// `asin(s) / s` as a polynomial in `s²`: the Taylor coefficients
    /// `(2k)! / (4^k (k!)² (2k + 1))`, enough of them for a truncation error below 1e-16
    /// relative when `s ≤ 1/8`.
    const ASIN_SERIES: [f64; 8] = [
        1.0,
        1.0 / 6.0,
        3.0 / 40.0,
        5.0 / 112.0,
        35.0 / 1152.0,
        63.0 / 2816.0,
        231.0 / 13312.0,
        143.0 / 10240.0,
    ];

    /// Half chords `s` up to this squared (`s ≤ 1/8`, angles up to about 14°) take the series.
    const SERIES_LIMIT: f64 = 1.0 / 64.0;

    /// The sum of the angles whose squared half chords are `half_chords_squared` (each at most
    /// [`SERIES_LIMIT`]), in two lanes so it vectorises; deterministic for a given order.
    ///
    /// Neighbouring normals of a scan mostly differ by a few degrees, where `atan2` (software in
    /// wasm) dominated the check. Half the chord `s = |u - v| / 2` between unit normals is
    /// `sin(θ / 2)`, and for `s ≤ 1/8` the `asin` series gives `θ` from it with only
    /// multiplications (accurate also for tiny angles, unlike `acos` of the dot product).
    fn small_angles_sum(half_chords_squared: &[f64]) -> f64 {
        let angle = |x: f64| {
            // Estrin's scheme: short dependency chains, the terms evaluate in parallel.
            let c = ASIN_SERIES;
            let x2 = x * x;
            let low = (c[0] + c[1] * x) + x2 * (c[2] + c[3] * x);
            let high = (c[4] + c[5] * x) + x2 * (c[6] + c[7] * x);
            2.0 * x.sqrt() * (low + x2 * x2 * high)
        };
        let mut lanes = [0.0f64; 2];
        let pairs = half_chords_squared.chunks_exact(2);
        let rest = pairs.remainder();
        for pair in pairs {
            lanes[0] += angle(pair[0]);
            lanes[1] += angle(pair[1]);
        }
        lanes[0] + lanes[1] + rest.iter().map(|&x| angle(x)).sum::<f64>()
    }
}
