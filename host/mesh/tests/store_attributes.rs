//! Attributes through the store's edits: kept bit for bit where a step did not touch them,
//! interpolated between parents where it made something new, and replayed to the same hash.

use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Attribute, Attributes, Domain, Values};
use meshflow_mesh::store::{MeshStore, Op};

/// A 3 × 3 grid of vertices (8 triangles) with colour, quality, normals, a face label and
/// per-corner texture coordinates.
fn grid() -> MeshData {
    let mut positions = Vec::new();
    for y in 0..3 {
        for x in 0..3 {
            positions.extend([x as f32, y as f32, 0.0]);
        }
    }
    let mut triangles = Vec::new();
    for y in 0..2u32 {
        for x in 0..2u32 {
            let v = 3 * y + x;
            triangles.extend([v, v + 1, v + 4, v, v + 4, v + 3]);
        }
    }
    let (vertices, faces) = (9, 8);
    let mut attributes = Attributes::default();
    let color: Vec<u8> = (0..9).flat_map(|v| [10 * v as u8, 100, 200 - v as u8, 255]).collect();
    let quality: Vec<f32> = (0..9).map(|v| v as f32 * 0.5).collect();
    let normal: Vec<f32> = (0..9).flat_map(|_| [0.0, 0.0, 1.0]).collect();
    let texcoord: Vec<f32> = triangles
        .iter()
        .flat_map(|&v| [positions[3 * v as usize] / 2.0, positions[3 * v as usize + 1] / 2.0])
        .collect();
    let label = Attribute {
        domain: Domain::Face,
        name: "label".into(),
        components: 1,
        values: Values::I32((0..faces as i32).collect()),
    };
    for a in [
        Attribute::color(color),
        Attribute::quality(quality),
        Attribute::normal(normal),
        Attribute::texcoord(Domain::Corner, texcoord),
        label,
    ] {
        attributes.insert(a, vertices, faces).unwrap();
    }
    MeshData::new(positions, triangles).with_attributes(attributes).unwrap()
}

fn values(mesh: &MeshData, domain: Domain, name: &str) -> Values {
    mesh.attributes.get(domain, name).unwrap().values.clone()
}

fn f32s(v: Values) -> Vec<f32> {
    match v {
        Values::F32(v) => v,
        other => panic!("not f32: {other:?}"),
    }
}

fn run(mesh: &MeshData, ops: Vec<Op>) -> MeshData {
    let mut store = MeshStore::new(mesh.clone());
    for op in ops {
        store.apply(op).unwrap();
    }
    let (result, log) = store.finish();
    // Replaying the log reaches the same state, attributes included.
    let mut replay = MeshStore::new(mesh.clone());
    for op in log {
        replay.apply(op).unwrap();
    }
    assert_eq!(replay.finish().0.content_hash(), result.content_hash());
    result.attributes.check(result.vertex_count(), result.triangle_count()).unwrap();
    result
}

#[test]
fn a_moved_vertex_keeps_colour_and_quality_and_only_normals_around_it_change() {
    let mesh = grid();
    let out = run(&mesh, vec![Op::MoveVertices { ids: vec![4], xyz: vec![1.0, 1.0, 0.5] }]);
    assert_eq!(values(&out, Domain::Vertex, "color"), values(&mesh, Domain::Vertex, "color"));
    assert_eq!(values(&out, Domain::Vertex, "quality"), values(&mesh, Domain::Vertex, "quality"));
    let (before, after) = (
        f32s(values(&mesh, Domain::Vertex, "normal")),
        f32s(values(&out, Domain::Vertex, "normal")),
    );
    // Vertex 4 is the centre: every vertex shares a triangle with it, except none here; its
    // own normal stays upright by symmetry, its neighbours' tilt.
    assert!((after[3 * 4 + 2] - 1.0).abs() < 1e-6);
    let tilted = (0..9).filter(|&v| after[3 * v..3 * v + 3] != before[3 * v..3 * v + 3]).count();
    assert!(tilted >= 4, "{tilted} normals changed");
    for v in 0..9 {
        let n = &after[3 * v..3 * v + 3];
        let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        assert!((length - 1.0).abs() < 1e-5, "normal {v} has length {length}");
    }
}

