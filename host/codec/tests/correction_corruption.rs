//! Damaged corrections give typed errors, never a panic or a huge allocation.

mod correction_common;

use correction_common::{Rng, attributed, grid, random_edits, smooth};
use meshflow_codec::correction::{self, CorrectionError};
use meshflow_mesh::MeshData;
use meshflow_mesh::store::{MeshStore, Op};
use proptest::prelude::*;

/// A small correction with ops of many kinds, and its base (with attributes for odd seeds).
fn sample(seed: u64) -> (MeshData, Vec<u8>) {
    let mut rng = Rng(seed);
    let base = grid(4, 4, 2, &mut rng);
    let base = if seed % 2 == 1 { attributed(base, &mut rng) } else { base };
    let mut store = MeshStore::new(base.clone());
    random_edits(&mut store, &mut rng, 12);
    let (result, log) = store.finish();
    let bytes = correction::encode(&base, &log, &result).unwrap();
    (base, bytes)
}

/// Offset of the checksum and of what it covers.
const CHECKSUM: std::ops::Range<usize> = 6..22;

fn reseal(bytes: &mut [u8]) {
    let sum = blake3::hash(&bytes[CHECKSUM.end..]);
    bytes[CHECKSUM].copy_from_slice(&sum.as_bytes()[..16]);
}

#[test]
fn every_truncation_is_an_error() {
    let (base, bytes) = sample(1);
    for len in 0..bytes.len() {
        let error = correction::apply(base.clone(), &bytes[..len]).unwrap_err();
        assert!(
            matches!(
                error,
                CorrectionError::BadMagic
                    | CorrectionError::Truncated
                    | CorrectionError::ChecksumMismatch
            ),
            "prefix {len}: {error}"
        );
    }
}

#[test]
fn every_single_bit_flip_is_an_error() {
    let (base, bytes) = sample(2);
    for bit in 0..8 * bytes.len() {
        let mut damaged = bytes.clone();
        damaged[bit / 8] ^= 1 << (bit % 8);
        assert!(correction::apply(base.clone(), &damaged).is_err(), "bit {bit}");
    }
}

/// A smoothing step over 22,500 vertices is decoded in chunks while two threads predict
/// them: damage anywhere in it is caught (never a wrong mesh), and a decoding that stops
/// early stops the predicting threads too (the test would hang otherwise).
#[test]
fn damage_in_a_chunked_smoothing_step_is_caught() {
    let base = grid(150, 150, 0, &mut Rng(5));
    let mut store = MeshStore::new(base.clone());
    store.apply(Op::SetPositions { xyz: smooth(&base, 0.5) }).unwrap();
    let (result, log) = store.finish();
    let bytes = correction::encode(&base, &log, &result).unwrap();
    let body = correction::decode(&bytes).unwrap().header_bytes..bytes.len();
    for i in (body.start..body.end).step_by(body.len() / 40) {
        let mut damaged = bytes.clone();
        damaged[i] ^= 0x5a;
        reseal(&mut damaged);
        match correction::apply(base.clone(), &damaged) {
            Ok(mesh) => assert_eq!(mesh.content_hash(), result.content_hash(), "byte {i}"),
            Err(e) => assert!(!matches!(e, CorrectionError::ChecksumMismatch), "byte {i}: {e}"),
        }
    }
    assert!(correction::apply(base.clone(), &bytes[..body.end - body.len() / 2]).is_err());
}

#[test]
fn wrong_version_magic_and_base_are_named() {
    let (base, bytes) = sample(3);
    let mut next = bytes.clone();
    next[4..6].copy_from_slice(&(correction::VERSION + 1).to_le_bytes());
    let error = correction::apply(base.clone(), &next).unwrap_err();
    assert!(
        matches!(
            error,
            CorrectionError::UnsupportedVersion { found, supported }
                if found == correction::VERSION + 1 && supported == correction::VERSION
        ),
        "{error}"
    );
    let mut magic = bytes.clone();
    magic[0] = b'X';
    assert!(matches!(correction::decode(&magic), Err(CorrectionError::BadMagic)));
    let other = grid(4, 4, 3, &mut Rng(99));
    assert!(matches!(
        correction::apply(other.clone(), &bytes),
        Err(CorrectionError::BaseMismatch { expected, found })
            if expected == base.content_hash() && found == other.content_hash()
    ));
}

#[test]
fn forged_counts_are_refused_before_decoding() {
    let (base, bytes) = sample(4);
    let header = correction::decode(&bytes).unwrap();
    // The first per-kind count follows the 4 hashes' worth of fixed fields and the 4
    // element-count varints; rewrite the file with an absurd add-vertices count instead.
    let mut forged = bytes[..86].to_vec();
    for n in header.base_counts.iter().chain(&header.result_counts) {
        varint(&mut forged, *n);
    }
    for (i, k) in header.kinds.iter().enumerate() {
        let edits = if i == 0 { 1 << 40 } else { k.edits };
        varint(&mut forged, k.ops);
        varint(&mut forged, edits);
    }
    for s in header.section_bytes {
        varint(&mut forged, s as u64);
    }
    forged.extend_from_slice(&bytes[header.header_bytes..]);
    reseal(&mut forged);
    assert!(matches!(correction::apply(base.clone(), &forged), Err(CorrectionError::Malformed(_))));
}

fn varint(out: &mut Vec<u8>, mut v: u64) {
    while v >= 0x80 {
        out.push(v as u8 | 0x80);
        v >>= 7;
    }
    out.push(v as u8);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// Damage the checksum cannot see (it was recomputed): the decoder itself must cope.
    #[test]
    fn resealed_damage_to_the_coded_sections_never_panics(
        seed in 0u64..16,
        at in any::<usize>(),
        value in any::<u8>(),
    ) {
        let (base, mut bytes) = sample(seed);
        let header = correction::decode(&bytes).unwrap();
        let body = header.header_bytes..bytes.len();
        prop_assume!(!body.is_empty());
        let i = body.start + at % body.len();
        bytes[i] = value;
        reseal(&mut bytes);
        match correction::apply(base.clone(), &bytes) {
            Ok(mesh) => prop_assert_eq!(mesh.content_hash(), header.result),
            Err(e) => prop_assert!(!matches!(e, CorrectionError::ChecksumMismatch)),
        }
    }
}
