//! The hosts an engine knows: their services, whether they answer, and how busy they are.

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use meshflow_api::fetch_rules::{check_address, guarded_client, origin};
use meshflow_api::host::ServiceEntry;
use meshflow_api::params::{ServiceInfo, ServiceKind};
use meshflow_api::{CONNECT_TIMEOUT, ClusterAccess, HostClient};
use serde::Serialize;

use crate::limits::{MAX_HOSTS, SUSPECT_FOR};
use crate::measured::Measured;
use crate::store::{self, Store};
use crate::trust::{self, Trust};

/// A plugin's size as a host offering it said (nothing from a host that did not).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PluginSize {
    /// The component's bytes, which compiling it scales with.
    pub component: Option<u64>,
    /// The bytes a fetch of it moves: the component zstd-compressed, about a third.
    pub sent: Option<u64>,
}

impl PluginSize {
    /// The bytes a fetch moves: the component's from a host that does not compress.
    pub fn sent(self) -> Option<u64> {
        self.sent.or(self.component)
    }
}

/// How often the engine asks every host for its health and services.
pub const POLL_INTERVAL: Duration = Duration::from_secs(2);

pub struct HostEntry {
    pub url: String,
    pub client: HostClient,
    state: Mutex<HostState>,
    /// Named at start (`--host`): never forgotten, however long it is down.
    pinned: AtomicBool,
    /// When the host last answered a poll (or was added).
    last_seen: Mutex<Instant>,
    /// Why and since when the host is suspect.
    suspect: Mutex<Option<(Instant, String)>>,
    /// How far an admin trusts it; with its suspicion, kept in the store (`trust.rs`).
    trust: Mutex<Trust>,
    store: Store,
}

#[derive(Default, Clone, Serialize)]
pub struct HostState {
    pub up: bool,
    pub services: Vec<ServiceEntry>,
    /// Runs in progress on the host, as it last said.
    pub running: u32,
    /// Of those, the ones this engine had not triggered (as far as its count then says):
    /// other engines', the CLI's.
    #[serde(skip)]
    others_running: u32,
    /// Tasks this engine has triggered there and not yet seen finish.
    pub assigned: u32,
    pub last_error: Option<String>,
    /// Whether it runs plugins fetched from other hosts (replays, steps moved to it); a
    /// host started with `--no-foreign-plugins` does not.
    pub foreign_plugins: bool,
    /// Which life of the host the last poll found (`Health::instance`).
    #[serde(skip)]
    instance: Option<String>,
}

/// The longest `Health::instance` kept (hosts send 16 hex digits); a longer one is not
/// believed, and restarts of that host go unnoticed.
const MAX_INSTANCE_CHARS: usize = 64;

impl HostState {
    /// The host's count of runs in progress, as a poll got it.
    fn polled_running(&mut self, running: u32) {
        self.running = running;
        self.others_running = running.saturating_sub(self.assigned);
    }
}

impl HostEntry {
    fn new(client: HostClient, url: String, store: Store) -> Self {
        Self {
            client,
            url,
            state: Mutex::new(HostState::default()),
            pinned: AtomicBool::new(false),
            last_seen: Mutex::new(Instant::now()),
            suspect: Mutex::default(),
            trust: Mutex::default(),
            store,
        }
    }

    /// Takes what the store kept of the host: its trust level and a suspicion not yet over.
    fn restore(&self, standing: trust::Standing) {
        *self.trust.lock().unwrap() = standing.trust;
        if let Some((why, since)) = standing.suspect {
            let age = Duration::from_secs(store::unix_now().saturating_sub(since).max(0) as u64);
            if let Some(since) = Instant::now().checked_sub(age).filter(|_| age < SUSPECT_FOR) {
                *self.suspect.lock().unwrap() = Some((since, why));
            }
        }
    }

    /// Writes the host's trust level and suspicion to the store (`cleared`: the verdict
    /// that just proved it right). A short statement, done in place so writes stay in order.
    fn persist(&self, cleared: Option<String>) {
        let suspect = self
            .suspect
            .lock()
            .unwrap()
            .clone()
            .map(|(since, why)| (why, store::unix_now() - since.elapsed().as_secs() as i64));
        let trust = *self.trust.lock().unwrap();
        let url = self.url.clone();
        let written = self.store.now(|c| {
            let cleared = match cleared {
                Some(cleared) => Some(cleared),
                None => trust::load(c, &url)?.cleared,
            };
            trust::save(c, &url, &trust::Standing { trust, suspect, cleared })
        });
        if let Err(error) = written {
            tracing::error!(host = %self.url, "keeping the host's standing: {error}");
        }
    }

