//! Replaying a correction: decode each op against the state before it, apply it, repeat.

use std::collections::VecDeque;
use std::sync::{Arc, mpsc};

use meshflow_mesh::MeshData;
use meshflow_mesh::store::{MeshStore, Op, OpKind};

use super::CorrectionError;
use super::codec::{END, Models, Sections, motion};
use super::coding::residual::{ResidualCoder, Residuals};
use super::coding::stream::{CorruptStream, SymbolReader};
use super::header::{Correction, KINDS, KindCount, kind_index};
use super::means::{MeanSource, Means};
use super::predict::{self, Neighbours, NewVertexNeighbours};
use super::removals::Removals;

/// Decoded element counts may exceed the file size by at most this factor: the adaptive
/// models never give a symbol a probability above `1 - 2^-16`, so no honest correction
/// packs more elements per byte, and a forged count cannot make the decoder allocate more.
const ELEMENTS_PER_BYTE: u64 = 1 << 13;
const ELEMENT_SLACK: u64 = 1 << 16;
/// Vertices per batch of `set-positions` predictions handed between threads: small enough
/// to stay in cache, large enough that handing over costs nothing.
const CHUNK: u32 = 8192;

/// Replays the sections of a correction whose header was read, starting from `base`
/// (whose neighbour means may have been gathered already). Returns the compacted result
/// and the log the replay recorded.
pub(super) fn replay(
    header: &Correction,
    sections: [&[u8]; 4],
    base: Arc<MeshData>,
    prepared: Option<&Means>,
) -> Result<(MeshData, Vec<Op>), CorrectionError> {
    let budget = ELEMENTS_PER_BYTE * header.total_bytes() as u64 + ELEMENT_SLACK;
    let declared: u64 = OpKind::ALL
        .iter()
        .filter(|&&k| k != OpKind::SetPositions)
        .map(|&k| header.count(k).edits.max(header.count(k).ops))
        .sum();
    if declared > budget {
        return Err(CorrectionError::Malformed(format!(
            "{declared} edits declared in a {}-byte correction",
            header.total_bytes()
        )));
    }
    let corrupt = |_| CorrectionError::Corrupt { op: 0 };
    let mut decoder = Decoder {
        store: MeshStore::new(base),
        models: Models::new(header.grid),
        input: Sections {
            ops: SymbolReader::new(sections[0]).map_err(corrupt)?,
            ids: SymbolReader::new(sections[1]).map_err(corrupt)?,
            connectivity: SymbolReader::new(sections[2]).map_err(corrupt)?,
            geometry: SymbolReader::new(sections[3]).map_err(corrupt)?,
        },
        remaining: header.kinds,
        announced: None,
        prepared,
    };
    let total_ops = header.op_count();
    let mut index = 0usize;
    while (index as u64) < total_ops {
        index += decoder.op(index)?;
    }
    if decoder.remaining.iter().any(|k| k.ops != 0 || k.edits != 0) {
        return Err(CorrectionError::Corrupt { op: index });
    }
    Ok(decoder.store.finish())
}

struct Decoder<'p> {
    store: MeshStore,
    models: Models,
    input: Sections<SymbolReader>,
    /// What the header says is still to come, per kind.
    remaining: [KindCount; KINDS],
    /// The kind of the next op, when it was read early (after an add-vertices).
    announced: Option<usize>,
    /// The base's neighbour means, gathered before: they hold for the first op only.
    prepared: Option<&'p Means>,
}

