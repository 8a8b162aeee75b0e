//! How a host server is set up, and every server limit as a named constant.

use std::path::PathBuf;
use std::time::Duration;

use meshflow_api::server::TlsFiles;
use meshflow_runtime::Limits;

/// Largest download (input mesh, correction or full mesh) a host accepts.
pub const DEFAULT_MAX_DOWNLOAD_BYTES: u64 = 2 << 30;
/// A download that sends nothing for this long is abandoned.
pub const DOWNLOAD_READ_TIMEOUT: Duration = Duration::from_secs(30);
pub const DOWNLOAD_CONNECT_TIMEOUT: Duration = Duration::from_secs(10);
/// The whole of a download, redirects included: a source that drips just fast enough to
/// beat the read timeout still ends here.
pub const DOWNLOAD_TIMEOUT: Duration = Duration::from_secs(600);
/// A download (spooled to a file) slower than this many bytes per second over a whole
/// [`SLOW_DOWNLOAD_WINDOW`] is cut: a source that drips holds no slot for long.
pub const MIN_DOWNLOAD_RATE: u64 = 16 << 10;
pub const SLOW_DOWNLOAD_WINDOW: Duration = Duration::from_secs(30);
/// What a download holds in memory on its way to its file.
pub const DOWNLOAD_BUFFER_BYTES: usize = 256 << 10;
/// Longest URL a session or update may name.
pub const MAX_URL_CHARS: usize = 4096;
/// Sessions untouched for this long are deleted.
pub const DEFAULT_SESSION_TTL: Duration = Duration::from_secs(6 * 3600);
/// Total size of stored blobs beyond which the oldest unneeded ones are deleted.
pub const DEFAULT_BLOB_BUDGET_BYTES: u64 = 8 << 30;
/// Output meshes kept in memory so their full (packed) blob can be made on first request.
pub const DEFAULT_RECENT_OUTPUTS: usize = 16;
/// The arrays those outputs may take together: beyond it the oldest are forgotten (the
/// newest is always kept; a session's current mesh is served from the session anyway), so
/// a WHILE over a large mesh does not keep every round's output.
pub const DEFAULT_RECENT_OUTPUT_BYTES: usize = 1 << 30;
/// How often idle sessions and excess blobs are looked for.
pub const EVICTION_INTERVAL: Duration = Duration::from_secs(60);
/// How long `GET /sessions/{id}?wait=ready` waits for a loading session.
pub const LONG_POLL: Duration = Duration::from_secs(60);
/// What a host answering 429 (every run slot taken, the queue full) asks callers to wait.
pub const BUSY_RETRY_AFTER: Duration = Duration::from_secs(1);
/// Meshes written in a file format at once (`POST /meshes/convert`): each holds a decoded
/// mesh and its file in memory.
pub const MAX_CONCURRENT_CONVERSIONS: usize = 2;
/// Edit logs encoded at once, after their steps were answered (`edit_logs.rs`).
pub const MAX_ENCODING_EDIT_LOGS: usize = 4;
/// How long a GET of an edit log still being encoded waits for it.
pub const EDIT_LOG_WAIT: Duration = Duration::from_secs(300);
/// An edit log's size before its plugin's first log is encoded here: a moved vertex costs
/// 4-8 bytes on real scans.
pub const DEFAULT_EDIT_LOG_BYTES_PER_EDIT: f64 = 6.0;
/// No edit log is smaller than its header.
pub const MIN_EDIT_LOG_BYTES: u64 = 100;
/// Steps of at most this many edits are answered with their edit log's real size, encoded
/// first (about 5 ms at most): per-edit rates learned on one mesh misjudged another's
/// component and hole repairs by 30-500×, and sent receivers to replay them.
pub const ENCODE_BEFORE_ANSWER_EDITS: usize = 20_000;
/// Meshes of at most this many vertices have their neighbour means gathered before the
/// edit log that needs them (25 bytes a vertex: 100 MB here), beside the plugin's run or
/// the log's download; a larger mesh's encode and apply gather them when they need them.
pub const MAX_PREPARED_MEANS_VERTICES: usize = 4_000_000;
/// Gathered means a host holds at once (so at most 200 MB beside its runs and downloads).
pub const MAX_PREPARED_MEANS: usize = 2;
/// A producer gathers them beside the run only for a kind of step whose last log took less
/// than this many bytes per edit: uniform smoothing's 0.005, not cotangent smoothing's 4.6
/// (a log of that rate is replayed or sent whole rather than waited for).
pub const PREPARE_BELOW_BYTES_PER_EDIT: f64 = 1.0;
/// Plugins whose bytes per edit are remembered for the estimate.
pub const MAX_EDIT_LOG_ESTIMATES: usize = 1024;
/// Attempts to register with the engine, and the pause between them.
pub const REGISTER_ATTEMPTS: u32 = 5;
pub const REGISTER_RETRY: Duration = Duration::from_secs(1);
/// One registration request: the engine asks this host for its services before answering.
pub const REGISTER_TIMEOUT: Duration = Duration::from_secs(15);