    pub fn trust(&self) -> Trust {
        *self.trust.lock().unwrap()
    }

    /// Sets how far the host is trusted, and keeps it.
    pub fn set_trust(&self, trust: Trust) {
        *self.trust.lock().unwrap() = trust;
        self.persist(None);
    }

    /// A verdict proved the host right: it is suspect no more (kept).
    pub fn clear_suspicion(&self, verdict: String) {
        *self.suspect.lock().unwrap() = None;
        self.persist(Some(verdict));
    }

    pub fn keep_always(&self) {
        self.pinned.store(true, Ordering::Relaxed);
    }

    pub fn state(&self) -> HostState {
        self.state.lock().unwrap().clone()
    }

    pub fn is_up(&self) -> bool {
        self.state.lock().unwrap().up
    }

    /// Whether the host is up, not suspect and offers `service`.
    /// Whether the host has the plugin with this digest loaded (a replay there needs no
    /// plugin download).
    pub fn has_plugin(&self, digest: &str) -> bool {
        self.state.lock().unwrap().services.iter().any(|s| s.plugin == digest)
    }

    /// Whether the host runs plugins it fetches by digest (a host not yet heard from is
    /// taken not to).
    pub fn runs_foreign_plugins(&self) -> bool {
        self.state.lock().unwrap().foreign_plugins
    }

    /// The plugin (digest) the host runs `service` with, and the service's kind: the one
    /// `pin` (a digest or its prefix) names, or the one serving unpinned requests.
    pub fn plugin_for(&self, service: &str, pin: Option<&str>) -> Option<(String, ServiceKind)> {
        let state = self.state.lock().unwrap();
        let entry = state.services.iter().find(|s| {
            s.info.name == service
                && match pin {
                    Some(pin) => s.plugin.starts_with(pin),
                    None => !s.pinned_only,
                }
        })?;
        Some((entry.plugin.clone(), entry.info.kind))
    }

    /// The size of the plugin `digest`, if the host offers it and said.
    pub fn plugin_size(&self, digest: &str) -> Option<PluginSize> {
        let state = self.state.lock().unwrap();
        let service = state.services.iter().find(|s| s.plugin == digest)?;
        let size = PluginSize { component: service.plugin_bytes, sent: service.plugin_sent_bytes };
        (size != PluginSize::default()).then_some(size)
    }

    pub fn offers(&self, service: &str) -> bool {
        let state = self.state.lock().unwrap();
        state.up && state.services.iter().any(|s| s.info.name == service) && !self.is_suspect()
    }

    /// Whether the host is up, not suspect and offers `service` from the plugin whose
    /// digest starts with `pin` (a whole digest, or the prefix a workflow gave).
    pub fn offers_plugin(&self, service: &str, pin: &str) -> bool {
        let state = self.state.lock().unwrap();
        let offered = |s: &ServiceEntry| s.info.name == service && s.plugin.starts_with(pin);
        state.up && state.services.iter().any(offered) && !self.is_suspect()
    }

    /// Takes the host out of plans for [`SUSPECT_FOR`], saying why.
    pub fn mark_suspect(&self, reason: String) {
        *self.suspect.lock().unwrap() = Some((Instant::now(), reason));
        self.persist(None);
    }

    /// Why the host is suspect, while it is.
    pub fn suspicion(&self) -> Option<String> {
        let suspect = self.suspect.lock().unwrap();
        suspect
            .as_ref()
            .filter(|(since, _)| since.elapsed() < SUSPECT_FOR)
            .map(|(_, why)| why.clone())
    }

    pub fn is_suspect(&self) -> bool {
        self.suspicion().is_some()
    }

    /// The load used to pick among hosts: what it runs plus what we are about to send it.
    /// Tasks running or waiting there: this engine's own as it counts them now, others' as
    /// of the last poll (the host's count then also held this engine's tasks of that
    /// moment, which may have finished since: counted twice, a task just done made a host
    /// look busy for up to a poll interval).
    pub fn load(&self) -> u32 {
        let state = self.state.lock().unwrap();
        state.others_running + state.assigned
    }

