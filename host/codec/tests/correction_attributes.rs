//! Corrections of meshes that carry attributes: steps that do not touch them cost nothing
//! more (the store derives what happens to them from the ops), and `set-attribute` values
//! are predicted, each way round-tripping exactly.

mod correction_common;

use correction_common::{Rng, assert_round_trip, grid, smooth};
use meshflow_codec::correction;
use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Attribute, Domain, NORMAL, Values};
use meshflow_mesh::store::{MeshStore, Op};

/// A bumpy grid with per-vertex colours (a smooth function of position plus noise),
/// quality, and normals.
fn coloured(w: u32, h: u32, seed: u64) -> MeshData {
    let mut rng = Rng(seed);
    let mut mesh = grid(w, h, 2, &mut rng);
    let (v, t) = (mesh.vertex_count(), mesh.triangle_count());
    let p = mesh.positions.clone();
    let colour = (0..v)
        .flat_map(|i| {
            let noise = rng.below(7) as f32 - 3.0;
            let wave = |f: f32, k: usize| 128.0 + 100.0 * (f * p[3 * i + k]).sin() + noise;
            [wave(0.7, 0), wave(0.4, 1), wave(1.1, 2), 255.0].map(|c| c.clamp(0.0, 255.0) as u8)
        })
        .collect();
    let quality = (0..v).map(|i| 0.5 + 0.3 * p[3 * i + 2] + 0.01 * rng.unit()).collect();
    let a = &mut mesh.attributes;
    a.insert(Attribute::color(colour), v, t).unwrap();
    a.insert(Attribute::quality(quality), v, t).unwrap();
    a.insert(Attribute::normal(vec![0.0; 3 * v]), v, t).unwrap();
    mesh
}

fn bare(mesh: &MeshData) -> MeshData {
    MeshData::new(mesh.positions.clone(), mesh.triangles.clone())
}

/// Runs `edit` on `base` and returns the result and its correction, checked to replay.
fn step(base: &MeshData, edit: impl Fn(&mut MeshStore)) -> (MeshData, Vec<u8>) {
    let mut store = MeshStore::new(base.clone());
    edit(&mut store);
    let (result, log) = store.finish();
    let bytes = assert_round_trip(base, &result, &log);
    assert_eq!(
        correction::apply(base.clone(), &bytes).unwrap().content_hash(),
        result.content_hash()
    );
    (result, bytes)
}

/// Splits, collapses, swaps and flips scattered over the mesh.
fn topology_edits(store: &mut MeshStore) {
    let slots = store.triangle_slots();
    for (i, t) in (0..slots).step_by(7).enumerate() {
        if !store.is_triangle_live(t) {
            continue;
        }
        let op = match i % 4 {
            0 => Op::SplitEdge { edge: 3 * t, at: None },
            1 => Op::CollapseEdge { edge: 3 * t + 1 },
            2 => Op::SplitTriangle { triangle: t, at: None },
            _ => Op::SwapEdge { edge: 3 * t + 2 },
        };
        let _ = store.apply(op); // refusals (boundary, non-manifold) are part of the shape
    }
}

#[test]
fn steps_that_do_not_touch_attributes_cost_no_more() {
    let coloured = coloured(60, 50, 1);
    let plain = bare(&coloured);
    // A smoothing step, then splits and collapses: the same ops with and without attributes.
    let smoothed = smooth(&coloured, 0.5);
    let set = |s: &mut MeshStore| {
        s.apply(Op::SetPositions { xyz: smoothed.clone() }).unwrap();
    };
    let (coloured_1, with) = step(&coloured, set);
    let (plain_1, without) = step(&plain, set);
    assert!(
        with.len() <= without.len() + 4,
        "smoothing: {} vs {} bytes",
        with.len(),
        without.len()
    );
    // The normals were recomputed on both sides; colours and quality kept bit for bit.
    let normal = coloured_1.attributes.get(Domain::Vertex, NORMAL).unwrap();
    assert!(normal.values != Values::F32(vec![0.0; normal.values.len()]));
    for name in ["color", "quality"] {
        assert_eq!(
            coloured_1.attributes.get(Domain::Vertex, name),
            coloured.attributes.get(Domain::Vertex, name)
        );
    }

    let (coloured_2, with) = step(&coloured_1, topology_edits);
    let (plain_2, without) = step(&plain_1, topology_edits);
    assert_eq!(bare(&coloured_2), plain_2, "the same geometry either way");
    assert!(coloured_2.vertex_count() > coloured_1.vertex_count());
    assert!(with.len() <= without.len() + 4, "edits: {} vs {} bytes", with.len(), without.len());
}

