//! The cleanup, smoothing and noise filters, run as WebAssembly through the host on
//! generated scans and hand-built meshes.

mod common;

use common::run;

use meshflow_generate::{ScanSpec, scan};
use meshflow_mesh::MeshData;
use meshflow_mesh::store::Op;
use meshflow_runtime::{Limits, Runtime, Value};
use meshflow_topology::adjacency::VertexNeighbours;
use meshflow_topology::boundary::{boundary_loops, boundary_vertices};
use meshflow_topology::components::TriangleComponents;
use meshflow_topology::geometry::{bounding_box, is_degenerate};
use meshflow_topology::halfedge::HalfEdges;
use meshflow_topology::shapes::{square_grid, triangular_sheet};

fn small_scan(seed: u64) -> MeshData {
    scan(&ScanSpec { vertices: 20_000, components: 12, holes: 15, noise: 0.2, seed })
}

fn loop_count(mesh: &MeshData) -> usize {
    let half_edges = HalfEdges::new(mesh.vertex_count(), &mesh.triangles);
    boundary_loops(&mesh.triangles, &half_edges).len()
}

fn unreferenced(mesh: &MeshData) -> usize {
    let mut used = vec![false; mesh.vertex_count()];
    mesh.triangles.iter().for_each(|&v| used[v as usize] = true);
    used.iter().filter(|&&u| !u).count()
}

// ---- remove-smallest-components ----------------------------------------------------------

#[test]
fn removing_the_smallest_components_leaves_exactly_one() {
    let mesh = small_scan(11);
    let before = TriangleComponents::new(mesh.vertex_count(), &mesh.triangles);
    assert!(before.count() > 10, "{} components", before.count());
    let largest = before.sizes()[before.largest().unwrap() as usize] as usize;

    let out = run("cleanup", "remove-smallest-components", &mesh, &[]);
    let result = out.mesh.unwrap();
    let after = TriangleComponents::new(result.vertex_count(), &result.triangles);
    assert_eq!(after.count(), 1, "{}", out.report);
    assert_eq!(result.triangle_count(), largest);
    // Stray vertices of the input stay; the removed pieces leave none behind.
    assert_eq!(unreferenced(&result), unreferenced(&mesh));
    // One `remove-component` a removed piece: the plugin never read the mesh.
    assert_eq!(out.log.len(), before.count() - 1);
    assert!(out.log.iter().all(|op| matches!(op, Op::RemoveComponent { .. })), "{:?}", out.log);
    assert!(out.report.starts_with(&format!(
        "removed {} of {}",
        before.count() - 1,
        before.count()
    )));
}

#[test]
fn removing_small_components_takes_a_mesh_larger_than_its_sandbox() {
    // 12.5M triangles, whose corners alone (150 MB) are more than the 130 MiB the guest may
    // hold, and a lone triangle: the plugin reads the host's list of components, not the
    // mesh, and asks the host to remove the piece.
    let squares = 2500;
    let (mut positions, mut triangles) = square_grid(squares);
    let (grid_vertices, grid_triangles) = (positions.len() / 3, triangles.len() / 3);
    let n = grid_vertices as u32;
    positions.extend([10.0, 0.0, 5.0, 11.0, 0.0, 5.0, 10.0, 1.0, 5.0]);
    triangles.extend([n, n + 1, n + 2]);
    let mesh = MeshData::new(positions, triangles);
    let cap = 130 << 20;
    assert!(mesh.triangles.len() * 4 > cap);
    let runtime = Runtime::new(Limits { memory_bytes: cap, ..Limits::default() }, None).unwrap();
    let plugin = common::builtin(&runtime, "cleanup");
    let out = runtime
        .run(&plugin, "remove-smallest-components", mesh, &[])
        .unwrap_or_else(|e| panic!("under {cap} bytes: {e}"));
    assert_eq!(out.log, [Op::RemoveComponent { triangle: grid_triangles as u32 }]);
    let result = out.mesh.unwrap();
    assert_eq!((result.vertex_count(), result.triangle_count()), (grid_vertices, grid_triangles));
    assert!(out.guest_peak_bytes <= cap, "{}", out.guest_peak_bytes);
}

