//! What a host fetches and from where: one HTTP client with the download deadlines, the
//! origins every download may reach, and the wider scope a request naming the cluster's
//! peers gets; and meshes fetched and decoded in one go ([`Downloads::mesh`]).

use super::config::{
    DOWNLOAD_CONNECT_TIMEOUT, DOWNLOAD_READ_TIMEOUT, DOWNLOAD_TIMEOUT, HostConfig, MAX_URL_CHARS,
};
use meshflow_api::ClientError;
use meshflow_api::fetch_rules::{
    FetchScope, OriginError, Origins, Refusal, check_origin, guarded_client, origin, quoted,
};
use std::time::{Duration, Instant};

use prometheus_client::metrics::counter::Counter;
use tokio_util::sync::CancellationToken;

use crate::meshes::{self, CurrentMesh, MeshEncoding, MeshError};
use crate::spool::{self, SpoolError, Spooled, Tap};

/// A mesh downloaded and decoded ([`Downloads::mesh`]).
pub struct FetchedMesh {
    /// The file it came in, to keep as its blob.
    pub spooled: Spooled,
    pub mesh: CurrentMesh,
    pub encoding: MeshEncoding,
    /// What the file held that the mesh does not keep (nothing for packed meshes).
    pub not_kept: Vec<String>,
    /// Until the last byte was in.
    pub download: Duration,
    /// From then until the mesh was decoded and hashed.
    pub load: Duration,
}

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
    /// Where downloads are spooled (the blobs folder: a finished one is renamed into a blob).
    spool_dir: std::path::PathBuf,
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
        let spool_dir = config.data_dir.join("blobs");
        Ok(Self { http, base, max_bytes: config.max_download_bytes, spool_dir, downloaded })
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

    /// Downloads `url` within `scope` into memory, by way of a file ([`Downloads::spool`]):
    /// only the bytes read back are held, once.
    pub async fn get(&self, url: &str, scope: &FetchScope) -> Result<Vec<u8>, SpoolError> {
        let spooled = self.spool(url, scope, &CancellationToken::new(), None).await?;
        let io = |source| SpoolError::Io { url: quoted(url), source };
        spooled.read().await.map_err(io)
    }

    /// Streams `url` within `scope` to a temporary file, hashed as it comes (and handed to
    /// `tap`), held to the size cap, the download deadlines and the floor rate; `cancel` (a
    /// session's) stops it at once and closes the connection.
    pub async fn spool(
        &self,
        url: &str,
        scope: &FetchScope,
        cancel: &CancellationToken,
        tap: Option<Tap>,
    ) -> Result<Spooled, SpoolError> {
        let fetched = async {
            let (response, shown) = meshflow_api::fetch_response(&self.http, url, scope).await?;
            spool::spool(response, &shown, &self.spool_dir, self.max_bytes, cancel, tap).await
        };
        let cancelled = || SpoolError::Cancelled { url: quoted(url) };
        let spooled = tokio::select! {
            () = cancel.cancelled() => Err(cancelled()),
            done = tokio::time::timeout(DOWNLOAD_TIMEOUT, fetched) => done.unwrap_or_else(|_| {
                Err(SpoolError::Fetch(ClientError::Timeout {
                    url: quoted(url),
                    message: format!(
                        "the download took longer than {} s",
                        DOWNLOAD_TIMEOUT.as_secs()
                    ),
                }))
            }),
        }?;
        self.downloaded.inc_by(spooled.bytes);
        Ok(spooled)
    }

    /// Downloads a mesh into a file (kept as its blob by renaming it) and decodes it: a packed
    /// mesh, as its URL names it, while its bytes arrive (the connectivity, then each
    /// geometry block, as they come: the decoding off the critical path), any other once
    /// they are all in.
    pub async fn mesh<E: From<SpoolError> + From<MeshError>>(
        &self,
        url: &str,
        scope: &FetchScope,
        cancel: &CancellationToken,
    ) -> Result<FetchedMesh, E> {
        let started = Instant::now();
        let (tap, arriving) = match MeshEncoding::by_url(url) {
            Some(MeshEncoding::Packed) => {
                let (tap, chunks) = std::sync::mpsc::channel();
                (Some(tap), Some(meshes::decode_arriving(url, chunks)))
            }
            _ => (None, None),
        };
        let spooled = self.spool(url, scope, cancel, tap).await?;
        let download = started.elapsed();
        let (mesh, encoding, not_kept) = match arriving {
            Some(decoding) => {
                (decoding.await.map_err(MeshError::from)??, MeshEncoding::Packed, Vec::new())
            }
            None => {
                let io = |source| SpoolError::Io { url: quoted(url), source };
                let decoded = meshes::decode_hashed(url, spooled.read().await.map_err(io)?).await?;
                (decoded.mesh, decoded.encoding, decoded.not_kept)
            }
        };
        let load = started.elapsed() - download;
        Ok(FetchedMesh { spooled, mesh, encoding, not_kept, download, load })
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
