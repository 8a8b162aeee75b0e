//! Hand-built meshes with known answers for the topology and geometry helpers.

use meshflow_topology::geometry::{self, Vec3};
use meshflow_topology::shapes::{square_grid, unit_cube};
use meshflow_topology::{
    self, EdgeKind, HalfEdges, NONE, TriangleComponents, VertexNeighbours, VertexTriangles,
    boundary_loops, boundary_vertices, has_duplicate_triangles, has_improper_triangles,
    is_edge_manifold, is_manifold, is_orientable, is_oriented, is_vertex_manifold,
    non_manifold_vertices, orientation_flips, unreferenced_vertices,
};

/// Everything the checks report about a mesh.
#[derive(Debug, PartialEq)]
struct Report {
    edges: usize,
    loops: Vec<usize>,
    components: usize,
    edge_manifold: bool,
    vertex_manifold: bool,
    oriented: bool,
    orientable: bool,
}

fn report(vertex_count: usize, t: &[u32]) -> Report {
    let he = HalfEdges::new(vertex_count, t);
    check_twins(&he);
    let loops = boundary_loops(t, &he);
    assert!(loops.iter().all(|l| l.closed), "open loop in {loops:?}");
    Report {
        edges: he.edge_count(),
        loops: loops.iter().map(|l| l.len()).collect(),
        components: TriangleComponents::new(vertex_count, t).count(),
        edge_manifold: is_edge_manifold(&he),
        vertex_manifold: is_vertex_manifold(vertex_count, t, &he),
        oriented: is_oriented(&he),
        orientable: is_orientable(&he),
    }
}

fn check_twins(he: &HalfEdges) {
    for h in 0..he.len() as u32 {
        let o = he.opposite(h);
        assert_eq!(o != NONE, he.kind(h).is_interior());
        if o != NONE {
            assert_eq!(he.opposite(o), h);
            assert_eq!(he.kind(o), he.kind(h));
        }
    }
}

fn rep(edges: usize, loops: &[usize], components: usize, flags: [bool; 4]) -> Report {
    Report {
        edges,
        loops: loops.to_vec(),
        components,
        edge_manifold: flags[0],
        vertex_manifold: flags[1],
        oriented: flags[2],
        orientable: flags[3],
    }
}

const ALL: [bool; 4] = [true; 4];

/// A grid of `n × n` unit quads in the xy plane, vertex `x + (n + 1) y`, two CCW triangles
/// per quad, leaving out the quads in `holes` (given as `(x, y)`).
fn grid(n: u32, holes: &[(u32, u32)]) -> (Vec<f32>, Vec<u32>) {
    let (p, t) = square_grid(n);
    // Square `x + n y` is triangles 2 (x + n y) and the next.
    let kept = t.chunks_exact(6).enumerate().filter(|(s, _)| {
        let (x, y) = (*s as u32 % n, *s as u32 / n);
        !holes.contains(&(x, y))
    });
    (p, kept.flat_map(|(_, quad)| quad.iter().copied()).collect())
}

/// A Möbius strip of `n` quads: top vertices 0..n, bottom n..2n, the last quad glued with a
/// half twist.
fn moebius(n: u32) -> Vec<u32> {
    let mut t = Vec::new();
    for i in 0..n {
        let (p0, q0) = (i, n + i);
        let (p1, q1) = if i + 1 < n { (i + 1, n + i + 1) } else { (n, 0) };
        t.extend([q0, q1, p1, q0, p1, p0]);
    }
    t
}

/// `loop_vertices` equals `expected` up to rotation.
fn same_cycle(loop_vertices: &[u32], expected: &[u32]) -> bool {
    let n = expected.len();
    loop_vertices.len() == n
        && (0..n).any(|r| (0..n).all(|i| loop_vertices[i] == expected[(i + r) % n]))
}

