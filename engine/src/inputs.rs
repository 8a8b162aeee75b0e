//! Meshes uploaded to the engine so that a workflow can name them by URL: streamed to a
//! file under the engine's data folder (never held in memory whole, readable by the engine's
//! user only), named by content digest, served to the hosts as they are, and deleted when no
//! kept run names them.

use std::path::{Path, PathBuf};

use futures_util::{Stream, StreamExt};
use tokio::io::AsyncWriteExt;

/// Extensions an input may carry; hosts pick the decoder by it.
const MESH_EXTENSIONS: [&str; 5] = ["mfm", "ply", "obj", "off", "stl"];

pub struct Inputs {
    dir: PathBuf,
}

/// Why an upload was not stored.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("input name \"{0}\" needs a mesh extension (mfm, ply, obj, off, stl)")]
    Extension(String),
    #[error("the upload is larger than the limit of {0} bytes")]
    TooLarge(u64),
    #[error("the upload broke off: {0}")]
    Body(String),
    #[error("storing the upload: {0}")]
    Io(#[from] std::io::Error),
}

/// A stored input: its file name under the inputs folder and its size.
pub struct Stored {
    pub file: String,
    pub bytes: u64,
}

impl Inputs {
    pub fn new(dir: PathBuf) -> std::io::Result<Self> {
        crate::files::private_dir(&dir)?;
        for entry in std::fs::read_dir(&dir)? {
            let entry = entry?;
            if entry.file_type()?.is_file() {
                crate::files::owner_only(&entry.path(), false)?;
            }
        }
        Ok(Self { dir })
    }

    /// Streams `body` to `<blake3>.<extension of name>`, refusing more than `limit` bytes;
    /// a refused or broken upload leaves nothing behind.
    pub async fn put<E: std::fmt::Display>(
        &self,
        name: &str,
        body: impl Stream<Item = Result<bytes::Bytes, E>>,
        limit: u64,
    ) -> Result<Stored, InputError> {
        let extension = Path::new(name)
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .filter(|e| MESH_EXTENSIONS.contains(&e.as_str()))
            .ok_or_else(|| InputError::Extension(name.chars().take(200).collect()))?;
        let partial =
            tempfile::Builder::new().prefix(".upload-").tempfile_in(&self.dir)?.into_temp_path();
        let mut file = tokio::fs::File::create(&partial).await?;
        let mut hasher = blake3::Hasher::new();
        let mut bytes = 0u64;
        let mut body = std::pin::pin!(body);
        while let Some(chunk) = body.next().await {
            let chunk = chunk.map_err(|e| InputError::Body(e.to_string()))?;
            bytes += chunk.len() as u64;
            if bytes > limit {
                return Err(InputError::TooLarge(limit));
            }
            hasher.update(&chunk);
            file.write_all(&chunk).await?;
        }
        file.sync_all().await?;
        crate::files::owner_only(&partial, false)?;
        let file = format!("{}.{extension}", hasher.finalize().to_hex());
        partial.persist(self.dir.join(&file)).map_err(|e| e.error)?;
        Ok(Stored { file, bytes })
    }

    /// The stored file of that name, if it is one of ours.
    pub fn path(&self, file: &str) -> Option<PathBuf> {
        let plain =
            file.chars().all(|c| c.is_ascii_alphanumeric() || c == '.') && !file.starts_with('.');
        plain.then(|| self.dir.join(file)).filter(|path| path.is_file())
    }

    /// Deletes a stored input (gone already is fine).
    pub fn remove(&self, file: &str) {
        if let Some(path) = self.path(file) {
            let _ = std::fs::remove_file(path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chunks(parts: &[&'static [u8]]) -> impl Stream<Item = Result<bytes::Bytes, String>> {
        futures_util::stream::iter(parts.iter().map(|p| Ok(bytes::Bytes::from_static(p))))
    }

    #[tokio::test]
    async fn uploads_are_stored_by_digest_and_oversized_ones_leave_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let inputs = Inputs::new(dir.path().to_owned()).unwrap();
        let stored = inputs.put("a.OBJ", chunks(&[b"v 0 0 0\n", b"v 1 0 0\n"]), 100).await.unwrap();
        assert_eq!(stored.file, format!("{}.obj", blake3::hash(b"v 0 0 0\nv 1 0 0\n").to_hex()));
        assert_eq!(std::fs::read(inputs.path(&stored.file).unwrap()).unwrap().len(), 16);
        let error = inputs.put("b.ply", chunks(&[b"0123456789", b"0123456789"]), 15).await;
        assert!(matches!(error, Err(InputError::TooLarge(15))));
        assert!(matches!(
            inputs.put("c.txt", chunks(&[b"x"]), 15).await,
            Err(InputError::Extension(_))
        ));
        let files = std::fs::read_dir(dir.path()).unwrap().count();
        assert_eq!(files, 1, "only the stored input remains");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode(&inputs.path(&stored.file).unwrap()), 0o600);
            assert_eq!(mode(dir.path()), 0o700);
        }
        assert!(inputs.path("../etc/passwd").is_none());
    }
}
