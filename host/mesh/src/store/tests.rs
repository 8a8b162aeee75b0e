use super::*;

/// Two triangles sharing edge 0-2, a third one attached at vertex 2..3, and a separate
/// triangle 5-6-7 (a second component).
///
/// ```text
/// 3 --- 2        7
/// |   / | \      | \
/// | /   |  4     5--6
/// 0 --- 1
/// ```
fn sample() -> MeshData {
    MeshData::new(
        vec![
            0.0, 0.0, 0.0, // 0
            1.0, 0.0, 0.0, // 1
            1.0, 1.0, 0.0, // 2
            0.0, 1.0, 0.0, // 3
            2.0, 0.5, 0.0, // 4
            5.0, 0.0, 0.0, // 5
            6.0, 0.0, 0.0, // 6
            5.0, 1.0, 0.0, // 7
        ],
        vec![0, 1, 2, 0, 2, 3, 1, 4, 2, 5, 6, 7],
    )
}

fn store() -> MeshStore {
    MeshStore::new(sample())
}

fn kind_of(result: Result<Option<u32>, EditError>) -> EditErrorKind {
    result.expect_err("the edit must be refused").kind
}

/// A refused edit must leave no trace: same data, same log.
fn assert_refused(op: Op, expected: EditErrorKind) {
    let mut s = store();
    s.apply(Op::MoveVertices { ids: vec![0], xyz: vec![0.5, 0.5, 0.5] }).unwrap();
    let (positions, triangles, log) =
        (s.positions().to_vec(), s.triangles().to_vec(), s.log.clone());
    assert_eq!(kind_of(s.apply(op.clone())), expected, "{op:?}");
    assert_eq!(s.positions(), positions, "{op:?} changed positions");
    assert_eq!(s.triangles(), triangles, "{op:?} changed triangles");
    assert_eq!(s.log, log, "{op:?} was logged");
}

fn replay(base: MeshData, log: &[Op]) -> MeshData {
    let mut s = MeshStore::new(base);
    for op in log {
        s.apply(op.clone()).unwrap();
    }
    s.finish().0
}

#[test]
fn every_edit_kind_validates_its_arguments() {
    use EditErrorKind::*;
    let cases = [
        (Op::AddVertices { xyz: vec![1.0, 2.0] }, InvalidArgument),
        (Op::AddVertices { xyz: vec![1.0, f32::NAN, 0.0] }, InvalidArgument),
        (Op::MoveVertices { ids: vec![8], xyz: vec![0.0; 3] }, InvalidVertex),
        (Op::MoveVertices { ids: vec![1, 2], xyz: vec![0.0; 3] }, InvalidArgument),
        (Op::MoveVertices { ids: vec![1], xyz: vec![f32::INFINITY, 0.0, 0.0] }, InvalidArgument),
        (Op::SetPositions { xyz: vec![0.0; 3] }, InvalidArgument),
        (Op::RemoveVertices { ids: vec![1, 99] }, InvalidVertex),
        (Op::RemoveVertices { ids: vec![1, 1] }, InvalidArgument),
        (Op::AddTriangles { abc: vec![0, 1] }, InvalidArgument),
        (Op::AddTriangles { abc: vec![0, 1, 3, 0, 1, 1] }, RepeatedVertex),
        (Op::AddTriangles { abc: vec![0, 1, 42] }, InvalidVertex),
        (Op::RemoveTriangles { ids: vec![4] }, InvalidTriangle),
        (Op::RemoveTriangles { ids: vec![0, 0] }, InvalidArgument),
        (Op::FlipTriangles { ids: vec![0, 7] }, InvalidTriangle),
        (Op::SplitTriangle { triangle: 9, at: None }, InvalidTriangle),
        (Op::SplitTriangle { triangle: 0, at: Some([f32::NAN, 0.0, 0.0]) }, InvalidArgument),
        (Op::ExtendEdge { edge: 40, vertex: 3 }, InvalidEdge),
        (Op::ExtendEdge { edge: 0, vertex: 1 }, RepeatedVertex),
        (Op::ExtendEdge { edge: 0, vertex: 100 }, InvalidVertex),
        (Op::SplitEdge { edge: 12, at: None }, InvalidEdge),
        (Op::SplitEdge { edge: 0, at: Some([0.0, f32::NEG_INFINITY, 0.0]) }, InvalidArgument),
        // Edge 0 -> 1 is on the boundary: one triangle.
        (Op::SwapEdge { edge: 0 }, NotApplicable),
        (Op::CollapseEdge { edge: 99 }, InvalidEdge),
        (Op::RemoveComponent { triangle: 4 }, InvalidTriangle),
        (Op::TransformComponent { triangle: 5, matrix: [0.0; 12] }, InvalidTriangle),
        (Op::Transform { matrix: [f32::NAN; 12] }, InvalidArgument),
        (
            Op::Transform {
                matrix: [f32::MAX, 0.0, 0.0, f32::MAX, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0],
            },
            InvalidArgument,
        ),
    ];
    for (op, kind) in cases {
        assert_refused(op, kind);
    }
}

