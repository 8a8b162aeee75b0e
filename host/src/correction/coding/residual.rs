//! Points coded as exact f32 residuals from a prediction, with context-adaptive models.
//!
//! Each axis has its own models, selected by the magnitude class of the residual coded just
//! before it, since the three residuals of a point (and of consecutive points) are
//! correlated in size: a vertex that moved far on x likely moved far on y.

use super::float::{residual, restore};
use super::integer::{int_model, split, zigzag};
use super::model::AdaptiveModel;
use super::stream::{CorruptStream, SymbolReader, SymbolWriter};

const CLASSES: usize = 4;

pub(crate) struct ResidualCoder {
    models: Vec<AdaptiveModel>,
    class: usize,
}

impl ResidualCoder {
    pub(crate) fn new() -> Self {
        Self { models: (0..3 * CLASSES).map(|_| int_model()).collect(), class: 0 }
    }

    pub(crate) fn write(&mut self, w: &mut SymbolWriter, actual: [f32; 3], predicted: [f32; 3]) {
        for k in 0..3 {
            let z = zigzag(residual(actual[k], predicted[k]));
            w.uint(&mut self.models[k * CLASSES + self.class], z);
            self.class = class_of(z);
        }
    }

    pub(crate) fn read(
        &mut self,
        r: &mut SymbolReader,
        predicted: [f32; 3],
    ) -> Result<[f32; 3], CorruptStream> {
        let mut point = [0.0; 3];
        for k in 0..3 {
            let z = r.uint(&mut self.models[k * CLASSES + self.class])?;
            self.class = class_of(z);
            point[k] = restore(predicted[k], super::integer::unzigzag(z));
        }
        Ok(point)
    }
}

fn class_of(z: u32) -> usize {
    match split(z).0 {
        0 => 0,
        1..6 => 1,
        6..26 => 2,
        _ => 3,
    }
}
