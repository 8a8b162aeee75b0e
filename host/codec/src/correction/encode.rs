//! Writing a correction: replay the log through a store, coding each op against the state
//! before it.

use std::sync::Arc;

use meshflow_mesh::as_le_bytes_f32;
use meshflow_mesh::store::{MeshStore, Op};
use meshflow_mesh::{ContentHash, MeshData};

use super::CorrectionError;
use super::codec::{END, Models, Sections, kind_symbol, motion};
use super::coding::stream::SymbolWriter;
use super::header::{self, Correction, KINDS, KindCount, kind_index};
use super::means::{Means, NeighbourMeans};
use super::predict::{self, NewVertexNeighbours};
use super::removals::Removals;
use crate::quantize::Grid;

/// Encodes the edit log `log` that turned `base` into `result` (as the store's
/// [`finish`](MeshStore::finish) returned them). The log is replayed to make the
/// predictions; a log that does not apply to `base`, or does not give `result`, is refused.
pub fn encode(base: &MeshData, log: &[Op], result: &MeshData) -> Result<Vec<u8>, CorrectionError> {
    // Hashing is a pass over each mesh: done on a second thread while the replay edits its
    // own copy of the base.
    let (hashes, sections) = std::thread::scope(|s| {
        let hashes = s.spawn(|| (base.content_hash(), result.content_hash()));
        let sections = encode_sections(Arc::new(base.clone()), log, result, None);
        (hashes.join().expect("hashing does not panic"), sections)
    });
    write(hashes, sections?, log, [counts(base), counts(result)])
}

/// [`encode`] as a host calls it: the base is shared (the replay copies only what the log
/// edits) and both hashes are already known, so neither mesh is hashed again; the base's
/// neighbour means may have been gathered already (the same bytes either way).
pub fn encode_known(
    base: Arc<MeshData>,
    base_hash: ContentHash,
    log: &[Op],
    result: &MeshData,
    result_hash: ContentHash,
    prepared: Option<&NeighbourMeans>,
) -> Result<Vec<u8>, CorrectionError> {
    // Counted before the replay takes the base: a base no one else holds is edited in place.
    let base_counts = counts(&base);
    let prepared = prepared.and_then(|p| p.of_mesh(base_hash, base.vertex_count() as u32));
    let sections = encode_sections(base, log, result, prepared)?;
    write((base_hash, result_hash), sections, log, [base_counts, counts(result)])
}

/// The header (hashes, counts, grid, edits per kind) and the coded sections.
fn write(
    (base_hash, result_hash): (ContentHash, ContentHash),
    (grid, sections): (Option<Grid>, [Vec<u8>; 4]),
    log: &[Op],
    [base_counts, result_counts]: [[u64; 2]; 2],
) -> Result<Vec<u8>, CorrectionError> {
    let mut kinds = [KindCount::default(); KINDS];
    for op in log {
        let count = &mut kinds[kind_index(op.kind())];
        count.ops += 1;
        count.edits += op.edit_count() as u64;
    }
    let header = Correction {
        version: header::VERSION,
        base: base_hash,
        result: result_hash,
        base_counts,
        result_counts,
        grid,
        kinds,
        header_bytes: 0,
        section_bytes: [0; 4],
    };
    Ok(header::write(&header, &sections))
}

fn counts(mesh: &MeshData) -> [u64; 2] {
    [mesh.vertex_count() as u64, mesh.triangle_count() as u64]
}

