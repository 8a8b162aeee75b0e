//! Corrections replay bit-exactly: random edit sequences of every kind, each kind alone,
//! and the size of the shapes the in-house services produce.

mod correction_common;

use correction_common::{
    Rng, assert_round_trip, attributed, grid, random_edits, random_op, smooth,
};
use meshflow_codec::correction;
use meshflow_mesh::MeshData;
use meshflow_mesh::store::{MeshStore, Op, OpKind};
use proptest::prelude::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(96))]

    #[test]
    fn random_edit_sequences_replay_bit_identically(
        seed in any::<u64>(),
        w in 2u32..9,
        h in 2u32..9,
        islands in 0u32..5,
        steps in 1usize..40,
        with_attributes in any::<bool>(),
    ) {
        let mut rng = Rng(seed);
        let base = grid(w, h, islands, &mut rng);
        let base = if with_attributes { attributed(base, &mut rng) } else { base };
        let mut store = MeshStore::new(base.clone());
        random_edits(&mut store, &mut rng, steps);
        let (result, log) = store.finish();
        assert_round_trip(&base, &result, &log);
    }
}

#[test]
fn each_op_kind_alone_round_trips() {
    for kind in OpKind::ALL {
        let mut applied = 0;
        for seed in 0..20 {
            let mut rng = Rng(seed);
            let base = grid(5, 4, 2, &mut rng);
            // Half the meshes carry attributes (one of each kind), for ops to change.
            let base = if seed % 2 == 1 { attributed(base, &mut rng) } else { base };
            let mut store = MeshStore::new(base.clone());
            let Some(op) = random_op(kind, &store, &mut rng) else { continue };
            if store.apply(op).is_err() {
                continue;
            }
            let (result, log) = store.finish();
            assert_eq!(log.len(), 1);
            assert_eq!(log[0].kind(), kind);
            assert_round_trip(&base, &result, &log);
            applied += 1;
        }
        assert!(applied >= 3, "{} applied only {applied} times", kind.name());
    }
}

#[test]
fn empty_logs_and_empty_meshes_round_trip() {
    let base = grid(3, 3, 0, &mut Rng(1));
    assert_round_trip(&base, &base, &[]);
    let empty = MeshData::default();
    assert_round_trip(&empty, &empty, &[]);
    let mut store = MeshStore::new(empty.clone());
    store
        .apply(Op::AddVertices { xyz: vec![1.0, 2.0, 3.0, -0.0, 0.0, f32::MIN_POSITIVE] })
        .unwrap();
    let (result, log) = store.finish();
    assert_round_trip(&empty, &result, &log);
}

#[test]
fn a_log_that_does_not_give_the_result_is_refused() {
    let base = grid(3, 3, 0, &mut Rng(2));
    let log = [Op::RemoveTriangles { ids: vec![0] }];
    let error = correction::encode(&base, &log, &base).unwrap_err();
    assert!(matches!(error, correction::CorrectionError::ResultMismatch { .. }), "{error}");
    // An empty log says the result is the base: any other result is refused.
    let other = grid(3, 3, 1, &mut Rng(2));
    let error = correction::encode(&base, &[], &other).unwrap_err();
    assert!(matches!(error, correction::CorrectionError::ResultMismatch { .. }), "{error}");
    let bad = [Op::RemoveTriangles { ids: vec![999] }];
    let error = correction::encode(&base, &bad, &base).unwrap_err();
    assert!(matches!(error, correction::CorrectionError::Replay { op: 0, .. }), "{error}");
}

/// Removing ~150 spurious components, as `remove-smallest-components` does, in either shape
/// (one remove-component each, or bulk triangle and vertex removals): well under 1 KB.
#[test]
fn removing_150_components_costs_under_a_kilobyte() {
    let base = grid(120, 100, 150, &mut Rng(3));
    let islands = (base.triangle_count() - 150) as u32..base.triangle_count() as u32;

    let mut store = MeshStore::new(base.clone());
    for t in islands.clone() {
        store.apply(Op::RemoveComponent { triangle: t }).unwrap();
    }
    let (result, log) = store.finish();
    let per_component = assert_round_trip(&base, &result, &log).len();

    let mut store = MeshStore::new(base.clone());
    store.apply(Op::RemoveTriangles { ids: islands.collect() }).unwrap();
    let first_island_vertex = base.vertex_count() as u32 - 450;
    store
        .apply(Op::RemoveVertices {
            ids: (first_island_vertex..first_island_vertex + 450).collect(),
        })
        .unwrap();
    let (result, log) = store.finish();
    let bulk = assert_round_trip(&base, &result, &log).len();

    assert!(per_component < 1024 && bulk < 300, "{per_component} B per component, {bulk} B bulk");
}

