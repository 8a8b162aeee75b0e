//! Load time of a large binary PLY. Ignored by default; run in release:
//! `cargo test --release -p meshflow-host --test io_perf -- --ignored --nocapture`.
//! Prints the figures instead of asserting them, so slow machines do not fail the suite.

use std::time::{Duration, Instant};

use meshflow_host::MeshData;
use meshflow_host::io::{self, Format, PlyEncoding};

/// A `side` × `side` vertex grid with two triangles per cell.
fn grid(side: u32) -> MeshData {
    let mut positions = Vec::with_capacity((side * side * 3) as usize);
    for j in 0..side {
        for i in 0..side {
            positions.extend_from_slice(&[
                i as f32 * 0.01,
                j as f32 * 0.01,
                ((i ^ j) % 7) as f32 * 0.001,
            ]);
        }
    }
    let mut triangles = Vec::with_capacity(((side - 1) * (side - 1) * 6) as usize);
    for j in 0..side - 1 {
        for i in 0..side - 1 {
            let v = j * side + i;
            triangles.extend_from_slice(&[v, v + 1, v + side, v + 1, v + side + 1, v + side]);
        }
    }
    MeshData::new(positions, triangles)
}

fn best_of<T>(runs: usize, mut f: impl FnMut() -> T) -> (Duration, T) {
    let mut best = Duration::MAX;
    let mut last = None;
    for _ in 0..runs {
        let start = Instant::now();
        let value = f();
        best = best.min(start.elapsed());
        last = Some(value);
    }
    (best, last.unwrap())
}

#[test]
#[ignore = "timing; run in release with --ignored --nocapture"]
fn load_time_of_a_one_million_vertex_binary_ply() {
    let mesh = grid(1001); // 1 002 001 vertices, 2 000 000 triangles
    let dir = std::env::temp_dir().join(format!("meshflow-io-perf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut report = Vec::new();
    for (name, format, encoding) in [
        ("grid.ply", Format::Ply, PlyEncoding::BinaryLittleEndian),
        ("grid_be.ply", Format::Ply, PlyEncoding::BinaryBigEndian),
        ("grid.stl", Format::Stl, PlyEncoding::default()),
        ("grid.obj", Format::Obj, PlyEncoding::default()),
        ("grid.off", Format::Off, PlyEncoding::default()),
        ("grid_ascii.ply", Format::Ply, PlyEncoding::Ascii),
    ] {
        let path = dir.join(name);
        let (save, ()) = best_of(1, || io::save_as(&path, &mesh, format, encoding).unwrap());
        let runs = if name == "grid.ply" { 7 } else { 2 };
        let (load, loaded) = best_of(runs, || io::load(&path).unwrap());
        if format == Format::Stl {
            assert_eq!(loaded.triangles.len(), mesh.triangles.len());
        } else {
            assert_eq!(loaded.content_hash(), mesh.content_hash());
        }
        let size = std::fs::metadata(&path).unwrap().len() as f64 / 1e6;
        report.push(format!("{name:>15}: {size:7.1} MB  save {save:>10.3?}  load {load:>10.3?}"));
    }
    std::fs::remove_dir_all(&dir).unwrap();
    println!("{} vertices, {} triangles", mesh.vertex_count(), mesh.triangle_count());
    for line in report {
        println!("{line}");
    }
}
