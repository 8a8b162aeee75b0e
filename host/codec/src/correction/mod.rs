//! Corrections (`.mfc`): the edit log of one step, entropy coded, replayed bit-exactly on
//! another host.
//!
//! A correction names the mesh it applies to and the mesh it produces (content hashes), and
//! holds the ops of the step. Both [`encode`] and [`apply`] replay the ops through a
//! [`MeshStore`](meshflow_mesh::store::MeshStore), so every prediction is made from the same state
//! on both sides and only residuals are coded:
//! - ids as deltas; ascending id lists as runs of consecutive ids; removals of whole
//!   components as one seed triangle each, and the vertices a triangle removal left unused
//!   as one symbol (`removals.rs`);
//! - new vertices as exact f32 residuals from the mean of their neighbours in the triangles
//!   added with them, split points from the centroid or midpoint they replace;
//! - moves as residuals from the old position; `set-positions` per vertex as "still",
//!   "exactly predicted" or a residual, the prediction being one step of uniform Laplacian
//!   smoothing with a fitted factor;
//! - `set-attribute` values as exact residuals from the element's value before the op, the
//!   value before it in the op, or for a set of every vertex from its neighbours or the
//!   geometry's normal (`attributes.rs`). What happens to attributes through the other ops
//!   (kept, interpolated at a split, recomputed normals) the store derives on both sides:
//!   it costs no byte.
//!
//! Residuals are differences of order-preserving integer images of the f32 bits, so the
//! codec is lossless. The header is readable without the base mesh ([`decode`]), for
//! `meshflow correction inspect`. The file layout is described in `header.rs`.
//!
//! ```
//! use meshflow_codec::correction;
//! use meshflow_mesh::{MeshData, store::{MeshStore, Op}};
//! let base = MeshData::new(vec![0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![0, 1, 2]);
//! let mut store = MeshStore::new(base.clone());
//! store.apply(Op::SplitTriangle { triangle: 0, at: None }).unwrap();
//! let (result, log) = store.finish();
//! let bytes = correction::encode(&base, &log, &result).unwrap();
//! assert_eq!(correction::apply(base, &bytes).unwrap(), result);
//! ```

mod attributes;
mod codec;
pub(crate) mod coding;
mod decode;
mod encode;
mod error;
mod header;
mod lists;
mod means;
mod predict;
mod removals;

pub use encode::{encode, encode_known};
pub use error::CorrectionError;
pub use header::{Correction, KindCount, SECTIONS, VERSION};
pub use means::NeighbourMeans;

use std::sync::Arc;

use meshflow_mesh::store::Op;
use meshflow_mesh::{ContentHash, MeshData};

/// Reads and checks a correction's header (magic, version, checksum, section sizes),
/// without the base mesh.
pub fn decode(bytes: &[u8]) -> Result<Correction, CorrectionError> {
    header::read(bytes).map(|(header, _)| header)
}

/// Applies a correction to `base`: checks the base hash, replays the ops, checks the result
/// hash. The result is bit-identical to the producer's. A shared `base` (a session's mesh)
/// is left as it is: the replay copies what the ops edit, when they first edit it.
pub fn apply(base: impl Into<Arc<MeshData>>, bytes: &[u8]) -> Result<MeshData, CorrectionError> {
    replay(base, bytes).map(|(mesh, _)| mesh)
}

/// Like [`apply`], also returning the replayed edit log (equal to the producer's log).
pub fn replay(
    base: impl Into<Arc<MeshData>>,
    bytes: &[u8],
) -> Result<(MeshData, Vec<Op>), CorrectionError> {
    let base = base.into();
    let (header, sections) = header::read(bytes)?;
    let counts = [base.vertex_count() as u64, base.triangle_count() as u64];
    if counts != header.base_counts {
        return Err(CorrectionError::BaseMismatch {
            expected: header.base,
            found: base.content_hash(),
        });
    }
    // The base hash (a pass over the whole mesh) is checked on a second thread while the
    // ops replay; on a mismatch the replay is discarded.
    let (found, replayed) = std::thread::scope(|s| {
        let hash = s.spawn(|| base.content_hash());
        let replayed = replay_checked(&header, sections, Arc::clone(&base), None);
        (hash.join().expect("hashing does not panic"), replayed)
    });
    if found != header.base {
        return Err(CorrectionError::BaseMismatch { expected: header.base, found });
    }
    replayed
}

/// Like [`apply`], for a caller that knows `base`'s hash and the result it was promised (a
/// host updating a session): a correction for another base or result is refused before any
/// replay, and `base` is not hashed again. `prepared` are `base`'s neighbour means if they
/// were gathered (while the correction downloaded): the same result either way.
pub fn apply_known(
    base: impl Into<Arc<MeshData>>,
    base_hash: ContentHash,
    bytes: &[u8],
    result: ContentHash,
    prepared: Option<&NeighbourMeans>,
) -> Result<MeshData, CorrectionError> {
    let (header, sections) = header::read(bytes)?;
    if header.base != base_hash {
        return Err(CorrectionError::BaseMismatch { expected: header.base, found: base_hash });
    }
    if header.result != result {
        return Err(CorrectionError::ResultMismatch { expected: result, found: header.result });
    }
    let base = base.into();
    let prepared = prepared.and_then(|p| p.of_mesh(base_hash, base.vertex_count() as u32));
    replay_checked(&header, sections, base, prepared).map(|(mesh, _)| mesh)
}

/// Replays the ops on `base` and checks the result's hash against the header.
fn replay_checked(
    header: &Correction,
    sections: [&[u8]; 4],
    base: Arc<MeshData>,
    prepared: Option<&means::Means>,
) -> Result<(MeshData, Vec<Op>), CorrectionError> {
    let (mesh, log) = decode::replay(header, sections, base, prepared)?;
    let found = mesh.content_hash();
    if found != header.result {
        return Err(CorrectionError::ResultMismatch { expected: header.result, found });
    }
    Ok((mesh, log))
}
