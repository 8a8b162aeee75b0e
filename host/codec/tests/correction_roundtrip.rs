//! Corrections replay bit-exactly: random edit sequences of every kind, each kind alone,
//! and the size of the shapes the in-house services produce.

mod correction_common;

use correction_common::{Rng, assert_round_trip, grid, random_edits, random_op, smooth};
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
    ) {
        let mut rng = Rng(seed);
        let base = grid(w, h, islands, &mut rng);
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
fn encoding_against_a_known_base_gives_the_same_bytes_and_the_result_hash() {
    let mut rng = Rng(11);
    let base = grid(6, 5, 2, &mut rng);
    let mut store = MeshStore::new(base.clone());
    random_edits(&mut store, &mut rng, 30);
    let (result, log) = store.finish();
    let shared = std::sync::Arc::new(base.clone());
    let (bytes, hash) =
        correction::encode_known(shared.clone(), base.content_hash(), &log, &result).unwrap();
    assert_eq!(bytes, correction::encode(&base, &log, &result).unwrap());
    assert_eq!(hash, result.content_hash());
    assert_eq!(correction::apply(shared, &bytes).unwrap().content_hash(), hash);
    // A wrong base hash is written as given, so every applier refuses the correction.
    let (forged, _) = correction::encode_known(base.clone().into(), hash, &log, &result).unwrap();
    assert!(correction::apply(base, &forged).is_err());
}
