//! Replay corrections (`.mfr`): a step named instead of listed (DESIGN §4).
//!
//! A replay correction says which plugin (its SHA-256 digest) ran which service with which
//! fully resolved parameters on which mesh (base hash), and which mesh came out (result
//! hash and counts). A host applies it by running the same component on its own copy of the
//! base and must reach the result hash; this crate only writes and reads the bytes, the
//! running is the host's.
//!
//! ```text
//! magic "MFR\x1a" | version u16 LE | checksum [16] (BLAKE3 of every byte after it)
//! plugin digest [32] | base hash [32] | result hash [32]
//! varints: result vertices, result triangles, service length, parameters length
//! service name (UTF-8) | parameters (JSON object, UTF-8), ending the file
//! ```
//!
//! ```
//! use meshflow_codec::replay::{self, Replay};
//! use meshflow_mesh::ContentHash;
//! let step = Replay {
//!     plugin: [7; 32],
//!     service: "laplacian-smoothing".into(),
//!     params: r#"{"iterations":3}"#.into(),
//!     base: ContentHash([1; 32]),
//!     result: ContentHash([2; 32]),
//!     result_counts: [1000, 1996],
//! };
//! let bytes = replay::encode(&step);
//! assert!(bytes.len() < 200);
//! assert_eq!(replay::decode(&bytes).unwrap(), step);
//! ```

use meshflow_mesh::ContentHash;

use crate::correction::coding::bytes::{ByteReader, FramingError, put_varint};

const MAGIC: [u8; 4] = *b"MFR\x1a";
pub const VERSION: u16 = 1;
const CHECKSUM_LEN: usize = 16;
/// A service name is at most 64 bytes (the runtime refuses longer ones at load).
pub const MAX_SERVICE_BYTES: usize = 64;
/// Resolved parameters are a few numbers and words; anything longer is not one.
pub const MAX_PARAMS_BYTES: usize = 16 << 10;

/// One step, named.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Replay {
    /// SHA-256 of the plugin component that ran.
    pub plugin: [u8; 32],
    pub service: String,
    /// Every parameter, defaults filled in, as a JSON object.
    pub params: String,
    pub base: ContentHash,
    pub result: ContentHash,
    /// `[vertices, triangles]` of the result.
    pub result_counts: [u64; 2],
}

impl Replay {
    /// The plugin digest as hosts name plugins: lower-case hex.
    pub fn plugin_hex(&self) -> String {
        self.plugin.iter().map(|b| format!("{b:02x}")).collect()
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    #[error("not a meshflow replay correction (bad magic bytes)")]
    BadMagic,
    #[error(
        "replay correction format version {found} is not supported (this build reads {supported})"
    )]
    UnsupportedVersion { found: u16, supported: u16 },
    #[error("the replay correction is truncated")]
    Truncated,
    #[error("the replay correction is corrupt: checksum mismatch")]
    ChecksumMismatch,
    #[error("the replay correction is malformed: {0}")]
    Malformed(String),
}

impl From<FramingError> for ReplayError {
    fn from(e: FramingError) -> Self {
        match e {
            FramingError::Truncated => ReplayError::Truncated,
            FramingError::BadVarint => ReplayError::Malformed("overlong varint".into()),
            FramingError::BadGrid => ReplayError::Malformed("invalid grid".into()),
        }
    }
}

/// Does `bytes` start like a replay correction?
pub fn is_replay(bytes: &[u8]) -> bool {
    bytes.starts_with(&MAGIC)
}

