//! Correction and packed-mesh benchmarks (issue 3), printed as a table. Run with
//! `cargo bench --bench corrections` (release).
//!
//! On a generated 1M-vertex scan and on the bunny, four steps shaped like the in-house
//! services (until those exist): RSC (one remove-component per spurious piece), LS (one
//! step of `laplacian-smoothing`'s own code, boundary pinned, uniform and then cotangent
//! weights), HF (each hole closed by a
//! ring of new vertices and a centre, added as vertices then triangles), RDT (collapses,
//! swaps and removals at scattered thin triangles). Per step: correction bytes, the
//! result's packed (.mfm) and binary PLY + zstd-19 bytes, and encode / apply / pack /
//! unpack times (best of a few runs). The scan runs twice: as generated, and quantised to
//! 16 bits per axis at ingest (`--quantize 16`), each step snapped back onto the grid.

mod common;

use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;
use std::time::Duration;

use common::{best, ms};

use meshflow_codec::quantize::{self, Grid};
use meshflow_codec::{correction, pack};
use meshflow_generate::{ScanSpec, scan};
use meshflow_mesh::MeshData;
use meshflow_mesh::store::{MeshStore, Op};
use meshflow_meshio as io;
use meshflow_plugin_smoothing::laplacian::{Pinning, Weights, smooth};

const RUNS: usize = 3;

fn ply_zstd19(mesh: &MeshData) -> usize {
    let mut ply = Vec::new();
    io::write_to(&mut ply, mesh, io::Format::Ply).expect("valid mesh");
    zstd::bulk::compress(&ply, 19).expect("in-memory compression").len()
}

/// Vertex-connected pieces: a seed triangle of every piece but the largest.
fn rsc(store: &mut MeshStore) {
    let triangles = store.triangles().to_vec();
    let mut parent: Vec<u32> = (0..store.vertex_slots()).collect();
    fn root(parent: &mut [u32], mut v: u32) -> u32 {
        while parent[v as usize] != v {
            parent[v as usize] = parent[parent[v as usize] as usize];
            v = parent[v as usize];
        }
        v
    }
    for t in triangles.chunks_exact(3) {
        let a = root(&mut parent, t[0]);
        for &v in &t[1..] {
            let b = root(&mut parent, v);
            parent[b as usize] = a;
        }
    }
    let mut pieces: HashMap<u32, (u32, usize)> = HashMap::new();
    for (i, t) in triangles.chunks_exact(3).enumerate() {
        let r = root(&mut parent, t[0]);
        pieces.entry(r).or_insert((i as u32, 0)).1 += 1;
    }
    let largest = pieces.values().map(|p| p.1).max().unwrap_or(0);
    let mut seeds: Vec<u32> = pieces.values().filter(|p| p.1 != largest).map(|p| p.0).collect();
    seeds.sort_unstable();
    for t in seeds {
        if store.is_triangle_live(t) {
            store.apply(Op::RemoveComponent { triangle: t }).expect("live seed");
        }
    }
}

fn ls(store: &mut MeshStore, mesh: &MeshData, weights: Weights) {
    let xyz = smooth(&mesh.positions, &mesh.triangles, 1, Pinning::Boundary, weights);
    store.apply(Op::SetPositions { xyz }).expect("one position per vertex");
}

/// Every boundary loop: a ring of vertices halfway to the loop's centre, the centre, and
/// the triangles between (3 per boundary edge).
fn hf(store: &mut MeshStore, mesh: &MeshData) {
    let mut directed = HashMap::new();
    for t in mesh.triangles.chunks_exact(3) {
        for k in 0..3 {
            *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0u32) += 1;
        }
    }
    let mut next: HashMap<u32, u32> = HashMap::new();
    for &(a, b) in directed.keys() {
        if !directed.contains_key(&(b, a)) && a != b {
            next.entry(a).or_insert(b);
        }
    }
    let mut starts: Vec<u32> = next.keys().copied().collect();
    starts.sort_unstable();
    let (mut xyz, mut abc) = (Vec::new(), Vec::new());
    let mut first_new = mesh.vertex_count() as u32;
    let p = |v: u32| -> [f32; 3] { std::array::from_fn(|k| mesh.positions[3 * v as usize + k]) };
    for start in starts {
        let mut ring = vec![start];
        let mut v = start;
        while let Some(n) = next.remove(&v) {
            if n == start || ring.len() > 4096 {
                break;
            }
            ring.push(n);
            v = n;
        }
        if ring.len() < 3 || next.contains_key(&v) {
            continue;
        }
        let l = ring.len() as u32;
        let centre: [f32; 3] =
            std::array::from_fn(|k| ring.iter().map(|&v| p(v)[k]).sum::<f32>() / l as f32);
        for &v in &ring {
            xyz.extend((0..3).map(|k| 0.5 * (p(v)[k] + centre[k])));
        }
        xyz.extend(centre);
        let c = first_new + l;
        for i in 0..l {
            let (a, b) = (ring[i as usize], ring[((i + 1) % l) as usize]);
            let (ma, mb) = (first_new + i, first_new + (i + 1) % l);
            abc.extend([b, a, ma, b, ma, mb, mb, ma, c]);
        }
        first_new += l + 1;
    }
    store.apply(Op::AddVertices { xyz }).expect("finite points");
    store.apply(Op::AddTriangles { abc }).expect("corners exist");
}

