//! Downloads streamed to a temporary file in the data folder while hashed (as the engine's
//! uploads are), so a host never holds a network copy of a mesh, correction or input in
//! memory beyond one write buffer: the size cap holds while streaming, a session's deletion
//! aborts its downloads at once (its cancellation token), and a download slower than
//! [`MIN_DOWNLOAD_RATE`] over a [`SLOW_DOWNLOAD_WINDOW`] is cut. The file is then read once
//! for parsing, and kept as the blob by renaming it (`BlobStore::adopt`), not written again.

use std::path::Path;
use std::time::Instant;

use futures_util::StreamExt;
use meshflow_api::ClientError;
use tokio::io::AsyncWriteExt;
use tokio_util::sync::CancellationToken;

use crate::config::{DOWNLOAD_BUFFER_BYTES, MIN_DOWNLOAD_RATE, SLOW_DOWNLOAD_WINDOW};

/// Why a spooled download stopped.
#[derive(Debug, thiserror::Error)]
pub enum SpoolError {
    #[error(transparent)]
    Fetch(#[from] ClientError),
    #[error("{url}: the download is larger than the limit of {limit} bytes")]
    TooLarge { url: String, limit: u64 },
    #[error(
        "{url}: the download was cut: {bytes} bytes in the last {} s, below the floor of {} \
         bytes/s",
        SLOW_DOWNLOAD_WINDOW.as_secs(), MIN_DOWNLOAD_RATE
    )]
    TooSlow { url: String, bytes: u64 },
    #[error("{url}: the download was cancelled (its session was deleted)")]
    Cancelled { url: String },
    #[error("{url}: storing the download: {source}")]
    Io {
        url: String,
        #[source]
        source: std::io::Error,
    },
}

/// A download on disk: a temporary file (deleted if dropped), its size and the BLAKE3 of
/// its bytes.
pub struct Spooled {
    pub path: tempfile::TempPath,
    pub bytes: u64,
    pub digest: blake3::Hash,
}

impl Spooled {
    /// The bytes, read once (for parsing).
    pub async fn read(&self) -> std::io::Result<Vec<u8>> {
        tokio::fs::read(&self.path).await
    }
}

/// The chunks of a download as they arrive, for a reader on another thread (a decoder); it
/// sees the end when the download ends, however it ends.
pub type Tap = std::sync::mpsc::Sender<Vec<u8>>;

/// Streams `response`'s body into a new temporary file under `dir`, at most `limit` bytes,
/// hashing it and handing each chunk to `tap` too; stops at once when `cancel` fires, and
/// when fewer than `MIN_DOWNLOAD_RATE * SLOW_DOWNLOAD_WINDOW` bytes came in one window.
pub async fn spool(
    response: reqwest::Response,
    url: &str,
    dir: &Path,
    limit: u64,
    cancel: &CancellationToken,
    mut tap: Option<Tap>,
) -> Result<Spooled, SpoolError> {
    let io = |source| SpoolError::Io { url: url.to_owned(), source };
    let too_large = || SpoolError::TooLarge { url: url.to_owned(), limit };
    if response.content_length().is_some_and(|n| n > limit) {
        return Err(too_large());
    }
    let path = tempfile::Builder::new()
        .prefix(".download-")
        .tempfile_in(dir)
        .map_err(io)?
        .into_temp_path();
    let file = tokio::fs::File::create(&path).await.map_err(io)?;
    let mut file = tokio::io::BufWriter::with_capacity(DOWNLOAD_BUFFER_BYTES, file);
    let mut hasher = blake3::Hasher::new();
    let mut bytes = 0u64;
    let floor = MIN_DOWNLOAD_RATE * SLOW_DOWNLOAD_WINDOW.as_secs();
    let mut window = (Instant::now(), 0u64);
    let mut body = response.bytes_stream();
    loop {
        let deadline = tokio::time::Instant::from_std(window.0 + SLOW_DOWNLOAD_WINDOW);
        let next = tokio::select! {
            () = cancel.cancelled() => return Err(SpoolError::Cancelled { url: url.to_owned() }),
            next = tokio::time::timeout_at(deadline, body.next()) => next,
        };
        let chunk = match next {
            // A window is over without its bytes: checked below.
            Err(_) => None,
            Ok(None) => break,
            Ok(Some(chunk)) => Some(chunk.map_err(|e| ClientError::Protocol {
                url: url.to_owned(),
                message: e.to_string(),
            })?),
        };
        if let Some(chunk) = &chunk {
            bytes += chunk.len() as u64;
            if bytes > limit {
                return Err(too_large());
            }
            hasher.update(chunk);
            file.write_all(chunk).await.map_err(io)?;
            // A reader that stopped (it found the bytes wrong) needs no more.
            if tap.as_ref().is_some_and(|tap| tap.send(chunk.to_vec()).is_err()) {
                tap = None;
            }
            window.1 += chunk.len() as u64;
        }
        if window.0.elapsed() >= SLOW_DOWNLOAD_WINDOW {
            if window.1 < floor {
                return Err(SpoolError::TooSlow { url: url.to_owned(), bytes: window.1 });
            }
            window = (Instant::now(), 0);
        }
    }
    file.flush().await.map_err(io)?;
    drop(file);
    Ok(Spooled { path, bytes, digest: hasher.finalize() })
}
