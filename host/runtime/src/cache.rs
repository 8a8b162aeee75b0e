//! Compiled components on disk, keyed by the component's digest and the engine's settings,
//! so a restart (or another CLI invocation) loads in ~0.1 ms instead of compiling again.

use std::hash::{Hash, Hasher};
use std::io::Write;
use std::path::{Path, PathBuf};

use wasmtime::Engine;
use wasmtime::component::Component;

use super::error::PluginError;

pub(crate) struct ArtifactCache {
    dir: PathBuf,
    /// Distinguishes artefacts of engines with different versions or settings.
    engine_tag: String,
}

impl ArtifactCache {
    pub(crate) fn new(dir: &Path, engine: &Engine) -> Result<Self, PluginError> {
        std::fs::create_dir_all(dir).map_err(|source| cache_error(dir, source))?;
        let mut hasher = std::hash::DefaultHasher::new();
        engine.precompile_compatibility_hash().hash(&mut hasher);
        Ok(Self { dir: dir.to_owned(), engine_tag: format!("{:016x}", hasher.finish()) })
    }

    fn path(&self, digest: &str) -> PathBuf {
        self.dir.join(format!("{digest}-{}.cwasm", self.engine_tag))
    }

    /// The compiled component for `bytes` (whose SHA-256 is `digest`), from disk if it is
    /// there, compiled and stored otherwise. An unreadable artefact is compiled again.
    pub(crate) fn load_or_compile(
        &self,
        engine: &Engine,
        digest: &str,
        bytes: &[u8],
    ) -> Result<Component, PluginError> {
        let path = self.path(digest);
        if path.exists() {
            // SAFETY: files in the cache directory are written only by `store` below from
            // `Component::serialize` of this engine configuration (the tag in the name).
            if let Ok(component) = unsafe { Component::deserialize_file(engine, &path) } {
                return Ok(component);
            }
        }
        let component = compile(engine, bytes)?;
        self.store(&path, &component)?;
        Ok(component)
    }

    fn store(&self, path: &Path, component: &Component) -> Result<(), PluginError> {
        let bytes = component.serialize().map_err(|e| PluginError::Compile(e.to_string()))?;
        let mut file = tempfile::NamedTempFile::new_in(&self.dir)
            .map_err(|source| cache_error(&self.dir, source))?;
        file.write_all(&bytes).map_err(|source| cache_error(path, source))?;
        file.persist(path).map_err(|e| cache_error(path, e.error))?;
        Ok(())
    }
}

pub(crate) fn compile(engine: &Engine, bytes: &[u8]) -> Result<Component, PluginError> {
    Component::new(engine, bytes).map_err(|e| PluginError::Compile(format!("{e:#}")))
}

fn cache_error(path: &Path, source: std::io::Error) -> PluginError {
    PluginError::Cache { path: path.display().to_string(), source }
}
