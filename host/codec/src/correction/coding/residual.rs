//! Points coded as exact f32 residuals from a prediction, with context-adaptive models.
//!
//! On a [`Grid`] a residual counts grid steps from the prediction snapped to the grid, so a
//! mesh quantised to `b` bits pays for `b`-bit indices, not for 24-bit mantissas. A value
//! the grid index cannot reproduce exactly (off the grid, or too far) is escaped and
//! written as its raw bits, so coding stays lossless whatever it is given.
//!
//! Each axis has its own models, selected by the magnitude class of the residual coded just
//! before it, since the three residuals of a point (and of consecutive points) are
//! correlated in size: a vertex that moved far on x likely moved far on y.

use super::float::{residual, restore};
use super::integer::{int_model, join, raw_bits, split, unzigzag, zigzag};
use super::model::AdaptiveModel;
use super::stream::{CorruptStream, SymbolReader, SymbolWriter};
use crate::quantize::Grid;

/// Magnitude classes of a residual, the context of the next one.
pub(crate) const CLASSES: usize = 4;
/// The grid residual `i32::MIN` (zigzag `u32::MAX`) is never coded: it announces raw bits.
const ESCAPE: u32 = u32::MAX;

pub(crate) struct ResidualCoder {
    models: Vec<AdaptiveModel>,
    class: usize,
    grid: Option<Grid>,
}

impl ResidualCoder {
    pub(crate) fn new(grid: Option<Grid>) -> Self {
        Self { models: (0..3 * CLASSES).map(|_| int_model()).collect(), class: 0, grid }
    }

    pub(crate) fn write(&mut self, w: &mut SymbolWriter, actual: [f32; 3], predicted: [f32; 3]) {
        self.write_axes(w, actual, predicted, None);
    }

    /// Like [`write`](Self::write), with the first axis's bucket coded as symbol
    /// `offset + bucket` of `joint`, a model the caller shares with its own symbols: one
    /// symbol per point fewer to code and decode.
    pub(crate) fn write_joint(
        &mut self,
        w: &mut SymbolWriter,
        actual: [f32; 3],
        predicted: [f32; 3],
        joint: &mut AdaptiveModel,
        offset: usize,
    ) {
        self.write_axes(w, actual, predicted, Some((joint, offset)));
    }

    fn write_axes(
        &mut self,
        w: &mut SymbolWriter,
        actual: [f32; 3],
        predicted: [f32; 3],
        mut joint: Option<(&mut AdaptiveModel, usize)>,
    ) {
        for k in 0..3 {
            let z = match &self.grid {
                None => zigzag(residual(actual[k], predicted[k])),
                Some(grid) => {
                    grid_residual(grid, k, actual[k], predicted[k]).map_or(ESCAPE, zigzag)
                }
            };
            let (bucket, bits, raw) = split(z);
            match joint.as_mut().filter(|_| k == 0) {
                Some((model, offset)) => w.symbol(model, *offset + bucket),
                None => w.symbol(&mut self.models[k * CLASSES + self.class], bucket),
            }
            w.raw(bits, raw);
            if self.grid.is_some() && z == ESCAPE {
                w.f32_bits(actual[k]);
            }
            self.class = class_of(z);
        }
    }

    /// The magnitude class of the last residual coded.
    pub(crate) fn class(&self) -> usize {
        self.class
    }

    pub(crate) fn read(
        &mut self,
        r: &mut SymbolReader,
        predicted: [f32; 3],
    ) -> Result<[f32; 3], CorruptStream> {
        let residuals = self.read_residuals(r)?;
        Ok(self.restore(residuals, predicted))
    }

    /// The residuals of a point, which do not depend on its prediction: they can be read
    /// before it is known.
    pub(crate) fn read_residuals(
        &mut self,
        r: &mut SymbolReader,
    ) -> Result<Residuals, CorruptStream> {
        let bucket = r.symbol(&mut self.models[self.class])?;
        self.read_residuals_after(r, bucket)
    }