/// ~0.1 % of the triangles: collapse one edge, swap one, remove one, in turn.
fn rdt(store: &mut MeshStore) {
    let step = (store.triangle_slots() / 1000).max(1);
    for (i, t) in (0..store.triangle_slots()).step_by(step as usize).enumerate() {
        if !store.is_triangle_live(t) {
            continue;
        }
        let op = match i % 3 {
            0 => Op::CollapseEdge { edge: 3 * t },
            1 => Op::SwapEdge { edge: 3 * t + 1 },
            _ => Op::RemoveTriangles { ids: vec![t] },
        };
        let _ = store.apply(op); // refusals (non-manifold, boundary) are part of the shape
    }
}

struct Row {
    mesh: &'static str,
    step: &'static str,
    edits: usize,
    correction: usize,
    extra: String,
    packed: usize,
    ply_zstd: usize,
    encode: Duration,
    apply: Duration,
    pack: Duration,
    unpack: Duration,
}

/// Runs the steps from `input`; on a `grid`, each result is snapped back onto it as the
/// host does after a step.
fn steps(name: &'static str, input: MeshData, grid: Option<Grid>, rows: &mut Vec<Row>) {
    let mut mesh = input;
    type Step = fn(&mut MeshStore, &MeshData);
    let steps: [(&str, Step); 5] = [
        ("RSC", |s, _| rsc(s)),
        ("LS(1)", |s, m| ls(s, m, Weights::Uniform)),
        // Not predicted exactly by the codec's uniform model: the honest harder case.
        ("LS cot", |s, m| ls(s, m, Weights::Cotangent)),
        ("HF", hf),
        ("RDT", |s, _| rdt(s)),
    ];
    for (step, edit) in steps {
        let mut store = MeshStore::new(mesh.clone());
        edit(&mut store, &mesh);
        let (result, log) = store.finish();
        let (result, log) = match &grid {
            Some(grid) => quantize::snap_step(grid, &mesh, result, log).expect("replays"),
            None => (result, log),
        };
        let (encode, bytes) =
            best(RUNS, || correction::encode(&mesh, &log, &result).expect("encodes"));
        // A host applies corrections to its session's shared mesh.
        let shared = Arc::new(mesh.clone());
        let (apply, applied) =
            best(RUNS, || correction::apply(Arc::clone(&shared), &bytes).expect("applies"));
        assert_eq!(applied.content_hash(), result.content_hash());
        let (pack_time, packed) = best(RUNS, || pack::encode(&result).expect("packs"));
        let (unpack, unpacked) = best(RUNS, || pack::decode(&packed).expect("unpacks"));
        assert_eq!(unpacked.content_hash(), result.content_hash());
        let edits = log.iter().map(|op| op.edit_count()).sum();
        let extra = match step {
            "LS(1)" | "LS cot" => {
                format!("{:.2} bit/vertex", 8.0 * bytes.len() as f64 / mesh.vertex_count() as f64)
            }
            "HF" if result.triangle_count() == mesh.triangle_count() => "no holes".into(),
            "HF" => {
                let added = result.triangle_count() - mesh.triangle_count();
                let new_vertices = result.vertex_count() - mesh.vertex_count();
                let per_triangle = bytes.len() as f64 / added as f64;
                format!("{per_triangle:.2} B/triangle ({new_vertices} v, {added} t)")
            }
            _ => format!("{} ops", log.len()),
        };
        rows.push(Row {
            mesh: name,
            step,
            edits,
            correction: bytes.len(),
            extra,
            packed: packed.len(),
            ply_zstd: ply_zstd19(&result),
            encode,
            apply,
            pack: pack_time,
            unpack,
        });
        mesh = result;
    }
}

fn main() {
    let mut rows = Vec::new();
    let bunny = io::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj"))
        .expect("the bunny ships with the repository");
    steps("bunny", bunny, None, &mut rows);
    let spec = ScanSpec { vertices: 1_000_000, components: 150, holes: 40, noise: 0.2, seed: 11 };
    let mut quantised = scan(&spec);
    steps("scan 1M", quantised.clone(), None, &mut rows);
    let grid = quantize::quantize(&mut quantised, 16).expect("a finite mesh");
    steps("1M q16", quantised, Some(grid), &mut rows);

    println!(
        "{:<8} {:<6} {:>9} {:>10} {:<34} {:>10} {:>10} {:>6} {:>9} {:>9} {:>9} {:>9}",
        "mesh",
        "step",
        "edits",
        "mfc B",
        "",
        "mfm B",
        "ply+zst19",
        "ratio",
        "enc ms",
        "apply ms",
        "pack ms",
        "unpack ms"
    );
    for r in rows {
        println!(
            "{:<8} {:<6} {:>9} {:>10} {:<34} {:>10} {:>10} {:>6.3} {:>9.1} {:>9.1} {:>9.1} {:>9.1}",
            r.mesh,
            r.step,
            r.edits,
            r.correction,
            r.extra,
            r.packed,
            r.ply_zstd,
            r.packed as f64 / r.ply_zstd as f64,
            ms(r.encode),
            ms(r.apply),
            ms(r.pack),
            ms(r.unpack)
        );
    }
}
