//! Shared by the correction and pack tests: a small PRNG, scan-like test meshes, random
//! edit sequences of every op kind, a smoothing step, and the round-trip check.

#![allow(dead_code)] // each test binary uses part of it

use meshflow_codec::correction;
use meshflow_mesh::MeshData;
use meshflow_mesh::attributes::{Domain, NumberType, Values};
use meshflow_mesh::store::{MeshStore, Op, OpKind};

/// SplitMix64: deterministic, seedable, good enough for test data.
pub struct Rng(pub u64);

impl Rng {
    pub fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    pub fn below(&mut self, n: u32) -> u32 {
        (self.next() % u64::from(n.max(1))) as u32
    }

    /// Uniform in [-1, 1).
    pub fn unit(&mut self) -> f32 {
        (self.next() >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    }

    pub fn chance(&mut self, percent: u32) -> bool {
        self.below(100) < percent
    }
}

/// A bumpy `w` x `h` vertex grid (two triangles per cell) plus `islands` separate small
/// triangles, like spurious scan fragments.
pub fn grid(w: u32, h: u32, islands: u32, rng: &mut Rng) -> MeshData {
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let bump = 0.05 * rng.unit();
            positions.extend([x as f32 * 0.1, y as f32 * 0.1, bump + (x as f32 * 0.3).sin()]);
        }
    }
    for y in 0..h.saturating_sub(1) {
        for x in 0..w.saturating_sub(1) {
            let v = y * w + x;
            triangles.extend([v, v + 1, v + w + 1, v, v + w + 1, v + w]);
        }
    }
    for _ in 0..islands {
        let v = (positions.len() / 3) as u32;
        let (cx, cy) = (rng.unit() * 5.0, rng.unit() * 5.0);
        positions.extend([cx, cy, 1.0, cx + 0.01, cy, 1.0, cx, cy + 0.01, 1.0]);
        triangles.extend([v, v + 1, v + 2]);
    }
    MeshData::new(positions, triangles)
}

fn live_vertex(store: &MeshStore, rng: &mut Rng) -> Option<u32> {
    (0..8).map(|_| rng.below(store.vertex_slots())).find(|&v| store.is_vertex_live(v))
}

fn live_triangle(store: &MeshStore, rng: &mut Rng) -> Option<u32> {
    (0..8).map(|_| rng.below(store.triangle_slots())).find(|&t| store.is_triangle_live(t))
}

fn distinct<T: Ord>(mut ids: Vec<T>, ascending: bool) -> Vec<T> {
    ids.sort();
    ids.dedup();
    if !ascending {
        ids.reverse();
    }
    ids
}

fn near(store: &MeshStore, rng: &mut Rng) -> [f32; 3] {
    let base = live_vertex(store, rng).and_then(|v| store.position(v).ok()).unwrap_or([0.0; 3]);
    base.map(|c| c + 0.05 * rng.unit())
}

