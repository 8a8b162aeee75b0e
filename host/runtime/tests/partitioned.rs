//! Runs on partitions: a local service on a mesh cut into partitions (forced small with
//! `max_partition_triangles`) gives the whole-mesh result bit for bit, whatever order the
//! mesh lists its vertices in.

mod common;

use std::collections::HashSet;

use meshflow_builtin_plugins::fixture;
use meshflow_generate::{ScanSpec, scan, shuffled};
use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Attribute, Attributes};
use meshflow_mesh::partition::Partitioning;
use meshflow_mesh::store::MeshStore;
use meshflow_runtime::{Limits, RunError, RunOutput, Runtime, Value};

/// A scan with holes, debris and defects, its ids shuffled, with a colour per vertex.
fn scan_mesh() -> MeshData {
    let spec = ScanSpec { vertices: 60_000, components: 12, holes: 30, noise: 0.2, seed: 33 };
    let mesh = shuffled(&scan(&spec));
    let n = mesh.vertex_count();
    let colours = (0..4 * n).map(|i| (i * 37 % 251) as u8).collect();
    let mut attributes = Attributes::default();
    attributes.insert(Attribute::color(colours), n, mesh.triangle_count()).unwrap();
    mesh.with_attributes(attributes).unwrap()
}

fn run(limits: Limits, service: &str, mesh: &MeshData, params: &[(&str, Value)]) -> RunOutput {
    run_of("smoothing", limits, service, mesh, params)
}

fn run_of(
    plugin: &str,
    limits: Limits,
    service: &str,
    mesh: &MeshData,
    params: &[(&str, Value)],
) -> RunOutput {
    let runtime = Runtime::new(limits, None).expect("a runtime");
    let plugin = common::builtin(&runtime, plugin);
    let params: Vec<(String, Value)> =
        params.iter().map(|(name, value)| (name.to_string(), value.clone())).collect();
    runtime
        .run(&plugin, service, mesh.clone(), &params)
        .unwrap_or_else(|e| panic!("{service}: {e}"))
}

fn partitioned(triangles: usize) -> Limits {
    Limits { max_partition_triangles: Some(triangles), concurrent_runs: 2, ..Limits::default() }
}

#[test]
fn smoothing_on_partitions_reaches_the_whole_mesh_hash() {
    let mesh = scan_mesh();
    let cases: [(&str, Vec<(&str, Value)>); 5] = [
        ("laplacian-smoothing", vec![("iterations", Value::Integer(3))]),
        (
            "laplacian-smoothing",
            vec![
                ("iterations", Value::Integer(2)),
                ("weights", Value::Text("cotangent".into())),
                ("keep-boundary", Value::Boolean(false)),
            ],
        ),
        ("taubin-smoothing", vec![("iterations", Value::Integer(2))]),
        ("laplacian-smoothing", vec![("iterations", Value::Integer(1))]),
        // Reach 0: each partition is its core alone, and draws by the whole mesh's ids.
        ("add-noise", vec![("amount", Value::Real(0.5)), ("seed", Value::Integer(3))]),
    ];
    for (service, params) in &cases {
        let whole = run(Limits::default(), service, &mesh, params);
        assert_eq!(whole.partitions, None, "{service}: the default runs it whole");
        let parts = run(partitioned(8_000), service, &mesh, params);
        let cut = parts.partitions.expect("it ran on partitions");
        assert!(cut.count >= 10, "{service}: {cut:?}");
        assert!(cut.largest < mesh.triangle_count() / 2, "{service}: {cut:?}");
        let (whole_mesh, parts_mesh) = (whole.mesh.unwrap(), parts.mesh.unwrap());
        assert_ne!(whole_mesh.content_hash(), mesh.content_hash(), "{service} moved vertices");
        assert_eq!(parts_mesh.content_hash(), whole_mesh.content_hash(), "{service} {params:?}");
        assert_eq!(parts.log, whole.log, "{service}: one set-positions, as the whole run's");
        assert!(parts.report.contains("partitions"), "{}", parts.report);
    }
}