    pub fn mark_down(&self, reason: String) {
        let mut state = self.state.lock().unwrap();
        state.up = false;
        state.last_error = Some(reason);
    }

    /// Counts a task in flight on this host until the guard drops.
    pub fn assign(self: &Arc<Self>) -> Assignment {
        self.state.lock().unwrap().assigned += 1;
        Assignment(self.clone())
    }

    /// Asks the host for its health and services; a host that does not answer is down.
    /// True when the answer came from another life of the host than the last one did (it
    /// restarted in between, losing the plugins it had fetched).
    pub async fn refresh(&self) -> bool {
        let polled = async {
            let health = self.client.health().await?;
            let services = self.client.services().await?;
            Ok::<_, meshflow_api::ClientError>((health, services))
        }
        .await;
        let mut state = self.state.lock().unwrap();
        match polled {
            Ok((health, services)) => {
                *self.last_seen.lock().unwrap() = Instant::now();
                state.up = true;
                state.polled_running(u32::try_from(health.running).unwrap_or(u32::MAX));
                state.services = services;
                state.foreign_plugins = health.foreign_plugins;
                state.last_error = None;
                // A host's own word, kept only at the length a real one has.
                let instance = health.instance.filter(|i| i.len() <= MAX_INSTANCE_CHARS);
                let before = std::mem::replace(&mut state.instance, instance);
                before.is_some() && before != state.instance
            }
            Err(error) => {
                state.up = false;
                state.last_error = Some(error.to_string());
                false
            }
        }
    }
}

pub struct Assignment(Arc<HostEntry>);

impl Drop for Assignment {
    fn drop(&mut self) {
        let mut state = self.0.state.lock().unwrap();
        state.assigned = state.assigned.saturating_sub(1);
    }
}

/// The hosts, kept in the engine's database so a restart knows them again.
pub struct Registry {
    hosts: Mutex<Vec<Arc<HostEntry>>>,
    store: Store,
    /// The engine's own origin, always a peer of its hosts.
    own_origin: String,
    /// The cluster token and the cluster's origins, shared by every host's client.
    access: ClusterAccess,
    /// One pool for all hosts; names resolve only to addresses that may be fetched.
    http: reqwest::Client,
    /// Links and speeds measured across runs, for the cost model.
    pub measured: Measured,
    /// What `GET /metrics` reports; the executor feeds it.
    pub(crate) metrics: crate::metrics::Metrics,
    /// `--spot-check`: the share of a spot-checked host's steps replayed (f64 bits).
    spot_check: std::sync::atomic::AtomicU64,
}

pub use meshflow_api::engine::ServiceOffer as Offer;