#[test]
fn a_minimum_size_removes_only_the_smaller_components() {
    let mesh = small_scan(12);
    let before = TriangleComponents::new(mesh.vertex_count(), &mesh.triangles);
    let min = 20;
    let out = run(
        "cleanup",
        "remove-smallest-components",
        &mesh,
        &[("min-triangles", Value::Integer(min))],
    );
    let result = out.mesh.unwrap();
    let after = TriangleComponents::new(result.vertex_count(), &result.triangles);
    let big = before.sizes().iter().filter(|&&s| s as i64 >= min).count();
    assert_eq!(after.count(), big);
    assert!(after.sizes().iter().all(|&s| s as i64 >= min));
}

// ---- laplacian-smoothing -------------------------------------------------------------------

#[test]
fn smoothing_with_a_fixed_boundary_leaves_boundary_vertices_bit_identical() {
    let mesh = small_scan(13);
    let he = HalfEdges::new(mesh.vertex_count(), &mesh.triangles);
    let boundary = boundary_vertices(mesh.vertex_count(), &mesh.triangles, &he);
    assert!(boundary.iter().filter(|&&b| b).count() > 100);
    for weights in ["uniform", "cotangent"] {
        let params = [("iterations", Value::Integer(3)), ("weights", Value::Text(weights.into()))];
        let out = run("smoothing", "laplacian-smoothing", &mesh, &params);
        assert!(matches!(out.log[..], [Op::SetPositions { .. }]), "one move-all edit");
        let result = out.mesh.unwrap();
        assert_eq!(result.triangles, mesh.triangles);
        let (mut moved, mut pinned) = (0, 0);
        for (v, &on_boundary) in boundary.iter().enumerate() {
            let (a, b) = (&mesh.positions[3 * v..3 * v + 3], &result.positions[3 * v..3 * v + 3]);
            if on_boundary {
                let bits = |p: &[f32]| p.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(a), bits(b), "{weights}: vertex {v}");
                pinned += 1;
            } else if a != b {
                moved += 1;
            }
        }
        assert!(pinned > 0 && moved > mesh.vertex_count() / 2, "{weights}: {moved} moved");
    }
}

/// A flat sheet of `n x n` vertices on a nearly equilateral lattice, lifted by `height`.
fn sheet(n: u32, height: impl Fn(f32, f32) -> f32) -> MeshData {
    let (mut positions, triangles) = triangular_sheet(n);
    for p in positions.chunks_exact_mut(3) {
        p[2] = height(p[0], p[1]);
    }
    MeshData::new(positions, triangles)
}

/// The mean difference between an interior vertex's height and its neighbours' mean
/// height (boundary vertices are pinned, so they do not count).
fn roughness(mesh: &MeshData) -> f64 {
    let neighbours = VertexNeighbours::new(mesh.vertex_count(), &mesh.triangles);
    let he = HalfEdges::new(mesh.vertex_count(), &mesh.triangles);
    let boundary = boundary_vertices(mesh.vertex_count(), &mesh.triangles, &he);
    let z = |v: u32| mesh.positions[3 * v as usize + 2] as f64;
    (0..mesh.vertex_count() as u32)
        .filter(|&v| !boundary[v as usize])
        .map(|v| {
            let around = neighbours.of(v);
            let mean = around.iter().map(|&w| z(w)).sum::<f64>() / around.len() as f64;
            (z(v) - mean).abs()
        })
        .sum::<f64>()
        / mesh.vertex_count() as f64
}

#[test]
fn cotangent_smoothing_flattens_a_noisy_bump() {
    let mesh = sheet(30, |x, y| {
        let bump = 2.0 * (-((x - 15.0).powi(2) + (y - 13.0).powi(2)) / 80.0).exp();
        // A classic shader hash: deterministic, uncorrelated between neighbours.
        let hash = ((12.9898 * x + 78.233 * y).sin() * 43758.547).fract();
        bump + 0.1 * hash
    });
    let params = [("iterations", Value::Integer(10)), ("weights", Value::Text("cotangent".into()))];
    let out = run("smoothing", "laplacian-smoothing", &mesh, &params);
    let result = out.mesh.unwrap();
    let (before, after) = (roughness(&mesh), roughness(&result));
    assert!(after < 0.25 * before, "roughness {before} -> {after}");
    assert!(out.report.contains("cotangent"), "{}", out.report);
}

