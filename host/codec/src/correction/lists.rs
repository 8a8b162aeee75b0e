//! Element ids in a correction: id lists as runs or deltas, single ids as deltas.

use super::coding::integer::int_model;
use super::coding::model::AdaptiveModel;
use super::coding::stream::{CorruptStream, SymbolReader, SymbolWriter};

/// Id lists of bulk ops. A strictly ascending list (the usual case: a filter collects what
/// to remove, then removes it) is coded as runs of consecutive ids, gap and length each, so
/// removing 10k triangles in 150 components costs ~150 runs, not 10k ids. Other lists are
/// coded as deltas between consecutive ids.
pub(super) struct IdListCoder {
    ascending: AdaptiveModel,
    count: AdaptiveModel,
    gap: AdaptiveModel,
    run: AdaptiveModel,
    delta: AdaptiveModel,
}

impl IdListCoder {
    pub(super) fn new() -> Self {
        Self {
            ascending: AdaptiveModel::new(2),
            count: int_model(),
            gap: int_model(),
            run: int_model(),
            delta: int_model(),
        }
    }

    pub(super) fn write(&mut self, w: &mut SymbolWriter, ids: &[u32]) {
        let ascending = ids.windows(2).all(|p| p[0] < p[1]);
        w.bit(&mut self.ascending, ascending);
        if !ascending {
            w.uint(&mut self.count, ids.len() as u32);
            let mut previous = 0u32;
            for &id in ids {
                w.int(&mut self.delta, id.wrapping_sub(previous) as i32);
                previous = id;
            }
            return;
        }
        let runs = runs(ids);
        w.uint(&mut self.count, runs.len() as u32);
        let mut end = 0u32;
        for (start, len) in runs {
            w.uint(&mut self.gap, start - end);
            w.uint(&mut self.run, len - 1);
            end = start + len;
        }
    }

    /// Reads a list of at most `limit` ids (what the header leaves for this op kind).
    pub(super) fn read(
        &mut self,
        r: &mut SymbolReader,
        limit: u64,
    ) -> Result<Vec<u32>, CorruptStream> {
        let mut ids = Vec::new();
        if !r.bit(&mut self.ascending)? {
            let count = r.uint(&mut self.count)?;
            if u64::from(count) > limit {
                return Err(CorruptStream);
            }
            let mut previous = 0u32;
            for _ in 0..count {
                previous = previous.wrapping_add(r.int(&mut self.delta)? as u32);
                ids.push(previous);
            }
            return Ok(ids);
        }
        let runs = r.uint(&mut self.count)?;
        let mut end = 0u32;
        for _ in 0..runs {
            let start = end.checked_add(r.uint(&mut self.gap)?).ok_or(CorruptStream)?;
            let len = r.uint(&mut self.run)?.checked_add(1).ok_or(CorruptStream)?;
            end = start.checked_add(len).ok_or(CorruptStream)?;
            if ids.len() as u64 + u64::from(len) > limit {
                return Err(CorruptStream);
            }
            ids.extend(start..end);
        }
        Ok(ids)
    }
}

/// `(start, length)` of each run of consecutive ids in an ascending list.
fn runs(ids: &[u32]) -> Vec<(u32, u32)> {
    let mut runs: Vec<(u32, u32)> = Vec::new();
    for &id in ids {
        match runs.last_mut() {
            Some((start, len)) if start.checked_add(*len) == Some(id) => *len += 1,
            _ => runs.push((id, 1)),
        }
    }
    runs
}

/// The triangle or half-edge a single op addresses, as a delta from the triangle the
/// previous single op addressed (edits of one step cluster), plus the corner for edges.
pub(super) struct ElementCoder {
    triangle: AdaptiveModel,
    corner: AdaptiveModel,
    last: u32,
}

impl ElementCoder {
    pub(super) fn new() -> Self {
        Self { triangle: int_model(), corner: AdaptiveModel::new(3), last: 0 }
    }

    pub(super) fn write_triangle(&mut self, w: &mut SymbolWriter, triangle: u32) {
        w.int(&mut self.triangle, triangle.wrapping_sub(self.last) as i32);
        self.last = triangle;
    }

    pub(super) fn read_triangle(&mut self, r: &mut SymbolReader) -> Result<u32, CorruptStream> {
        self.last = self.last.wrapping_add(r.int(&mut self.triangle)? as u32);
        Ok(self.last)
    }

    pub(super) fn write_edge(&mut self, w: &mut SymbolWriter, edge: u32) {
        self.write_triangle(w, edge / 3);
        w.symbol(&mut self.corner, (edge % 3) as usize);
    }

    pub(super) fn read_edge(&mut self, r: &mut SymbolReader) -> Result<u32, CorruptStream> {
        let triangle = self.read_triangle(r)?;
        let corner = r.symbol(&mut self.corner)? as u32;
        triangle.checked_mul(3).and_then(|e| e.checked_add(corner)).ok_or(CorruptStream)
    }
}