impl Decoder<'_> {
    /// Decodes and applies the op at `index` (and the next one, for a coded pair); returns
    /// how many ops it consumed.
    fn op(&mut self, index: usize) -> Result<usize, CorrectionError> {
        let corrupt = |_: CorruptStream| CorrectionError::Corrupt { op: index };
        let kind = self.kind().map_err(corrupt)?;
        if kind == OpKind::AddVertices {
            return self.add_vertices(index);
        }
        let op = self.decode(index, kind).map_err(corrupt)?;
        self.apply(index, op)?;
        Ok(1)
    }

    fn decode(&mut self, index: usize, kind: OpKind) -> Result<Op, CorruptStream> {
        if is_single(kind) {
            self.take(kind, 1)?;
        }
        let (m, input) = (&mut self.models, &mut self.input);
        Ok(match kind {
            OpKind::AddVertices => unreachable!("decoded with the triangles that may follow"),
            OpKind::AddTriangles => Op::AddTriangles { abc: self.triangles()? },
            OpKind::MoveVertices => {
                let ids = self.ids(kind)?;
                let mut xyz = Vec::new();
                for &v in &ids {
                    let from = predict::point(&self.store, v);
                    xyz.extend(self.models.moves.read(&mut self.input.geometry, from)?);
                }
                Op::MoveVertices { ids, xyz }
            }
            OpKind::SetPositions => Op::SetPositions { xyz: self.set_positions(index)? },
            OpKind::RemoveVertices => Op::RemoveVertices { ids: self.removal_ids(kind)? },
            OpKind::RemoveTriangles => Op::RemoveTriangles { ids: self.removal_ids(kind)? },
            OpKind::FlipTriangles => Op::FlipTriangles { ids: self.removal_ids(kind)? },
            OpKind::SplitTriangle => {
                let triangle = m.elements.read_triangle(&mut input.ops)?;
                let predicted = predict::centroid(&self.store, triangle);
                Op::SplitTriangle { triangle, at: self.point(predicted)? }
            }
            OpKind::SplitEdge => {
                let edge = m.elements.read_edge(&mut input.ops)?;
                let predicted = predict::midpoint(&self.store, edge);
                Op::SplitEdge { edge, at: self.point(predicted)? }
            }
            OpKind::ExtendEdge => {
                let edge = m.elements.read_edge(&mut input.ops)?;
                let delta = input.ops.int(&mut m.extend_vertex)?;
                m.last_extend_vertex = m.last_extend_vertex.wrapping_add(delta as u32);
                Op::ExtendEdge { edge, vertex: m.last_extend_vertex }
            }
            OpKind::SwapEdge => Op::SwapEdge { edge: m.elements.read_edge(&mut input.ops)? },
            OpKind::CollapseEdge => {
                Op::CollapseEdge { edge: m.elements.read_edge(&mut input.ops)? }
            }
            OpKind::RemoveComponent => {
                Op::RemoveComponent { triangle: m.elements.read_triangle(&mut input.ops)? }
            }
            OpKind::TransformComponent => {
                let triangle = m.elements.read_triangle(&mut input.ops)?;
                Op::TransformComponent { triangle, matrix: self.matrix()? }
            }
            OpKind::Transform => Op::Transform { matrix: self.matrix()? },
            OpKind::Clear => Op::Clear,
            OpKind::SetAttribute | OpKind::RemoveAttribute => {
                let limit = self.remaining[kind_index(kind)].edits;
                let op = m.attributes.read(
                    kind,
                    &self.store,
                    [&mut input.ops, &mut input.ids, &mut input.geometry],
                    &mut m.lists,
                    limit,
                )?;
                if kind == OpKind::SetAttribute {
                    self.take(kind, op.edit_count() as u64)?;
                }
                op
            }
        })
    }

    /// The next op's kind, counted against the header.
    fn kind(&mut self) -> Result<OpKind, CorruptStream> {
        let symbol = match self.announced.take() {
            Some(symbol) => symbol,
            None => self.input.ops.symbol(&mut self.models.kind)?,
        };
        if symbol == END {
            return Err(CorruptStream);
        }
        let kind = OpKind::ALL[symbol];
        let left = &mut self.remaining[kind_index(kind)].ops;
        *left = left.checked_sub(1).ok_or(CorruptStream)?;
        Ok(kind)
    }

    /// Counts `edits` elements against what the header declared for `kind`.
    fn take(&mut self, kind: OpKind, edits: u64) -> Result<(), CorruptStream> {
        let left = &mut self.remaining[kind_index(kind)].edits;
        *left = left.checked_sub(edits).ok_or(CorruptStream)?;
        Ok(())
    }

    fn apply(&mut self, index: usize, op: Op) -> Result<(), CorrectionError> {
        let kind = op.kind();
        let corners = Removals::before(&self.store, &op);
        self.store.apply(op).map_err(|source| CorrectionError::Replay {
            op: index,
            kind,
            source,
        })?;
        self.models.removals.applied(&mut self.store, corners);
        Ok(())
    }

    fn add_vertices(&mut self, index: usize) -> Result<usize, CorrectionError> {
        let corrupt = |_: CorruptStream| CorrectionError::Corrupt { op: index };
        let count = self.input.ops.uint(&mut self.models.count).map_err(corrupt)?;
        self.take(OpKind::AddVertices, u64::from(count)).map_err(corrupt)?;
        let next = self.input.ops.symbol(&mut self.models.kind).map_err(corrupt)?;
        self.announced = Some(next);
        let paired = next == kind_index(OpKind::AddTriangles);
        let abc = if paired {
            self.kind().map_err(corrupt)?;
            self.triangles().map_err(corrupt)?
        } else {
            Vec::new()
        };
        let first = self.store.vertex_slots();
        let around = NewVertexNeighbours::new(first, count as usize, &abc);
        let mut xyz = Vec::new();
        for j in 0..count as usize {
            let predicted = around.predict(&self.store, &xyz, j);
            let p = self.models.new_points.read(&mut self.input.geometry, predicted);
            xyz.extend(p.map_err(corrupt)?);
        }
        self.apply(index, Op::AddVertices { xyz })?;
        if !paired {
            return Ok(1);
        }
        self.apply(index + 1, Op::AddTriangles { abc })?;
        Ok(2)
    }

    fn triangles(&mut self) -> Result<Vec<u32>, CorruptStream> {
        let count = self.input.ops.uint(&mut self.models.count)?;
        self.take(OpKind::AddTriangles, u64::from(count))?;
        self.models.corners.restart(self.store.vertex_slots());
        let mut abc = Vec::new();
        for _ in 0..count {
            abc.extend(self.models.corners.read(&mut self.input.connectivity)?);
        }
        Ok(abc)
    }

    fn ids(&mut self, kind: OpKind) -> Result<Vec<u32>, CorruptStream> {
        let limit = self.remaining[kind_index(kind)].edits;
        let ids = self.models.lists.read(&mut self.input.ids, limit)?;
        self.take(kind, ids.len() as u64)?;
        Ok(ids)
    }

    /// The ids of a removal or flip, coded by [`Removals`].
    fn removal_ids(&mut self, kind: OpKind) -> Result<Vec<u32>, CorruptStream> {
        let limit = self.remaining[kind_index(kind)].edits;
        let (m, input) = (&mut self.models, &mut self.input);
        let ids = m.removals.read(&mut self.store, &mut m.lists, &mut input.ids, kind, limit)?;
        self.take(kind, ids.len() as u64)?;
        Ok(ids)
    }

    fn point(&mut self, predicted: Option<[f32; 3]>) -> Result<Option<[f32; 3]>, CorruptStream> {
        let (m, input) = (&mut self.models, &mut self.input);
        if !input.ops.bit(&mut m.has_point)? {
            return Ok(None);
        }
        Ok(Some(m.split_points.read(&mut input.geometry, predicted.unwrap_or([0.0; 3]))?))
    }

    fn matrix(&mut self) -> Result<[f32; 12], CorruptStream> {
        let mut matrix = [0.0; 12];
        for v in &mut matrix {
            *v = self.input.geometry.f32_bits()?;
        }
        Ok(matrix)
    }

    /// The mirror of the encoder's `set_positions`. The predictions (neighbour means, most of
    /// the work, unless they were gathered before) are made on two more threads, alternate
    /// chunks each. The symbols do not depend on them, so the decoding runs ahead (while the
    /// triangles are indexed, at first) and restores each chunk of vertices when its
    /// predictions have arrived.
    fn set_positions(&mut self, index: usize) -> Result<Vec<f32>, CorruptStream> {
        self.take(OpKind::SetPositions, u64::from(self.store.vertex_slots()))?;
        let (store, grid) = (&self.store, self.models.grid);
        let prepared = self.prepared.filter(|_| index == 0);
        let (m, input) = (&mut self.models, &mut self.input);
        let lambda = input.geometry.f32_bits()?;
        let (current, slots) = (store.positions(), store.vertex_slots());
        std::thread::scope(|s| {
            let (even, odd) = (mpsc::sync_channel(2), mpsc::sync_channel(2));
            let predictions = [even.1, odd.1];
            let (send_even, send_odd) = (even.0, odd.0);
            s.spawn(move || {
                let means = match prepared {
                    Some(means) => MeanSource::Prepared(means),
                    None => MeanSource::Gathered(Neighbours::new(slots, store.triangles())),
                };
                let chunks = |parity: usize, send: mpsc::SyncSender<Vec<[f32; 3]>>| {
                    let mut around = Vec::new();
                    let firsts = (0..slots).step_by(CHUNK as usize).skip(parity).step_by(2);
                    for first in firsts {
                        let chunk = (first..slots.min(first + CHUNK)).map(|v| {
                            let p = predict::point(store, v);
                            if !store.is_vertex_live(v) {
                                return p;
                            }
                            predict::smoothed(p, means.mean(current, v, &mut around), lambda, grid)
                        });
                        if send.send(chunk.collect()).is_err() {
                            return; // the decoding stopped at corrupt data
                        }
                    }
                };
                std::thread::scope(|s| {
                    s.spawn(|| chunks(1, send_odd));
                    chunks(0, send_even);
                });
            });
            let mut xyz = current.to_vec();
            // Decoded chunks whose predictions have not arrived, oldest first.
            let mut waiting = VecDeque::new();
            let mut context = motion::STILL;
            for first in (0..slots).step_by(CHUNK as usize) {
                // Each moved vertex, with its residuals unless exactly predicted.
                let mut moved = Vec::new();
                for v in (first..slots.min(first + CHUNK)).filter(|&v| store.is_vertex_live(v)) {
                    let symbol = input.geometry.symbol(&mut m.motion[context])?;
                    context = match symbol {
                        motion::STILL => symbol,
                        motion::PREDICTED => {
                            moved.push((v, None));
                            symbol
                        }
                        _ => {
                            let bucket = symbol - motion::RESIDUAL;
                            let residuals =
                                m.smoothing.read_residuals_after(&mut input.geometry, bucket)?;
                            moved.push((v, Some(residuals)));
                            motion::RESIDUAL + m.smoothing.class()
                        }
                    };
                }
                waiting.push_back((first, moved));
                while let Some(&(first, _)) = waiting.front()
                    && let Ok(predicted) = predictions[chunk_parity(first)].try_recv()
                {
                    let (first, moved) = waiting.pop_front().expect("not empty");
                    place(&mut xyz, &m.smoothing, first, &moved, &predicted);
                }
            }
            for (first, moved) in waiting {
                let predicted = predictions[chunk_parity(first)]
                    .recv()
                    .expect("the predicting threads send every chunk");
                place(&mut xyz, &m.smoothing, first, &moved, &predicted);
            }
            Ok(xyz)
        })
    }
}

/// Which of the two predicting threads serves the chunk starting at vertex `first`.
fn chunk_parity(first: u32) -> usize {
    (first / CHUNK % 2) as usize
}

/// Writes the moved vertices of the chunk starting at vertex `first` into `xyz`, from the
/// chunk's `predicted` positions.
fn place(
    xyz: &mut [f32],
    coder: &ResidualCoder,
    first: u32,
    moved: &[(u32, Option<Residuals>)],
    predicted: &[[f32; 3]],
) {
    for &(v, residuals) in moved {
        let p = predicted[(v - first) as usize];
        let q = residuals.map_or(p, |r| coder.restore(r, p));
        let i = 3 * v as usize;
        xyz[i..i + 3].copy_from_slice(&q);
    }
}

/// Kinds that stand for exactly one edit.
fn is_single(kind: OpKind) -> bool {
    !matches!(
        kind,
        OpKind::AddVertices
            | OpKind::AddTriangles
            | OpKind::MoveVertices
            | OpKind::SetPositions
            | OpKind::RemoveVertices
            | OpKind::RemoveTriangles
            | OpKind::FlipTriangles
            | OpKind::SetAttribute
    )
}
