//! Corrections replay bit-exactly: random edit sequences of every kind, each kind alone,
//! and the size of the shapes the in-house services produce.

mod correction_common;

use correction_common::{Rng, grid, random_edits, random_op};
use meshflow_host::MeshData;
use meshflow_host::correction;
use meshflow_host::store::{MeshStore, Op, OpKind};
use proptest::prelude::*;

/// Encodes the step, applies it to the base, and checks hash, bytes and the replayed log.
fn assert_round_trip(base: &MeshData, result: &MeshData, log: &[Op]) -> Vec<u8> {
    let bytes = correction::encode(base, log, result).expect("a store's own log encodes");
    let (replayed, replayed_log) = correction::replay(base, &bytes).expect("applies");
    assert_eq!(replayed.content_hash(), result.content_hash());
    assert_eq!(bits(&replayed.positions), bits(&result.positions));
    assert_eq!(replayed.triangles, result.triangles);
    assert_eq!(ops_bits(&replayed_log), ops_bits(log));
    let header = correction::decode(&bytes).unwrap();
    assert_eq!(header.base, base.content_hash());
    assert_eq!(header.result, result.content_hash());
    assert_eq!(header.op_count(), log.len() as u64);
    assert_eq!(header.total_bytes(), bytes.len());
    bytes
}

fn bits(values: &[f32]) -> Vec<u32> {
    values.iter().map(|v| v.to_bits()).collect()
}

/// The log with floats as bit patterns, so `-0.0 != 0.0` and equality is exact.
fn ops_bits(log: &[Op]) -> String {
    format!("{:?}", log.iter().map(|op| format!("{op:?}")).collect::<Vec<_>>())
}

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
#[test]
fn smoothing_steps_cost_few_bits_per_vertex() {
    let base = grid(60, 60, 0, &mut Rng(4));
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

/// Uniform Laplacian smoothing with factor `lambda`, interior vertices only, in f64 over
/// sorted distinct neighbours.
fn smooth(mesh: &MeshData, lambda: f64) -> Vec<f32> {
    let n = mesh.vertex_count();
    let mut neighbours = vec![Vec::new(); n];
    let mut edge_uses = std::collections::HashMap::new();
    for t in mesh.triangles.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (t[k], t[(k + 1) % 3]);
            neighbours[a as usize].extend([b, t[(k + 2) % 3]]);
            *edge_uses.entry((a.min(b), a.max(b))).or_insert(0) += 1;
        }
    }
    let mut boundary = vec![false; n];
    for ((a, b), uses) in edge_uses {
        if uses == 1 {
            boundary[a as usize] = true;
            boundary[b as usize] = true;
        }
    }
    let mut out = mesh.positions.clone();
    for v in 0..n {
        let list = &mut neighbours[v];
        list.sort_unstable();
        list.dedup();
        if boundary[v] || list.is_empty() {
            continue;
        }
        for k in 0..3 {
            let sum: f64 =
                list.iter().map(|&u| f64::from(mesh.positions[3 * u as usize + k])).sum();
            let mean = sum * (1.0 / list.len() as f64);
            let p = f64::from(mesh.positions[3 * v + k]);
            out[3 * v + k] = (mean * lambda + p * (1.0 - lambda)) as f32;
        }
    }
    out
}