#[test]
fn normals_of_vertices_a_step_did_not_touch_stay_bit_for_bit() {
    let mut mesh = grid();
    // Normals as a scanner wrote them: not what the geometry says.
    let odd: Vec<f32> = (0..9).flat_map(|v| [0.1 * v as f32, 0.0, 0.99]).collect();
    mesh.attributes.insert(Attribute::normal(odd.clone()), 9, 8).unwrap();
    let out = run(&mesh, vec![Op::MoveVertices { ids: vec![0], xyz: vec![0.0, 0.0, 0.3] }]);
    let after = f32s(values(&out, Domain::Vertex, "normal"));
    // Vertex 0's triangles are (0, 1, 4) and (0, 4, 3): only 0, 1, 3, 4 are recomputed.
    for v in [2, 5, 6, 7, 8] {
        assert_eq!(after[3 * v..3 * v + 3], odd[3 * v..3 * v + 3], "vertex {v}");
    }
    for v in [0, 1, 3, 4] {
        assert_ne!(after[3 * v..3 * v + 3], odd[3 * v..3 * v + 3], "vertex {v}");
    }
}

#[test]
fn a_normal_the_step_set_is_kept() {
    let mesh = grid();
    let out = run(
        &mesh,
        vec![
            Op::MoveVertices { ids: vec![4], xyz: vec![1.0, 1.0, 0.5] },
            Op::SetAttribute {
                domain: Domain::Vertex,
                name: "normal".into(),
                components: 3,
                ids: Some(vec![4]),
                values: Values::F32(vec![1.0, 0.0, 0.0]),
            },
        ],
    );
    assert_eq!(f32s(values(&out, Domain::Vertex, "normal"))[12..15], [1.0, 0.0, 0.0]);
}

#[test]
fn a_split_edge_interpolates_at_its_parameter_and_its_corners_follow() {
    let mesh = grid();
    // Half-edge 0 runs 0 -> 1; a point a quarter of the way along.
    let out = run(&mesh, vec![Op::SplitEdge { edge: 0, at: Some([0.25, 0.0, 0.0]) }]);
    let v = 9;
    let color = match values(&out, Domain::Vertex, "color") {
        Values::U8(c) => c,
        _ => unreachable!(),
    };
    // Red 0 and 10 at a quarter: 2.5 rounds away from zero to 3; blue 200 and 199: 199.75.
    assert_eq!(color[4 * v..4 * v + 4], [3, 100, 200, 255]);
    let quality = f32s(values(&out, Domain::Vertex, "quality"));
    assert_eq!(quality[v], 0.125);
    // The split triangle's corners at the new vertex have the interpolated texcoord.
    let uv = f32s(values(&out, Domain::Corner, "texcoord"));
    let corner = out.triangles.iter().position(|&c| c == v as u32).unwrap();
    assert_eq!(uv[2 * corner..2 * corner + 2], [0.125, 0.0]);
    // Both halves keep the split triangle's label.
    let Values::I32(labels) = values(&out, Domain::Face, "label") else { unreachable!() };
    assert_eq!(labels.iter().filter(|&&l| l == 0).count(), 2);
}

#[test]
fn a_split_triangle_blends_its_corners_and_a_collapse_keeps_the_survivor() {
    let mesh = grid();
    let out = run(&mesh, vec![Op::SplitTriangle { triangle: 0, at: None }]);
    // Triangle 0 is (0, 1, 4): quality 0, 0.5, 2 → a third of 2.5.
    assert_eq!(f32s(values(&out, Domain::Vertex, "quality"))[9], (2.5f64 / 3.0) as f32);

    let out = run(&mesh, vec![Op::CollapseEdge { edge: 0 }]);
    // Vertex 1 merged into 0 and is gone: 0 keeps its values, 2.. move down one.
    let quality = f32s(values(&out, Domain::Vertex, "quality"));
    assert_eq!(quality, [0.0, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]);
}

