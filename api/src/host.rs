//! The host HTTP API's bodies: serde types shared by the host server and
//! [`HostClient`](crate::HostClient).

use serde::{Deserialize, Serialize};

use meshflow_params::ServiceInfo;

/// `GET /health`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Health {
    pub status: String,
    pub version: String,
    /// Runs in progress: the engine's measure of load.
    pub running: usize,
    pub sessions: usize,
    /// Whether the host runs plugins it fetched from the cluster by digest (replays, and
    /// steps the engine moves to the mesh); `false` with `--no-foreign-plugins`. Hosts from
    /// before this field did.
    #[serde(default = "yes")]
    pub foreign_plugins: bool,
    /// Different every time the host starts: a host that restarted has lost the plugins it
    /// fetched (they are reloaded from its disk on demand at most). Absent from hosts
    /// before it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub instance: Option<String>,
}

fn yes() -> bool {
    true
}

/// One entry of `GET /services`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ServiceEntry {
    pub plugin: String,
    pub builtin: bool,
    pub info: ServiceInfo,
    /// Another plugin serves this name to unpinned runs (it replaced this one); this one
    /// runs only when a request names its digest.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub pinned_only: bool,
    /// The size of the plugin's component in bytes: what a host that lacks it downloads
    /// to replay a step of it (older hosts do not say).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin_bytes: Option<u64>,
    /// What such a host downloads: the component zstd-compressed, as `GET
    /// /plugins/{digest}/wasm` sends it to a client accepting zstd (older hosts do not say).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin_sent_bytes: Option<u64>,
}

/// `POST /plugins`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct UploadedPlugin {
    pub digest: String,
    pub services: Vec<ServiceInfo>,
    /// Services no plugin offered before.
    #[serde(default)]
    pub new: Vec<String>,
    /// Services another plugin served to unpinned runs until this upload (`?replace=true`);
    /// that plugin stays for runs pinned to it until it is deleted.
    #[serde(default)]
    pub replaced: Vec<String>,
    /// Services of a plugin that was already loaded (the same bytes uploaded again).
    #[serde(default)]
    pub present: Vec<String>,
}

/// One entry of `GET /plugins`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PluginEntry {
    pub digest: String,
    pub builtin: bool,
    pub services: Vec<String>,
    /// The component's size in bytes (older hosts do not say).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bytes: Option<u64>,
}

/// At most this many plugins in one `POST /replay-plugins`.
pub const MAX_PREFETCH_PLUGINS: usize = 64;

/// `POST /replay-plugins` (with the cluster's `peers`, as [`Vouched`]): plugins a run may
/// ask this host to replay steps of, to fetch and compile before it does.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct PrefetchPlugins {
    pub plugins: Vec<WantedPlugin>,
}

/// A plugin by digest, and the origin of a host of the cluster that has it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq, Eq)]
pub struct WantedPlugin {
    pub digest: String,
    pub from: String,
}

/// `POST /replay-plugins` answer: one outcome per plugin asked for, in order.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct PrefetchedPlugins {
    pub plugins: Vec<PluginPrefetch>,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct PluginPrefetch {
    pub digest: String,
    pub outcome: PrefetchOutcome,
    /// From the request to the plugin being ready (or the failure).
    pub ms: f64,
    /// The component's size, when the host holds it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bytes: Option<u64>,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "kebab-case")]
pub enum PrefetchOutcome {
    /// Offered here, or already compiled for an earlier replay: nothing to do.
    Present,
    /// Kept on disk from an earlier replay; loaded now (from the compiled-artefact cache).
    Loaded,
    /// Downloaded from `from`, its digest checked, and compiled.
    Fetched,
    /// Not available: a replay will try to fetch it again when it needs it.
    Failed,
}

impl PrefetchOutcome {
    pub fn name(self) -> &'static str {
        match self {
            Self::Present => "present",
            Self::Loaded => "loaded",
            Self::Fetched => "fetched",
            Self::Failed => "failed",
        }
    }
}

/// A request that names URLs to fetch (`POST /sessions`, `POST /sessions/{id}/update`),
/// with the origins of the cluster (the engine's and its hosts') the sender vouches for:
/// the host may fetch from them and sends them the cluster token.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Vouched<T> {
    #[serde(flatten)]
    pub body: T,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub peers: Vec<String>,
}

