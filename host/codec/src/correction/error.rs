//! Why a correction could not be encoded, read or applied.

use meshflow_mesh::ContentHash;
use meshflow_mesh::store::{EditError, OpKind};

use super::coding::bytes::{FramingError, SealError};

#[derive(Debug, thiserror::Error)]
pub enum CorrectionError {
    #[error("not a meshflow correction (bad magic bytes)")]
    BadMagic,
    #[error("correction format version {found} is not supported (this build reads {supported})")]
    UnsupportedVersion { found: u16, supported: u16 },
    #[error("the correction is truncated")]
    Truncated,
    #[error("the correction is corrupt: checksum mismatch")]
    ChecksumMismatch,
    #[error("the correction header is malformed: {0}")]
    Malformed(String),
    #[error("the correction's coded data is corrupt at operation {op}")]
    Corrupt { op: usize },
    #[error("the correction applies to mesh {expected}, not to this mesh ({found})")]
    BaseMismatch { expected: ContentHash, found: ContentHash },
    #[error("replaying the correction gave mesh {found}, not the expected {expected}")]
    ResultMismatch { expected: ContentHash, found: ContentHash },
    #[error("operation {op} ({}) was refused by the mesh store: {source}", kind.name())]
    Replay { op: usize, kind: OpKind, source: EditError },
}

impl From<FramingError> for CorrectionError {
    fn from(e: FramingError) -> Self {
        match e {
            FramingError::Truncated => CorrectionError::Truncated,
            FramingError::BadVarint => CorrectionError::Malformed("overlong varint".into()),
            FramingError::BadGrid => CorrectionError::Malformed("invalid grid".into()),
        }
    }
}

impl From<SealError> for CorrectionError {
    fn from(e: SealError) -> Self {
        match e {
            SealError::BadMagic => CorrectionError::BadMagic,
            SealError::UnsupportedVersion(found) => {
                CorrectionError::UnsupportedVersion { found, supported: super::VERSION }
            }
            SealError::Truncated => CorrectionError::Truncated,
            SealError::ChecksumMismatch => CorrectionError::ChecksumMismatch,
        }
    }
}
