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
//! unpack times (best of a few runs); for the steps that set every position, also the
//! encode and apply with the base's neighbour means gathered before (as a host does beside
//! the plugin's run and the log's download), and that gathering. The scan runs twice: as generated, and quantised to
//! 16 bits per axis at ingest (`--quantize 16`), each step snapped back onto the grid.
//!
//! `cargo bench --bench corrections -- attributes` measures instead what attributes cost
//! (issue 35): the scan and the bunny given per-vertex colours (a smooth function of
//! position plus noise) and quality, with and without them (and with normals, which the
//! store recomputes): `.mfm` size and times, the edit logs of an RSC and an LS step, and
//! the time the store takes for the step. `MESHFLOW_ATTRIBUTE_MESHES=a.ply:b.ply` adds
//! meshes from outside the repository: each attribute's packed bytes beside zstd-19 of its
//! raw bytes.

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
use meshflow_mesh::attributes::{Attribute, Domain, NORMAL};
use meshflow_mesh::store::{MeshStore, Op};
use meshflow_meshio as io;
use meshflow_plugin_smoothing::laplacian::{Pinning, Weights, smooth};

const RUNS: usize = 3;
/// The attribute figures compare times within a few percent: more runs on a noisy machine.
const ATTRIBUTE_RUNS: usize = 7;

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
    /// A log that sets every position: the base's neighbour means gathered, then the
    /// encode and the apply with them.
    prepared: Option<[Duration; 3]>,
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
        let prepared = matches!(log.first(), Some(Op::SetPositions { .. })).then(|| {
            let (base_hash, result_hash) = (mesh.content_hash(), result.content_hash());
            let (gather, means) = best(RUNS, || correction::NeighbourMeans::of(&mesh, base_hash));
            let (encode, again) = best(RUNS, || {
                let base = Arc::clone(&shared);
                correction::encode_known(base, base_hash, &log, &result, result_hash, Some(&means))
                    .expect("encodes")
            });
            assert_eq!(again, bytes);
            let (apply, _) = best(RUNS, || {
                let base = Arc::clone(&shared);
                correction::apply_known(base, base_hash, &bytes, result_hash, Some(&means))
                    .expect("applies")
            });
            [gather, encode, apply]
        });
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
            prepared,
        });
        mesh = result;
    }
}

/// `mesh` with per-vertex colours, a smooth function of position plus noise (a shared
/// brightness noise of ±3 and ±2 per channel, as a photo's), and a scanner-like quality
/// (smooth, plus noise of about 1 % in its low bits); with `normals`, normals too (zero:
/// the store recomputes those a step changes).
fn paint(mesh: &MeshData, normals: bool) -> MeshData {
    let mut state = 0x2545_f491_4f6c_dd1du64;
    let mut noise = |n: u64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state % (2 * n + 1)) as f32 - n as f32
    };
    let (v, t) = (mesh.vertex_count(), mesh.triangle_count());
    let p = &mesh.positions;
    // Scaled to the mesh, so colour changes across the surface as on a scan of an object.
    let (lo, hi) = p.chunks_exact(3).fold(([f32::MAX; 3], [f32::MIN; 3]), |(lo, hi), q| {
        (std::array::from_fn(|k| lo[k].min(q[k])), std::array::from_fn(|k| hi[k].max(q[k])))
    });
    let size = (0..3).map(|k| hi[k] - lo[k]).fold(0.0f32, f32::max).max(f32::MIN_POSITIVE);
    let unit = |i: usize, k: usize| (p[3 * i + k] - lo[k]) / size;
    let mut colour = Vec::with_capacity(4 * v);
    let mut quality = Vec::with_capacity(v);
    for i in 0..v {
        let (x, y, z) = (unit(i, 0), unit(i, 1), unit(i, 2));
        let shared = noise(3);
        let smooth = [
            128.0 + 90.0 * (6.0 * x).sin(),
            128.0 + 80.0 * (5.0 * y + 2.0 * z).cos(),
            110.0 + 60.0 * (9.0 * x * z).sin(),
        ];
        for c in smooth {
            colour.push((c + shared + noise(2)).clamp(0.0, 255.0) as u8);
        }
        colour.push(255);
        quality.push(0.6 + 0.3 * (4.0 * y).sin() + 0.004 * (noise(1000) / 1000.0));
    }
    let mut painted = mesh.clone();
    let a = &mut painted.attributes;
    a.insert(Attribute::color(colour), v, t).expect("one colour per vertex");
    a.insert(Attribute::quality(quality), v, t).expect("one quality per vertex");
    if normals {
        a.insert(Attribute::normal(vec![0.0; 3 * v]), v, t).expect("one normal per vertex");
    }
    painted
}