#[test]
fn every_way_of_predicting_set_values_round_trips_and_pays_off() {
    let base = coloured(40, 40, 2);
    let (v, p) = (base.vertex_count(), base.positions.clone());
    let quality = |m: &MeshData| match &m.attributes.get(Domain::Vertex, "quality").unwrap().values
    {
        Values::F32(q) => q.clone(),
        _ => unreachable!(),
    };
    let q = quality(&base);
    let set = |name: &str, components: u8, ids: Option<Vec<u32>>, values: Values| {
        let (name, ids) = (name.to_owned(), ids.clone());
        move |s: &mut MeshStore| {
            let op = Op::SetAttribute {
                domain: Domain::Vertex,
                name: name.clone(),
                components,
                ids: ids.clone(),
                values: values.clone(),
            };
            s.apply(op).unwrap();
        }
    };
    // Against the values before the op: a small change of half the qualities.
    let ids: Vec<u32> = (0..v as u32).step_by(2).collect();
    let bumped = ids.iter().map(|&i| q[i as usize] + 1e-4).collect();
    let (_, bytes) = step(&base, set("quality", 1, Some(ids.clone()), Values::F32(bumped)));
    assert!(
        bytes.len() < 2 * ids.len(),
        "{} bytes for {} bumped qualities",
        bytes.len(),
        ids.len()
    );
    // Against a scale of the values before the op, fitted and sent: a quality rescaled as a
    // service computes it in f32 (two roundings; the prediction rounds once).
    let rescaled = q.iter().map(|x| x * 0.9 + 0.01).collect();
    let (_, bytes) = step(&base, set("quality", 1, None, Values::F32(rescaled)));
    assert!(bytes.len() < v / 4, "{} bytes for {v} rescaled qualities", bytes.len());
    // Against the value before in the op: new vertices, one colour each, a ramp.
    let ramp = |s: &mut MeshStore| {
        let first = s.vertex_slots();
        s.apply(Op::AddVertices { xyz: vec![0.5; 3 * 500] }).unwrap();
        let ids = (first..first + 500).collect();
        let values = (0..500u32).flat_map(|i| [(i / 4) as u8, 100, (i / 8) as u8, 255]).collect();
        set("color", 4, Some(ids), Values::U8(values))(s);
    };
    let (_, with) = step(&base, ramp);
    let (_, without) = step(&base, |s| {
        s.apply(Op::AddVertices { xyz: vec![0.5; 3 * 500] }).unwrap();
    });
    assert!(
        with.len() - without.len() < 250,
        "{} bytes for 500 colours",
        with.len() - without.len()
    );
    // Over every vertex, from the neighbours: a quality smooth over the surface.
    let smooth_quality = (0..v).map(|i| (2.0 * p[3 * i]).sin() + p[3 * i + 1]).collect();
    let (_, bytes) = step(&base, set("quality", 1, None, Values::F32(smooth_quality)));
    assert!(bytes.len() < 3 * v, "{} bytes for {v} smooth qualities", bytes.len());
    // Over every vertex, from the geometry: the normals the store itself would compute.
    let moved: Vec<f32> = p.iter().map(|c| c * 1.25).collect();
    let (recomputed, _) = step(&base, |s| {
        s.apply(Op::SetPositions { xyz: moved.clone() }).unwrap();
    });
    let normals = recomputed.attributes.get(Domain::Vertex, NORMAL).unwrap().values.clone();
    let mut without_normals = recomputed.clone();
    without_normals.attributes.remove(Domain::Vertex, NORMAL);
    let (_, bytes) = step(&without_normals, set(NORMAL, 3, None, normals));
    assert!(bytes.len() < v / 4, "{} bytes for {v} recomputed normals", bytes.len());
    // Zero and anything else: random bits still round-trip.
    let mut rng = Rng(3);
    let noise = (0..v).map(|_| f32::from_bits(rng.next() as u32 & 0x3fff_ffff)).collect();
    step(&base, set("noise", 1, None, Values::F32(noise)));
    step(&base, set("zero", 2, None, Values::F32(vec![0.0; 2 * v])));
    // And every number type and domain, with ids and without.
    for (domain, values, components) in [
        (
            Domain::Face,
            Values::I32((0..base.triangle_count() as i32).map(|i| i / 5 - 40).collect()),
            1,
        ),
        (
            Domain::Corner,
            Values::F64((0..3 * base.triangle_count()).map(|i| (i % 11) as f64 * 0.25).collect()),
            1,
        ),
        (Domain::Face, Values::U32((0..2 * base.triangle_count() as u32).collect()), 2),
    ] {
        step(&base, move |s: &mut MeshStore| {
            let op = Op::SetAttribute {
                domain,
                name: "extra".into(),
                components,
                ids: None,
                values: values.clone(),
            };
            s.apply(op).unwrap();
        });
    }
}