/// The scan with defects spread over it, every few hundred triangles: caps (a corner moved
/// onto the middle of its opposite edge), needles (a corner moved onto another), duplicated
/// triangles and triangles that repeat a vertex, some of them next to each other so that
/// repairs cascade.
fn defective_scan() -> MeshData {
    let mut mesh = scan_mesh();
    let (positions, triangles) = (&mut mesh.positions, &mut mesh.triangles);
    let mut appended = Vec::new();
    for (n, t) in (0..triangles.len() / 3).step_by(397).enumerate() {
        let c = [0, 1, 2].map(|k| triangles[3 * t + k] as usize);
        let point = |p: &[f32], v: usize| [p[3 * v], p[3 * v + 1], p[3 * v + 2]];
        let (a, b) = (point(positions, c[1]), point(positions, c[2]));
        let target = match n % 4 {
            0 | 3 => [0, 1, 2].map(|k| (a[k] + b[k]) / 2.0),
            1 => a,
            _ => [0; 3].map(|_| 0.0),
        };
        match n % 4 {
            0 | 1 | 3 => positions[3 * c[0]..3 * c[0] + 3].copy_from_slice(&target),
            _ => appended.extend([c[0], c[1], c[2], c[0], c[0], c[1]].map(|v| v as u32)),
        }
    }
    triangles.extend(appended);
    mesh
}

#[test]
fn degenerate_repair_on_partitions_reaches_the_whole_mesh_hash() {
    let mesh = defective_scan();
    let service = "remove-degenerate-triangles";
    for params in [vec![], vec![("epsilon", Value::Real(1e-3))]] {
        let whole = run_of("cleanup", Limits::default(), service, &mesh, &params);
        assert_eq!(whole.partitions, None);
        for needs in ["split", "collapsed", "duplicate"] {
            assert!(whole.report.contains(needs), "{}", whole.report);
        }
        for part_size in [8_000, 30_000] {
            let parts = run_of("cleanup", partitioned(part_size), service, &mesh, &params);
            let cut = parts.partitions.expect("it ran on partitions");
            assert!(cut.count >= 4, "{cut:?}");
            assert!(parts.report.contains("region"), "{}", parts.report);
            let whole_mesh = whole.mesh.as_ref().unwrap();
            let parts_mesh = parts.mesh.unwrap();
            assert_ne!(whole_mesh.triangle_count(), mesh.triangle_count(), "it repaired");
            assert_eq!(parts_mesh.content_hash(), whole_mesh.content_hash(), "{params:?}");
            // The step's log, made on the region and placed, rebuilds it.
            let mut replayed = MeshStore::new(mesh.clone());
            for op in parts.log {
                replayed.apply(op).expect("the placed log applies to the mesh");
            }
            assert_eq!(replayed.finish().0.content_hash(), whole_mesh.content_hash());
        }
    }
}

#[test]
fn decimation_in_blocks_keeps_their_shared_vertices_and_gives_one_hash_on_every_host() {
    let mesh = scan_mesh();
    let service = "quadric-decimation";
    let ratio = ("target-ratio", Value::Real(0.3));
    let params = [ratio.clone(), ("block-triangles", Value::Integer(20_000))];
    let blocked = run_of("remeshing", Limits::default(), service, &mesh, &params);
    let blocks = blocked.partitions.expect("it ran in blocks");
    assert!(blocks.count >= 5 && blocks.rings == 0, "{blocks:?}");
    assert!(blocked.report.contains("blocks"), "{}", blocked.report);
    let result = blocked.mesh.as_ref().unwrap();
    let kept = result.triangle_count() as f64 / mesh.triangle_count() as f64;
    assert!((0.29..0.45).contains(&kept), "{kept}: {}", blocked.report);

    // Another host, with other limits (one run slot, partitions forced small), cuts the
    // same blocks: the same result.
    let other =
        Limits { max_partition_triangles: Some(3_000), concurrent_runs: 1, ..Limits::default() };
    let again = run_of("remeshing", other, service, &mesh, &params);
    assert_eq!(again.mesh.unwrap().content_hash(), result.content_hash());
    // The step's log rebuilds it.
    let mut replayed = MeshStore::new(mesh.clone());
    for op in blocked.log.clone() {
        replayed.apply(op).expect("the placed log applies to the mesh");
    }
    assert_eq!(replayed.finish().0.content_hash(), result.content_hash());

    // Every vertex two blocks share is still there, where it was.
    let cut = Partitioning::new(&mesh, 20_000);
    let cut_blocks = cut.blocks();
    assert!(cut_blocks.shared_count() > 100);
    let at = |p: &[f32]| [p[0].to_bits(), p[1].to_bits(), p[2].to_bits()];
    let left: HashSet<[u32; 3]> = result.positions.chunks_exact(3).map(at).collect();
    for index in 0..cut_blocks.len() {
        let block = cut_blocks.block(index);
        for &v in &block.shared {
            let p = &block.mesh.positions[3 * v as usize..][..3];
            assert!(left.contains(&at(p)), "shared vertex {} gone", block.vertices[v as usize]);
        }
    }

    // Whole (block-triangles 0), the result is another: the blocks' borders kept theirs.
    let whole = run_of(
        "remeshing",
        Limits::default(),
        service,
        &mesh,
        &[ratio, ("block-triangles", Value::Integer(0))],
    );
    assert_eq!(whole.partitions, None);
    assert_ne!(whole.mesh.unwrap().content_hash(), result.content_hash());
}