fn matrix(rng: &mut Rng) -> [f32; 12] {
    let mut m = [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
    for v in &mut m {
        *v += 0.1 * rng.unit();
    }
    m
}

/// A random op of the given kind against the store's current state (it may be refused).
pub fn random_op(kind: OpKind, store: &MeshStore, rng: &mut Rng) -> Option<Op> {
    let edge = |rng: &mut Rng| live_triangle(store, rng).map(|t| 3 * t + rng.below(3));
    Some(match kind {
        OpKind::AddVertices => {
            Op::AddVertices { xyz: (0..1 + rng.below(4)).flat_map(|_| near(store, rng)).collect() }
        }
        OpKind::MoveVertices => {
            let ids: Vec<u32> =
                (0..1 + rng.below(6)).filter_map(|_| live_vertex(store, rng)).collect();
            let ids = if rng.chance(50) { distinct(ids, rng.chance(70)) } else { ids };
            let xyz = ids.iter().flat_map(|_| near(store, rng)).collect();
            Op::MoveVertices { ids, xyz }
        }
        OpKind::SetPositions => {
            let lambda = if rng.chance(50) { 1.0 } else { 0.3 + 0.5 * rng.unit().abs() };
            let p = store.positions();
            let mut xyz = p.to_vec();
            for v in 0..store.vertex_slots() as usize {
                if rng.chance(80) {
                    for k in 0..3 {
                        let neighbour = p[3 * ((v + 1) % store.vertex_slots() as usize) + k];
                        xyz[3 * v + k] = p[3 * v + k] + lambda * (neighbour - p[3 * v + k]);
                    }
                }
            }
            Op::SetPositions { xyz }
        }
        OpKind::RemoveVertices => Op::RemoveVertices {
            ids: distinct(
                (0..1 + rng.below(3)).filter_map(|_| live_vertex(store, rng)).collect(),
                rng.chance(70),
            ),
        },
        OpKind::AddTriangles => {
            let mut abc = Vec::new();
            for _ in 0..1 + rng.below(3) {
                abc.extend([
                    live_vertex(store, rng)?,
                    live_vertex(store, rng)?,
                    live_vertex(store, rng)?,
                ]);
            }
            Op::AddTriangles { abc }
        }
        OpKind::RemoveTriangles => Op::RemoveTriangles {
            ids: distinct(
                (0..1 + rng.below(8)).filter_map(|_| live_triangle(store, rng)).collect(),
                rng.chance(70),
            ),
        },
        OpKind::FlipTriangles => Op::FlipTriangles {
            ids: (0..1 + rng.below(4)).filter_map(|_| live_triangle(store, rng)).collect(),
        },
        OpKind::SplitTriangle => Op::SplitTriangle {
            triangle: live_triangle(store, rng)?,
            at: rng.chance(50).then(|| near(store, rng)),
        },
        OpKind::ExtendEdge => Op::ExtendEdge { edge: edge(rng)?, vertex: live_vertex(store, rng)? },
        OpKind::SplitEdge => {
            Op::SplitEdge { edge: edge(rng)?, at: rng.chance(50).then(|| near(store, rng)) }
        }
        OpKind::SwapEdge => Op::SwapEdge { edge: edge(rng)? },
        OpKind::CollapseEdge => Op::CollapseEdge { edge: edge(rng)? },
        OpKind::RemoveComponent => Op::RemoveComponent { triangle: live_triangle(store, rng)? },
        OpKind::TransformComponent => {
            Op::TransformComponent { triangle: live_triangle(store, rng)?, matrix: matrix(rng) }
        }
        OpKind::Transform => Op::Transform { matrix: matrix(rng) },
        OpKind::Clear => Op::Clear,
        OpKind::SetAttribute => set_attribute(store, rng)?,
        OpKind::RemoveAttribute => {
            let (domain, name, ..) = ATTRIBUTES[rng.below(ATTRIBUTES.len() as u32) as usize];
            Op::RemoveAttribute { domain, name: name.into() }
        }
    })
}

/// The attributes random edits set: well-known ones and one of a file's own.
const ATTRIBUTES: [(Domain, &str, u8, NumberType); 4] = [
    (Domain::Vertex, "quality", 1, NumberType::F32),
    (Domain::Vertex, "color", 4, NumberType::U8),
    (Domain::Face, "label", 1, NumberType::I32),
    (Domain::Corner, "texcoord", 2, NumberType::F32),
];

/// A set-attribute on some live elements, or on every slot.
fn set_attribute(store: &MeshStore, rng: &mut Rng) -> Option<Op> {
    let (domain, name, components, ty) = ATTRIBUTES[rng.below(ATTRIBUTES.len() as u32) as usize];
    let ids: Option<Vec<u32>> = if rng.chance(30) {
        None
    } else {
        let one = |rng: &mut Rng| match domain {
            Domain::Vertex => live_vertex(store, rng),
            Domain::Face => live_triangle(store, rng),
            Domain::Corner => live_triangle(store, rng).map(|t| 3 * t + rng.below(3)),
        };
        Some((0..1 + rng.below(5)).filter_map(|_| one(rng)).collect())
    };
    let elements = ids.as_ref().map_or_else(
        || domain.len(store.vertex_slots() as usize, store.triangle_slots() as usize),
        Vec::len,
    );
    let mut values = Values::empty(ty);
    for _ in 0..elements * usize::from(components) {
        values.push(match ty {
            NumberType::U8 => f64::from(rng.below(256)),
            NumberType::I32 => f64::from(rng.below(2000)) - 1000.0,
            _ => f64::from(rng.unit()),
        });
    }
    Some(Op::SetAttribute { domain, name: name.into(), components, ids, values })
}

/// Hole-filling shaped: new vertices and, right after, triangles joining them to the mesh.
pub fn fill_like(store: &mut MeshStore, rng: &mut Rng) {
    let first = store.vertex_slots();
    let count = 1 + rng.below(4);
    let xyz: Vec<f32> = (0..count).flat_map(|_| near(store, rng)).collect();
    let Some(anchor) = live_vertex(store, rng) else { return };
    if store.apply(Op::AddVertices { xyz }).is_err() {
        return;
    }
    let mut abc = Vec::new();
    for j in 0..count {
        let other = if j + 1 < count { first + j + 1 } else { anchor };
        if other != first + j && other != anchor {
            abc.extend([first + j, other, anchor]);
        }
    }
    let _ = store.apply(Op::AddTriangles { abc });
}

/// `steps` random edits on `store`, of every kind (clear rarely); refused ones are skipped.
pub fn random_edits(store: &mut MeshStore, rng: &mut Rng, steps: usize) {
    for _ in 0..steps {
        let pick = rng.below(OpKind::ALL.len() as u32 + 1) as usize;
        if pick == OpKind::ALL.len() {
            fill_like(store, rng);
            continue;
        }
        let kind = OpKind::ALL[pick];
        if kind == OpKind::Clear && !rng.chance(10) {
            continue;
        }
        if let Some(op) = random_op(kind, store, rng) {
            let _ = store.apply(op);
        }
    }
}

/// Encodes the step, applies it to the base, and checks hash, bytes and the replayed log.
pub fn assert_round_trip(base: &MeshData, result: &MeshData, log: &[Op]) -> Vec<u8> {
    let bytes = correction::encode(base, log, result).expect("a store's own log encodes");
    let (replayed, replayed_log) = correction::replay(base.clone(), &bytes).expect("applies");
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

/// Uniform Laplacian smoothing with factor `lambda`, interior vertices only, in f64 over
/// sorted distinct neighbours.
pub fn smooth(mesh: &MeshData, lambda: f64) -> Vec<f32> {
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
            // Divided, as `laplacian-smoothing` does.
            let mean = sum / list.len() as f64;
            let p = f64::from(mesh.positions[3 * v + k]);
            out[3 * v + k] = (mean * lambda + p * (1.0 - lambda)) as f32;
        }
    }
    out
}

