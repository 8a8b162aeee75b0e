//! Triangle corners coded against a cache of recently used vertices.
//!
//! Neighbouring triangles share vertices, so most corners are among the last few seen; a
//! corner that is not is usually the next vertex never seen before. Only the rest cost an
//! explicit delta. A corner costs 2-4 bits on scan-ordered meshes instead of ~20.

use super::integer::int_model;
use super::model::AdaptiveModel;
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
    recent: [u32; CACHE],
    recent_len: usize,
    next_new: u32,
    last: u32,
}

impl CornerCoder {
    pub(crate) fn new() -> Self {
        Self {
            slot: std::array::from_fn(|_| AdaptiveModel::new(CACHE + 2)),
            delta: int_model(),
            recent: [0; CACHE],
            recent_len: 0,
            next_new: 0,
            last: 0,
        }
    }

    /// Starts a new run of triangles, keeping what the models learnt; `first_new` is the
    /// lowest vertex id no earlier triangle of the run can have used.
    pub(crate) fn restart(&mut self, first_new: u32) {
        self.recent_len = 0;
        self.next_new = first_new;
        self.last = first_new.saturating_sub(1);
    }

    pub(crate) fn write(&mut self, w: &mut SymbolWriter, corners: [u32; 3]) {
        for (k, v) in corners.into_iter().enumerate() {
            match self.recent[..self.recent_len].iter().position(|&r| r == v) {
                Some(i) => w.symbol(&mut self.slot[k], i),
                None if v == self.next_new => w.symbol(&mut self.slot[k], NEXT_NEW),
                None => {
                    w.symbol(&mut self.slot[k], ESCAPE);
                    w.int(&mut self.delta, v.wrapping_sub(self.last) as i32);
                }
            }
            self.saw(v);
        }
    }

    pub(crate) fn read(&mut self, r: &mut SymbolReader) -> Result<[u32; 3], CorruptStream> {
        let mut corners = [0; 3];
        for (k, corner) in corners.iter_mut().enumerate() {
            let v = match r.symbol(&mut self.slot[k])? {
                NEXT_NEW => self.next_new,
                ESCAPE => self.last.wrapping_add(r.int(&mut self.delta)? as u32),
                i if i < self.recent_len => self.recent[i],
                _ => return Err(CorruptStream),
            };
            self.saw(v);
            *corner = v;
        }
        Ok(corners)
    }

    fn saw(&mut self, v: u32) {
        let end = match self.recent[..self.recent_len].iter().position(|&r| r == v) {
            Some(i) => i,
            None => {
                self.recent_len = (self.recent_len + 1).min(CACHE);
                self.recent_len - 1
            }
        };
        self.recent.copy_within(0..end, 1);
        self.recent[0] = v;
        if v >= self.next_new {
            self.next_new = v.saturating_add(1);
        }
        self.last = v;
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
