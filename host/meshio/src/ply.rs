//! Stanford PLY: ascii, binary little endian and binary big endian.
//!
//! The header is parsed into elements and properties; the body is then read straight from
//! the byte slice. Binary vertex records of a fixed layout (the usual case) are decoded in
//! one pass without per-value dispatch, which is what makes large scans load fast.

mod header;
mod plan;
mod read;
mod source;
mod write;

pub(crate) use read::read;
pub(crate) use write::{unsupported, write};