// ---- add-noise ----------------------------------------------------------------------------

#[test]
fn noise_reproduces_by_seed_differs_by_seed_and_respects_the_amount() {
    let mesh = small_scan(14);
    let noisy = |seed: i64| {
        let params = [("amount", Value::Real(0.5)), ("seed", Value::Integer(seed))];
        run("smoothing", "add-noise", &mesh, &params).mesh.unwrap()
    };
    let (a, b, c) = (noisy(1), noisy(1), noisy(2));
    assert_eq!(a.content_hash(), b.content_hash());
    assert_ne!(a.content_hash(), c.content_hash());
    assert_eq!(a.triangles, mesh.triangles);

    let diagonal = bounding_box(&mesh.positions).unwrap().diagonal();
    let amount = 0.005 * diagonal;
    let largest = mesh.positions.iter().fold(0f32, |m, &x| m.max(x.abs())) as f64;
    // Rounding the moved point to f32 may add half an ulp per axis.
    let slack = 3f64.sqrt() * largest * f32::EPSILON as f64;
    let mut moved = 0;
    for (p, q) in mesh.positions.chunks_exact(3).zip(a.positions.chunks_exact(3)) {
        let d = (0..3).map(|k| (q[k] as f64 - p[k] as f64).powi(2)).sum::<f64>().sqrt();
        assert!(d <= amount + slack, "moved {d} > {amount}");
        moved += (d > 0.0) as usize;
    }
    assert_eq!(moved, mesh.vertex_count());
}

// ---- remove-degenerate-triangles -----------------------------------------------------------

/// A 4x4 grid of unit squares (vertex `5y + x` at (x, y)), each split on its diagonal, with
/// a cap on the border, a cap inside, two needles on one edge, a duplicate and a triangle
/// with a repeated vertex.
fn damaged_grid() -> MeshData {
    let (mut positions, mut triangles) = square_grid(4);
    let mut place = |v: usize, x: f32, y: f32| positions[3 * v..3 * v + 2].copy_from_slice(&[x, y]);
    place(6, 0.5, 0.0); // (0, 1, 6) lies flat on the border edge 0-1
    place(17, 1.0, 2.5); // (11, 17, 16) lies flat on the interior edge 11-16
    place(13, 3.0, 1.0); // onto vertex 8: (7, 8, 13) and (8, 14, 13) are needles
    triangles.extend([18, 13, 12, 3, 3, 9]);
    MeshData::new(positions, triangles)
}

fn degenerate_count(mesh: &MeshData) -> usize {
    (0..mesh.triangle_count() as u32)
        .filter(|&t| is_degenerate(&mesh.positions, &mesh.triangles, t))
        .count()
}

#[test]
fn degenerate_repair_leaves_no_flat_triangle_and_keeps_the_holes() {
    let mesh = damaged_grid();
    assert_eq!(degenerate_count(&mesh), 5);
    let out = run("cleanup", "remove-degenerate-triangles", &mesh, &[]);
    let result = out.mesh.unwrap();
    assert_eq!(degenerate_count(&result), 0);
    assert_eq!(loop_count(&result), 1);
    assert_eq!(result.triangle_count(), 29);
    assert_eq!(
        out.report,
        "removed 1 repeated-vertex and 1 duplicate triangle(s); 4 degenerate triangle(s): \
         split 2 cap(s), collapsed 1 needle(s), removed 0 unrepairable triangle(s)"
    );
}

#[test]
fn degenerate_repair_cleans_a_generated_scan() {
    let mesh = small_scan(15);
    assert!(degenerate_count(&mesh) > 0);
    let out = run("cleanup", "remove-degenerate-triangles", &mesh, &[]);
    let result = out.mesh.unwrap();
    assert_eq!(degenerate_count(&result), 0, "{}", out.report);
    // A second run finds nothing to do.
    let again = run("cleanup", "remove-degenerate-triangles", &result, &[]);
    assert!(again.log.is_empty(), "{}", again.report);
}
