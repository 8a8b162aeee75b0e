//! Writing a correction: replay the log through a store, coding each op against the state
//! before it.

use crate::MeshData;
use crate::store::{MeshStore, Op};

use super::CorrectionError;
use super::codec::{END, Models, Sections, kind_symbol, motion};
use super::coding::stream::SymbolWriter;
use super::header::{self, Correction, KindCount, kind_index};
use super::predict::{self, Neighbours, NewVertexNeighbours, neighbour_mean, smoothed};

/// Encodes the edit log `log` that turned `base` into `result` (as the store's
/// [`finish`](MeshStore::finish) returned them). The log is replayed to make the
/// predictions; a log that does not apply to `base`, or does not give `result`, is refused.
pub fn encode(base: &MeshData, log: &[Op], result: &MeshData) -> Result<Vec<u8>, CorrectionError> {
    let mut kinds = [KindCount::default(); 16];
    for op in log {
        let count = &mut kinds[kind_index(op.kind())];
        count.ops += 1;
        count.edits += op.edit_count() as u64;
    }
    let mut encoder = Encoder {
        store: MeshStore::new(base.clone()),
        models: Models::new(),
        out: Sections {
            ops: SymbolWriter::new(),
            ids: SymbolWriter::new(),
            connectivity: SymbolWriter::new(),
            geometry: SymbolWriter::new(),
        },
        kind_announced: false,
    };
    let mut i = 0;
    while i < log.len() {
        i += encoder.op(i, &log[i], log.get(i + 1))?;
    }
    let (replayed, _) = encoder.store.finish();
    let (expected, found) = (result.content_hash(), replayed.content_hash());
    if expected != found {
        return Err(CorrectionError::ResultMismatch { expected, found });
    }
    let header = Correction {
        version: header::VERSION,
        base: base.content_hash(),
        result: expected,
        base_counts: [base.vertex_count() as u64, base.triangle_count() as u64],
        result_counts: [result.vertex_count() as u64, result.triangle_count() as u64],
        kinds,
        header_bytes: 0,
        section_bytes: [0; 4],
    };
    let Sections { ops, ids, connectivity, geometry } = encoder.out;
    Ok(header::write(
        &header,
        &[ops.finish(), ids.finish(), connectivity.finish(), geometry.finish()],
    ))
}

struct Encoder {
    store: MeshStore,
    models: Models,
    out: Sections<SymbolWriter>,
    /// The current op's kind was already written (right after the previous op's count).
    kind_announced: bool,
}

impl Encoder {
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
            Op::SetPositions { xyz } => self.set_positions(xyz),
            Op::RemoveVertices { ids }
            | Op::RemoveTriangles { ids }
            | Op::FlipTriangles { ids } => m.lists.write(&mut out.ids, ids),
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
        self.store.apply(op.clone()).map(|_| ()).map_err(|source| CorrectionError::Replay {
            op: index,
            kind: op.kind(),
            source,
        })
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
    fn set_positions(&mut self, xyz: &[f32]) {
        let store = &self.store;
        let current = store.positions();
        if xyz.len() != current.len() {
            return; // the store refuses it in `apply`
        }
        let neighbours = Neighbours::of_store(store);
        let live = |v: u32| store.is_vertex_live(v);
        let means: Vec<Option<[f64; 3]>> = (0..store.vertex_slots())
            .map(|v| if live(v) { neighbour_mean(current, neighbours.of(v)) } else { None })
            .collect();
        let lambda = fit_lambda(current, xyz, &means);
        let (m, out) = (&mut self.models, &mut self.out);
        out.geometry.f32_bits(lambda);
        let mut previous = motion::STILL;
        for v in 0..store.vertex_slots() {
            if !live(v) {
                continue;
            }
            let i = 3 * v as usize;
            let p = [current[i], current[i + 1], current[i + 2]];
            let q = [xyz[i], xyz[i + 1], xyz[i + 2]];
            let predicted = means[v as usize].map_or(p, |mean| smoothed(p, mean, lambda));
            let state = if same_bits(q, p) {
                motion::STILL
            } else if same_bits(q, predicted) {
                motion::PREDICTED
            } else {
                motion::RESIDUAL
            };
            out.geometry.symbol(&mut m.motion[previous], state);
            previous = state;
            if state == motion::RESIDUAL {
                m.smoothing.write(&mut out.geometry, q, predicted);
            }
        }
    }
}

fn same_bits(a: [f32; 3], b: [f32; 3]) -> bool {
    a.map(f32::to_bits) == b.map(f32::to_bits)
}

/// The least-squares smoothing factor λ of `new ≈ p + λ (mean − p)` over the vertices that
/// moved; snapped to exactly 1 (plain neighbour averaging) when within rounding of it.
fn fit_lambda(current: &[f32], new: &[f32], means: &[Option<[f64; 3]>]) -> f32 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for (v, mean) in means.iter().enumerate() {
        let Some(mean) = mean else { continue };
        for k in 0..3 {
            let p = f64::from(current[3 * v + k]);
            let (d, l) = (f64::from(new[3 * v + k]) - p, mean[k] - p);
            if d != 0.0 {
                num += d * l;
                den += l * l;
            }
        }
    }
    let lambda = (num / den) as f32;
    if !lambda.is_finite() || (lambda - 1.0).abs() < 1e-4 { 1.0 } else { lambda }
}
