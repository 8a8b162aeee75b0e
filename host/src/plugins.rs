//! The plugins a host offers: built-in ones and uploaded ones (stored under
//! `DATA/plugins/<digest>.wasm`, reloaded at restart). The routes are `routes/plugins.rs`.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::{Arc, RwLock};

use meshflow_api::host::{PluginEntry, ServiceEntry};
use meshflow_meshio as io;
use meshflow_runtime::{Catalog, Plugin, PluginError, RunError, Runtime, ServiceInfo, digest};

/// Largest plugin component accepted by upload.
pub const MAX_PLUGIN_BYTES: usize = 64 << 20;

/// The zstd level plugins are sent to other hosts at. Components shrink to about a third
/// (the built-ins: 200-345 KB to 66-110 KB); level 9 takes 10 ms for a built-in and 0.4 s
/// for an 18 MB Python component, where level 19 gained another 8 % at 20 times the time.
const SENT_ZSTD_LEVEL: i32 = 9;

/// Why a plugin could not be found, added or removed.
#[derive(Debug, thiserror::Error)]
pub enum PluginSetError {
    #[error(transparent)]
    Run(#[from] RunError),
    #[error("no plugin `{0}`")]
    NotFound(String),
    #[error("no plugin `{0}`: {1}")]
    NotFoundBecause(String, String),
    #[error("plugin {digest} has no service `{service}`; it offers: {offered}")]
    NoSuchService { digest: String, service: String, offered: String },
    #[error(
        "plugin {digest} offers services already on this host: {taken}; upload it with \
         replace (`meshflow plugin upload --replace`, `POST /plugins?replace=true`) to serve \
         them from the new plugin, the old staying for runs pinned to it"
    )]
    Collides { digest: String, taken: String },
    #[error("built-in plugins cannot be deleted")]
    Builtin,
    /// The uploaded bytes are not a plugin.
    #[error(transparent)]
    Invalid(PluginError),
    #[error("background task failed: {0}")]
    Task(#[from] tokio::task::JoinError),
    #[error("{0}")]
    Storage(String),
    /// zstd could not compress the component for other hosts.
    #[error("compressing the plugin for other hosts: {0}")]
    Compress(#[source] std::io::Error),
}

/// What an upload changed: the services no plugin offered before, and those it now
/// serves in place of another plugin.
#[derive(Debug, Default)]
pub struct Uploaded {
    pub new: Vec<String>,
    pub replaced: Vec<String>,
}

/// An upload: its digest, the services it offers, and what it changed (nothing when the
/// same bytes were here already).
pub struct Upload {
    pub digest: String,
    pub services: Vec<ServiceInfo>,
    pub present: bool,
    pub outcome: Uploaded,
}

pub struct PluginSet {
    dir: PathBuf,
    inner: RwLock<Loaded>,
    /// The built-ins' bytes, for hosts that replay their steps and lack them.
    builtin_bytes: Vec<(String, &'static [u8])>,
    /// Each plugin's component size and its form for other hosts, by digest.
    kept: RwLock<HashMap<String, Kept>>,
}

/// What a host keeps of each plugin beside the loaded component.
struct Kept {
    /// The component's size, which `GET /plugins` reports.
    bytes: u64,
    /// The component zstd-compressed, as it goes to a host replaying its steps (`GET
    /// /plugins/{digest}/wasm` with `Accept-Encoding: zstd`); its size is what `GET
    /// /services` says such a host downloads.
    sent: Arc<Vec<u8>>,
}

impl Kept {
    fn of(component: &[u8]) -> Result<Self, PluginSetError> {
        let sent =
            zstd::bulk::compress(component, SENT_ZSTD_LEVEL).map_err(PluginSetError::Compress)?;
        Ok(Self { bytes: component.len() as u64, sent: Arc::new(sent) })
    }
}

struct Loaded {
    /// Newest first: an upload that replaced services serves them ahead of older plugins
    /// and the built-ins; the older ones stay for runs pinned to their digest.
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
    pub fn load(
        runtime: &Runtime,
        dir: PathBuf,
        builtin_bytes: &[&'static [u8]],
    ) -> anyhow::Result<Self> {
        let builtins = builtin_bytes
            .iter()
            .map(|bytes| runtime.load(bytes))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| anyhow::anyhow!("loading a built-in plugin: {e}"))?;
        let builtin_bytes: Vec<(String, &'static [u8])> =
            builtins.iter().map(|p| p.digest.clone()).zip(builtin_bytes.iter().copied()).collect();
        let mut kept = HashMap::new();
        for (digest, bytes) in &builtin_bytes {
            kept.insert(digest.clone(), Kept::of(bytes)?);
        }
        let mut stored: Vec<_> = std::fs::read_dir(&dir)?
            .flatten()
            .filter(|e| e.path().extension().is_some_and(|x| x == "wasm"))
            .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
            .collect();
        stored.sort();
        let mut uploaded = Vec::new();
        // Oldest first, each put in front: the newest serves a name, as before the restart.
        for (_, path) in stored {
            match std::fs::read(&path).map_err(|e| e.to_string()).and_then(|bytes| {
                let plugin = runtime.load(&bytes).map_err(|e| e.to_string())?;
                Ok((plugin, Kept::of(&bytes).map_err(|e| e.to_string())?))
            }) {
                Ok((plugin, sent)) => {
                    kept.insert(plugin.digest.clone(), sent);
                    uploaded.insert(0, plugin);
                }
                Err(e) => tracing::warn!("skipping stored plugin {}: {e}", path.display()),
            }
        }
        let inner = RwLock::new(Loaded::new(uploaded, builtins));
        Ok(Self { dir, inner, builtin_bytes, kept: RwLock::new(kept) })
    }

    fn read(&self) -> std::sync::RwLockReadGuard<'_, Loaded> {
        self.inner.read().expect("plugin set lock")
    }

    fn kept(&self) -> std::sync::RwLockReadGuard<'_, HashMap<String, Kept>> {
        self.kept.read().expect("kept plugins lock")
    }

    /// The component size of the plugin with this digest, if it is here.
    pub fn size(&self, digest: &str) -> Option<u64> {
        self.kept().get(digest).map(|k| k.bytes)
    }

    /// The plugin with this digest as it goes to other hosts (zstd-compressed), if it is
    /// loaded here.
    pub fn sent(&self, digest: &str) -> Option<Arc<Vec<u8>>> {
        self.by_digest(digest)?;
        self.kept().get(digest).map(|k| k.sent.clone())
    }

    /// The plugin to run `service` with: the given one, or the catalogue's choice.
    pub fn find(
        &self,
        service: &str,
        digest: Option<&str>,
    ) -> Result<(Plugin, ServiceInfo), PluginSetError> {
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
            .ok_or_else(|| PluginSetError::NotFound(digest.to_owned()))?;
        with_service(plugin.clone(), service)
    }

    /// Every service of every plugin; those another plugin replaced are `pinned_only`.
    pub fn services(&self) -> Vec<ServiceEntry> {
        let (loaded, kept) = (self.read(), self.kept());
        loaded
            .catalog
            .every_service()
            .into_iter()
            .map(|(info, plugin, serves_unpinned)| ServiceEntry {
                plugin: plugin.digest.clone(),
                builtin: loaded.is_builtin(&plugin.digest),
                info: info.clone(),
                pinned_only: !serves_unpinned,
                plugin_bytes: kept.get(&plugin.digest).map(|k| k.bytes),
                plugin_sent_bytes: kept.get(&plugin.digest).map(|k| k.sent.len() as u64),
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
                bytes: self.size(&p.digest),
            })
            .collect()
    }

    /// The loaded plugin with this digest, whatever services it offers.
    pub fn by_digest(&self, digest: &str) -> Option<Plugin> {
        self.read().catalog.plugins().iter().find(|p| p.digest == digest).cloned()
    }

    /// The component bytes of a loaded plugin (for another host replaying its steps).
    pub fn bytes(&self, digest: &str) -> Option<Vec<u8>> {
        self.by_digest(digest)?;
        if let Some((_, bytes)) = self.builtin_bytes.iter().find(|(d, _)| d == digest) {
            return Some(bytes.to_vec());
        }
        std::fs::read(self.dir.join(format!("{digest}.wasm"))).ok()
    }

    pub fn known(&self, digest: &str) -> Option<Vec<ServiceInfo>> {
        let loaded = self.read();
        loaded.catalog.plugins().iter().find(|p| p.digest == digest).map(|p| p.services.clone())
    }

    /// Validates (loads, on a blocking thread, with `runtime`) and adds uploaded component
    /// `bytes`, unless the same bytes are here already; see [`PluginSet::add`].
    pub async fn upload<B>(
        &self,
        runtime: &Arc<Runtime>,
        bytes: B,
        replace: bool,
    ) -> Result<Upload, PluginSetError>
    where
        B: AsRef<[u8]> + Clone + Send + 'static,
    {
        let digest = digest(bytes.as_ref());
        if let Some(services) = self.known(&digest) {
            let outcome = Uploaded::default();
            return Ok(Upload { digest, services, present: true, outcome });
        }
        let (runtime, loaded) = (runtime.clone(), bytes.clone());
        let (plugin, kept) = tokio::task::spawn_blocking(move || {
            let plugin = runtime.load(loaded.as_ref()).map_err(PluginSetError::Invalid)?;
            Ok::<_, PluginSetError>((plugin, Kept::of(loaded.as_ref())?))
        })
        .await??;
        let services = plugin.services.clone();
        let outcome = self.add(plugin, bytes.as_ref(), kept, replace)?;
        tracing::info!("plugin {digest} uploaded (replacing: {:?})", outcome.replaced);
        Ok(Upload { digest, services, present: false, outcome })
    }

    /// Stores an uploaded plugin's bytes and offers its services. A plugin offering a
    /// service another plugin already serves is refused unless `replace`; then it serves
    /// those names to unpinned runs and the other stays for runs pinned to it. Returns the
    /// services that are new and those replaced.
    fn add(
        &self,
        plugin: Plugin,
        bytes: &[u8],
        kept: Kept,
        replace: bool,
    ) -> Result<Uploaded, PluginSetError> {
        let mut loaded = self.inner.write().expect("plugin set lock");
        if loaded.catalog.plugins().iter().any(|p| p.digest == plugin.digest) {
            // The same bytes raced another upload of them.
            return Ok(Uploaded::default());
        }
        let mut outcome = Uploaded::default();
        let mut taken = Vec::new();
        for service in &plugin.services {
            match loaded.catalog.find(&service.name) {
                Ok((owner, _)) => {
                    taken.push(format!("{} (plugin {})", service.name, owner.digest));
                    outcome.replaced.push(service.name.clone());
                }
                Err(_) => outcome.new.push(service.name.clone()),
            }
        }
        if !taken.is_empty() && !replace {
            return Err(PluginSetError::Collides {
                digest: plugin.digest.clone(),
                taken: taken.join(", "),
            });
        }
        // Written under the lock, so a concurrent delete cannot remove the file between
        // writing and listing it; plugins are small and uploads rare.
        let path = self.dir.join(format!("{}.wasm", plugin.digest));
        io::write_private_file(&path, |out| out.write_all(bytes))
            .map_err(|e| PluginSetError::Storage(format!("storing the plugin: {e}")))?;
        self.kept.write().expect("kept plugins lock").insert(plugin.digest.clone(), kept);
        let mut uploaded = std::mem::take(&mut loaded.uploaded);
        uploaded.insert(0, plugin);
        *loaded = Loaded::new(uploaded, std::mem::take(&mut loaded.builtins));
        Ok(outcome)
    }

    pub fn remove(&self, digest: &str) -> Result<(), PluginSetError> {
        let mut loaded = self.inner.write().expect("plugin set lock");
        if loaded.is_builtin(digest) {
            return Err(PluginSetError::Builtin);
        }
        let mut uploaded = std::mem::take(&mut loaded.uploaded);
        let before = uploaded.len();
        uploaded.retain(|p| p.digest != digest);
        let found = uploaded.len() != before;
        *loaded = Loaded::new(uploaded, std::mem::take(&mut loaded.builtins));
        if !found {
            return Err(PluginSetError::NotFound(digest.to_owned()));
        }
        self.kept.write().expect("kept plugins lock").remove(digest);
        std::fs::remove_file(self.dir.join(format!("{digest}.wasm")))
            .map_err(|e| PluginSetError::Storage(format!("deleting the stored plugin: {e}")))
    }
}

/// `plugin` with its description of `service`, or why it has none.
pub fn with_service(
    plugin: Plugin,
    service: &str,
) -> Result<(Plugin, ServiceInfo), PluginSetError> {
    let Some(info) = plugin.service(service).cloned() else {
        let offered: Vec<&str> = plugin.services.iter().map(|s| s.name.as_str()).collect();
        return Err(PluginSetError::NoSuchService {
            digest: plugin.digest.clone(),
            service: service.to_owned(),
            offered: offered.join(", "),
        });
    };
    Ok((plugin, info))
}