    /// The counterpart of [`write_joint`](Self::write_joint), once the caller has read the
    /// first axis's `bucket` (below `BUCKETS`) from its model.
    pub(crate) fn read_residuals_after(
        &mut self,
        r: &mut SymbolReader,
        bucket: usize,
    ) -> Result<Residuals, CorruptStream> {
        let mut residuals = Residuals([(0, 0); 3]);
        for (k, (z, escaped)) in residuals.0.iter_mut().enumerate() {
            let bucket = match k {
                0 => bucket,
                _ => r.symbol(&mut self.models[k * CLASSES + self.class])?,
            };
            *z = join(bucket, r.raw(raw_bits(bucket))?);
            self.class = class_of(*z);
            if self.grid.is_some() && *z == ESCAPE {
                *escaped = r.f32_bits()?.to_bits();
            }
        }
        Ok(residuals)
    }

    /// The point `residuals` (read by this coder) code from `predicted`.
    pub(crate) fn restore(&self, residuals: Residuals, predicted: [f32; 3]) -> [f32; 3] {
        std::array::from_fn(|k| {
            let (z, escaped) = residuals.0[k];
            match (&self.grid, z) {
                (None, _) => restore(predicted[k], unzigzag(z)),
                (Some(_), ESCAPE) => f32::from_bits(escaped),
                (Some(grid), _) => from_grid(grid, k, predicted[k], unzigzag(z)),
            }
        })
    }
}

/// Per axis, the coded residual and, for an escaped one, the exact bits that follow it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Residuals([(u32, u32); 3]);

/// Grid steps from `predicted` (snapped) to `actual`, when decoding them gives back
/// `actual`'s exact bits.
fn grid_residual(grid: &Grid, axis: usize, actual: f32, predicted: f32) -> Option<i32> {
    let r = grid.index(axis, actual) - grid.index(axis, grid.snap(axis, predicted));
    let r = (r.fract() == 0.0 && r.abs() < f64::from(i32::MAX)).then_some(r as i32)?;
    (from_grid(grid, axis, predicted, r).to_bits() == actual.to_bits()).then_some(r)
}

fn from_grid(grid: &Grid, axis: usize, predicted: f32, r: i32) -> f32 {
    grid.value(axis, grid.index(axis, grid.snap(axis, predicted)) + f64::from(r))
}

fn class_of(z: u32) -> usize {
    match split(z).0 {
        0 => 0,
        1..6 => 1,
        6..26 => 2,
        _ => 3,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_points_cost_their_steps_and_anything_else_is_escaped_exactly() {
        let grid = Grid::from_exponents([-10, -10, -4]);
        let mut points: Vec<[f32; 3]> = (0..500)
            .map(|i| [i as f32 / 1024.0, -(i as f32) / 512.0, (i % 7) as f32 / 16.0])
            .collect();
        points.extend([[0.1, -0.0, 1e30], [f32::MAX, f32::MIN, 3.0e-40]]);
        let predicted = |i: usize| if i == 0 { [0.0; 3] } else { points[i - 1] };
        for grid in [None, grid] {
            let mut w = SymbolWriter::new();
            let mut coder = ResidualCoder::new(grid);
            for (i, &p) in points.iter().enumerate() {
                coder.write(&mut w, p, predicted(i));
            }
            let bytes = w.finish();
            let mut r = SymbolReader::new(&bytes).unwrap();
            let mut coder = ResidualCoder::new(grid);
            for (i, &p) in points.iter().enumerate() {
                let q = coder.read(&mut r, predicted(i)).unwrap();
                assert_eq!(q.map(f32::to_bits), p.map(f32::to_bits), "point {i}");
            }
            if grid.is_some() {
                assert!(bytes.len() < 500, "{} bytes for 500 steady grid steps", bytes.len());
            }
        }
    }
}