/// Codes the log's ops into the four sections, replaying them; checks the replay ends at
/// `result` (byte for byte, which is what equal hashes mean). `prepared` are the base's
/// neighbour means, if gathered.
fn encode_sections(
    base: Arc<MeshData>,
    log: &[Op],
    result: &MeshData,
    prepared: Option<&Means>,
) -> Result<(Option<Grid>, [Vec<u8>; 4]), CorrectionError> {
    // A step that edited nothing (a repair with nothing to repair) codes no op: no grid to
    // detect and no replay, only the check that its result is its base.
    if log.is_empty() {
        if !same_bytes(&base, result) {
            let (expected, found) = (result.content_hash(), base.content_hash());
            return Err(CorrectionError::ResultMismatch { expected, found });
        }
        return Ok((None, std::array::from_fn(|_| SymbolWriter::new().finish())));
    }
    // Detected, not declared: any mesh whose coordinates all sit on a coarse grid gains.
    let grid = Grid::detect([&base.positions[..], &result.positions[..]]);
    let mut encoder = Encoder {
        store: MeshStore::new(base),
        models: Models::new(grid),
        out: Sections {
            ops: SymbolWriter::new(),
            ids: SymbolWriter::new(),
            connectivity: SymbolWriter::new(),
            geometry: SymbolWriter::new(),
        },
        kind_announced: false,
        prepared,
    };
    let mut i = 0;
    while i < log.len() {
        i += encoder.op(i, &log[i], log.get(i + 1))?;
    }
    let (replayed, _) = encoder.store.finish();
    if !same_bytes(&replayed, result) {
        let (expected, found) = (result.content_hash(), replayed.content_hash());
        return Err(CorrectionError::ResultMismatch { expected, found });
    }
    let Sections { ops, ids, connectivity, geometry } = encoder.out;
    Ok((grid, [ops.finish(), ids.finish(), connectivity.finish(), geometry.finish()]))
}

struct Encoder<'p> {
    store: MeshStore,
    models: Models,
    out: Sections<SymbolWriter>,
    /// The current op's kind was already written (right after the previous op's count).
    kind_announced: bool,
    /// The base's neighbour means, gathered before: they hold for the first op only.
    prepared: Option<&'p Means>,
}

