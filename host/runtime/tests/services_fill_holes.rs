//! `fill-holes` run as WebAssembly through the host: holes punched into closed meshes are
//! closed by manifold, consistently oriented, well-shaped patches that follow the surface;
//! holes above the limit and holes through non-manifold vertices stay open and are reported.

use meshflow_builtin_plugins::PLUGINS;
use meshflow_generate::{ScanSpec, scan};
use meshflow_mesh::MeshData;
use meshflow_runtime::{Limits, RunOutput, Runtime, Value};
use meshflow_topology::boundary::{BoundaryLoop, boundary_loops};
use meshflow_topology::geometry::{corner_angles_degrees, norm, point};
use meshflow_topology::halfedge::HalfEdges;
use meshflow_topology::manifold::{is_edge_manifold, is_oriented};
use meshflow_topology::shapes::uv_sphere;

fn fill(mesh: &MeshData, params: &[(&str, Value)]) -> RunOutput {
    let runtime = Runtime::new(Limits::default(), None).expect("a runtime");
    let wasm = PLUGINS.iter().find(|p| p.name == "holes").expect("the holes plugin").wasm;
    let plugin = runtime.load(wasm).expect("the plugin loads");
    let params: Vec<(String, Value)> =
        params.iter().map(|(name, value)| (name.to_string(), value.clone())).collect();
    runtime.run(&plugin, "fill-holes", mesh.clone(), &params).expect("fill-holes runs")
}

fn sphere(rings: u32, segments: u32) -> MeshData {
    let (positions, triangles) = uv_sphere(rings, segments);
    MeshData::new(positions, triangles)
}

/// Removes the triangles whose centroid is within `radius` of `centre`.
fn punch(mesh: &mut MeshData, centre: [f64; 3], radius: f64) {
    let kept: Vec<u32> = mesh
        .triangles
        .chunks_exact(3)
        .filter(|t| {
            let c = t.iter().fold([0.0; 3], |s, &v| {
                let p = point(&mesh.positions, v);
                [s[0] + p[0] / 3.0, s[1] + p[1] / 3.0, s[2] + p[2] / 3.0]
            });
            norm([c[0] - centre[0], c[1] - centre[1], c[2] - centre[2]]) > radius
        })
        .flatten()
        .copied()
        .collect();
    mesh.triangles = kept;
}

fn loops(mesh: &MeshData) -> Vec<BoundaryLoop> {
    boundary_loops(&mesh.triangles, &HalfEdges::new(mesh.vertex_count(), &mesh.triangles))
}

/// A sphere with three holes of different sizes (all within the default limit).
fn holed_sphere() -> MeshData {
    let mut mesh = sphere(60, 120);
    punch(&mut mesh, [1.0, 0.0, 0.0], 0.12);
    punch(&mut mesh, [0.0, 1.0, 0.3], 0.3);
    punch(&mut mesh, [-0.6, -0.6, -0.5], 0.5);
    mesh
}

/// Minimum and maximum corner angle (degrees) of every triangle from `first` on.
fn angle_ranges(mesh: &MeshData, first: usize) -> Vec<(f64, f64)> {
    (first..mesh.triangle_count())
        .map(|t| {
            let a = corner_angles_degrees(&mesh.positions, &mesh.triangles, t as u32);
            (a.iter().copied().fold(f64::MAX, f64::min), a.iter().copied().fold(0.0, f64::max))
        })
        .collect()
}

#[test]
fn holes_within_the_limit_are_closed_by_good_patches() {
    let mesh = holed_sphere();
    let holes = loops(&mesh);
    assert_eq!(holes.len(), 3);
    assert!(holes.iter().all(|h| h.closed && h.consistent));
    let out = fill(&mesh, &[]);
    let filled = out.mesh.expect("a filter returns a mesh");
    assert!(out.report.starts_with("filled 3 hole(s)"), "{}", out.report);
    assert!(loops(&filled).is_empty(), "holes left: {}", out.report);
    let half_edges = HalfEdges::new(filled.vertex_count(), &filled.triangles);
    assert!(is_edge_manifold(&half_edges));
    assert!(is_oriented(&half_edges), "the patches disagree with their surroundings");
    // Refinement added vertices at about the sphere's density, and fairing put them on it.
    let new_vertices = filled.vertex_count() - mesh.vertex_count();
    assert!(new_vertices > 100, "only {new_vertices} new vertices");
    let radius_error = (mesh.vertex_count()..filled.vertex_count())
        .map(|v| (norm(point(&filled.positions, v as u32)) - 1.0).abs())
        .fold(0.0, f64::max);
    // A flat fill of the largest hole (angular radius ≈ 0.5) would sag 1 - cos 0.5 ≈ 0.12.
    assert!(radius_error < 0.03, "new vertices up to {radius_error} off the sphere");
    // Good triangles: new ones are appended after the survivors.
    let mut ranges = angle_ranges(&filled, mesh.triangle_count());
    ranges.sort_by(|a, b| a.0.total_cmp(&b.0));
    let median = ranges[ranges.len() / 2].0;
    let slivers = ranges.iter().filter(|r| r.0 < 5.0).count() as f64 / ranges.len() as f64;
    assert!(median >= 30.0, "median minimum angle {median}");
    assert!(slivers < 0.01, "{:.1} % of new triangles have an angle below 5°", 100.0 * slivers);
}

#[test]
fn a_hole_above_the_limit_stays_open_and_is_reported() {
    let mesh = holed_sphere();
    let sizes: Vec<usize> = loops(&mesh).iter().map(|h| h.len()).collect();
    let limit = sizes.iter().copied().max().unwrap() - 1;
    let out = fill(&mesh, &[("max-hole-edges", Value::Integer(limit as i64))]);
    let filled = out.mesh.unwrap();
    assert!(out.report.starts_with("filled 2 hole(s)"), "{}", out.report);
    assert!(out.report.contains(&format!("1 above {limit} edges")), "{}", out.report);
    let left: Vec<usize> = loops(&filled).iter().map(|h| h.len()).collect();
    assert_eq!(left, [limit + 1]);
}

#[test]
fn fairing_and_refinement_can_be_turned_off() {
    let mesh = holed_sphere();
    let out = fill(&mesh, &[("refine", Value::Boolean(false))]);
    let filled = out.mesh.unwrap();
    // The bare triangulation: n - 2 triangles per hole, no new vertex.
    let expected: usize = loops(&mesh).iter().map(|h| h.len() - 2).sum();
    assert_eq!(filled.vertex_count(), mesh.vertex_count());
    assert_eq!(filled.triangle_count(), mesh.triangle_count() + expected);
    assert!(loops(&filled).is_empty());
}

#[test]
fn a_scan_is_filled_deterministically_and_only_non_fillable_loops_remain() {
    let mesh = scan(&ScanSpec { vertices: 30_000, components: 5, holes: 20, noise: 0.2, seed: 3 });
    let out = fill(&mesh, &[]);
    let filled = out.mesh.unwrap();
    assert!(filled.triangle_count() > mesh.triangle_count(), "{}", out.report);
    let mut sorted = Vec::new();
    for hole in loops(&filled) {
        sorted.clone_from(&hole.vertices);
        sorted.sort_unstable();
        let simple = hole.closed && hole.consistent && sorted.windows(2).all(|w| w[0] != w[1]);
        assert!(!simple || hole.len() > 500, "a fillable hole of {} edges is open", hole.len());
    }
    let again = fill(&mesh, &[]).mesh.unwrap();
    assert_eq!(filled.content_hash(), again.content_hash());
}
