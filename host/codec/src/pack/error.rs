//! Why a mesh could not be packed or unpacked.

use crate::correction::coding::bytes::{FramingError, SealError};
use meshflow_mesh::ContentHash;

#[derive(Debug, thiserror::Error)]
pub enum PackError {
    #[error("not a meshflow packed mesh (bad magic bytes)")]
    BadMagic,
    #[error("packed mesh format version {found} is not supported (this build reads {supported})")]
    UnsupportedVersion { found: u16, supported: u16 },
    #[error("the packed mesh is truncated")]
    Truncated,
    #[error("the packed mesh is corrupt: checksum mismatch")]
    ChecksumMismatch,
    #[error("the packed mesh is malformed: {0}")]
    Malformed(String),
    #[error("the packed mesh's coded {0} data is corrupt")]
    Corrupt(&'static str),
    #[error("the unpacked mesh is {found}, not the packed {expected}")]
    HashMismatch { expected: ContentHash, found: ContentHash },
    #[error("reading the packed mesh: {0}")]
    Read(#[from] std::io::Error),
    #[error("cannot pack an invalid mesh: {0}")]
    InvalidMesh(String),
}

impl From<FramingError> for PackError {
    fn from(e: FramingError) -> Self {
        match e {
            FramingError::Truncated => PackError::Truncated,
            FramingError::BadVarint => PackError::Malformed("overlong varint".into()),
            FramingError::BadGrid => PackError::Malformed("invalid grid".into()),
        }
    }
}

impl From<SealError> for PackError {
    fn from(e: SealError) -> Self {
        match e {
            SealError::BadMagic => PackError::BadMagic,
            SealError::UnsupportedVersion(found) => {
                PackError::UnsupportedVersion { found, supported: super::VERSION }
            }
            SealError::Truncated => PackError::Truncated,
            SealError::ChecksumMismatch => PackError::ChecksumMismatch,
        }
    }
}
