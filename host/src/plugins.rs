//! The plugins a host offers: built-in ones and uploaded ones (stored under
//! `DATA/plugins/<digest>.wasm`, reloaded at restart); upload, list and delete.

use std::path::PathBuf;
use std::sync::{Arc, RwLock};

use axum::Json;
use axum::body::Bytes;
use axum::extract::{Path, State};
use axum::http::{HeaderMap, StatusCode, header};

use super::error::ApiError;
use super::state::Host;
use meshflow_api::host::{PluginEntry, ServiceEntry, UploadedPlugin};
use meshflow_meshio as io;
use meshflow_runtime::{Catalog, Runtime};
use meshflow_runtime::{Plugin, ServiceInfo, digest};

/// Largest plugin component accepted by upload.
pub const MAX_PLUGIN_BYTES: usize = 64 << 20;

pub struct PluginSet {
    dir: PathBuf,
    inner: RwLock<Loaded>,
}

struct Loaded {
    /// In upload order; they shadow built-ins of the same service name.
    uploaded: Vec<Plugin>,
    builtins: Vec<Plugin>,
    catalog: Catalog,
}

impl Loaded {
    fn new(uploaded: Vec<Plugin>, builtins: Vec<Plugin>) -> Self {
        let mut catalog = Catalog::new();
        uploaded.iter().chain(&builtins).for_each(|p| catalog.add(p.clone()));
        Self { uploaded, builtins, catalog }
    }

    fn is_builtin(&self, digest: &str) -> bool {
        self.builtins.iter().any(|p| p.digest == digest)
    }
}

impl PluginSet {
    /// Loads the built-ins and every stored upload (oldest first). A stored plugin that no
    /// longer loads is skipped with a warning rather than keeping the host down.
    pub fn load(runtime: &Runtime, dir: PathBuf, builtins: &[&[u8]]) -> anyhow::Result<Self> {
        let builtins = builtins
            .iter()
            .map(|bytes| runtime.load(bytes))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| anyhow::anyhow!("loading a built-in plugin: {e}"))?;
        let mut stored: Vec<_> = std::fs::read_dir(&dir)?
            .flatten()
            .filter(|e| e.path().extension().is_some_and(|x| x == "wasm"))
            .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
            .collect();
        stored.sort();
        let mut uploaded = Vec::new();
        for (_, path) in stored {
            match std::fs::read(&path)
                .map_err(|e| e.to_string())
                .and_then(|bytes| runtime.load(&bytes).map_err(|e| e.to_string()))
            {
                Ok(plugin) => uploaded.push(plugin),
                Err(e) => tracing::warn!("skipping stored plugin {}: {e}", path.display()),
            }
        }
        Ok(Self { dir, inner: RwLock::new(Loaded::new(uploaded, builtins)) })
    }

    fn read(&self) -> std::sync::RwLockReadGuard<'_, Loaded> {
        self.inner.read().expect("plugin set lock")
    }

    /// The plugin to run `service` with: the given one, or the catalogue's choice.
    pub fn find(
        &self,
        service: &str,
        digest: Option<&str>,
    ) -> Result<(Plugin, ServiceInfo), ApiError> {
        let loaded = self.read();
        let Some(digest) = digest else {
            let (plugin, info) = loaded.catalog.find(service)?;
            return Ok((plugin.clone(), info.clone()));
        };
        let plugin = loaded
            .catalog
            .plugins()
            .iter()
            .find(|p| p.digest == digest)
            .ok_or_else(|| ApiError::not_found("plugin", digest))?;
        let info = plugin.service(service).ok_or_else(|| {
            let offered: Vec<&str> = plugin.services.iter().map(|s| s.name.as_str()).collect();
            ApiError::bad_request(
                "unknown-service",
                format!(
                    "plugin {digest} has no service `{service}`; it offers: {}",
                    offered.join(", ")
                ),
            )
        })?;
        Ok((plugin.clone(), info.clone()))
    }

    pub fn services(&self) -> Vec<ServiceEntry> {
        let loaded = self.read();
        let services = loaded.catalog.services();
        services
            .into_iter()
            .map(|(info, plugin)| ServiceEntry {
                plugin: plugin.digest.clone(),
                builtin: loaded.is_builtin(&plugin.digest),
                info: info.clone(),
            })
            .collect()
    }

    pub fn entries(&self) -> Vec<PluginEntry> {
        let loaded = self.read();
        loaded
            .catalog
            .plugins()
            .iter()
            .map(|p| PluginEntry {
                digest: p.digest.clone(),
                builtin: loaded.is_builtin(&p.digest),
                services: p.services.iter().map(|s| s.name.clone()).collect(),
            })
            .collect()
    }

    fn known(&self, digest: &str) -> Option<Vec<ServiceInfo>> {
        let loaded = self.read();
        loaded.catalog.plugins().iter().find(|p| p.digest == digest).map(|p| p.services.clone())
    }

    /// Stores an uploaded plugin's bytes and offers its services ahead of the built-ins.
    fn add(&self, plugin: Plugin, bytes: &[u8]) -> Result<(), ApiError> {
        let path = self.dir.join(format!("{}.wasm", plugin.digest));
        io::write_file(&path, |out| out.write_all(bytes))
            .map_err(|e| ApiError::internal(format!("storing the plugin: {e}")))?;
        let mut loaded = self.inner.write().expect("plugin set lock");
        let mut uploaded = std::mem::take(&mut loaded.uploaded);
        // Two uploads of the same bytes may race; keep one.
        if !uploaded.iter().any(|p| p.digest == plugin.digest) {
            uploaded.push(plugin);
        }
        *loaded = Loaded::new(uploaded, std::mem::take(&mut loaded.builtins));
        Ok(())
    }

    fn remove(&self, digest: &str) -> Result<(), ApiError> {
        let mut loaded = self.inner.write().expect("plugin set lock");
        if loaded.is_builtin(digest) {
            return Err(ApiError::new(
                StatusCode::FORBIDDEN,
                "builtin",
                "built-in plugins cannot be deleted",
            ));
        }
        let mut uploaded = std::mem::take(&mut loaded.uploaded);
        let before = uploaded.len();
        uploaded.retain(|p| p.digest != digest);
        let found = uploaded.len() != before;
        *loaded = Loaded::new(uploaded, std::mem::take(&mut loaded.builtins));
        if !found {
            return Err(ApiError::not_found("plugin", digest));
        }
        std::fs::remove_file(self.dir.join(format!("{digest}.wasm")))
            .map_err(|e| ApiError::internal(format!("deleting the stored plugin: {e}")))
    }
}

