//! The checks over the derived connectivity give exactly the values the checks gave when
//! each built its own edge buckets ([`crate::reference`]): the same integers and booleans,
//! and the same bits of every real, on meshes with every defect a raw scan has.

use crate::arrays::MeshArrays;
use crate::fixtures::*;
use crate::{counts, normals, reference, topology};

/// A deterministic stream of pseudo-random numbers (SplitMix64).
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// A bumpy `n × n` grid with, depending on `seed`: holes, flipped triangles, duplicates,
/// non-manifold fins, repeated and out-of-range ids, zero-area triangles and shuffled ids.
fn defective_grid(seed: u64, n: u32) -> Fixture {
    let mut rng = Stream(seed);
    let side = n + 1;
    let mut positions = Vec::new();
    for y in 0..side {
        for x in 0..side {
            let z = (rng.below(1000) as f32) / 4000.0;
            positions.extend([x as f32, y as f32, z]);
        }
    }
    let mut triangles = Vec::new();
    for y in 0..n {
        for x in 0..n {
            if rng.below(20) == 0 {
                continue; // a hole
            }
            let v = x + side * y;
            let w = v + side;
            triangles.extend([v, v + 1, w + 1, v, w + 1, w]);
        }
    }
    let count = triangles.len() / 3;
    let defects = seed % 4;
    for _ in 0..rng.below(4 * u64::from(n)) {
        let t = rng.below(count as u64) as usize;
        match (defects, rng.below(6)) {
            (0, _) => {}
            (_, 0) => triangles.swap(3 * t + 1, 3 * t + 2),
            (_, 1) => {
                let copy: Vec<u32> = triangles[3 * t..3 * t + 3].to_vec();
                triangles.extend(copy);
            }
            (_, 2) => {
                let apex = rng.below(u64::from(side * side)) as u32;
                let (a, b) = (triangles[3 * t], triangles[3 * t + 1]);
                triangles.extend([b, a, apex]);
            }
            (1 | 3, 3) => triangles.extend([triangles[3 * t], triangles[3 * t], 0]),
            (3, 4) => triangles.extend([triangles[3 * t], triangles[3 * t + 1], side * side + 7]),
            (_, _) => {
                // A zero-area triangle: its apex moved onto its first corner.
                let (a, c) = (triangles[3 * t] as usize, triangles[3 * t + 2] as usize);
                let first: Vec<f32> = positions[3 * a..3 * a + 3].to_vec();
                positions[3 * c..3 * c + 3].copy_from_slice(&first);
            }
        }
    }
    if seed.is_multiple_of(3) {
        // Vertex ids without locality, as scans from other tools come.
        let vertices = (side * side) as usize;
        let mut order: Vec<u32> = (0..vertices as u32).collect();
        for i in (1..vertices).rev() {
            order.swap(i, rng.below(i as u64 + 1) as usize);
        }
        let mut shuffled = vec![0.0; positions.len()];
        for (old, &new) in order.iter().enumerate() {
            let (o, n) = (3 * old, 3 * new as usize);
            shuffled[n..n + 3].copy_from_slice(&positions[o..o + 3]);
        }
        positions = shuffled;
        for id in triangles.iter_mut() {
            if (*id as usize) < vertices {
                *id = order[*id as usize];
            }
        }
    }
    Fixture { positions, triangles }
}

fn assert_same(name: &str, mesh: &Fixture) {
    let (v, t) = (mesh.vertex_count(), &mesh.triangles[..]);
    let arrays = MeshArrays::native(&mesh.positions, t);
    let now = (
        counts::edge_count(&arrays),
        counts::component_count(&arrays).unwrap(),
        counts::hole_count(&arrays).unwrap(),
        topology::is_manifold(&arrays).unwrap(),
        topology::is_oriented(&arrays).unwrap(),
        topology::is_orientable(&arrays).unwrap(),
        normals::normal_instability(&arrays).to_bits(),
    );
    let before = (
        reference::counts::edge_count(v, t),
        reference::counts::component_count(v, t),
        reference::counts::hole_count(v, t),
        reference::topology::is_manifold(v, t),
        reference::topology::is_oriented(v, t),
        reference::topology::is_orientable(v, t),
        reference::normals::normal_instability(&mesh.positions, t).to_bits(),
    );
    assert_eq!(now, before, "{name}");
}

#[test]
fn the_fixtures_give_what_they_gave() {
    for (name, mesh) in [
        ("cube", cube()),
        ("open cube", open_cube()),
        ("flipped cube", flipped_cube()),
        ("tetrahedron", tetrahedron()),
        ("mobius strip", mobius_strip(7)),
        ("two sheets", two_sheets()),
        ("bow tie", bow_tie()),
        ("degenerate only", degenerate_only()),
        ("sphere", sphere(9)),
        ("empty", Fixture { positions: vec![], triangles: vec![] }),
    ] {
        assert_same(name, &mesh);
    }
}

#[test]
fn defective_grids_give_what_they_gave() {
    for seed in 0..48 {
        let mesh = defective_grid(seed, 4 + (seed as u32 % 5) * 6);
        assert_same(&format!("grid of seed {seed}"), &mesh);
    }
}

#[test]
fn the_grids_have_the_defects_they_should() {
    // Without this the comparison above could pass on clean meshes only.
    let answers = |seed| {
        let mesh = defective_grid(seed, 22);
        let arrays = MeshArrays::native(&mesh.positions, &mesh.triangles);
        (topology::is_manifold(&arrays).unwrap(), topology::is_oriented(&arrays).unwrap())
    };
    assert!(answers(4).1, "seed 4 has holes only, no flips");
    assert!(!answers(5).0 && !answers(5).1, "seed 5 has flips, duplicates and fins");
    let degenerate = defective_grid(7, 22);
    let proper = |t: &[u32]| t[0] != t[1] && t[1] != t[2] && t[0] != t[2];
    let bad = degenerate.triangles.chunks_exact(3).filter(|t| !proper(t)).count();
    assert!(bad > 0, "seed 7 has repeated ids");
}
