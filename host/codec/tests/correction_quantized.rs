//! Grid quantisation at ingest: steps stay on the grid once the host snaps them, and both
//! corrections and packed meshes code coordinates as grid steps, bit-exactly and smaller.

mod correction_common;

use correction_common::{Rng, assert_round_trip, random_edits, smooth};
use meshflow_codec::quantize::{self, Grid};
use meshflow_codec::{correction, pack};
use meshflow_generate::{ScanSpec, scan};
use meshflow_mesh::MeshData;
use meshflow_mesh::store::{MeshStore, Op};

fn scan_mesh() -> MeshData {
    scan(&ScanSpec { vertices: 20_000, components: 4, holes: 3, noise: 0.2, seed: 5 })
}

/// One smoothing step (interior vertices), as the host records it: plain neighbour
/// averaging when `uniform`, else a factor that varies per vertex (as geometric weights do),
/// which no single factor predicts.
fn smoothing_step(base: &MeshData, uniform: bool) -> (MeshData, Vec<Op>) {
    let mut xyz = smooth(base, 1.0);
    if !uniform {
        for (v, (q, p)) in xyz.chunks_exact_mut(3).zip(base.positions.chunks_exact(3)).enumerate() {
            let lambda = 0.3 + 0.4 * (v as f64 * 0.618_034).fract();
            for k in 0..3 {
                let (p, q0) = (f64::from(p[k]), f64::from(q[k]));
                q[k] = (p + lambda * (q0 - p)) as f32;
            }
        }
    }
    let mut store = MeshStore::new(base.clone());
    store.apply(Op::SetPositions { xyz }).unwrap();
    store.finish()
}

#[test]
fn smoothing_a_quantised_mesh_stays_on_the_grid_and_its_correction_is_smaller() {
    let original = scan_mesh();
    let mut quantised = original.clone();
    let grid = quantize::quantize(&mut quantised, 12).unwrap();
    assert!(grid.holds(&quantised.positions));
    assert!(!grid.holds(&original.positions));

    for uniform in [true, false] {
        let (result, log) = smoothing_step(&original, uniform);
        let float_bytes = assert_round_trip(&original, &result, &log);
        assert_eq!(correction::decode(&float_bytes).unwrap().grid, None);

        let (result, log) = smoothing_step(&quantised, uniform);
        assert!(!grid.holds(&result.positions), "smoothing leaves the grid");
        let (result, log) = quantize::snap_step(&grid, &quantised, result, log).unwrap();
        assert!(grid.holds(&result.positions));
        assert_eq!(log.len(), 1, "the smoothing step's own set-positions is snapped");
        let grid_bytes = assert_round_trip(&quantised, &result, &log);
        let header = correction::decode(&grid_bytes).unwrap();
        let detected = header.grid.expect("the correction codes grid steps");
        assert!(detected.holds(&result.positions));

        // Plain averaging is predicted exactly either way (a few bits a vertex, plus 3 B of
        // grid in the header); varying factors are not, and then grid steps are far cheaper
        // than float residuals.
        let bound = if uniform { float_bytes.len() + 8 } else { float_bytes.len() / 2 };
        assert!(
            grid_bytes.len() < bound,
            "uniform {uniform}: {} B on the grid, {} B on floats",
            grid_bytes.len(),
            float_bytes.len()
        );
    }
}

#[test]
fn random_steps_on_a_quantised_mesh_snap_back_and_replay_bit_exactly() {
    for seed in 0..24 {
        let mut rng = Rng(seed);
        let mut base = correction_common::grid(7, 6, 2, &mut rng);
        let grid = quantize::quantize(&mut base, 8).unwrap();
        let mut store = MeshStore::new(base.clone());
        random_edits(&mut store, &mut rng, 12);
        let (result, log) = store.finish();
        let (result, log) = quantize::snap_step(&grid, &base, result, log).unwrap();
        assert!(grid.holds(&result.positions), "seed {seed}");
        let bytes = assert_round_trip(&base, &result, &log);
        let header = correction::decode(&bytes).unwrap();
        if result.vertex_count() > 0 {
            assert!(header.grid.is_some(), "seed {seed}: a grid mesh is coded on its grid");
        }
    }
}

#[test]
fn quantised_meshes_pack_smaller_and_unpack_bit_exactly() {
    let original = scan_mesh();
    let mut quantised = original.clone();
    quantize::quantize(&mut quantised, 12).unwrap();
    let (float_packed, grid_packed) =
        (pack::encode(&original).unwrap(), pack::encode(&quantised).unwrap());
    assert_eq!(pack::decode(&grid_packed).unwrap(), quantised);
    assert_eq!(pack::decode(&float_packed).unwrap(), original);
    assert!(
        grid_packed.len() < float_packed.len() * 3 / 4,
        "{} B quantised, {} B float",
        grid_packed.len(),
        float_packed.len()
    );
}

/// A grid is only detected when every coordinate lies on it: one `-0.0` (on no grid) is
/// enough to fall back to float residuals, still losslessly.
#[test]
fn detection_ignores_meshes_with_a_single_off_grid_coordinate() {
    let mut mesh = scan_mesh();
    quantize::quantize(&mut mesh, 10).unwrap();
    assert!(Grid::detect([&mesh.positions[..]]).is_some());
    mesh.positions[7] = -0.0;
    assert_eq!(Grid::detect([&mesh.positions[..]]), None);
    assert_eq!(pack::decode(&pack::encode(&mesh).unwrap()).unwrap(), mesh);
}
