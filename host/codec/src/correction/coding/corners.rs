//! Triangle corners coded against a cache of recently used vertices.
//!
//! Neighbouring triangles share vertices, so most corners are among the last few seen; a
//! corner that is not is usually the next vertex never seen before. Only the rest cost an
//! explicit delta. A corner costs 2-4 bits on scan-ordered meshes instead of ~20.

use super::integer::int_model;
use super::model::AdaptiveModel;
use super::recent::RecentVertices;
use super::stream::{CorruptStream, SymbolReader, SymbolWriter};

/// Recently used vertices remembered, most recent first.
const CACHE: usize = 16;
/// Symbol for "the lowest id not yet seen".
const NEXT_NEW: usize = CACHE;
/// Symbol for "explicit delta from the previous corner".
const ESCAPE: usize = CACHE + 1;

/// The state both sides keep while coding a run of triangles.
pub(crate) struct CornerCoder {
    /// One model per corner slot: the first corner of a triangle behaves unlike the others.
    slot: [AdaptiveModel; 3],
    delta: AdaptiveModel,
    recent: RecentVertices,
}

impl CornerCoder {
    pub(crate) fn new() -> Self {
        Self {
            slot: std::array::from_fn(|_| AdaptiveModel::new(CACHE + 2)),
            delta: int_model(),
            recent: RecentVertices::new(CACHE),
        }
    }

    /// Starts a new run of triangles, keeping what the models learnt; `first_new` is the
    /// lowest vertex id no earlier triangle of the run can have used.
    pub(crate) fn restart(&mut self, first_new: u32) {
        self.recent.restart(first_new);
    }

    pub(crate) fn write(&mut self, w: &mut SymbolWriter, corners: [u32; 3]) {
        for (k, v) in corners.into_iter().enumerate() {
            match self.recent.rank(v) {
                Some(i) => w.symbol(&mut self.slot[k], i),
                None if v == self.recent.next_new() => w.symbol(&mut self.slot[k], NEXT_NEW),
                None => {
                    w.symbol(&mut self.slot[k], ESCAPE);
                    w.int(&mut self.delta, v.wrapping_sub(self.recent.last()) as i32);
                }
            }
            self.recent.saw(v);
        }
    }

    pub(crate) fn read(&mut self, r: &mut SymbolReader) -> Result<[u32; 3], CorruptStream> {
        let mut corners = [0; 3];
        for (k, corner) in corners.iter_mut().enumerate() {
            let v = match r.symbol(&mut self.slot[k])? {
                NEXT_NEW => self.recent.next_new(),
                ESCAPE => self.recent.last().wrapping_add(r.int(&mut self.delta)? as u32),
                i => self.recent.get(i).ok_or(CorruptStream)?,
            };
            self.recent.saw(v);
            *corner = v;
        }
        Ok(corners)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_strip_round_trips_and_costs_few_bits_per_corner() {
        let width = 100u32;
        let mut triangles = Vec::new();
        for row in 0..50 {
            for x in 0..width - 1 {
                let v = row * width + x;
                triangles.push([v, v + 1, v + width + 1]);
                triangles.push([v, v + width + 1, v + width]);
            }
        }
        triangles.push([7, 7_000_000, 3]);
        let mut w = SymbolWriter::new();
        let mut coder = CornerCoder::new();
        for &t in &triangles {
            coder.write(&mut w, t);
        }
        let bytes = w.finish();
        let bits_per_corner = bytes.len() as f64 * 8.0 / (3 * triangles.len()) as f64;
        assert!(bits_per_corner < 3.0, "{bits_per_corner}");
        let mut r = SymbolReader::new(&bytes).unwrap();
        let mut coder = CornerCoder::new();
        for &t in &triangles {
            assert_eq!(coder.read(&mut r), Ok(t));
        }
    }
}
