//! Entropy-coding building blocks shared by corrections and packed meshes.

pub(crate) mod bytes;
pub(crate) mod corners;
pub(crate) mod float;
pub(crate) mod integer;
pub(crate) mod model;
pub(crate) mod numbers;
pub(crate) mod recent;
pub(crate) mod residual;
pub(crate) mod stream;