impl Encoder<'_> {
    /// Codes and applies `op` (and `next` with it, where they are coded as a pair); returns
    /// how many ops it consumed.
    fn op(&mut self, index: usize, op: &Op, next: Option<&Op>) -> Result<usize, CorrectionError> {
        if !std::mem::take(&mut self.kind_announced) {
            self.out.ops.symbol(&mut self.models.kind, kind_symbol(op.kind()));
        }
        let (m, out) = (&mut self.models, &mut self.out);
        match op {
            Op::AddVertices { xyz } => return self.add_vertices(index, xyz, next),
            Op::AddTriangles { abc } => self.triangles(abc),
            Op::MoveVertices { ids, xyz } => {
                m.lists.write(&mut out.ids, ids);
                for (&v, p) in ids.iter().zip(xyz.chunks_exact(3)) {
                    let from = predict::point(&self.store, v);
                    m.moves.write(&mut out.geometry, [p[0], p[1], p[2]], from);
                }
            }
            Op::SetPositions { xyz } => self.set_positions(index, xyz),
            Op::RemoveVertices { ids }
            | Op::RemoveTriangles { ids }
            | Op::FlipTriangles { ids } => {
                m.removals.write(&mut self.store, &mut m.lists, &mut out.ids, op.kind(), ids)
            }
            Op::SplitTriangle { triangle, at } => {
                m.elements.write_triangle(&mut out.ops, *triangle);
                let predicted = predict::centroid(&self.store, *triangle);
                self.point(*at, predicted);
            }
            Op::SplitEdge { edge, at } => {
                m.elements.write_edge(&mut out.ops, *edge);
                let predicted = predict::midpoint(&self.store, *edge);
                self.point(*at, predicted);
            }
            Op::ExtendEdge { edge, vertex } => {
                m.elements.write_edge(&mut out.ops, *edge);
                out.ops.int(&mut m.extend_vertex, vertex.wrapping_sub(m.last_extend_vertex) as i32);
                m.last_extend_vertex = *vertex;
            }
            Op::SwapEdge { edge } | Op::CollapseEdge { edge } => {
                m.elements.write_edge(&mut out.ops, *edge)
            }
            Op::RemoveComponent { triangle } => m.elements.write_triangle(&mut out.ops, *triangle),
            Op::TransformComponent { triangle, matrix } => {
                m.elements.write_triangle(&mut out.ops, *triangle);
                matrix.iter().for_each(|&v| out.geometry.f32_bits(v));
            }
            Op::Transform { matrix } => matrix.iter().for_each(|&v| out.geometry.f32_bits(v)),
            Op::Clear => {}
            Op::SetAttribute { .. } | Op::RemoveAttribute { .. } => m.attributes.write(
                [&mut out.ops, &mut out.ids, &mut out.geometry],
                &mut m.lists,
                &self.store,
                op,
            ),
        }
        self.apply(index, op)?;
        Ok(1)
    }

    /// New vertices are predicted from the triangles that use them, so when triangles are
    /// added right after (as hole filling does), their corners are coded first.
    fn add_vertices(
        &mut self,
        index: usize,
        xyz: &[f32],
        next: Option<&Op>,
    ) -> Result<usize, CorrectionError> {
        let (m, out) = (&mut self.models, &mut self.out);
        out.ops.uint(&mut m.count, (xyz.len() / 3) as u32);
        // The decoder must know now whether triangles follow.
        out.ops.symbol(&mut m.kind, next.map_or(END, |n| kind_symbol(n.kind())));
        let first = self.store.vertex_slots();
        let abc: &[u32] = match next {
            Some(Op::AddTriangles { abc }) => {
                self.triangles(abc);
                abc
            }
            _ => {
                self.kind_announced = true;
                &[]
            }
        };
        let around = NewVertexNeighbours::new(first, xyz.len() / 3, abc);
        for (j, p) in xyz.chunks_exact(3).enumerate() {
            let predicted = around.predict(&self.store, xyz, j);
            self.models.new_points.write(&mut self.out.geometry, [p[0], p[1], p[2]], predicted);
        }
        self.apply(index, &Op::AddVertices { xyz: xyz.to_vec() })?;
        match next {
            Some(next @ Op::AddTriangles { .. }) => {
                self.apply(index + 1, next)?;
                Ok(2)
            }
            _ => Ok(1),
        }
    }

    fn apply(&mut self, index: usize, op: &Op) -> Result<(), CorrectionError> {
        let corners = Removals::before(&self.store, op);
        self.store.apply(op.clone()).map_err(|source| CorrectionError::Replay {
            op: index,
            kind: op.kind(),
            source,
        })?;
        self.models.removals.applied(&mut self.store, corners);
        Ok(())
    }

    fn triangles(&mut self, abc: &[u32]) {
        let (m, out) = (&mut self.models, &mut self.out);
        out.ops.uint(&mut m.count, (abc.len() / 3) as u32);
        m.corners.restart(self.store.vertex_slots());
        for t in abc.chunks_exact(3) {
            m.corners.write(&mut out.connectivity, [t[0], t[1], t[2]]);
        }
    }

    /// An optional explicit point of a split, as a residual from the default point.
    fn point(&mut self, at: Option<[f32; 3]>, predicted: Option<[f32; 3]>) {
        let (m, out) = (&mut self.models, &mut self.out);
        out.ops.bit(&mut m.has_point, at.is_some());
        if let Some(p) = at {
            m.split_points.write(&mut out.geometry, p, predicted.unwrap_or([0.0; 3]));
        }
    }

    /// Every live vertex: still, exactly predicted, or its residual from the prediction,
    /// one step of uniform Laplacian smoothing with the factor that fits this op best.
    fn set_positions(&mut self, index: usize, xyz: &[f32]) {
        let store = &self.store;
        let current = store.positions();
        if xyz.len() != current.len() {
            return; // the store refuses it in `apply`
        }
        let grid = self.models.grid;
        // Fitting λ and coding need each mean up to four times: gathered once (or before).
        let gathered;
        let means = match self.prepared.filter(|_| index == 0) {
            Some(prepared) => prepared,
            None => {
                gathered = Means::of(current, store.triangles(), store.vertex_slots());
                &gathered
            }
        };
        let moved = Moved { store, current, new: xyz, grid, means };
        let lambda = moved.best_lambda();
        let (m, out) = (&mut self.models, &mut self.out);
        out.geometry.f32_bits(lambda);
        let mut context = motion::STILL;
        for v in (0..store.vertex_slots()).filter(|&v| store.is_vertex_live(v)) {
            let (p, q) = (at(current, v), at(xyz, v));
            let predicted = predict::smoothed(p, means.get(v), lambda, grid);
            // "Predicted" first: on a grid, many small moves snap back to the old position,
            // and one symbol for all of them keeps the runs long.
            let model = &mut m.motion[context];
            if same_bits(q, predicted) {
                out.geometry.symbol(model, motion::PREDICTED);
                context = motion::PREDICTED;
            } else if same_bits(q, p) {
                out.geometry.symbol(model, motion::STILL);
                context = motion::STILL;
            } else {
                m.smoothing.write_joint(&mut out.geometry, q, predicted, model, motion::RESIDUAL);
                context = motion::RESIDUAL + m.smoothing.class();
            }
        }
    }
}

