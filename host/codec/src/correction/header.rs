//! The uncompressed front of a `.mfc` file: identity, hashes, counts and section sizes.
//!
//! ```text
//! magic "MFC\x1a" | version u16 LE | checksum [16] (BLAKE3 of every byte after it)
//! base hash [32] | result hash [32]
//! varints: base vertices, base triangles, result vertices, result triangles,
//!          grid flag (0, or 1 and then the zigzagged step exponent of each axis),
//!          ops and edits for each of the 18 op kinds (OpKind::ALL order),
//!          byte length of each section (SECTIONS order)
//! sections, back to back, ending exactly at the end of the file
//! ```

use crate::quantize::Grid;
use meshflow_mesh::ContentHash;
use meshflow_mesh::store::OpKind;

use super::CorrectionError;
use super::coding::bytes::{open_sealed, put_grid, put_varint, seal, sealed_front};

pub(crate) const MAGIC: [u8; 4] = *b"MFC\x1a";
/// 7: `set-attribute` values as residuals from a prediction.
pub const VERSION: u16 = 7;

/// How many op kinds the header counts.
pub(crate) const KINDS: usize = OpKind::ALL.len();

/// The entropy-coded streams of a correction, in file order.
pub const SECTIONS: [&str; 4] = ["ops", "ids", "connectivity", "geometry"];

/// How many ops of one kind a correction holds, and how many elements they touch.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct KindCount {
    pub ops: u64,
    pub edits: u64,
}

/// Everything a correction says about itself; readable without the base mesh.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Correction {
    pub version: u16,
    pub base: ContentHash,
    pub result: ContentHash,
    /// `[vertices, triangles]` of the base mesh.
    pub base_counts: [u64; 2],
    /// `[vertices, triangles]` of the result mesh.
    pub result_counts: [u64; 2],
    /// The grid base and result lie on, when coordinates are coded as grid steps.
    pub grid: Option<Grid>,
    /// Per op kind, in `OpKind::ALL` order.
    pub kinds: [KindCount; KINDS],
    /// Bytes of the uncompressed header.
    pub header_bytes: usize,
    /// Bytes of each section, in [`SECTIONS`] order.
    pub section_bytes: [usize; 4],
}

impl Correction {
    pub fn op_count(&self) -> u64 {
        self.kinds.iter().map(|k| k.ops).sum()
    }

    pub fn count(&self, kind: OpKind) -> KindCount {
        self.kinds[kind_index(kind)]
    }

    pub fn total_bytes(&self) -> usize {
        self.header_bytes + self.section_bytes.iter().sum::<usize>()
    }
}

pub(crate) fn kind_index(kind: OpKind) -> usize {
    OpKind::ALL.iter().position(|&k| k == kind).expect("ALL lists every kind")
}

/// The whole file: header fields, then the sections, with the checksum filled in.
pub(crate) fn write(header: &Correction, sections: &[Vec<u8>; 4]) -> Vec<u8> {
    let capacity = 256 + sections.iter().map(Vec::len).sum::<usize>();
    let mut out = sealed_front(MAGIC, VERSION, capacity);
    out.extend_from_slice(&header.base.0);
    out.extend_from_slice(&header.result.0);
    for n in header.base_counts.iter().chain(&header.result_counts) {
        put_varint(&mut out, *n);
    }
    put_grid(&mut out, header.grid);
    for k in &header.kinds {
        put_varint(&mut out, k.ops);
        put_varint(&mut out, k.edits);
    }
    for s in sections {
        put_varint(&mut out, s.len() as u64);
    }
    for s in sections {
        out.extend_from_slice(s);
    }
    seal(&mut out);
    out
}

/// Checks magic, version and checksum, reads the header, and splits off the sections.
pub(crate) fn read(bytes: &[u8]) -> Result<(Correction, [&[u8]; 4]), CorrectionError> {
    let mut r = open_sealed(bytes, MAGIC, VERSION)?;
    let version = VERSION;
    let base = ContentHash(r.array()?);
    let result = ContentHash(r.array()?);
    let mut counts = [0u64; 4];
    for c in &mut counts {
        *c = r.varint()?;
        if *c > u64::from(u32::MAX) {
            return Err(CorrectionError::Malformed(format!("element count {c} exceeds u32 ids")));
        }
    }
    let grid = r.grid()?;
    let mut kinds = [KindCount::default(); KINDS];
    for k in &mut kinds {
        *k = KindCount { ops: r.varint()?, edits: r.varint()? };
    }
    let mut section_bytes = [0usize; 4];
    for s in &mut section_bytes {
        *s = usize::try_from(r.varint()?).map_err(|_| CorrectionError::Truncated)?;
    }
    let header_bytes = bytes.len() - r.remaining();
    let mut sections = [&[][..]; 4];
    for (s, &len) in sections.iter_mut().zip(&section_bytes) {
        *s = r.take(len)?;
    }
    if r.remaining() != 0 {
        return Err(CorrectionError::Malformed(format!(
            "{} bytes after the last section",
            r.remaining()
        )));
    }
    let header = Correction {
        version,
        base,
        result,
        base_counts: [counts[0], counts[1]],
        result_counts: [counts[2], counts[3]],
        grid,
        kinds,
        header_bytes,
        section_bytes,
    };
    Ok((header, sections))
}