/// `POST /sessions`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CreateSession {
    pub input: InputRef,
    /// Keep the session's mesh on a coordinate grid (a workflow's `quantize`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<GridSpec>,
}

/// A session's coordinate grid: made over the input's bounding box with at most `2^bits`
/// cells per axis, or given by its step exponents (what a session made that way reports,
/// for a host that joins the run later from a mesh already on the grid).
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum GridSpec {
    Bits(u32),
    Exponents([i32; 3]),
}

/// Where a session's input mesh is, and optionally the content hash it must have.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct InputRef {
    pub url: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub hash: Option<String>,
}

/// `POST /meshes/convert`: a mesh written in a file format by a host, which checks the mesh's
/// content hash before it writes a byte of it.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ConvertMesh {
    /// The content hash the mesh must have.
    pub hash: String,
    /// Where to fetch the mesh when the host does not hold it; without it, a mesh the host
    /// does not hold is not found (404).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub from: Option<String>,
    pub format: MeshFileFormat,
    /// The step exponents of the grid the named mesh lies on (a quantised run's input): a
    /// mesh fetched from `from` is snapped onto it before its hash is checked.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<[i32; 3]>,
}

/// What a mesh is written as for people and other tools.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum MeshFileFormat {
    Ply,
    Obj,
    Off,
    Stl,
    /// The packed mesh as hosts keep and send it.
    Mfm,
    /// Plain arrays for the browser's viewer ([`crate::raw_mesh`]).
    Raw,
}

impl MeshFileFormat {
    pub const ALL: [Self; 6] = [Self::Ply, Self::Obj, Self::Off, Self::Stl, Self::Mfm, Self::Raw];

    /// By its extension, in lower case.
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|format| format.extension() == name)
    }

    pub fn extension(self) -> &'static str {
        match self {
            Self::Ply => "ply",
            Self::Obj => "obj",
            Self::Off => "off",
            Self::Stl => "stl",
            Self::Mfm => "mfm",
            Self::Raw => "raw",
        }
    }
}

/// `POST /sessions` answer.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SessionCreated {
    pub id: String,
    pub state: SessionState,
}

#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum SessionState {
    Loading,
    Ready,
    Busy,
    Failed,
}

/// `GET /sessions/{id}`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct SessionStatus {
    pub id: String,
    pub state: SessionState,
    /// Content hash of the session's current mesh, once loaded.
    pub hash: Option<String>,
    pub vertices: Option<usize>,
    pub triangles: Option<usize>,
    /// Why the session failed.
    pub error: Option<String>,
    pub download_ms: Option<f64>,
    pub load_ms: Option<f64>,
    pub input_bytes: Option<u64>,
    /// What the input file held that a mesh does not keep (colours, normals, …), once loaded.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub not_kept: Vec<String>,
    /// What the mesh carries beyond positions and triangles (`vertex color (4 × u8)`, …).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub attributes: Vec<String>,
    /// The step exponents of the session's grid, when it keeps one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub grid: Option<[i32; 3]>,
}

/// A blob another host produced: an edit log (`.mfc`) or a named step (`.mfr`).
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct BlobRef {
    pub url: String,
    pub bytes: u64,
    /// The edit log sets every vertex's position (a smoothing step's, say): a receiver
    /// gathers the codec's prediction from its own mesh while the log downloads. Never set
    /// on a named step.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub sets_positions: bool,
}

impl BlobRef {
    /// A blob no more is known of than its URL and size.
    pub fn new(url: String, bytes: u64) -> Self {
        Self { url, bytes, sets_positions: false }
    }
}

/// A full mesh another host can produce, named by its content hash.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FullRef {
    pub url: String,
    pub hash: String,
}

/// How a receiving host should bring itself up to date: replay the edit log
/// (`correction`), re-run the step (`replay`), or take the full mesh.
#[derive(Clone, Copy, Debug, Serialize, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Transfer {
    Correction,
    Replay,
    Full,
}

impl Transfer {
    pub fn name(self) -> &'static str {
        match self {
            Transfer::Correction => "correction",
            Transfer::Replay => "replay",
            Transfer::Full => "full",
        }
    }
}