/// NaN canonicalisation is off in the sandbox (DESIGN §8), so a plugin can hand the store
/// any NaN bit pattern: every op that carries a coordinate must refuse each of them.
#[test]
fn every_edit_that_carries_coordinates_refuses_non_finite_values() {
    let payload_nan = f32::from_bits(0xffc0_1234);
    for bad in [f32::NAN, payload_nan, f32::INFINITY, f32::NEG_INFINITY] {
        let point = [0.5, bad, 0.5];
        let mut matrix = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        matrix[3] = bad;
        let mut all = store().positions().to_vec();
        all[4] = bad;
        let ops = [
            Op::AddVertices { xyz: point.to_vec() },
            Op::MoveVertices { ids: vec![2], xyz: point.to_vec() },
            Op::SetPositions { xyz: all },
            Op::SplitTriangle { triangle: 0, at: Some(point) },
            Op::SplitEdge { edge: 1, at: Some(point) },
            Op::TransformComponent { triangle: 3, matrix },
            Op::Transform { matrix },
        ];
        for op in ops {
            assert_refused(op, EditErrorKind::InvalidArgument);
        }
    }
}

#[test]
fn a_non_finite_coordinate_is_named_by_its_axis() {
    let message = |op| store().apply(op).unwrap_err().to_string();
    let at = Some([0.5, f32::NAN, 0.5]);
    assert!(message(Op::SplitEdge { edge: 1, at }).contains("split-edge: y is NaN"));
    let xyz = vec![0.0, 0.0, 0.0, 0.0, 0.0, f32::INFINITY];
    let moved = message(Op::AddVertices { xyz });
    assert!(moved.contains("add-vertices: point 1's z is inf"), "{moved}");
}

#[test]
fn removed_elements_refuse_further_edits() {
    let mut s = store();
    s.apply(Op::RemoveTriangles { ids: vec![1] }).unwrap();
    s.apply(Op::RemoveVertices { ids: vec![4] }).unwrap();
    assert_eq!(
        kind_of(s.apply(Op::FlipTriangles { ids: vec![1] })),
        EditErrorKind::InvalidTriangle
    );
    assert_eq!(kind_of(s.apply(Op::SplitEdge { edge: 3, at: None })), EditErrorKind::InvalidEdge);
    assert_eq!(
        kind_of(s.apply(Op::MoveVertices { ids: vec![4], xyz: vec![0.0; 3] })),
        EditErrorKind::InvalidVertex
    );
    assert!(s.position(4).unwrap_err().message.contains("removed"));
    // Removing vertex 4 took triangle 2 with it.
    assert!(!s.is_triangle_live(2));
    assert_eq!(s.triangles()[6..9], [REMOVED; 3]);
}

#[test]
fn compaction_keeps_survivor_order_and_remaps_corners() {
    let mut s = store();
    s.apply(Op::RemoveVertices { ids: vec![3] }).unwrap(); // takes triangle 1
    s.apply(Op::AddVertices { xyz: vec![9.0, 9.0, 9.0] }).unwrap(); // vertex 8
    s.apply(Op::AddTriangles { abc: vec![4, 8, 2] }).unwrap();
    let (mesh, _) = s.finish();
    assert_eq!(mesh.vertex_count(), 8);
    assert_eq!(&mesh.positions[9..12], &[2.0, 0.5, 0.0]); // old 4 is new 3
    assert_eq!(&mesh.positions[21..24], &[9.0, 9.0, 9.0]); // old 8 is new 7
    assert_eq!(mesh.triangles, vec![0, 1, 2, 1, 3, 2, 4, 5, 6, 3, 7, 2]);
}