/// A grid and 20 spurious patches of 5x5 vertices, with vertices and triangles in a random
/// order, as a range scanner interleaves them: the patches' ids are scattered.
fn interleaved_scan(rng: &mut Rng) -> MeshData {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let mut patch = |w: u32, offset: [f32; 3], rng: &mut Rng| {
        let first = (positions.len() / 3) as u32;
        for y in 0..w {
            for x in 0..w {
                let bump = 0.01 * rng.unit();
                positions.extend([
                    offset[0] + x as f32 * 0.1,
                    offset[1] + y as f32 * 0.1,
                    offset[2] + bump,
                ]);
            }
        }
        for y in 0..w - 1 {
            for x in 0..w - 1 {
                let v = first + y * w + x;
                triangles.extend([v, v + 1, v + w + 1, v, v + w + 1, v + w]);
            }
        }
    };
    patch(60, [0.0; 3], rng);
    for i in 0..20 {
        patch(5, [10.0 + i as f32, 0.0, 1.0], rng);
    }
    let vertices = positions.len() / 3;
    let mut order: Vec<u32> = (0..vertices as u32).collect();
    for i in (1..order.len()).rev() {
        order.swap(i, rng.below(i as u32 + 1) as usize);
    }
    // order[new] = old; where[old] = new.
    let mut moved = vec![0.0; positions.len()];
    let mut new_id = vec![0u32; vertices];
    for (new, &old) in order.iter().enumerate() {
        moved[3 * new..3 * new + 3]
            .copy_from_slice(&positions[3 * old as usize..3 * old as usize + 3]);
        new_id[old as usize] = new as u32;
    }
    let mut faces: Vec<[u32; 3]> =
        triangles.chunks_exact(3).map(|t| [t[0], t[1], t[2]].map(|v| new_id[v as usize])).collect();
    for i in (1..faces.len()).rev() {
        faces.swap(i, rng.below(i as u32 + 1) as usize);
    }
    MeshData::new(moved, faces.concat())
}

/// Removing whole components costs bytes per component however their ids lie: the removed
/// triangles as one seed each, the vertices they left unused as one symbol.
#[test]
fn removing_interleaved_components_costs_bytes_per_component() {
    let base = interleaved_scan(&mut Rng(11));
    let mut store = MeshStore::new(base.clone());
    // As `remove-smallest-components` does it: triangles, then the vertices left unused.
    let big_patch_triangles = 2 * 59 * 59;
    let corners_of_small: Vec<u32> = {
        let mut size = std::collections::HashMap::new();
        let labels = component_labels(&base);
        labels.iter().for_each(|&l| *size.entry(l).or_insert(0) += 1);
        let small: Vec<u32> = (0..base.triangle_count() as u32)
            .filter(|&t| size[&labels[t as usize]] < big_patch_triangles)
            .collect();
        assert_eq!(small.len(), 20 * 32);
        store.apply(Op::RemoveTriangles { ids: small.clone() }).unwrap();
        let mut corners: Vec<u32> = small
            .iter()
            .flat_map(|&t| base.triangles[3 * t as usize..3 * t as usize + 3].to_vec())
            .collect();
        corners.sort_unstable();
        corners.dedup();
        corners
    };
    store.apply(Op::RemoveVertices { ids: corners_of_small.clone() }).unwrap();
    let (result, log) = store.finish();
    let bytes = assert_round_trip(&base, &result, &log).len();
    assert!(bytes <= 300, "{bytes} B for 20 interleaved components");

    // The same pieces removed through their vertices alone: one seed each too.
    let mut store = MeshStore::new(base.clone());
    store.apply(Op::RemoveVertices { ids: corners_of_small }).unwrap();
    let (result, log) = store.finish();
    let by_vertices = assert_round_trip(&base, &result, &log).len();
    assert!(by_vertices <= 300, "{by_vertices} B through vertices");

    // A removal that is not a union of components is listed, and still exact.
    let mut store = MeshStore::new(base.clone());
    store.apply(Op::RemoveTriangles { ids: vec![0, 5, 9] }).unwrap();
    store.apply(Op::FlipTriangles { ids: (20..400).collect() }).unwrap();
    let (result, log) = store.finish();
    assert_round_trip(&base, &result, &log);
}

/// Edge-connected component label of each triangle (two shared corners), by union-find.
fn component_labels(mesh: &MeshData) -> Vec<u32> {
    let n = mesh.triangle_count();
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn root(parent: &mut [u32], mut t: u32) -> u32 {
        while parent[t as usize] != t {
            parent[t as usize] = parent[parent[t as usize] as usize];
            t = parent[t as usize];
        }
        t
    }
    let mut by_edge = std::collections::HashMap::new();
    for t in 0..n {
        let c = &mesh.triangles[3 * t..3 * t + 3];
        for k in 0..3 {
            let (a, b) = (c[k].min(c[(k + 1) % 3]), c[k].max(c[(k + 1) % 3]));
            if let Some(&other) = by_edge.get(&(a, b)) {
                let (x, y) = (root(&mut parent, t as u32), root(&mut parent, other));
                parent[x as usize] = y;
            } else {
                by_edge.insert((a, b), t as u32);
            }
        }
    }
    (0..n as u32).map(|t| root(&mut parent, t)).collect()
}