#[test]
fn removed_elements_take_their_values_with_them() {
    let mesh = grid();
    let out = run(&mesh, vec![Op::RemoveVertices { ids: vec![2] }]);
    assert_eq!(out.vertex_count(), 8);
    let Values::I32(labels) = values(&out, Domain::Face, "label") else { unreachable!() };
    // Vertex 2 is in triangle 2 only ((1, 2, 5)); triangle 3 is (1, 5, 4).
    assert_eq!(labels, [0, 1, 3, 4, 5, 6, 7]);
    assert_eq!(f32s(values(&out, Domain::Corner, "texcoord")).len(), 2 * 3 * 7);
    assert_eq!(f32s(values(&out, Domain::Vertex, "quality"))[2], 1.5);
}

#[test]
fn a_flip_swaps_corner_values_and_new_triangles_continue_the_corners_at_their_vertices() {
    let mesh = grid();
    let uv = f32s(values(&mesh, Domain::Corner, "texcoord"));
    let out = run(&mesh, vec![Op::FlipTriangles { ids: vec![0] }]);
    let flipped = f32s(values(&out, Domain::Corner, "texcoord"));
    assert_eq!(flipped[2..4], uv[4..6]);
    assert_eq!(flipped[4..6], uv[2..4]);

    let out = run(&mesh, vec![Op::AddTriangles { abc: vec![2, 8, 6] }]);
    let uv_out = f32s(values(&out, Domain::Corner, "texcoord"));
    // Each new corner copies a live corner at its vertex, so its texcoord is that vertex's.
    assert_eq!(uv_out[48..54], [1.0, 0.0, 1.0, 1.0, 0.0, 1.0]);
}

#[test]
fn new_vertices_without_values_take_defaults_and_are_counted() {
    let mesh = grid();
    let mut store = MeshStore::new(mesh.clone());
    store.apply(Op::AddVertices { xyz: vec![5.0, 5.0, 0.0, 6.0, 6.0, 0.0] }).unwrap();
    store
        .apply(Op::SetAttribute {
            domain: Domain::Vertex,
            name: "quality".into(),
            components: 1,
            ids: Some(vec![10]),
            values: Values::F32(vec![7.0]),
        })
        .unwrap();
    assert_eq!(store.defaulted_vertex_count(), 1);
    let (out, _) = store.finish();
    let Values::U8(color) = values(&out, Domain::Vertex, "color") else { unreachable!() };
    assert_eq!(color[36..40], [255, 255, 255, 255]);
    assert_eq!(f32s(values(&out, Domain::Vertex, "quality"))[9..], [0.0, 7.0]);
}

#[test]
fn set_attribute_makes_new_attributes_and_refuses_what_does_not_fit() {
    let plain = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2]);
    let set = |name: &str, components, ids: Option<Vec<u32>>, values| Op::SetAttribute {
        domain: Domain::Vertex,
        name: name.into(),
        components,
        ids,
        values,
    };
    let out = run(&plain, vec![set("curvature", 1, Some(vec![1]), Values::F64(vec![2.5]))]);
    assert_eq!(values(&out, Domain::Vertex, "curvature"), Values::F64(vec![0.0, 2.5, 0.0]));
    assert_ne!(out.content_hash(), plain.content_hash());

    let mut store = MeshStore::new(plain);
    for (op, why) in [
        (set("color", 3, None, Values::U8(vec![0; 9])), "4 × u8"),
        (set("quality", 1, None, Values::F32(vec![0.0, f32::NAN, 0.0])), "not finite"),
        (set("quality", 1, Some(vec![3]), Values::F32(vec![0.0])), "does not exist"),
        (set("quality", 1, None, Values::F32(vec![0.0; 2])), "need 3 numbers"),
        (set("bad name", 1, None, Values::F32(vec![0.0; 3])), "names are"),
    ] {
        let error = store.apply(op).unwrap_err();
        assert!(error.message.contains(why), "{error:?} should say {why}");
    }
    let error =
        store.apply(Op::RemoveAttribute { domain: Domain::Face, name: "x".into() }).unwrap_err();
    assert!(error.message.contains("no face attribute x"));
    assert_eq!(store.log().len(), 0, "refused edits are not recorded");
}