/// Bit-identical meshes (so `-0.0 != 0.0`, as in the content hash).
fn same_bytes(a: &MeshData, b: &MeshData) -> bool {
    a.triangles == b.triangles
        && as_le_bytes_f32(&a.positions) == as_le_bytes_f32(&b.positions)
        && a.attributes.materials == b.attributes.materials
        && a.attributes.len() == b.attributes.len()
        && a.attributes.iter().zip(b.attributes.iter()).all(|(x, y)| {
            (x.domain, &x.name, x.components) == (y.domain, &y.name, y.components)
                && x.values.number_type() == y.values.number_type()
                && x.values.le_bytes() == y.values.le_bytes()
        })
}

fn at(positions: &[f32], v: u32) -> [f32; 3] {
    let i = 3 * v as usize;
    [positions[i], positions[i + 1], positions[i + 2]]
}

fn same_bits(a: [f32; 3], b: [f32; 3]) -> bool {
    a.map(f32::to_bits) == b.map(f32::to_bits)
}

/// The live vertices a `set-positions` moves, with what predicts them.
struct Moved<'a> {
    store: &'a MeshStore,
    current: &'a [f32],
    new: &'a [f32],
    grid: Option<Grid>,
    means: &'a Means,
}

impl Moved<'_> {
    /// `(old, new, neighbour mean)` of each live vertex that moved and has neighbours.
    fn each(&self) -> impl Iterator<Item = ([f32; 3], [f32; 3], [f64; 3])> + '_ {
        (0..self.store.vertex_slots()).filter_map(|v| {
            let (p, q) = (at(self.current, v), at(self.new, v));
            if !self.store.is_vertex_live(v) || same_bits(p, q) {
                return None;
            }
            Some((p, q, self.means.get(v)?))
        })
    }

    /// The smoothing factor to code: the least-squares fit of `new ≈ p + λ (mean − p)`, or
    /// exactly 1 (plain neighbour averaging) when that is within rounding of the fit or
    /// predicts more vertices exactly (on a grid, snapping skews the fit).
    fn best_lambda(&self) -> f32 {
        let (mut num, mut den) = (0.0f64, 0.0f64);
        for (p, q, mean) in self.each() {
            for k in 0..3 {
                let (d, l) = (f64::from(q[k]) - f64::from(p[k]), mean[k] - f64::from(p[k]));
                num += d * l;
                den += l * l;
            }
        }
        let fitted = (num / den) as f32;
        if !fitted.is_finite() || (fitted - 1.0).abs() < 1e-4 {
            return 1.0;
        }
        let hits = |lambda: f32| {
            let exact = |&(p, q, mean): &([f32; 3], [f32; 3], [f64; 3])| {
                same_bits(q, predict::smoothed(p, Some(mean), lambda, self.grid))
            };
            self.each().filter(exact).count()
        };
        if hits(1.0) > hits(fitted) { 1.0 } else { fitted }
    }
}