/// `mesh` with one attribute of every domain and number type, values from `rng` (colours and
/// quality smooth over the surface plus noise, the rest anything finite), and materials.
pub fn attributed(mut mesh: MeshData, rng: &mut Rng) -> MeshData {
    use meshflow_mesh::attributes::{Attribute, Materials};
    let (v, t) = (mesh.vertex_count(), mesh.triangle_count());
    let p = mesh.positions.clone();
    let colour: Vec<u8> = (0..v)
        .flat_map(|i| {
            let wave = |k: usize, f: f32| (127.0 + 100.0 * (f * p[3 * i + k]).sin()) as i32;
            let noise = rng.below(9) as i32 - 4;
            [wave(0, 0.3) + noise, wave(1, 0.5) + noise, wave(2, 0.2) + noise, 255]
                .map(|c| c.clamp(0, 255) as u8)
        })
        .collect();
    let quality = (0..v).map(|i| p[3 * i] * p[3 * i + 1] + 0.01 * rng.unit()).collect();
    let label: Vec<i32> = (0..t).map(|i| (i / 7) as i32 - rng.below(2) as i32).collect();
    let uv: Vec<f32> = (0..3 * t)
        .flat_map(|c| {
            let corner = mesh.triangles[c] as usize;
            [p[3 * corner], p[3 * corner + 1] + if rng.chance(5) { 0.5 } else { 0.0 }]
        })
        .collect();
    let weight: Vec<f64> = (0..v).map(|_| f64::from(rng.unit()) * 1e-3).collect();
    let flags: Vec<u32> = (0..t).map(|_| rng.below(4)).collect();
    let normal: Vec<f32> = (0..v)
        .flat_map(|i| {
            let n = [p[3 * i].cos(), 1.0 + 0.01 * rng.unit(), p[3 * i + 1].sin()];
            let length = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
            n.map(|c| c / length)
        })
        .collect();
    let a = &mut mesh.attributes;
    a.insert(Attribute::normal(normal), v, t).unwrap();
    a.insert(Attribute::color(colour), v, t).unwrap();
    a.insert(Attribute::quality(quality), v, t).unwrap();
    a.insert(Attribute::texcoord(Domain::Corner, uv), v, t).unwrap();
    for (domain, name, components, values) in [
        (Domain::Face, "label", 1, Values::I32(label)),
        (Domain::Vertex, "weight", 1, Values::F64(weight)),
        (Domain::Face, "flags", 1, Values::U32(flags)),
    ] {
        a.insert(Attribute { domain, name: name.into(), components, values }, v, t).unwrap();
    }
    a.materials = Materials {
        names: vec!["skin".into(), "Ölfarbe".into()],
        libraries: vec!["scan.mtl".into()],
        textures: vec!["scan_0.png".into()],
    };
    mesh
}