/// A host the registry refuses, and why.
#[derive(Debug, thiserror::Error)]
pub enum RegisterError {
    #[error(transparent)]
    BadUrl(#[from] BadHostUrl),
    #[error("the engine knows {MAX_HOSTS} hosts already")]
    Full,
    #[error(transparent)]
    Store(#[from] store::StoreError),
}

/// A host URL the registry refuses, and why.
#[derive(Debug, thiserror::Error)]
#[error("`{url}` is not a host's base URL: {reason}")]
pub struct BadHostUrl {
    pub url: String,
    pub reason: &'static str,
}

/// The base URL of a host as the registry keeps it (no trailing `/`), or why it is none.
fn host_base_url(text: &str) -> Result<String, BadHostUrl> {
    let bad = |reason| BadHostUrl { url: text.chars().take(200).collect(), reason };
    let url = reqwest::Url::parse(text).map_err(|_| bad("it does not parse as a URL"))?;
    if !matches!(url.scheme(), "http" | "https") {
        return Err(bad("only http and https are spoken"));
    }
    if url.host_str().is_none_or(str::is_empty) {
        return Err(bad("it names no host"));
    }
    if !url.username().is_empty() || url.password().is_some() {
        return Err(bad("it carries credentials"));
    }
    if url.query().is_some() || url.fragment().is_some() {
        return Err(bad("it has a query or fragment"));
    }
    if check_address(&url).is_err() {
        return Err(bad("link-local and metadata addresses are never hosts"));
    }
    Ok(url.as_str().trim_end_matches('/').to_owned())
}

impl Registry {
    /// A registry of an engine reached at `public_url`, whose hosts' clients send
    /// `cluster_token`, keeping its hosts in `store`.
    pub fn new(
        public_url: &str,
        cluster_token: Option<String>,
        store: Store,
    ) -> anyhow::Result<Self> {
        let own_origin = origin(&reqwest::Url::parse(public_url)?);
        let access = ClusterAccess::new(cluster_token);
        access.set_peers(vec![own_origin.clone()]);
        let http = guarded_client().connect_timeout(CONNECT_TIMEOUT).build()?;
        // Measurements that do not read back (a file from another version) are re-learned.
        let measured = match store.now(store::load_measurements) {
            Ok(snapshot) => Measured::restore(snapshot.unwrap_or_default()),
            Err(error) => {
                tracing::warn!("starting from default link and speed figures: {error}");
                Measured::default()
            }
        };
        let metrics = crate::metrics::Metrics::default();
        let spot_check = std::sync::atomic::AtomicU64::new(trust::DEFAULT_SPOT_CHECK.to_bits());
        Ok(Self {
            hosts: Mutex::default(),
            store,
            own_origin,
            access,
            http,
            measured,
            metrics,
            spot_check,
        })
    }

    /// A client for the host at `url`, with the cluster's token.
    fn client_for(&self, url: &str) -> HostClient {
        HostClient::with_client(url, self.http.clone()).with_access(self.access.clone())
    }

    /// The client of the registered host that `url` (its base or a URL under it, e.g. a blob
    /// URL it gave) belongs to, if any: the cluster token goes to no other server.
    pub fn registered(&self, url: &str) -> Option<HostClient> {
        let under = |base: &str| {
            url.strip_prefix(base).is_some_and(|rest| rest.is_empty() || rest.starts_with('/'))
        };
        let hosts = self.hosts.lock().unwrap();
        let host = hosts.iter().filter(|h| under(&h.url)).max_by_key(|h| h.url.len());
        host.map(|h| h.client.clone())
    }

    /// Adds a host (once per URL, at most [`MAX_HOSTS`]), records it, and asks it for its
    /// services before returning. The URL must be a plain `http(s)://host[:port][/path]`
    /// base: no credentials, query or fragment.
    pub async fn register(&self, url: &str) -> Result<Arc<HostEntry>, RegisterError> {
        let url = host_base_url(url)?;
        let (entry, new) = {
            let mut hosts = self.hosts.lock().unwrap();
            match hosts.iter().find(|h| h.url == url) {
                Some(entry) => (entry.clone(), false),
                None if hosts.len() >= MAX_HOSTS => return Err(RegisterError::Full),
                None => {
                    let client = self.client_for(&url);
                    let entry = Arc::new(HostEntry::new(client, url, self.store.clone()));
                    hosts.push(entry.clone());
                    self.access.set_peers(self.peers(&hosts));
                    (entry, true)
                }
            }
        };
        if new {
            let url = entry.url.clone();
            let standing = self
                .store
                .call(move |c| {
                    store::add_host(c, &url)?;
                    trust::load(c, &url)
                })
                .await?;
            entry.restore(standing);
        }
        self.refresh(&entry).await;
        Ok(entry)
    }

    /// Polls one host; a host that restarted since the last poll holds none of the plugins
    /// it had fetched, so the cost model stops counting them.
    pub async fn refresh(&self, host: &HostEntry) {
        if host.refresh().await {
            self.measured.forget_fetched(&host.url);
        }
    }

    /// A client of the host at `url`: the registered one's, or a new one for a host no
    /// longer registered (to delete what a run left there).
    pub fn client(&self, url: &str) -> HostClient {
        let hosts = self.hosts.lock().unwrap();
        match hosts.iter().find(|h| h.url == url) {
            Some(entry) => entry.client.clone(),
            None => self.client_for(url),
        }
    }

    /// Forgets hosts that have not answered for `age` ([`FORGET_DOWN_HOST_AFTER`] for the
    /// janitor), unless they were named at start.
    pub async fn forget_down_longer_than(&self, age: Duration) {
        let forgotten: Vec<String> = {
            let mut hosts = self.hosts.lock().unwrap();
            let (gone, kept) = std::mem::take(&mut *hosts).into_iter().partition(|h| {
                !h.pinned.load(Ordering::Relaxed)
                    && !h.is_up()
                    && h.last_seen.lock().unwrap().elapsed() > age
            });
            *hosts = kept;
            self.access.set_peers(self.peers(&hosts));
            gone.into_iter().map(|h: Arc<HostEntry>| h.url.clone()).collect()
        };
        for url in forgotten {
            tracing::info!("forgetting host {url}: down for over {age:?}");
            self.measured.forget_host(&url);
            if let Err(error) = self.store.call(move |c| store::remove_host(c, &url)).await {
                tracing::error!("{error}");
            }
        }
    }

    /// The origins hosts may fetch from and send the cluster token to: the engine's and
    /// every registered host's.
    fn peers(&self, hosts: &[Arc<HostEntry>]) -> Vec<String> {
        let hosts = hosts.iter().filter_map(|h| reqwest::Url::parse(&h.url).ok());
        let mut peers: Vec<String> = hosts.map(|url| origin(&url)).collect();
        peers.push(self.own_origin.clone());
        peers.sort();
        peers.dedup();
        peers
    }

    pub fn hosts(&self) -> Vec<Arc<HostEntry>> {
        self.hosts.lock().unwrap().clone()
    }

    /// The size of the plugin `digest` as a host offering it last said: what a host lacking
    /// it downloads and compiles to replay a step of it.
    pub fn plugin_size(&self, digest: &str) -> PluginSize {
        self.hosts().iter().find_map(|h| h.plugin_size(digest)).unwrap_or_default()
    }

    /// Polls every host, concurrently.
    pub async fn refresh_all(&self) {
        let hosts = self.hosts();
        futures_util::future::join_all(hosts.iter().map(|h| self.refresh(h))).await;
    }

    /// Keeps polling until the process ends.
    pub fn spawn_poller(self: &Arc<Self>) {
        let registry = Arc::downgrade(self);
        tokio::spawn(async move {
            loop {
                tokio::time::sleep(POLL_INTERVAL).await;
                let Some(registry) = registry.upgrade() else { return };
                registry.refresh_all().await;
            }
        });
    }

    /// The service catalogue: every service offered by a host that is up, by name.
    pub fn catalogue(&self) -> BTreeMap<String, Offer> {
        let mut offers = BTreeMap::<String, Offer>::new();
        for host in self.hosts() {
            let state = host.state();
            if !state.up {
                continue;
            }
            for service in state.services {
                let offer = offers.entry(service.info.name.clone()).or_insert_with(|| Offer {
                    info: service.info.clone(),
                    hosts: Vec::new(),
                    plugins: Vec::new(),
                });
                // A host lists a service once per plugin offering it (replaced ones too).
                if !offer.hosts.contains(&host.url) {
                    offer.hosts.push(host.url.clone());
                }
                if !offer.plugins.contains(&service.plugin) {
                    offer.plugins.push(service.plugin);
                }
            }
        }
        offers
    }

    pub fn service(&self, name: &str) -> Option<ServiceInfo> {
        self.catalogue().remove(name).map(|offer| offer.info)
    }

    /// The registered host at `url` (its base URL as registered, a trailing `/` ignored).
    pub fn host(&self, url: &str) -> Option<Arc<HostEntry>> {
        let url = url.trim_end_matches('/');
        self.hosts().into_iter().find(|h| h.url == url)
    }

    /// Sets how far the host at `url` is trusted and keeps it, registered or not yet (a
    /// host named by `--host-trust` may register later).
    pub async fn set_trust(&self, url: &str, level: Trust) -> Result<(), store::StoreError> {
        if let Some(host) = self.host(url) {
            host.set_trust(level);
            return Ok(());
        }
        let url = url.trim_end_matches('/').to_owned();
        self.store
            .call(move |c| {
                let standing = trust::Standing { trust: level, ..trust::load(c, &url)? };
                trust::save(c, &url, &standing)
            })
            .await
    }

    /// The share of a `spot-check` host's steps replayed elsewhere (`--spot-check`).
    pub fn spot_check_share(&self) -> f64 {
        f64::from_bits(self.spot_check.load(Ordering::Relaxed))
    }

    pub fn set_spot_check_share(&self, share: f64) {
        self.spot_check.store(share.clamp(0.0, 1.0).to_bits(), Ordering::Relaxed);
    }
}

impl crate::validate::Catalogue for Registry {
    fn describe(&self, service: &str, pin: Option<&str>) -> Option<ServiceInfo> {
        let Some(pin) = pin else { return self.service(service) };
        self.hosts().iter().filter(|h| h.offers_plugin(service, pin)).find_map(|host| {
            let state = host.state();
            let entry = state
                .services
                .into_iter()
                .find(|s| s.info.name == service && s.plugin.starts_with(pin))?;
            Some(entry.info)
        })
    }

    fn digests(&self, service: &str) -> Vec<String> {
        self.catalogue().remove(service).map(|offer| offer.plugins).unwrap_or_default()
    }

    fn names(&self) -> Vec<String> {
        self.catalogue().into_keys().collect()
    }
}

/// A registry of an engine on :7000 with a cluster token, keeping its hosts in a database
/// under `dir`; and that database.
#[cfg(test)]
pub(crate) fn test_registry(dir: &std::path::Path) -> (Registry, Store) {
    let store = Store::open(&dir.join("engine.sqlite3")).unwrap();
    let registry =
        Registry::new("http://127.0.0.1:7000", Some("secret".into()), store.clone()).unwrap();
    (registry, store)
}

#[cfg(test)]
impl HostEntry {
    /// Makes the host up and offering `services` (as filters of plugin `d…d`), as a poll
    /// would.
    pub(crate) fn pretend_offering(&self, services: &[&str]) {
        let entry = |name: &&str| ServiceEntry {
            plugin: "d".repeat(64),
            builtin: true,
            info: ServiceInfo {
                name: (*name).to_owned(),
                kind: meshflow_api::params::ServiceKind::Filter,
                doc: String::new(),
                params: Vec::new(),
                result_type: None,
            },
            pinned_only: false,
            plugin_bytes: None,
            plugin_sent_bytes: None,
        };
        let mut state = self.state.lock().unwrap();
        state.up = true;
        state.services = services.iter().map(entry).collect();
    }
}

impl crate::downloads::Hosts for Registry {
    fn registered(&self, url: &str) -> Option<HostClient> {
        Registry::registered(self, url)
    }

    fn up(&self) -> Vec<HostClient> {
        self.hosts().iter().filter(|h| h.is_up()).map(|h| h.client.clone()).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::limits::FORGET_DOWN_HOST_AFTER;

    fn registry(dir: &tempfile::TempDir) -> (Registry, Store) {
        test_registry(dir.path())
    }

    #[tokio::test]
    async fn hosts_down_too_long_are_forgotten_unless_named_at_start() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, store) = registry(&dir);
        // Nothing listens on port 9 of the loopback: both hosts are down at once.
        let dead = registry.register("http://127.0.0.1:9/a").await.unwrap();
        let named = registry.register("http://127.0.0.1:9/b").await.unwrap();
        named.keep_always();
        assert!(!dead.is_up() && !named.is_up());
        registry.forget_down_longer_than(FORGET_DOWN_HOST_AFTER).await;
        assert_eq!(registry.hosts().len(), 2, "down for a moment is not long");
        tokio::time::sleep(Duration::from_millis(20)).await;
        registry.forget_down_longer_than(Duration::from_millis(10)).await;
        let urls: Vec<String> = registry.hosts().iter().map(|h| h.url.clone()).collect();
        assert_eq!(urls, ["http://127.0.0.1:9/b"]);
        assert_eq!(store.now(store::load_hosts).unwrap(), ["http://127.0.0.1:9/b"]);
    }

    #[tokio::test]
    async fn a_host_that_restarted_is_no_longer_counted_as_holding_the_plugins_it_fetched() {
        use axum::routing::get;
        let instance = Arc::new(Mutex::new("first life".to_owned()));
        let health = {
            let instance = instance.clone();
            move || {
                let instance = instance.lock().unwrap().clone();
                async move {
                    axum::Json(serde_json::json!({
                        "status": "ok", "version": "0", "running": 0, "sessions": 0,
                        "instance": instance
                    }))
                }
            }
        };
        let app = axum::Router::new()
            .route("/health", get(health))
            .route("/services", get(|| async { axum::Json(serde_json::json!([])) }));
        let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
        let url = format!("http://{}", listener.local_addr().unwrap());
        tokio::spawn(async move { axum::serve(listener, app).await });

        let dir = tempfile::tempdir().unwrap();
        let (registry, _store) = registry(&dir);
        let host = registry.register(&url).await.unwrap();
        assert!(host.is_up());
        registry.measured.prefetched(&url, "digest");
        registry.refresh_all().await;
        assert!(registry.measured.has_fetched(&url, "digest"), "the same life keeps them");
        *instance.lock().unwrap() = "second life".to_owned();
        registry.refresh_all().await;
        assert!(!registry.measured.has_fetched(&url, "digest"), "a restart loses them");
    }

    #[tokio::test]
    async fn a_task_of_this_engine_stops_counting_when_it_ends_not_at_the_next_poll() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, _store) = registry(&dir);
        let host = registry.register("http://127.0.0.1:9/a").await.unwrap();
        let ours = host.assign();
        // The poll sees our task and one of another engine's.
        host.state.lock().unwrap().polled_running(2);
        assert_eq!(host.load(), 2);
        drop(ours);
        assert_eq!(host.load(), 1, "the other engine's task is all that is left");
        host.state.lock().unwrap().polled_running(0);
        assert_eq!(host.load(), 0);
    }

    #[tokio::test]
    async fn measured_links_survive_a_restart_and_go_with_a_forgotten_host() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, store) = registry(&dir);
        let (kept, gone) = ("http://127.0.0.1:9/b", "http://127.0.0.1:9/a");
        let unmeasured = registry.measured.link_into(kept);
        // Both took 8 s to download a 5 MB input: 5 Mbit/s, not the default's 100.
        for host in [kept, gone] {
            registry.measured.downloaded(None, host, 5_000_000, 8_000.0);
        }
        let measured = registry.measured.link_into(kept);
        assert_ne!(measured, unmeasured);
        let snapshot = registry.measured.take_snapshot().expect("something was measured");
        store.now(|c| store::save_measurements(c, &snapshot)).unwrap();
        drop(registry);

        let (restarted, _) = test_registry(dir.path());
        assert_eq!(restarted.measured.link_into(kept), measured);
        restarted.register(gone).await.unwrap();
        tokio::time::sleep(Duration::from_millis(20)).await;
        restarted.forget_down_longer_than(Duration::from_millis(10)).await;
        assert_eq!(restarted.measured.link_into(gone), unmeasured);
        assert_eq!(restarted.measured.link_into(kept), measured);
    }

    #[test]
    fn measurements_that_do_not_read_back_leave_the_defaults_and_the_engine_starts() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, store) = registry(&dir);
        let unmeasured = registry.measured.link_into("http://127.0.0.1:9/a");
        drop(registry);
        store
            .now(|c| {
                c.execute(
                    "INSERT OR REPLACE INTO measurements (only, snapshot) VALUES (1, ?1)",
                    ["{\"pairs\": \"not a list\""],
                )?;
                Ok(())
            })
            .unwrap();
        let (restarted, _) = test_registry(dir.path());
        assert_eq!(restarted.measured.link_into("http://127.0.0.1:9/a"), unmeasured);
    }

    #[test]
    fn host_urls_are_plain_http_bases() {
        assert_eq!(host_base_url("http://127.0.0.1:7101/").unwrap(), "http://127.0.0.1:7101");
        assert_eq!(
            host_base_url("https://lab.example/meshflow").unwrap(),
            "https://lab.example/meshflow"
        );
        for bad in [
            "not a url at all",
            "file:///etc/passwd",
            "ftp://127.0.0.1/",
            "http://user:secret@127.0.0.1:7101",
            "http://127.0.0.1:7101/?x=1",
            "http://127.0.0.1:7101/#top",
            "http://169.254.169.254/",
            "http://[fe80::1]:7101",
        ] {
            assert!(host_base_url(bad).is_err(), "{bad} was taken");
        }
    }

    #[tokio::test]
    async fn clients_are_only_for_registered_hosts() {
        let dir = tempfile::tempdir().unwrap();
        let (registry, _) = registry(&dir);
        // Nobody listens on port 9: the host is registered, though down.
        registry.register("http://127.0.0.1:9").await.unwrap();
        let base = |url: &str| registry.registered(url).map(|c| c.base_url().to_owned());
        assert_eq!(base("http://127.0.0.1:9/blobs/x.mfm").as_deref(), Some("http://127.0.0.1:9"));
        assert_eq!(base("http://127.0.0.1:9").as_deref(), Some("http://127.0.0.1:9"));
        assert!(base("http://127.0.0.1:90/blobs/x.mfm").is_none());
        assert!(base("http://127.0.0.1:10/blobs/x.mfm").is_none());
        assert!(base("not a url").is_none());
    }
}
