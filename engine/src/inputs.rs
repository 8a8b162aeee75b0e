//! Meshes uploaded to the engine so that a workflow can name them by URL: stored under the
//! engine's data folder by content digest, served to the hosts as they are.

use std::path::{Path, PathBuf};

/// Extensions an input may carry; hosts pick the decoder by it.
const MESH_EXTENSIONS: [&str; 5] = ["mfm", "ply", "obj", "off", "stl"];

pub struct Inputs {
    dir: PathBuf,
}

impl Inputs {
    pub fn new(dir: PathBuf) -> std::io::Result<Self> {
        std::fs::create_dir_all(&dir)?;
        Ok(Self { dir })
    }

    /// Stores `bytes` as `<blake3>.<extension of name>` and returns that file name.
    pub async fn put(&self, name: &str, bytes: &[u8]) -> Result<String, String> {
        let extension = Path::new(name)
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .filter(|e| MESH_EXTENSIONS.contains(&e.as_str()))
            .ok_or_else(|| {
                format!(
                    "input name \"{name}\" needs a mesh extension ({})",
                    MESH_EXTENSIONS.join(", ")
                )
            })?;
        let file = format!("{}.{extension}", blake3::hash(bytes).to_hex());
        let path = self.dir.join(&file);
        if !tokio::fs::try_exists(&path).await.unwrap_or(false) {
            let partial = self.dir.join(format!(".{file}.partial"));
            tokio::fs::write(&partial, bytes).await.map_err(|e| e.to_string())?;
            tokio::fs::rename(&partial, &path).await.map_err(|e| e.to_string())?;
        }
        Ok(file)
    }

    /// The stored file of that name, if it is one of ours.
    pub fn path(&self, file: &str) -> Option<PathBuf> {
        let plain =
            file.chars().all(|c| c.is_ascii_alphanumeric() || c == '.') && !file.starts_with('.');
        plain.then(|| self.dir.join(file)).filter(|path| path.is_file())
    }
}
