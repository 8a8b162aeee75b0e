//! Timings on a 1M-vertex / 2M-triangle grid. Ignored by default; run with
//! `cargo test -p meshflow-topology --release --test topology_perf -- --ignored --nocapture`.

use std::time::Instant;

use meshflow_topology::geometry;
use meshflow_topology::{
    Connectivity, EdgeBuckets, HalfEdges, TriangleComponents, VertexNeighbours, VertexTriangles,
    boundary_loops, is_orientable, is_vertex_manifold,
};

/// `n × n` quads, two triangles each, a hole every 50 quads; vertex ids optionally scrambled
/// (as in a scan whose vertex order has no locality).
fn grid(n: u32, scramble: bool) -> (Vec<f32>, Vec<u32>) {
    let vertex_count = (n + 1) * (n + 1);
    // A bijection with poor locality: multiply by an odd constant modulo a power of two,
    // keeping only the values that land in range (cycle walking).
    let m = vertex_count.next_power_of_two();
    let map = |v: u32| {
        if !scramble {
            return v;
        }
        let mut x = v;
        loop {
            x = x.wrapping_mul(0x9E37_79B1) & (m - 1);
            if x < vertex_count {
                return x;
            }
        }
    };
    let mut p = vec![0f32; 3 * vertex_count as usize];
    for y in 0..=n {
        for x in 0..=n {
            let v = map(x + (n + 1) * y) as usize;
            p[3 * v..3 * v + 3].copy_from_slice(&[x as f32, y as f32, ((x * y) % 7) as f32 * 0.1]);
        }
    }
    let mut t = Vec::with_capacity(6 * (n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            if x % 50 == 25 && y % 50 == 25 {
                continue;
            }
            let v = x + (n + 1) * y;
            let w = v + n + 1;
            t.extend([v, v + 1, w + 1, v, w + 1, w].map(map));
        }
    }
    (p, t)
}

/// Runs `f` five times and prints the fastest time (the machine may be shared).
fn time<R>(label: &str, mut f: impl FnMut() -> R) -> R {
    let mut best = f64::INFINITY;
    let mut result = None;
    for _ in 0..5 {
        let start = Instant::now();
        let r = f();
        best = best.min(start.elapsed().as_secs_f64());
        result = Some(r);
    }
    println!("{label:<28} {:>8.1} ms", best * 1e3);
    result.unwrap()
}

fn run(scramble: bool) {
    let (p, t) = grid(1000, scramble);
    let v = p.len() / 3;
    println!("--- {} vertices, {} triangles, scrambled ids: {scramble}", v, t.len() / 3);
    let vt = time("VertexTriangles::new", || VertexTriangles::new(v, &t));
    let vn =
        time("VertexNeighbours (from vt)", || VertexNeighbours::from_vertex_triangles(&vt, &t));
    time("cotangent_weights", || geometry::cotangent_weights(&p, &t, &vn));
    time("EdgeBuckets::new", || EdgeBuckets::new(v, &t));
    let he = time("HalfEdges::new", || HalfEdges::new(v, &t));
    time("Connectivity::new", || Connectivity::new(v, &t));
    time("Connectivity::in_parts(2)", || Connectivity::in_parts(v, &t, 2));
    let loops = time("boundary_loops", || boundary_loops(&t, &he));
    let c = time("TriangleComponents::new", || TriangleComponents::new(v, &t));
    time("TriangleComponents::vertex_c", || TriangleComponents::vertex_connected(v, &t));
    time("is_vertex_manifold", || is_vertex_manifold(v, &t, &he));
    time("is_orientable", || is_orientable(&he));
    time("vertex_normals", || geometry::vertex_normals(&p, &t));
    assert_eq!(he.edge_count(), 2 * 1000 * 1001 + 1000 * 1000 - 400);
    assert_eq!(loops.len(), 1 + 400);
    assert_eq!(c.count(), 1);
}

#[test]
#[ignore]
fn timings_on_a_2m_triangle_grid() {
    run(false);
    run(true);
}