/// Everything a host server needs to start.
#[derive(Clone, Debug)]
pub struct HostConfig {
    /// Holds `blobs/`, `plugins/`, `cache/` and `sessions/`; survives restarts.
    pub data_dir: PathBuf,
    /// Bearer token for plugin upload and delete (the upload token); without one uploads
    /// are refused.
    pub token: Option<String>,
    /// The cluster token: every route but `/health` and the plugin uploads needs it, and
    /// this host sends it to its engine and the cluster's hosts.
    pub cluster_token: Option<String>,
    /// Origins (`scheme://host[:port]`) inputs may come from besides the cluster.
    pub allow_input_from: Vec<String>,
    /// Listen on a non-loopback address without a cluster token.
    pub insecure_no_auth: bool,
    /// An engine to register with at start (`POST {engine}/hosts`).
    pub engine: Option<String>,
    /// The URL others reach this host at; by default `http://` (`https://` with `tls`) +
    /// the listening address.
    pub public_url: Option<String>,
    /// Serve https with this certificate and key (re-read when the files change).
    pub tls: Option<TlsFiles>,
    /// What a client not on the loopback sends to read `/metrics`; without it only loopback
    /// clients may.
    pub metrics_token: Option<String>,
    /// Built-in plugin components, offered after uploaded ones.
    pub builtins: Vec<&'static [u8]>,
    /// Compiled-component cache; `data_dir/cache` by default. Hosts may share one.
    pub artefact_cache: Option<PathBuf>,
    pub limits: Limits,
    /// Run and replay plugins fetched from the cluster's hosts by digest (DESIGN §4; a step
    /// the engine moves to this host because it holds the mesh). `false`
    /// (`--no-foreign-plugins`): only the plugins this host loaded itself run here.
    pub foreign_plugins: bool,
    pub max_download_bytes: u64,
    pub session_ttl: Duration,
    pub blob_budget_bytes: u64,
    pub recent_outputs: usize,
    pub recent_output_bytes: usize,
}

impl HostConfig {
    /// A configuration with every limit at its default.
    pub fn new(data_dir: impl Into<PathBuf>) -> Self {
        Self {
            data_dir: data_dir.into(),
            token: None,
            cluster_token: None,
            allow_input_from: Vec::new(),
            insecure_no_auth: false,
            engine: None,
            public_url: None,
            tls: None,
            metrics_token: None,
            builtins: Vec::new(),
            artefact_cache: None,
            limits: Limits::default(),
            foreign_plugins: true,
            max_download_bytes: DEFAULT_MAX_DOWNLOAD_BYTES,
            session_ttl: DEFAULT_SESSION_TTL,
            blob_budget_bytes: DEFAULT_BLOB_BUDGET_BYTES,
            recent_outputs: DEFAULT_RECENT_OUTPUTS,
            recent_output_bytes: DEFAULT_RECENT_OUTPUT_BYTES,
        }
    }
}
