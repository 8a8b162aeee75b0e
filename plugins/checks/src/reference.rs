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
    use meshflow_plugin_sdk::topology::EdgeBuckets;

    use crate::normals::{AngleSum, unit_normals};

    /// The mean angle in degrees between the normals of the two triangles of each interior
    /// manifold edge, the edges enumerated by the plugin's own [`EdgeBuckets`] (ascending
    /// edges) rather than the host's connectivity; the angle arithmetic is the check's own.
    pub fn normal_instability(positions: &[f32], triangles: &[u32]) -> f64 {
        let normals = unit_normals(positions, triangles);
        let mut angles = AngleSum::default();
        EdgeBuckets::new(positions.len() / 3, triangles).for_each_edge(|_, sides| {
            if let [x, y] = sides {
                angles.add(normals[x.triangle() as usize], normals[y.triangle() as usize]);
            }
        });
        angles.mean_degrees()
    }
}
