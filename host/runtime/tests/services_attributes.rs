//! Attributes through the WIT, as WebAssembly on the host's runtime: `curvature` writes mean
//! curvature as quality (1/r on a sphere); the built-ins that make vertices with
//! `add-vertices` (fill-holes, loop-subdivision, repair-non-manifold) give them values
//! blended from where they came from; a check may read attributes but not write them; a
//! step whose new vertices kept the defaults says so in its report.

mod common;

use common::{run, runtime};

use meshflow_builtin_plugins::fixture;
use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Attribute, COLOR, Domain, QUALITY, Values};
use meshflow_mesh::store::Op;
use meshflow_runtime::Value;
use meshflow_topology::boundary::boundary_loops;
use meshflow_topology::geometry::{norm, point};
use meshflow_topology::halfedge::HalfEdges;
use meshflow_topology::shapes::uv_sphere;

/// Colours and quality that vary smoothly over the mesh: RGB from the position in
/// [-1, 1]³, quality the height.
fn coloured(mut mesh: MeshData) -> MeshData {
    let n = mesh.vertex_count();
    let channel = |x: f32| ((x.clamp(-1.0, 1.0) + 1.0) * 127.5).round() as u8;
    let rgba =
        mesh.positions.chunks_exact(3).flat_map(|p| p.iter().map(|&x| channel(x)).chain([255]));
    let rgba: Vec<u8> = rgba.collect();
    let quality: Vec<f32> = mesh.positions.chunks_exact(3).map(|p| p[2]).collect();
    let t = mesh.triangle_count();
    mesh.attributes.insert(Attribute::color(rgba), n, t).unwrap();
    mesh.attributes.insert(Attribute::quality(quality), n, t).unwrap();
    mesh
}

fn colors(mesh: &MeshData) -> &[u8] {
    match &mesh.attributes.get(Domain::Vertex, COLOR).expect("colours").values {
        Values::U8(rgba) => rgba,
        other => panic!("colours as {:?}", other.number_type()),
    }
}

fn quality(mesh: &MeshData) -> &[f32] {
    match &mesh.attributes.get(Domain::Vertex, QUALITY).expect("quality").values {
        Values::F32(q) => q,
        other => panic!("quality as {:?}", other.number_type()),
    }
}

fn sphere(rings: u32, segments: u32, radius: f32) -> MeshData {
    let (mut positions, triangles) = uv_sphere(rings, segments);
    positions.iter_mut().for_each(|x| *x *= radius);
    MeshData::new(positions, triangles)
}

/// The tolerance is the formula's own error on this sphere (`plugins/smoothing`'s tests:
/// second order in the edge length, under 0.4 % at the worst vertex of a 16 × 32 UV sphere);
/// the sandbox computes the same f64 operations as a native build.
#[test]
fn curvature_writes_one_over_r_as_quality_and_moves_nothing() {
    let r = 2.5f32;
    let mesh = coloured(sphere(16, 32, r));
    let out = run("smoothing", "curvature", &mesh, &[]);
    let result = out.mesh.expect("a filter's mesh");
    assert!(out.report.starts_with("mean curvature of 482 vertices as quality"), "{}", out.report);
    assert_eq!(result.positions, mesh.positions, "the geometry is unchanged");
    assert_eq!(colors(&result), colors(&mesh), "the colours are kept");
    for (v, &h) in quality(&result).iter().enumerate() {
        assert!((f64::from(h * r) - 1.0).abs() < 0.01, "vertex {v}: H = {h}, 1/r = {}", 1.0 / r);
    }
    assert!(matches!(&out.log[..], [Op::SetAttribute { name, ids: None, .. }] if name == QUALITY));

    let out = run("smoothing", "curvature", &mesh, &[("kind", Value::Text("gaussian".into()))]);
    let k = quality(out.mesh.as_ref().unwrap());
    assert!(k.iter().all(|&k| (f64::from(k * r * r) - 1.0).abs() < 0.02), "{k:?}");
}

#[test]
fn curvature_on_an_open_mesh_gives_its_border_zero_and_says_so() {
    let (positions, triangles) = meshflow_topology::shapes::square_grid(3);
    let out = run("smoothing", "curvature", &MeshData::new(positions, triangles), &[]);
    assert!(
        out.report.contains("12 vertices on a boundary, non-manifold or misoriented edge got 0"),
        "{}",
        out.report
    );
    assert!(quality(out.mesh.as_ref().unwrap()).iter().all(|&h| h == 0.0));
}

/// Removes the triangles whose centroid is within `radius` of `centre`.
fn punch(mesh: &mut MeshData, centre: [f64; 3], radius: f64) {
    let positions = mesh.positions.clone();
    let kept: Vec<u32> = mesh
        .triangles
        .chunks_exact(3)
        .filter(|t| {
            let c = t.iter().fold([0.0; 3], |s, &v| {
                let p = point(&positions, v);
                [s[0] + p[0] / 3.0, s[1] + p[1] / 3.0, s[2] + p[2] / 3.0]
            });
            norm([c[0] - centre[0], c[1] - centre[1], c[2] - centre[2]]) > radius
        })
        .flatten()
        .copied()
        .collect();
    let t = kept.len() / 3;
    let attributes = std::mem::take(&mut mesh.attributes);
    mesh.triangles = kept;
    // Vertex attributes only: they stay valid with fewer triangles.
    for a in attributes.iter() {
        mesh.attributes.insert(a.clone(), mesh.vertex_count(), t).unwrap();
    }
}