#[test]
fn same_edits_in_two_stores_give_the_same_bytes_and_hash() {
    let edits = vec![
        Op::SplitTriangle { triangle: 0, at: None },
        Op::SplitEdge { edge: 5, at: None },
        Op::CollapseEdge { edge: 12 },
        Op::RemoveComponent { triangle: 3 },
        Op::Transform { matrix: [2.0, 0.0, 0.0, 1.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0, -1.0] },
    ];
    let run = || {
        let mut s = store();
        for op in edits.clone() {
            s.apply(op).unwrap();
        }
        s.finish()
    };
    let (a, log_a) = run();
    let (b, log_b) = run();
    assert_eq!(a, b);
    assert_eq!(a.content_hash(), b.content_hash());
    assert_eq!(log_a, log_b);
    // Replaying the log through a third store reproduces the same state.
    assert_eq!(replay(sample(), &log_a).content_hash(), a.content_hash());
}

#[test]
fn split_triangle_puts_the_vertex_at_the_centroid_and_keeps_orientation() {
    let mut s = store();
    let v = s.apply(Op::SplitTriangle { triangle: 0, at: None }).unwrap().unwrap();
    assert_eq!(v, 8);
    assert_eq!(s.position(8).unwrap(), [(0.0 + 1.0 + 1.0) / 3.0, (0.0 + 0.0 + 1.0) / 3.0, 0.0]);
    assert_eq!(s.triangle(0).unwrap(), [0, 1, 8]);
    assert_eq!(s.triangle(4).unwrap(), [1, 2, 8]);
    assert_eq!(s.triangle(5).unwrap(), [2, 0, 8]);
}

#[test]
fn split_edge_splits_both_triangles_on_an_interior_edge() {
    let mut s = store();
    // Half-edge 2 of triangle 0 runs 2 -> 0, shared with triangle 1 (0, 2, 3).
    let v = s.apply(Op::SplitEdge { edge: 2, at: None }).unwrap().unwrap();
    assert_eq!(s.position(v).unwrap(), [0.5, 0.5, 0.0]);
    assert_eq!(s.triangle_count(), 6);
    assert_eq!(s.triangle(0).unwrap(), [v, 1, 2]);
    assert_eq!(s.triangle(1).unwrap(), [0, v, 3]);
    assert_eq!(s.triangle(4).unwrap(), [v, 0, 1]);
    assert_eq!(s.triangle(5).unwrap(), [v, 2, 3]);
}

#[test]
fn swap_edge_turns_the_diagonal() {
    let mut s = store();
    // Half-edge 2 runs 2 -> 0, shared by (0, 1, 2) and (0, 2, 3): the new diagonal is 1-3,
    // and each triangle keeps the slot of its edge's start.
    s.apply(Op::SwapEdge { edge: 2 }).unwrap();
    assert_eq!(s.triangle(0).unwrap(), [3, 1, 2]);
    assert_eq!(s.triangle(1).unwrap(), [0, 1, 3]);
    // Swapping back is refused only if the old diagonal came back some other way: here it
    // is free again, so the swap is its own inverse up to rotation.
    s.apply(Op::SwapEdge { edge: 0 }).unwrap();
    assert_eq!(s.triangle(0).unwrap(), [3, 0, 2]);
    assert_eq!(s.triangle(1).unwrap(), [0, 1, 2]);
}

#[test]
fn collapse_edge_merges_the_end_into_the_start() {
    let mut s = store();
    // Half-edge 0: 0 -> 1. Triangle 0 has both ends and goes; triangle 2 (1, 4, 2) becomes (0, 4, 2).
    s.apply(Op::CollapseEdge { edge: 0 }).unwrap();
    assert!(!s.is_vertex_live(1));
    assert!(!s.is_triangle_live(0));
    assert_eq!(s.triangle(2).unwrap(), [0, 4, 2]);
    assert_eq!(s.position(0).unwrap(), [0.0, 0.0, 0.0]);
}

#[test]
fn extend_edge_adds_the_neighbour_oriented_alike() {
    let mut s = store();
    let t = s.apply(Op::ExtendEdge { edge: 0, vertex: 7 }).unwrap().unwrap();
    assert_eq!(s.triangle(t).unwrap(), [1, 0, 7]);
}

#[test]
fn remove_component_takes_its_unused_vertices_only() {
    let mut s = store();
    s.apply(Op::RemoveComponent { triangle: 3 }).unwrap();
    assert_eq!(s.triangle_count(), 3);
    assert_eq!(s.removed_vertices(), vec![5, 6, 7]);
    let mut s = store();
    s.apply(Op::RemoveComponent { triangle: 0 }).unwrap();
    assert_eq!(s.triangle_count(), 1);
    assert_eq!(s.removed_vertices(), vec![0, 1, 2, 3, 4]);
}