/// Uploads and deletes need the host's token; a host without one takes none.
fn authorize(host: &Host, headers: &HeaderMap) -> Result<(), ApiError> {
    let Some(token) = &host.config.token else {
        return Err(ApiError::new(
            StatusCode::FORBIDDEN,
            "uploads-disabled",
            "uploads disabled: start the host with --token",
        ));
    };
    let given = headers
        .get(header::AUTHORIZATION)
        .and_then(|v| v.to_str().ok())
        .and_then(|v| v.strip_prefix("Bearer "));
    // Comparing hashes takes the same time wherever the strings differ.
    match given {
        Some(given) if blake3::hash(given.as_bytes()) == blake3::hash(token.as_bytes()) => Ok(()),
        _ => Err(ApiError::new(
            StatusCode::UNAUTHORIZED,
            "unauthorized",
            "a valid bearer token is required",
        )),
    }
}

/// `POST /plugins`: body = component bytes.
pub async fn upload(
    State(host): State<Arc<Host>>,
    headers: HeaderMap,
    body: Bytes,
) -> Result<(StatusCode, Json<UploadedPlugin>), ApiError> {
    authorize(&host, &headers)?;
    let digest = digest(&body);
    if let Some(services) = host.plugins.known(&digest) {
        return Ok((StatusCode::OK, Json(UploadedPlugin { digest, services })));
    }
    let runtime = host.runtime.clone();
    let bytes = body.clone();
    let plugin = tokio::task::spawn_blocking(move || runtime.load(&bytes))
        .await?
        .map_err(|e| ApiError::unprocessable("invalid-plugin", e.to_string()))?;
    let services = plugin.services.clone();
    host.plugins.add(plugin, &body)?;
    tracing::info!("plugin {digest} uploaded");
    Ok((StatusCode::CREATED, Json(UploadedPlugin { digest, services })))
}

/// `GET /plugins`.
pub async fn list(State(host): State<Arc<Host>>) -> Json<Vec<PluginEntry>> {
    Json(host.plugins.entries())
}

/// `GET /services`.
pub async fn services(State(host): State<Arc<Host>>) -> Json<Vec<ServiceEntry>> {
    Json(host.plugins.services())
}

/// `DELETE /plugins/{digest}`.
pub async fn delete(
    State(host): State<Arc<Host>>,
    Path(digest): Path<String>,
    headers: HeaderMap,
) -> Result<StatusCode, ApiError> {
    authorize(&host, &headers)?;
    host.plugins.remove(&digest)?;
    Ok(StatusCode::NO_CONTENT)
}