/// Unit vertex normals weighted by each corner's angle, in f64 with the system's `acos`
/// (what Blender writes), rounded to f32.
fn angle_weighted_normals(mesh: &MeshData) -> Vec<f32> {
    let p = |v: u32| -> [f64; 3] {
        std::array::from_fn(|k| f64::from(mesh.positions[3 * v as usize + k]))
    };
    let sub = |a: [f64; 3], b: [f64; 3]| [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    let cross = |u: [f64; 3], w: [f64; 3]| {
        [u[1] * w[2] - u[2] * w[1], u[2] * w[0] - u[0] * w[2], u[0] * w[1] - u[1] * w[0]]
    };
    let length = |u: [f64; 3]| (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    let mut sums = vec![[0.0f64; 3]; mesh.vertex_count()];
    for c in mesh.triangles.chunks_exact(3) {
        let n = cross(sub(p(c[1]), p(c[0])), sub(p(c[2]), p(c[0])));
        let l = length(n);
        if l == 0.0 {
            continue;
        }
        for k in 0..3 {
            let (a, b, d) = (c[k], c[(k + 1) % 3], c[(k + 2) % 3]);
            let (u, w) = (sub(p(b), p(a)), sub(p(d), p(a)));
            let cos = (u[0] * w[0] + u[1] * w[1] + u[2] * w[2]) / (length(u) * length(w));
            let angle = cos.clamp(-1.0, 1.0).acos();
            (0..3).for_each(|i| sums[a as usize][i] += angle * n[i] / l);
        }
    }
    sums.iter()
        .flat_map(|s| {
            let l = length(*s);
            if l > 0.0 { s.map(|x| (x / l) as f32) } else { [0.0, 0.0, 1.0] }
        })
        .collect()
}

fn zstd19(bytes: &[u8]) -> usize {
    zstd::bulk::compress(bytes, 19).expect("in-memory compression").len()
}

/// One attribute's bytes: raw, packed (the packed mesh less the one without it), and
/// zstd-19 of the raw little-endian bytes; and its element count.
struct AttributeSize {
    name: String,
    raw: usize,
    packed: usize,
    zstd: usize,
    elements: usize,
}

/// How long unpacking takes once the last byte is in when the bytes arrive as a download
/// brings them (`pack::decode_from`): all but the last tenth handed over, time for the
/// decoder to take what it can from them (3× a whole unpack), then the rest.
fn unpack_after_last_byte(packed: &[u8], unpack: Duration) -> Duration {
    use std::io::Write;
    let (reader, mut writer) = std::io::pipe().expect("a pipe");
    let split = packed.len() * 9 / 10;
    let (head, tail) = (packed[..split].to_vec(), packed[split..].to_vec());
    let link = std::thread::spawn(move || {
        writer.write_all(&head).expect("the decoder reads");
        std::thread::sleep(3 * unpack);
        let last = std::time::Instant::now();
        writer.write_all(&tail).expect("the decoder reads");
        last
    });
    let (_, hash) = pack::decode_from(reader).expect("unpacks");
    let done = std::time::Instant::now();
    assert_eq!(hash, pack::stated_hash(packed).expect("sealed"));
    done - link.join().expect("the link thread")
}

fn attribute_sizes(mesh: &MeshData) -> Vec<AttributeSize> {
    let packed = pack::encode(mesh).expect("packs").len();
    mesh.attributes
        .iter()
        .map(|a| {
            let mut without = mesh.clone();
            without.attributes.remove(a.domain, &a.name);
            let cost = packed - pack::encode(&without).expect("packs").len();
            let raw = a.values.to_le_bytes();
            let ty = a.values.number_type().name();
            AttributeSize {
                name: format!("{} {} ({} × {ty})", a.domain.name(), a.name, a.components),
                raw: raw.len(),
                packed: cost,
                zstd: zstd19(&raw),
                elements: a.element_count(),
            }
        })
        .collect()
}

fn print_size(s: &AttributeSize) {
    let bits = 8.0 * s.packed as f64 / s.elements.max(1) as f64;
    println!(
        "    {:<30} raw {:>9}  packed {:>9} ({bits:5.2} bit/element)  zstd-19 {:>9}",
        s.name, s.raw, s.packed, s.zstd
    );
}

/// The `set-attribute` ops that give vertices `new` (each with its parents and weights)
/// values blended from their parents, as `blend_new_vertex_attributes` in the SDK writes
/// them for every vertex attribute but normals.
fn blends(mesh: &MeshData, new: &[(u32, [(u32, f64); 2])]) -> Vec<Op> {
    let ids: Vec<u32> = new.iter().map(|n| n.0).collect();
    mesh.attributes
        .iter()
        .filter(|a| a.domain == Domain::Vertex && a.name != NORMAL)
        .map(|a| {
            let per = usize::from(a.components);
            let mut values = meshflow_mesh::attributes::Values::empty(a.values.number_type());
            for (_, parents) in new {
                for k in 0..per {
                    let x: f64 =
                        parents.iter().map(|&(p, w)| w * a.values.get(per * p as usize + k)).sum();
                    values.push(x);
                }
            }
            Op::SetAttribute {
                domain: Domain::Vertex,
                name: a.name.clone(),
                components: a.components,
                ids: Some(ids.clone()),
                values,
            }
        })
        .collect()
}

/// Steps whose service writes attributes (on the painted meshes): their edit logs, the same
/// steps' without their `set-attribute` ops, and what the values add per element set (the
/// largest op's elements; the subdivision and midpoints set colour and quality of each).
fn set_attribute_steps(bunny: &MeshData, scan: &MeshData) {
    use meshflow_mesh::attributes::Values;
    use meshflow_plugin_remeshing::loop_subdivision::loop_subdivision;
    use meshflow_plugin_sdk::topology::halfedge::HalfEdges;
    use meshflow_plugin_smoothing::curvature::{Kind, curvature};

    println!(
        "\nsteps that write attributes: edit log bytes with and without them, best of {ATTRIBUTE_RUNS}:"
    );
    println!(
        "{:<8} {:<30} {:>9} {:>10} {:>10} {:>12} {:>9}",
        "mesh", "step", "elements", "mfc B", "w/o sets B", "bit/element", "enc ms"
    );
    type Step = Box<dyn Fn(&mut MeshStore, &MeshData)>;
    let subdivide: Step = Box::new(|store, m| {
        let result = loop_subdivision(&m.positions, &m.triangles, 1).expect("manifold");
        let old = m.positions.len();
        store.apply(Op::SetPositions { xyz: result.positions[..old].to_vec() }).expect("ok");
        let first = store.vertex_slots();
        store.apply(Op::AddVertices { xyz: result.positions[old..].to_vec() }).expect("ok");
        let new: Vec<(u32, [(u32, f64); 2])> = (first..)
            .zip(&result.edge_ends)
            .map(|(v, &[a, b])| (v, [(a, 0.5), (b, 0.5)]))
            .collect();
        for op in blends(m, &new) {
            store.apply(op).expect("blended values");
        }
        let all = (0..store.triangle_slots()).collect();
        store.apply(Op::RemoveTriangles { ids: all }).expect("ok");
        store.apply(Op::AddTriangles { abc: result.triangles }).expect("ok");
    });
    /// Every vertex's quality set at once, as a filter writing it does.
    fn set_quality(store: &mut MeshStore, q: Vec<f32>) {
        let values = Values::F32(q);
        let op = Op::SetAttribute {
            domain: Domain::Vertex,
            name: "quality".into(),
            components: 1,
            ids: None,
            values,
        };
        store.apply(op).expect("one quality per vertex");
    }
    fn curvature_as_quality(store: &mut MeshStore, m: &MeshData) {
        let kinds = HalfEdges::new(m.vertex_count(), &m.triangles);
        set_quality(store, curvature(&m.positions, &m.triangles, kinds.kinds(), Kind::Mean).values);
    }
    let rescale: Step = Box::new(|store, m| {
        let Some(Values::F32(q)) = m.attributes.get(Domain::Vertex, "quality").map(|a| &a.values)
        else {
            return;
        };
        set_quality(store, q.iter().map(|x| x * 0.9 + 0.01).collect());
    });
    // New vertices at the midpoint of every third triangle's first edge, blended (as a
    // service that splits by itself would write them).
    let midpoints: Step = Box::new(|store, m| {
        let mut xyz = Vec::new();
        let mut new = Vec::new();
        let first = store.vertex_slots();
        for t in m.triangles.chunks_exact(3).step_by(3) {
            let (a, b) = (t[0], t[1]);
            let p = |v: u32, k: usize| m.positions[3 * v as usize + k];
            xyz.extend((0..3).map(|k| 0.5 * (p(a, k) + p(b, k))));
            new.push((first + new.len() as u32, [(a, 0.5), (b, 0.5)]));
        }
        store.apply(Op::AddVertices { xyz }).expect("finite points");
        for op in blends(m, &new) {
            store.apply(op).expect("blended values");
        }
    });
    let steps: [(&str, &MeshData, &str, Step); 5] = [
        ("bunny", bunny, "loop subdivision (blended)", subdivide),
        ("scan 1M", scan, "curvature as quality", Box::new(curvature_as_quality)),
        ("scan 1M", scan, "quality x 0.9 + 0.01", rescale),
        ("scan 1M", scan, "midpoints, blended", midpoints),
        ("bunny", bunny, "curvature as quality", Box::new(curvature_as_quality)),
    ];
    for (name, mesh, step, edit) in steps {
        let painted = paint(mesh, false);
        let mut store = MeshStore::new(painted.clone());
        edit(&mut store, &painted);
        let (result, log) = store.finish();
        let (encode, bytes) =
            best(ATTRIBUTE_RUNS, || correction::encode(&painted, &log, &result).expect("encodes"));
        let applied = correction::apply(painted.clone(), &bytes).expect("applies");
        assert_eq!(applied.content_hash(), result.content_hash());
        // The same step without its set-attribute ops.
        let mut store = MeshStore::new(painted.clone());
        let sets = |op: &&Op| matches!(op, Op::SetAttribute { .. });
        for op in log.iter().filter(|op| !sets(op)) {
            store.apply(op.clone()).expect("replays");
        }
        let (bare_result, bare_log) = store.finish();
        let without = correction::encode(&painted, &bare_log, &bare_result).expect("encodes");
        let elements: usize = log.iter().filter(sets).map(Op::edit_count).max().unwrap_or(0);
        let bits = 8.0 * bytes.len().saturating_sub(without.len()) as f64 / elements as f64;
        println!(
            "{name:<8} {step:<30} {elements:>9} {:>10} {:>10} {bits:>12.2} {:>9.1}",
            bytes.len(),
            without.len(),
            ms(encode)
        );
    }
}

/// The attribute figures (see the module notes).
fn attributes_bench() {
    let bunny = io::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/data/bunny.obj"))
        .expect("the bunny ships with the repository");
    let spec = ScanSpec { vertices: 1_000_000, components: 150, holes: 40, noise: 0.2, seed: 11 };
    let scan = scan(&spec);
    println!("packed meshes (.mfm), best of {ATTRIBUTE_RUNS}:");
    println!(
        "{:<8} {:<26} {:>10} {:>9} {:>9} {:>11} {:>10} {:>10}",
        "mesh", "carries", "mfm B", "pack ms", "unpack ms", "arriving ms", "attr B", "zstd-19 B"
    );
    for (name, mesh) in [("bunny", &bunny), ("scan 1M", &scan)] {
        let painted = paint(mesh, true);
        let (v, t) = (mesh.vertex_count(), mesh.triangle_count());
        // Normals as the store computes them (area-weighted), after any step that moves.
        let mut store = MeshStore::new(painted.clone());
        let identity = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        store.apply(Op::Transform { matrix: identity }).expect("an affine map");
        let stored = store.finish().0;
        let normal = stored.attributes.get(Domain::Vertex, NORMAL).expect("kept");
        assert!(normal.values.to_le_bytes().iter().any(|&b| b != 0), "recomputed");
        // Normals as other tools write them (Blender: angle-weighted).
        let mut angled = painted.clone();
        let normals = Attribute::normal(angle_weighted_normals(mesh));
        angled.attributes.insert(normals, v, t).expect("one normal per vertex");
        let variants = [
            ("positions, triangles", mesh.clone()),
            ("+ colour, quality", paint(mesh, false)),
            ("+ c, q, store's normal", stored),
            ("+ c, q, angle-w. normal", angled),
        ];
        for (carries, m) in variants {
            let (pack_time, packed) = best(ATTRIBUTE_RUNS, || pack::encode(&m).expect("packs"));
            let (unpack, unpacked) =
                best(ATTRIBUTE_RUNS, || pack::decode(&packed).expect("unpacks"));
            assert_eq!(unpacked.content_hash(), m.content_hash());
            let arriving = (0..3).map(|_| unpack_after_last_byte(&packed, unpack)).min().unwrap();
            let raw: usize = m.attributes.iter().map(|a| a.values.to_le_bytes().len()).sum();
            let sizes = attribute_sizes(&m);
            let attr: usize = sizes.iter().map(|s| s.packed).sum();
            let zstd: usize = sizes.iter().map(|s| s.zstd).sum();
            println!(
                "{name:<8} {carries:<26} {:>10} {:>9.1} {:>9.1} {:>11.1} {:>10} {:>10}   raw {raw}",
                packed.len(),
                ms(pack_time),
                ms(unpack),
                ms(arriving),
                attr,
                zstd
            );
            for s in sizes {
                print_size(&s);
            }
        }
    }

    println!(
        "\nsteps: edit log (.mfc) bytes and the store's time for the step, best of {ATTRIBUTE_RUNS}:"
    );
    println!(
        "{:<8} {:<6} {:<26} {:>9} {:>10} {:>9} {:>9} {:>9}",
        "mesh", "step", "carries", "edits", "mfc B", "store ms", "enc ms", "apply ms"
    );
    type Step = fn(&mut MeshStore, &MeshData);
    let steps: [(&str, Step); 2] =
        [("RSC", |s, _| rsc(s)), ("LS(1)", |s, m| ls(s, m, Weights::Uniform))];
    for (name, mesh) in [("bunny", &bunny), ("scan 1M", &scan)] {
        let variants = [
            ("positions, triangles", mesh.clone()),
            ("+ colour, quality", paint(mesh, false)),
            ("+ colour, quality, normal", paint(mesh, true)),
        ];
        for (step, edit) in steps {
            for (carries, m) in &variants {
                let shared = Arc::new(m.clone());
                let (store_time, (result, log)) = best(ATTRIBUTE_RUNS, || {
                    let mut store = MeshStore::new(Arc::clone(&shared));
                    edit(&mut store, m);
                    store.finish()
                });
                let (encode, bytes) =
                    best(ATTRIBUTE_RUNS, || correction::encode(m, &log, &result).expect("encodes"));
                let (apply, applied) = best(ATTRIBUTE_RUNS, || {
                    correction::apply(Arc::clone(&shared), &bytes).expect("applies")
                });
                assert_eq!(applied.content_hash(), result.content_hash());
                if m.attributes.get(Domain::Vertex, NORMAL).is_some() && step == "LS(1)" {
                    assert_ne!(result.attributes, m.attributes, "normals recomputed");
                }
                let edits: usize = log.iter().map(|op| op.edit_count()).sum();
                println!(
                    "{name:<8} {step:<6} {carries:<26} {edits:>9} {:>10} {:>9.1} {:>9.1} {:>9.1}",
                    bytes.len(),
                    ms(store_time),
                    ms(encode),
                    ms(apply)
                );
            }
        }
    }

    set_attribute_steps(&bunny, &scan);

    let Ok(paths) = std::env::var("MESHFLOW_ATTRIBUTE_MESHES") else { return };
    println!(
        "\nmeshes from outside the repository: each attribute packed and as zstd-19 of its raw bytes:"
    );
    for path in paths.split(':').filter(|p| !p.is_empty()) {
        let mesh = io::load(Path::new(path)).expect("a mesh file");
        println!("{path}: {} vertices, {} triangles", mesh.vertex_count(), mesh.triangle_count());
        for s in attribute_sizes(&mesh) {
            print_size(&s);
        }
    }
}

fn main() {
    if std::env::args().any(|a| a == "attributes") {
        attributes_bench();
        return;
    }
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
    for r in &rows {
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
    println!("\nWith the base's neighbour means gathered before (ms):");
    println!(
        "{:<8} {:<6} {:>9} {:>9} {:>11} {:>9} {:>11}",
        "mesh", "step", "means", "enc", "enc, ready", "apply", "apply, ready"
    );
    for r in &rows {
        if let Some([gather, encode, apply]) = r.prepared {
            println!(
                "{:<8} {:<6} {:>9.1} {:>9.1} {:>11.1} {:>9.1} {:>11.1}",
                r.mesh,
                r.step,
                ms(gather),
                ms(r.encode),
                ms(encode),
                ms(r.apply),
                ms(apply)
            );
        }
    }
}