/// One step of plain neighbour averaging (what `laplacian-smoothing` computes) is predicted
/// exactly, so it costs about the "moved" flags; a different factor costs a little more.
/// 22,500 vertices: several chunks for each of the decoder's two predicting threads.
#[test]
fn smoothing_steps_cost_few_bits_per_vertex() {
    let base = grid(150, 150, 0, &mut Rng(4));
    for (lambda, max_bits) in [(1.0f64, 1.0), (0.5, 12.0)] {
        let xyz = smooth(&base, lambda);
        let mut store = MeshStore::new(base.clone());
        store.apply(Op::SetPositions { xyz }).unwrap();
        let (result, log) = store.finish();
        let bytes = assert_round_trip(&base, &result, &log);
        let bits = 8.0 * bytes.len() as f64 / base.vertex_count() as f64;
        assert!(bits < max_bits, "lambda {lambda}: {bits:.2} bits per vertex");
    }
}

#[test]
fn encoding_against_known_hashes_gives_the_same_bytes() {
    let mut rng = Rng(11);
    let base = grid(6, 5, 2, &mut rng);
    let mut store = MeshStore::new(base.clone());
    random_edits(&mut store, &mut rng, 30);
    let (result, log) = store.finish();
    let shared = std::sync::Arc::new(base.clone());
    let (base_hash, result_hash) = (base.content_hash(), result.content_hash());
    let bytes =
        correction::encode_known(shared.clone(), base_hash, &log, &result, result_hash, None)
            .unwrap();
    assert_eq!(bytes, correction::encode(&base, &log, &result).unwrap());
    assert_eq!(correction::apply(shared, &bytes).unwrap().content_hash(), result_hash);
    // A wrong hash is written as given, so every applier refuses the correction.
    let forged = correction::encode_known(
        base.clone().into(),
        result_hash,
        &log,
        &result,
        result_hash,
        None,
    );
    assert!(correction::apply(base.clone(), &forged.unwrap()).is_err());
    let forged =
        correction::encode_known(base.clone().into(), base_hash, &log, &result, base_hash, None);
    assert!(correction::apply(base, &forged.unwrap()).is_err());
}

/// Neighbour means gathered before the log exists (a host does it beside the plugin's run
/// and beside the log's download) give the same bytes and the same result; means of
/// another mesh, or a move of every vertex that is not the log's first op, are not used.
#[test]
fn neighbour_means_gathered_before_give_the_same_bytes_and_result() {
    let mut rng = Rng(12);
    let base = grid(120, 90, 3, &mut rng);
    let other = grid(120, 90, 3, &mut rng);
    let (base_hash, other_hash) = (base.content_hash(), other.content_hash());
    let prepared = correction::NeighbourMeans::of(&base, base_hash);
    let on_one_thread = correction::NeighbourMeans::beside(&base, base_hash);
    // Means of another mesh under this mesh's name: used, they would decode wrong.
    let misnamed = correction::NeighbourMeans::of(&other, base_hash);
    let of_other = correction::NeighbourMeans::of(&other, other_hash);
    // A smoothing step, alone or after one vertex moved (the means then differ from the
    // base's around it).
    let smoothed = |moved_first: bool| {
        let mut store = MeshStore::new(base.clone());
        if moved_first {
            store.apply(Op::MoveVertices { ids: vec![500], xyz: vec![0.5, 0.5, 2.0] }).unwrap();
        }
        store.apply(Op::SetPositions { xyz: smooth(&base, 1.0) }).unwrap();
        store.finish()
    };
    for moved_first in [false, true] {
        let (result, log) = smoothed(moved_first);
        let result_hash = result.content_hash();
        let plain = correction::encode(&base, &log, &result).unwrap();
        for means in [&prepared, &on_one_thread, &of_other] {
            let shared = std::sync::Arc::new(base.clone());
            let encoded = correction::encode_known(
                shared,
                base_hash,
                &log,
                &result,
                result_hash,
                Some(means),
            );
            assert_eq!(encoded.unwrap(), plain, "moved first: {moved_first}");
            let applied =
                correction::apply_known(base.clone(), base_hash, &plain, result_hash, Some(means));
            assert_eq!(applied.unwrap(), result, "moved first: {moved_first}");
        }
        if !moved_first {
            let applied = correction::apply_known(
                base.clone(),
                base_hash,
                &plain,
                result_hash,
                Some(&misnamed),
            );
            assert!(applied.is_err(), "misnamed means decode another result");
        }
    }
}