#[test]
fn single_triangle() {
    let t = [0, 1, 2];
    assert_eq!(report(3, &t), rep(3, &[3], 1, ALL));
    let he = HalfEdges::new(3, &t);
    assert_eq!(he.kinds(), [EdgeKind::Boundary; 3]);
    assert_eq!(boundary_loops(&t, &he)[0].half_edges, [0, 1, 2]);
    assert_eq!(VertexNeighbours::new(3, &t).of(1), [0, 2]);
}

#[test]
fn two_triangles_sharing_an_edge() {
    let t = [0, 1, 2, 2, 1, 3];
    assert_eq!(report(4, &t), rep(5, &[4], 1, ALL));
    let he = HalfEdges::new(4, &t);
    assert_eq!((he.opposite(1), he.kind(1)), (3, EdgeKind::Interior));
    let l = &boundary_loops(&t, &he)[0];
    assert_eq!(l.half_edges, [0, 4, 5, 2]);
    assert_eq!(l.vertices, [0, 1, 3, 2]);
    assert!(l.consistent);
    // Reversing the second triangle makes the shared edge inconsistent.
    let f = [0, 1, 2, 1, 2, 3];
    assert_eq!(report(4, &f), rep(5, &[4], 1, [true, true, false, true]));
    let hf = HalfEdges::new(4, &f);
    assert_eq!(hf.kind(1), EdgeKind::InteriorInconsistent);
    assert_eq!(hf.inconsistent_edge_count(), 1);
    assert_eq!(orientation_flips(&hf), Some(vec![false, true]));
    assert!(!boundary_loops(&f, &hf)[0].consistent);
}