pub fn encode(step: &Replay) -> Vec<u8> {
    let mut out = Vec::with_capacity(128 + step.service.len() + step.params.len());
    out.extend_from_slice(&MAGIC);
    out.extend_from_slice(&VERSION.to_le_bytes());
    out.extend_from_slice(&[0; CHECKSUM_LEN]);
    out.extend_from_slice(&step.plugin);
    out.extend_from_slice(&step.base.0);
    out.extend_from_slice(&step.result.0);
    for n in [step.result_counts[0], step.result_counts[1]] {
        put_varint(&mut out, n);
    }
    put_varint(&mut out, step.service.len() as u64);
    put_varint(&mut out, step.params.len() as u64);
    out.extend_from_slice(step.service.as_bytes());
    out.extend_from_slice(step.params.as_bytes());
    let checksum = blake3::hash(&out[6 + CHECKSUM_LEN..]);
    out[6..6 + CHECKSUM_LEN].copy_from_slice(&checksum.as_bytes()[..CHECKSUM_LEN]);
    out
}

pub fn decode(bytes: &[u8]) -> Result<Replay, ReplayError> {
    let mut r = ByteReader::new(bytes);
    if r.take(4).map_err(|_| ReplayError::BadMagic)? != MAGIC {
        return Err(ReplayError::BadMagic);
    }
    let version = r.u16()?;
    if version != VERSION {
        return Err(ReplayError::UnsupportedVersion { found: version, supported: VERSION });
    }
    let checksum = r.take(CHECKSUM_LEN)?;
    if blake3::hash(&bytes[6 + CHECKSUM_LEN..]).as_bytes()[..CHECKSUM_LEN] != *checksum {
        return Err(ReplayError::ChecksumMismatch);
    }
    let plugin = r.array()?;
    let base = ContentHash(r.array()?);
    let result = ContentHash(r.array()?);
    let result_counts = [r.varint()?, r.varint()?];
    if result_counts.iter().any(|&c| c > u64::from(u32::MAX)) {
        return Err(ReplayError::Malformed("element count exceeds u32 ids".into()));
    }
    let text = |r: &mut ByteReader, len: u64, max: usize, what: &str| {
        let len = usize::try_from(len)
            .ok()
            .filter(|&l| l <= max)
            .ok_or_else(|| ReplayError::Malformed(format!("{what} longer than {max} bytes")))?;
        String::from_utf8(r.take(len)?.to_vec())
            .map_err(|_| ReplayError::Malformed(format!("{what} is not UTF-8")))
    };
    let (service_len, params_len) = (r.varint()?, r.varint()?);
    let service = text(&mut r, service_len, MAX_SERVICE_BYTES, "service name")?;
    let params = text(&mut r, params_len, MAX_PARAMS_BYTES, "parameters")?;
    if r.remaining() != 0 {
        return Err(ReplayError::Malformed(format!(
            "{} bytes after the parameters",
            r.remaining()
        )));
    }
    Ok(Replay { plugin, service, params, base, result, result_counts })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Replay {
        Replay {
            plugin: [0xab; 32],
            service: "add-noise".into(),
            params: r#"{"amount":0.5,"seed":7}"#.into(),
            base: ContentHash([3; 32]),
            result: ContentHash([4; 32]),
            result_counts: [85_849, 170_000],
        }
    }

    #[test]
    fn a_step_reads_back_and_stays_small() {
        let bytes = encode(&sample());
        assert!(bytes.len() <= 200, "{} bytes", bytes.len());
        assert!(is_replay(&bytes));
        assert_eq!(decode(&bytes).unwrap(), sample());
        assert_eq!(sample().plugin_hex(), "ab".repeat(32));
    }

    #[test]
    fn every_truncation_and_bit_flip_is_an_error() {
        let bytes = encode(&sample());
        for len in 0..bytes.len() {
            assert!(decode(&bytes[..len]).is_err(), "prefix {len}");
        }
        for bit in 0..8 * bytes.len() {
            let mut damaged = bytes.clone();
            damaged[bit / 8] ^= 1 << (bit % 8);
            assert!(decode(&damaged).is_err(), "bit {bit}");
        }
    }

    #[test]
    fn oversized_fields_are_refused_before_reading_them() {
        let mut step = sample();
        step.params = "x".repeat(MAX_PARAMS_BYTES + 1);
        assert!(matches!(decode(&encode(&step)), Err(ReplayError::Malformed(_))));
    }
}