#[test]
fn components_list_live_pieces_by_first_triangle_and_remove_component_takes_them() {
    let mut s = store();
    let component = |first_triangle, triangles| Component { first_triangle, triangles };
    assert_eq!(s.components(), [component(0, 3), component(3, 1)]);
    // A triangle touching the pieces at vertices only (3, 4 and 5) is a piece of its own.
    let t = s.apply(Op::AddTriangles { abc: vec![4, 5, 3] }).unwrap().unwrap();
    assert_eq!(s.components(), [component(0, 3), component(3, 1), component(t, 1)]);
    s.apply(Op::RemoveTriangles { ids: vec![0] }).unwrap();
    // Triangle 0 gone, triangles 1 and 2 share no edge any more.
    assert_eq!(
        s.components(),
        [component(1, 1), component(2, 1), component(3, 1), component(t, 1)]
    );
    s.apply(Op::RemoveComponent { triangle: 3 }).unwrap();
    assert_eq!(s.components(), [component(1, 1), component(2, 1), component(t, 1)]);
}

#[test]
fn transform_component_moves_only_that_component() {
    let mut s = store();
    let shift = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 3.0];
    s.apply(Op::TransformComponent { triangle: 3, matrix: shift }).unwrap();
    assert_eq!(s.position(5).unwrap(), [5.0, 0.0, 3.0]);
    assert_eq!(s.position(0).unwrap(), [0.0, 0.0, 0.0]);
}

#[test]
fn set_positions_ignores_and_records_no_values_for_removed_slots() {
    let mut s = store();
    s.apply(Op::RemoveVertices { ids: vec![7] }).unwrap();
    let mut xyz = s.positions().to_vec();
    xyz.iter_mut().for_each(|x| *x += 1.0);
    xyz[21] = f32::NAN; // vertex 7 is removed: its value is ignored
    s.apply(Op::SetPositions { xyz }).unwrap();
    assert_eq!(s.positions()[21], 5.0);
    let Some(Op::SetPositions { xyz }) = s.log().last() else { panic!("not logged") };
    assert_eq!(xyz[21], 5.0);
    assert_eq!(xyz[0], 1.0);
}

#[test]
fn clear_leaves_an_empty_mesh() {
    let mut s = store();
    s.apply(Op::SplitTriangle { triangle: 0, at: None }).unwrap();
    s.apply(Op::Clear).unwrap();
    assert_eq!((s.vertex_count(), s.triangle_count()), (0, 0));
    assert_eq!(s.finish().0, MeshData::default());
}

#[test]
fn single_edits_are_merged_into_bulk_ops_in_the_log() {
    let mut s = store();
    for i in 0..3 {
        s.apply(Op::AddVertices { xyz: vec![i as f32, 0.0, 0.0] }).unwrap();
    }
    s.apply(Op::RemoveTriangles { ids: vec![0] }).unwrap();
    s.apply(Op::RemoveTriangles { ids: vec![1] }).unwrap();
    assert_eq!(
        s.log(),
        &[
            Op::AddVertices { xyz: vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 2.0, 0.0, 0.0] },
            Op::RemoveTriangles { ids: vec![0, 1] },
        ]
    );
}

#[test]
fn degenerate_input_triangles_load_but_cannot_be_created() {
    let mesh = MeshData::new(vec![0.0; 9], vec![0, 0, 1, 0, 1, 2]);
    let mut s = MeshStore::new(mesh);
    assert_eq!(
        kind_of(s.apply(Op::SplitTriangle { triangle: 0, at: None })),
        EditErrorKind::NotApplicable
    );
    // Removing the vertex takes the degenerate triangle with it exactly once.
    s.apply(Op::RemoveVertices { ids: vec![0] }).unwrap();
    assert_eq!(s.triangle_count(), 0);
}