#[test]
fn tetrahedron() {
    let t = [0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
    assert_eq!(report(4, &t), rep(6, &[], 1, ALL));
    let he = HalfEdges::new(4, &t);
    assert!(he.is_closed() && is_manifold(4, &t, &he));
    assert_eq!(he.interior_edge_count(), 6);
    assert_eq!(VertexTriangles::new(4, &t).of(3), [1, 2, 3]);
    assert_eq!(VertexNeighbours::new(4, &t).of(3), [0, 1, 2]);
}

#[test]
fn cube() {
    let (p, t) = unit_cube();
    assert_eq!(report(8, &t), rep(18, &[], 1, ALL));
    let he = HalfEdges::new(8, &t);
    assert_eq!(orientation_flips(&he), Some(vec![false; 12]));
    // Geometry: outward normals, area 6, corner normals along the diagonals.
    assert_eq!(geometry::triangle_normal(&p, &t, 0), [0., 0., -1.]);
    assert_eq!(geometry::total_area(&p, &t), 6.0);
    let n = geometry::vertex_normals(&p, &t);
    let s = 1.0 / 3f32.sqrt();
    assert!((n[7][0] - s).abs() < 1e-6 && (n[7][1] - s).abs() < 1e-6);
    assert!((n[0][2] + s).abs() < 1e-6);
    let bb = geometry::bounding_box(&p).unwrap();
    assert!((bb.diagonal() - 3f64.sqrt()).abs() < 1e-12);
    assert_eq!(geometry::surface_centroid(&p, &t), Some([0.5; 3]));
    for h in 0..36 {
        let d = geometry::dihedral_angle(&p, &t, &he, h).unwrap();
        // Across a face diagonal: flat; across a cube edge: 90°.
        assert!(d.abs() < 1e-12 || (d - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let a = geometry::corner_angles_degrees(&p, &t, h / 3);
        assert!(a.iter().all(|&x| (x - 45.0).abs() < 1e-9 || (x - 90.0).abs() < 1e-9));
    }
    // Cotangent weight of a face diagonal (opposite two right angles) is 0, of a cube edge
    // (opposite two 45° angles) is 1.
    assert!(geometry::cotangent_weight(&p, &t, &he, 2).abs() < 1e-12); // 3 -> 0
    assert!((geometry::cotangent_weight(&p, &t, &he, 0) - 1.0).abs() < 1e-12); // 0 -> 2
    let vn = VertexNeighbours::new(8, &t);
    let w = geometry::cotangent_weights(&p, &t, &vn);
    // Vertex 0's neighbours: 1, 2, 4 along cube edges (weight 1), 3, 5, 6 across faces (0).
    assert_eq!(vn.of(0), [1, 2, 3, 4, 5, 6]);
    let row = &w[vn.offsets()[0] as usize..vn.offsets()[1] as usize];
    let expect = [1.0, 1.0, 0.0, 1.0, 0.0, 0.0];
    assert!(row.iter().zip(expect).all(|(x, e)| (x - e).abs() < 1e-6), "{row:?}");
}

#[test]
fn cube_with_one_flipped_triangle() {
    let (_, mut t) = unit_cube();
    t.swap(4, 5); // triangle 1: (0, 3, 1) -> (0, 1, 3)
    assert_eq!(report(8, &t), rep(18, &[], 1, [true, true, false, true]));
    let he = HalfEdges::new(8, &t);
    assert_eq!(he.inconsistent_edge_count(), 3);
    let flips = orientation_flips(&he).unwrap();
    assert_eq!(flips.iter().filter(|&&f| f).count(), 1);
    assert!(flips[1]);
}

#[test]
fn moebius_strip() {
    let t = moebius(5);
    let r = report(10, &t);
    assert_eq!(r, rep(4 * 5, &[10], 1, [true, true, false, false]));
    let he = HalfEdges::new(10, &t);
    assert_eq!(orientation_flips(&he), None);
    let l = &boundary_loops(&t, &he)[0];
    // The single boundary curve passes every vertex once.
    let mut v = l.vertices.clone();
    v.sort();
    assert_eq!(v, (0..10).collect::<Vec<_>>());
    // A plain (untwisted) band of the same size is orientable with two loops.
    let mut band = Vec::new();
    for i in 0..5u32 {
        let (p0, q0, p1, q1) = (i, 5 + i, (i + 1) % 5, 5 + (i + 1) % 5);
        band.extend([q0, q1, p1, q0, p1, p0]);
    }
    assert_eq!(report(10, &band), rep(20, &[5, 5], 1, ALL));
}

#[test]
fn two_sheets_sharing_an_edge() {
    // Three triangles on edge 0-1.
    let t = [0, 1, 2, 1, 0, 3, 0, 1, 4];
    let he = HalfEdges::new(5, &t);
    assert!(!is_edge_manifold(&he));
    assert_eq!(he.non_manifold_edge_count(), 1);
    assert_eq!(he.non_manifold_edges().row(0), [0, 3, 6]);
    assert_eq!([he.opposite(0), he.opposite(3), he.opposite(6)], [NONE; 3]);
    assert_eq!(he.kind(3), EdgeKind::NonManifold);
    assert_eq!(he.edge_count(), 7);
    assert_eq!(non_manifold_vertices(5, &t, &he), [0, 1]);
    assert!(!is_manifold(5, &t, &he));
    assert!(is_oriented(&he) && is_orientable(&he));
    assert_eq!(TriangleComponents::new(5, &t).count(), 1);
    // Boundary: six boundary edges, odd at vertices 0 and 1, so one loop closes and the rest
    // is an open chain; each boundary half-edge appears exactly once.
    let loops = boundary_loops(&t, &he);
    let mut all: Vec<u32> = loops.iter().flat_map(|l| l.half_edges.clone()).collect();
    all.sort();
    assert_eq!(all, [1, 2, 4, 5, 7, 8]);
    assert_eq!(loops[0].half_edges, [1, 2, 4, 5]);
    assert!(loops[0].closed);
    assert_eq!(loops[1].half_edges, [7, 8]);
    assert!(!loops[1].closed);
    // Two sheets (four triangles) on one edge: still non-manifold, loops all close.
    let t4 = [0, 1, 2, 1, 0, 3, 0, 1, 4, 1, 0, 5];
    let he4 = HalfEdges::new(6, &t4);
    assert_eq!(he4.non_manifold_edges().row(0), [0, 3, 6, 9]);
    let loops = boundary_loops(&t4, &he4);
    assert!(loops.iter().all(|l| l.closed && l.len() == 4), "{loops:?}");
}

#[test]
fn bow_tie_vertex() {
    let t = [0, 1, 2, 0, 3, 4];
    assert_eq!(report(5, &t), rep(6, &[3, 3], 2, [true, false, true, true]));
    let he = HalfEdges::new(5, &t);
    assert_eq!(non_manifold_vertices(5, &t, &he), [0]);
    assert_eq!(TriangleComponents::vertex_connected(5, &t).count(), 1);
    // Two cones sharing their apex 0: closed fans, still a non-manifold vertex.
    let cones = [0, 1, 2, 0, 2, 3, 0, 3, 1, 0, 4, 5, 0, 5, 6, 0, 6, 4];
    let hc = HalfEdges::new(7, &cones);
    assert_eq!(non_manifold_vertices(7, &cones, &hc), [0]);
}

#[test]
fn grid_with_square_hole() {
    let (p, t) = grid(5, &[(2, 2)]);
    assert_eq!(report(36, &t), rep(84, &[20, 4], 1, ALL));
    let he = HalfEdges::new(36, &t);
    let loops = boundary_loops(&t, &he);
    // The hole runs clockwise seen from +z (the surface is on its left).
    assert!(same_cycle(&loops[1].vertices, &[15, 14, 20, 21]), "{:?}", loops[1]);
    assert_eq!(loops[0].half_edges[0], 0);
    assert_eq!(loops[0].vertices[..3], [0, 1, 2]);
    for l in &loops {
        assert_eq!(l.half_edges.iter().min(), l.half_edges.first());
        for (i, &h) in l.half_edges.iter().enumerate() {
            assert_eq!(l.vertices[i], meshflow_topology::halfedge::origin(&t, h));
        }
    }
    let on_boundary = boundary_vertices(36, &t, &he);
    assert_eq!(on_boundary.iter().filter(|&&b| b).count(), 24);
    assert!(on_boundary[14] && !on_boundary[7]);
    assert_eq!(geometry::total_area(&p, &t), 24.0);
}

#[test]
fn grid_with_holes_touching_at_a_vertex() {
    // Quads (1, 1) and (2, 2) removed: they meet at vertex 2 + 5 * 2 = 12.
    let (_, t) = grid(4, &[(1, 1), (2, 2)]);
    let he = HalfEdges::new(25, &t);
    assert_eq!(non_manifold_vertices(25, &t, &he), [12]);
    let loops = boundary_loops(&t, &he);
    // Walking through the fans, the two holes form one boundary curve through 12 twice.
    assert_eq!(loops.iter().map(|l| l.len()).collect::<Vec<_>>(), [16, 8]);
    assert!(loops.iter().all(|l| l.closed && l.consistent));
    assert_eq!(loops[1].vertices.iter().filter(|&&v| v == 12).count(), 2);
}

#[test]
fn degenerate_triangles() {
    let (p, mut t) = unit_cube();
    // A repeated-index sliver on the cube edge 0-1, a point triangle, an out-of-range one.
    t.extend([0, 0, 1, 2, 2, 2, 0, 1, 99]);
    let he = HalfEdges::new(8, &t);
    assert_eq!(he.edge_count(), 18);
    // Edges and orientation ignore them; manifoldness does not (a sliver is no surface).
    assert!(he.is_closed() && is_oriented(&he) && is_edge_manifold(&he));
    assert!(is_vertex_manifold(8, &t, &he) && !is_manifold(8, &t, &he));
    assert!(he.kinds()[36..].iter().all(|&k| k == EdgeKind::Degenerate));
    assert!(he.opposites()[36..].iter().all(|&o| o == NONE));
    assert!(boundary_loops(&t, &he).is_empty());
    // The sliver and the out-of-range triangle join the cube through edge 0-1; the point
    // triangle has no edge and stands alone.
    let c = TriangleComponents::new(8, &t);
    assert_eq!(c.sizes(), [14, 1]);
    assert_eq!(c.label(13), 1);
    assert_eq!(c.largest(), Some(0));
    assert_eq!(orientation_flips(&he).unwrap().iter().filter(|&&f| f).count(), 0);
    assert!(geometry::is_degenerate(&p, &t, 12) && geometry::is_degenerate(&p, &t, 13));
    assert!(!geometry::is_degenerate(&p, &t, 0));
    // Adjacency lists the sliver once around 0 and 1, without a self-loop.
    let vt = VertexTriangles::new(8, &t);
    assert_eq!(vt.of(0), [0, 1, 4, 5, 8, 9, 12, 14]);
    assert_eq!(vt.of(2), [0, 6, 7, 9, 13]);
    let vn = VertexNeighbours::new(8, &t);
    assert_eq!(vn.of(0), [1, 2, 3, 4, 5, 6]);
    assert_eq!(vn.of(2), [0, 3, 6, 7]);
    // Normals ignore the out-of-range triangle and are unchanged by zero-area ones.
    assert_eq!(geometry::vertex_normals(&p, &t), geometry::vertex_normals(&p, &t[..36]));
}

#[test]
fn unreferenced_vertices_are_ignored() {
    let (mut p, t) = unit_cube();
    p.extend([5.0, 5.0, 5.0, -1.0, 0.0, 0.0, 0.5, 0.5, 0.5]);
    assert_eq!(report(11, &t), rep(18, &[], 1, ALL));
    assert_eq!(unreferenced_vertices(11, &t), [8, 9, 10]);
    let vt = VertexTriangles::new(11, &t);
    assert_eq!(vt.offsets().len(), 12);
    assert!(vt.of(9).is_empty());
    assert!(VertexNeighbours::new(11, &t).of(10).is_empty());
    assert_eq!(geometry::vertex_normals(&p, &t)[8], [0.0; 3]);
    let bb = geometry::bounding_box(&p).unwrap();
    assert_eq!((bb.min, bb.max), ([-1.0, 0.0, 0.0], [5.0; 3]));
    let c: Vec3 = geometry::centroid(&p).unwrap();
    assert!((c[0] - (4.0 + 5.0 - 1.0 + 0.5) / 11.0).abs() < 1e-12);
}

#[test]
fn empty_mesh() {
    assert_eq!(report(0, &[]), rep(0, &[], 0, ALL));
    assert_eq!(report(4, &[]), rep(0, &[], 0, ALL));
    assert!(VertexTriangles::new(4, &[]).of(3).is_empty());
    assert_eq!(TriangleComponents::new(4, &[]).largest(), None);
}

#[test]
fn improper_and_duplicated_triangles_are_not_manifold() {
    let single = [0, 1, 2];
    assert!(is_manifold(3, &single, &HalfEdges::new(3, &single)));
    let repeated = [1, 1, 1].repeat(1000);
    assert!(has_improper_triangles(3, &repeated));
    assert!(!is_manifold(3, &repeated, &HalfEdges::new(3, &repeated)));
    let out_of_range = [0, 1, 2, 0, 1, 7];
    assert!(!is_manifold(3, &out_of_range, &HalfEdges::new(3, &out_of_range)));
    for twice in [[0, 1, 2, 0, 1, 2], [0, 1, 2, 2, 1, 0]] {
        let he = HalfEdges::new(3, &twice);
        assert!(is_edge_manifold(&he) && has_duplicate_triangles(&twice, &he), "{twice:?}");
        assert!(!is_manifold(3, &twice, &he), "{twice:?}");
    }
    // Removed triangles (all corners NONE) are absent.
    let with_removed = [0, 1, 2, NONE, NONE, NONE];
    assert!(!has_improper_triangles(3, &with_removed));
}