/// `POST /sessions/{id}/update`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Update {
    pub correction: Option<BlobRef>,
    /// The step named (`.mfr`), to re-run here; the edit log is the fallback.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub replay: Option<BlobRef>,
    pub full: FullRef,
    #[serde(rename = "use")]
    pub use_: Transfer,
}

/// `POST /sessions/{id}/update` answer.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct Updated {
    pub hash: String,
    pub via: Transfer,
    /// Bytes downloaded, the failed correction attempt included.
    pub bytes: u64,
    pub download_ms: f64,
    pub apply_ms: f64,
    /// Why the transfer asked for was not used, when the host fell back to another.
    pub fallback: Option<String>,
    /// The mesh the producer's own edit log or replay reached here when it was not the one
    /// the step announced (the host then took the full mesh): a disagreement between hosts.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub disagreed: Option<String>,
    /// A replay that first had to wait for its plugin here (fetch and compile, or a
    /// prefetch still under way): how long that took, within `apply_ms`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin_wait_ms: Option<f64>,
}

/// `POST /sessions/{id}/run`.
#[derive(Clone, Debug, Default, Serialize, Deserialize, PartialEq)]
pub struct RunRequest {
    pub service: String,
    #[serde(default)]
    pub params: serde_json::Map<String, serde_json::Value>,
    /// Run this plugin's service rather than the one the catalogue picks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub plugin: Option<String>,
}

/// `POST /sessions/{id}/run` answer.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum RunResult {
    Filter(FilterResult),
    Check(CheckResult),
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct FilterResult {
    pub service: String,
    pub plugin: String,
    pub input_hash: String,
    pub output_hash: String,
    pub vertices: usize,
    pub triangles: usize,
    pub edits: usize,
    /// What the mesh carries beyond positions and triangles (`vertex color (4 × u8)`, …).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub attributes: Vec<String>,
    /// The plugin's run, from instantiation to its result.
    pub compute_ms: f64,
    /// The time the run waited for a free run slot on the host before that.
    #[serde(default)]
    pub queue_ms: f64,
    pub report: String,
    /// Every parameter the plugin ran with, defaults filled in: what a re-run must send.
    #[serde(default)]
    pub resolved_params: serde_json::Map<String, serde_json::Value>,
    /// The step's edit log (`.mfc`). It is encoded after this answer (DESIGN §4): its
    /// `bytes` are the producer's estimate, and a GET of its URL waits until it is written.
    pub correction: BlobRef,
    /// The step named: plugin digest, service, resolved parameters, hashes (`.mfr`).
    pub replay: BlobRef,
    pub full: FullRef,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct CheckResult {
    pub service: String,
    pub plugin: String,
    pub value: serde_json::Value,
    pub compute_ms: f64,
    #[serde(default)]
    pub queue_ms: f64,
    pub report: String,
    /// Every parameter the plugin ran with, defaults filled in.
    #[serde(default)]
    pub resolved_params: serde_json::Map<String, serde_json::Value>,
}

/// Every error body: `{"error": {"code", "message"}}`.
#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ErrorBody {
    pub error: ErrorDetail,
}

#[derive(Clone, Debug, Serialize, Deserialize, PartialEq)]
pub struct ErrorDetail {
    pub code: String,
    pub message: String,
}

/// Milliseconds, rounded to microseconds: how the API reports timings.
pub fn millis(duration: std::time::Duration) -> f64 {
    (duration.as_secs_f64() * 1e6).round() / 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_check_value_crosses_json_bit_for_bit() {
        // The normal instability of a smoothed bunny: serde_json's default parser read it
        // back one ulp low, and a host's WHILE disagreed with a local run.
        let value = 10.943364815672625_f64;
        let sent = CheckResult {
            service: "normal-instability".into(),
            plugin: "d".into(),
            value: serde_json::json!(value),
            compute_ms: 1.0,
            queue_ms: 0.0,
            report: String::new(),
            resolved_params: Default::default(),
        };
        let text = serde_json::to_string(&sent).unwrap();
        let read: CheckResult = serde_json::from_str(&text).unwrap();
        assert_eq!(read.value.as_f64().unwrap().to_bits(), value.to_bits(), "{text}");
    }
}