#[test]
fn shared_slots_show_the_slots_as_they_were_when_taken() {
    let mut s = store();
    s.apply(Op::RemoveTriangles { ids: vec![1] }).unwrap();
    let taken = s.shared_slots();
    assert!(std::ptr::eq(&taken.triangles[..], s.triangles()), "taking them copies nothing");
    assert_eq!(taken.triangles[3..6], [REMOVED; 3], "tombstones included");

    s.apply(Op::MoveVertices { ids: vec![0], xyz: vec![0.5, 0.5, 0.5] }).unwrap();
    assert_eq!(taken.positions[..3], [0.0; 3], "an edit while they are held does not reach them");
    assert_eq!(s.positions()[..3], [0.5; 3]);
    drop(taken);
    let before = s.positions().as_ptr();
    s.apply(Op::MoveVertices { ids: vec![1], xyz: vec![0.5, 0.5, 0.5] }).unwrap();
    assert_eq!(s.positions().as_ptr(), before, "once dropped, edits copy nothing");
}

#[test]
fn a_shared_mesh_is_read_in_place_and_copied_on_the_first_edit() {
    let shared = Arc::new(sample());
    let reader = MeshStore::new(Arc::clone(&shared));
    assert!(std::ptr::eq(reader.positions(), &shared.positions[..]), "reads copy nothing");
    assert_eq!(reader.finish().0, *shared);

    let mut editor = MeshStore::new(Arc::clone(&shared));
    editor.apply(Op::RemoveTriangles { ids: vec![3] }).unwrap();
    editor.apply(Op::MoveVertices { ids: vec![0], xyz: vec![0.5, 0.5, 0.5] }).unwrap();
    let (edited, _) = editor.finish();
    assert_eq!(edited.triangle_count(), 3);
    assert_eq!(*shared, sample(), "the caller's mesh is untouched by the edits");

    // Moving every vertex at once replaces the shared positions rather than editing them.
    let mut smoother = MeshStore::new(Arc::clone(&shared));
    let moved: Vec<f32> = shared.positions.iter().map(|x| x + 1.0).collect();
    smoother.apply(Op::SetPositions { xyz: moved.clone() }).unwrap();
    let (smoothed, _) = smoother.finish();
    assert_eq!((smoothed.positions, smoothed.triangles), (moved, shared.triangles.clone()));
    assert_eq!(*shared, sample(), "the caller's mesh is untouched by set-positions");
}

#[test]
fn triangles_around_read_the_same_scanned_as_from_the_index() {
    // The sample with a triangle repeating vertex 2 (as raw input may have), then one removed.
    let mut mesh = sample();
    mesh.triangles.extend([2, 4, 2]);
    let mut scanned = MeshStore::new(mesh.clone());
    scanned.apply(Op::RemoveTriangles { ids: vec![1] }).unwrap();
    let vertices = 0..mesh.vertex_count() as u32;
    assert!(vertices.len() <= SCANS_BEFORE_INDEX, "every query below is a scan");
    let by_scan: Vec<Vec<u32>> = vertices.clone().map(|v| scanned.triangles_around(v)).collect();
    assert!(scanned.incidence.is_none());

    let mut indexed = MeshStore::new(mesh);
    indexed.apply(Op::RemoveTriangles { ids: vec![1] }).unwrap();
    indexed.incidence();
    let by_index: Vec<Vec<u32>> = vertices.map(|v| indexed.triangles_around(v)).collect();
    assert_eq!(by_scan, by_index);
    assert_eq!(
        by_scan[2],
        [0, 2, 4],
        "the removed triangle is gone, the repeating one listed once"
    );

    // Past the limit the store builds the index and keeps answering the same.
    for _ in 0..SCANS_BEFORE_INDEX {
        scanned.triangles_around(0);
    }
    assert!(scanned.incidence.is_some());
    assert_eq!(scanned.triangles_around(2), [0, 2, 4]);
}

#[test]
fn a_scan_of_a_large_mesh_finds_what_the_index_finds() {
    // 162 triangles: ten whole blocks of the scan and two triangles after them, the last
    // repeating a vertex, and one removed inside a block.
    let (positions, mut triangles) = meshflow_topology::shapes::square_grid(9);
    triangles.extend([40, 41, 40]);
    let mesh = MeshData::new(positions, triangles);
    let mut scanned = MeshStore::new(mesh.clone());
    scanned.apply(Op::RemoveTriangles { ids: vec![17] }).unwrap();
    let mut indexed = MeshStore::new(mesh.clone());
    indexed.apply(Op::RemoveTriangles { ids: vec![17] }).unwrap();
    indexed.incidence();
    for v in 0..mesh.vertex_count() as u32 {
        assert_eq!(scan_around(scanned.triangles(), v), indexed.triangles_around(v), "vertex {v}");
    }
    assert_eq!(scan_around(scanned.triangles(), 40).last(), Some(&162));
}
