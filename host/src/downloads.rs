//! What a host fetches and from where: one HTTP client with the download deadlines, the
//! origins every download may reach, and the wider scope a request naming the cluster's
//! peers gets.

use super::config::{
    DOWNLOAD_CONNECT_TIMEOUT, DOWNLOAD_READ_TIMEOUT, DOWNLOAD_TIMEOUT, HostConfig, MAX_URL_CHARS,
};
use meshflow_api::ClientError;
use meshflow_api::fetch_rules::{
    FetchScope, OriginError, Origins, Refusal, check_origin, guarded_client, origin, quoted,
};
use prometheus_client::metrics::counter::Counter;

/// A request named a peer that is not an origin.
#[derive(Debug, thiserror::Error)]
#[error("peers: {0}")]
pub struct PeersError(#[source] OriginError);

/// Why a URL a request names for this host to fetch is refused.
#[derive(Debug, thiserror::Error)]
pub enum UrlError {
    #[error("a URL may have at most {MAX_URL_CHARS} characters")]
    TooLong,
    /// Not a URL; the text quoted.
    #[error("{0} is not a URL")]
    NotAUrl(String),
    #[error(transparent)]
    Peers(#[from] PeersError),
    /// Outside what the host fetches from.
    #[error(transparent)]
    NotAllowed(#[from] Refusal),
}

pub struct Downloads {
    /// For downloads: inputs, corrections, full meshes and plugins of other hosts.
    http: reqwest::Client,
    /// What every download may reach before a request names its peers (see
    /// [`Downloads::scope`]).
    base: FetchScope,
    max_bytes: u64,
    /// Bytes downloaded, for `/metrics`.
    downloaded: Counter,
}

impl Downloads {
    pub fn new(config: &HostConfig, public_url: &str) -> anyhow::Result<Self> {
        let http = guarded_client()
            .connect_timeout(DOWNLOAD_CONNECT_TIMEOUT)
            .read_timeout(DOWNLOAD_READ_TIMEOUT)
            .build()?;
        let base = base_scope(config, public_url)?;
        let downloaded = Counter::default();
        Ok(Self { http, base, max_bytes: config.max_download_bytes, downloaded })
    }

    /// The client downloads go through (also the engine registration's).
    pub fn client(&self) -> &reqwest::Client {
        &self.http
    }

    /// What a request naming `peers` (the cluster's origins, as the engine sent them) may
    /// fetch: this host's own origins plus the peers, which also get the cluster token.
    pub fn scope(&self, peers: &[String]) -> Result<FetchScope, PeersError> {
        let mut scope = self.base.clone();
        for peer in peers {
            let peer = check_origin(peer).map_err(PeersError)?;
            scope.allowed.add(peer.clone());
            scope.cluster.insert(peer);
        }
        Ok(scope)
    }

    /// A URL a request names for this host to fetch, normalised (parsed, so quoting it in
    /// an error later repeats no raw bytes), if it is within what the host fetches from
    /// with these `peers`.
    pub fn allowed_url(&self, text: &str, peers: &[String]) -> Result<String, UrlError> {
        if text.len() > MAX_URL_CHARS {
            return Err(UrlError::TooLong);
        }
        let url = reqwest::Url::parse(text).map_err(|_| UrlError::NotAUrl(quoted(text)))?;
        self.scope(peers)?.allowed.check(&url)?;
        Ok(url.into())
    }

    /// Downloads `url` within `scope`, held to the size cap and the download deadlines.
    pub async fn get(&self, url: &str, scope: &FetchScope) -> Result<Vec<u8>, ClientError> {
        let bytes =
            meshflow_api::fetch(&self.http, url, scope, self.max_bytes, DOWNLOAD_TIMEOUT).await?;
        self.downloaded.inc_by(bytes.len() as u64);
        Ok(bytes)
    }

    /// The counter of bytes downloaded (shared: a clone counts into the same total).
    pub fn downloaded(&self) -> Counter {
        self.downloaded.clone()
    }
}

/// The origins a host fetches from whatever the request: its engine's and its own (which
/// also get the cluster token) and its `--allow-input-from`. A host with neither a cluster
/// token nor an allow-list (loopback only, see `start`) fetches from any origin.
fn base_scope(config: &HostConfig, public_url: &str) -> anyhow::Result<FetchScope> {
    let mut cluster = std::collections::BTreeSet::new();
    for url in Some(public_url).into_iter().chain(config.engine.as_deref()) {
        cluster.insert(origin(&reqwest::Url::parse(url)?));
    }
    let mut listed = Vec::new();
    for text in &config.allow_input_from {
        listed.push(check_origin(text)?);
    }
    let allowed = match config.cluster_token.is_none() && listed.is_empty() {
        true => Origins::any(),
        false => Origins::of(listed.into_iter().chain(cluster.iter().cloned())),
    };
    Ok(FetchScope { allowed, cluster, token: config.cluster_token.clone() })
}