#[test]
fn fill_holes_gives_new_vertices_colours_between_the_boundarys() {
    let mut mesh = coloured(sphere(40, 80, 1.0));
    punch(&mut mesh, [0.6, 0.6, 0.5], 0.45);
    let half_edges = HalfEdges::new(mesh.vertex_count(), &mesh.triangles);
    let holes = boundary_loops(&mesh.triangles, &half_edges);
    assert_eq!(holes.len(), 1);
    let rim = &holes[0].vertices;
    let out = run("holes", "fill-holes", &mesh, &[]);
    assert!(!out.report.contains("default"), "{}", out.report);
    let filled = out.mesh.unwrap();
    let new = mesh.vertex_count()..filled.vertex_count();
    assert!(new.len() > 20, "{}", out.report);

    let (before, after) = (colors(&mesh), colors(&filled));
    assert_eq!(&after[..before.len()], before, "old vertices keep their colours bit for bit");
    for channel in 0..4 {
        let rim_values = rim.iter().map(|&v| after[4 * v as usize + channel]);
        let (lo, hi) = rim_values.fold((u8::MAX, 0), |(lo, hi), x| (lo.min(x), hi.max(x)));
        assert!(lo < hi || channel == 3, "channel {channel} is flat on the boundary");
        for v in new.clone() {
            let x = after[4 * v + channel];
            assert!((lo..=hi).contains(&x), "vertex {v} channel {channel}: {x} not in {lo}..={hi}");
        }
    }
    let q = quality(&filled);
    let (lo, hi) = rim
        .iter()
        .map(|&v| q[v as usize])
        .fold((f32::MAX, f32::MIN), |(lo, hi), x| (lo.min(x), hi.max(x)));
    assert!(new.clone().all(|v| (lo..=hi).contains(&q[v])), "quality outside {lo}..={hi}");
    // Not all alike: the values vary across the patch as around the hole.
    assert!(new.clone().any(|v| after[4 * v] != after[4 * new.start]));
}

#[test]
fn loop_subdivision_gives_each_edge_point_its_edges_mean() {
    let mesh = coloured(sphere(4, 6, 1.0));
    let out = run("remeshing", "loop-subdivision", &mesh, &[("iterations", Value::Integer(2))]);
    assert!(!out.report.contains("default"), "{}", out.report);
    let result = out.mesh.unwrap();
    let (before, after) = (colors(&mesh), colors(&result));
    assert_eq!(&after[..before.len()], before);
    assert!(result.vertex_count() > 4 * mesh.vertex_count());
    // Every edge point of the first level is the rounded mean of an edge's ends: its colour
    // lies between the extremes of the input's, and alpha stays opaque.
    for channel in 0..4 {
        let column =
            |rgba: &[u8]| rgba.iter().skip(channel).step_by(4).copied().collect::<Vec<_>>();
        let (input, output) = (column(before), column(after));
        let (lo, hi) = (*input.iter().min().unwrap(), *input.iter().max().unwrap());
        assert!(output.iter().all(|x| (lo..=hi).contains(x)), "channel {channel}");
    }
    assert!(after.iter().skip(3).step_by(4).all(|&a| a == 255));
}

#[test]
fn repair_non_manifold_gives_a_vertex_copy_its_originals_values() {
    // Two triangles touching at vertex 0 only: the repair splits it in two.
    let mesh = coloured(MeshData::new(
        vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 0.0],
        vec![0, 1, 2, 0, 3, 4],
    ));
    let out = run("cleanup", "repair-non-manifold", &mesh, &[]);
    let result = out.mesh.unwrap();
    assert_eq!(result.vertex_count(), 6, "{}", out.report);
    assert!(!out.report.contains("default"), "{}", out.report);
    assert_eq!(colors(&result)[20..24], colors(&mesh)[0..4]);
    assert_eq!(quality(&result)[5], quality(&mesh)[0]);
}

#[test]
fn a_check_reads_attributes_but_is_refused_writing_them() {
    let runtime = runtime();
    let hostile = runtime.load(fixture("hostile")).expect("the hostile fixture loads");
    let mesh = coloured(sphere(4, 6, 1.0));
    let out = runtime.run(&hostile, "set-attribute-in-check", mesh, &[]).expect("it answers");
    let Some(Value::Text(text)) = out.value else { panic!("{:?}", out.value) };
    assert_eq!(
        text,
        "edit refused (read-only mesh): set-attribute refused: a check may not edit the mesh | \
         edit refused (read-only mesh): remove-attribute refused: a check may not edit the mesh"
    );
    assert!(out.log.is_empty());
}

#[test]
fn new_vertices_left_at_their_defaults_are_reported() {
    let runtime = runtime();
    let hostile = runtime.load(fixture("hostile")).expect("the hostile fixture loads");
    let mesh = coloured(sphere(4, 6, 1.0));
    let out = runtime.run(&hostile, "add-bare-vertex", mesh.clone(), &[]).unwrap();
    assert_eq!(
        out.report,
        "added a vertex\n1 new vertex took default colour, quality: the service gave none"
    );
    let result = out.mesh.unwrap();
    let last = result.vertex_count() - 1;
    assert_eq!(colors(&result)[4 * last..], [255, 255, 255, 255]);
    // Without attributes, nothing to say.
    let bare = MeshData::new(mesh.positions.clone(), mesh.triangles.clone());
    let out = runtime.run(&hostile, "add-bare-vertex", bare, &[]).unwrap();
    assert_eq!(out.report, "added a vertex");
}