#[test]
fn a_service_that_is_not_local_runs_whole_and_a_small_mesh_is_not_cut() {
    let mesh = scan_mesh();
    let mean = [("kind", Value::Text("mean".into()))];
    let output = run(partitioned(8_000), "curvature", &mesh, &mean);
    assert_eq!(output.partitions, None, "curvature declares no reach");
    let small = run(partitioned(mesh.triangle_count()), "laplacian-smoothing", &mesh, &[]);
    assert_eq!(small.partitions, None);
}

#[test]
fn over_the_automatic_partition_size_a_service_that_fits_runs_whole() {
    // Many triangles over few vertices: over the partition size of 256 MiB (2.1M
    // triangles), while add-noise, which reads positions only, fits the cap whole. Whole
    // is faster (cutting costs a sort and copies), so it is not cut.
    let positions = (0..3 * 1000).map(|i| (i % 17) as f32).collect();
    let triangles = (0..3 * 2_200_000).map(|i| (i / 3 + i % 3) as u32 % 1000).collect();
    let mesh = MeshData::new(positions, triangles);
    let limits = Limits { memory_bytes: 256 << 20, concurrent_runs: 2, ..Limits::default() };
    assert!(limits.partition_triangles() < mesh.triangle_count());
    let noise = [("amount", Value::Real(0.5)), ("seed", Value::Integer(3))];
    let forced = Limits { max_partition_triangles: Some(limits.partition_triangles()), ..limits };
    let output = run(limits, "add-noise", &mesh, &noise);
    assert_eq!(output.partitions, None);
    // The same size given by the operator cuts it.
    let cut = run(forced, "add-noise", &mesh, &noise);
    assert_eq!(cut.partitions.map(|p| p.count), Some(2));
    assert_eq!(cut.mesh.unwrap().content_hash(), output.mesh.as_ref().unwrap().content_hash());
    let default = run(Limits::default(), "add-noise", &mesh, &noise);
    assert_eq!(output.mesh.unwrap().content_hash(), default.mesh.unwrap().content_hash());
}

#[test]
fn a_reach_over_most_of_the_mesh_runs_it_whole() {
    let mesh = scan_mesh();
    // 400 Taubin iterations reach 800 rings: every partition would be most of the mesh.
    let params = [("iterations", Value::Integer(400))];
    let output = run(partitioned(8_000), "taubin-smoothing", &mesh, &params);
    assert_eq!(output.partitions, None);
}

#[test]
fn a_service_that_claims_locality_wrongly_is_refused_on_partitions() {
    let mesh = scan_mesh();
    let runtime = Runtime::new(partitioned(8_000), None).expect("a runtime");
    let hostile = runtime.load(fixture("hostile")).expect("the hostile fixture loads");
    assert!(hostile.declares_locality());
    let error = runtime.run(&hostile, "local-but-adds", mesh.clone(), &[]).expect_err("adds");
    assert!(matches!(&error, RunError::NotLocal { edit: "add-vertices", .. }), "{error}");
    assert!(error.to_string().contains("partition"), "{error}");
    // Its result depends on the partition's size: the audit partition tells.
    let error = runtime.run(&hostile, "local-but-global", mesh.clone(), &[]).expect_err("global");
    assert!(matches!(&error, RunError::ReachExceeded { rings: 1, .. }), "{error}");
    // Blocks must keep the vertices they share; a block of ten triangles is refused.
    let error =
        runtime.run(&hostile, "blocks-but-moves-all", mesh.clone(), &[]).expect_err("moves");
    let message = error.to_string();
    assert!(
        message.contains("shares with another block") && message.contains("block "),
        "{message}"
    );
    let error = runtime.run(&hostile, "blocks-of-ten", mesh.clone(), &[]).expect_err("ten");
    assert!(error.to_string().contains("at least 1000"), "{error}");
    // On a mesh below the partition size both run whole, as any service.
    let small = MeshData::new(mesh.positions[..300].to_vec(), vec![0, 1, 2]);
    runtime.run(&hostile, "local-but-global", small, &[]).expect("runs whole");
}
