//! Native times of decimation (to 10 %) and isotropic remeshing (at the mean edge length)
//! on generated scans of growing size, repaired as the services bench does, with the
//! vertex and triangle ids shuffled as a real scan's may be. Prints a hash of each result
//! (collapses and moves, or edits and positions), so runs can be compared bit for bit.
//!
//! `cargo run --release -p meshflow-plugin-remeshing --example scaling -- [decimation|remeshing]
//! [--ordered] [--iterations N] SIZE...`

use std::time::Instant;

use meshflow_generate::{ScanSpec, scan};
use meshflow_plugin_cleanup::nonmanifold::repair_non_manifold;
use meshflow_plugin_remeshing::decimate::{self, decimate};
use meshflow_plugin_remeshing::isotropic::{self, Edit, remesh};
use meshflow_plugin_sdk::topology::NONE;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let filter = args.first().map_or("decimation", |s| s.as_str());
    let ordered = args.iter().any(|a| a == "--ordered");
    let iterations = args
        .iter()
        .position(|a| a == "--iterations")
        .and_then(|i| args.get(i + 1)?.parse().ok())
        .unwrap_or(1);
    let sizes = args.iter().skip(1).filter_map(|a| a.parse::<usize>().ok()).filter(|&n| n > 100);
    for size in sizes {
        let (mut positions, mut triangles) = repaired_scan(size);
        if !ordered {
            (positions, triangles) = shuffled(&positions, &triangles);
        }
        let started = Instant::now();
        let (hash, summary) = match filter {
            "remeshing" => {
                let settings = isotropic::Settings {
                    target_length: mean_edge_length(&positions, &triangles),
                    iterations,
                    feature_angle_degrees: 45.0,
                };
                let r = remesh(&positions, &triangles, settings).expect("a manifold scan");
                let edits = r.edits.iter().flat_map(|e| match *e {
                    Edit::SplitEdge { edge, at } => {
                        [0, edge, at[0].to_bits(), at[1].to_bits(), at[2].to_bits()]
                    }
                    Edit::CollapseEdge { edge } => [1, edge, 0, 0, 0],
                    Edit::SwapEdge { edge } => [2, edge, 0, 0, 0],
                });
                let words = edits.chain(r.positions.iter().map(|x| x.to_bits()));
                (
                    fnv(words),
                    format!("{} splits, {} collapses, {} flips", r.splits, r.collapses, r.flips),
                )
            }
            _ => {
                let settings = decimate::Settings {
                    target_triangles: triangles.len() / 3 / 10,
                    preserve_boundary: true,
                    quality_weight: 0.0,
                };
                let d = decimate(&positions, &triangles, settings);
                let words = d.collapses.iter().chain(&d.moved).copied();
                let words = words.chain(d.moved_positions.iter().map(|x| x.to_bits()));
                (fnv(words), format!("{} triangles left", d.triangles_after))
            }
        };
        println!(
            "{filter} {} {} vertices, {} triangles: {:.3} s, hash {hash:016x}, {summary}",
            if ordered { "ordered" } else { "shuffled" },
            positions.len() / 3,
            triangles.len() / 3,
            started.elapsed().as_secs_f64()
        );
    }
}

/// The bench's scan (its defects scaled with the size) after `repair-non-manifold`.
fn repaired_scan(vertices: usize) -> (Vec<f32>, Vec<u32>) {
    let spec = ScanSpec {
        vertices,
        components: (150 * vertices / 1_000_000).max(1),
        holes: (400 * vertices / 1_000_000).max(4),
        noise: 0.1,
        seed: 1,
    };
    let mesh = scan(&spec);
    let repair = repair_non_manifold(&mesh.positions, &mesh.triangles);
    let mut triangles = mesh.triangles.clone();
    for &t in repair.removed.iter().chain(&repair.repointed) {
        triangles[3 * t as usize..3 * t as usize + 3].fill(NONE);
    }
    triangles.extend(&repair.readded);
    triangles.retain(|&v| v != NONE);
    let mut positions = mesh.positions.clone();
    positions.extend(&repair.new_positions);
    (positions, triangles)
}

/// The same mesh with vertices, triangles and each triangle's corners in a random order.
fn shuffled(positions: &[f32], triangles: &[u32]) -> (Vec<f32>, Vec<u32>) {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = |below: usize| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % below as u64) as usize
    };
    let n = positions.len() / 3;
    let mut new_id: Vec<u32> = (0..n as u32).collect();
    for i in (1..n).rev() {
        new_id.swap(i, next(i + 1));
    }
    let mut moved = vec![0.0; positions.len()];
    for (v, &w) in new_id.iter().enumerate() {
        moved[3 * w as usize..3 * w as usize + 3].copy_from_slice(&positions[3 * v..3 * v + 3]);
    }
    let mut corners: Vec<[u32; 3]> =
        triangles.chunks_exact(3).map(|c| [c[0], c[1], c[2]].map(|v| new_id[v as usize])).collect();
    for i in (1..corners.len()).rev() {
        corners.swap(i, next(i + 1));
    }
    for c in &mut corners {
        c.rotate_left(next(3));
    }
    (moved, corners.into_iter().flatten().collect())
}

fn mean_edge_length(positions: &[f32], triangles: &[u32]) -> f64 {
    let at = |v: u32| positions[3 * v as usize..][..3].iter().map(|&x| x as f64);
    let sum: f64 = triangles
        .chunks_exact(3)
        .flat_map(|c| [(c[0], c[1]), (c[1], c[2]), (c[2], c[0])])
        .map(|(a, b)| at(a).zip(at(b)).map(|(x, y)| (x - y) * (x - y)).sum::<f64>().sqrt())
        .sum();
    sum / triangles.len() as f64
}

/// FNV-1a over 32-bit words.
fn fnv(words: impl Iterator<Item = u32>) -> u64 {
    words
        .flat_map(u32::to_le_bytes)
        .fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3))
}
